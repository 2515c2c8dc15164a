"""The time loop: one driver for every engine, over steppers with one contract.

:class:`TimeLoop` runs a run from t_start to t_end. It owns everything that is
not a step: the stretches between switches of functions of time (the method
restarts on the new branch past each), the step-size policy when Newton does
not converge (:class:`StepSizes`: halving, the augmented formulation's jump,
regrowth), landing a step on an event (contacts, joint limits, springs whose
points pass; ``events.EventLocator``), the output stride and the buffers the
rows go through to the :class:`~mbdsl.io.Solution`, the progress callback
and the run's observers (:mod:`mbdsl.io.observers`: the result streams), Ctrl-C, handing a step a stepper cannot take to the fallback,
and the failure's report in the model's words.

A stepper takes steps: ``advance(loop, mode, h, limit) -> (status, steps)``
from the loop's state (``loop.ls``, a :class:`LoopState`; t and the step
control in ``loop.state``), in a mode and with a status of
:mod:`.outcomes`, recording every ``loop.every``-th step into the loop's
buffers and updating the state after every step it accepts. Two exist:

* ``engine.KernelStepper``: the compiled loop (``integrators.compiled.run``), which takes
  up to 2000 steps (:data:`CHUNK`) in one call with its own Newton iteration
  (explicit inverse or LAPACK band LU);
* :class:`PythonStepper`: the Python Newton iteration (``newton.Newton``,
  dense LU or SuperLU) on a method's own residual and Newton matrix (the
  numpy engine) or on the kernels' (``engine.SparseAdapter``: systems too
  large for the compiled loop's linear solvers, and the fallback of the
  compiled loop at a step it cannot take).

Error-control rejections stay inside a stepper's call (as scipy's
``OdeSolver.step`` retries its own), counted in the state; a step Newton
cannot converge always returns to this loop.
"""

from __future__ import annotations

import time as _time

import numpy as np

from .base import StepState
from .diagnosis import fail_chatter, fail_stalled, fail_unstable
from .events import restart_after_switch, switch_gap
from .outcomes import ATTEMPT, CONVERGED, EVENT, LAND, REJECTED, RUN, TOLERANCE
from .records import (CNT_STEPS, CONTROL_FIELDS, CTL_H_MAX, STATE_FIELDS, ST_AFTER_REJECTION,
                      ST_CARRY, ST_ERR, ST_H, ST_H_LAST, ST_LIMIT, ST_MODE, ST_REJECTED, ST_T,
                      vector)

__all__ = ["TimeLoop", "LoopState", "StepSizes", "CHUNK", "FLUSH_INTERVAL", "sparse_newton"]

#: Rows the loop's output buffers hold, and the steps a stepper takes in one call at
#: most: it returns when either is reached. Ctrl-C and the progress callback are seen
#: between the compiled loop's calls, so with ``output_every`` K a call must not take
#: CHUNK K steps (a chain of 1000 links, 1.6 ms a step, recording every 100th: 5
#: minutes).
CHUNK = 2000
#: ... and the most bytes those buffers take: a model of n coordinates keeps
#: fewer rows where CHUNK rows of its q, v, a, lambda and mu would take more (a
#: chain of 1e5 links, 3e5 coordinates: 35 rows, not the 24 GB 2000 rows take,
#: which the machine's memory does not have); every model below 5000
#: coordinates keeps CHUNK.
OUTPUT_BYTES = 256 * 2 ** 20


def buffer_rows(n: int, m: int) -> int:
    """Rows of the loop's output buffers for n coordinates and m constraint
    rows: CHUNK, or fewer (at least 1) to stay within OUTPUT_BYTES."""
    per_row = 8 * (3 * n + 2 * m + 8)       # q, v, a, lambda, mu, t, h and the counts
    return int(max(1, min(CHUNK, OUTPUT_BYTES // per_row)))
#: Error control: a run whose last STALL_STEPS accepted steps averaged less
#: than STALL_FRACTION times its nominal step, with at least STALL_REJECTED
#: rejected steps per accepted one among them, stops (E604): a generated
#: mechanism whose friction switch the steps chased took 1.1e6 steps of about
#: 2e-10 s in 2.3e-4 s of its 0.3 s before it was killed, 1.16 rejected per
#: accepted step. Steps that resolve a fast motion are as short and are
#: accepted: the light cart-pole's passages take 2e5 steps of 4e-10 s at rtol
#: 1e-8 (NSTIFF), with 30 rejected steps in the whole run.
STALL_STEPS = 200_000
STALL_FRACTION = 1e-6
STALL_REJECTED = 0.1
#: Error control: a run whose last FLOOR_STEPS accepted steps were all at the
#: smallest size the halving reaches (below 2 h_min), each after a failed
#: attempt (a rejected step per accepted one), stops there too (E604): it
#: cannot get anywhere (a pole of 1e-12 m on a light cart, stepped at 6e-15 s,
#: each step refused as singular by the compiled solver and taken by the
#: fallback, ran 200 000 such steps, 48 s, before STALL_STEPS said so). Steps
#: as small that the error control accepts resolve a fast motion and go on
#: (the light cart-pole's passages at rtol 1e-7: steps of 1.7e-11 s, h_min
#: being 1e-11 s).
FLOOR_STEPS = 1000
#: The buffered rows go to the Solution, the progress callback and the observers when
#: the buffers are full, at a boundary of the run (an event landed, a hand-over, a
#: switch, the end, Ctrl-C), or when this much wall time [s] has passed since they
#: last went: a run whose steps fail often returns to the loop at every failure (it
#: halves), and appending each call's one or two rows to the Solution cost more than
#: the kernel's step. A Python stepper's call ends after as long.
FLUSH_INTERVAL = 0.2
#: ... or when the Solution holds this many rows more than when they last went: a
#: stream that writes the rows to its file (``io.stream.RowStream``) keeps the rows held
#: in memory bounded on a machine of any speed, not only within FLUSH_INTERVAL's
#: worth of steps.
FLUSH_ROWS = 1 << 14
#: A run waiting for an ``upgrade`` (its kernels being built): the stepper's first
#: call takes this many steps, each later one about UPGRADE_CALL_SECONDS of wall time
#: (sized by the call before), so that the switch comes soon after the build ends,
#: not after a call of CHUNK uncompiled steps. Cutting a call costs a new Newton
#: matrix at its start, which changes the steps only within Newton's tolerance.
UPGRADE_FIRST_CALL = 10
UPGRADE_CALL_SECONDS = 0.5
#: how much longer a failed step of the augmented formulation is retried first
JUMP = 1.5
#: a two-step method's first step after an event, as a fraction of the
#: contact's step limit (``events.EventLocator.step_limit``)
RESTART_FRACTION = 0.05



def sparse_newton(options, size) -> bool:
    """Whether the Python Newton iteration factors a Newton matrix of ``size``
    unknowns with SuperLU (asked for, or "auto" above ``DENSE_LIMIT``),
    rather than dense LU."""
    from ..assembly.sparse import DENSE_LIMIT
    return options.linear_solver == "sparse" or (options.linear_solver == "auto"
                                                  and size > DENSE_LIMIT)


class StepSizes:
    """What the loop does with a step Newton cannot converge, and when a
    reduced step grows back: one policy for a run, whichever stepper takes
    the step.

    A failed step is halved, down to ``h_min``; with the augmented
    formulation it is first retried once ``JUMP`` times longer (see
    :meth:`failed`). With fixed steps, after ``grow_after`` accepted steps
    at a reduced size the step doubles, back to h at most.

    Parameters
    ----------
    h : float [s]
        The nominal step (fixed steps) or the first one (error control).
    h_min : float [s]
        The smallest step tried: h / 2**max_halvings with fixed steps, the
        control's ``h_min`` (default 1e-12 of the span) with error control.
    grow_after : int
    augmented : bool
        The method's formulation is the augmented one.
    adaptive : bool
        Error-controlled steps: the control, not this policy, grows them.

    Attributes
    ----------
    jumped : float or None
        The size [s] of the step that failed before a jump, while jumping.
    good : int
        Accepted steps since the step was last reduced (fixed steps).
    """

    def __init__(self, h, h_min, grow_after, augmented, adaptive):
        self.h, self.h_min, self.grow_after = h, h_min, grow_after
        self.augmented, self.adaptive = augmented, adaptive
        self.jumped = None
        self.jumped_at = None    # t [s] of the last jump: one jump per point of the run
        self.good = 0

    @classmethod
    def of_run(cls, method, h, t_start, t_end, control, max_halvings, grow_after):
        """The policy of a run of ``method`` from t_start to t_end [s] with
        nominal (or first) step h [s] and ``control`` (None: fixed steps)."""
        h_min = (h / 2.0 ** max_halvings if control is None
                 else control.h_min or 1e-12 * (t_end - t_start))
        return cls(h, h_min, grow_after, getattr(method, "formulation", None) == "augmented",
                   control is not None)

    def failed(self, t, step, t_end):
        """The size [s] to retry the step from t [s] of size ``step`` [s]
        that Newton did not converge, or None when none is left (the run
        ends there). The augmented formulation first retries once JUMP times
        longer, to land past the singular position the step failed next to
        rather than halve, which aims the step end at it (every halving at a
        rank loss lands closer to it, where Newton converges slowest); the
        halvings of the step that failed first follow if the longer one
        fails too."""
        if (self.augmented and self.jumped is None and t != self.jumped_at
                and t + JUMP * step < t_end - 1e-9 * self.h):
            # once per t: the error control may shorten the jumped step (and clear
            # ``jumped``), and a jump from the same t again would cycle for ever
            # (jump, shortened by the error estimate, Newton fails, jump: measured
            # on a generated closed loop with friction, 1.6e6 rejections in 80 s)
            self.jumped, self.jumped_at = step, t
            return JUMP * step
        if self.jumped is not None:
            step, self.jumped = self.jumped, None
        if step / 2.0 >= self.h_min * (1.0 - 1e-12):
            self.good = 0
            return step / 2.0
        return None

    def landed(self, h_next):
        """The next step's size [s] after an accepted step planned at h_next
        [s]: the size before a jump, if the step was one."""
        if self.jumped is not None:
            h_next, self.jumped = self.jumped, None
        return h_next

    def grown(self, h_cur, steps=1):
        """The next step's size [s] after ``steps`` accepted fixed steps of
        h_cur [s]: doubled (to h at most) once ``grow_after`` have been
        taken at a reduced size."""
        if self.adaptive or h_cur >= self.h:
            return h_cur
        self.good += steps
        if self.good >= self.grow_after:
            h_cur, self.good = min(2.0 * h_cur, self.h), 0
        return h_cur

    def steps_before_growth(self, h_cur):
        """How many fixed steps of h_cur [s] a stepper may take before this
        policy changes the size (a jump: one; a reduced size: until it
        grows), or 0 for no limit."""
        if self.jumped is not None:
            return 1
        if self.adaptive or h_cur >= self.h:
            return 0
        return max(self.grow_after - self.good, 1)


def _segments(t_start, t_end, h, switches):
    """[(start, end, switch or None)]: the stretches of [t_start, t_end] between
    the switches of functions of time (``events.switch_times``): each ends
    ``events.switch_gap`` (SWITCH_GAP h) before its switch (time, text), the
    next starts as far after it."""
    out, start = [], t_start
    for t_switch, text in switches:
        out.append((start, t_switch - switch_gap(h, t_switch), (t_switch, text)))
        start = t_switch + switch_gap(h, t_switch)
    return out + [(start, t_end, None)]


def _restart_at_switch(system, method, sol, switch, h, ls, sink=None) -> float:
    """A stretch ended ``SWITCH_GAP`` h before ``switch`` (time, text), with a
    row there: record the event, put the new branch's state just past it
    (``events.restart_after_switch``, v taken onto the velocity constraint
    of the new branch) into the loop's v, a, lam, b (auxiliary
    acceleration) and mu (the method's ``extra`` multipliers) (``ls``, a
    :class:`LoopState`), in place, and into that row (``sink.amend_last``:
    the Solution's last row, or with rows at requested times the event's
    rows, ``dense.DenseOutput``). Returns the restart's time [s]."""
    t_switch, text = switch
    sol.events.append((t_switch, text, "switched", 0.0))
    t_new = t_switch + switch_gap(h, t_switch)
    new = restart_after_switch(system, method, t_new, ls.q, ls.v, project=True)
    extra = ls.extra
    if new is not None:
        ls.restart_from(new)
    (sink or sol).amend_last(t=t_new, v=ls.v, a=ls.a, lam=ls.lam,
                             extras={extra: ls.mu} if extra is not None else None)
    return t_new


class LoopState:
    """The accepted state a run's steppers advance in place, and the buffers
    their rows go through to the Solution.

    Attributes
    ----------
    start : StepState
        The method's state at the start (``Method.start``).
    q, v, a, b : ndarray, shape (n,)
        The accepted state; ``b`` the auxiliary acceleration of the methods
        that carry one (generalized-alpha).
    lam, mu : ndarray, shape (m,)
        The multipliers and the method's extra ones (mu of the SI2 methods,
        psi_I of HHT-ADD; name ``extra``, or None).
    q_prev, v_prev : ndarray, shape (n,)
        The state one step before (a two-step method's history).
    counts : ndarray of int, shape (6,)
        The Newton counts since the last recorded row: iterations,
        residuals, Newton matrices, factorizations, steps whose multipliers
        stalled at round-off, steps.
    out_t, out_h, out_q, out_v, out_a, out_lam, out_mu, out_stats : ndarray
        The output buffers, ``rows`` rows (:func:`buffer_rows`): time, step
        size, state, counts.
    buffered, sent : int
        Rows recorded in the buffers, and how many of them are in the
        Solution (:meth:`flush`); the next call records after them, into the
        rest of the buffers, so where a compiled call ends (and the next
        starts a new Newton matrix) follows from the steps alone, never from
        when the rows were sent.
    """

    def __init__(self, system, method, initial):
        n, m = system.n, system.m
        start = self.start = method.start(system, initial)[-1]
        self.q, self.v, self.a = start.q.copy(), start.v.copy(), start.a.copy()
        self.carries_aux = "aux" in start.extra
        self.b = (np.array(start.extra["aux"], dtype=float) if self.carries_aux
                  else np.zeros(n))
        self.lam, self.mu = start.lam.copy(), np.zeros(m)
        self.extra = method.extras[0] if method.extras else None
        if self.extra is not None and self.extra in start.extra:
            self.mu[:] = start.extra[self.extra]
        self.q_prev, self.v_prev = self.q.copy(), self.v.copy()
        self.counts = np.zeros(6, np.int64)
        rows = self.rows = buffer_rows(n, m)
        self.out_t, self.out_h = np.empty(rows), np.empty(rows)
        self.out_q, self.out_v, self.out_a = (np.empty((rows, n)) for _ in range(3))
        self.out_lam, self.out_mu = np.empty((rows, m)), np.empty((rows, m))
        self.out_stats = np.empty((rows, 6), np.int64)
        self.buffered = self.sent = 0

    def step_state(self, t) -> StepState:
        """The accepted state at t [s] as a StepState (its ``extra``: the
        method's extra multipliers and auxiliary acceleration), copied."""
        s = StepState(float(t), self.q.copy(), self.v.copy(), self.a.copy(), self.lam.copy())
        if self.carries_aux:
            s.extra["aux"] = self.b.copy()
        if self.extra is not None:
            s.extra[self.extra] = self.mu.copy()
        return s

    def restart_from(self, new: StepState) -> None:
        """Take a restart's state (``events.restart_after_switch``): its v, a,
        lambda, auxiliary acceleration and the method's extra multipliers,
        in place."""
        self.v[:], self.a[:], self.lam[:] = new.v, new.a, new.lam
        if self.carries_aux and "aux" in new.extra:
            self.b[:] = new.extra["aux"]
        if self.extra is not None and self.extra in new.extra:
            self.mu[:] = new.extra[self.extra]

    def outputs(self):
        """The out_* buffers past the rows already buffered, for the next call
        of the compiled loop to record into: (t, h, q, v, a, lam, mu, stats)."""
        k = self.buffered
        return (self.out_t[k:], self.out_h[k:], self.out_q[k:], self.out_v[k:],
                self.out_a[k:], self.out_lam[k:], self.out_mu[k:], self.out_stats[k:])

    def record(self, t, h):
        """Record the current state at t [s], taken with a step of h [s], and
        the counts since the last record (then zero), into the next row of
        the buffers (which must not be full)."""
        k = self.buffered
        self.out_t[k], self.out_h[k] = t, h
        self.out_q[k], self.out_v[k], self.out_a[k] = self.q, self.v, self.a
        self.out_lam[k], self.out_mu[k] = self.lam, self.mu
        self.out_stats[k] = self.counts
        self.counts[:] = 0
        self.buffered = k + 1

    def flush(self, sol):
        """Append the buffered rows not yet sent (with the step size each was
        taken at) to ``sol``; full buffers start again from their first row."""
        i, k = self.sent, self.buffered
        if k > i:
            x = self.extra
            sol.append_block(self.out_t[i:k].copy(), self.out_q[i:k].copy(),
                             self.out_v[i:k].copy(), self.out_a[i:k].copy(),
                             self.out_lam[i:k].copy(),
                             {x: self.out_mu[i:k].copy()} if x is not None else {},
                             self.out_stats[i:k].copy(), self.out_h[i:k].copy())
        self.sent = k
        if k == self.rows:
            self.buffered = self.sent = 0

    def add_row(self, sol, t, h):
        """Append the current state at t [s], with the counts since the last
        record (then zero), to ``sol``, after the buffered rows; h [s]: its step
        size."""
        self.flush(sol)                 # (full buffers start again from their first row)
        self.record(t, h)
        self.flush(sol)


class TimeLoop:
    """One run: from t_start to t_end on ``stepper``, recording into ``sol``
    (which holds the initial row); sets sol.status and sol.message.

    Parameters
    ----------
    system : AssembledSystem
    method : Method
    sol : Solution
    ls : LoopState
    stepper : KernelStepper or PythonStepper
        Takes the steps.
    fallback : PythonStepper or None
        Takes a step ``stepper`` cannot take at all (Newton failing at the
        smallest step ``sizes`` allows, or on a step landed on an event;
        with error control, the tolerance at h_min): its own Newton may
        converge where the stepper's did not, or the run ends with its
        diagnosis. The run goes back to ``stepper`` after a step accepted
        (with fixed steps, once the step is back to h).
    t_start, t_end, h : float [s]
        h: the nominal (fixed) or first (``control``) step.
    control : StepControl or None
    sizes : StepSizes
    output_every : int
    events : EventLocator or None
        Contacts, joint limits and springs with a free length: a stepper
        returns EVENT at a step that crosses one, and this loop lands a step
        on it (:meth:`land`).
    sink : DenseOutput, optional
        Where the recorded steps go: the rows at requested times
        (``dense.DenseOutput``, which needs every step: ``output_every``
        1); None: the steps are the Solution's rows.
    upgrade : callable (TimeLoop) -> (stepper, fallback) or None, optional
        Asked after each call of ``stepper`` that ended converged: new
        steppers to go on with from the loop's state (a run of the
        uncompiled kernels switching to the compiled ones once built,
        ``driver.KernelUpgrade``), or None to go on as before. Once it has
        answered with steppers it is not asked again.
    """

    def __init__(self, system, method, sol, ls, stepper, fallback, t_start, t_end, h, control,
                 sizes, output_every, events, sink=None, upgrade=None):
        self.system, self.method, self.sol, self.ls = system, method, sol, ls
        self.upgrade = upgrade
        # steps per call while an upgrade is awaited (UPGRADE_FIRST_CALL), else None
        self.pace = UPGRADE_FIRST_CALL if upgrade is not None else None
        self.sink = sol if sink is None else sink
        self.stepper, self.primary, self.fallback = stepper, stepper, fallback
        self.t_start, self.t_end, self.h, self.h_cur = t_start, t_end, h, h
        self.control, self.sizes, self.every, self.events = control, sizes, output_every, events
        span = t_end - t_start
        self.fixed = control is None
        if self.fixed:
            self.ctl = vector(CONTROL_FIELDS, rtol=1.0, atol=1.0, safety=1.0, min_factor=1.0,
                              max_factor=1.0, h_min=h, h_max=h, fixed=1.0, index1=0.0)
        else:
            self.ctl = vector(CONTROL_FIELDS, rtol=control.rtol, atol=control.atol,
                              safety=control.safety, min_factor=control.min_factor,
                              max_factor=control.max_factor, h_min=sizes.h_min,
                              h_max=min(control.h_max, span), fixed=0.0,
                              index1=float(control.index1))
        self.h_max = self.ctl[CTL_H_MAX]
        # no previous step, no compensation of the sum t yet (Kahan: t exact to round-off
        # over 1e6 steps), no rejection, no limit, no error of the step-size filter
        self.state = vector(STATE_FIELDS, t=t_start, h=h, rejected=0.0, h_last=0.0, mode=RUN,
                            carry=0.0, after_rejection=0.0, limit=0.0, err=0.0, ratio=0.0)
        self.trial = np.empty((2, system.n))     # the end of a step that crossed an event
        self.step_no, self.t = 0, t_start
        self.seg_end = t_end         # the stepper runs to the end of the stretch
        self.progress, self.observers = None, ()
        self.told_rows, self.told_events = 0, 0   # rows and events the observers were told of
        self.told = (0, 0)           # steps and iterations the progress callback was told of
        self.landed_now = False      # the last call of step_on landed on an event
        # a method's own stability limit (HHT-ADD on flexible beams): looked
        # at every so many accepted steps, the stepper's calls cut to that many
        self.check_every = method.stability_check_every(system)
        self.checked_at = 0          # step_no at the last look
        self.retried = False         # step_on retries a step Newton did not converge
        self.stall_mark = (0, t_start, 0.0)  # (steps, t, rejected) where the last STALL_STEPS began
        # (step_no, t, rejected steps) where the steps at h_min began, and whether
        # the last look found one
        self.floor_mark = (0, t_start, 0, False)
        if events is not None:
            events.start(t_start, ls.start)
            stepper.events_changed(self)

    def run(self, switches, progress, observers=()):
        """From switch to switch to t_end, landing events and handing steps
        the stepper cannot take to the fallback; returns the Solution."""
        sol, ls, state = self.sol, self.ls, self.state
        span = self.t_end - self.t_start
        segments = _segments(self.t_start, self.t_end, self.h, switches)
        self.progress, self.observers = progress, tuple(observers)
        self.told_rows, self.told_events = sol.n_rows, len(sol.events)
        clock = _time.perf_counter
        flushed, rows_then = clock(), sol.n_rows
        try:
            while self.t < self.t_end - 1e-12 * span:
                self.seg_end, switch = segments[0][1:]
                if self.events is not None and not self.fixed:  # the closed gaps' step limit
                    self.ctl[CTL_H_MAX] = min(self.h_max, self.events.step_limit())
                status = self.step_on()
                if self._unstable(status) or self._chatters() or self._stalled():
                    break
                if status != CONVERGED and not self._fall_back():
                    if ls.counts[CNT_STEPS]:  # accepted steps since the last record: keep the last
                        ls.add_row(self.sink, self.t, float(state[ST_H_LAST]) or self.h)
                    self.flush()
                    # a Python stepper's word: the compiled loop always has one as fallback
                    self.stepper.diagnose(self, status)
                    break
                if self.stepper is self.fallback and self._may_hand_back(status):
                    self.stepper = self.primary
                    self.primary.resync()
                if self.upgrade is not None and self.stepper is self.primary:
                    self._upgrade()
                if self.t >= self.seg_end - 1e-12 * span and switch is not None:
                    ls.flush(self.sink)
                    self.t = _restart_at_switch(self.system, self.method, sol, switch, self.h,
                                                ls, self.sink)
                    # BDF restarts: BDF1
                    state[ST_T], state[ST_H_LAST], state[ST_CARRY] = self.t, 0.0, 0.0
                    state[ST_ERR] = 0.0                  # the step-size filter restarts too
                    self.stepper.resync()
                    segments.pop(0)
                if (clock() - flushed >= FLUSH_INTERVAL
                        or sol.n_rows - rows_then >= FLUSH_ROWS):
                    self.flush()
                    flushed, rows_then = clock(), sol.n_rows
            else:
                sol.status, sol.message = "completed", f"reached t_end = {self.t_end:g} s"
            self.flush()
        except KeyboardInterrupt:       # the driver marks the run interrupted
            if ls.counts[CNT_STEPS]:    # accepted steps since the last record
                ls.add_row(self.sink, float(state[ST_T]), float(state[ST_H_LAST]) or self.h)
            raise
        except Exception as exc:        # a bug: keep what was computed, then let it surface
            sol.status = "failed"
            sol.message = f"internal error at t = {self.t:.6g} s: {exc!r}"
            raise
        finally:                        # whatever ends the run, no recorded row is lost
            ls.flush(self.sink)
            if self.sink is not sol:
                self.sink.close()
            sol.last_state = ls.step_state(state[ST_T])
        return sol

    def _upgrade(self):
        """Go on with the steppers ``upgrade`` answers with, if it does."""
        new = self.upgrade(self)
        if new is None:
            return
        self.upgrade = self.pace = None
        self.flush()              # the rows so far, told before the engine changes
        # a Python stepper kept (its kernels swapped) keeps its history; the
        # compiled loop starts every call from the loop's state
        self.stepper = self.primary = new[0]
        self.fallback = new[1]
        if self.events is not None:
            self.stepper.events_changed(self)

    def flush(self):
        """The buffered rows to the Solution, then the progress callback (the
        mean Newton iterations per step since it was last told) and the
        observers: the rows recorded and the events logged since they were
        last told (``on_rows``, ``on_event``)."""
        sol = self.sol
        self.ls.flush(self.sink)
        if self.progress is not None:
            tot = sol.stats_total
            steps, iterations = tot.steps - self.told[0], tot.iterations - self.told[1]
            if steps > 0:
                self.told = (tot.steps, tot.iterations)
                # 0: after a restart
                h_last = float(self.state[ST_H_LAST]) or float(self.state[ST_H])
                self.progress(self.t, h_last, round(iterations / steps))
        if self.observers and sol.n_rows > self.told_rows:
            start, self.told_rows = self.told_rows, sol.n_rows
            for observer in self.observers:
                observer.on_rows(sol, start, sol.n_rows)
        if self.observers and len(sol.events) > self.told_events:
            new, self.told_events = sol.events[self.told_events:], len(sol.events)
            for event in new:
                for observer in self.observers:
                    observer.on_event(sol, event)

    def step_on(self):
        """One call of the stepper from t, at the step the policy has (with
        fixed steps up to the next change of size; CHUNK steps at most; the
        fallback one step), then what the policy makes of its return: the
        steps taken count towards regrowth, an event is landed on
        (:meth:`land`), a step Newton did not converge is retried at the
        size ``sizes.failed`` gives. Returns CONVERGED, or the status of a
        step the stepper cannot take."""
        state, sizes = self.state, self.sizes
        self.landed_now = False
        h_try = self.h_cur if self.fixed else float(state[ST_H])
        limit = sizes.steps_before_growth(h_try)
        limit = min(limit, CHUNK) if limit else CHUNK
        if self.stepper is self.fallback:
            limit = 1
        if self.check_every:
            limit = min(limit, self.check_every)
        if self.pace is not None:
            limit = min(limit, self.pace)
            started = _time.perf_counter()
        status, taken = self.attempt(RUN, h_try, limit)
        if self.pace is not None and taken:
            per_step = max(_time.perf_counter() - started, 1e-9) / taken
            self.pace = int(min(CHUNK, max(1, UPGRADE_CALL_SECONDS / per_step)))
        if taken:                   # (the limit stops the call where the size would change)
            if self.fixed:
                self.h_cur = sizes.grown(sizes.landed(self.h_cur), taken)
            elif status == CONVERGED:
                state[ST_H] = sizes.landed(float(state[ST_H]))
        if status == EVENT:
            self.landed_now = True
            return self.land()
        if status in (CONVERGED, TOLERANCE):
            return status
        retry = self._retry()
        if retry is None:
            return status
        self.retried = True
        if self.fixed:
            self.h_cur = retry
        else:
            state[ST_H] = retry
        return CONVERGED

    def _unstable(self, status):
        """Every ``check_every`` accepted steps, and before a step Newton did
        not converge is retried smaller, the method's look at its own
        stability at the last accepted state (``Method.stability_check``) for
        the run's step: with fixed steps the h asked for (an instability
        first shows as Newton failing, and halving would only hide it), with
        error control the next step's size. True when it says the steps
        cannot go on: the run then stops with E603
        (``diagnosis.fail_unstable``), its rows kept."""
        retried, self.retried = self.retried, False
        if not self.check_every or status not in (CONVERGED, EVENT):
            return False
        if not retried and self.step_no - self.checked_at < self.check_every:
            return False
        self.checked_at = self.step_no
        h = self.h if self.fixed else float(self.state[ST_H])
        found = self.method.stability_check(self.system, self.ls.step_state(self.t), h)
        if found is None:
            return False
        self.flush()
        fail_unstable(self.sol, *found)
        return True

    def _stalled(self):
        """Error control only: whether the last ``STALL_STEPS`` accepted steps
        covered less than ``STALL_STEPS * STALL_FRACTION`` times the nominal
        step (their mean below a millionth of h) while the controller kept
        rejecting (at least ``STALL_REJECTED`` rejected steps per accepted
        one): the steps chase a switch and the run would take millions of
        steps more to get anywhere; or whether the last ``FLOOR_STEPS`` were
        all at the smallest size the halving reaches, each after a failed
        attempt. It stops with E604
        (``diagnosis.fail_stalled``), its rows kept."""
        if self.fixed:
            return False
        h_last, (first, t_first, rejected_first, before) = (float(self.state[ST_H_LAST]),
                                                             self.floor_mark)
        floor = 0.0 < h_last < 2.0 * self.sizes.h_min
        rejected = self.sol.stats_total.rejected
        if not (floor and before):          # counted from the second look that finds one
            first, t_first, rejected_first = self.step_no, self.t, rejected
        self.floor_mark = (first, t_first, rejected_first, floor)
        if (self.step_no - first >= FLOOR_STEPS
                and rejected - rejected_first >= self.step_no - first):
            self.flush()
            fail_stalled(self.sol, self.method, t_first, self.t, self.step_no - first, self.h)
            return True
        steps, t0, rejected0 = self.stall_mark
        if self.step_no - steps < STALL_STEPS:
            return False
        rejected = float(self.sol.stats_total.rejected)
        if (self.t - t0 < STALL_STEPS * STALL_FRACTION * self.h
                and rejected - rejected0 >= STALL_REJECTED * (self.step_no - steps)):
            self.flush()
            fail_stalled(self.sol, self.method, t0, self.t, self.step_no - steps, self.h)
            return True
        self.stall_mark = (self.step_no, self.t, rejected)
        return False

    def _chatters(self):
        """Whether a spring's points kept passing each other within less than
        a step (``EventLocator.chatter``): the run then stops with E605
        (``diagnosis.fail_chatter``), its rows kept."""
        if self.events is None or self.events.chatter is None:
            return False
        self.flush()
        fail_chatter(self.sol, self.t, *self.events.chatter)
        return True

    def _retry(self):
        """The step of size state[ST_H] from t that Newton did not converge: the
        size to retry it at (``sizes.failed``), counted as a rejected step,
        with no growth right after it under error control; None when none is
        left."""
        if self.fixed:
            self.stepper.newton_failed(self)
        retry = self.sizes.failed(self.t, float(self.state[ST_H]), self.t_end)
        if retry is not None:
            self.sol.stats_total.rejected += 1
            self.state[ST_AFTER_REJECTION] = 1.0
        return retry

    def _fall_back(self):
        """A step the stepper cannot take: whether the fallback takes over
        (counted as a rejected step; with fixed steps at the current size,
        with error control at the step's), or there is none to."""
        if self.fallback is None or self.stepper is self.fallback:
            return False
        self.sol.stats_total.rejected += 1       # the stepper's attempt at the step
        self.stepper = self.fallback
        self.fallback.resync()
        return True

    def _may_hand_back(self, status):
        """After the fallback's call: whether the run goes back to the
        stepper (a step accepted; with fixed steps at h again; not jumping
        nor just landed on an event)."""
        return (status == CONVERGED and (not self.fixed or self.h_cur >= self.h)
                and self.sizes.jumped is None and not self.landed_now
                and self.t < self.t_end - 1e-9 * self.h)

    def _restart_after_event(self, project=True):
        """After a landed event (a contact or limit closing or opening, a
        spring's points passing), at the landed state: the method starts
        again from the index-1 acceleration and multipliers of the new branch
        (``events.restart_after_switch``), as at a switch of a function of
        time, its velocities first taken back onto the velocity constraint
        (an index-3 method's drift). A one-step method's carried acceleration (HHT's a_n,
        generalized-alpha's auxiliary one) belongs to the old branch: kept,
        it alternates about the new one for many steps and the run drops to
        first order; a two-step method restarts with BDF1 (``land``). The
        recorded row of the landing step keeps the step's own values."""
        ls = self.ls
        new = restart_after_switch(self.system, self.method, self.t, ls.q, ls.v, project=project)
        if new is not None:           # (a singular index-1 matrix: the step's state stays)
            ls.restart_from(new)
            self.stepper.resync()
        if self.sink is not self.sol:  # rows at requested times: the event's two rows
            ls.flush(self.sink)
            self.sink.amend_last(v=ls.v, a=ls.a, lam=ls.lam,
                                 extras={ls.extra: ls.mu} if ls.extra is not None else None)

    def attempt(self, mode, h_try, limit=0):
        """Call the stepper in ``mode`` from (t, q, v, ...) with a first step
        of h_try, at most ``limit`` accepted steps (0: no limit); returns (its
        status, the steps it took)."""
        ls, state = self.ls, self.state
        state[ST_H], state[ST_MODE], state[ST_LIMIT] = h_try, mode, limit
        if ls.buffered == ls.rows:
            self.flush()
        status, taken = self.stepper.advance(self, mode, h_try, limit)
        if state[ST_REJECTED]:  # the error control's rejections: no jump to return from
            self.sol.stats_total.rejected += int(state[ST_REJECTED])
            self.sizes.jumped = None
        state[ST_REJECTED] = 0.0
        self.step_no += taken
        self.t = float(state[ST_T])
        return status, taken

    def land(self):
        """The stepper stopped at a step that crosses an event (a gap opening
        or closing, a spring's points passing; its end in ``trial``): retake
        it with the size that ends it just past the event
        (``EventLocator.check``), until one lands (a retake Newton cannot
        converge retried at the size ``sizes`` gives); take that step; then
        change the contact's state (``commit``) and plan the next step
        (back to the size before the cut, within the closed gaps' step
        limit; a two-step method restarts with BDF1). Returns the status of
        the last attempt."""
        ls, state, events = self.ls, self.state, self.events
        t0, step = self.t, float(state[ST_H])
        resume = step                 # the size planned, to go back to once landed
        a0 = ls.a.copy()
        if not self.method.acceleration_is_total:   # the motion's q'' for the free flight
            try:
                a0 = self.system.index1_state(t0, ls.q, ls.v)[0]
            except np.linalg.LinAlgError:
                pass
        last = StepState(t0, ls.q.copy(), ls.v.copy(), a0, ls.lam.copy())
        events.resume_at(ls.q)        # the stepper took the steps since the last event
        if events.spring_passes(ls.q, self.trial[0]):  # the tried steps continue its old branch
            events.hold(ls.q)
            self.stepper.events_changed(self)
            self.stepper.forget_crossing()     # that step was solved without it
        self.ctl[CTL_H_MAX] = self.h_max      # the step limit of the gaps after the event, below
        h_try = step
        mode = None
        landed = 0                    # steps taken (a cut one ending before the event, then on it)
        while True:
            if mode is None:          # where to end the step that crossed
                cut = events.check(t0, step, last, StepState(t0 + step, self.trial[0].copy(),
                                                             self.trial[1].copy(), None, None))
                mode, h_try = (LAND, step) if cut is None else (ATTEMPT, cut)
                self.sol.event_cuts += cut is not None
            status, taken = self.attempt(mode, h_try)
            landed += taken
            if status == EVENT:           # the retaken step crossed too: look again
                step, mode = float(state[ST_H]), None
            elif status == REJECTED:      # its error estimate: again, shorter
                mode, h_try = ATTEMPT, float(state[ST_H])
            elif status in (CONVERGED, TOLERANCE):
                break
            else:                         # Newton did not converge: the policy
                h_try = self._retry()
                if h_try is None:
                    break
                mode = ATTEMPT
        if status != CONVERGED:
            events.release()
            self.stepper.events_changed(self)
            return status
        # the step taken: its events (none, if it ended before them) from its own ends
        t = self.t
        events.check(t0, t - t0, last,
                     StepState(t, ls.q.copy(), ls.v.copy(), ls.a.copy(), ls.lam.copy()))
        events.commit()
        events.release()
        self.stepper.events_changed(self)
        if events.happened:           # every method restarts on the new branch
            self._restart_after_event(project=events.restarts)
        if self.fixed:                # back to the size before the cut, one step more at it
            h_next = self.h_cur = self.sizes.grown(self.h_cur, landed)
        else:
            h_next = min(max(float(state[ST_H]), resume), events.step_limit())
        if events.happened:
            state[ST_ERR] = 0.0            # the step-size filter restarts on the new branch
        if events.happened and self.method.history_length > 1:
            state[ST_H_LAST] = 0.0            # BDF1 from the event
            if not self.fixed:
                h_next = min(h_next, RESTART_FRACTION * events.changed_limit)
        state[ST_H] = h_next
        return status
