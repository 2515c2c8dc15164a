"""The Python stepper: steps taken by the Python Newton iteration on a
method's residual and Newton matrix (the numpy engine's, or the kernels'
through ``engine.SparseAdapter``), under the stepper contract of
:class:`~mbdsl.integrators.loop.TimeLoop` (:mod:`.outcomes`). It is the
numpy engine's stepper and the compiled loop's fallback for a step the
kernels' own loop cannot take.
"""

from __future__ import annotations

import time as _time

import numpy as np

from .adaptive import index1_acceleration
from .base import StepState
from .common import EPS
from .diagnosis import fail, fail_tolerance
from . import loop as _loop      # its FLUSH_INTERVAL read at each call
from .newton import FRAME_HOLD, ROUNDOFF_ULPS
from .outcomes import CONVERGED, EVENT, LAND, REJECTED, RUN, TOLERANCE
from .records import (CNT_FACTORIZATIONS, CNT_ITERATIONS, CNT_JACOBIANS, CNT_RESIDUALS,
                      CNT_STALLED, INDEX1_LIMIT, CNT_STEPS, CTL_H_MAX, CTL_H_MIN, ST_AFTER_REJECTION, ST_CARRY,
                      ST_ERR, ST_H, ST_H_LAST, ST_RATIO, ST_REJECTED, ST_T)

__all__ = ["PythonStepper", "constraints_at_roundoff"]


def constraints_at_roundoff(system, t: float, q: np.ndarray, v: np.ndarray,
                            velocity: bool) -> bool:
    """Whether the state meets its position constraints (and, with
    ``velocity``, its velocity constraints) to within ``newton.ROUNDOFF_ULPS``
    ulps of their terms, |Phi| <= ULPS eps (1 + |q|_max) and |Phi_q v + Phi_t|
    <= that times (1 + |v|_max): what floating point can represent, so that a
    Newton iteration stagnating there has converged (newton.py).

    Parameters
    ----------
    system : AssembledSystem
    t : float [s]
    q, v : ndarray, shape (n,) [m, rad; m/s, rad/s]
    velocity : bool
        Test Phi_q v + Phi_t too (the stabilized index-2 methods' rows).

    Returns
    -------
    bool
    """
    if system.m == 0:
        return True
    scale = ROUNDOFF_ULPS * EPS * (1.0 + float(np.max(np.abs(q), initial=0.0)))
    if np.max(np.abs(system.Phi(q, t))) > scale:
        return False
    if not velocity:
        return True
    nu = system.Phiq_times(q, t, v) + system.Phi_t(q, t)
    return bool(np.max(np.abs(nu)) <= scale * (1.0 + float(np.max(np.abs(v), initial=0.0))))


class PythonStepper:
    """Steps taken by the Python Newton iteration (``newton.Newton``: dense LU,
    or SuperLU above ``DENSE_LIMIT`` unknowns or when asked) on a method's
    residual and Newton matrix: the method's own (the numpy engine), or the
    kernels' (``engine.SparseAdapter``). The stepper contract of
    :class:`TimeLoop` (:mod:`.outcomes`); the steps of the compiled loop,
    ``integrators.compiled.loop._run``, in Python, with the method's own error estimate
    (``Method.local_error``) and its carried state (the StepStates of its
    history, with the force terms it caches).

    Parameters
    ----------
    system : AssembledSystem
    method : Method or SparseAdapter
    newton : Newton
    control : StepControl or None
    initial : InitialState or None
        The run's start, for the first step (None: a fallback, which starts
        from the loop's state at each hand-over).
    """

    def __init__(self, system, method, newton, control, initial):
        from ..assembly.sparse import JacobianAssembler
        self.system, self.method, self.newton, self.control = system, method, newton, control
        blocks = method.blocks(system)
        self.kinds = np.concatenate([np.full(b.size, b.kind == "multiplier") for b in blocks])
        # Newton's round-off test on the residual (newton.py): the saddle-point forms, their
        # Phi_q v + Phi_t rows too at index 2 (a second block of multipliers); the
        # additive form on the constraint rows it names, both levels
        self.constraint_rows = method.constraint_rows(system)
        self.roundoff_rows = (int(self.kinds.sum()) == 2 * system.m
                              if method.saddle_point_rows or self.constraint_rows is not None
                              else None)
        sparse = _loop.sparse_newton(newton.options, len(self.kinds))
        self.assembler = JacobianAssembler(len(self.kinds), sparse=sparse)
        self.history = None
        if initial is not None:
            self.history = method.start(system, initial)
            previous = initial.method_state.get("previous")
            if previous is not None and method.history_length > 1:   # resuming a two-step method
                self.history = [previous] + self.history
        self.failure = None          # (ctx, NewtonResult, t, step) or (None, err, t, step)
        self.crossing = None         # (t, step, ctx, NewtonResult, StepState): EVENT's step

    @property
    def linear_solver(self) -> str:
        """"sparse" (SuperLU) or "dense" (LAPACK's LU through scipy)."""
        return "sparse" if self.assembler.sparse else "dense"

    def resync(self):
        """The loop's state was changed by another (the compiled loop's steps,
        a restart at a switch): start the next step from it, with a new
        Newton matrix."""
        self.history = self.crossing = None
        self.newton.invalidate()

    def events_changed(self, loop):
        """The contacts changed state (their law reads it from the system's
        contact state, which the kernels' copy follows in ``SparseAdapter``)."""

    def forget_crossing(self):
        """The step that crossed an event is not to be landed on as it was
        solved (a spring's direction is held for the landing)."""
        self.crossing = None

    def newton_failed(self, loop):
        """Newton did not converge on a fixed step (nothing to change here)."""

    def _from_loop(self, loop):
        """The history the method steps from: the loop's accepted state as a
        start of the method (its cached terms evaluated there), with its
        extra multipliers and auxiliary acceleration, and for a two-step
        method the state one step before (its a and lambda NaN: BDF2 reads
        q and v) when the last step was a step (state[ST_H_LAST] > 0)."""
        from ..assembly.initial import InitialState
        ls, system, t = loop.ls, self.system, loop.t
        start = InitialState(t, ls.q.copy(), ls.v.copy(), ls.a.copy(), ls.lam.copy(),
                             float(np.max(np.abs(system.Phi(ls.q, t)), initial=0.0)), 0.0,
                             float("nan"),
                             method_state={"aux": ls.b.copy()} if ls.carries_aux else {})
        s = self.method.start(system, start)[-1]
        if ls.extra is not None:
            s.extra[ls.extra] = ls.mu.copy()
        h_last = float(loop.state[ST_H_LAST])
        if h_last > 0.0 and self.method.history_length > 1:
            previous = StepState(t - h_last, ls.q_prev.copy(), ls.v_prev.copy(),
                                 np.full_like(ls.a, np.nan), np.full_like(ls.lam, np.nan))
            return [previous, s]
        return [s]

    def advance(self, loop, mode, h, limit):
        """Steps from the loop's state (the contract of :class:`TimeLoop`,
        ``integrators.compiled.loop._run``'s in Python); returns (status, steps taken)."""
        system, method, ls, state = self.system, self.method, loop.ls, loop.state
        if self.history is None:
            self.history = self._from_loop(loop)
        control, fixed = self.control, loop.fixed
        h_min, h_max = loop.ctl[CTL_H_MIN], loop.ctl[CTL_H_MAX]
        t0, t_end = loop.t, loop.seg_end
        span = t_end - t0
        events = loop.events if mode != LAND else None
        augmented = method.formulation == "augmented"
        after_rejection = state[ST_AFTER_REJECTION] != 0.0
        from .engine import _kernels
        K = _kernels(uncompiled=system.kernel_model().uncompiled)
        step_end, step_ratio = K.step_end, K.step_ratio    # the compiled loop's rules (compiled/loop.py)
        index1 = not fixed and self._estimates_on_index1()
        clock = _time.perf_counter
        started = clock()
        t, taken = t0, 0
        # the step that crossed an event, converged: LAND of that very step takes it as it is
        crossing, self.crossing = (self.crossing if mode == LAND else None), None
        while t < t_end - 1e-12 * span and ls.buffered < ls.rows:
            step, t_new, carry = step_end(h, t, t_end, float(state[ST_CARRY]))
            history = self.history if state[ST_H_LAST] != 0.0 else self.history[-1:]  # BDF1 start
            c = ls.counts
            if crossing is not None and crossing[:2] == (t, step):
                ctx, res, new = crossing[2:]   # landing the step that crossed: solved already
            else:
                ctx, res = self._solve(history, t_new, step, augmented)
                c[[CNT_ITERATIONS, CNT_RESIDUALS, CNT_JACOBIANS, CNT_FACTORIZATIONS]] += (
                    res.n_iter, res.n_residual, res.n_jacobian, res.n_factor)
                if not res.converged:
                    self.failure = (ctx, res, t, step)
                    state[ST_T], state[ST_H] = t, step
                    state[ST_AFTER_REJECTION] = 1.0 if after_rejection else 0.0
                    return res.status.code, taken
                new = method.accept(res.w, ctx)
            crossing = None
            if events is not None and events.crosses(t, ctx.last, t_new, new):
                loop.trial[0], loop.trial[1] = new.q, new.v
                state[ST_T], state[ST_H] = t, step
                self.crossing = (t, step, ctx, res, new)
                return EVENT, taken
            if not fixed:
                err = self._error_norm(ctx, new, step, index1)
                if err > 1.0 or after_rejection:     # the filter restarts after a rejection
                    state[ST_ERR] = 0.0
                factor = step_ratio(err, float(state[ST_ERR]), float(state[ST_RATIO]),
                                    control.safety, control.min_factor, control.max_factor)
                if err > 1.0:
                    if step <= h_min * (1.0 + 1e-9):
                        self.failure = (None, err, t, step)
                        state[ST_T], state[ST_H] = t, step
                        return TOLERANCE, taken
                    state[ST_REJECTED] += 1.0
                    h = max(step * min(factor, 1.0), h_min)
                    after_rejection = True
                    if mode != RUN:
                        state[ST_T], state[ST_H], state[ST_AFTER_REJECTION] = t, h, 1.0
                        return REJECTED, taken
                    continue
                if after_rejection:
                    factor = min(factor, 1.0)
                after_rejection = False
                state[ST_ERR], state[ST_RATIO] = err, factor
            c[CNT_STALLED] += int(res.multipliers_stalled)
            self._accept(ls, new, step, t_new, carry, state, history)
            t = t_new
            taken += 1
            if not fixed:
                # a step shortened to land on the stretch's end (a switch of a function
                # of time) leaves the size planned before it
                h = max(min(step * factor, h_max), h if t >= t_end - 1e-12 * span else 0.0)
            if (loop.step_no + taken) % loop.every == 0 or t >= t_end - 1e-12 * span:
                ls.record(t, step)
            if mode != RUN or taken == limit or clock() - started > _loop.FLUSH_INTERVAL:
                break
        state[ST_T], state[ST_H], state[ST_AFTER_REJECTION] = t, h, 1.0 if after_rejection else 0.0
        return CONVERGED, taken

    def _estimates_on_index1(self) -> bool:
        """Whether an error-controlled step's estimate reads the index-1
        accelerations (``_index1_error``), by the compiled loop's rule
        (``compiled.loop._run_flags``): the method asks for it, and a band
        plan (rigid bodies) or at most ``INDEX1_LIMIT`` constraint rows (the
        dense least squares) can give it; not where friction reads the
        multipliers."""
        from .engine import _index1_band
        system = self.system
        return (self.control.index1 and self.method.estimate_on_index1 and 0 < system.m
                and (system.m <= INDEX1_LIMIT or _index1_band(system) is not None)
                and not system.frictions)

    def _error_norm(self, ctx, new, step, index1) -> float:
        """The weighted norm of the step's local error estimate (at most 1:
        accepted), on the index-1 accelerations where ``index1`` says so
        (``Method.estimate_on_index1``, :meth:`_index1_error`)."""
        method = self.method
        e = self._index1_error(ctx, new) if index1 else method.local_error(ctx, new)
        return self.control.norm(e, ctx.last.q, new.q, step,
                                 noise=abs(method.error_coefficient(ctx)[0]) / step ** 2)

    def _index1_error(self, ctx, new):
        """The local error estimate on the index-1 projections of the
        method's ``estimate_acceleration`` (``adaptive.index1_acceleration``),
        that of the step's start kept from the step before; new's in
        ``new.extra["a1"]``."""
        system, last, method = self.system, ctx.last, self.method
        dense = system.m <= INDEX1_LIMIT
        a_old = last.extra.get("a1")
        if a_old is None:
            a_old = index1_acceleration(system, last.t, last.q, last.v,
                                        method.estimate_acceleration(system, last), dense)
        a_new = new.extra["a1"] = index1_acceleration(
            system, new.t, new.q, new.v, method.estimate_acceleration(system, new), dense)
        c, absolute = self.method.error_coefficient(ctx)
        return c * (a_new if absolute else a_new - a_old)

    def _solve(self, history, t_new, step, augmented):
        """Newton on the step of size ``step`` [s] to t_new [s] after
        ``history``: (its StepContext, the NewtonResult)."""
        system, method = self.system, self.method
        ctx = method.context(system, history, t_new, step)
        ctx.assembler = self.assembler
        ctx.regularization = method.regularization
        w0 = method.predict(ctx)
        scales = method.scales(system, step, ctx.last.q)
        key = step
        if augmented:
            # only Phi_q^T lambda is unique where Phi_q loses rank: converge on a;
            # a Newton matrix of its own every step (Method.formulated)
            scales = np.where(self.kinds, 0.0, scales)
            key = (step, t_new)
        at_roundoff = None
        if self.roundoff_rows is not None and not augmented:
            def at_roundoff(w):
                """Whether the iterate w meets its constraints to round-off."""
                s = method.accept(w, ctx)
                return constraints_at_roundoff(system, s.t, s.q, s.v, self.roundoff_rows)
        frames_held = None
        if system.layout.frame_rows.size and not augmented:
            def frames_held(w):
                """Whether the iterate w holds the spatial bodies' frames."""
                s = method.accept(w, ctx)
                rows = system.layout.frame_rows
                return bool(np.max(np.abs(system.Phi(s.q, s.t)[rows])) <= FRAME_HOLD)
        res = self.newton.solve(lambda w: method.residual(w, ctx),
                                lambda w: method.jacobian(w, ctx), w0, self.kinds, scales,
                                key=key, floor=method.roundoff_floor(system, step, ctx.last.q),
                                at_roundoff=at_roundoff, constraint_rows=self.constraint_rows,
                                frames_held=frames_held, velocity_rows=method.index == 2)
        return ctx, res

    def _accept(self, ls, new, step, t_new, carry, state, history):
        """The step to ``new`` (at t_new [s], of size ``step`` [s]) taken: the
        loop's state and this stepper's history."""
        self.history = (list(history) + [new])[-self.method.history_length:]
        ls.q_prev[:], ls.v_prev[:] = ls.q, ls.v
        ls.q[:], ls.v[:], ls.a[:], ls.lam[:] = new.q, new.v, new.a, new.lam
        if ls.extra is not None:
            ls.mu[:] = new.extra[ls.extra]
        if ls.carries_aux:
            ls.b[:] = new.extra["aux"]
        state[ST_H_LAST], state[ST_CARRY] = step, carry
        state[ST_T] = t_new
        ls.counts[CNT_STEPS] += 1

    def diagnose(self, loop, status):
        """The run ends at the step this stepper could not take: its status and
        message in the model's words, and a diagnostic (E601, E602)."""
        ctx, res, t, step = self.failure
        if status == TOLERANCE:
            fail_tolerance(loop.sol, self.method, self.control, t, step, res)
        else:
            fail(loop.sol, self.method, ctx, res, t, step, loop.h)
