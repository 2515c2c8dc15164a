"""HDF5 results (h5py): the only module that imports h5py.

Layout of a file written by :func:`write_hdf5` (N stored time points, n
coordinates, m constraint rows)::

    /                       attrs: every key of mbdsl.io.metadata.metadata (str)
    /t                      (N,)      [s]
    /q  /v  /a              (N, n)    attrs["columns"]: coordinate names
    /lambda                 (N, m)    attrs["columns"]: lambda.<joint>.<row>
    /extras/<mu|psi1>       (N, m)    the method's further multipliers
    /energies               (N, 6)    kinetic, potential, total, work, dissipated, balance [J]
    /constraints            (N, 2)    max |Phi| [m], max |Phi_q v + Phi_t| [m/s]
    /reactions              (N, 3 J + D)  fx, fy [N], torque [N m] per joint, then the
                            driver loads driver.<name>.force|torque, the
                            coupler loads coupler.<name>.<variable>.force|torque,
                            the rope tensions rope.<name>.tension [N]
                            and the outputs output.<name>
    /newton                 (N, 5)    iterations, residuals, jacobians,
                                      factorizations, h of each step
    /model_source           str       the .mbd text (also an attribute)
    /metadata               (bytes,)  uint8: UTF-8 JSON {"attributes": the root
                                      attributes, "columns": dataset -> column names}

Every dataset carries its column names in ``attrs["columns"]``. Arrays are
stored as float64/int64 as computed, so :func:`read_hdf5` returns a
Solution equal to the written one bit for bit.

Damage is detected, not read as results: the file is written with the
newest format (``libver="latest"``: checksums on the superblock and every
object header), each non-empty dataset with the Fletcher-32 checksum filter,
and the metadata and column names, whose strings HDF5 keeps in its global
heap without a checksum, also as the checked ``/metadata`` record, which is
what :func:`read_hdf5` reads. A byte changed in what it reads makes it raise
instead of returning other numbers (or, in the global heap, making the HDF5
library loop, as damaged files of older versions can).
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from .metadata import (metadata, method_parameters, rebuild_system, run_description, run_stats,
                       select_columns, unfinished_message)
from .derived import KEPT_PREFIXES
from .solution import Solution
from .stream import RowStream

__all__ = ["write_hdf5", "read_hdf5", "update_attributes", "HdfStream", "FileRows",
           "SweepTable", "read_sweep"]


def _dataset(group, name, data, columns=None):
    """A dataset with the Fletcher-32 checksum (chunked) when it has values,
    and its column names in ``attrs["columns"]`` when given."""
    data = np.asarray(data)
    ds = group.create_dataset(name, data=data, fletcher32=bool(data.size))
    if columns is not None:
        ds.attrs["columns"] = np.array(columns, dtype=h5py.string_dtype())
    return ds


def _write_record(f, record: dict) -> None:
    """The checked copy of the metadata and column names: ``/metadata``, the
    record as UTF-8 JSON in a uint8 dataset under the Fletcher-32 checksum
    (replaced whole when it exists)."""
    if "metadata" in f:
        del f["metadata"]
    _dataset(f, "metadata", np.frombuffer(json.dumps(record).encode("utf-8"), dtype=np.uint8))


def _tables(sol, derived, names=None) -> list:
    """[(dataset path, rows (k, ...), column names or None)] of a Solution's
    rows (the module docstring's layout), from its arrays and derived columns;
    with ``names`` (``metadata.select_columns``) only those columns, each
    dataset keeping its place (a dataset none of whose columns is chosen
    has width 0, a statistic not chosen is left out)."""
    tables = _all_tables(sol, derived)
    if names is None:
        return tables
    keep, out = set(names), []
    stat_column = {f"newton/{k}": ("step.h" if k == "h" else f"newton.{k}")
                   for k in sol.STAT_NAMES}
    for name, data, cols in tables:
        if cols is None:
            if name == "t" or stat_column.get(name) in keep:
                out.append((name, data, None))
            continue
        idx = [i for i, c in enumerate(cols) if c in keep]
        out.append((name, data[:, idx], [cols[i] for i in idx]))
    return out


def _all_tables(sol, derived) -> list:
    """:func:`_tables` of every column."""
    lay = sol.system.layout
    out = [("t", sol.t, None), ("q", sol.q, lay.coordinates), ("v", sol.v, lay.velocities),
           ("a", sol.a, lay.accelerations), ("lambda", sol.lam, lay.multiplier_names())]
    out += [(f"extras/{x}", sol.extras[x], [f"{x}.{a}.{b}" for a, b in lay.rows])
            for x in sol.extra_names]
    energies = [k for k in Solution.DERIVED_NAMES if k.startswith("energy.")]
    cons = ["constraint.position", "constraint.velocity"]
    reac = [k for k in derived if k.startswith(KEPT_PREFIXES)]
    out += [("energies", np.column_stack([derived[k] for k in energies]), energies),
            ("constraints", np.column_stack([derived[k] for k in cons]), cons),
            ("reactions", np.column_stack([derived[k] for k in reac])
             if reac else np.zeros((len(sol.t), 0)), reac)]
    out += [(f"newton/{k}", sol.stats[k], None) for k in Solution.STAT_NAMES]   # ints stay ints
    return out


def _record_columns(tables) -> dict:
    return {name: list(cols) for name, _, cols in tables if cols is not None}


def write_hdf5(solution, path, extra_metadata: dict | None = None,
               columns: list | None = None) -> Path:
    """Write a Solution as HDF5 (layout in the module docstring).

    Parameters
    ----------
    solution : Solution
    path : str or Path
    extra_metadata : dict, optional
        More root attributes.
    columns : list of str, optional
        Patterns of the columns to write (``metadata.select_columns``); None: all.

    Returns
    -------
    Path

    Raises
    ------
    OSError
        If the file cannot be written.
    ValueError
        A pattern of ``columns`` matches no column.
    """
    path = Path(path)
    sol = solution
    names = None if columns is None else select_columns(sol.columns, columns)
    tables = _tables(sol, sol.derived(), names)
    meta = metadata(sol, extra_metadata, columns=names)
    with h5py.File(path, "w", libver="latest") as f:
        for k, v in meta.items():
            f.attrs[k] = v
        f.create_group("extras")
        for name, data, cols in tables:
            _dataset(f, name, data, cols)
        f.create_dataset("model_source", data=sol.model.source or "",
                         dtype=h5py.string_dtype())
        _write_record(f, {"attributes": meta, "columns": _record_columns(tables)})
    return path


class HdfStream(RowStream):
    """Writes a run's HDF5 file as it goes (``mbdsl simulate -o run.h5``).

    The file is created at the first chunk with every dataset of the layout
    (module docstring) empty and resizable (chunked, Fletcher-32), the
    metadata with ``status: running``, then put in single-writer/multiple-
    reader mode (SWMR): each chunk of rows is appended to every dataset and
    flushed, and HDF5 orders its writes so that the file on disk is
    consistent after every flush. A process killed outright (SIGKILL, a
    power cut) leaves a file that :func:`read_hdf5` reads with every chunk
    flushed before the kill, status ``running``. ``on_end`` writes the
    remaining rows, then reopens the file to write the final metadata
    (status, message, totals, timings, events, warnings).

    Parameters and errors as :class:`~mbdsl.io.stream.RowStream`; the file is
    created here, so that an unwritable path fails before the run starts.
    """

    #: Rows per HDF5 chunk of the row datasets (fewer for wide ones: :meth:`chunk_shape`).
    CHUNK_ROWS = 1024
    #: Values per HDF5 chunk at most (1 MiB): a chunk is written, checksummed and
    #: read whole, so the chunk of a chain of 10 000 links (30 000 columns) must not
    #: span 1024 rows (245 MB rewritten at each flush of a few rows).
    CHUNK_VALUES = 1 << 17

    @classmethod
    def chunk_shape(cls, width: tuple) -> tuple:
        """The chunk of a dataset whose rows have shape ``width``: up to
        ``CHUNK_ROWS`` rows and ``CHUNK_VALUES`` values, a wide row split
        into blocks of columns (a column is then read without the others)."""
        if not width:
            return (cls.CHUNK_ROWS,)
        cols = max(1, min(width[0] or 1, cls.CHUNK_VALUES // 8))
        rows = max(1, min(cls.CHUNK_ROWS, cls.CHUNK_VALUES // cols))
        return (rows, cols) + tuple(w or 1 for w in width[1:])

    #: The rows written leave memory: the finished Solution reads them from
    #: the file (``Solution.attach_file`` with :class:`FileRows`).
    releases_rows = True

    def __init__(self, path, interval: float = 0.5, columns: list | None = None):
        super().__init__(path, interval, columns)
        self.path.touch()             # fail early on an unwritable path
        self._file = None
        self._columns = {}            # dataset -> column names (derived datasets)

    def _open(self, sol) -> None:
        """The file with the run's metadata (status running); its datasets
        come with the first chunk (:meth:`_write`), whose tables give them."""
        self._meta = metadata(sol, final=False, columns=self.names)
        f = h5py.File(self.path, "w", libver="latest")
        for k, v in self._meta.items():
            f.attrs[k] = v
        f.create_dataset("model_source", data=sol.model.source or "",
                         dtype=h5py.string_dtype())
        self._file = f

    def _create(self, tables) -> None:
        """Every dataset of the layout, empty and resizable, as the tables of
        the first chunk give them; the checked record; then SWMR mode."""
        f = self._file
        for name, data, names in tables:
            width = data.shape[1:]
            # resizable datasets are chunked; a chunk has no empty side (no reactions: (k, 0))
            ds = f.create_dataset(name, shape=(0,) + width,
                                  maxshape=(None,) + tuple(w or None for w in width),
                                  dtype=data.dtype, fletcher32=True,
                                  chunks=self.chunk_shape(width))
            if names is not None:
                ds.attrs["columns"] = np.array(names, dtype=h5py.string_dtype())
        self._columns = _record_columns(tables)
        _write_record(f, {"attributes": self._meta, "columns": _record_columns(tables)})
        f.swmr_mode = True

    def _write(self, part) -> None:
        f = self._file
        tables = _tables(part, part.derived(), self.names)
        if not f.swmr_mode:
            self._create(tables)
        for name, data, _ in tables:
            ds = f[name]
            k = ds.shape[0]
            ds.resize(k + len(data), axis=0)
            if data.size:
                ds[k:] = data
        f.flush()

    def _close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def _hand_back(self, n: int) -> "FileRows":
        self._close()
        return FileRows(self.path, n, self._columns)

    def _end(self, sol, meta) -> None:
        self._close()
        update_attributes(self.path, meta)

    def close_unused(self) -> None:
        """The run never started: remove the empty file."""
        if self._file is not None:
            self._file.close()
        super().close_unused()


class FileRows:
    """The rows of a result file (layout in the module docstring), read when
    asked for: where a run streamed to HDF5 (:class:`HdfStream`) reads its
    rows back after they left memory (``Solution.attach_file``).

    Each read opens the file and closes it again: no handle is held between
    reads (the stream reopens the file to write its final metadata, and
    HDF5 refuses a second handle on a file in another mode).

    Parameters
    ----------
    path : str or Path
    n : int
        Rows of the run (each dataset's first n rows are read).
    columns : dict of str -> list of str
        Column names of the derived datasets ("energies", "constraints",
        "reactions"), as in the file's ``/metadata`` record.

    Attributes
    ----------
    derived : dict of str -> (str, int)
        Derived column name -> (dataset, column index).
    """

    DERIVED = ("energies", "constraints", "reactions")

    def __init__(self, path, n: int, columns: dict):
        self.path, self.n = Path(path), int(n)
        self.derived = {c: (name, j) for name in self.DERIVED
                        for j, c in enumerate(columns.get(name, ()))}

    def read(self, dataset: str, j=None) -> np.ndarray:
        """Rows 0..n-1 of ``dataset``, shape (n, ...), or of its column j (an
        index, shape (n,); or a list of increasing indices, shape (n, k)).

        Raises
        ------
        OSError
            The file cannot be opened (moved or deleted since the run).
        """
        with h5py.File(self.path, "r") as f:
            ds = f[dataset]
            if j is None:
                return ds[:self.n]
            if np.ndim(j) == 0:
                return ds[:self.n, int(j)]
            j = [int(i) for i in j]
            if j and j == list(range(j[0], j[-1] + 1)):    # a slice reads faster
                return ds[:self.n, j[0]:j[-1] + 1]
            return ds[:self.n, j]


def update_attributes(path, attrs: dict) -> None:
    """Replace root attributes (str -> str) of a result file written by
    :func:`write_hdf5`, and their checked copy in ``/metadata``.

    Raises
    ------
    OSError
        If the file cannot be opened for writing.
    """
    with h5py.File(path, "a") as f:
        for k, v in attrs.items():
            f.attrs[k] = v
        if "metadata" in f:
            record = json.loads(bytes(f["metadata"][()]).decode("utf-8"))
            record["attributes"].update(attrs)
            _write_record(f, record)


def _columns(ds) -> list[str]:
    return [c.decode() if isinstance(c, bytes) else str(c) for c in ds.attrs["columns"]]


def read_hdf5(path):
    """A Solution from a file written by :func:`write_hdf5`.

    Raises
    ------
    OSError
        Not an HDF5 file, or unreadable.
    ValueError
        An HDF5 file that is not an mbdsl result, or a damaged one (a
        checksum that does not match, a missing or unreadable part).
    """
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError:
        # a file whose writer was killed while it streamed (HdfStream, SWMR mode)
        # is still marked open for writing: SWMR readers open it
        f = h5py.File(path, "r", swmr=True)
    with f:
        try:
            return _read(f, path)
        except (OSError, KeyError, RuntimeError, TypeError, IndexError,
                json.JSONDecodeError) as exc:
            raise ValueError(f"{path}: the file is damaged ({exc}); its results cannot be "
                             "trusted: write it again with mbdsl simulate") from None


def _read(f, path):
    """The Solution of the open result file ``f`` (:func:`read_hdf5`)."""
    if "metadata" in f:           # the checked copy; the attributes are not read
        record = json.loads(bytes(f["metadata"][()]).decode("utf-8"))
        meta, columns = record["attributes"], record["columns"]
    else:                         # a file of an older version: its attributes
        meta = {k: (v.decode() if isinstance(v, bytes) else str(v)) for k, v in f.attrs.items()}
        columns = None
    if "method" not in meta or "q" not in f:
        raise ValueError(f"{path}: an HDF5 file, but not a result written by mbdsl")
    system = rebuild_system(meta, path)
    extra_names = json.loads(meta.get("extras", "[]"))
    rows = (["t", "q", "v", "a", "lambda", "energies", "constraints", "reactions"]
            + [f"extras/{x}" for x in extra_names]
            + [f"newton/{k}" for k in Solution.STAT_NAMES])
    written = json.loads(meta["columns"]) if "columns" in meta else None   # some columns only
    rows = [name for name in rows if written is None or name in f]
    # a file streamed by a process killed between two datasets' writes of a
    # chunk: the rows every dataset holds
    n = min(f[name].shape[0] for name in rows)
    lay = system.layout

    def read(name, names=None):
        """The dataset's first n rows (those every row dataset holds); of a
        file of some columns, as the whole table of ``names`` with NaN where
        a column was not written (a statistic not written: zeros)."""
        if written is None:
            return f[name][:n]
        if names is None:
            return f[name][:n] if name in f else np.zeros(n, dtype=int)
        out = np.full((n, len(names)), np.nan)
        held = columns[name] if columns is not None else _columns(f[name])
        where = {c: i for i, c in enumerate(names)}
        values = f[name][:n]
        for j, c in enumerate(held):
            out[:, where[c]] = values[:, j]
        return out
    extra_rows = [f"{a}.{b}" for a, b in lay.rows]
    derived = {}
    for name in ("energies", "constraints", "reactions"):
        values = read(name)
        names = columns[name] if columns is not None else _columns(f[name])
        derived.update({c: values[:, i] for i, c in enumerate(names)})
    status, message = meta.get("status", "completed"), meta.get("message", "")
    if status == "running":
        message = unfinished_message(read("t"), float(meta["t_end"]))
    return Solution.from_arrays(
        system, method_name=meta["method"], method_parameters=method_parameters(meta),
        extra_names=extra_names, h=float(meta["h"]), t_end=float(meta["t_end"]),
        t=read("t"), q=read("q", lay.coordinates), v=read("v", lay.velocities),
        a=read("a", lay.accelerations), lam=read("lambda", lay.multiplier_names()),
        extras={x: read(f"extras/{x}", [f"{x}.{r}" for r in extra_rows]) for x in extra_names},
        stats={k: read(f"newton/{k}") for k in Solution.STAT_NAMES},
        stats_total=run_stats(meta), status=status, message=message,
        wall_time=float(meta.get("wall_time", 0.0)), derived=derived, written=written,
        **run_description(meta))


class SweepTable:
    """The table of a parameter sweep (``studies.sweep``): one row per run,
    appended and flushed as each run finishes.

    Layout: ``/runs/<column>`` (N,) per column, float64 for the numbers,
    UTF-8 strings for ``status``, ``code``, ``message`` and ``engine``; root attributes
    ``columns`` (JSON list, the order), ``parameters`` (JSON list) and the
    sweep's description (model name, file, source, how it was asked for).

    Parameters
    ----------
    path : str or Path
        Created, or continued when it holds the same sweep's table.
    columns : list of str
    parameters : list of str
        The leading columns that identify a run (:meth:`done`).
    attributes : dict of str -> str

    Raises
    ------
    ValueError
        ``path`` holds another table (other columns or parameters), or is
        not a sweep table.
    OSError
        The file cannot be written.
    """

    TEXT = ("status", "code", "message", "engine")

    def __init__(self, path, columns, parameters, attributes: dict):
        self.path, self.columns = Path(path), list(columns)
        exists = self.path.exists() and self.path.stat().st_size > 0
        self._file = h5py.File(self.path, "a" if exists else "w", libver="latest")
        f = self._file
        if exists:
            try:
                same = (json.loads(f.attrs["columns"]) == self.columns
                        and json.loads(f.attrs["parameters"]) == list(parameters))
            except (KeyError, ValueError, TypeError):
                same = False
            if not same:
                f.close()
                raise ValueError(f"{self.path} holds another sweep's table (other parameters "
                                 "or columns): give another output file")
            return
        f.attrs["columns"] = json.dumps(self.columns)
        f.attrs["parameters"] = json.dumps(list(parameters))
        for k, v in attributes.items():
            f.attrs[k] = v
        runs = f.create_group("runs")
        for c in self.columns:
            runs.create_dataset(c, shape=(0,), maxshape=(None,), chunks=(256,),
                                dtype=h5py.string_dtype() if c in self.TEXT else "f8")
        f.flush()

    def done(self) -> set:
        """The parameter values (tuples, in ``parameters`` order) of the runs in the table."""
        f = self._file
        params = json.loads(f.attrs["parameters"])
        if not params:
            return {()} if len(f["runs"][self.columns[0]]) else set()
        values = [f["runs"][p][()] for p in params]
        return {tuple(float(x) for x in row) for row in zip(*values)}

    def append(self, row: dict) -> None:
        """One run's row (column -> value; absent numbers NaN), flushed."""
        runs = self._file["runs"]
        for c in self.columns:
            ds = runs[c]
            k = ds.shape[0]
            ds.resize(k + 1, axis=0)
            ds[k] = str(row.get(c, "")) if c in self.TEXT else float(row.get(c, np.nan))
        self._file.flush()

    def close(self) -> None:
        """Close the file (every row is flushed already)."""
        self._file.close()


def read_sweep(path) -> dict:
    """A sweep table (:class:`SweepTable`) as column -> ndarray (N,), in its
    column order (strings for status, code and message).

    Raises
    ------
    ValueError
        Not a sweep table.
    """
    with h5py.File(path, "r") as f:
        if "runs" not in f or "columns" not in f.attrs:
            raise ValueError(f"{path} is not a sweep table written by mbdsl sweep")
        out = {}
        for c in json.loads(f.attrs["columns"]):
            values = f["runs"][c][()]
            out[c] = (np.array([v.decode() if isinstance(v, bytes) else str(v) for v in values])
                      if c in SweepTable.TEXT else values)
        return out
