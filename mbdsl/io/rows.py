"""The rows of a run as it is recorded: per-step Newton statistics, the row
store the time loop appends to (and a streamed run releases), the arrays of a
Solution read back from its file, and the extent of a column kept chunk by
chunk.

Shapes: N stored time points, n coordinates, m constraint equations.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

__all__ = ["StepStats", "RunStats", "Extent", "FLOW_NAMES", "STAT_NAMES", "RowStore", "RowArray",
           "FileArrays"]


@dataclass
class StepStats:
    """Newton statistics of one recorded row (zeros for the initial row).

    With an output stride (``output_every`` K > 1) a row stands for the K
    steps since the previous row: the counts are their sums, ``h`` the size
    of the last of them and ``steps`` their number.
    """

    iterations: int = 0
    residuals: int = 0
    jacobians: int = 0
    factorizations: int = 0
    h: float = 0.0
    multipliers_stalled: int = 0      # steps accepted at the round-off floor (0 or 1 per step)
    steps: int = 1


@dataclass
class RunStats:
    """Totals over a run."""

    steps: int = 0
    iterations: int = 0
    residuals: int = 0
    jacobians: int = 0
    factorizations: int = 0
    rejected: int = 0
    multipliers_stalled: int = 0


class Extent(NamedTuple):
    """What a run's summary and checks read of one column: its first and last
    values, its least and greatest, its largest magnitude and the row of it
    (the first such row; NaN counts as largest, as in ``numpy.argmax``).

    Computed from a whole column (:meth:`of`), or chunk by chunk as a run
    streams its rows to a file (:meth:`merge`), with the same result.
    """

    first: float
    last: float
    min: float
    max: float
    absmax: float
    at: int

    @classmethod
    def of(cls, values, offset: int = 0) -> "Extent":
        """The extent of ``values`` (shape (k,), k >= 1), rows numbered from ``offset``."""
        x = np.asarray(values, dtype=float)
        with np.errstate(all="ignore"):
            k = int(np.argmax(np.abs(x)))
            return cls(float(x[0]), float(x[-1]), float(np.min(x)), float(np.max(x)),
                       float(abs(x[k])), offset + k)

    def merge(self, later: "Extent") -> "Extent":
        """The extent of this column's rows followed by those of ``later``."""
        with np.errstate(all="ignore"):
            first_wins = int(np.argmax([self.absmax, later.absmax])) == 0
            return Extent(self.first, later.last, float(np.min([self.min, later.min])),
                          float(np.max([self.max, later.max])),
                          self.absmax if first_wins else later.absmax,
                          self.at if first_wins else later.at)


class RowArray:
    """A Solution's array of rows (``t``, ``q``, ``v``, ``a``, ``lam``): held,
    or, for a run whose rows went to its HDF5 file as it streamed and left
    memory (:meth:`Solution.attach_file`), read from that file when first
    asked for and then held."""

    def __init__(self, dataset: str):
        self.dataset = dataset

    def __set_name__(self, owner, name):
        self.name, self.slot = name, "_held_" + name

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        held = obj.__dict__.get(self.slot)
        if held is not None:
            return held
        source = obj.__dict__.get("_file_rows")
        if source is None:
            raise AttributeError(f"the run's rows are not stacked yet (no '{self.name}' "
                                 "before Solution.finalize)")
        held = obj.__dict__[self.slot] = source.read(self.dataset)
        return held

    def __set__(self, obj, value):
        obj.__dict__[self.slot] = value

    def held(self, obj) -> bool:
        """Whether ``obj`` holds the array (not only its file does)."""
        return obj.__dict__.get(self.slot) is not None


class FileArrays(Mapping):
    """Arrays of a result file by name, each read when first asked for and
    then held (a streamed run's extras, Newton statistics and derived
    columns, :meth:`Solution.attach_file`); :meth:`column` reads one column
    of one without holding it."""

    def __init__(self, source, datasets: dict):
        #: name -> (dataset, column or None for the whole dataset)
        self._source, self._datasets, self._held = source, dict(datasets), {}

    def __getitem__(self, key):
        if key not in self._held:
            dataset, j = self._datasets[key]
            self._held[key] = self._source.read(dataset, j)
        return self._held[key]

    def __iter__(self):
        return iter(self._datasets)

    def __len__(self):
        return len(self._datasets)

    def column(self, key, j: int) -> np.ndarray:
        """Column j of the (N, k) array ``key``, read alone unless it is held."""
        if key in self._held:
            return self._held[key][:, j]
        return self._source.read(self._datasets[key][0], j)


#: The energy integrals a run with rows at requested times carries per row,
#: integrated over its steps (``integrators.dense``).
FLOW_NAMES = ("energy.work", "energy.dissipated")

#: Per-step Newton statistics, stored and written in this order (``STAT_NAMES``).
STAT_NAMES = ("iterations", "residuals", "jacobians", "factorizations", "h")


class RowStore:
    """The recorded rows of a run, in segments of arrays.

    The compiled time loop hands over blocks of rows as arrays
    (:meth:`extend`); the numpy engine one accepted state at a time
    (:meth:`append`), kept as objects until the next block or read, then
    stacked into one segment. Why: a Python object per recorded step cost as
    much as the compiled step itself (about 10 us per row, half of it the
    garbage collector walking them).

    A segment is a dict: "t" (k,), "q", "v", "a" (k, n), "lam" (k, m), one
    (k, m) array per extra multiplier name, and one (k,) array per
    ``STAT_NAMES`` entry; with ``flows``, also (k,) arrays
    "energy.work" and "energy.dissipated" integrated over the steps
    (``integrators.dense``: rows at requested times).
    """

    def __init__(self, n: int, m: int, extra_names, flows: bool = False):
        self.n, self.m, self.extra_names = n, m, tuple(extra_names)
        self.flow_names = FLOW_NAMES if flows else ()
        self._segments: list[dict] = []
        self._states: list = []
        self._stats: list = []
        self._count = 0
        #: Rows let go (:meth:`release`): the first stored row is row ``released``.
        self.released = 0

    def __len__(self) -> int:
        return self._count

    def append(self, state, stats: StepStats) -> None:
        """One accepted state (``StepState``) and its statistics."""
        self._states.append(state)
        self._stats.append(stats)
        self._count += 1

    def extend(self, segment: dict) -> None:
        """A block of rows (a segment as in the class docstring; the arrays are kept)."""
        self._flush()
        self._segments.append(segment)
        self._count += len(segment["t"])

    def _flush(self) -> None:
        if not self._states:
            return
        rows, k, m = self._states, len(self._states), self.m
        seg = {"t": np.array([s.t for s in rows], dtype=float),
               "q": np.array([s.q for s in rows], dtype=float).reshape(k, self.n),
               "v": np.array([s.v for s in rows], dtype=float).reshape(k, self.n),
               "a": np.array([s.a for s in rows], dtype=float).reshape(k, self.n),
               "lam": np.array([s.lam for s in rows], dtype=float).reshape(k, m)}
        for x in self.extra_names:
            seg[x] = np.array([s.extra[x] for s in rows], dtype=float).reshape(k, m)
        for name in STAT_NAMES:
            seg[name] = np.array([getattr(s, name) for s in self._stats])
        for name in self.flow_names:       # the initial row: nothing exchanged yet
            seg[name] = np.zeros(k)
        self._segments.append(seg)
        self._states, self._stats = [], []

    def get(self, i0: int, i1: int) -> dict:
        """Rows i0..i1-1 as one segment: views of the stored arrays when one
        segment holds them all, else new arrays (read-only use)."""
        self._flush()
        if i0 < self.released and i1 > i0:
            raise IndexError(f"rows before {self.released} were released (written to the "
                             f"result file), not rows {i0}..{i1 - 1}")
        parts, start = [], self.released
        for seg in self._segments:
            k = len(seg["t"])
            lo, hi = max(i0 - start, 0), min(i1 - start, k)
            if lo < hi:
                parts.append({key: x[lo:hi] for key, x in seg.items()})
            start += k
        keys = (("t", "q", "v", "a", "lam") + self.extra_names + STAT_NAMES
                + self.flow_names)
        if not parts:
            shapes = {"t": (0,), "q": (0, self.n), "v": (0, self.n), "a": (0, self.n)}
            return {key: np.zeros(shapes.get(key, (0, self.m) if key == "lam"
                                             or key in self.extra_names else (0,)))
                    for key in keys}
        if len(parts) == 1:
            return {key: parts[0][key] for key in keys}
        return {key: np.concatenate([p[key] for p in parts]) for key in keys}

    def release(self, upto: int) -> None:
        """Let go of the segments that hold only rows before ``upto`` (a
        stream wrote them to its file), the last segment always kept (the
        last row may still be amended, :meth:`set_last`)."""
        self._flush()
        while len(self._segments) > 1 and self.released + len(self._segments[0]["t"]) <= upto:
            self.released += len(self._segments.pop(0)["t"])

    def stack(self) -> None:
        """Hold every row as one segment (the arrays a finished run's Solution
        exposes), the segments of the run freed."""
        self._flush()
        if len(self._segments) > 1:
            self._segments = [self.get(self.released, self._count)]

    def last(self) -> dict:
        """The last row, as a one-row segment."""
        return self.get(self._count - 1, self._count)

    def set_last(self, **values) -> None:
        """Overwrite entries of the last row: a key of a segment (class
        docstring) and its new value (a float for "t", an array for the others)."""
        self._flush()
        for key, value in values.items():
            self._segments[-1][key][-1] = value
