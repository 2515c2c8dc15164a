"""The compiled engine: the recipe methods through numba kernels.

Every method that states itself as a recipe (``Method.kernel_recipe``,
:mod:`.recipe`: all eight) runs here;
the kernels hold no method name.

Three ways of running, chosen by the size and structure of the Newton
matrix (:func:`linear_solver_plan`), each a stepper of the one time loop
(``loop.TimeLoop``), which records output, reports progress, lands steps on
events and switches, halves failed steps and lets Ctrl-C through:

* up to ``DENSE_LIMIT`` unknowns, the steps run compiled
  (:func:`mbdsl.integrators.compiled.run`: one loop for fixed and
  error-controlled steps, up to ``loop.CHUNK`` steps a call;
  :class:`KernelStepper`) with an explicit inverse;
* above it, when a bandwidth-reducing ordering (reverse Cuthill-McKee,
  scipy.sparse.csgraph) makes the Newton matrix narrow-banded (chains,
  linkages built link by link), the same compiled loop with LAPACK's band
  LU (dgbtrf, called from the kernels, and its band substitution), or,
  where the coordinates fall into small groups (spatial bodies), with the
  coordinates eliminated group by group and the band LU of the constraint
  rows' Schur complement (:mod:`.compiled.condensed`; the plans are
  :mod:`.solver_plans`');
* otherwise, the Python Newton iteration (``python_stepper.PythonStepper``,
  :mod:`.newton`) on compiled residuals and Newton matrices assembled on a
  CSC pattern fixed at the start (:class:`SparseAdapter`), with SuperLU.

A step the compiled loop cannot take at all goes to the Python stepper on
the same kernels, the time loop's ``fallback``, whose own Newton may take
it, or which writes the failure in the model's words; the compiled loop
resumes after it. The same source runs uncompiled (``engine="uncompiled"``,
:func:`.kernel_cache.uncompiled_kernels`) for debugging. The numpy engine
computes the methods' residuals and Newton matrices with independent code;
``tests/integrators/test_engine.py`` checks that they agree.

What the kernels cover (:func:`unsupported` says why a model or method is not):
the methods with a recipe;
rigid bodies and flexible beams (the floating frame of reference); revolute,
point_on_line, prismatic, fixed and distance joints (also on beam points); drivers, torques and point forces, constant or
functions of time (compiled from the language's expressions); loads of the
state (torques, joint torques and joint forces reading the motion);
spring-dampers (also between beam points), rotational spring-dampers,
friction in joints, contacts and joint limits (with their events:
``loop.TimeLoop.land``), gravity; both constraint formulations (Lagrange
and augmented). Anything else runs on the numpy engine.
"""

from __future__ import annotations



import numpy as np
import scipy

from .base import StepState
from .records import LU_FIELDS, LU_VALID, OPTION_FIELDS, OPT_REFRESH, vector
from .solver_plans import (BAND_LIMIT, BAND_MIN_SIZE, CompiledModel, LinearSolverPlan,  # noqa: F401
                           _kernels, _recipe_value, band_ordering, band_plan, condensed_cost,
                           condensed_solver_plan, linear_solver_plan, newton_pattern,
                           newton_size)

# the linear solvers' plans (``solver_plans``) are read from here too, where the
# compiled engine's other set-up is
__all__ = ["ENGINES", "unsupported", "CompiledModel", "select_engine", "run_model",
           "prepare_compiled", "copy_run_state",
           "KernelStepper",
           "newton_size", "SparseAdapter", "LinearSolverPlan", "linear_solver_plan", "band_plan",
           "band_ordering", "condensed_solver_plan", "condensed_cost", "newton_pattern",
           "BAND_LIMIT", "BAND_MIN_SIZE"]

#: Engine names accepted by ``integrate(..., engine=...)`` and ``--engine``.
ENGINES = ("auto", "numpy", "compiled", "uncompiled")

def numba_available() -> bool:
    """True when numba can be imported."""
    try:
        from ..kernels import jit
    except ImportError:
        return False
    return jit.available()


def unsupported(system, method) -> str | None:
    """Why the compiled engine cannot run this model with this method, or None."""
    if method.kernel_recipe(1.0, False) is None:
        return f"the compiled engine has no recipe for {method.name}"
    return _unsupported_elements(system)


def _unsupported_elements(system) -> str | None:
    """Why the kernels cannot evaluate this model's elements, or None: a
    function of time without an expression to compile (the packing refuses
    an element kind no kernel family holds)."""
    functions = list(system.driver_functions) + list(system.load_functions)
    if any(not f.constant and f.expr is None for f in functions):
        return "a function of time has no expression to compile"
    return None


def index1_multipliers(system, t, q, v, accelerations=False):
    """The Lagrange multipliers of the index-1 system at stored rows, shape
    (N, m): ``AssembledSystem.index1_multipliers``, evaluated by the kernels
    when this process has loaded them and they cover the model (a run on the
    compiled engine), else row by row by the system's dense index-1 matrix.
    Rigid bodies: the Schur complement Phi_q M^-1 Phi_q^T in a band Cholesky
    (``integrators.compiled.index1_multipliers_band``, ``_index1_band``; linear in the
    size of a chain); flexible beams: the dense index-1 matrix
    (``integrators.compiled.index1_multipliers``). Rows: t (N,) [s], q and v (N, n).

    Contacts: each row with the impact speeds in force at its time, from the
    contact log of the model's last run (``ContactState.log``,
    ``speeds_at``), a block of rows per contact state.

    With ``accelerations``, returns (multipliers, accelerations (N, n)
    [m/s^2, rad/s^2]), the accelerations those multipliers give
    (:func:`index1_accelerations`), which the band kernel computes from the
    Phi_q and Q it has at hand (0.3 of 1.4 us a row on the double pendulum
    when computed apart, in numpy)."""
    from .kernel_cache import loaded
    t = np.ascontiguousarray(np.atleast_1d(t), dtype=float)
    q = np.ascontiguousarray(np.atleast_2d(q), dtype=float)
    v = np.ascontiguousarray(np.atleast_2d(v), dtype=float)
    blocks, speeds = _contact_blocks(system, t)
    band = None
    if not loaded() or _unsupported_elements(system) is not None:
        out = _per_contact_state(system, blocks, speeds, system.m, lambda i0, i1: (
            system.index1_multipliers(t[i0:i1], q[i0:i1], v[i0:i1])))
    else:
        cm = run_model(system)                # its impact speeds are set per block below
        out = np.empty((len(t), system.m))
        R, C = np.empty(cm.bound, np.int64), np.empty(cm.bound, np.int64)
        band = _index1_band(system)
        acc = np.empty((len(t) if accelerations and band is not None else 0, system.n))
        for i0, i1 in blocks:
            if speeds is not None:
                cm.impact_speed[:] = speeds[i0]
            rows = (t[i0:i1], q[i0:i1], v[i0:i1], out[i0:i1], R, C, np.empty(cm.bound),
                    system.FRICTION_ITERATIONS)
            if band is None:
                _kernels().index1_multipliers(cm.ints, cm.floats, *rows)
            else:
                _kernels().index1_multipliers_band(cm.ints, cm.floats, *rows, *band,
                                                   acc[i0:i1] if len(acc) else acc)
    if not accelerations:
        return out
    if band is None:
        acc = index1_accelerations(system, t, q, v, out)
    return out, acc


def index1_accelerations(system, t, q, v, lam) -> np.ndarray:
    """The accelerations the multipliers lam give at stored rows, shape (N, n)
    [m/s^2, rad/s^2] (``AssembledSystem.accelerations``: M a = Q - Phi_q^T
    lambda), each block of rows with the contacts' impact speeds in force at
    its time (as :func:`index1_multipliers`). With the index-1 multipliers,
    the index-1 accelerations. Rows: t (N,) [s], q and v (N, n), lam (N, m)."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    blocks, speeds = _contact_blocks(system, t)
    return _per_contact_state(system, blocks, speeds, system.n, lambda i0, i1: (
        system.accelerations(t[i0:i1], q[i0:i1], v[i0:i1], lam[i0:i1])))


def _contact_blocks(system, t):
    """(blocks [(i0, i1)] of rows with one contact state each, the impact
    speeds in force at each row (N, k), or None without contacts), from the
    contact log of the model's last run (``ContactState.log``, ``speeds_at``)."""
    group = system.contact_state
    if group is None or not len(t):
        return [(0, len(t))], None
    speeds = group.speeds_at(t, group.log)
    change = np.flatnonzero(np.any(speeds[1:] != speeds[:-1], axis=1)) + 1
    edges = [0, *change.tolist(), len(t)]
    return list(zip(edges[:-1], edges[1:])), speeds


def _per_contact_state(system, blocks, speeds, width, rows):
    """rows(i0, i1) (shape (i1 - i0, width)) over every block of
    :func:`_contact_blocks`, the contact state's impact speeds set to the
    block's while it is evaluated (and restored after)."""
    group = system.contact_state
    if speeds is None:
        i0, i1 = blocks[0]
        return rows(i0, i1)
    kept = group.impact_speed.copy()
    try:
        out = np.empty((blocks[-1][1], width))
        for i0, i1 in blocks:
            group.impact_speed[:] = speeds[i0]
            out[i0:i1] = rows(i0, i1)
        return out
    finally:
        group.impact_speed[:] = kept


def _index1_band(system):
    """(order, kd) of ``integrators.compiled.index1_multipliers_band`` for a
    model of rigid bodies (constant diagonal M): the reverse Cuthill-McKee
    order of the constraint rows on the pattern of Phi_q M^-1 Phi_q^T and its
    half-bandwidth kd there; None for flexible beams (M(q) is not diagonal:
    the dense index-1 matrix). Cached on the system."""
    if hasattr(system, "_index1_band_plan"):
        return system._index1_band_plan
    plan = None
    if system.mass_is_constant and system.m:
        import scipy.sparse
        from scipy.sparse.csgraph import reverse_cuthill_mckee
        rows, cols = system.pattern_Phi_q
        B = scipy.sparse.csr_matrix((np.ones(len(rows)), (rows, cols)),
                                    shape=(system.m, system.n))
        A = (B @ B.T).tocoo()
        order = np.asarray(reverse_cuthill_mckee(A.tocsr(), symmetric_mode=True), np.int64)
        place = np.empty(system.m, np.int64)
        place[order] = np.arange(system.m)
        kd = int(np.max(np.abs(place[A.row] - place[A.col]), initial=0))
        plan = (order, kd)
    system._index1_band_plan = plan
    return plan


def index1_band_vector(system) -> np.ndarray:
    """The band plan of :func:`_index1_band` as the compiled loop reads it
    (``compiled.index1._index1_scratch``): int64 (m + 1,), the constraint
    rows' reverse Cuthill-McKee order then the half-bandwidth kd; empty for
    flexible beams (no plan: the dense index-1 solve)."""
    plan = _index1_band(system)
    if plan is None:
        return np.empty(0, np.int64)
    order, kd = plan
    return np.append(order, kd).astype(np.int64)


def recipe(method, h, first):
    """The method's recipe at step size h [s] (``first``: a start-up step),
    with its constraint formulation: ``reg`` = epsilon of the augmented
    formulation (``Method.formulated``), 0 for Lagrange."""
    from .recipe import RECIPE_FIELDS
    rec = method.kernel_recipe(h, first)
    rec[RECIPE_FIELDS.index("reg")] = getattr(method, "regularization", 0.0)
    return rec


_MONOMIALS: dict = {}


def recipe_monomials(method):
    """(2, 5, len(RECIPE_FIELDS)): the method's recipe for a start-up step
    (0) and the steps after it (1) as monomials c h^a c0^b w0^c w1^d in the
    step size h and a two-step method's coefficients c0, w0, w1 (rows: c, a,
    b, c, d; ``Method.kernel_recipe_at``), which the error-controlled compiled
    loop evaluates at every step (``integrators.compiled.loop._recipe_at``); None for a recipe
    that is not of that form."""
    # a pure function of the method's class and parameters (all scalars), kept
    # per parameter set: fitted from 13 recipes, 0.2 ms of every integrate call
    key = (type(method), tuple(sorted(vars(method).items())))
    try:
        if key not in _MONOMIALS:
            _MONOMIALS[key] = _fit_monomials(method)
        mono = _MONOMIALS[key]
    except TypeError:                         # a parameter that is not a scalar: not kept
        mono = _fit_monomials(method)
    return None if mono is None else mono.copy()


def _fit_monomials(method):
    """``recipe_monomials`` fitted from the method's recipes."""
    from .recipe import RECIPE_FIELDS
    reg = RECIPE_FIELDS.index("reg")

    def at(first, *x):
        """The recipe at (h, c0, w0, w1), with the formulation's epsilon."""
        rec = method.kernel_recipe_at(x[0], first, x[1], x[2], x[3])
        rec[reg] = getattr(method, "regularization", 0.0)
        return rec

    out = []
    for first in (True, False):
        base = at(first, 1.0, 1.0, 1.0, 1.0)
        powers = []
        for j in range(4):
            x = [1.0, 1.0, 1.0, 1.0]
            x[j] = 2.0
            r = at(first, *x)
            if np.any(r[base == 0.0] != 0.0):
                return None
            k = np.zeros_like(base)
            nz = base != 0.0
            k[nz] = np.round(np.log2(np.abs(r[nz] / base[nz])))
            powers.append(k)
        mono = np.stack([base] + powers)
        x = np.array([0.37, 1.9, 1.3, -0.41])     # a check away from the fitting points
        value = mono[0] * np.prod(x[:, None] ** mono[1:], axis=0)
        if not np.allclose(value, at(first, *x), rtol=1e-12, atol=0.0):
            return None
        out.append(mono)
    return np.stack(out)


def solver_code(K, plan) -> int:
    """The kernels' code (``integrators.compiled.linalg``) of the linear
    solver of ``plan``: DENSE, DENSE_SPLIT (two blocks' inverses), BANDED
    or CONDENSED."""
    if plan.kind == "dense":
        return K.DENSE_SPLIT if plan.blocks == 2 else K.DENSE
    return K.CONDENSED if plan.kind == "condensed" else K.BANDED


def newton_matrix_cost(plan, size, system, method) -> int:
    """The cost class of a Newton matrix for ``NewtonOptions.refresh_rate``:
    0 when a new one costs about as much as a few iterations, 1 when its
    factorization costs many (``LinearSolverPlan.factorization_is_expensive``),
    2 for the additive form (HHT-ADD) on flexible beams, whose matrix holds
    M_b(q)^-1 times every column of the beams' rows: on the flexible slider
    crank one costs 180 us against 10 us per iteration, and refreshing it
    only where the iteration stalls (rate 0.5) took 0.21 instead of 0.36
    matrices per step at the same 3.98 iterations (128 -> 111 us per step).
    Its first corrections of the beams' accelerations shrink by 0.4-0.6 from
    an earlier step's matrix, so the stall rule at 1/2 still renewed it in
    most steps of a longer run; at 0.8 (``NewtonOptions.refresh_rate``, the
    stall rule's ratio above 1/2), over 1 s: 0.44 -> 0.20 matrices and 3.90
    -> 4.08 iterations per step, 162 -> 118-122 us per step, q within
    1.5e-12 of full Newton's as before.
    """
    from .recipe import ADDITIVE
    if system.beam_sets and _recipe_value(method, "form") == ADDITIVE:
        return 2
    return int(plan.factorization_is_expensive(size))


def ratio_recipe(method, h, spacing):
    """The recipe of a two-step method's step of size h [s] after one of
    length ``spacing`` [s]: BDF2 with the coefficients of the step ratio
    (``common.bdf_ratio_coefficients``), with the constraint formulation's
    ``reg`` as in :func:`recipe`."""
    from .common import bdf_ratio_coefficients
    from .recipe import RECIPE_FIELDS
    rec = method.kernel_recipe_at(h, False, *bdf_ratio_coefficients(h, spacing))
    rec[RECIPE_FIELDS.index("reg")] = getattr(method, "regularization", 0.0)
    return rec


def step_recipe(method, history, h):
    """(recipe, first) of the step of size h [s] after ``history`` (a list of
    StepState): the start-up recipe, the steady one, or for a two-step
    method whose last two states are not h apart :func:`ratio_recipe`."""
    first = method.first_step(history, h)
    if not first and method.history_length > 1 and len(history) >= 2:
        spacing = history[-1].t - history[-2].t
        if abs(spacing - h) > 1e-9 * h:
            return ratio_recipe(method, h, spacing), first
    return recipe(method, h, first), first


def select_engine(engine: str, system, method, compile_policy: str = "wait",
                  announce=None) -> str:
    """'numpy', 'compiled' or 'uncompiled' for a requested engine.

    "uncompiled" is taken only when asked for: the compiled engine's kernels
    and loops run by the interpreter (:func:`.kernel_cache.uncompiled_kernels`),
    for debugging them.

    ``compile_policy`` "background" (with ``engine="auto"``): when the
    kernels are not built for this machine yet, start building them in a
    detached process (:mod:`.kernel_cache`) and choose 'uncompiled' for this
    run (the same kernels and loops, run by the interpreter; per step about
    as fast as the numpy engine with its joints on the uncompiled kernels,
    twice as fast on the slider crank: ``benchmarks/engines.py``), telling
    ``announce``; the run goes on compiled once the build is done
    (``driver.KernelUpgrade``).

    Raises
    ------
    ValueError
        Unknown engine name or compile policy, or ``"compiled"`` or
        ``"uncompiled"`` for a model or method the kernels do not cover (the
        message says why), or without numba.
    """
    if engine not in ENGINES:
        raise ValueError(f"unknown engine '{engine}'; available: {', '.join(ENGINES)}")
    if compile_policy not in ("wait", "background"):
        raise ValueError(f"compile_policy must be 'wait' or 'background', got {compile_policy!r}")
    if engine == "numpy":
        return "numpy"
    reason = unsupported(system, method)
    if reason is None and not numba_available():
        reason = "numba is not installed"
    if reason is not None:
        if engine in ("compiled", "uncompiled"):
            raise ValueError(f"the {engine} engine cannot run this model: {reason}")
        return "numpy"
    if engine == "uncompiled":
        return "uncompiled"
    if engine == "auto" and compile_policy == "background":
        from .kernel_cache import kernels_ready, start_background_build
        if not kernels_ready() and start_background_build():
            if announce is not None:
                announce("the compiled kernels are being built for this machine in the "
                         "background (once, about three minutes); this run starts on the "
                         "uncompiled kernels and goes on compiled once they are built")
            return "uncompiled"
    return "compiled"


def run_model(system, uncompiled: bool = False) -> "CompiledModel":
    """The system's model data for one run (or one evaluation that writes
    the run state, as the multipliers' contact blocks do): a copy
    (``PackedModel.fresh``) of the packing kept on the system, made once
    per system and kind of kernels."""
    templates = system.__dict__.setdefault("_run_models", {})
    if uncompiled not in templates:
        templates[uncompiled] = CompiledModel(system, _kernels(uncompiled=True) if uncompiled
                                              else None)
    return templates[uncompiled].fresh()


def copy_run_state(cm, source) -> None:
    """The run state of ``source`` (the same system's model data on the other
    kernels: compiled or uncompiled) into ``cm``: the packed floats, which
    hold it (the contacts' impact speeds, the springs' held directions)
    beside the model's constants.

    Raises
    ------
    RuntimeError
        The two kernels pack the model differently (they are one source:
        a bug).
    """
    if (cm.ints.shape != source.ints.shape or not np.array_equal(cm.ints, source.ints)
            or cm.floats.shape != source.floats.shape):
        raise RuntimeError("the compiled and the uncompiled kernels pack this model differently")
    cm.floats[:] = source.floats


def prepare_compiled(system, method, options, q, announce=None, python_loop=False,
                     uncompiled=False):
    """(CompiledModel, LinearSolverPlan, seconds): the kernels' model data and
    linear solver for a run from configuration q (n,), with every kernel the
    run calls loaded (compiled first, announced, if not built for this
    machine; ``python_loop``: the Python stepper on the kernels' residual and
    Newton matrix, ``SparseAdapter``; ``uncompiled``: the kernels run by the
    interpreter, nothing compiled or loaded); the seconds are the time this
    took, never step time."""
    import time
    from .kernel_cache import ensure_loaded
    t0 = time.perf_counter()
    if not uncompiled:
        ensure_loaded(None, announce)         # compiles everything, announced, if not built
    cm = run_model(system, uncompiled)        # the run's own copy: its events write into it
    plan = linear_solver_plan(system, method, options, q, cm)  # banded: calls a kernel
    if not uncompiled:                        # this loop's entry points
        ensure_loaded("sparse" if python_loop else
                      {"condensed": "banded"}.get(plan.kind, plan.kind), announce)
    return cm, plan, time.perf_counter() - t0


# ---------------------------------------------------------------------------------------------
# The compiled time loop (small systems)
# ---------------------------------------------------------------------------------------------

class KernelStepper:
    """The compiled loop (``integrators.compiled.run``) as a stepper of ``loop.TimeLoop``:
    up to CHUNK steps in one call, its own Newton iteration with the linear
    solver of ``plan`` ("dense": explicit inverse; "banded": LAPACK's band
    LU), recording into the loop's buffers.

    Parameters
    ----------
    system : AssembledSystem
    method : Method
        With a recipe the loop can evaluate at any step.
    mono : ndarray, shape (2, 5, len(RECIPE_FIELDS))
        That recipe as monomials in the step (``recipe_monomials``, found
        once per run by the driver: half a millisecond, a run of 200 steps'
        2 to 5 us a step).
    cm : CompiledModel
    plan : LinearSolverPlan
    options : NewtonOptions
    initial : InitialState
        The run's start (its forces, ``InitialState.Q``, for the first step).
    h : float [s]
        The nominal or first step.
    index1 : bool
        Error control estimates on the index-1 accelerations (``StepControl.index1``
        and ``Method.estimate_on_index1``): the loop gets the band plan of
        their Schur complement (:func:`index1_band_vector`).
    """

    def __init__(self, system, method, mono, cm, plan, options, initial, h, index1=False):
        self.system, self.method, self.cm, self.plan, self.opt = system, method, cm, plan, options
        self.K = cm.K
        self.mono = mono
        self.size = size = newton_size(system, method)
        cost = newton_matrix_cost(plan, size, system, method)
        # the extrapolated start, except where a Newton matrix costs about ten
        # iterations (HHT-ADD on flexible beams): from there the first corrections
        # shrank less, the stall rule renewed the matrix in 0.46 steps of every one
        # instead of 0.085, and a step took 131 us instead of 94 (flexible slider crank)
        self.opts = vector(
            OPTION_FIELDS, rtol=options.rtol, atol_kinematic=options.atol_kinematic,
            atol_multiplier=options.atol_multiplier, max_iter=options.max_iter,
            refresh=options.refresh_rate(cost),
            full=1.0 if options.jacobian.value == "full" else 0.0,
            extrapolate=1.0 if options.start == "extrapolated" and cost < 2 else 0.0)
        self.solver = solver_code(cm.K, plan)
        self.lin = plan.workspace(size, cm.bound)
        self.lu_state = vector(LU_FIELDS, valid=0.0, rate=0.5, step=0.0, c0=0.0)
        self.R, self.C = np.empty(cm.bound, np.int64), np.empty(cm.bound, np.int64)
        self.V = np.empty(cm.bound)
        n = system.n
        # the Newton scratch, lent to every call of the loop, which sizes its
        # unknowns from the recipe (``compiled.layout``): the two must agree,
        # as the loop writes without bounds checks
        if cm.K.layout(mono[1][0].copy(), n, system.m)[0] != size:
            raise RuntimeError(f"{method.name}: the compiled loop's unknowns differ from "
                               f"newton_size ({size})")
        # error control's index-1 accelerations on the band Schur complement
        band = index1_band_vector(system) if index1 else np.empty(0, np.int64)
        self.ws = cm.K.workspace(n, system.m, size, cm.ints, band)
        # F_n of the first step when the start's forces are not the law's at
        # (q, v, lambda) (friction's Coulomb limit at rest, InitialState.Q); NaN: the
        # kernels compute it
        self.no_F = np.full(n, np.nan)
        self.F_start = self.no_F
        if getattr(initial, "Q", None) is not None:
            from .common import start_force_term
            from .recipe import ADDITIVE, RECIPE_FIELDS
            additive = method.kernel_recipe(h, True)[RECIPE_FIELDS.index("form")] == ADDITIVE
            self.F_start = (-system.mass_solve(initial.q, initial.Q) if additive
                            else start_force_term(system, initial))

    def resync(self):
        """The loop's state was changed by another (the fallback, a restart at
        a switch): the next call starts a new Newton matrix, as every call
        does."""

    def events_changed(self, loop):
        """The contacts' impact speeds and the springs' held directions (set by
        the event locator) into the kernels' data."""
        group = self.system.contact_state
        if group is not None:
            self.cm.impact_speed[:] = group.impact_speed
        if self.system.flipping_springs is not None:
            self.cm.spring_held[:] = self.system.spring_held

    def forget_crossing(self):
        """Nothing kept: the compiled loop solves every step it is asked for."""

    def newton_failed(self, loop):
        """A fixed step Newton did not converge: HHT-SI2's split Newton
        matrix (two blocks, band, condensed or dense) leaves out O(h) terms;
        where they matter (stiff forces, fast rotation), go on with the whole
        band matrix (the whole matrix's inverse after the dense blocks')."""
        plan = self.plan
        if plan.blocks != 2:
            return
        system, method, size = self.system, self.method, self.size
        if plan.kind == "dense":
            why = f"{plan.why}; whole matrix's inverse after a failed step at t = {loop.t:.6g} s"
            plan = self.plan = LinearSolverPlan("dense", f"explicit inverse ({size} unknowns)")
        else:                                    # from the condensed solver too
            why = f"{plan.why}; whole band matrix after a failed step at t = {loop.t:.6g} s"
            plan = self.plan = band_plan(system, method, loop.ls.q, False, plan.addresses,
                                         self.cm)
        plan.why = why
        self.solver = solver_code(self.K, plan)
        self.lin = plan.workspace(size, self.cm.bound)
        cost = newton_matrix_cost(plan, size, system, method)
        self.opts[OPT_REFRESH] = self.opt.refresh_rate(cost)
        loop.sol.linear_solver_note = plan.why

    def advance(self, loop, mode, h, limit):
        """One call of the compiled loop from the loop's state (in ``mode``,
        first step h [s], at most ``limit`` steps, 0: no limit), with a new
        Newton matrix (between calls an event may have changed the contact
        law, a switch the branch, the fallback the state); returns (status,
        steps taken)."""
        ls, state = loop.ls, loop.state
        self.lu_state[LU_VALID] = 0.0
        status, taken, nrec = self.K.run(
            self.mono, self.cm.ints, self.cm.floats, h, loop.t, loop.seg_end, loop.step_no,
            loop.every, ls.q, ls.v, ls.a, ls.b, ls.lam, ls.mu, ls.q_prev, ls.v_prev, loop.ctl,
            self.opts, self.solver, self.lin, self.lu_state, self.R, self.C, self.V,
            *ls.outputs(), ls.counts, self.F_start if loop.step_no == 0 else self.no_F, state,
            loop.trial, self.ws)
        ls.buffered += nrec
        return status, taken


# ---------------------------------------------------------------------------------------------
# Large systems: compiled evaluation, Python Newton with SuperLU
# ---------------------------------------------------------------------------------------------

class SparseAdapter:
    """A recipe method whose residual, Newton matrix, scales and force term
    are evaluated by the kernels; everything else is the wrapped method's:
    the Python stepper (``python_stepper.PythonStepper``) on the compiled evaluation
    (large models, for SuperLU; the compiled loop's fallback; a recipe the
    compiled loop cannot evaluate at a step size). The Newton matrix is a
    CSC matrix on a pattern fixed at the first evaluation (values refilled
    in place), or with ``dense`` its ndarray. The contacts' impact speeds
    (the state the time loop's events change) are copied into
    the kernels' model data at each step's context."""

    def __init__(self, system, method, cm=None, dense=False):
        from .recipe import RECIPE_FIELDS
        self._method = method
        self._system = system
        self._cm = cm or CompiledModel(system)
        self._K = self._cm.K
        self._dense = bool(dense)
        self._field = {k: i for i, k in enumerate(RECIPE_FIELDS)}
        n = system.n
        self.size = newton_size(system, method)
        self._R = np.empty(self._cm.bound, np.int64)
        self._C = np.empty(self._cm.bound, np.int64)
        self._V = np.empty(self._cm.bound)
        # the residual's scratch has two halves (``compiled.recipes._residual``)
        self._qx, self._vx, self._work = np.zeros(n + 3), np.zeros(n + 3), np.zeros(2 * (n + 3))
        self._pattern = None

    def __getattr__(self, name):          # name, extras, blocks, start, predict, describe...
        return getattr(self._method, name)

    @property
    def cm(self):
        """The model data the kernels evaluate (``CompiledModel``)."""
        return self._cm

    def use_kernels(self, cm):
        """Evaluate on the model data ``cm`` and its kernels from now on (a
        run of the uncompiled kernels going on compiled: the same packing,
        so the same triplet bound, its run state copied by the caller,
        ``copy_run_state``)."""
        self._cm, self._K = cm, cm.K

    def _get(self, rec, name):
        return rec[self._field[name]]

    def context(self, system, history, t, h):
        """The wrapped method's context, with the recipe of this step and its
        predictors (``integrators.compiled.loop._run``) for the kernels."""
        ctx = self._method.context(system, history, t, h)
        if system.contact_state is not None:
            self._cm.impact_speed[:] = system.contact_state.impact_speed
        if system.flipping_springs is not None:
            self._cm.spring_held[:] = system.spring_held
        rec, first = step_recipe(self._method, history, h)
        s = history[-1]
        p = history[-2] if len(history) >= 2 else s
        q_pred, v_pred = np.empty(system.n), np.empty(system.n)
        b = s.extra.get("aux")
        b = np.zeros(system.n) if b is None else b
        self._K.predict(rec, first, s.q, s.v, s.a, b, p.q, p.v, q_pred, v_pred)
        F = np.empty(system.n)
        self._K.old_force(rec, self._cm.ints, self._cm.floats, s.t, s.q, s.v, s.lam, F, self._qx,
                          self._vx, self._work[:system.n + 3])
        qx_old = np.zeros(system.n + 3)          # q_n, or Mhat's q_n + mh v_n
        qx_old[:system.n] = s.q + self._get(rec, "mh") * s.v
        ctx.cache.update(recipe=rec, kq_pred=q_pred, kv_pred=v_pred, kF=F, kqx_old=qx_old,
                         kb=b, ka=s.a)
        return ctx

    def residual(self, w, ctx):
        """Upsilon(w) by the kernel."""
        r = np.empty(self.size)
        c = ctx.cache
        self._K.residual(c["recipe"], self._cm.ints, self._cm.floats, ctx.t, c["kq_pred"],
                         c["kv_pred"], c["kF"], c["kqx_old"], w, r, self._qx, self._vx,
                         self._work)
        return r

    def jacobian(self, w, ctx):
        """The Newton matrix on the fixed pattern: CSC, or its ndarray (``dense``)."""
        K, c = self._K, ctx.cache
        p = K.jacobian_triplets(c["recipe"], self._cm.ints, self._cm.floats, ctx.t, c["kq_pred"],
                                c["kv_pred"], c["kF"], c["kqx_old"], w, self._R, self._C, self._V,
                                self._qx, self._vx)
        if self._pattern is None or self._pattern[0] != p:
            key = self._C[:p] * self.size + self._R[:p]
            uniq, position = np.unique(key, return_inverse=True)
            indptr = np.searchsorted(uniq // self.size, np.arange(self.size + 1))
            self._pattern = (p, position.astype(np.int64), (uniq % self.size).astype(np.int32),
                             indptr.astype(np.int32), len(uniq))
        _, position, indices, indptr, nnz = self._pattern
        data = np.empty(nnz)
        K.accumulate(self._V, p, position, data)
        J = scipy.sparse.csc_matrix((data, indices, indptr), shape=(self.size, self.size))
        return J.toarray() if self._dense else J

    def scales(self, system, h, q):
        """The recipe's scales (as the wrapped method's), with the mobility
        from the kernel."""
        from .recipe import ADDITIVE
        m, n = system.m, system.n
        mob = np.empty(m)
        self._K.mobility(self._cm.ints, self._cm.floats, q, mob, self._R, self._C, self._V,
                         self._qx)
        rec, g = self._method.kernel_recipe(h, False), self._get
        sx, sy = g(rec, "sx"), g(rec, "sy")
        if g(rec, "form") == ADDITIVE:
            sm = g(rec, "sm") * mob
            return np.concatenate([np.full(2 * n, sx), np.full(n, sy), sm, sm])
        if g(rec, "has_y") == 0.0:
            return np.concatenate([np.full(n, sx), sx * mob])
        smu = sy * mob if g(rec, "mu_mob") != 0.0 else np.full(m, sy)
        return np.concatenate([np.full(n, sx), np.full(n, sy), sx * mob, smu])

    def accept(self, w, ctx):
        """The state of the converged w by the recipe (``integrators.compiled.loop._run``)."""
        n, m = self._system.n, self._system.m
        rec = ctx.cache["recipe"]
        qx, vx = np.zeros(n + 3), np.zeros(n + 3)
        self._K.state(rec, n, w, ctx.cache["kq_pred"], ctx.cache["kv_pred"], qx, vx)
        size, l0, e0, a0 = self._K.layout(rec, n, m)
        s = StepState(ctx.t, qx[:n].copy(), vx[:n].copy(), w[a0:a0 + n].copy(),
                      w[l0:l0 + m].copy())
        if self._method.extras:         # mu, psi1: empty blocks on a model without joints
            s.extra[self._method.extras[0]] = w[e0:e0 + m].copy()
        if "aux" in ctx.last.extra:
            b = np.array(ctx.cache["kb"], dtype=float)
            self._K.advance(rec, b, ctx.cache["ka"], w[a0:a0 + n])
            s.extra["aux"] = b
        return s
