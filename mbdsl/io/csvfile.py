"""CSV results: ``#`` metadata lines (model name, file, SHA-256 and source
text, the parameter values, method and its parameters, h, t_end, tool
version, run status and why it stopped, Newton totals), then a header row of
column names and one row per stored time point, every value with 17
significant digits so that a CSV round trip loses nothing (``%.17g`` is exact
for IEEE doubles).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from .metadata import (metadata, method_parameters, rebuild_system, run_description, run_stats,
                       select_columns, unfinished_message)
from .derived import KEPT_PREFIXES
from .solution import Solution
from .stream import RowStream

__all__ = ["write_csv", "CsvStream", "read_csv_metadata", "read_csv_solution", "written_report"]


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


#: The least time [s] writing a CSV file must take, and more than the
#: integration did, for :func:`written_report` to point at HDF5.
CSV_NOTE_SECONDS = 5.0


def written_report(path, rows: int, columns: int, timings: dict, csv: bool = True) -> str:
    """The command line's line on a written result, "wrote PATH (R rows, C
    columns)", and a note on a line of its own when writing a CSV file took
    at least ``CSV_NOTE_SECONDS`` and longer than the steps did: formatting
    a value with 17 significant digits costs about 0.4 us, where HDF5 stores
    the binary doubles (the 100-link chain's 97 million values: 38 s as CSV,
    2.7 s as HDF5, docs/performance.md).

    Parameters
    ----------
    path : Path or None
        The file written; None: standard output (no note).
    rows, columns : int
        What was written.
    timings : dict
        The run's wall times [s] (``Solution.timings``: "output", "integration").
    csv : bool
        Whether the file is a CSV file (no note for HDF5).
    """
    line = f"wrote {'standard output' if path is None else path} ({rows} rows, {columns} columns)"
    spent = float(timings.get("output") or 0.0)
    if path is None or not csv or spent < CSV_NOTE_SECONDS or spent <= float(timings.get("integration") or 0.0):
        return line
    return (f"{line}\nnote: writing {rows * columns:,} values as CSV took {spent:.0f} s; -o "
            f"{Path(path).with_suffix('.h5').name} stores them as HDF5 in a fraction of that, "
            "and --output-every K, --output-dt DT or --columns PATTERNS write fewer")


class CsvStream(RowStream):
    """Writes a run's CSV as it goes (``mbdsl simulate -o run.csv``).

    The metadata lines come first with ``status: running``; chunks of rows
    follow (:class:`RowStream`); ``on_end`` writes the remaining rows,
    appends what is known only at the end (the ``message``, Newton totals,
    timings, events), each once, and overwrites the header's status and
    wall time (written padded) with the final ones. A run stopped by
    Ctrl-C, a failed step or a bug therefore leaves every accepted step and
    says why it stopped; a file whose status is ``running`` comes from a
    process that was killed outright.

    Parameters and errors as :class:`~mbdsl.io.stream.RowStream`; the file is
    created here, so that an unwritable path fails before the run starts.
    """

    def __init__(self, path, interval: float = 0.5, columns: list | None = None):
        super().__init__(path, interval, columns)
        self._file = open(self.path, "w", encoding="utf-8")

    #: Header fields known only at the end, written padded to these widths and
    #: rewritten in place by :meth:`on_end`, so that the head of the file is true
    #: ("running" until then: a process killed outright leaves that).
    _LATE_FIELDS = {"status": 11, "wall_time": 24}
    #: Fields known only at the end, written once after the rows by :meth:`on_end`.
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


def read_csv_solution(path):
    """A Solution from a CSV written by :func:`write_csv` (exact: 17 digits)."""
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
               if k in Solution.DERIVED_NAMES or k.startswith(KEPT_PREFIXES)}
    stats = {k: stat(f"newton.{k}", int) for k in Solution.STAT_NAMES[:-1]}
    stats["h"] = stat("step.h", float)
    status, message = meta.get("status", "completed").strip(), meta.get("message", "")
    if status == "running":
        message = unfinished_message(values[:, col["t"]], float(meta["t_end"]))
    return Solution.from_arrays(
        system, method_name=meta["method"], method_parameters=method_parameters(meta),
        extra_names=extra_names, h=float(meta["h"]), t_end=float(meta["t_end"]),
        t=values[:, col["t"]], q=block(lay.coordinates), v=block(lay.velocities),
        a=block(lay.accelerations), lam=block(lay.multiplier_names()),
        extras={x: block([f"{x}.{r}" for r in rows]) for x in extra_names},
        stats=stats, stats_total=run_stats(meta), status=status,
        message=message, wall_time=float(meta.get("wall_time", 0.0)),
        derived=derived, written=written, **run_description(meta))
