"""Progress bar for long runs (tqdm): the only module that imports tqdm.

The bar shows simulated time against the end time, the current step size,
Newton iterations per step since the last refresh, and tqdm's estimate of
the time to go. It appears only after a run has taken a second (tqdm's
``delay``), so short runs print nothing, and it is off unless both stdout
and the bar's stream (stderr) are terminals: piped or redirected runs, CI
logs and scripts see no bar.
"""

from __future__ import annotations

import sys
import time

__all__ = ["ProgressBar", "TaskBar"]


def _on_terminal(file) -> bool:
    """True when both ``file`` and stdout are terminals (bars are for people, not logs)."""
    return all(bool(getattr(f, "isatty", lambda: False)()) for f in (file, sys.stdout))


class ProgressBar:
    """A ``progress(t, h, iterations)`` callback for :func:`mbdsl.simulate`.

    Use as a context manager; the bar closes (and leaves its last line) on
    exit, including on an exception or Ctrl-C.

    Parameters
    ----------
    t_start, t_end : float [s]
        Simulated time span.
    enabled : bool, optional
        Default: stdout and ``file`` are terminals.
    delay : float [s]
        Wall time before the bar first appears.
    refresh : float [s]
        Minimum wall time between refreshes; calls in between cost one clock read.
    file : text stream, optional
        Default ``sys.stderr``.
    """

    def __init__(self, t_start: float, t_end: float, enabled: bool | None = None,
                 delay: float = 1.0, refresh: float = 0.2, file=None):
        from tqdm import tqdm
        file = file or sys.stderr
        self.enabled = _on_terminal(file) if enabled is None else enabled
        self.t_start, self.refresh = float(t_start), float(refresh)
        self._iters = self._steps = 0
        self._last = time.perf_counter()
        self._bar = tqdm(total=float(t_end) - float(t_start), unit="s", unit_scale=False,
                         desc="simulated", delay=delay, disable=not self.enabled, file=file,
                         bar_format="{desc} {n:.4g}/{total:.4g} s |{bar}| {postfix} "
                                    "[{elapsed}<{remaining}]", dynamic_ncols=True, leave=True)

    def __call__(self, t: float, h: float, iterations: int) -> None:
        """Record one accepted step at time t [s] with step h [s]."""
        if not self.enabled:
            return
        self._iters += iterations
        self._steps += 1
        self._t, self._h = t, h
        now = time.perf_counter()
        if now - self._last < self.refresh:
            return
        self._last = now
        self._show()

    def _show(self) -> None:
        self._bar.set_postfix_str(f"h {self._h:.2e} s, {self._iters / self._steps:.1f} it/step",
                                  refresh=False)
        self._iters = self._steps = 0
        self._bar.update(float(self._t) - self.t_start - self._bar.n)

    def close(self) -> None:
        """Show the last step recorded, and close the bar."""
        if self.enabled and self._steps:
            self._show()
        self._bar.close()

    def __enter__(self) -> "ProgressBar":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class TaskBar:
    """A ``progress(done, total)`` callback counting finished runs of a study.

    Same rules as :class:`ProgressBar`: off unless stdout and the bar's
    stream are terminals, appears after ``delay`` seconds. Use as a context
    manager.
    """

    def __init__(self, desc: str = "runs", enabled: bool | None = None, delay: float = 1.0,
                 file=None):
        from tqdm import tqdm
        file = file or sys.stderr
        self.enabled = _on_terminal(file) if enabled is None else enabled
        self._bar = tqdm(total=0, unit="run", desc=desc, delay=delay, disable=not self.enabled,
                         file=file, dynamic_ncols=True, leave=True)

    def __call__(self, done: int, total: int) -> None:
        """Record that ``done`` of ``total`` runs have finished."""
        if self._bar.total != total:
            self._bar.total = total
        self._bar.update(done - self._bar.n)

    def close(self) -> None:
        """Close the bar, leaving its last line."""
        self._bar.close()

    def __enter__(self) -> "TaskBar":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
