"""Values at the times the user asks for: dense output between accepted steps.

With ``output_times`` (``mbdsl simulate --output-dt DT`` or ``--output-times
t1,t2,...``, ``output_dt`` in the simulate block, ``t_eval`` in
:func:`mbdsl.simulate`) a run records a row at exactly each requested time,
whatever steps it takes. The time loop records every accepted step into its
buffers as usual; :class:`DenseOutput` stands between those buffers and the
:class:`~mbdsl.io.Solution`, holds the last step, and turns each
block of steps into the rows at the requested times they cover. Memory is
one step plus the rows asked for, whatever the number of steps.

Within a step [t_n, t_n+1] of size h, at s = (t - t_n) / h:

* **q**: the cubic Hermite interpolant of (q_n, v_n) and (q_n+1, v_n+1)
  (Hairer, Norsett & Wanner, *Solving ODEs I*, II.6, eq. (6.7)): an
  interpolation error O(h^4) under the methods' O(h^2), so the rows
  converge at the method's order.
* **v**: the derivative of that cubic (error O(h^3)). It needs no
  acceleration, so it holds where a step's acceleration is not the
  motion's q'': the index-3 accelerations of NEWMARK and HHT-I3 that
  oscillate about it from step to step, HHT-ADD's a = M^-1 Q.
* **a, lambda and the method's extra multipliers**: linear between the
  steps' values (error O(h^2), the order the methods give them). They are
  the method's own values interpolated, not an index-1 solve at the
  interpolated state: a multiplier of an index-3 method is its step's.
* **energy.work, energy.dissipated**: integrated by the trapezoidal rule
  over the steps (not over the rows), then linear within a step: an
  impact's damping, over in a few steps between two rows, is in the
  balance as without dense output.

A requested time within 1e-9 h of a step's end takes that step's row
itself: fixed steps with an output interval that is a multiple of h write
the steps bit for bit. Every event gets two rows at its time, the state
the step landed on (before) and the state the method restarts from
(after): a contact or limit closing or opening, a spring's points passing,
a switch of a function of time (whose rows are the ends of the gap the
steps leave about it). A run that stops early ends with a row at its last
accepted step. A row's Newton counts are the sums over the steps since the
row before; its ``step.h`` is the size of the step it lies in.
"""

from __future__ import annotations

import time as _time

import numpy as np

__all__ = ["DenseOutput", "output_times"]

#: A requested time this close to a step's end, in units of the step,
#: takes the step's own row.
SNAP = 1e-9


def output_times(t_start: float, t_end: float, dt: float | None = None,
                 times=None) -> np.ndarray:
    """The times a run records rows at [s], sorted, in (t_start, t_end].

    Parameters
    ----------
    t_start, t_end : float [s]
    dt : float [s], optional
        An output interval: t_start + k dt for k = 1, 2, ... up to t_end,
        and t_end itself (a last interval shorter than dt, as Modelica's
        output interval).
    times : sequence of float [s], optional
        Explicit times; the run's start (the initial row) and duplicates are
        dropped, and t_end is added (every run ends with a row there).

    Returns
    -------
    ndarray, shape (k,) [s]

    Raises
    ------
    ValueError
        Both or neither of dt and times; dt <= 0 or not finite; a time
        outside [t_start, t_end] or not finite; so many rows (above 1e8)
        that the interval is surely a mistake.
    """
    if (dt is None) == (times is None):
        raise ValueError("give an output interval (output_dt) or output times, not both")
    span = t_end - t_start
    if dt is not None:
        dt = float(dt)
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"the output interval must be a positive time, got {dt!r}")
        count = int(np.floor(span / dt * (1 + 1e-12)))
        if count > 1e8:
            raise ValueError(f"an output interval of {dt:g} s asks for {count:.3g} rows over "
                             f"{span:g} s; give a larger one")
        out = t_start + dt * np.arange(1, count + 1)
    else:
        out = np.asarray(times, dtype=float).ravel()
        bad = out[~np.isfinite(out) | (out < t_start - 1e-12 * span)
                  | (out > t_end + 1e-12 * span)]
        if len(bad):
            raise ValueError(f"output time {bad[0]:g} s is outside the run "
                             f"(t = {t_start:g} .. {t_end:g} s)")
    out = np.unique(np.clip(out, t_start, t_end))
    out = out[out > t_start + 1e-12 * span]
    if not len(out) or out[-1] < t_end - 1e-12 * span:
        out = np.append(out, t_end)
    else:
        out[-1] = t_end
    return out


class DenseOutput:
    """Rows at requested times from a run's accepted steps (module notes).

    It takes the place of the Solution for the time loop's rows: the loop
    hands it blocks of accepted steps (:meth:`append_block`, the signature
    of ``Solution.append_block``) and the restarts at events
    (:meth:`amend_last`); :meth:`close` ends the run.

    Parameters
    ----------
    system : AssembledSystem
    sol : Solution
        Holds the initial row; receives the rows at the requested times.
    times : ndarray, shape (k,) [s]
        From :func:`output_times`.
    start : StepState
        The run's initial state (the held step to interpolate from).
    extra : str or None
        The name of the method's extra multipliers (``LoopState.extra``).

    Attributes
    ----------
    elapsed : float [s]
        Wall time spent here (counted as output, not integration).
    """

    def __init__(self, system, sol, times, start, extra):
        self.system, self.sol, self.times = system, sol, np.asarray(times, dtype=float)
        self.extra = extra
        self.next = 0                               # the first requested time not written
        m = system.m
        mu = start.extra.get(extra, np.zeros(m)) if extra is not None else np.zeros(m)
        # the held step: the last accepted state, the row to interpolate from
        self.held = {"t": float(start.t), "q": start.q.copy(), "v": start.v.copy(),
                     "a": start.a.copy(), "lam": start.lam.copy(),
                     "mu": np.array(mu, dtype=float), "h": 0.0, "work": 0.0, "diss": 0.0}
        self.written_t = float(start.t)             # the time of the last row written
        self.carry = np.zeros(6, np.int64)          # counts of the steps since that row
        self.flows = bool(system.has_loads) or bool(getattr(system, "driver_functions", ()))
        self.p = None                               # (p_in, p_dissipated) at the held step [W]
        self.elapsed = 0.0

    # -- the loop's side ------------------------------------------------------------------
    def append_block(self, t, q, v, a, lam, extras: dict, counts, h) -> None:
        """Accepted steps (arrays as ``Solution.append_block``): the rows at the
        requested times they cover go to the Solution; the last is held."""
        t0 = _time.perf_counter()
        k = len(t)
        if k == 0:
            return
        sol = self.sol
        h = np.full(k, float(h)) if np.ndim(h) == 0 else np.asarray(h, float)
        mu = extras[self.extra] if self.extra is not None else np.zeros_like(lam)
        sol.add_totals(counts, h)        # every step counts, whatever rows it gives
        hd = self.held
        work, diss = self._flows(t, q, v, lam)
        T = np.concatenate([[hd["t"]], t])
        H = np.concatenate([[hd["h"]], h])
        cum = np.concatenate([self.carry[None], self.carry + np.cumsum(counts, axis=0)])
        lo = self.next
        hi = int(np.searchsorted(self.times, T[-1] + SNAP * H[-1], side="right"))
        if hi > lo:
            tau = self.times[lo:hi]
            j = np.clip(np.searchsorted(T, tau, side="left"), 1, k)   # step j: T[j-1]..T[j]
            span = T[j] - T[j - 1]
            with np.errstate(divide="ignore", invalid="ignore"):
                s = np.where(span > 0, (tau - T[j - 1]) / np.where(span > 0, span, 1.0), 1.0)
            at_end = np.abs(tau - T[j]) <= SNAP * span
            at_start = ~at_end & (np.abs(tau - T[j - 1]) <= SNAP * span)

            def pick(held, block):
                """The held step's value then the block's: (k + 1, ...)."""
                return np.concatenate([held[None], block])

            Q, V, A = pick(hd["q"], q), pick(hd["v"], v), pick(hd["a"], a)
            L, M = pick(hd["lam"], lam), pick(hd["mu"], mu)
            W, D = pick(np.float64(hd["work"]), work), pick(np.float64(hd["diss"]), diss)
            rows = self._interpolate(s, span, j, Q, V, A, L, M, W, D)
            for ends, idx in ((at_end, j), (at_start, j - 1)):     # a step's own row
                if np.any(ends):
                    i = idx[ends]
                    for key, X in zip(("q", "v", "a", "lam", "mu", "work", "diss"),
                                      (Q, V, A, L, M, W, D)):
                        rows[key][ends] = X[i]
            c = cum[j]
            row_counts = np.diff(np.concatenate([np.zeros((1, 6), np.int64), c]), axis=0)
            self.carry = cum[-1] - c[-1]
            self._write(tau, rows, row_counts, H[j])
            self.next = hi
        else:
            self.carry = cum[-1]
        self.held = {"t": float(t[-1]), "q": q[-1].copy(), "v": v[-1].copy(),
                     "a": a[-1].copy(), "lam": lam[-1].copy(), "mu": np.array(mu[-1]),
                     "h": float(h[-1]), "work": float(work[-1]), "diss": float(diss[-1])}
        self.elapsed += _time.perf_counter() - t0

    def amend_last(self, t: float | None = None, a=None, lam=None, extras: dict | None = None,
                   v=None) -> None:
        """An event at the held step: its row as the step landed (before),
        then the state the method restarts from (after: v, a, lambda, the
        extra multipliers, at t [s] if given: the far end of a switch's gap),
        as in ``Solution.amend_last``. Requested times between the two get
        the restarted state."""
        t0 = _time.perf_counter()
        hd = self.held
        if hd["t"] > self.written_t:                 # before (unless a requested time took it)
            self._write_held()
        if t is not None:
            hd["t"] = float(t)
        for key, x in (("v", v), ("a", a), ("lam", lam)):
            if x is not None:
                hd[key] = np.array(x, dtype=float)
        if extras and self.extra is not None and self.extra in extras:
            hd["mu"] = np.array(extras[self.extra], dtype=float)
        self.p = None
        hi = int(np.searchsorted(self.times, hd["t"] + SNAP * hd["h"], side="right"))
        taus = self.times[self.next:hi]              # inside a switch's gap, or at the event
        for tau in taus[taus < hd["t"]]:
            self._write_held(float(tau))
        self._write_held()                           # after
        for tau in taus[taus > hd["t"]]:
            self._write_held(float(tau))
        self.next = max(self.next, hi)
        self.elapsed += _time.perf_counter() - t0

    def close(self) -> None:
        """The run ended: a row at the last accepted step if none was written
        there (a run that stopped early), with the counts since the last row;
        requested times the last step ended short of by the loop's own
        end test (1e-12 of the run's span: t_end after steps of 1e-12 s)
        get its state."""
        hd = self.held
        if hd["t"] > self.written_t:
            self._write_held()
        span = self.times[-1] - self.times[0] if len(self.times) > 1 else 0.0
        near = 1e-12 * max(span, abs(self.times[-1]) if len(self.times) else 0.0)
        for tau in self.times[self.next:]:
            if tau > hd["t"] + near:
                break
            self._write_held(float(tau))
            self.next += 1

    # -- helpers --------------------------------------------------------------------------
    def _flows(self, t, q, v, lam):
        """energy.work and energy.dissipated [J] at the block's steps: the
        trapezoidal rule over the steps from the held one."""
        k = len(t)
        if not self.flows:
            return np.zeros(k), np.zeros(k)
        hd, system = self.held, self.system
        group = getattr(system, "contact_state", None)
        log = group.log if group is not None else ()     # the impact speeds so far
        if self.p is None:
            p = system.power(np.array([hd["t"]]), hd["q"][None], hd["v"][None],
                             hd["lam"][None], contact_log=log)
            self.p = (float(p[0][0]), float(p[1][0]))
        p_in, p_diss = system.power(t, q, v, lam, contact_log=log)
        dt = 0.5 * np.diff(np.concatenate([[hd["t"]], t]))
        work = hd["work"] + np.cumsum(dt * (p_in + np.concatenate([[self.p[0]], p_in[:-1]])))
        diss = hd["diss"] + np.cumsum(dt * (p_diss + np.concatenate([[self.p[1]],
                                                                      p_diss[:-1]])))
        self.p = (float(p_in[-1]), float(p_diss[-1]))
        return work, diss

    @staticmethod
    def _interpolate(s, span, j, Q, V, A, L, M, W, D):
        """The rows at s in steps j (T[j-1]..T[j]) of the stacked step values."""
        s = s[:, None]
        hv = span[:, None]
        s2, s3 = s * s, s * s * s
        q0, q1, v0, v1 = Q[j - 1], Q[j], V[j - 1], V[j]
        q = ((2 * s3 - 3 * s2 + 1) * q0 + (s3 - 2 * s2 + s) * hv * v0
             + (3 * s2 - 2 * s3) * q1 + (s3 - s2) * hv * v1)
        with np.errstate(divide="ignore", invalid="ignore"):
            dq = ((6 * s2 - 6 * s) * (q0 - q1) / np.where(hv > 0, hv, 1.0)
                  + (3 * s2 - 4 * s + 1) * v0 + (3 * s2 - 2 * s) * v1)

        def lin(X):
            """X (steps, ...) linear within each row's step."""
            return (1 - s) * X[j - 1] + s * X[j]

        w = s[:, 0]
        return {"q": q, "v": dq, "a": lin(A), "lam": lin(L), "mu": lin(M),
                "work": (1 - w) * W[j - 1] + w * W[j], "diss": (1 - w) * D[j - 1] + w * D[j]}

    def _write_held(self, t: float | None = None) -> None:
        """The held state as one row at its time (or at t [s]), with the
        counts since the last row."""
        hd = self.held
        rows = {key: np.array(hd[key])[None] for key in ("q", "v", "a", "lam", "mu", "work",
                                                          "diss")}
        self._write(np.array([hd["t"] if t is None else t]), rows, self.carry[None].copy(),
                    np.array([hd["h"]]))
        self.carry = np.zeros(6, np.int64)

    def _write(self, tau, rows, counts, h) -> None:
        extras = {self.extra: rows["mu"]} if self.extra is not None else {}
        self.sol.append_block(tau, rows["q"], rows["v"], rows["a"], rows["lam"], extras,
                              counts, h, totals=False,
                              flows={"energy.work": rows["work"],
                                     "energy.dissipated": rows["diss"]})
        self.written_t = float(tau[-1])
