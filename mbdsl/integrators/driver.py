"""``integrate``: a run from its options to its Solution.

It checks the options, picks the engine (``engine.select_engine``), finds
consistent initial conditions when none are given, builds the run's steppers
and runs the one time loop (:class:`~mbdsl.integrators.loop.TimeLoop`: the
step-size policy when Newton does not converge, events, switches, the output
stride, Ctrl-C, the fallback and the failure's report in the model's words),
with BLAS on one thread; the :class:`~mbdsl.io.Solution` keeps every
accepted step whatever ends the run.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time

import numpy as np

from ..assembly.initial import InitialState, consistent_initial_state
from ..errors import ConvergenceError
from ..gcpause import paused
from ..io.solution import Solution
from ..io.rows import StepStats
from .adaptive import StepControl
from .base import Method
from .blas_threads import one_thread
from .dense import DenseOutput
from .dense import output_times as dense_times
from .events import EventLocator, switch_times, time_switches
from .loop import LoopState, StepSizes, TimeLoop, sparse_newton
from .python_stepper import PythonStepper
from .newton import Newton, NewtonOptions

__all__ = ["integrate"]



def integrate(system, method: Method, t_end: float, h: float, *, t_start: float = 0.0,
              initial: InitialState | None = None, newton: NewtonOptions | None = None,
              on_failure: str = "raise", max_halvings: int = 6, grow_after: int = 4,
              progress=None, observers=(), output_every: int = 1,
              engine: str = "auto", announce=None, compile_policy: str = "wait",
              control: StepControl | None = None, python_loop: bool = False,
              setup_time: float = 0.0, output_times=None) -> Solution:
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
        Told the time t [s] reached, the last step h [s] and the mean Newton
        iterations per step since it was last told, when the rows go out of
        the loop's buffers (full buffers, every ``loop.FLUSH_INTERVAL`` s of
        wall time, a switch, the end).
    observers : sequence of RunObserver, optional
        Told of the run as it goes (:mod:`mbdsl.io.observers`: ``on_start``,
        ``on_rows`` when progress is told, ``on_event``, ``on_end``), e.g.
        :class:`mbdsl.io.CsvStream`, which streams the rows to a file;
        ``on_end`` runs on every exit, including Ctrl-C and an unexpected
        exception, so no step is lost.
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
        On the compiled or uncompiled engine, take every step with the
        Python Newton iteration on the kernels' residual and Newton matrix
        (``engine.SparseAdapter``) where the kernels' own loop would apply:
        the stepper a step the compiled loop cannot take is handed to, run
        alone (to compare the two).
    setup_time : float [s]
        Time the caller spent setting the run up before this call (reading
        the model, assembling it, the initial state), counted in
        ``timings["setup"]`` before any row is written.
    output_times : sequence of float [s], optional
        Rows at exactly these times (and t_end), interpolated within the
        steps with each method's dense output (:mod:`.dense`), instead of one
        row per step; events get their rows too. Excludes ``output_every``.

    Returns
    -------
    Solution

    Raises
    ------
    ValueError
        For h <= 0, t_end <= t_start, output_every < 1 (or > 1 with
        output_times), an output time outside the run, an unknown engine,
        or ``engine="compiled"`` or ``"uncompiled"`` where it does not apply (also with
        ``control``).
    ConvergenceError
        With ``on_failure="raise"`` when the run cannot go on.
    """
    output_every, control = _checked(h, t_start, t_end, on_failure, output_every, method,
                                     control)
    _mass_inverse(system, method, control)
    if output_times is not None:
        if output_every != 1:
            raise ValueError("rows at requested times (output_times) and output_every "
                             "exclude each other")
        output_times = dense_times(t_start, t_end, times=output_times)
    with one_thread():      # small matrices: a threaded BLAS only waits (blas_threads)
        which, engine, engine_note = _engine_for(system, method, engine, control,
                                                 compile_policy, announce)
        solver = Newton(newton)
        if which == "numpy" and solver.options.linear_solver in ("banded", "condensed"):
            raise ValueError(f"linear_solver='{solver.options.linear_solver}' is a solver of "
                             "the compiled engine, which cannot run this model or was not "
                             "asked for")
        clock = _time.perf_counter
        timings = dict.fromkeys(Solution.TIMING_NAMES, 0.0)
        t0 = clock()
        if initial is None:
            initial = consistent_initial_state(system, t_start)
        timings["setup"] = float(setup_time) + clock() - t0
        steppers = _steppers(system, method, initial, solver, which, control, python_loop,
                             announce, h, timings)
        upgrade = None
        if which == "uncompiled" and engine == "auto":   # the background build's run
            upgrade = KernelUpgrade(system, method, initial, solver, control, python_loop,
                                    announce, h)
        note = (engine_note or _unsupported(system, method)
                if engine in ("auto", "auto_numpy") and which == "numpy" else None)
        sizes = StepSizes.of_run(method, h, t_start, t_end, control, max_halvings, grow_after)
        sol = _run(system, method, t_start, t_end, h, initial, steppers, control, (which, note),
                   sizes, output_every, progress, tuple(observers), timings, output_times,
                   upgrade)
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


def _mass_inverse(system, method, control) -> None:
    """AssemblyError (E303) when the run applies M^-1 and a spatial body's
    director inertia is zero: a flat plate (J3 = J1 + J2) or a thin rod has
    a body axis that carries no mass in director coordinates
    (``model.spatial``), so M is singular there. HHT-ADD's formulas apply
    M^-1 (``Method.needs_mass_inverse``), and so does the index-1 projection
    the error estimate of the index-3 methods reads (``StepControl.index1``,
    ``Method.estimate_on_index1``). The Newton matrices of every other run
    stay invertible: the frame rows fix that director by the other two."""
    index1 = control is not None and control.index1 and method.estimate_on_index1
    if not (method.needs_mass_inverse or index1):
        return
    for b in system.model.bodies:
        if b.index in system.cmap.spatial and not np.all(b.mass_diagonal > 0.0):
            from ..errors import AssemblyError, Diagnostic
            what, hint = ((f"{method.name} needs M^-1", "run it with another method (hht-i3, "
                           "hht-si2, genalpha, nstiff, nstiff-si2, newmark): theirs do not "
                           "invert M") if method.needs_mass_inverse else
                          (f"error-controlled steps of {method.name} estimate on the index-1 "
                           "accelerations, which need M^-1", "run it with fixed steps, or "
                           "with error control on hht-si2 or nstiff-si2 (their estimate needs "
                           "no M^-1)"))
            d = Diagnostic("error", "E303", f"{what}, and body '{b.name}' with principal "
                           f"moments {tuple(float(x) for x in b.inertia)} kg m^2 has a body "
                           "axis without mass in director coordinates (a flat plate's "
                           "J3 = J1 + J2, or a thin rod's)", b.span, "M is singular", hint=hint)
            raise AssemblyError(d.message, [d])


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


@paused
def _steppers(system, method, initial, solver, which, control, python_loop, announce, h,
              timings):
    """(the stepper, its fallback or None, the linear solver's name): on the
    compiled or uncompiled engine the kernels' own loop
    (``engine.KernelStepper``) with the Python Newton on the kernels
    (``engine.SparseAdapter``) as its fallback, or that alone for
    SuperLU-sized models, ``python_loop`` and a recipe the compiled loop
    cannot evaluate at a step size (``engine.recipe_monomials``); on the
    numpy engine the Python Newton on the method's own residual. Loading
    the kernels goes to ``timings["kernels"]``."""
    if which == "numpy":
        stepper = PythonStepper(system, method, solver, control, initial)
        return stepper, None, stepper.linear_solver
    from .engine import (KernelStepper, SparseAdapter, newton_size, prepare_compiled,
                         recipe_monomials)
    mono = recipe_monomials(method)
    python_loop = python_loop or mono is None
    cm, plan, timings["kernels"] = prepare_compiled(system, method, solver.options, initial.q,
                                                    announce, python_loop=python_loop,
                                                    uncompiled=which == "uncompiled")
    size = newton_size(system, method)
    if plan.kind == "sparse" or python_loop:
        dense = not sparse_newton(solver.options, size)
        stepper = PythonStepper(system, SparseAdapter(system, method, cm, dense=dense), solver,
                                control, initial)
        return stepper, None, stepper.linear_solver
    options = solver.options
    if options.linear_solver in ("banded", "condensed"):   # the fallback's own choice
        options = dataclasses.replace(options, linear_solver="auto")
    dense = not sparse_newton(options, size)
    fallback = PythonStepper(system, SparseAdapter(system, method, cm, dense=dense),
                             Newton(options), control, None)
    index1 = control is not None and control.index1 and method.estimate_on_index1
    return KernelStepper(system, method, mono, cm, plan, solver.options, initial, h,
                         index1=index1), fallback, plan.kind


def _run(system, method, t_start, t_end, h, initial, steppers, control, engine, sizes,
         output_every, progress, observers, timings, output_times=None, upgrade=None):
    """Run the time loop (``loop.TimeLoop``) on ``steppers`` (the stepper,
    its fallback, the linear solver's name; ``upgrade``: a
    :class:`KernelUpgrade` or None); returns the Solution, whatever ended
    the run."""
    t0 = _time.perf_counter()
    primary, fallback, linear_solver = steppers
    functions = time_switches(system)
    switches = switch_times(functions, t_start, t_end, h) if functions else ()
    sol = Solution(system, method, h, t_end, initial)
    sol.engine, sol.engine_note = engine
    sol.control, sol.linear_solver, sol.timings = control, linear_solver, timings
    ls = LoopState(system, method, initial)
    sink = None
    if output_times is not None:      # rows at requested times, from every step
        sol.dense_output()
        sink = DenseOutput(system, sol, output_times, ls.start, ls.extra)
    sol.append(ls.start, StepStats())
    events = EventLocator(system, h, sol) if EventLocator.found_by_steps(system) else None
    run = TimeLoop(system, method, sol, ls, primary, fallback, t_start, t_end, h, control,
                   sizes, output_every, events, sink, upgrade)
    for observer in observers:  # a file's head, its columns checked, before any step
        observer.on_start(sol)
    # the heads' time is output's (the observers' elapsed), neither setup's nor,
    # having been spent before the loop, to be taken from the loop's
    opened = sum(o.elapsed for o in observers)
    timings["setup"] += _time.perf_counter() - t0 - opened
    loop_start = _time.perf_counter()
    try:
        run.run(switches, progress, observers)
    except KeyboardInterrupt:
        _interrupted(sol)
    finally:
        _finish(sol, observers, loop_start, getattr(sink, "elapsed", 0.0) if sink else 0.0,
                opened, upgrade)
        if sink is not None:
            sol.timings["output"] += sink.elapsed
    return sol


class KernelUpgrade:
    """A run on the uncompiled kernels while the compiled ones are built in
    the background (``compile_policy="background"``) goes on compiled once
    they are ready.

    The time loop asks it after each call of its stepper
    (``TimeLoop.upgrade``). At most every ``interval`` seconds of wall time
    it looks at the build's marker (``ready``, by default
    :func:`.kernel_cache.kernels_ready`); once the marker says built, it
    loads the compiled kernels, announced, and answers with steppers on
    them from the loop's state: the compiled loop with the linear solver
    chosen again (the uncompiled copy has no LAPACK band routines), its
    packed model's run state (contact impact speeds, springs' held
    directions) copied from the uncompiled one. Where the compiled engine
    too takes the steps with the Python Newton on the kernels (SuperLU-sized
    models, ``python_loop``), that stepper is kept, its history with it,
    and only its kernels are swapped. The loading is timed as ``timings["kernels"]``,
    never as steps; the Solution records where the switch came
    (``sol.compiled_from``: t [s], the steps before it and their
    integration time [s], set when the run ends) and says so in its summary.

    While it is awaited, the time loop cuts its stepper's calls to about
    half a second each (``loop.UPGRADE_CALL_SECONDS``), so that the switch
    comes soon after the build ends.

    Parameters
    ----------
    system, method, initial, solver, control, python_loop, announce, h
        The run's, as ``integrate`` has them.
    ready : callable () -> bool, optional
        Whether the compiled kernels are built.
    interval : float [s]
        The least wall time between two looks at ``ready``.
    """

    def __init__(self, system, method, initial, solver, control, python_loop, announce, h,
                 ready=None, interval=1.0):
        from .kernel_cache import kernels_ready
        self.run = (system, method, initial, solver, control, python_loop, announce, h)
        self.ready = ready if ready is not None else kernels_ready
        self.interval = float(interval)
        self.looked = _time.perf_counter()
        self.seconds = 0.0        # loading the compiled kernels
        #: (t [s], steps, clock [s], the loop's output time so far [s]) at the
        #: switch, or None: ``_finish`` makes ``Solution.compiled_from`` of it
        self.at = None

    def __call__(self, loop):
        """New (stepper, fallback) on the compiled kernels, or None (not
        looked at yet, or not built)."""
        now = _time.perf_counter()
        if now - self.looked < self.interval:
            return None
        self.looked = now
        if not self.ready():
            return None
        return self._switch(loop)

    def _switch(self, loop):
        """Load the compiled kernels and build the steppers on them."""
        from .engine import KernelStepper, copy_run_state
        system, method, initial, solver, control, python_loop, announce, h = self.run
        t0 = _time.perf_counter()
        written = sum(o.elapsed for o in loop.observers) + getattr(loop.sink, "elapsed", 0.0)
        self.at = (loop.t, loop.step_no, t0, written)
        if announce is not None:
            announce(f"the compiled kernels are built: the run goes on with them from "
                     f"t = {loop.t:.6g} s")
        old = loop.primary
        # announce: a cache the marker wrongly calls built compiles here, and says so
        new, fallback, kind = _steppers(system, method, initial, solver, "compiled", control,
                                        python_loop, announce, h, {})
        def packed(stepper):
            """The model data a stepper's kernels evaluate: the compiled loop's,
            or the Python Newton's adapter's."""
            return stepper.cm if isinstance(stepper, KernelStepper) else stepper.method.cm
        cm = packed(new)
        copy_run_state(cm, packed(old))
        if not isinstance(new, KernelStepper) and not isinstance(old, KernelStepper):
            # the Python Newton on the kernels (SuperLU-sized models, ``python_loop``)
            # goes on as it was, its history with it, on the compiled kernels
            old.method.use_kernels(cm)
            new, fallback = old, loop.fallback
        loop.sol.engine, loop.sol.linear_solver = "compiled", kind
        self.seconds = _time.perf_counter() - t0
        return new, fallback


def _interrupted(sol):
    """Ctrl-C ended the run (the loop recorded its last accepted state):
    status "interrupted", at the time of that state."""
    sol.status = "interrupted"
    sol.message = (f"interrupted by the user at t = {sol.last_t:.6g} s; every accepted step "
                   "is kept")


def _finish(sol, observers, loop_start, resampling=0.0, opened=0.0, upgrade=None):
    """Stack the recorded rows and tell the observers the run ended (a
    stream closes its file): on every exit of a run.

    ``sol.timings["integration"]`` is the time since the loop started less
    the observers' time during it (their ``elapsed`` less ``opened`` [s],
    what they spent before the loop: a file's head), which goes to
    ``"output"`` with their final calls, as does ``resampling`` [s]
    (the rows at requested times, ``dense.DenseOutput``), and less the
    compiled kernels' loading during the run (``upgrade``, a
    :class:`KernelUpgrade` or None), which goes to ``"kernels"``;
    ``sol.wall_time`` is the integration time. A run that went on compiled
    gets ``sol.compiled_from``: where it switched and the integration time
    of its uncompiled steps, so that its summary gives each engine's time
    per step apart.
    """
    clock = _time.perf_counter
    written = sum(o.elapsed for o in observers) - opened + resampling
    kernels = upgrade.seconds if upgrade is not None else 0.0
    sol.timings["kernels"] += kernels
    sol.timings["integration"] = clock() - loop_start - written - kernels
    sol.wall_time = sol.timings["integration"]
    if upgrade is not None and upgrade.at is not None:
        t_at, steps_at, clock_at, written_at = upgrade.at
        before = max(clock_at - loop_start - (written_at - opened), 0.0)
        sol.compiled_from = (t_at, steps_at, before)
    t0 = clock()
    if not any(o.releases_rows for o in observers):   # else the rows are read from its file
        sol.finalize()          # stacking the rows, and the method's output multipliers
    stacking = clock() - t0
    for observer in observers:
        observer.on_end(sol)
    if observers:
        sol.timings["output"] = sum(o.elapsed for o in observers)
    sol.timings["output"] += stacking


def _result(sol, on_failure):
    """The Solution, or ConvergenceError carrying it for a failed run under "raise"."""
    if sol.status == "failed" and on_failure == "raise":
        raise ConvergenceError(sol.message, sol.diagnostics, solution=sol)
    return sol


