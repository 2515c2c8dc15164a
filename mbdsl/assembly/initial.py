"""Consistent initial conditions: q0, v0, then (a0, lambda0).

1. **Placement.** Bodies are placed along a breadth-first spanning tree of the
   joint graph from the ground (``model.graph``): each body takes its angle
   from an ``initial``/``guess`` line or a driver's value at t0 (else its
   parent's angle for fixed and prismatic joints, else 0) and is translated
   so that the tree joint's two points coincide. The user never computes
   dependent positions by hand.
2. **Closure.** Gauss-Newton with minimum-norm steps on
   [Phi(q, t0); q_fixed - values] = 0 closes the loops, moving the
   coordinates the user did not fix as little as possible from the placement.
   Flexible beams start undeformed; their elastic coordinates are weighted
   so that they change only where the loops cannot close otherwise
   (``ELASTIC_WEIGHT``).
3. **Velocities.** The minimum-norm change of the given velocities (0 where
   none is given) that satisfies Phi_q v + Phi_t = 0 with the fixed ones
   kept, elastic rates weighted the same way.
4. **Accelerations and multipliers** from the index-1 system
   [[M, Phi_q^T], [Phi_q, 0]] [a0; lambda0] = [Q; gamma].

Source: Haug, Computer-Aided Kinematics and Dynamics of Mechanical Systems,
sec. 3.6 (assembly) and 6.3 (initial conditions); ``methods.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import warnings

import numpy as np
import scipy

from ..gcpause import paused
from ..errors import AssemblyError, Diagnostic
from . import ffr
from .sparse import DENSE_LIMIT, issparse
from .structure import (RANK_LIMIT, StructureReport, analyse_structure,
                        friction_on_redundant_joints, joint_miss, miss_diagnosis,
                        redundancy_diagnostics)
from ..model.spatial import DIRECTORS
from .placement import place_bodies
from .system import AssembledSystem

__all__ = ["InitialState", "consistent_initial_state", "place_bodies"]


@dataclass
class InitialState:
    """A consistent initial state and how it was found.

    Attributes
    ----------
    t : float [s]
    q, v, a : ndarray, shape (n,)
    lam : ndarray, shape (m,)
    position_residual, velocity_residual, acceleration_residual : float
        max |Phi|, max |Phi_q v + Phi_t|, max |Phi_q a - gamma| at the end.
    solved : dict of str -> float
        Coordinates the assembly computed (not fixed by ``initial``), with
        their values.
    iterations : int
        Newton iterations of the closure.
    structure : StructureReport or None
        DOF by count and by rank at q (None above ``RANK_LIMIT`` rows).
    warnings : list of Diagnostic
        E.g. W402, a mechanism that cannot move.
    method_state : dict
        Values a method carries between steps, when a run resumes from an
        accepted step rather than from t_0: generalized-alpha's ``aux``
        (ndarray, shape (n,)), and ``previous``, the accepted state before
        (a StepState whose t, q and v a two-step method reads, or None);
        empty for a start.
    Q : ndarray, shape (n,), or None
        The applied forces a_0 and lambda_0 were solved with, when they are
        not Q(t_0, q_0, v_0, lambda_0): a friction joint at rest starts from
        the Coulomb limit (:func:`coulomb_start`); None otherwise.
    placements : list of str
        How the start of the assembly placed the far body of each distance
        joint it met (:func:`place_bodies`), for the "solved for" line.
    """

    t: float
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    position_residual: float
    velocity_residual: float
    acceleration_residual: float
    solved: dict = field(default_factory=dict)
    iterations: int = 0
    structure: StructureReport | None = None
    warnings: list = field(default_factory=list)
    method_state: dict = field(default_factory=dict)
    Q: np.ndarray | None = None
    placements: list = field(default_factory=list)

    #: At most this many solved coordinates are listed in :meth:`report`.
    REPORT_COORDINATES = 10

    def report(self) -> str:
        """A few lines for the CLI summary: the residuals, and the coordinates
        the assembly solved for (at most ``REPORT_COORDINATES``, then "and N
        more"; a value below 1e-12 of the model's length scale, or 1e-12 rad,
        printed as 0: the round-off of a coordinate that is zero)."""
        it = self.iterations
        lines = [f"initial conditions: |Phi| = {self.position_residual:.1e}, "
                 f"|Phi_q v + Phi_t| = {self.velocity_residual:.1e}, "
                 f"|Phi_q a - gamma| = {self.acceleration_residual:.1e} "
                 f"({it} Newton iteration{'' if it == 1 else 's'})"]
        if self.solved:
            lengths = [abs(v) for k, v in self.solved.items() if k.endswith((".x", ".y"))]
            scale = max(lengths, default=0.0)

            def shown(k, v):
                """v, or 0 when it is round-off of a zero coordinate."""
                small = 1e-12 * (scale if k.endswith((".x", ".y")) else 1.0)
                return 0.0 if abs(v) < small else v

            items = list(self.solved.items())
            text = ", ".join(f"{k} = {shown(k, v):.6g}" for k, v in items[:self.REPORT_COORDINATES])
            if len(items) > self.REPORT_COORDINATES:
                text += f", and {len(items) - self.REPORT_COORDINATES} more"
            if self.placements:
                text += " (" + "; ".join(self.placements) + "; a 'guess' picks another start)"
            lines.append("  solved for: " + text)
        return "\n".join(lines)


def _min_norm_step(J, r):
    """Minimum-norm solution of J x = r (J has full row rank or is small).

    Dense: LAPACK least squares (rank-revealing, any J). Sparse (large
    models): x = J^T (J J^T)^{-1} r with SuperLU, falling back to the dense
    solve when J J^T is singular (redundant constraints).
    """
    if issparse(J):
        JJ = (J @ J.T).tocsc()
        # redundant rows make J J^T singular: a tiny diagonal shift keeps the
        # step the minimum-norm one to round-off (consistent rows) without a
        # dense least-squares solve of a large matrix
        for shift in (0.0, 1e-12 * max(abs(JJ).max(), 1e-300)):
            try:
                A = JJ if shift == 0.0 else (JJ + shift * scipy.sparse.identity(JJ.shape[0])).tocsc()
                y = scipy.sparse.linalg.splu(A).solve(r)
                if np.all(np.isfinite(y)):
                    return J.T @ y
            except RuntimeError:
                pass
        J = J.toarray()
    return np.linalg.lstsq(J, r, rcond=None)[0]


#: Column weight of the elastic coordinates of flexible beams in the
#: minimum-norm closure and velocity projection: a change of an elastic
#: coordinate costs (1/ELASTIC_WEIGHT)^2 times a change of a reference
#: coordinate, so the loops close by moving the bodies, and the beams deform
#: only where the geometry leaves no other way (a beam forced between two
#: points further apart than its length).
ELASTIC_WEIGHT = 1e-3


def _column_weights(system) -> np.ndarray:
    """Weights W of the minimum-norm steps, shape (n,): 1, or ELASTIC_WEIGHT."""
    w = np.ones(system.n)
    for b in system.model.flexible_bodies:
        w[b.elastic_columns()] = ELASTIC_WEIGHT
    return w


def _weighted_step(J, r, w):
    """min ||dq / w|| subject to J dq = r: dq = w * minnorm(J diag(w), r)."""
    if issparse(J):
        Jw = J @ scipy.sparse.diags(w)
    else:
        Jw = J * w[None, :]
    return w * _min_norm_step(Jw, r)


def _selection(columns, n: int, sparse: bool):
    """The rows of the n x n identity at ``columns`` (k,): E with E q =
    q[columns], shape (k, n), dense or (``sparse``, large models) CSR: a
    chain of 10 000 links fixes 10 000 angles among 30 000 coordinates, and
    its dense E would take 2.4 GB."""
    k = len(columns)
    if sparse:
        return scipy.sparse.csr_matrix((np.ones(k), (np.arange(k), columns)), shape=(k, n))
    E = np.zeros((k, n))
    E[np.arange(k), columns] = 1.0
    return E


def _stacked_jacobian(system, q, t, E, sparse):
    """[Phi_q; E] (E selects the coordinates the user fixed, ``_selection``),
    dense or CSR."""
    if not sparse:
        return np.vstack([system.Phi_q(q, t), E])
    rows, cols = system.pattern_Phi_q
    Pq = scipy.sparse.csr_matrix((system.Phi_q_values(q, t), (rows, cols)),
                                 shape=(system.m, system.n))
    return scipy.sparse.vstack([Pq, scipy.sparse.csr_matrix(E)]).tocsr()


#: Iterations allowed for the quasi-static start of flexible beams.
QUASI_STATIC_ITERATIONS = 50


@paused
def consistent_initial_state(system: AssembledSystem, t0: float = 0.0,
                             tol: float = 1e-12, max_iter: int = 50,
                             redundant: str = "error") -> InitialState:
    """Find q0, v0, a0, lambda0 consistent with all constraint levels.

    With flexible beams the elastic coordinates start at their quasi-static
    values: the deflection under the initial loads (gravity, the inertia of
    the initial motion, the joint forces) with elastic accelerations zero.
    A beam started undeformed instead vibrates at its (unresolved, for the
    usual step sizes) natural frequencies, which the methods damp
    differently and which would dominate every comparison of them. The
    Newton-like update q_f <- q_f + K^{-1} G^{-1} a_f (K the stiffness,
    a_f the elastic accelerations of the index-1 solution, G the elastic
    block of the index-1 matrix's inverse) is iterated with the whole state
    made consistent at each step, until the update is at round-off (dense:
    meant for models of a few hundred coordinates). The elastic rates start at 0. (A static
    correction, as in Shabana, Dynamics of Multibody Systems, sec. 5.7, on
    the initial conditions of deformable bodies.)

    Parameters
    ----------
    system : AssembledSystem
    t0 : float [s]
    tol : float
        Largest acceptable max |Phi| [m, rad] at the end (the iteration
        itself runs until its correction is at round-off).
    max_iter : int
        Newton iterations allowed for closing the loops.
    redundant : {"error", "accept"}
        Redundant joints (rows of Phi_q dependent on others at the assembled
        configuration, consistently): E401 ("error"), or W405 warnings naming
        them and a start whose accelerations and multipliers are the
        minimum-norm solution of the singular index-1 system ("accept", for
        the augmented formulation; the multipliers of dependent rows are not
        unique).

    Returns
    -------
    InitialState

    Raises
    ------
    AssemblyError
        E503 when the loops cannot be closed (naming the joint with the
        largest residual, in metres or radians), E504 when the given
        velocities contradict the constraints, E505 when the index-1 matrix
        is singular (redundant constraints or a singular position).
    """
    if redundant not in ("error", "accept"):
        raise ValueError(f"redundant must be 'error' or 'accept', got {redundant!r}")
    state = _consistent_state(system, t0, tol, max_iter, None, redundant=redundant)
    if system.model.static:
        dependent = state.structure.dependent if state.structure is not None else ()
        q = static_positions(system, t0, state.q, state.lam, dependent=dependent)
        return _consistent_state(system, t0, tol, max_iter, None, q_start=q,
                                 redundant=redundant)
    if not system.beam_sets:
        return state
    state, settled = _quasi_static(system, state, t0, tol, max_iter)
    if settled:
        _large_deflections(system, state)
    return state


def _quasi_static(system, state, t0, tol, max_iter):
    """The consistent state whose flexible beams start quasi-statically
    deflected (their elastic accelerations at round-off): Newton on the
    elastic coordinates, each step halved until it reduces them. Returns
    (the state reached, whether it settled); W403 (``_not_quasi_static``) in
    its warnings when it did not."""
    cols = np.concatenate([b.elastic_columns() for b in system.model.flexible_bodies])
    def tangent(q):
        """The beams' elastic stiffness at q (with geometric stiffening: its tangent)."""
        qx = np.concatenate([q, np.zeros(3)])
        cm = system.kernel_model()
        return scipy.linalg.block_diag(*[Kb for s in system.beam_sets
                                         for Kb in ffr.tangent_stiffness(cm, s, qx)])
    def elastic_acceleration(st):
        """Largest elastic acceleration of a state (0 when quasi-static)."""
        return float(np.max(np.abs(st.a[cols])))

    n, m = system.n, system.m
    # an elastic acceleration at round-off is quasi-static already (an unloaded
    # beam at rest), and so is one ten orders below where it started (a
    # spinning beam: 2e-10 m/s^2 left of 1e2 is the round-off of its loads):
    # nothing to iterate, nothing to warn about
    start = elastic_acceleration(state)

    def settled(st):
        """Whether the elastic accelerations are at round-off of the motion's."""
        return elastic_acceleration(st) <= max(1e-12 * (1.0 + float(np.max(np.abs(st.a)))),
                                               1e-10 * start)
    for _ in range(QUASI_STATIC_ITERATIONS):
        if settled(state):
            break
        # a_f responds to elastic forces F_f as a_f = G F_f, G the elastic block
        # of the index-1 matrix's inverse (the constrained system's inverse
        # mass); the elastic force of a deflection change d is -K d, so
        # a_f(q_f + d) ~ a_f - G K d = 0 gives d = K^{-1} G^{-1} a_f.
        unit = np.zeros((n + m, len(cols)))
        unit[cols, np.arange(len(cols))] = 1.0
        step = np.zeros(n)
        try:
            G = np.linalg.solve(_index1_matrix(system, state.q, t0), unit)[cols]
            step[cols] = np.linalg.solve(tangent(state.q),
                                         np.linalg.lstsq(G, state.a[cols], rcond=1e-12)[0])
        except np.linalg.LinAlgError:
            step[:] = np.nan
        if not np.all(np.isfinite(step)):
            state.warnings.append(_not_quasi_static(system, elastic_acceleration(state)))
            return state, False
        for _ in range(12):          # halve a step that does not reduce a_f
            try:
                trial = _consistent_state(system, t0, tol, max_iter, state.q + step)
            except AssemblyError:
                trial = None
            if trial is not None and elastic_acceleration(trial) < elastic_acceleration(state):
                break
            step *= 0.5
        else:
            if settled(state):
                break
            state.warnings.append(_not_quasi_static(system, elastic_acceleration(state)))
            return state, False
        state = trial
        if np.max(np.abs(step)) <= 1e-12 * (1e-9 + np.max(np.abs(state.q[cols]))):
            break
    else:
        state.warnings.append(_not_quasi_static(system, elastic_acceleration(state)))
        return state, False
    return state, True


def _large_deflections(system, state) -> None:
    """W403 on each beam that starts deflected beyond ``LARGE_DEFLECTION`` of
    its length (its linear elasticity no longer holds)."""
    for b in system.model.flexible_bodies:
        largest = b.mesh.max_translation(state.q[b.elastic_columns()])
        if largest > LARGE_DEFLECTION * b.length:
            state.warnings.append(Diagnostic(
                "warning", "W403", f"flexible beam '{b.name}' starts with a quasi-static deflection "
                f"of {largest:.3g} m, more than {LARGE_DEFLECTION:.0%} of its length "
                f"({b.length:g} m): its linear elasticity does not hold there", b.span,
                "deflects too much", hint="check E, the cross-section and the loads (SI units): "
                "the floating frame of reference assumes small elastic deflections"))


#: A quasi-static deflection above this fraction of a beam's length is reported (W403).
LARGE_DEFLECTION = 0.1


def _not_quasi_static(system, accel):
    """W403: the beams start where the iteration stopped, not quasi-statically."""
    beams = system.model.flexible_bodies
    return Diagnostic(
        "warning", "W403", f"the flexible beam{'s' if len(beams) > 1 else ''} "
        f"{', '.join(repr(b.name) for b in beams)} could not be started at "
        f"{'their' if len(beams) > 1 else 'its'} quasi-static "
        f"deflection (elastic accelerations up to {accel:.3g} remain): the beams will vibrate "
        "from t = 0", beams[0].span, "starts out of balance",
        hint="linear elasticity in the floating frame needs small deflections: check E, the "
             "cross-section and the loads, or use more elements")


#: Newton iterations of the static equilibrium.
STATIC_ITERATIONS = 50


#: Above this many unknowns (n + m) the static equilibrium's Newton matrix is
#: sparse (SuperLU): a 1000-link chain's (5000 unknowns) Newton step drops
#: from seconds (dense LU) to milliseconds.
STATIC_DENSE_LIMIT = 400
#: Gauss-Newton iterations of a retraction onto the constraints (``_retract``).
RETRACTION_ITERATIONS = 20


def _static_matrix(system, t0, q, v0, lam, E):
    """[[Q_q - (Phi_q^T lambda)_q, -Phi_q^T, -E^T], [Phi_q, 0, 0], [E, 0, 0]], dense."""
    n, m, f = system.n, system.m, E.shape[0]
    Qq = system.force_derivatives(t0, q, v0, lam)[0]
    K = (np.zeros((n, n)) if Qq is None else Qq) - system.PhiqT_lam_q(q, lam)
    Pq = system.Phi_q(q, t0)
    return np.block([[K, -Pq.T, -E.T], [Pq, np.zeros((m, m + f))],
                     [E, np.zeros((f, m + f))]])


def _static_matrix_sparse(system, t0, q, v0, lam, E):
    """The same matrix as scipy.sparse CSC, from the systems' sparsity patterns."""
    import scipy.sparse as sp
    n, m = system.n, system.m
    rows, cols = system.pattern_hessian
    K = -sp.csr_matrix((system.PhiqT_lam_q_values(q, lam), (rows, cols)), shape=(n, n))
    Qq = system.force_derivative_values(t0, q, v0, lam)[0]
    if Qq is not None:
        K = K + sp.csr_matrix((Qq, system.pattern_force), shape=(n, n))
    Pq = sp.csr_matrix((system.Phi_q_values(q, t0), system.pattern_Phi_q), shape=(m, n))
    Es = sp.csr_matrix(E)
    return sp.bmat([[K, -Pq.T, -Es.T], [Pq, None, None], [Es, None, None]], format="csc")


def _held_turns(system, q, hold_initials):
    """The rows that hold a spatial body's orientation, given by an
    ``initial`` line, in a static equilibrium: a_2 . a0_3, a_3 . a0_1 and
    a_1 . a0_2 at the given axes a0_k (their changes are the small
    rotation's components along a0_1, a0_2, a0_3: d a_k = d theta x a0_k).
    Three rows where holding the nine directors would make six of them
    redundant with the body's frame rows (``model.spatial``). Shape (3 k,
    n) for k such bodies; None without."""
    bodies = sorted({ic.body for ic in system.model.initials
                     if hold_initials and not ic.guess and ic.field in DIRECTORS})
    if not bodies:
        return None
    rows = np.zeros((3 * len(bodies), system.n))
    for k, b in enumerate(bodies):
        col = system.cmap.spatial[b]
        A0 = q[col + 3:col + 12].reshape(3, 3).T          # columns: the given axes a0_k
        for r, (i, j) in enumerate(((1, 2), (2, 0), (0, 1))):
            rows[3 * k + r, col + 3 + 3 * i:col + 6 + 3 * i] = A0[:, j]
    return rows


def _retract(system, t0, q, E, given, sparse) -> np.ndarray:
    """q brought back onto the constraints and the held values, Phi(q, t0) = 0
    and E q = given, by the least change (Gauss-Newton on the minimum-norm
    correction, C dq = c with C = [Phi_q; E]): the static Newton's step on a
    spatial model moves the directors along the tangent of the rotation, off
    their frame rows by about the square of the turn, and a step of half a
    radian then lands where the angles it reads no longer mean a turn (the
    retraction of Newton's method on a manifold: Absil, Mahony and
    Sepulchre, Optimization Algorithms on Matrix Manifolds, 2008, sec. 4.1).
    Returns the projected q (n,); q itself where it does not converge."""
    out = q.copy()
    for _ in range(RETRACTION_ITERATIONS):
        c = np.concatenate([system.Phi(out, t0), E @ out - given])
        if np.max(np.abs(c), initial=0.0) <= 1e-13 * (1.0 + np.max(np.abs(out))):
            return out
        Phi_q = system.Phi_q(out, t0)
        if sparse:
            import scipy.sparse.linalg
            C = scipy.sparse.vstack([scipy.sparse.csr_matrix(Phi_q), E], "csr")
            dq = scipy.sparse.linalg.lsqr(C, c, atol=1e-15, btol=1e-15)[0]
        else:
            C = np.vstack([Phi_q.toarray() if hasattr(Phi_q, "toarray") else Phi_q, E])
            dq = np.linalg.lstsq(C, c, rcond=None)[0]
        out = out - dq
    return q


def static_positions(system, t0: float, q: np.ndarray, lam: np.ndarray,
                     hold_initials: bool = True, dependent=()) -> np.ndarray:
    """Positions of static equilibrium: Q(t0, q, 0) = Phi_q^T lambda, Phi(q, t0) = 0,
    with the coordinates the ``initial`` lines give held at their values
    (``hold_initials``; False: only the drivers hold, as for the modes about
    the equilibrium, ``mbdsl.modes``).

    Newton's method on

        Q(t0, q, 0) - Phi_q(q)^T lambda - E^T mu = 0,   Phi(q, t0) = 0,   E q = q_given

    (mu the reactions of the held coordinates), matrix
    [[Q_q - (Phi_q^T lambda)_q, -Phi_q^T, -E^T], [Phi_q, 0, 0], [E, 0, 0]],
    started from the assembled configuration q (n,) and its multipliers
    lambda (m,). Every declared force enters (gravity, springs, torques, point
    forces, beam strain) at zero velocity; drivers hold their values at t0.
    (A static analysis as in Haug, Computer-Aided Kinematics and Dynamics of
    Mechanical Systems, sec. 9.1, with the equilibrium found by Newton's
    method on the constrained equations rather than by minimising the
    potential, so that non-conservative loads are allowed.) Where Newton's
    method does not converge on a spatial model it runs again with each step
    brought back onto the constraints (``_retract``): an equilibrium a large
    turn away (a servo's set point 0.8 rad off) is then reached, where the
    plain steps leave the directors' frames and diverge.

    Redundant constraint rows (``dependent``: their indices in lambda,
    ``StructureReport.dependent``) would make the matrix singular; they hold
    wherever the independent rows do, so Newton runs on the independent rows
    with the dependent rows' multipliers at zero (a statically indeterminate
    mechanism: its reactions are not unique, only Phi_q^T lambda is).

    Raises
    ------
    AssemblyError
        E507 when Newton does not reach an equilibrium (none near the
        assembled configuration, or the mechanism is not held: a free
        degree of freedom under a load that no spring resists).
    """
    try:
        return _static_newton(system, t0, q, lam, hold_initials, dependent, False)
    except AssemblyError:
        if not system.layout.frame_rows.size:
            raise
        return _static_newton(system, t0, q, lam, hold_initials, dependent, True)


def _held_rows(system, q, hold_initials, sparse):
    """(E, held, given) of the static equilibrium: the rows E (f, n) of the
    held coordinates (``initial`` lines, the first-order states' integrals)
    and of the held turns (``_held_turns``), the function x -> their values,
    and their values at q."""
    n = system.n
    iq = np.array([ic.column(system.cmap) for ic in system.model.initials
                   if hold_initials and not ic.guess and not ic.is_velocity
                   and ic.field not in DIRECTORS]
                  + list(system.state_cols), dtype=int)     # a state's integral: always held
    E = _selection(iq, n, sparse)
    turns = _held_turns(system, q, hold_initials)
    if turns is None:
        def held(x):
            """The held coordinates' values."""
            return x[iq]
    else:                                     # spatial orientations: three rows each
        E = scipy.sparse.vstack([E, turns], "csr") if sparse else np.vstack([E, turns])

        def held(x):
            """The held coordinates' and turns' values."""
            return E @ x
    return E, held, held(q).copy()


def _static_newton(system, t0, q, lam, hold_initials, dependent, retract) -> np.ndarray:
    """``static_positions``' Newton iteration; with ``retract``, each step
    brought back onto the constraints (``_retract``). AssemblyError (E507)
    when it does not converge."""
    model, n, m = system.model, system.n, system.m
    sparse = n + m > STATIC_DENSE_LIMIT
    E, held, given = _held_rows(system, q, hold_initials, sparse)
    f = E.shape[0]
    v0 = np.zeros(n)            # at rest; the first-order states at their initial values
    for ic in model.state_conditions:
        if ic.is_velocity:
            v0[ic.column(system.cmap)] = ic.value
    x = np.concatenate([q, lam, np.zeros(f)])
    live = None                  # the unknowns Newton solves for: all but redundant rows'
    if len(dependent):
        x[n + np.asarray(dependent, dtype=int)] = 0.0
        kept = np.setdiff1d(np.arange(m), dependent)
        live = np.r_[np.arange(n), n + kept, n + m + np.arange(f)]
    scale = 1.0 + float(np.max(np.abs(system.Q(t0, q, v0, lam)), initial=0.0))
    residual = np.inf
    for _ in range(STATIC_ITERATIONS):
        q, lam, mu = x[:n], x[n:n + m], x[n + m:]
        with np.errstate(all="ignore"):
            r = np.concatenate([system.Q(t0, q, v0, lam) - system.PhiqT_times(q, t0, lam) - E.T @ mu,
                                system.Phi(q, t0), held(q) - given])
            J = (_static_matrix_sparse(system, t0, q, v0, lam, E) if n + m > STATIC_DENSE_LIMIT
                 else _static_matrix(system, t0, q, v0, lam, E))
        residual = float(np.max(np.abs(r[:n]), initial=0.0)) / scale
        if not np.all(np.isfinite(r)):
            break
        if live is not None:
            J, r = (J[live][:, live] if n + m > STATIC_DENSE_LIMIT else J[np.ix_(live, live)],
                    r[live])
        try:
            if n + m > STATIC_DENSE_LIMIT:
                import scipy.sparse.linalg
                with warnings.catch_warnings():
                    warnings.simplefilter("error")       # a singular matrix: stop, as dense
                    dx = scipy.sparse.linalg.spsolve(J, r)
                if not np.all(np.isfinite(dx)):
                    break
            else:
                dx = np.linalg.solve(J, r)
        except (np.linalg.LinAlgError, Warning, RuntimeError):   # SuperLU: MatrixRankWarning
            break
        if live is not None:             # the redundant rows' multipliers stay at zero
            full = np.zeros_like(x)
            full[live] = dx
            dx = full
        x = x - dx
        if retract:
            x[:n] = _retract(system, t0, x[:n], E, given, sparse)
        if np.max(np.abs(dx[:n]), initial=0.0) <= 1e-14 * (1.0 + np.max(np.abs(x[:n]))):
            q = x[:n]
            r = system.Q(t0, q, v0, x[n:n + m]) - system.PhiqT_times(q, t0, x[n:n + m]) - E.T @ x[n + m:]
            if float(np.max(np.abs(r), initial=0.0)) <= 1e-9 * scale:
                return q
            break
    d = Diagnostic("error", "E507",
                   "no static equilibrium was found near the assembled configuration "
                   f"(force residual {residual:.3g} of the loads after Newton's method): "
                   "the mechanism may not be held against its loads",
                   model.static_span, "initial static",
                   hint="a degree of freedom that only gravity or a constant load acts on has "
                   "no equilibrium, and one that nothing acts on (a free body's place on a "
                   "frictionless floor, its turn) no single one: add a spring, hold it with "
                   "an 'initial' line, or drive it")
    raise AssemblyError(d.message, [d])


def _consistent_state(system, t0, tol, max_iter, elastic, q_start=None, redundant="error"):
    """consistent_initial_state with the elastic coordinates started at
    ``elastic[elastic columns]`` (shape (n,)) instead of 0, or the whole
    configuration started at ``q_start`` (n,) (a static equilibrium)."""
    model, lay = system.model, system.layout
    n = system.n
    fixed_q = [(ic.column(system.cmap), ic.value) for ic in model.initials + model.state_conditions
               if not ic.guess and not ic.is_velocity]
    if elastic is not None:      # the quasi-static iteration sets them: the bodies close the loops
        fixed_q = fixed_q + [(int(i), float(elastic[i])) for b in model.flexible_bodies
                             for i in b.elastic_columns()]
    sparse = system.n + system.m > DENSE_LIMIT
    weights = _column_weights(system)
    q, it, res_q, placements = _positions(system, t0, tol, max_iter, elastic, q_start, fixed_q,
                                          sparse, weights)
    structure, warnings = _structure_at(system, q, t0, redundant, elastic)
    v, res_v = _velocities(system, q, t0, sparse, weights)
    a, lam, res_a, Q_start = _accelerations(system, q, v, t0, sparse, structure)
    fixed_idx = {ic.column(system.cmap) for ic in model.initials + model.state_conditions
                 if not ic.guess and not ic.is_velocity}
    solved = {lay.coordinates[i]: float(q[i]) for i in range(n) if i not in fixed_idx}
    return InitialState(t0, q, v, a, lam, res_q, res_v, res_a, solved, it, structure, warnings,
                        Q=Q_start, placements=placements)


def _positions(system, t0, tol, max_iter, elastic, q_start, fixed_q, sparse, weights):
    """(q, Newton iterations, max |Phi(q)|, the bodies' placements): the
    configuration closest (in ``weights``) to the bodies placed along the
    joints that satisfies Phi(q, t0) = 0 and the given coordinates
    ``fixed_q`` [(column, value)]; AssemblyError (E501, E503) if none is found."""
    model, lay, n = system.model, system.layout, system.n
    iq = np.array([i for i, _ in fixed_q], dtype=int)
    vq = np.array([v for _, v in fixed_q])
    E = _selection(iq, n, sparse)
    with np.errstate(all="ignore"):
        placements = []
        q = (place_bodies(system, t0, placements) if q_start is None
             else np.array(q_start, dtype=float))
        if elastic is not None:
            for b in model.flexible_bodies:
                q[b.elastic_columns()] = elastic[b.elastic_columns()]
        _require_finite(system, q, "placing the bodies along the joints gives", t0)
    q_start = q.copy()
    it = 0
    for it in range(1, max_iter + 1):
        with np.errstate(all="ignore"):
            r = np.concatenate([system.Phi(q, t0), q[iq] - vq])
            try:
                dq = _weighted_step(_stacked_jacobian(system, q, t0, E, sparse), r, weights)
            except (np.linalg.LinAlgError, ValueError, RuntimeError):
                break
        if not np.all(np.isfinite(dq)):
            break
        q = q - dq
        # Newton converges quadratically: go on until the correction is at
        # round-off, so that |Phi(q0)| is ~1e-17 m, not merely below tol
        if np.max(np.abs(dq), initial=0.0) <= 1e-14 * (1.0 + np.max(np.abs(q), initial=0.0)):
            break
    phi = system.Phi(q, t0)
    res_q = float(np.max(np.abs(phi), initial=0.0))
    fixed_err = float(np.max(np.abs(q[iq] - vq), initial=0.0))
    if not np.all(np.isfinite(q)) or res_q > 1e3 * tol or fixed_err > 1e3 * tol:
        # more initial conditions than the count of DOF: the likely cause
        d = dof_diagnostic(model, n - system.m, "count") if elastic is None else None
        if d is not None:
            raise AssemblyError(d.message, [d])
        try:
            d = miss_diagnosis(system, q_start, t0, fixed_q)
        except (np.linalg.LinAlgError, ValueError, RuntimeError):
            d = None
        if d is not None:
            raise AssemblyError(d.message, [d])
        phi0 = system.Phi(q_start, t0)
        worst = phi0 if np.all(np.isfinite(phi0)) else phi
        name, value = lay.worst_element(worst)
        value = joint_miss(system, name, worst[lay.element_rows[name]])
        d = Diagnostic("error", "E503",
                       f"the initial configuration cannot be assembled: joint '{name}' stays "
                       f"open by {value:.3g} (m or rad) after {it} Newton iterations",
                       lay.span_of(name), "cannot be closed",
                       hint="check the lengths and points on this loop, or give a 'guess' "
                       "for an angle near the intended assembly branch")
        raise AssemblyError(d.message, [d])
    return q, it, res_q, placements


def _structure_at(system, q, t0, redundant, elastic):
    """(structure, warnings) at the assembled configuration: redundant joints
    refused (E401, unless accepted) by name before the singular index-1 matrix
    could say less, the DOF by rank against the initial conditions (E501),
    a mechanism that cannot move (W402)."""
    model = system.model
    # here, by name, before the singular index-1 matrix could say less
    structure, warnings = None, []
    if system.m <= RANK_LIMIT:
        structure = _check_structure(system, q, t0, redundant)  # E401 first: the cause, if any
        if structure.redundant:
            warnings += redundancy_diagnostics(structure, system.layout, accepted=True)
    d = dof_diagnostic(model, structure.dof_rank if structure else model.dof,
                       "rank" if structure else "count") if elastic is None else None
    if d is not None:
        raise AssemblyError(d.message, [d])
    if structure is not None:
        if structure.dof_rank == 0 and not model.drivers:
            warnings.append(Diagnostic(
                "warning", "W402", f"the mechanism cannot move: 0 degrees of freedom "
                f"({structure.summary()}) and no driver", model.joints[0].span
                if model.joints else None, "locks the mechanism",
                hint="nothing will move; remove a joint, or add a driver if that was intended"))
    return structure, warnings


def _velocities(system, q, t0, sparse, weights):
    """(v, max |Phi_q v + Phi_t|): the velocities closest to the given and
    guessed ones (``initial`` and ``guess`` lines) that satisfy the velocity
    constraints, min ||v - v_g|| s.t. Phi_q v = -Phi_t, v[fixed] = given;
    AssemblyError (E504) when the given ones contradict the constraints."""
    model, lay, n = system.model, system.layout, system.n
    fixed_v = [(ic.column(system.cmap), ic.value) for ic in model.initials + model.state_conditions
               if not ic.guess and ic.is_velocity]
    guess_v = [(ic.column(system.cmap), ic.value) for ic in model.initials
               if ic.guess and ic.is_velocity]
    v_g = np.zeros(n)
    for i, val in guess_v + fixed_v:
        v_g[i] = val
    iv = np.array([i for i, _ in fixed_v], dtype=int)
    Ev = _selection(iv, n, sparse)
    Phi_t = system.Phi_t(q, t0)
    A = _stacked_jacobian(system, q, t0, Ev, sparse)
    rhs = np.concatenate([-Phi_t, v_g[iv]])
    v = v_g + _weighted_step(A, rhs - A @ v_g, weights)
    res_v = float(np.max(np.abs(system.Phiq_times(q, t0, v) + Phi_t), initial=0.0))
    scale = 1.0 + float(np.max(np.abs(v), initial=0.0))
    if res_v > 1e-9 * scale or float(np.max(np.abs(v[iv] - v_g[iv]), initial=0.0)) > 1e-9 * scale:
        name, value = lay.worst_element(system.Phiq_times(q, t0, v) + Phi_t)
        d = Diagnostic("error", "E504",
                       f"the initial velocities contradict the constraints: joint '{name}' "
                       f"has a velocity residual {value:.3g}",
                       lay.span_of(name), "velocity not consistent",
                       hint="give fewer initial velocities (the DOF count), or check their values")
        raise AssemblyError(d.message, [d])
    return v, res_v


def _accelerations(system, q, v, t0, sparse, structure):
    """(a, lambda, max |Phi_q a - gamma|, Q at the start or None) from the index-1 system
    [[M, Phi_q^T], [Phi_q, 0]] [a; lambda] = [Q; gamma] (friction: its loads
    iterated from zero multipliers to their Coulomb limit at rest,
    ``coulomb_start``); AssemblyError (E401, E505) when it is singular."""
    model, n = system.model, system.n
    with np.errstate(all="ignore"):
        # friction's loads start from zero multipliers; iterated below
        Q = system.Q(t0, q, v, np.zeros(system.m) if system.frictions else None)
        gam = system.gamma(q, v, t0)
    _require_finite(system, Q, "the applied forces Q are", t0, what="force")
    m = system.m
    rhs = np.concatenate([Q, gam])
    try:
        with np.errstate(all="ignore"):
            if sparse:
                rows, cols = system.pattern_Phi_q
                Pq = scipy.sparse.coo_matrix((system.Phi_q_values(q, t0), (rows, cols)),
                                             shape=(m, n))
                K = scipy.sparse.bmat([[system.mass_sparse(q), Pq.T],
                                       [Pq, None]], format="csc")
                lu = scipy.sparse.linalg.splu(K)
                sol = lu.solve(rhs)
                d = np.abs(lu.U.diagonal())
            elif structure is not None and structure.redundant:
                # consistent but dependent rows: the minimum-norm solution (a
                # unique; lambda one of many with the same Phi_q^T lambda)
                K = _index1_matrix(system, q, t0)
                sol = np.linalg.lstsq(K, rhs, rcond=None)[0]
                d = np.ones(1)
                lu = None
            else:
                K = _index1_matrix(system, q, t0)
                lu = scipy.linalg.lu_factor(K, check_finite=True)
                sol = scipy.linalg.lu_solve(lu, rhs)
                d = np.abs(np.diag(lu[0]))
        # singular when the solve does not reproduce its right-hand side: a
        # pivot-ratio test would also refuse well-posed but badly scaled
        # systems (a diagonal M spanning many decades solves exactly)
        if not np.all(np.isfinite(sol)) or np.min(d) == 0.0:
            raise np.linalg.LinAlgError("singular")
        with np.errstate(all="ignore"):
            resid = np.max(np.abs(K @ sol - rhs))
            Knorm = np.max(np.abs(K)) if not sparse else abs(K).max()
        if not resid <= 1e-8 * (Knorm * np.max(np.abs(sol)) + np.max(np.abs(rhs)) + 1e-300):
            raise np.linalg.LinAlgError("singular")
        Q_start = None
        if system.frictions:        # friction: Q(lambda), at rest its Coulomb limit
            sol, Q_start = coulomb_start(system, t0, q, v, (
                (lambda r: np.linalg.lstsq(K, r, rcond=None)[0]) if lu is None else
                lu.solve if sparse else lambda r: scipy.linalg.lu_solve(lu, r)))
    except (np.linalg.LinAlgError, ValueError, RuntimeError, scipy.linalg.LinAlgWarning):
        if structure is None and system.m <= 4 * RANK_LIMIT:
            _check_structure(system, q, t0)          # raises E401 when joints are redundant
        d = Diagnostic("error", "E505",
                       "the index-1 matrix [[M, Phi_q^T], [Phi_q, 0]] is singular at the initial "
                       "configuration: the constraints are redundant or the mechanism is at a "
                       "singular position" + (f" (with {system.m} constraint rows, more than "
                       f"{4 * RANK_LIMIT}, the joints involved are not analysed one by one)"
                       if system.m > 4 * RANK_LIMIT else ""),
                       model.joints[0].span if model.joints else None,
                       "", hint="remove a redundant joint, or start away from a dead-centre position")
        raise AssemblyError(d.message, [d]) from None
    a, lam = sol[:n], sol[n:]
    res_a = float(np.max(np.abs(system.Phiq_times(q, t0, a) - gam), initial=0.0))
    return a, lam, res_a, Q_start


def coulomb_start(system, t0, q, v, solve):
    """a_0 and lambda_0 of a model with friction, joints at rest at their
    Coulomb limit.

    The regularised law gives no friction at z = 0, so a joint at rest starts
    with the acceleration of a frictionless joint and reaches its friction
    force only once |z| ~ v_reg, after about v_reg / |dz/dt| (2e-5 s for a block
    on an incline): a transient no step resolves, which a second-order method
    would carry as an O(h) velocity error. The start therefore takes the
    limit v_reg -> 0 (Filippov's solution of the Coulomb law): with slip
    s_i in [-1, 1] in place of tanh(z_i / v_reg) (and mu_static), each joint
    at rest (|z| <= 1e-3 v_reg) slides (s = +-1, dz/dt of that sign) when
    even its full static friction cannot hold it, and otherwise sticks
    (dz/dt = 0, s found by regula falsi; dz/dt is monotone in s). Several
    joints are swept in turn (Gauss-Seidel) until their s settle.

    Parameters
    ----------
    system : AssembledSystem
    t0 : float [s]
    q, v : ndarray, shape (n,)
    solve : callable
        Solves with the factorized index-1 matrix, rhs (n + m,) -> (n + m,).

    Returns
    -------
    sol : ndarray, shape (n + m,)
        (a_0, lambda_0).
    Q : ndarray, shape (n,), or None
        The applied forces at the start (None: no joint at rest, the law itself).
    """
    n = system.n
    v_reg = np.array([f.v_reg for f in system.frictions])
    rest = np.abs(system.friction_speeds(q, v)) <= 1e-3 * v_reg
    if not rest.any():
        return system.index1_solve(None, t0, q, v, solve), None
    slip = np.where(rest, 0.0, np.nan)

    def rate(s):
        """(dz/dt per friction joint, (a, lambda)) with slips s (NaN: the law)."""
        sol = system.index1_solve(None, t0, q, v, solve, slip=s)
        return system.friction_speeds(q, v, sol[:n]), sol

    for _ in range(20):
        before = slip.copy()
        for i in np.flatnonzero(rest):
            trial = slip.copy()
            trial[i] = 1.0
            up = rate(trial)[0][i]
            if up > 0.0:                 # slides forward even against full friction
                slip[i] = 1.0
                continue
            trial[i] = -1.0
            down = rate(trial)[0][i]
            if down < 0.0:
                slip[i] = -1.0
                continue
            lo, f_lo, hi, f_hi = -1.0, down, 1.0, up        # f_lo >= 0 >= f_hi: sticks
            tol = 1e-14 * (abs(f_lo) + abs(f_hi)) + 1e-300
            s = 0.0
            for _ in range(60):
                s = lo - f_lo * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
                trial[i] = s
                f = rate(trial)[0][i]
                if abs(f) <= tol:
                    break
                if f > 0.0:
                    lo, f_lo = s, f
                    f_hi *= 0.5                            # Illinois: no stalled end
                else:
                    hi, f_hi = s, f
                    f_lo *= 0.5
            slip[i] = s
        if np.max(np.abs(slip[rest] - before[rest])) <= 1e-12:
            break
    sol = rate(slip)[1]
    return sol, system.Q(t0, q, v, sol[n:], slip)


def _index1_matrix(system, q, t0) -> np.ndarray:
    """[[M(q), Phi_q^T], [Phi_q, 0]], dense, shape (n + m, n + m)."""
    Phi_q = system.Phi_q(q, t0)
    m = system.m
    return np.block([[system.mass_matrix(q), Phi_q.T], [Phi_q, np.zeros((m, m))]])


def _require_finite(system, x, context, t0, what="coordinate"):
    """E506 naming the first body (or first-order state) whose entries of x
    (shape (n,)) are not finite."""
    bad = np.nonzero(~np.isfinite(x))[0]
    if len(bad) == 0:
        return
    name = system.layout.coordinates[bad[0]]
    offset = system.cmap.state_offset
    if bad[0] >= offset:                     # a first-order state's integral, value or rate
        state = system.model.states[bad[0] - offset]
        name = (f"state.{state.name}.rate" if what == "force"    # Q there is its rate
                else f"state.{state.name}.integral")
        span, hint = state.span, ("a state's rate or initial value of extreme size: check "
                                  "its parameters and the quantities it reads")
    else:
        span = system.model.body(name.rpartition(".")[0]).span
        hint = ("a mass, length, point or force of extreme size: check the units "
                "(SI: kg, m, s, N) and the values of this body")
    d = Diagnostic("error", "E506",
                   f"{context} a non-finite {what} at t = {t0:g} s: '{name}' "
                   f"({float(x[bad[0]])}); {len(bad)} value{'s overflow' if len(bad) > 1 else ' overflows'}",
                   span, "overflows here", hint=hint)
    raise AssemblyError(d.message, [d])


def dof_diagnostic(model, dof: int, by: str):
    """E501 when the model's initial position or velocity conditions (not
    guesses) are more than ``dof`` degrees of freedom allow, else None; ``by``
    says how the DOF were counted ("rank", "count")."""
    pos = [ic for ic in model.initials if not ic.guess and not ic.is_velocity and ic.counted]
    vel = [ic for ic in model.initials if not ic.guess and ic.is_velocity and ic.counted]
    for kind, ics in (("position", pos), ("velocity", vel)):
        if dof >= 0 and len(ics) > dof:
            return Diagnostic("error", "E501", f"{len(ics)} initial {kind} conditions fix more "
                              f"than the {dof} degree{'s' if dof != 1 else ''} of freedom "
                              f"(by {by}) allow", ics[dof].span, "one too many",
                              hint="turn some into 'guess' lines: the assembly then computes "
                              "them from the joints")
    return None


def _check_structure(system, q, t0, redundant="error") -> StructureReport:
    """The structure report at q; AssemblyError (E401) naming redundant joints
    (unless ``redundant == "accept"``), E506 when the constraint Jacobian is
    not finite."""
    try:
        report = analyse_structure(system, q, t0)
    except FloatingPointError as exc:
        name = str(exc)
        d = Diagnostic("error", "E506", f"the constraint Jacobian of '{name}' is not finite at the "
                       f"assembled configuration (t = {t0:g} s)", system.layout.span_of(name),
                       "overflows here", hint="a point or length of extreme size: check the "
                       "units (SI: m) and the points this joint connects")
        raise AssemblyError(d.message, [d]) from None
    if report.redundant:
        diags = friction_on_redundant_joints(report, system)
        if diags:
            raise AssemblyError(diags[0].message, diags, structure=report)
    if report.redundant and redundant != "accept":
        diags = redundancy_diagnostics(report, system.layout)
        raise AssemblyError(diags[0].message, diags, structure=report)
    return report
