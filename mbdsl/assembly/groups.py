"""Element groups: every instance of one element type at once.

Each group stores its instances as a struct of arrays (body columns,
body-fixed vectors, parameters) built once: the model data
``integrators.engine.CompiledModel`` packs for the kernels. A constraint
group (rows ``rows`` (k, r), columns ``cols`` (k, c) into the extended
coordinate vector q_ext = [q, 0, 0, 0], where the three trailing zeros are
the ground) holds data only: the kernels of ``integrators/compiled.py`` are
the one evaluation of Phi and its derivatives (``AssembledSystem.Phi`` and
the functions after it), and ``tests/assembly/constraint_oracle.py`` an
independent numpy one they are tested against. The force groups still
evaluate their loads here, vectorised (local Q (k, c), Q_q and Q_v (k, c,
c), scattered by the system). All formulas are in absolute planar
coordinates (Haug, Computer-Aided Kinematics and Dynamics of Mechanical
Systems, ch. 3; Nikravesh, Computer-Aided Analysis of Mechanical Systems,
ch. 4): A(phi) is the rotation matrix, B(phi) = dA/dphi, and
d^2(A s)/dphi^2 = -A s.

Shapes: k instances, r rows per instance, c local coordinates.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rot", "drot", "body_columns", "PointSet", "point_difference", "CoincidenceGroup", "PointOnLineGroup", "LinearConstraintGroup",
           "SpringDamperGroup", "RotationalSpringGroup",
           "TorqueGroup", "StateTorqueGroup", "PointForceGroup"]


def rot(phi: np.ndarray, s: np.ndarray) -> np.ndarray:
    """A(phi) s for arrays: phi shape (..., k), s shape (k, 2) or (..., k, 2)
    -> (..., k, 2). Leading axes are rows of a stored solution (evaluated
    all at once for its derived columns); the integrators pass one row."""
    c, si = np.cos(phi), np.sin(phi)
    out = np.empty(np.shape(phi) + (2,))
    out[..., 0] = c * s[..., 0] - si * s[..., 1]
    out[..., 1] = si * s[..., 0] + c * s[..., 1]
    return out


def drot(phi: np.ndarray, s: np.ndarray) -> np.ndarray:
    """B(phi) s = dA/dphi s, shapes as for :func:`rot`."""
    c, si = np.cos(phi), np.sin(phi)
    out = np.empty(np.shape(phi) + (2,))
    out[..., 0] = -si * s[..., 0] - c * s[..., 1]
    out[..., 1] = c * s[..., 0] - si * s[..., 1]
    return out


def body_columns(cmap, bodies) -> np.ndarray:
    """Columns (x, y, phi) in q_ext of body indices (ground = -1 -> n..n+2; a
    particle's phi -> n+2), shape (k, 3), from the model's
    :class:`~mbdsl.model.elements.CoordinateMap`."""
    return cmap(bodies)


class PointSet:
    """k points, one per instance, on rigid bodies, flexible beams or the ground.

    A point is at r + A(phi) u with u = s + S q_e: s its body-fixed (or
    undeformed) position, S the columns of a flexible beam's shape matrix
    for the e elastic coordinates q_e it depends on (none on a rigid body).
    Local coordinates per instance: (x, y, phi, q_e), with e padded to the
    largest count in the set by the ground's dummy column (q_ext = 0 there)
    and zero shape entries. Rigid-only sets have e = 0 and cost what the
    rigid formulas cost.

    * position: r + A u                                   (k, 2)
    * jac:      [I, B u, A S]                             (k, 2, 3 + e)
    * hess:     d2/dphi2 = -A u, d2/dphi dq_e = B S       (k, 2, 3 + e, 3 + e)

    (Shabana, Dynamics of Multibody Systems, sec. 5.3: the position of an
    arbitrary point of a deformable body in the floating frame.)
    """

    def __init__(self, cmap, points):
        n = cmap.n
        points = list(points)
        k = len(points)
        self.e = max((len(p.elastic_columns) for p in points), default=0)
        self.c = 3 + self.e
        ecols = np.full((k, self.e), n, dtype=np.intp)
        self.S = np.zeros((k, 2, self.e))
        for i, p in enumerate(points):      # build time only
            ne = len(p.elastic_columns)
            ecols[i, :ne] = p.elastic_columns
            self.S[i, :, :ne] = p.elastic_shape
        self.cols = np.concatenate([body_columns(cmap, [p.body for p in points]), ecols], axis=1)
        self.s = np.array([p.local for p in points], dtype=float).reshape(-1, 2)
        self.flexible = self.e > 0
        self._jac = np.zeros((k, 2, self.c))
        self._jac[:, 0, 0] = self._jac[:, 1, 1] = 1.0
        self._hess = np.zeros((k, 2, self.c, self.c))

    def local(self, q) -> np.ndarray:
        """u = s + S q_e in the body frame, shape (k, 2), from local coordinates q (k, c)."""
        if not self.flexible:
            return self.s
        return self.s + np.einsum("kaj,...kj->...ka", self.S, q[..., 3:])

    def position(self, q) -> np.ndarray:
        """Global positions, shape (..., k, 2) for q of shape (..., k, c)."""
        return q[..., 0:2] + rot(q[..., 2], self.local(q))

    def jac(self, q) -> np.ndarray:
        """d position / d q_local, shape (..., k, 2, c) (for one row, q of
        shape (k, c), a reused buffer)."""
        J = self._jac if q.ndim == 2 else np.broadcast_to(self._jac, q.shape[:-2] + self._jac.shape).copy()
        J[..., 2] = drot(q[..., 2], self.local(q))
        if self.flexible:
            c, si = np.cos(q[..., 2])[..., None], np.sin(q[..., 2])[..., None]
            J[..., 0, 3:] = c * self.S[:, 0] - si * self.S[:, 1]
            J[..., 1, 3:] = si * self.S[:, 0] + c * self.S[:, 1]
        return J

    def hess(self, q) -> np.ndarray:
        """d2 position / d q_local2, shape (k, 2, c, c) (a reused buffer)."""
        H = self._hess
        H[:, :, 2, 2] = -rot(q[:, 2], self.local(q))
        if self.flexible:
            c, si = np.cos(q[:, 2]), np.sin(q[:, 2])
            BS = np.stack([-si[:, None] * self.S[:, 0] - c[:, None] * self.S[:, 1],
                           c[:, None] * self.S[:, 0] - si[:, None] * self.S[:, 1]], axis=1)
            H[:, :, 2, 3:] = BS
            H[:, :, 3:, 2] = BS
        return H


def point_difference(P1: PointSet, q1, P2: PointSet, q2) -> np.ndarray:
    """d = p2 - p1, shape (k, 2), from the local coordinates of both sets.

    Reference coordinates are subtracted first: exact when the two bodies
    are within a factor 2 of each other (Sterbenz), so the round-off is eps
    times the point offsets, not eps |r|. Index-3 methods divide Phi by
    beta h^2, so this round-off reaches the velocities.
    """
    return (q2[..., 0:2] - q1[..., 0:2]) + (rot(q2[..., 2], P2.local(q2))
                                            - rot(q1[..., 2], P1.local(q1)))


class _PointPair:
    """Two point sets side by side, local coordinates (q_1 [c1], q_2 [c2]),
    and the derivatives of their difference d = p2 - p1."""

    def __init__(self, cmap, first, second):
        self.P1, self.P2 = PointSet(cmap, first), PointSet(cmap, second)
        self.c1 = self.P1.c
        self.cols = np.concatenate([self.P1.cols, self.P2.cols], axis=1)
        k, c = self.cols.shape
        self._D = np.zeros((k, 2, c))
        self._DD = np.zeros((k, 2, c, c))

    def split(self, qx):
        """Local coordinates of both points, (..., k, c1) and (..., k, c2)."""
        q = qx[..., self.cols]
        return q[..., :self.c1], q[..., self.c1:]

    def difference(self, q1, q2):
        """d = p2 - p1, shape (..., k, 2)."""
        return point_difference(self.P1, q1, self.P2, q2)

    def difference_jac(self, q1, q2):
        """dd/dq_local = [-J1, J2], shape (..., k, 2, c1 + c2) (for one row a
        reused buffer)."""
        D = self._D if q1.ndim == 2 else np.empty(q1.shape[:-2] + self._D.shape)
        D[..., :self.c1] = -self.P1.jac(q1)
        D[..., self.c1:] = self.P2.jac(q2)
        return D

    def difference_hess(self, q1, q2):
        """d2d/dq_local2 = -H1 (+) H2, shape (k, 2, c, c) (a reused buffer)."""
        c1, DD = self.c1, self._DD
        DD[:, :, :c1, :c1] = -self.P1.hess(q1)
        DD[:, :, c1:, c1:] = self.P2.hess(q2)
        return DD


class CoincidenceGroup:
    """Two points coincide (revolute, and the first two rows of fixed).

    Phi = (r2 + A2 u2) - (r1 + A1 u1) (2 rows). Local coordinates
    (x1, y1, phi1, q_e1, x2, y2, phi2, q_e2); q_e are the elastic
    coordinates of a point on a flexible beam (none for rigid bodies).
    """

    r = 2
    nonlinear = True

    def __init__(self, cmap, rows, first, second):
        self.rows = np.asarray(rows, dtype=np.intp).reshape(-1, 2)
        self.pair = _PointPair(cmap, first, second)
        self.cols = self.pair.cols
        self.time_dependent = False


class DistanceGroup:
    """Two points held at a fixed distance L (``distance`` joint: a massless rod).

    Phi = (d . d - L^2) / (2 L), d = p2 - p1 (1 row): zero exactly when |d| = L,
    smooth everywhere (|d| - L is not at d = 0), and scaled so that Phi is a
    length near the solution and its multiplier the rod's tension [N]
    (Haug, Computer-Aided Kinematics and Dynamics of Mechanical Systems,
    sec. 3.3, the distance constraint). With D = dd/dq_local:

        Phi_q = d^T D / L,   Phi_qq = (D^T D + sum_a d_a D_a,qq) / L
    """

    r = 1
    nonlinear = True

    def __init__(self, cmap, rows, first, second, lengths):
        self.rows = np.asarray(rows, dtype=np.intp).reshape(-1, 1)
        self.pair = _PointPair(cmap, first, second)
        self.cols = self.pair.cols
        self.L = np.asarray(lengths, float).reshape(-1)
        self.time_dependent = False


class PointOnLineGroup:
    """Point P stays on the line through point L of body l, or is driven
    along it.

    Phi = n . d - f(t), d = p_P - p_L, n = A_l n0 turning with body l's
    (reference) frame (1 row): with n0 the line's unit normal and no f, P
    stays on the line (point_on_line, prismatic); with n0 the line's unit
    direction, n . d is the distance of P along the line and f(t) drives it
    (a ``P.distance`` driver). Local coordinates (x_L, y_L, phi_L, q_eL, x_P,
    y_P, phi_P, q_eP), D = dd/dq_local:

        Phi_q  = n^T D + (B_l n0 . d) e_phiL^T
        Phi_qq = n . D_qq + e_phiL (B_l n0)^T D + D^T (B_l n0) e_phiL^T
                 - (n . d) e_phiL e_phiL^T
        Phi_t  = -f'(t),  Phi_tt = -f''(t),  Phi_qt = 0

    ``functions`` holds a TimeFunction or None per instance.
    """

    r = 1
    nonlinear = True

    def __init__(self, cmap, rows, point, line, normal, functions=None):
        self.rows = np.asarray(rows, dtype=np.intp).reshape(-1, 1)
        self.pair = _PointPair(cmap, line, point)          # d = p_P - p_L
        self.cols = self.pair.cols
        self.n0 = np.asarray(normal, float).reshape(-1, 2)
        k = len(self.rows)
        self.functions = list(functions) if functions is not None else [None] * k
        self.time_dependent = any(f is not None for f in self.functions)


class LinearConstraintGroup:
    """Rows linear in q with constant coefficients, minus a time function:

        Phi = c1 q[col1] + c2 q[col2] - offset - f(t)

    This covers the locked relative angle of fixed and prismatic joints
    (phi2 - phi1 - angle), joint-angle drivers (phi2 - phi1 - f(t)) and
    coordinate drivers (q_c - f(t), written with the ground's dummy column
    and coefficient 0 as its first column). Linear: Hess = 0, Phi_qt = 0.
    ``functions`` holds a TimeFunction or None per instance.
    """

    r = 1
    nonlinear = False

    def __init__(self, cmap, rows, cols, coefs, offset, functions):
        self.rows = np.asarray(rows, dtype=np.intp).reshape(-1, 1)
        self.cols = np.asarray(cols, dtype=np.intp).reshape(-1, 2)
        self.coefs = np.asarray(coefs, float).reshape(-1, 2)
        self.offset = np.asarray(offset, float)
        self.functions = list(functions)
        self.time_dependent = any(f is not None for f in self.functions)


# ---------------------------------------------------------------------------
# Force groups: local generalized forces Q (k, c) and their derivatives
# Q_q, Q_v (k, c, c), scattered by the system with accumulation.
# ---------------------------------------------------------------------------

class SpringDamperGroup:
    """Translational spring-dampers between point pairs.

    d = p2 - p1, l = |d|, e = d / l, ldot = e . d', tension
    f = k (l - l0) + c ldot, generalized force Q = -D^T (f e) with
    D = dd/dq_local. Q_q follows from the chain rule through e, l, ldot and
    the Hessians of d; Q_v = -c (D^T e)(D^T e)^T. The points may lie on
    flexible beams (``PointSet``).
    """

    def __init__(self, cmap, first, second, k, c, length):
        self.pair = _PointPair(cmap, first, second)
        self.cols = self.pair.cols
        self.k, self.c, self.l0 = (np.asarray(x, float) for x in (k, c, length))
        self.damped = bool(np.any(self.c != 0.0))

    def _kin(self, qx, vx):
        q1, q2 = self.pair.split(qx)
        v = vx[self.cols]
        d = self.pair.difference(q1, q2)
        G = self.pair.difference_jac(q1, q2)
        ddot = np.einsum("kaj,kj->ka", G, v)
        l = np.sqrt(np.einsum("ka,ka->k", d, d))
        # two coincident points: no direction, and no force along it (the
        # time loop lands a step there as an event, docs/contact.md)
        e = np.divide(d, l[:, None], out=np.zeros_like(d), where=l[:, None] > 0.0)
        return q1, q2, v, d, G, ddot, l, e

    def lengths(self, qx):
        """Current lengths l, shape (..., k) [m]."""
        d = self.pair.difference(*self.pair.split(qx))
        return np.sqrt(np.einsum("...a,...a->...", d, d))

    def forces(self, qx, vx, t):
        """Local Q, shape (k, c) [N, N m]."""
        _, _, _, d, G, ddot, l, e = self._kin(qx, vx)
        f = self.k * (l - self.l0)
        if self.damped:
            f = f + self.c * np.einsum("ka,ka->k", e, ddot)
        return -np.einsum("kaj,ka->kj", G, f[:, None] * e)

    def derivatives(self, qx, vx, t):
        """Local (Q_q, Q_v), each shape (k, c, c)."""
        q1, q2, v, d, G, ddot, l, e = self._kin(qx, vx)
        Hd = self.pair.difference_hess(q1, q2)          # (k, 2, c, c)
        Hv = np.einsum("kaij,kj->kai", Hd, v)           # d(ddot)/dq
        inv_l = np.divide(1.0, l, out=np.zeros_like(l), where=l > 0.0)
        P = (np.eye(2)[None] - e[:, :, None] * e[:, None, :]) * inv_l[:, None, None]
        de = np.einsum("kab,kbj->kaj", P, G)            # de/dq, (k, 2, c)
        ldot = np.einsum("ka,ka->k", e, ddot)
        dl = np.einsum("ka,kaj->kj", e, G)              # dl/dq, (k, c)
        f = self.k * (l - self.l0) + self.c * ldot
        dldot = np.einsum("ka,kaj->kj", ddot, de) + np.einsum("ka,kaj->kj", e, Hv)
        df = self.k[:, None] * dl + self.c[:, None] * dldot
        dF = e[:, :, None] * df[:, None, :] + f[:, None, None] * de   # d(f e)/dq
        F = f[:, None] * e
        Q_q = -np.einsum("kaj,kai->kji", G, dF) - np.einsum("ka,kaij->kij", F, Hd)
        Ge = np.einsum("kaj,ka->kj", G, e)
        Q_v = -self.c[:, None, None] * Ge[:, :, None] * Ge[:, None, :]
        return Q_q, Q_v

    def energy(self, qx):
        """Potential energy of all springs [J]: a float, or shape (...) for
        rows qx (..., nx)."""
        l = self.lengths(qx)
        return 0.5 * np.sum(self.k * (l - self.l0) ** 2, axis=-1)

    def dissipation(self, qx, vx):
        """Power the dampers dissipate, sum of c ldot^2 [W], shape (N,) for
        rows qx, vx (N, nx)."""
        if not self.damped:
            return np.zeros(qx.shape[0])
        q1, q2 = self.pair.split(qx)
        d = self.pair.difference(q1, q2)                           # (N, k, 2)
        G = self.pair.difference_jac(q1, q2)                       # (N, k, 2, c)
        ddot = np.einsum("nkaj,nkj->nka", G, vx[:, self.cols])
        l = np.sqrt(np.einsum("nka,nka->nk", d, d))[..., None]
        e = np.divide(d, l, out=np.zeros_like(d), where=l > 0.0)
        ldot = np.einsum("nka,nka->nk", e, ddot)
        return np.sum(self.c * ldot ** 2, axis=-1)


class RotationalSpringGroup:
    """Torsional spring-dampers on relative angles theta = phi2 - phi1 - angle.

    Torque -(k theta + c theta') on body 2, the opposite on body 1. Linear:
    Q_q and Q_v are constant. Local coordinates (phi1, phi2).
    """

    def __init__(self, cmap, body1, body2, k, c, angle):
        self.cols = np.stack([body_columns(cmap, body1)[:, 2], body_columns(cmap, body2)[:, 2]], axis=1)
        self.k, self.c, self.angle = (np.asarray(x, float) for x in (k, c, angle))
        pattern = np.array([[-1.0, 1.0], [1.0, -1.0]])  # d(Q1, Q2)/d(phi1, phi2) / k
        self._Q_q = self.k[:, None, None] * pattern[None]
        self._Q_v = self.c[:, None, None] * pattern[None]
        self.damped = bool(np.any(self.c != 0.0))

    def forces(self, qx, vx, t):
        """Local Q, shape (k, 2) [N m]."""
        q, v = qx[self.cols], vx[self.cols]
        tau = self.k * (q[:, 1] - q[:, 0] - self.angle) + self.c * (v[:, 1] - v[:, 0])
        return np.stack([tau, -tau], axis=1)

    def derivatives(self, qx, vx, t):
        """Local (Q_q, Q_v), constant, shape (k, 2, 2)."""
        return self._Q_q, self._Q_v

    def energy(self, qx):
        """Potential energy [J]: a float, or shape (...) for rows qx (..., nx)."""
        q = qx[..., self.cols]
        return 0.5 * np.sum(self.k * (q[..., 1] - q[..., 0] - self.angle) ** 2, axis=-1)

    def dissipation(self, qx, vx):
        """Power the dampers dissipate, sum of c theta'^2 [W], shape (N,) for
        rows vx (N, nx)."""
        v = vx[:, self.cols]
        return np.sum(self.c * (v[..., 1] - v[..., 0]) ** 2, axis=-1)


class TorqueGroup:
    """Applied torques tau(t) on bodies. No q or v dependence."""

    def __init__(self, cmap, body, functions):
        self.cols = body_columns(cmap, body)[:, 2:3]
        self.functions = list(functions)

    def forces(self, qx, vx, t):
        """Local Q, shape (k, 1) [N m]."""
        return np.array([[f.f(t)] for f in self.functions])

    derivatives = None


class StateTorqueGroup:
    """Loads of time and of the motion, tau(t, x) times a direction w(q):

    * a torque on a body (``torque``): w = e_phi of the body;
    * a torque in a revolute joint (``joint_torque``): w = e_phi2 - e_phi1;
    * a force along a sliding joint (``joint_force``): w = grad s, s the
      joint's distance (``model.elements.line_distance``): +tau u on its
      sliding point, -tau u on the line's point, in generalized form;

    x the state variables the expression reads (``StateVariable``: linear in
    q or v, or a sliding joint's distance or speed). Then

        Q = tau w,  Q_q = w (dtau/dq)^T + tau dw/dq,  Q_v = w (dtau/dv)^T

    with dtau/dq = sum_k dtau/dx_k dx_k/dq (the expression's partial
    derivatives, symbolic: ``StateFunction.grads``; dx/dq of a distance is
    grad s, of a speed grad s . v is (d^2 s) v and dx/dv = grad s), and dw/dq
    = d^2 s for a force, 0 for a torque. Local coordinates per instance: the
    coordinates of its direction, then those its variables read, padded by
    the ground's dummy column.

    Attributes
    ----------
    cols : ndarray of intp, shape (k, c)
    targets : list of (int, int) or None
        Per torque, the local columns of the +tau and the -tau body (the
        ground's dummy column for a torque on one body); None for a force.
    """

    def __init__(self, cmap, plus, minus, functions, lines=None):
        n = cmap.n
        from ..model.elements import line_columns
        self.cmap = cmap
        self.functions = list(functions)
        self.lines = list(lines) if lines is not None else [None] * len(self.functions)
        ground_phi = n + 2
        per, self.targets, self._line_cols, self._vars = [], [], [], []
        for p, m, f, line in zip(plus, minus, self.functions, self.lines):
            if line is None:
                own = [int(c) for c in cmap([p, m])[:, 2]]
            else:
                own = line_columns(line, cmap)
            cols = list(own)
            for var in getattr(f, "variables", ()):
                cols += var.columns(cmap)
            cols = list(dict.fromkeys(cols))
            where = {c: a for a, c in enumerate(cols)}
            self.targets.append((where[own[0]], where[own[1]]) if line is None else None)
            self._line_cols.append([where[c] for c in own] if line is not None else None)
            self._vars.append([(var, [where[c] for c in var.columns(cmap)])
                               for var in getattr(f, "variables", ())])
            per.append(cols)
        width = max(len(c) for c in per)
        self.cols = np.array([c + [ground_phi] * (width - len(c)) for c in per], dtype=np.intp)
        self.damped = any(var.level == 1 for v in self._vars for var, _ in v)

    def _tau(self, f, qx, vx, t):
        """tau and, for a state function, the variables' values."""
        if hasattr(f, "variables"):
            x = f.values(qx, vx, self.cmap)
            return f.f(t, x), x
        return f.f(t), None

    def _direction(self, i, qx):
        """(local columns, w, dw/dq or None) of instance i."""
        if self.lines[i] is None:
            a, b = self.targets[i]
            return [a, b], np.array([1.0, -1.0]), None
        from ..model.elements import line_distance
        _, grad, H = line_distance(self.lines[i], qx, self.cmap)
        return self._line_cols[i], grad, H

    def forces(self, qx, vx, t):
        """Local Q, shape (k, c) [N, N m]."""
        out = np.zeros(self.cols.shape)
        for i, f in enumerate(self.functions):
            tau, _ = self._tau(f, qx, vx, t)
            cols, w, _ = self._direction(i, qx)
            np.add.at(out[i], cols, tau * w)
        return out

    def derivatives(self, qx, vx, t):
        """Local (Q_q, Q_v), shape (k, c, c)."""
        from ..model.elements import line_distance
        k, c = self.cols.shape
        Qq, Qv = np.zeros((k, c, c)), np.zeros((k, c, c))
        for i, f in enumerate(self.functions):
            tau, x = self._tau(f, qx, vx, t)
            cols, w, dw = self._direction(i, qx)
            if dw is not None:
                Qq[i][np.ix_(cols, cols)] += tau * dw
            if x is None:
                continue
            dq, dv = np.zeros(c), np.zeros(c)
            for grad, (var, local) in zip(f.grads, self._vars[i]):
                g = grad(t, x)
                if var.line is None:
                    target = dq if var.level == 0 else dv
                    for a, (_, _, coef) in zip(local, var.terms):
                        target[a] += g * coef
                    continue
                _, gs, Hs = line_distance(var.line, qx, self.cmap)
                if var.level == 0:
                    np.add.at(dq, local, g * gs)
                else:
                    np.add.at(dq, local, g * (Hs @ vx[var.columns(self.cmap)]))
                    np.add.at(dv, local, g * gs)
            for a, wa in zip(cols, w):
                Qq[i, a] += wa * dq
                Qv[i, a] += wa * dv
        return Qq, Qv


class PointForceGroup:
    """Forces F(t), fixed in the global frame, at body points.

    Q = J^T F with J = d p / d q_local (``PointSet``): (F, (B u) . F,
    S^T A^T F); Q_q = sum_a F_a d2 p_a / dq2 (for a rigid body the one
    entry d/dphi (B s . F) = -(A s) . F).
    """

    def __init__(self, cmap, points, fx, fy):
        self.points = PointSet(cmap, points)
        self.cols = self.points.cols
        self.fx, self.fy = list(fx), list(fy)

    def _F(self, t):
        return np.array([[fx.f(t), fy.f(t)] for fx, fy in zip(self.fx, self.fy)])

    def forces(self, qx, vx, t):
        """Local Q, shape (k, c) [N, N m]."""
        return np.einsum("kaj,ka->kj", self.points.jac(qx[self.cols]), self._F(t))

    def derivatives(self, qx, vx, t):
        """Local (Q_q, None), Q_q shape (k, c, c)."""
        return np.einsum("ka,kaij->kij", self._F(t), self.points.hess(qx[self.cols])), None


class FrictionGroup:
    """Coulomb friction in joints, from each joint's own reaction.

    A friction load tau acts along the joint's motion coordinate z with
    direction w (as ``StateTorqueGroup``): in a revolute joint z is the
    relative rate omega_2 - omega_1 and w = e_phi2 - e_phi1 (a torque, +tau
    on the second body, -tau on the first); in a prismatic or point_on_line
    joint z is the sliding speed ds/dt and w = grad s (a force along the
    line). The law is the regularised Coulomb-Stribeck law of Andersson,
    Soderberg & Bjorklund (2007), eq. (8), with a viscous term:

        tau = -N mu(z) tanh(z / v_reg) - c z,
        mu(z) = mu_k + (mu_s - mu_k) exp(-(z / v_s)^2)

    with N the normal load, from the joint's multipliers lambda_J: r |lambda_J|
    for a revolute (r the pin radius: the friction torque of a pin pressed
    with the reaction |lambda_J|), |lambda_J| for a sliding joint (its normal
    row's multiplier is the normal force: the row's normal is a unit vector).
    tanh(z/v_reg) replaces sign(z): a joint under a load below mu N "sticks"
    at the creep speed z = v_reg atanh(load / (mu N)), below 2 v_reg for a
    load below 0.96 mu N.

    Derivatives (exact, for the Newton matrix):

        Q = tau w,  Q_q = tau dw/dq + w (dtau/dz) (dz/dq),
        Q_v = w (dtau/dz) w^T,  Q_lambda = w (dtau/dlambda_J)^T

    with dz/dq = (d^2 s) v for a sliding joint (0 for a revolute) and
    dtau/dlambda_J = -mu(z) tanh(z/v_reg) dN/dlambda_J, dN/dlambda_J =
    r lambda_J/|lambda_J| (0 at |lambda_J| = 0, the subgradient).

    Parameters
    ----------
    cmap : CoordinateMap
        The model's body columns (``Model.coordinate_map``).
    plus, minus : sequence of int
        Per instance, the second and first body of a revolute (-1: ground);
        ignored for a sliding joint.
    lines : sequence
        Per instance, None (revolute) or the sliding joint's line geometry
        (``model.elements.line_distance``).
    rows : sequence of sequence of int
        Per instance, the joint's reaction rows of lambda (2 for a revolute,
        the normal row for a sliding joint).
    params : sequence of (mu_k, mu_s, v_s, c, v_reg, r)
        Units: v_s, v_reg in m/s (sliding) or rad/s (revolute); c in N s/m or
        N m s/rad; r in m (1 for a sliding joint).

    References
    ----------
    Andersson, Soderberg & Bjorklund (2007), "Friction models for sliding dry,
    boundary and fluid lubricated contacts", Tribology International 40,
    580-587.
    """

    damped = True
    uses_multipliers = True

    def __init__(self, cmap, plus, minus, lines, rows, params):
        n = cmap.n
        from ..model.elements import line_columns
        self.n, self.cmap, self.lines = n, cmap, list(lines)
        ground_phi = n + 2
        per, self._dir = [], []
        for p, m, line in zip(plus, minus, self.lines):
            if line is None:
                cols = [int(c) for c in cmap([p, m])[:, 2]]
            else:
                cols = line_columns(line, cmap)
            per.append(cols)
        width = max(len(c) for c in per)
        self.cols = np.array([c + [ground_phi] * (width - len(c)) for c in per], dtype=np.intp)
        self.rows = [np.asarray(r, dtype=np.intp) for r in rows]
        self.params = np.asarray(params, float).reshape(-1, 6)

    def _kinematics(self, i, qx, vx):
        """(local columns, w, dw/dq or None, z, dz/dq local) of instance i."""
        if self.lines[i] is None:
            w = np.array([1.0, -1.0])
            return [0, 1], w, None, float(w @ vx[self.cols[i, :2]]), np.zeros(2)
        from ..model.elements import line_distance
        _, grad, H = line_distance(self.lines[i], qx, self.cmap)
        v = vx[self.cols[i, :6]]
        return list(range(6)), grad, H, float(grad @ v), H @ v

    def law(self, i, z, lam_J, slip=None):
        """(tau, dtau/dz, dtau/dlambda_J) of instance i at speed z and
        reaction multipliers lam_J; ``slip`` in [-1, 1] replaces tanh(z/v_reg)
        (and mu(z) is mu_static) for the Coulomb limit at rest (``initial``)."""
        mu_k, mu_s, v_s, c, v_reg, r = self.params[i]
        e = np.exp(-(z / v_s) ** 2) if v_s > 0 else 0.0
        mu = mu_k + (mu_s - mu_k) * e
        dmu = (mu_s - mu_k) * e * (-2.0 * z / v_s ** 2) if v_s > 0 else 0.0
        th = np.tanh(z / v_reg)
        if slip is not None and not np.isnan(slip):
            th, mu, dmu = slip, mu_s, 0.0
        R = float(np.sqrt(lam_J @ lam_J))
        N = r * R
        dN = r * lam_J / R if R > 0.0 else np.zeros_like(lam_J)
        tau = -N * mu * th - c * z
        dz = -N * (dmu * th + mu * (1.0 - th * th) / v_reg) - c
        return tau, dz, -mu * th * dN

    def forces(self, qx, vx, t, lam, slip=None):
        """Local Q, shape (k, c) [N, N m]; ``slip`` (k,) as in :meth:`law`
        (NaN: the law itself)."""
        out = np.zeros(self.cols.shape)
        for i in range(len(self.lines)):
            cols, w, _, z, _ = self._kinematics(i, qx, vx)
            tau, _, _ = self.law(i, z, lam[self.rows[i]], None if slip is None else slip[i])
            out[i, cols] += tau * w
        return out

    def speeds(self, qx, vx, ax=None):
        """Per instance the joint speed z, or with accelerations ``ax`` its
        rate dz/dt = w . a + (dw/dq v) . v, shape (k,)."""
        out = np.zeros(len(self.lines))
        for i in range(len(self.lines)):
            cols, w, dw, z, _ = self._kinematics(i, qx, vx)
            if ax is None:
                out[i] = z
                continue
            c = self.cols[i, cols]
            out[i] = w @ ax[c] + (0.0 if dw is None else vx[c] @ dw @ vx[c])
        return out

    def regularisation(self):
        """v_reg per instance, shape (k,)."""
        return self.params[:, 4].copy()

    def derivatives(self, qx, vx, t, lam):
        """Local (Q_q, Q_v), shape (k, c, c)."""
        k, c = self.cols.shape
        Qq, Qv = np.zeros((k, c, c)), np.zeros((k, c, c))
        for i in range(k):
            cols, w, dw, z, dzq = self._kinematics(i, qx, vx)
            tau, dz, _ = self.law(i, z, lam[self.rows[i]])
            ix = np.ix_(cols, cols)
            if dw is not None:
                Qq[i][ix] += tau * dw
            Qq[i][ix] += dz * np.outer(w, dzq)
            Qv[i][ix] += dz * np.outer(w, w)
        return Qq, Qv

    def multiplier_derivatives(self, qx, vx, t, lam):
        """Per instance, dQ_local/dlambda_J, shape (c, len(rows_J))."""
        out = []
        for i in range(len(self.lines)):
            cols, w, _, z, _ = self._kinematics(i, qx, vx)
            _, _, dl = self.law(i, z, lam[self.rows[i]])
            block = np.zeros((self.cols.shape[1], len(self.rows[i])))
            block[cols] = np.outer(w, dl)
            out.append(block)
        return out

    def dissipation(self, qx, vx, t, lam):
        """Power dissipated, -tau z >= 0, per instance, shape (k,) [W]."""
        out = np.zeros(len(self.lines))
        for i in range(len(self.lines)):
            _, _, _, z, _ = self._kinematics(i, qx, vx)
            tau, _, _ = self.law(i, z, lam[self.rows[i]])
            out[i] = -tau * z
        return out
