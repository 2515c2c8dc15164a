"""What a run tells while it goes: the observer interface of the time loop.

The time loop (``integrators.loop.TimeLoop``) and the driver around it
(``integrators.driver.integrate``) report to observers and know nothing of
files: the result streams (``stream.RowStream``: CSV, HDF5) and the command
line's printer of chosen columns are observers. The calls, in order:

1. ``on_start(sol)`` once, before the first step; the Solution holds the
   initial row. A stream writes its file's head here (and checks its
   columns), so that a wrong column pattern costs no run.
2. ``on_rows(sol, start, stop)`` whenever rows ``start .. stop-1`` left the
   loop's buffers for the Solution (every ``loop.FLUSH_INTERVAL`` s of wall
   time or ``loop.FLUSH_ROWS`` rows, at a switch, at the end). The last row
   may still be amended (a restart at an event or a switch replaces its
   velocity, acceleration and multipliers): a writer holds it back.
3. ``on_event(sol, event)`` for each event logged since the last call
   (``Solution.events``: (t [s], element, "closed"/"opened"/"switched", speed)),
   right after the rows up to it.
4. ``on_end(sol)`` once, on every exit of the run (completed, failed, Ctrl-C,
   an internal error), after the Solution's rows were stacked (unless an
   observer ``releases_rows``).

Two attributes tell the driver how to treat an observer: ``elapsed`` [s], its
wall time, counted in ``timings["output"]`` and not in the integration's; and
``releases_rows``: it reads the rows back from its own file, so the Solution
may drop the rows written (``Solution.release_rows``) and is not stacked at
the end (``Solution.attach_file`` instead).
"""

from __future__ import annotations

__all__ = ["RunObserver"]


class RunObserver:
    """The base of an observer of a run; every call does nothing by default.

    Attributes
    ----------
    elapsed : float [s]
        Wall time spent in the observer's calls.
    releases_rows : bool
        Whether the observer reads the rows back from its own file.
    """

    elapsed = 0.0
    releases_rows = False

    def on_start(self, sol) -> None:
        """Before the first step; ``sol`` holds the initial row."""

    def on_rows(self, sol, start: int, stop: int) -> None:
        """Rows ``start .. stop-1`` of ``sol`` were recorded (the last may
        still be amended)."""

    def on_event(self, sol, event: tuple) -> None:
        """An event was logged: (t [s], element, kind, speed)."""

    def on_end(self, sol) -> None:
        """The run ended, whatever ended it (``sol.status``)."""
