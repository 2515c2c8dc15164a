"""Structural analysis at an assembled configuration: DOF by count and by rank,
redundant joints, loops that cannot close, and what a singular matrix involves.

* **DOF by count** (Gruebler): n - m. **DOF by rank**: n - rank(Phi_q(q)).
  They differ when joints repeat each other's equations (a four-bar with a
  joint too many): the index-1 and Newton matrices are then singular, so the
  run is refused before any step and the joints are named.
* **Which rows are redundant**: rows are taken in declaration order and a
  row is redundant when it lies in the span of the rows before it
  (Gram-Schmidt with re-orthogonalisation, relative tolerance 1e-9). The
  joint declared later is reported, with the joints whose rows it repeats
  (the nonzero coefficients of its least-squares combination).
* **Loops that cannot close**: with the spanning-tree joints and the user's
  ``initial`` coordinates held (weighted least squares), the loop-closing
  joint that misses is named with its miss in metres, with the bodies and
  joints of its loop (the fundamental cycle of the body graph).

Source: Haug, Computer-Aided Kinematics and Dynamics of Mechanical Systems,
sec. 3.3-3.6 (redundant constraints, assembly); Wittenburg, Dynamics of
Multibody Systems, ch. 5 (kinematic loops).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import Diagnostic
from ..model import graph

__all__ = ["StructureReport", "analyse_structure", "independent_rows", "miss_diagnosis",
           "friction_on_redundant_joints",
           "involved_names", "RANK_LIMIT"]

#: Largest number of constraint rows analysed densely at every start; above
#: it, the analysis runs only when a factorization reports a singular matrix.
RANK_LIMIT = 600


def independent_rows(A: np.ndarray, rtol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Rows of A independent of all rows before them, in order.

    Parameters
    ----------
    A : ndarray, shape (m, n)
    rtol : float
        A row is dependent when its component orthogonal to the earlier rows
        is below rtol times its norm (times max(1, scale of A)).

    Returns
    -------
    independent, dependent : ndarray of int
        Row numbers; ``len(independent)`` is the numerical rank.
    """
    m, n = A.shape
    basis = np.empty((min(m, n), n))        # orthonormal rows found so far, filled in place
    k = 0
    ind, dep = [], []
    for i in range(m):
        r = A[i].astype(float)
        norm = np.linalg.norm(r)
        B = basis[:k]
        for _ in range(2):                     # twice is enough (Kahan-Parlett)
            r = r - B.T @ (B @ r)
        rn = np.linalg.norm(r)
        if norm == 0.0 or rn <= rtol * norm or k == len(basis):
            dep.append(i)
        else:
            ind.append(i)
            basis[k] = r / rn
            k += 1
    return np.array(ind, dtype=int), np.array(dep, dtype=int)


@dataclass
class Redundancy:
    """A joint (or driver) whose rows repeat earlier ones."""

    name: str
    rows: list
    depends_on: list


@dataclass
class StructureReport:
    """DOF by count and by rank, and the redundant joints.

    Attributes
    ----------
    n, m : int
        Coordinates of the mechanism (a first-order state's integral is none)
        and constraint rows.
    rank : int
        Numerical rank of Phi_q at the configuration.
    redundant : list of Redundancy
    dependent : list of int
        The rows of Phi_q that repeat earlier ones (the redundant joints'
        rows, indices into lambda), sorted; the others are independent.
    """

    n: int
    m: int
    rank: int
    redundant: list = field(default_factory=list)
    dependent: list = field(default_factory=list)

    @property
    def dof_count(self) -> int:
        """Gruebler's count n - m."""
        return self.n - self.m

    @property
    def dof_rank(self) -> int:
        """n - rank(Phi_q)."""
        return self.n - self.rank

    def summary(self) -> str:
        """``DOF by count = -1, by rank = 1``."""
        return f"DOF by count = {self.dof_count}, by rank = {self.dof_rank}"


def analyse_structure(system, q: np.ndarray, t: float) -> StructureReport:
    """Rank of Phi_q(q, t) and the redundant joints, in declaration order.

    Parameters
    ----------
    system : AssembledSystem
    q : ndarray, shape (n,)
        An assembled configuration.
    t : float [s]

    Returns
    -------
    StructureReport

    Raises
    ------
    FloatingPointError
        Phi_q has non-finite entries; the argument is the joint's name.
    """
    lay = system.layout
    n = system.n - len(system.state_cols)
    if system.m == 0:
        return StructureReport(n, 0, 0)
    with np.errstate(all="ignore"):
        A = system.Phi_q(q, t)
    finite = np.all(np.isfinite(A), axis=1)
    if not np.all(finite):
        name = lay.rows[int(np.argmin(finite))][0]
        raise FloatingPointError(name)
    # a spatial body's frame rows first (``model.spatial.Frame``): they always hold, and
    # a dependent row is then a joint's, the one the report can tell the user to remove
    frames = {f.name for f in system.model.frames}
    first = lay.element_mask(frames)
    order = np.r_[np.flatnonzero(first), np.flatnonzero(~first)]
    ind, dep = independent_rows(A[order])
    ind, dep = np.sort(order[ind]), np.sort(order[dep])
    report = StructureReport(n, system.m, len(ind), dependent=[int(i) for i in dep])
    by_element: dict[str, list[int]] = {}
    for i in dep:
        by_element.setdefault(lay.rows[i][0], []).append(int(i))
    for name, rows in by_element.items():
        others = []
        if len(ind):
            coef, *_ = np.linalg.lstsq(A[ind].T, A[rows].T, rcond=None)
            weight = np.max(np.abs(coef), axis=1)
        else:
            weight = np.zeros(0)
        for k in np.nonzero(weight > 1e-8 * max(weight.max(initial=0.0), 1e-300))[0]:
            other = lay.rows[ind[k]][0]
            if other != name and other not in others:
                others.append(other)
        report.redundant.append(Redundancy(name, [lay.rows[i][1] for i in rows], others))
    return report


def redundancy_diagnostics(report: StructureReport, layout,
                           accepted: bool = False) -> list[Diagnostic]:
    """E401 for each redundant joint, at its declaration; W405 instead when
    ``accepted`` (the run goes on with the augmented formulation)."""
    out = []
    for r in report.redundant:
        rows = ", ".join(str(k) for k in r.rows)
        with_ = (" of joint" + ("s " if len(r.depends_on) > 1 else " ")
                 + ", ".join(f"'{o}'" for o in r.depends_on)) if r.depends_on else ""
        what = (f"repeat{'s' if len(r.rows) == 1 else ''} the equations{with_}" if r.depends_on
                 else f"vanish{'es' if len(r.rows) == 1 else ''} at this configuration "
                      "(a zero Jacobian row: degenerate geometry)")
        out.append(Diagnostic(
            "warning" if accepted else "error", "W405" if accepted else "E401",
            "redundant constraints" + (" accepted by the augmented formulation" if accepted
                                       else "")
            + f": row{'s' if len(r.rows) > 1 else ''} {rows} of '{r.name}' "
            f"{what} ({report.summary()})", layout.span_of(r.name), "redundant",
            hint="their reactions are not unique (only Phi_q^T lambda is); remove the joint "
                 "for unique reactions" if accepted else
                 f"remove '{r.name}', or replace it by a joint that adds only what is missing "
                 "(e.g. point_on_line instead of revolute); redundant rows make the "
                 "multipliers undetermined and the Newton matrix singular",
            notes=(f"{report.m} constraint equations, rank {report.rank}, "
                   f"{report.n} coordinates",)))
    return out


def friction_on_redundant_joints(report: StructureReport, system) -> list[Diagnostic]:
    """E403 for each friction element in a joint whose rows are redundant.

    Coulomb friction in a joint reads the joint's normal reaction (its
    multipliers). Where the joint's rows repeat another joint's, only the sum
    Phi_q^T lambda is determined, not how the reaction splits between them
    (the minimum-norm split halves it): the friction force would follow an
    arbitrary choice. The diagnostic names the friction, its joint and the
    joint(s) it repeats or is repeated by.
    """
    from ..model.elements import Friction
    partners: dict[str, set] = {}
    for r in report.redundant:
        group = {r.name, *r.depends_on}
        for name in group:
            partners.setdefault(name, set()).update(group - {name})
    out = []
    for f in system.model.forces:
        if not isinstance(f, Friction) or f.joint.name not in partners:
            continue
        others = sorted(partners[f.joint.name])
        listed = ", ".join(f"'{o}'" for o in others) or "itself"
        out.append(Diagnostic(
            "error", "E403",
            f"friction '{f.name}' reads the normal reaction of joint '{f.joint.name}', "
            f"whose equations repeat those of {listed}: the reaction's split between them, "
            "and so the friction force, is not determined", f.span, "needs a determinate reaction",
            hint=f"remove the redundant joint ({listed} or '{f.joint.name}') so that one "
                 "joint carries the reaction, or put the friction on a joint that is not "
                 "redundant",
            notes=(f"{report.m} constraint equations, rank {report.rank}, "
                   f"{report.n} coordinates",)))
    return out


def miss_diagnosis(system, q_start: np.ndarray, t0: float, fixed: list[tuple[int, float]],
                   max_iter: int = 60) -> Diagnostic | None:
    """Why the loops cannot close: the joint that misses, by how much, on which loop.

    Holds the spanning-tree joints and the ``initial`` coordinates with a
    large weight and closes the rest in the least-squares sense; the
    loop-closing joint with the largest residual is the one that cannot
    hold. When freeing the ``initial`` coordinates lets the loop close, the
    diagnostic says which coordinate to change and to what.

    Returns
    -------
    Diagnostic or None
        E503, or None when the model is too large for the dense analysis.
    """
    model, lay = system.model, system.layout
    n, m = system.n, system.m
    if n + m > 4 * RANK_LIMIT or m == 0:
        return None
    tree = {j.name for _, _, j in graph.spanning_tree_edges(model) if j is not None}
    drivers = {d.name for d in model.drivers}
    hard_rows = lay.element_mask(tree | drivers)
    iq = np.array([i for i, _ in fixed], dtype=int)
    vq = np.array([v for _, v in fixed], dtype=float)

    with np.errstate(all="ignore"):
        q = _close_loops(system, q_start, t0, hard_rows, iq, vq, True, max_iter)
        if q is None:
            return None
        phi = system.Phi(q, t0)
        name, value = lay.worst_element(phi)
        value = joint_miss(system, name, phi[lay.element_rows[name]])
        bodies, joints = graph.loop_through(model, name)
        loop = (" on the loop " + " - ".join(bodies) + " (joints " + ", ".join(joints) + ")"
                if bodies else "")
        hint = (f"check the points and lengths on this loop: with every other joint holding, "
                f"'{name}' misses by {value:.3g} m")
        if len(iq):
            q_free = _close_loops(system, q_start, t0, hard_rows, iq, vq, False, max_iter)
            if q_free is not None and np.max(np.abs(system.Phi(q_free, t0))) < 1e-9:
                k = int(np.argmax(np.abs(q_free[iq] - vq)))
                coord = lay.coordinates[iq[k]]
                hint = (f"the loop closes when 'initial {coord}' is not imposed (it closes at "
                        f"{coord} = {q_free[iq[k]]:.6g}); change that value, or make it a "
                        "'guess'")
    return Diagnostic("error", "E503",
                      f"the initial configuration cannot be assembled: joint '{name}' cannot "
                      f"close{loop}; with the other joints holding it misses by {value:.3g} m",
                      lay.span_of(name), f"misses by {value:.3g} m", hint=hint)


def _close_loops(system, q_start, t0, hard_rows, iq, vq, hold_fixed, max_iter):
    """min ||Phi_loop(q)|| subject to the tree joints, the drivers and (if
    hold_fixed) the initial coordinates holding exactly: Gauss-Newton in the
    null space of the held rows, each trial point projected back onto
    them, with backtracking on the loop residual; None where the step is
    not finite."""
    import scipy.linalg
    n = system.n
    k = len(iq) if hold_fixed else 0
    E = np.zeros((k, n))
    E[np.arange(k), iq[:k]] = 1.0

    def held(q):
        """Residuals of the held rows (tree joints, drivers, initial values)."""
        return np.concatenate([system.Phi(q, t0)[hard_rows], q[iq[:k]] - vq[:k]])

    def held_jac(q):
        """Jacobian of :func:`held`, shape (held rows, n)."""
        return np.vstack([system.Phi_q(q, t0)[hard_rows], E])

    def project(q):
        """Back onto the held rows by minimum-norm Newton steps."""
        for _ in range(30):
            r = held(q)
            if np.max(np.abs(r), initial=0.0) < 1e-13:
                break
            q = q - np.linalg.lstsq(held_jac(q), r, rcond=None)[0]
        return q

    def loop_res(q):
        """Residuals of the loop-closing joints."""
        return system.Phi(q, t0)[~hard_rows]

    q = project(q_start.copy())
    for _ in range(max_iter):
        r = loop_res(q)
        N = scipy.linalg.null_space(held_jac(q)) if np.any(hard_rows) or k else np.eye(n)
        if N.shape[1] == 0:
            break
        z = np.linalg.lstsq(system.Phi_q(q, t0)[~hard_rows] @ N, r, rcond=None)[0]
        dq = N @ z
        if not np.all(np.isfinite(dq)):
            return None
        f0, step = float(r @ r), 1.0
        while step > 1e-8:
            q_new = project(q - step * dq)
            r_new = loop_res(q_new)
            if float(r_new @ r_new) < f0:
                break
            step *= 0.5
        else:
            break
        q = q_new
        if f0 - float(r_new @ r_new) < 1e-24:
            break
    return q


def joint_miss(system, name: str, residual: np.ndarray) -> float:
    """How far a joint or driver is from holding [m or rad], from its rows' residual.

    The rows of most joints are distances or angles already, and their miss
    is the largest; a joint family whose row is not says how far its joint is
    from holding (its ``miss``, ``kernels.system.joint_hook``).

    Parameters
    ----------
    system : AssembledSystem
    name : str
        The joint's or driver's name.
    residual : ndarray, shape (rows,)
        Its rows of Phi.
    """
    residual = np.atleast_1d(np.asarray(residual, float))
    joint = next((j for j in system.model.joints if j.name == name), None)
    miss = (system.kernel_model().K.joint_hook(joint.kind, "miss")
            if joint is not None else None)
    if miss is not None:
        return miss(joint, residual)
    return float(np.max(np.abs(residual), initial=0.0))


def involved_names(system, method, vector: np.ndarray, share: float = 0.1) -> tuple[list, list]:
    """Bodies and joints a Newton-space vector (e.g. a null vector) involves.

    Parameters
    ----------
    system : AssembledSystem
    method : Method
        Its ``blocks`` say which unknowns are kinematic (one per coordinate)
        and which are multipliers (one per constraint row).
    vector : ndarray, shape (unknowns,)
    share : float
        Entries above ``share`` times the largest, per kind, are named.

    Returns
    -------
    coordinates, elements : list of str
        Coordinate names (``rod.phi``) and joint/driver names, largest first.
    """
    lay = system.layout
    kin = np.zeros(system.n)
    mult = np.zeros(system.m)
    i = 0
    for b in method.blocks(system):
        part = np.abs(vector[i:i + b.size])
        if b.kind == "kinematic":
            kin = np.maximum(kin, part)
        else:
            mult = np.maximum(mult, part)
        i += b.size
    big = max(kin.max(initial=0.0), mult.max(initial=0.0))
    coords = [lay.coordinates[k] for k in np.argsort(-kin) if kin[k] > share * big][:6]
    order = np.argsort(-mult, kind="stable")
    named = lay.row_element[order[mult[order] > share * big]]
    elements = list(dict.fromkeys(lay.element_names[e] for e in named.tolist()))
    return coords, elements[:6]
