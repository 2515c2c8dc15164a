"""Writing a run's rows as it goes: the base of the CSV and HDF5 streams.

A stream is an observer of the run (:class:`~mbdsl.io.observers.RunObserver`):
told when the run starts, when rows were recorded, and when it ends, it
writes chunks of rows with their derived columns, never ending a file
mid-chunk.
"""

from __future__ import annotations

import abc
import signal
import threading
import time
from pathlib import Path

import numpy as np

from .metadata import metadata, select_columns
from .observers import RunObserver
from .rows import FLOW_NAMES, Extent
from .solution import Solution

__all__ = ["RowStream"]


class _Timer:
    """Adds the wall time of a ``with`` block to ``owner.elapsed``."""

    def __init__(self, owner):
        self.owner = owner

    def __enter__(self):
        self._t0 = time.perf_counter()

    def __exit__(self, *exc):
        self.owner.elapsed += time.perf_counter() - self._t0


class _DeferredInterrupt:
    """Hold Ctrl-C while a chunk is written, so the file never ends mid-chunk or
    counts a chunk twice; the KeyboardInterrupt is raised right after."""

    def __enter__(self):
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


class RowStream(RunObserver, abc.ABC):
    """Writes a run's rows as it goes: the base of :class:`CsvStream` and
    ``hdf5.HdfStream``.

    Chunks of rows go out at most every ``interval`` seconds of wall time
    (``on_rows``, told by the time loop), each with its derived columns
    (energies, constraint norms, reactions, outputs; the energy integrals
    carried from chunk to chunk), Ctrl-C held while a chunk is written;
    ``on_end`` writes the remaining rows and what is known only at the end.
    A subclass opens the file (``_open``), writes a chunk (``_write``, a
    Solution of its rows) and ends it (``_end``, with the final metadata).

    Memory stays bounded on long runs: a chunk also goes out once
    ``PENDING_ROWS`` rows wait, whatever the interval, and is written in
    parts of at most ``PART_ROWS`` rows (the derived columns' temporaries).
    A stream with ``releases_rows`` (HDF5, which reads back one column at a
    time) then lets the Solution drop the rows written
    (``Solution.release_rows``); at the end the Solution reads its rows from
    the file (``Solution.attach_file``) and its summary and checks the
    derived columns' extents kept chunk by chunk (``rows.Extent``). The
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
        it starts (:meth:`on_start`). A file of some columns keeps the rows in
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
        self._extents = {}          # their extents (rows.Extent), merged chunk by chunk
        self._energy = None         # the energy integrals at the last row written
        #: Wall time spent computing and writing rows [s] (``Solution.timings["output"]``).
        self.elapsed = 0.0

    def _part(self, sol, i0, i1, finalized):
        """Rows i0..i1-1 as a Solution with their derived columns, from the
        stacked arrays of a finalized Solution or from the rows recorded so
        far during the run; the energy integrals go on from the last chunk."""
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
            self._derived.append(derived)
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

    def on_start(self, sol) -> None:
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

    def on_rows(self, sol, start: int, stop: int) -> None:
        """Rows were recorded: write the pending ones (all but the last, which
        the loop may still amend) if ``interval`` has passed or
        ``PENDING_ROWS`` wait."""
        now = time.perf_counter()
        n = sol.n_rows - 1          # the last row may still be amended: held back
        if (self._header and now - self._last < self.interval
                and n - self._written < self.PENDING_ROWS):
            return
        self._last = now
        if not self._header:
            self.on_start(sol)
        with _DeferredInterrupt(), _Timer(self):
            self._write_rows(sol, n, finalized=False)

    def on_end(self, sol) -> Path:
        """After the run: the remaining rows and the final status.

        A stream that ``releases_rows`` takes the Solution as the run left
        it (not finalized), writes the rows it still holds, closes the file
        and attaches it to the Solution (``Solution.attach_file``), which
        reads its rows from there on. Otherwise the Solution is finalized
        and the derived columns computed chunk by chunk become its own (its
        summary does not compute them again)."""
        with _DeferredInterrupt():
            if not self._header:
                self.on_start(sol)
            with _Timer(self):
                if self.releases_rows:
                    self._write_rows(sol, sol.n_rows, finalized=False)
                    sol.attach_file(self._hand_back(self._written), self._extents)
                else:
                    self._write_rows(sol, len(sol.t), finalized=True)
                    if self._derived and None not in self._derived:
                        sol.adopt_derived({k: np.concatenate([d[k] for d in self._derived])
                                           for k in self._derived[0]})
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
