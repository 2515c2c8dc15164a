"""The time loop: one for every method, never branching on which it runs.

Each step: the method builds its :class:`StepContext`, predicts w(0), and the
shared :class:`~mbdsl.integrators.newton.Newton` solves its residual. A step
whose Newton iteration does not converge is never accepted: it is retried
with h/2, up to ``max_halvings`` times; after ``grow_after`` successful steps
at a reduced size the step doubles again, back to the nominal h
(:class:`StepSizes`: the one policy, which the compiled loop follows too,
returning at every step it cannot converge). If the run
still cannot go on, it stops with a message in the model's words (time, step
size, method, Newton norms, the joint with the largest constraint residual)
and the :class:`~mbdsl.solution.Solution` keeps every accepted step.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time as _time

import numpy as np

from ..assembly.initial import InitialState, consistent_initial_state
from ..assembly.sparse import DENSE_LIMIT, JacobianAssembler
from ..errors import ConvergenceError, Diagnostic
from ..solution import Solution, StepStats
from .adaptive import StepControl
from .base import Method
from .blas_threads import one_thread
from .events import EventLocator, switch_times, time_switches
from .newton import Newton, NewtonOptions, NewtonStatus

__all__ = ["integrate"]

_HINTS = {
    NewtonStatus.SINGULAR: "the Newton matrix is singular: the mechanism may be at a singular "
                           "(dead-centre) position, or joints may be redundant",
    NewtonStatus.DIVERGING: "Newton diverges: the step may be too large for the fastest motion "
                            "(a stiff spring, a fast driver); try a smaller h",
    NewtonStatus.MAX_ITER: "Newton converges too slowly: try a smaller h or full Newton",
    NewtonStatus.NONFINITE: "a value became infinite or NaN: check stiffnesses, masses and "
                            "driver functions for extreme values",
}


def integrate(system, method: Method, t_end: float, h: float, *, t_start: float = 0.0,
              initial: InitialState | None = None, newton: NewtonOptions | None = None,
              on_failure: str = "raise", max_halvings: int = 6, grow_after: int = 4,
              progress=None, writer=None, output_every: int = 1,
              engine: str = "auto", announce=None, compile_policy: str = "wait",
              control: StepControl | None = None, python_loop: bool = False) -> Solution:
    """Integrate the equations of motion from t_start to t_end.

    Parameters
    ----------
    system : AssembledSystem
    method : Method
        A configured recipe, e.g. ``HHTI3(alpha=-0.1)``.
    t_end : float [s]
    h : float [s]
        Nominal step size; the last step is shortened to land on t_end.
        With ``control``: the first step's size.

    Other Parameters
    ----------------
    t_start : float [s]
    initial : InitialState, optional
        Computed with :func:`consistent_initial_state` when not given.
    newton : NewtonOptions, optional
    on_failure : {"raise", "return"}
        On a step that cannot converge: raise :class:`ConvergenceError`
        (carrying the partial solution) or return the partial solution with
        ``status == "failed"``.
    max_halvings : int
        A failing step is retried with h/2 down to h / 2**max_halvings; a
        step that fails at that size ends the run.
    grow_after : int
        Successful steps at a reduced size before the step doubles again.
    progress : callable (t, h, iterations) -> None, optional
        Told the time t [s] reached, the step h [s] and the Newton
        iterations: after each step of the driver's loop; the compiled loop
        tells it when its rows go out (full buffers, every
        ``engine.FLUSH_INTERVAL`` s of wall time, the end), with its last
        step and the mean iterations per step since it was last told.
    writer : object with ``append(solution)`` and ``finish(solution)``, optional
        Streams accepted steps to a file as the run goes
        (:class:`mbdsl.output.CsvStream`); ``finish`` runs on every exit,
        including Ctrl-C and an unexpected exception, so no step is lost.
        Called after each recorded step (the compiled loop: when progress
        is told).
    output_every : int
        Record every K-th step (and the last one), so that a long run of a
        large model does not hold every step in memory; a recorded row's
        Newton counts are the sums over the steps it stands for.
    engine : {"auto", "numpy", "compiled", "uncompiled"}
        "compiled" runs the methods with a kernel recipe (``recipe.py``)
        through the numba kernels of :mod:`.engine` (an error when the
        model or method is not covered: see ``engine.unsupported``);
        "uncompiled" the same kernels and loops run by the interpreter
        (for debugging a kernel; slow); "numpy" the vectorised numpy
        assembly; "auto" the compiled engine where it applies.
    announce : callable (str) -> None, optional
        Told when the compiled kernels are being compiled for this machine
        (once; see :mod:`.kernel_cache`).
    compile_policy : {"wait", "background"}
        With ``engine="auto"``, when the compiled kernels are not built for
        this machine yet: compile them now ("wait"), or start building them
        in a detached process and run this model on the uncompiled engine
        ("background", what the command line does, announced).
    control : StepControl, optional
        Error-controlled step sizes (:mod:`.adaptive`): each step's local
        error estimate within rtol and atol, on either engine. None (the
        default): fixed steps of h.
    python_loop : bool
        On the compiled or uncompiled engine, run this module's time loop and
        Newton iteration on the kernels' residual and Newton matrix
        (``engine.SparseAdapter``) where the kernels' own loop would apply:
        the loop a step the compiled loop cannot converge is handed to
        (``_fallback``), with its halvings, the augmented formulation's jump
        and the failure's diagnosis, run alone (to compare the two loops).

    Returns
    -------
    Solution

    Raises
    ------
    ValueError
        For h <= 0, t_end <= t_start, output_every < 1, an unknown engine,
        or ``engine="compiled"`` or ``"uncompiled"`` where it does not apply (also with
        ``control``).
    ConvergenceError
        With ``on_failure="raise"`` when the run cannot go on.
    """
    output_every, control = _checked(h, t_start, t_end, on_failure, output_every, method,
                                     control)
    with one_thread():      # small matrices: a threaded BLAS only waits (blas_threads)
        which, engine, engine_note = _engine_for(system, method, engine, control,
                                                 compile_policy, announce)
        solver = Newton(newton)
        if which == "numpy" and solver.options.linear_solver == "banded":
            raise ValueError("linear_solver='banded' is a solver of the compiled engine, which "
                             "cannot run this model or was not asked for")
        clock = _time.perf_counter
        timings = dict.fromkeys(Solution.TIMING_NAMES, 0.0)
        t0 = clock()
        if initial is None:
            initial = consistent_initial_state(system, t_start)
        loop = dict(output_every=output_every, progress=progress, writer=writer,
                    max_halvings=max_halvings, grow_after=grow_after,
                    sizes=StepSizes.of_run(method, h, t_start, t_end, control, max_halvings,
                                           grow_after))
        cm = None
        if which in ("compiled", "uncompiled"):
            timings["setup"] = clock() - t0
            sol, cm = _compiled_loop(system, method, t_start, t_end, h, initial, solver, which,
                                     control, python_loop, announce, timings, loop)
            if sol is not None:
                return _result(sol, on_failure)
            t0 = clock()
        sol = _driver_loop(system, method, t_start, t_end, h, initial, solver, which, cm,
                           control, timings, t0, loop,
                           engine_note=(engine_note or _unsupported(system, method)
                                        if engine in ("auto", "auto_numpy") else None))
        return _result(sol, on_failure)


def _unsupported(system, method):
    """Why the compiled engine cannot run this (``engine.unsupported``), or None."""
    from .engine import unsupported
    return unsupported(system, method)


def _checked(h, t_start, t_end, on_failure, output_every, method, control):
    """(output_every, control) of :func:`integrate` checked: its ValueErrors,
    and the step control's growth limited to the method's largest step ratio."""
    if not (h > 0 and math.isfinite(h)):
        raise ValueError(f"h must be positive and finite, got {h}")
    if not (t_end > t_start):
        raise ValueError(f"t_end ({t_end}) must be after t_start ({t_start})")
    if on_failure not in ("raise", "return"):
        raise ValueError("on_failure must be 'raise' or 'return'")
    if not (isinstance(output_every, (int, np.integer)) and output_every >= 1):
        raise ValueError(f"output_every must be a positive integer, got {output_every!r}")
    if control is not None and method.max_step_ratio is not None \
            and control.max_factor > method.max_step_ratio:
        control = dataclasses.replace(control, max_factor=method.max_step_ratio)
    return int(output_every), control


def _engine_for(system, method, engine, control, compile_policy, announce):
    """(the engine that runs, the engine asked for, the note why not the
    compiled one or None): ``engine.select_engine``, after error control
    sent a method whose recipe the compiled loop cannot vary to numpy
    ("auto_numpy")."""
    from .engine import recipe_monomials, select_engine
    engine_note = None
    if control is not None:
        if (engine != "numpy" and method.kernel_recipe(1.0, False) is not None
                and recipe_monomials(method) is None):          # a recipe the loop cannot vary
            if engine in ("compiled", "uncompiled"):
                raise ValueError(f"the {engine} engine cannot vary the step of {method.name}")
            if _unsupported(system, method) is None:
                engine_note = f"error-controlled steps of {method.name} run on numpy"
            engine = "auto_numpy"
    which = select_engine("numpy" if engine == "auto_numpy" else engine, system, method,
                          compile_policy, announce)
    return which, engine, engine_note


def _compiled_loop(system, method, t_start, t_end, h, initial, solver, which, control,
                   python_loop, announce, timings, loop):
    """Run on the kernels' own time loop where it applies: (the Solution,
    None), or (None, the kernels' model data) for the driver's loop on the
    kernels (SuperLU-sized systems, ``python_loop``, a recipe the compiled
    loop cannot evaluate at a step size, ``engine.recipe_monomials``)."""
    from .engine import prepare_compiled, recipe_monomials, run_compiled
    # The compiled loop runs from switch to switch of the functions of time and
    # returns at each event (contacts, springs whose points pass) for a step to be
    # landed on it; the driver's own loop lands each switch as it comes
    # (EventLocator.before_switch).
    python_loop = python_loop or recipe_monomials(method) is None
    functions = time_switches(system)
    switches = (switch_times(functions, t_start, t_end, h) if functions and not python_loop
                else ())
    cm, plan, timings["kernels"] = prepare_compiled(system, method, solver.options,
                                                    initial.q, announce,
                                                    python_loop=python_loop,
                                                    uncompiled=which == "uncompiled")
    if plan.kind == "sparse" or python_loop:
        return None, cm
    sol = Solution(system, method, h, t_end, initial)
    sol.engine, sol.linear_solver = which, plan.kind
    sol.control = control
    sol.append(method.start(system, initial)[-1], StepStats())
    sol.timings = timings
    fallback = functools.partial(_fallback, system, method, solver.options, control, loop, cm)
    loop_start = _time.perf_counter()
    try:
        run_compiled(system, method, t_end, h, t_start, initial, solver.options, sol, plan,
                     control, fallback, loop["sizes"], cm=cm, switches=switches,
                     output_every=loop["output_every"], progress=loop["progress"],
                     writer=loop["writer"])
    except KeyboardInterrupt:
        _interrupted(sol)
    finally:
        _finish(sol, loop["writer"], loop_start)
    return sol, None


def _fallback(system, method, newton, control, loop, cm, sol, t, end, h, state, events=None,
              h_first=None):
    """Take over from a compiled loop at a step it could not take (Newton
    failed at the smallest step the run's :class:`StepSizes` allows, or on
    a step landed on an event; with error control, the tolerance not met
    at h_min): run this module's time loop on the same kernels
    (``SparseAdapter`` on the model data ``cm``, on ``sol``'s engine) from
    t towards end [s], from the loop's accepted state (q, v, a, lambda, aux,
    previous; ``engine._LoopState.state``: a two-step method goes on from
    its previous state, not with a start-up step), with a first step
    h_first [s] (h when None), h [s] the run's nominal (fixed) or current
    (error control) step, and the run's StepSizes (``loop["sizes"]``, as
    the compiled loop left it). Its own Newton may take the step, or the
    run ends with the diagnosis in the model's words. It hands the run back
    after an accepted step (with fixed steps, ``control`` None, once its
    step is back to h; ``hand_back``), the size it planned next in the
    part's ``next_step``, or at end. ``events``: the compiled loop's
    ``EventLocator``, which this loop goes on with (the contacts' state,
    armed gaps and impact speeds, as they are: a new one would start them
    afresh and log the closed gaps again); None when the loop has none. Appends the part's rows to
    ``sol``; a part that did not complete sets ``sol``'s status, message
    and diagnostics. Returns the part (a Solution).

    ``newton``, ``control``, ``loop``: the run's Newton options, step control
    and loop options (:func:`integrate`); "banded", the compiled loop's
    linear solver, becomes this loop's own choice ("auto")."""
    if newton.linear_solver == "banded":
        newton = dataclasses.replace(newton, linear_solver="auto")
    q, v, a, lam, aux, previous = state
    # the accepted state as a start, its residuals measured
    start = InitialState(t, q.copy(), v.copy(), a.copy(), lam.copy(),
                         float(np.max(np.abs(system.Phi(q, t)), initial=0.0)),
                         float(np.max(np.abs(system.Phiq_times(q, t, v) + system.Phi_t(q, t)),
                                      initial=0.0)),
                         float("nan"), method_state={"aux": aux.copy(), "previous": previous})
    part_loop = dict(loop, output_every=1, progress=None, writer=None,
                     hand_back=True, events=events, h_first=h_first)
    timings = dict.fromkeys(Solution.TIMING_NAMES, 0.0)
    part = _driver_loop(system, method, t, end, h, start, Newton(newton), sol.engine, cm,
                        control, timings, _time.perf_counter(), part_loop, engine_note=None)
    sol.extend(part, start=1)
    if part.status != "completed":
        sol.status, sol.message = part.status, part.message
        sol.diagnostics = part.diagnostics
    return part


def _driver_loop(system, method, t_start, t_end, h, initial, solver, which, cm, control,
                 timings, t0, loop, engine_note):
    """Run this module's time loop (:func:`_time_loop`): the numpy engine's
    methods, or the kernels' residual and Newton matrix (``SparseAdapter``)
    on the compiled or uncompiled engine with model data ``cm``."""
    from .engine import SparseAdapter
    blocks = method.blocks(system)
    kinds = np.concatenate([np.full(b.size, b.kind == "multiplier") for b in blocks])
    size = len(kinds)
    choice = solver.options.linear_solver
    assembler = JacobianAssembler(size, sparse=(choice == "sparse" or
                                               (choice == "auto" and size > DENSE_LIMIT)))
    if which in ("compiled", "uncompiled"):
        method = SparseAdapter(system, method, cm, dense=not assembler.sparse)
    history = method.start(system, initial)
    previous = initial.method_state.get("previous")
    if previous is not None and method.history_length > 1:    # resuming a two-step method
        history = [previous] + history
    sol = Solution(system, method, h, t_end, initial)
    sol.control = control
    sol.engine = which
    sol.engine_note = engine_note
    sol.linear_solver = "sparse" if assembler.sparse else "dense"
    sol.append(history[-1], StepStats())
    sol.last_state = history[-1]
    timings["setup"] += _time.perf_counter() - t0
    sol.timings = timings
    loop_start = _time.perf_counter()
    try:
        _time_loop(system, method, solver, sol, history, kinds, assembler, t_start, t_end, h,
                   loop["max_halvings"], loop["grow_after"], loop["output_every"],
                   loop["progress"], loop["writer"], control, loop.get("hand_back", False),
                   loop.get("events"), loop.get("sizes"), loop.get("h_first"))
    except KeyboardInterrupt:
        _interrupted(sol)
    finally:
        _finish(sol, loop["writer"], loop_start)
    return sol


def _time_loop(system, method, solver, sol, history, kinds, assembler, t_start, t_end, h,
               max_halvings, grow_after, output_every, progress, writer, control=None,
               hand_back=False, resume_events=None, sizes=None, h_first=None):
    """Step ``method`` from t_start to t_end with the Python Newton iteration,
    recording into ``sol`` (which holds the initial row); sets its status and
    message (halving, regrowth and the failure report as in the module notes;
    with ``control`` the step sizes of :mod:`.adaptive`). ``hand_back``
    (the compiled loop's fallback): stop, completed, after the first
    accepted step (fixed steps: from which the next is of the nominal h
    again), with the next step's size in ``sol.next_step``;
    ``resume_events``: the compiled loop's EventLocator, gone on with;
    ``sizes``: the run's :class:`StepSizes` (a new one when None), the
    first step h_first [s] (h when None).
    Ctrl-C (KeyboardInterrupt) records the last accepted state and goes on
    to the caller (:func:`_interrupted`); any other exception is a bug: the
    status says so and the exception propagates."""
    pending = StepStats(steps=0)      # steps not yet recorded (output stride)
    n_steps = 0
    # The limit is on the step size, not on consecutive failures: counting
    # failures lets a run creep towards a lock-up with ever smaller steps.
    if sizes is None:
        sizes = StepSizes.of_run(method, h, t_start, t_end, control, max_halvings, grow_after)
    t, h_cur = t_start, h_first or h
    carry = 0.0          # Kahan compensation: t stays exact to round-off over 1e6 steps
    adaptive = control is not None
    if adaptive:
        h_min = sizes.h_min
        h_max = min(control.h_max, t_end - t_start)
        after_rejection = False
    events = None
    if resume_events is not None:     # taking over from the compiled loop: its contacts' state
        events = resume_events
        events.sol = sol
        events.resume_at(history[-1].q)
    elif EventLocator.needed(system):
        events = EventLocator(system, h, sol)
        events.start(t_start, history[-1])
    resume = None                # the step size planned before a step was cut for an event
    try:
        while t < t_end - 1e-9 * h:
            step = min(h_cur, t_end - t)
            if t_end - (t + step) < 1e-6 * step:   # land on t_end, never leave a sliver
                step = t_end - t
            if events is not None:
                shorter = events.before_switch(t, step, t_end)  # a switch of a function of time
                if shorter < step:
                    step, resume = shorter, resume or h_cur
            y = step - carry
            t_new = t + y
            new_carry = (t_new - t) - y
            if step == t_end - t:         # the last step lands on t_end exactly
                t_new, new_carry = t_end, 0.0
            ctx = method.context(system, history, t_new, step)
            ctx.assembler = assembler
            ctx.regularization = method.regularization
            w0 = method.predict(ctx)
            scales = method.scales(system, step, ctx.last.q)
            key = step
            if method.formulation == "augmented":
                # only Phi_q^T lambda is unique where Phi_q loses rank: converge on a;
                # a Newton matrix of its own every step (Method.formulated)
                scales = np.where(kinds, 0.0, scales)
                key = (step, t_new)
            res = solver.solve(lambda w: method.residual(w, ctx), lambda w: method.jacobian(w, ctx),
                               w0, kinds, scales, key=key,
                               floor=method.roundoff_floor(system, step, ctx.last.q))
            if not res.converged:
                sol.stats_total.rejected += 1
                retry = sizes.failed(t, step, t_end)    # a jump, or half the step
                if retry is not None:
                    h_cur = retry
                    continue
                sol.stats_total.rejected -= 1           # the failure that ends the run
                _fail(sol, method, ctx, res, t, step, h)
                break
            state = method.accept(res.w, ctx)
            if events is not None:
                # first whether it ends on its events: a step into a stiff
                # contact is cut to the closing, not rejected for its error
                cut = events.check(t, step, ctx.last, state)
                if cut is not None:
                    resume = resume or max(h_cur, step)
                    h_cur = cut
                    sol.event_cuts += 1
                    continue
            if adaptive:
                err = control.norm(method.local_error(ctx, state), ctx.last.q, state.q)
                if err > 1.0:
                    if step <= h_min * (1.0 + 1e-9):
                        _fail_tolerance(sol, method, control, t, step, err)
                        break
                    sol.stats_total.rejected += 1
                    h_cur = max(step * control.factor(err, True), h_min)
                    after_rejection, sizes.jumped = True, None
                    continue
                h_cur = min(step * control.factor(err, after_rejection), h_max)
                after_rejection, sizes.jumped = False, None
            if events is not None:
                events.commit()
                if resume is not None:                  # landed on it: back to the size planned
                    h_cur, resume = max(h_cur, resume) if adaptive else resume, None
                if adaptive:
                    h_cur = min(h_cur, events.step_limit())
            h_cur = sizes.landed(h_cur)                 # past a jump: back to the size before
            history = (list(history) + [state])[-method.history_length:]
            if events is not None and events.happened and method.history_length > 1:
                # an event is a kink in the motion: a two-step method starts
                # afresh from it rather than reach back across it, with a
                # short one-step (BDF1) start: its numerical damping of the
                # contact mode grows as h^2
                history = [state]
                if adaptive:
                    h_cur = min(h_cur, RESTART_FRACTION * events.changed_limit)

            sol.last_state = state
            n_steps += 1
            pending = StepStats(pending.iterations + res.n_iter, pending.residuals + res.n_residual,
                                pending.jacobians + res.n_jacobian,
                                pending.factorizations + res.n_factor, step,
                                pending.multipliers_stalled + int(res.multipliers_stalled),
                                pending.steps + 1)
            t, carry = t_new, new_carry
            if events is not None:
                switched = events.after_switch(t, method, state)
                if switched is not None:        # restarted just after it, on the new branch
                    t, state = switched
                    carry, history, sol.last_state = 0.0, [state], state
                    if resume is not None:
                        h_cur, resume = max(h_cur, resume), None
            recorded = n_steps % output_every == 0 or t >= t_end - 1e-9 * h
            if recorded:
                sol.append(state, pending)
                pending = StepStats(steps=0)
            h_cur = sizes.grown(h_cur)
            if progress is not None:
                progress(t, step, res.n_iter)
            if writer is not None and recorded:
                writer.append(sol)
            if hand_back and (adaptive or h_cur >= h) and sizes.jumped is None \
                    and resume is None and (events is None or not events.happened) \
                    and t < t_end - 1e-9 * h:
                sol.status, sol.message = "completed", f"handed back at t = {t:g} s"
                sol.next_step = h_cur
                break
        else:
            sol.status, sol.message = "completed", f"reached t_end = {t_end:g} s"
        if pending.steps:          # a failure after unrecorded steps: keep the last state
            sol.append(history[-1], pending)
    except KeyboardInterrupt:         # the driver marks the run interrupted (_interrupted)
        if pending.steps:
            sol.append(history[-1], pending)
        raise
    except Exception as exc:          # a bug: keep what was computed, then let it surface
        sol.status = "failed"
        sol.message = f"internal error at t = {t:.6g} s: {exc!r}"
        raise


#: how much longer a failed step of the augmented formulation is retried first
JUMP = 1.5
#: a two-step method's first step after an event, as a fraction of the
#: contact's step limit (``events.EventLocator.step_limit``)
RESTART_FRACTION = 0.05


class StepSizes:
    """What the driver does with a step Newton cannot converge, and when a
    reduced step grows back: one policy for a run, whichever loop takes the
    step (this module's :func:`_time_loop`, or the compiled loop through
    ``engine._CompiledRun``, which returns at every such step), and carried
    across a hand-over from one to the other.

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
        if self.augmented and self.jumped is None and t + JUMP * step < t_end - 1e-9 * self.h:
            self.jumped = step
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
        """How many fixed steps of h_cur [s] the compiled loop may take before
        this policy changes the size (a jump: one; a reduced size: until it
        grows), or 0 for no limit."""
        if self.jumped is not None:
            return 1
        if self.adaptive or h_cur >= self.h:
            return 0
        return max(self.grow_after - self.good, 1)


def _interrupted(sol):
    """Ctrl-C ended the run (the loop recorded its last accepted state):
    status "interrupted", at the time of that state."""
    sol.status = "interrupted"
    sol.message = (f"interrupted by the user at t = {sol.last_t:.6g} s; every accepted step "
                   "is kept")


def _finish(sol, writer, loop_start):
    """Stack the recorded rows and close the stream: on every exit of a run.

    ``sol.timings["integration"]`` is the time since the loop started less
    the writer's time during it (``writer.elapsed``), which goes to
    ``"output"`` with the writer's final flush; ``sol.wall_time`` is the
    integration time.
    """
    clock = _time.perf_counter
    written = getattr(writer, "elapsed", 0.0)
    sol.timings["integration"] = clock() - loop_start - written
    sol.wall_time = sol.timings["integration"]
    t0 = clock()
    sol.finalize()              # stacking the rows, and the method's output multipliers
    stacking = clock() - t0
    if writer is not None:
        writer.finish(sol)
        sol.timings["output"] = getattr(writer, "elapsed", 0.0)
    sol.timings["output"] += stacking


def _result(sol, on_failure):
    """The Solution, or ConvergenceError carrying it for a failed run under "raise"."""
    if sol.status == "failed" and on_failure == "raise":
        raise ConvergenceError(sol.message, sol.diagnostics, solution=sol)
    return sol


def _null_vector(method, ctx, w):
    """(s_min / s_max, right singular vector of s_min) of the Newton matrix at w
    (dense SVD; None for matrices too large to decompose densely)."""
    J = method.jacobian(w, ctx)
    if hasattr(J, "toarray"):
        if J.shape[0] > 3000:
            return None
        J = J.toarray()
    J = np.asarray(J, dtype=float)
    if not np.all(np.isfinite(J)):
        return None
    _, sv, vt = np.linalg.svd(J)
    return sv[-1] / max(sv[0], 1e-300), vt[-1]


def _stiff_elements(system, h):
    """Springs whose natural period (sqrt of k over the attached mass or
    inertia, a one-body estimate) is shorter than 4 h: (name, period [s])."""
    out = []
    model = system.model
    for f in model.forces:
        k = getattr(f, "k", None)
        if not k:
            continue
        if hasattr(f, "joint"):                      # rotational: k [N m/rad] over inertia
            bodies = [f.joint.first.body, f.joint.second.body]
            inertia = [model.bodies[b].inertia for b in bodies if b >= 0]
        else:
            bodies = [f.first.body, f.second.body]
            inertia = [model.bodies[b].mass for b in bodies if b >= 0]
        if inertia:
            period = 2.0 * np.pi * np.sqrt(min(inertia) / k)
            if period < 4.0 * h:
                out.append((f.name, period))
    return sorted(out, key=lambda x: x[1])


def _fail_tolerance(sol, method, control, t, step, err):
    """Stop a run whose local error stays above the tolerance at the smallest step."""
    msg = (f"the step from t = {t:.6g} s cannot meet the error tolerance with "
           f"{method.describe()}: at the smallest step h = {step:.3g} s its local error is "
           f"{err:.3g} times rtol = {control.rtol:g}, atol = {control.atol:g}")
    sol.status, sol.message = "failed", msg
    sol.diagnostics = [Diagnostic(
        "error", "E602", msg, None, "",
        hint="a force or driver with a jump or a kink at this time (the error does not "
             "shrink with h there), or a tolerance below the round-off of q: loosen rtol/atol")]


def _fail(sol, method, ctx, res, t, step, h):
    from ..assembly.structure import involved_names
    system = ctx.system
    detail = ""
    span = None
    hint = _HINTS.get(res.status, "")
    try:
        with np.errstate(all="ignore"):
            state = method.accept(res.w, ctx)
            phi = system.Phi(state.q, ctx.t)
        if np.all(np.isfinite(phi)) and system.m:
            name, value = system.layout.worst_element(phi)
            detail = f"; the largest constraint residual is at '{name}' ({value:.3g})"
            span = system.layout.span_of(name)
    except (FloatingPointError, ValueError, ZeroDivisionError, np.linalg.LinAlgError):
        pass
    try:
        with np.errstate(all="ignore"):        # at the last accepted state: finite, meaningful
            svd = _null_vector(method, ctx, method.predict(ctx))
    except (FloatingPointError, ValueError, np.linalg.LinAlgError):
        svd = None
    # 1e-6: a step failing next to a singular position (the N-four-bar's
    # Newton matrix at its last accepted state: 2e-7) is told so
    near_singular = svd is not None and svd[0] < 1e-6
    if res.status is NewtonStatus.SINGULAR or near_singular:
        null = svd[1] if svd is not None else None
        if near_singular and res.status is not NewtonStatus.SINGULAR:
            detail += f"; the Newton matrix is nearly singular (s_min/s_max = {svd[0]:.1e})"
        if null is not None:
            coords, elements = involved_names(system, method, null)
            if elements:
                detail += ("; the singular direction involves the rows of "
                           + ", ".join(f"'{e}'" for e in elements)
                           + (" and the coordinates " + ", ".join(coords) if coords else ""))
                span = system.layout.span_of(elements[0]) or span
                hint = (f"the equations of {', '.join(repr(e) for e in elements)} become "
                        "dependent here: a singular (dead-centre or locked) position of the "
                        "linkage, e.g. a crank and rod in line; "
                        + ("--formulation augmented goes through such positions, or "
                           if method.accepts_augmented and method.formulation == "lagrange"
                           else "")
                        + "start elsewhere, drive past it with a motion, or check the joint "
                        "geometry")
            elif coords:
                detail += "; the singular direction involves " + ", ".join(coords)
                hint = ("no joint holds these coordinates: a body with no mass or inertia in "
                        "that direction, or a free motion with nothing to resist it")
    elif res.status in (NewtonStatus.DIVERGING, NewtonStatus.MAX_ITER):
        stiff = _stiff_elements(system, step)
        if stiff:
            name, period = stiff[0]
            alpha = getattr(method, "alpha", None)
            rho_inf = getattr(method, "rho_inf", None)
            if alpha is not None and alpha <= -0.3 + 1e-9:      # that advice is followed
                remedy = ("use a smaller h (alpha is already -0.3, the most damping HHT "
                          "allows), or nstiff / nstiff-si2, which damp such a mode more")
            elif rho_inf is not None and rho_inf <= 1e-12:
                remedy = ("use a smaller h (rho_inf is already 0: such a mode is removed in "
                          "one step where the step resolves nothing of it)")
            else:
                remedy = ("use a smaller h, or a method with numerical damping "
                          "(hht-i3/hht-si2 with alpha = -0.3, genalpha/genalpha-si2 with "
                          "rho_inf = 0)")
            hint = (f"'{name}' oscillates with a period of about {period:.2g} s, "
                    f"shorter than the step can follow (h = {step:.2g} s): {remedy}")
            span = span or next((f.span for f in system.model.forces if f.name == name), None)
    k = len(res.norms)
    if k == 0:
        norms = "no Newton iteration"
    elif k <= 2:
        norms = "Newton norms " + ", ".join(f"{x:.2g}" for x in res.norms)
    else:            # where it started and where it ended: the trend is what helps
        norms = f"Newton norm {res.norms[0]:.2g} -> {res.norms[-1]:.2g} in {k} iterations"
    msg = (f"the step from t = {t:.6g} s could not converge with {method.describe()} "
           f"(h = {step:.3g} s after halving from {h:.3g} s): {res.status.value}; "
           f"{norms}{detail}")
    sol.status, sol.message = "failed", msg
    sol.diagnostics = [Diagnostic("error", "E601", msg, span, "involved here" if span else "",
                                  hint=hint)]
