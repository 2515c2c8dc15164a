"""Writing solutions to files and reading them back.

The format follows the file's extension: ``.h5``/``.hdf5`` is HDF5
(:mod:`mbdsl.hdf5`, h5py), anything else CSV.

CSV: ``#`` metadata lines (model name, file, SHA-256 and source text, the
parameter values, method and its parameters, h, t_end, tool version, run
status and why it stopped, Newton totals), then a header row of column names
and one row per stored time point, every value with 17 significant digits
so that a CSV round trip loses nothing (``%.17g`` is exact for IEEE doubles).

A file is self-contained: :func:`load_solution` rebuilds the model from the
stored source text and parameter values, so a result can be plotted or
animated on a machine that never saw the ``.mbd`` file.
"""

from __future__ import annotations

import abc
import io
import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

__all__ = ["write_csv", "read_csv_metadata", "write_solution", "load_solution", "metadata",
           "HDF5_SUFFIXES", "CsvStream", "RowStream", "select_columns"]

HDF5_SUFFIXES = (".h5", ".hdf5")


def _pattern(text: str) -> str:
    """A column pattern as a regular expression: ``*`` any run of characters,
    ``?`` one, everything else literal (``link[99999].*``: the brackets are
    part of the name, not a character class as in shell globs)."""
    import re
    return "".join(".*" if c == "*" else "." if c == "?" else re.escape(c) for c in text)


def select_columns(names, patterns) -> list[str]:
    """The columns of ``names`` that match any of ``patterns`` (``*`` and
    ``?`` wildcards, :func:`_pattern`), in the order of ``names``, with "t"
    always first (``mbdsl simulate --columns``).

    Parameters
    ----------
    names : sequence of str
        Every column of the run (``Solution.columns``).
    patterns : sequence of str

    Raises
    ------
    ValueError
        A pattern that matches no column, with the closest names.
    """
    import difflib
    import re
    texts = [p.strip() for p in patterns if p.strip()]
    # one alternation, one match per column (1.4 million columns of a 100 000-link chain)
    anyof = re.compile("(?:" + "|".join(f"(?P<p{k}>{_pattern(p)})" for k, p in enumerate(texts))
                       + r")\Z")
    chosen, hit = ["t"], set()
    for n in names:
        found = anyof.match(n)
        if found is not None:
            hit.add(found.lastgroup)
            if n != "t":
                chosen.append(n)
    for k, text in enumerate(texts):
        if f"p{k}" in hit or any(re.match(_pattern(text) + r"\Z", n) for n in names):
            continue        # (a column that an earlier pattern took as well)
        close = difflib.get_close_matches(text.replace("*", ""), list(names), n=3)
        raise ValueError(f"--columns: '{text}' matches no column of this run"
                         + (f"; did you mean {', '.join(close)}?" if close else
                            " (mbdsl check lists the model's elements)"))
    return chosen


def metadata(solution, extra: dict | None = None, final: bool = True,
             columns: list | None = None) -> dict:
    """Everything about a run that is not a time history, as str -> str.

    Keys: ``mbdsl_version``, ``model``, ``model_file``, ``model_sha256``,
    ``model_source`` (JSON string), ``model_parameters`` (JSON object),
    ``method``, ``formulation``, ``method.<coefficient>``, ``h``, ``t_end``, ``status``,
    ``message``, ``extras`` (JSON list), ``units`` (JSON object: column ->
    SI unit, "" for none or mixed), ``stats_total`` (JSON object),
    ``wall_time``, ``engine``, ``linear_solver``, ``timings`` (JSON object);
    for a model with contacts or joint limits ``events`` (JSON list of [t [s],
    gap, "closed" or "opened", speed [m/s or rad/s]]: when and which gap of a
    contact or limit closed or opened, with its approach or separation
    speed) and ``event_cuts`` (steps retaken to land on them); for a finished
    run (``final``) ``warnings`` (JSON list of [code, message]: what the run's
    own rows say is wrong with it, ``Solution.warnings``). A file of some
    columns only (``columns``, :func:`select_columns`) also has ``columns``
    (JSON list of the columns written), and ``units`` has only those.
    """
    from . import __version__
    model = solution.model
    meta = {
        "mbdsl_version": __version__,
        "model": model.name,
        "model_file": model.file,
        "model_sha256": model.sha256,
        "method": solution.method_name,
        "formulation": getattr(solution, "formulation", "lagrange"),
    }
    meta.update({f"method.{k}": repr(float(v)) for k, v in solution.method_parameters.items()})
    control = getattr(solution, "control", None)
    if control is not None:           # error-controlled steps; h is the first step's size
        meta.update({"rtol": repr(control.rtol), "atol": repr(control.atol)})
    meta.update({"h": repr(solution.h), "t_end": repr(solution.t_end),
                 "status": solution.status, "message": solution.message.replace("\n", " ")})
    if model.parameters:
        meta["parameters"] = ", ".join(f"{k}={float(v)!r}" for k, v in model.parameters.items())
    meta["model_parameters"] = json.dumps({k: float(v) for k, v in model.parameters.items()})
    meta["extras"] = json.dumps(list(solution.extra_names))
    units = solution.column_units()
    if columns is not None:
        meta["columns"] = json.dumps(list(columns))
        units = {k: units[k] for k in columns if k in units}
    meta["units"] = json.dumps(units)
    meta["stats_total"] = json.dumps(asdict(solution.stats_total))
    meta["wall_time"] = repr(float(solution.wall_time))
    meta["engine"] = solution.engine
    meta["linear_solver"] = solution.linear_solver
    meta["timings"] = json.dumps(solution.timings)
    if solution.events or getattr(solution.system, "contact_group", None) is not None:
        meta["events"] = json.dumps([[float(t), name, kind, float(speed)]
                                     for t, name, kind, speed in solution.events])
        meta["event_cuts"] = str(int(solution.event_cuts))
    if getattr(solution, "dense", False):    # not one row per step (integrators.dense)
        meta["rows"] = "at requested times"
    if final:
        meta["warnings"] = json.dumps([[w.code, w.message] for w in solution.warnings])
    meta["model_source"] = json.dumps(model.source)      # one line: newlines escaped
    meta.update(extra or {})
    return meta


def write_csv(solution, path, extra_metadata: dict | None = None,
              columns: list | None = None) -> Path:
    """Write a Solution as CSV.

    Parameters
    ----------
    solution : Solution
    path : str or Path, or a text stream
        A stream (``sys.stdout``: ``mbdsl simulate -o -``) is written to, not closed.
    extra_metadata : dict, optional
        More ``# key: value`` lines.
    columns : list of str, optional
        Patterns of the columns to write (:func:`select_columns`); None: every column.

    Returns
    -------
    Path or the stream
        What was written.

    Raises
    ------
    OSError
        If the file cannot be written.
    ValueError
        A pattern of ``columns`` matches no column.
    """
    names = None if columns is None else select_columns(solution.columns, columns)
    names, values = solution.table(names)
    buf = io.StringIO()
    for k, v in metadata(solution, extra_metadata, columns=names if columns else None).items():
        buf.write(f"# {k}: {v}\n")
    buf.write(",".join(names) + "\n")
    buf.write(_csv_rows(values))
    if hasattr(path, "write"):
        path.write(buf.getvalue())
        return path
    path = Path(path)
    path.write_text(buf.getvalue(), encoding="utf-8")
    return path


def _csv_rows(values) -> str:
    """Rows of floats as CSV text, 17 significant digits (exact for doubles)."""
    if not len(values):
        return ""
    line = ",".join(["%.17g"] * values.shape[1])
    return "\n".join([line % tuple(row) for row in values.tolist()]) + "\n"


class _Timer:
    """Adds the wall time of a ``with`` block to ``owner.elapsed``."""

    def __init__(self, owner):
        self.owner = owner

    def __enter__(self):
        import time
        self._t0 = time.perf_counter()

    def __exit__(self, *exc):
        import time
        self.owner.elapsed += time.perf_counter() - self._t0


class _DeferredInterrupt:
    """Hold Ctrl-C while a chunk is written, so the file never ends mid-chunk or
    counts a chunk twice; the KeyboardInterrupt is raised right after."""

    def __enter__(self):
        import signal
        import threading
        self._signal, self._hit, self._old = signal, False, None
        if threading.current_thread() is threading.main_thread():
            self._old = signal.signal(signal.SIGINT, self._handler)
        return self

    def _handler(self, signum, frame):
        self._hit = True

    def __exit__(self, *exc):
        if self._old is not None:
            self._signal.signal(self._signal.SIGINT, self._old)
        if self._hit and exc[0] is None:
            raise KeyboardInterrupt


class RowStream(abc.ABC):
    """Writes a run's rows as it goes: the base of :class:`CsvStream` and
    ``hdf5.HdfStream``.

    Chunks of rows go out at most every ``interval`` seconds of wall time
    (``append``, told by the time loop), each with its derived columns
    (energies, constraint norms, reactions, outputs; the energy integrals
    carried from chunk to chunk), Ctrl-C held while a chunk is written;
    ``finish`` writes the remaining rows and what is known only at the end.
    A subclass opens the file (``_open``), writes a chunk (``_write``, a
    Solution of its rows) and ends it (``_end``, with the final metadata).

    Memory stays bounded on long runs: a chunk also goes out once
    ``PENDING_ROWS`` rows wait, whatever the interval, and is written in
    parts of at most ``PART_ROWS`` rows (the derived columns' temporaries).
    A stream with ``releases_rows`` (HDF5, which reads back one column at a
    time) then lets the Solution drop the rows written
    (``Solution.release_rows``); at the end the Solution reads its rows from
    the file (``Solution.attach_file``) and its summary and checks the
    derived columns' extents kept chunk by chunk (``solution.Extent``). The
    last row recorded is held back until the end: the loop may still amend
    it (a restart at an event or a switch).

    Parameters
    ----------
    path : str or Path
    interval : float [s]
        Wall time between chunks.
    columns : list of str, optional
        Patterns of the columns the file holds (:func:`select_columns`; "t"
        always); None: every column. Checked against the run's columns when
        it starts (:meth:`begin`). A file of some columns keeps the rows in
        the Solution (it cannot give them back).

    Raises
    ------
    OSError
        The file cannot be created (a subclass creates it in ``__init__``).
    """

    #: Rows waiting that send a chunk out before its interval has passed.
    PENDING_ROWS = 1 << 14
    #: Most rows whose derived columns are computed at once.
    PART_ROWS = 1 << 14
    #: The Solution may let go of the rows written (``_hand_back`` gives them back).
    releases_rows = False

    def __init__(self, path, interval: float = 0.5, columns: list | None = None):
        self.path, self.interval = Path(path), float(interval)
        self.patterns = None if columns is None else list(columns)
        self.names = None           # the columns written (select_columns), or None: all
        self.releases_rows = type(self).releases_rows and self.patterns is None
        self._header, self._written, self._last = False, 0, 0.0
        self._derived = []          # derived columns of the rows written, chunk by chunk
        self._extents = {}          # their extents (solution.Extent), merged chunk by chunk
        self._energy = None         # the energy integrals at the last row written
        #: Wall time spent computing and writing rows [s] (``Solution.timings["output"]``).
        self.elapsed = 0.0

    def _part(self, sol, i0, i1, finalized):
        """Rows i0..i1-1 as a Solution with their derived columns, from the
        stacked arrays of a finalized Solution or from the rows recorded so
        far during the run; the energy integrals go on from the last chunk."""
        from .solution import FLOW_NAMES, Solution
        if finalized:
            sl = slice(i0, i1)
            t, q, v, a, lam = sol.t[sl], sol.q[sl], sol.v[sl], sol.a[sl], sol.lam[sl]
            extras = {k: x[sl] for k, x in sol.extras.items()}
            stats = {k: x[sl] for k, x in sol.stats.items()}
            flows = ({k: x[sl] for k, x in sol.flows.items()}
                     if getattr(sol, "flows", None) is not None else None)
        else:
            d = sol.rows(i0, i1)
            t, q, v, a, lam = d["t"], d["q"], d["v"], d["a"], d["lam"]
            extras = {x: d[x] for x in sol.extra_names}
            stats = {k: d[k] for k in Solution.STAT_NAMES}
            flows = {k: d[k] for k in FLOW_NAMES if k in d} or None
        part = Solution.from_arrays(
            sol.system, method_name=sol.method_name, method_parameters=sol.method_parameters,
            extra_names=sol.extra_names, h=sol.h, t_end=sol.t_end, t=t, q=q, v=v, a=a, lam=lam,
            extras=extras, stats=stats, stats_total=sol.stats_total, status=sol.status,
            message=sol.message, flows=flows)
        part.energy_start = self._energy
        part.contact_log = sol.contact_log     # the impact speeds behind the contacts' damping
        derived = part.derived()
        self._energy = dict(part.energy_end)
        if not self.releases_rows:  # the Solution gets them at the end
            self._derived.append(part._derived)
        from .solution import Extent, Solution
        for k in Solution.DERIVED_NAMES:        # what the summary and the guards read
            ext = Extent.of(derived[k], i0)
            self._extents[k] = self._extents[k].merge(ext) if k in self._extents else ext
        return part

    def _write_rows(self, sol, n, finalized) -> None:
        """Rows written .. n-1, in parts of at most ``PART_ROWS``."""
        while self._written < n:
            i1 = min(n, self._written + self.PART_ROWS)
            self._write(self._part(sol, self._written, i1, finalized))
            self._written = i1
            if self.releases_rows and not finalized:
                sol.release_rows(self._written)

    def begin(self, sol) -> None:
        """Before the first step (the run's Solution holds its initial row):
        the columns chosen, then the file's head (metadata, status running).

        Raises
        ------
        ValueError
            A pattern of ``columns`` matches no column of the run.
        """
        if self._header:
            return
        if self.patterns is not None:
            self.names = select_columns(sol.columns, self.patterns)
        with _Timer(self):
            self._open(sol)
        self._header = True

    def append(self, sol) -> None:
        """After an accepted step: write the pending rows if ``interval`` has passed."""
        import time
        now = time.perf_counter()
        n = sol.n_rows - 1          # the last row may still be amended: held back
        if (self._header and now - self._last < self.interval
                and n - self._written < self.PENDING_ROWS):
            return
        self._last = now
        if not self._header:
            self.begin(sol)
        with _DeferredInterrupt(), _Timer(self):
            self._write_rows(sol, n, finalized=False)

    def finish(self, sol) -> Path:
        """After the run: the remaining rows and the final status.

        A stream that ``releases_rows`` takes the Solution as the run left
        it (not finalized), writes the rows it still holds, closes the file
        and attaches it to the Solution (``Solution.attach_file``), which
        reads its rows from there on. Otherwise the Solution is finalized
        and the derived columns computed chunk by chunk become its own (its
        summary does not compute them again)."""
        with _DeferredInterrupt():
            if not self._header:
                self.begin(sol)
            with _Timer(self):
                if self.releases_rows:
                    self._write_rows(sol, sol.n_rows, finalized=False)
                    sol.attach_file(self._hand_back(self._written), self._extents)
                else:
                    self._write_rows(sol, len(sol.t), finalized=True)
                    if sol._derived is None and self._derived and None not in self._derived:
                        sol._derived = {k: np.concatenate([d[k] for d in self._derived])
                                        for k in self._derived[0]}
                self._derived, self._extents = [], {}   # the Solution's now: not held twice
            sol.timings["output"] = self.elapsed
            self._end(sol, metadata(sol, columns=self.names))
        return self.path

    def close_unused(self) -> None:
        """The run never started (no consistent initial state): remove the file."""
        if not self._header:
            self.path.unlink(missing_ok=True)

    @abc.abstractmethod
    def _open(self, sol) -> None:
        """Create the file for the run ``sol`` (its metadata, status running)."""

    @abc.abstractmethod
    def _write(self, part) -> None:
        """Append the rows of ``part`` (a Solution of one chunk, derived
        columns computed) and flush them."""

    @abc.abstractmethod
    def _end(self, sol, meta) -> None:
        """Close the file with the final metadata ``meta``."""

    def _hand_back(self, n: int):
        """Close the file (before its final metadata) and return its n rows,
        read when asked for (``hdf5.FileRows``): what a stream that
        ``releases_rows`` gives the Solution at the end. None: this stream's
        file does not give rows back (its Solution keeps them)."""
        return None


class CsvStream(RowStream):
    """Writes a run's CSV as it goes (``mbdsl simulate -o run.csv``).

    The metadata lines come first with ``status: running``; chunks of rows
    follow (:class:`RowStream`); ``finish`` writes the remaining rows,
    appends what is known only at the end (the ``message``, Newton totals,
    timings, events), each once, and overwrites the header's status and
    wall time (written padded) with the final ones. A run stopped by
    Ctrl-C, a failed step or a bug therefore leaves every accepted step and
    says why it stopped; a file whose status is ``running`` comes from a
    process that was killed outright.

    Parameters and errors as :class:`~mbdsl.output.RowStream`; the file is
    created here, so that an unwritable path fails before the run starts.
    """

    def __init__(self, path, interval: float = 0.5, columns: list | None = None):
        super().__init__(path, interval, columns)
        self._file = open(self.path, "w", encoding="utf-8")

    #: Header fields known only at the end, written padded to these widths and
    #: rewritten in place by :meth:`finish`, so that the head of the file is true
    #: ("running" until then: a process killed outright leaves that).
    _LATE_FIELDS = {"status": 11, "wall_time": 24}
    #: Fields known only at the end, written once after the rows by :meth:`finish`.
    _TRAILER = ("message", "stats_total", "timings", "events", "event_cuts", "warnings")

    def _open(self, sol):
        buf = io.StringIO()
        self._late = {}
        for k, v in metadata(sol, final=False, columns=self.names).items():
            if k in self._TRAILER:               # known at the end: written there
                continue
            if k in self._LATE_FIELDS:
                buf.write(f"# {k}: ")
                self._late[k] = len(buf.getvalue().encode("utf-8"))
                buf.write(f"{v:<{self._LATE_FIELDS[k]}}\n")
            else:
                buf.write(f"# {k}: {v}\n")
        buf.write(",".join(self.names or sol.columns) + "\n")
        self._file.write(buf.getvalue())
        self._file.flush()

    def _write(self, part) -> None:
        self._file.write(_csv_rows(part.table(self.names)[1]))
        self._file.flush()

    def _rewrite_late_fields(self, meta) -> None:
        """The header's status and wall time, overwritten in place (closed file)."""
        with open(self.path, "r+b") as f:
            for k, offset in self._late.items():
                value = f"{meta[k]:<{self._LATE_FIELDS[k]}}"[:self._LATE_FIELDS[k]]
                f.seek(offset)
                f.write(value.encode("ascii"))

    def _end(self, sol, meta) -> None:
        for k in self._TRAILER:
            if k in meta:
                self._file.write(f"# {k}: {meta[k]}\n")
        self._file.close()
        self._rewrite_late_fields(meta)

    def close_unused(self) -> None:
        """The run never started (no consistent initial state): remove the empty file."""
        self._file.close()
        super().close_unused()


def read_csv_metadata(path) -> tuple[dict, list[str], np.ndarray]:
    """Read a CSV written by :func:`write_csv`: (metadata, column names, values).

    Returns
    -------
    meta : dict of str -> str
    names : list of str
    values : ndarray, shape (rows, len(names))
    """
    meta, header, rows = {}, None, []
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("#"):
                key, _, value = line[1:].strip().partition(": ")
                meta[key] = value
            elif header is None:
                header = line.strip().split(",")
            elif line.strip():
                rows.append([float(x) for x in line.split(",")])
    return meta, header or [], np.array(rows).reshape(len(rows), len(header or []))


def write_solution(solution, path, extra_metadata: dict | None = None,
                   columns: list | None = None) -> Path:
    """Write a Solution, HDF5 for ``.h5``/``.hdf5``, else CSV; ``columns``:
    patterns of the columns to write (:func:`select_columns`), None: all.

    Raises
    ------
    OSError
        If the file cannot be written.
    ValueError
        A pattern of ``columns`` matches no column.
    """
    if Path(path).suffix.lower() in HDF5_SUFFIXES:
        from .hdf5 import write_hdf5
        return write_hdf5(solution, path, extra_metadata, columns)
    return write_csv(solution, path, extra_metadata, columns)


def rebuild_system(meta: dict, path):
    """The AssembledSystem of a stored run, from its metadata (source + parameters).

    Raises
    ------
    ValueError
        The file holds no model source (written by an older version or for a
        model built in Python without source text).
    MbdError
        The stored source no longer parses (a newer language version).
    """
    from . import assemble, load_text
    source = json.loads(meta["model_source"]) if "model_source" in meta else None
    if not source:
        raise ValueError(f"{path}: the file holds no model source; load_solution needs it to "
                         "rebuild the model (results of models built in Python without text "
                         "cannot be reloaded)")
    params = json.loads(meta.get("model_parameters", "{}"))
    model = load_text(source, file=meta.get("model_file", str(path)), overrides=params)
    return assemble(model)


def run_description(meta: dict) -> dict:
    """``timings``, ``engine``, ``linear_solver``, ``events``,
    ``event_cuts``, ``dense`` and ``warnings`` of a stored run, for :meth:`Solution.from_arrays`
    (absent from files of older versions)."""
    return {"timings": json.loads(meta.get("timings", "{}")),
            "engine": meta.get("engine", "numpy"),
            "linear_solver": meta.get("linear_solver", "dense"),
            "events": [(float(t), str(name), str(kind), float(speed))
                       for t, name, kind, speed in json.loads(meta.get("events", "[]"))],
            "event_cuts": int(meta.get("event_cuts", 0)),
            "dense": meta.get("rows") == "at requested times",
            "warnings": (None if "warnings" not in meta else
                         [(str(c), str(m)) for c, m in json.loads(meta["warnings"])])}


def unfinished_message(t, t_end: float) -> str:
    """What a result file whose status is still ``running`` says: its run was
    stopped outright while it wrote the file (rows at times t [s])."""
    if not len(t):
        return "the run did not finish: the file has no rows"
    return (f"the run did not finish: the file ends at t = {float(t[-1]):.6g} s of "
            f"{float(t_end):g} s (the process writing it was stopped)")


def _method_parameters(meta: dict) -> dict:
    return {k[7:]: float(v) for k, v in meta.items() if k.startswith("method.")}


def _run_stats(meta: dict):
    from .solution import RunStats
    return RunStats(**json.loads(meta["stats_total"])) if "stats_total" in meta else RunStats()


def read_csv_solution(path):
    """A Solution from a CSV written by :func:`write_csv` (exact: 17 digits)."""
    from .solution import Solution
    meta, names, values = read_csv_metadata(path)
    if not names:
        raise ValueError(f"{path}: the file is truncated (it ends inside its header, before "
                         "the column names); write it again with mbdsl simulate")
    system = rebuild_system(meta, path)
    col = {name: i for i, name in enumerate(names)}
    lay = system.layout

    written = json.loads(meta["columns"]) if "columns" in meta else None   # some columns only

    def block(keys):
        """Columns by name, shape (rows, len(keys)); NaN for a column a file
        of some columns does not hold."""
        if written is not None:
            out = np.full((len(values), len(keys)), np.nan)
            for j, k in enumerate(keys):
                if k in col:
                    out[:, j] = values[:, col[k]]
            return out
        return values[:, [col[k] for k in keys]] if keys else np.zeros((len(values), 0))

    def stat(name, kind):
        """Column ``name`` of the file's rows as dtype ``kind``, zeros when absent."""
        return (values[:, col[name]].astype(kind) if name in col
                else np.zeros(len(values), dtype=kind))

    extra_names = json.loads(meta.get("extras", "[]"))
    rows = [f"{a}.{b}" for a, b in lay.rows]
    derived = {k: values[:, i] for k, i in col.items()
               if k in Solution.DERIVED_NAMES or k.startswith(("reaction.", "driver.", "output."))}
    stats = {k: stat(f"newton.{k}", int) for k in Solution.STAT_NAMES[:-1]}
    stats["h"] = stat("step.h", float)
    status, message = meta.get("status", "completed").strip(), meta.get("message", "")
    if status == "running":
        message = unfinished_message(values[:, col["t"]], float(meta["t_end"]))
    return Solution.from_arrays(
        system, method_name=meta["method"], method_parameters=_method_parameters(meta),
        extra_names=extra_names, h=float(meta["h"]), t_end=float(meta["t_end"]),
        t=values[:, col["t"]], q=block(lay.coordinates), v=block(lay.velocities),
        a=block(lay.accelerations), lam=block(lay.multiplier_names()),
        extras={x: block([f"{x}.{r}" for r in rows]) for x in extra_names},
        stats=stats, stats_total=_run_stats(meta), status=status,
        message=message, wall_time=float(meta.get("wall_time", 0.0)),
        derived=derived, written=written, **run_description(meta))


def load_solution(path):
    """Read a result file (CSV or HDF5, by extension) back into a Solution.

    Parameters
    ----------
    path : str or Path
        Written by ``mbdsl simulate -o`` or :func:`write_solution`.

    Returns
    -------
    Solution
        Equal to the written one: bit for bit from HDF5, and from CSV too
        (17 significant digits); the model is rebuilt from the stored source.

    Raises
    ------
    OSError
        The file cannot be read.
    ValueError
        Not a result file of this tool, or no model source in it.
    """
    path = Path(path)
    if path.suffix.lower() in HDF5_SUFFIXES:
        from .hdf5 import read_hdf5
        return read_hdf5(path)
    try:
        return read_csv_solution(path)
    except (KeyError, IndexError) as exc:
        raise ValueError(f"{path}: not a result file written by mbdsl "
                         f"(missing {exc})") from None
