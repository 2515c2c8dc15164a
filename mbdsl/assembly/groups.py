"""Element groups: every instance of one element type evaluated at once.

Each group stores its instances as a struct of arrays (body columns,
body-fixed vectors, parameters) built once, and evaluates with vectorised
numpy. A constraint group returns *local* arrays over the ``c`` coordinates
it touches (columns ``cols``, shape (k, c), into the extended coordinate
vector q_ext = [q, 0, 0, 0], where the three trailing zeros are the ground):

* ``phi``  (k, r)        constraint values
* ``jac``  (k, r, c)     d phi / d q_local
* ``hess`` (k, r, c, c)  d^2 phi / d q_local^2 (None for linear groups)

and the system scatters them. All formulas are in absolute planar
coordinates (Haug, Computer-Aided Kinematics and Dynamics of Mechanical
Systems, ch. 3; Nikravesh, Computer-Aided Analysis of Mechanical Systems,
ch. 4): A(phi) is the rotation matrix, B(phi) = dA/dphi, and
d^2(A s)/dphi^2 = -A s.

Shapes: k instances, r rows per instance, c local coordinates.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rot", "drot", "body_columns", "CoincidenceGroup", "PointOnLineGroup", "LinearConstraintGroup",
           "SpringDamperGroup", "RotationalSpringGroup",
           "TorqueGroup", "PointForceGroup"]


def rot(phi: np.ndarray, s: np.ndarray) -> np.ndarray:
    """A(phi) s for arrays: phi shape (k,), s shape (k, 2) -> (k, 2)."""
    c, si = np.cos(phi), np.sin(phi)
    out = np.empty_like(s)
    out[:, 0] = c * s[:, 0] - si * s[:, 1]
    out[:, 1] = si * s[:, 0] + c * s[:, 1]
    return out


def drot(phi: np.ndarray, s: np.ndarray) -> np.ndarray:
    """B(phi) s = dA/dphi s, shape (k, 2)."""
    c, si = np.cos(phi), np.sin(phi)
    out = np.empty_like(s)
    out[:, 0] = -si * s[:, 0] - c * s[:, 1]
    out[:, 1] = c * s[:, 0] - si * s[:, 1]
    return out


def body_columns(n: int, bodies) -> np.ndarray:
    """Columns (x, y, phi) in q_ext of body indices (ground = -1 -> n..n+2), shape (k, 3)."""
    b = np.asarray(bodies, dtype=np.intp)
    base = np.where(b < 0, n, 3 * b)
    return base[:, None] + np.arange(3)[None, :]


class CoincidenceGroup:
    """Two points coincide (revolute, and the first two rows of fixed).

    Phi = r2 + A2 s2 - r1 - A1 s1 (2 rows). Local coordinates
    (x1, y1, phi1, x2, y2, phi2).
    """

    r = 2

    def __init__(self, n, rows, body1, s1, body2, s2):
        self.rows = np.asarray(rows, dtype=np.intp).reshape(-1, 2)
        self.cols = np.concatenate([body_columns(n, body1), body_columns(n, body2)], axis=1)
        self.s1, self.s2 = np.asarray(s1, float).reshape(-1, 2), np.asarray(s2, float).reshape(-1, 2)
        k = len(self.rows)
        self._jac = np.zeros((k, 2, 6))
        self._jac[:, 0, 0] = self._jac[:, 1, 1] = -1.0
        self._jac[:, 0, 3] = self._jac[:, 1, 4] = 1.0
        self._hess = np.zeros((k, 2, 6, 6))
        self.time_dependent = False

    def phi(self, qx, t):
        """Constraint values, shape (k, 2) [m]."""
        q = qx[self.cols]
        # Differences of the (possibly large) reference coordinates first: exact
        # when the two bodies are within a factor 2 of each other (Sterbenz), so
        # the round-off is eps times the point offsets, not eps |r|. Index-3
        # methods divide Phi by beta h^2, so this round-off reaches the velocities.
        return (q[:, 3:5] - q[:, 0:2]) + (rot(q[:, 5], self.s2) - rot(q[:, 2], self.s1))

    def jac(self, qx):
        """Local Jacobian, shape (k, 2, 6)."""
        q = qx[self.cols]
        J = self._jac
        J[:, :, 2] = -drot(q[:, 2], self.s1)
        J[:, :, 5] = drot(q[:, 5], self.s2)
        return J

    def hess(self, qx):
        """Local Hessian, shape (k, 2, 6, 6): only the phi-phi entries."""
        q = qx[self.cols]
        H = self._hess
        H[:, :, 2, 2] = rot(q[:, 2], self.s1)
        H[:, :, 5, 5] = -rot(q[:, 5], self.s2)
        return H


class PointOnLineGroup:
    """Point P of body p stays on the line through point L of body l.

    Phi = n . (rP + AP sP - rL - AL sL), n = AL n0 the line's unit normal
    (1 row). Local coordinates (xP, yP, phiP, xL, yL, phiL).
    """

    r = 1

    def __init__(self, n, rows, body_p, s_p, body_l, s_l, normal):
        self.rows = np.asarray(rows, dtype=np.intp).reshape(-1, 1)
        self.cols = np.concatenate([body_columns(n, body_p), body_columns(n, body_l)], axis=1)
        self.sp = np.asarray(s_p, float).reshape(-1, 2)
        self.sl = np.asarray(s_l, float).reshape(-1, 2)
        self.n0 = np.asarray(normal, float).reshape(-1, 2)
        k = len(self.rows)
        self._jac = np.zeros((k, 1, 6))
        self._hess = np.zeros((k, 1, 6, 6))
        self.time_dependent = False

    def _parts(self, qx):
        q = qx[self.cols]
        nvec = rot(q[:, 5], self.n0)
        d = (q[:, 0:2] - q[:, 3:5]) + (rot(q[:, 2], self.sp) - rot(q[:, 5], self.sl))
        return q, nvec, d

    def phi(self, qx, t):
        """Constraint values, shape (k, 1) [m]."""
        _, nvec, d = self._parts(qx)
        return np.einsum("ka,ka->k", nvec, d)[:, None]

    def jac(self, qx):
        """Local Jacobian, shape (k, 1, 6)."""
        q, nvec, d = self._parts(qx)
        Bn = drot(q[:, 5], self.n0)
        J = self._jac
        J[:, 0, 0:2] = nvec
        J[:, 0, 2] = np.einsum("ka,ka->k", nvec, drot(q[:, 2], self.sp))
        J[:, 0, 3:5] = -nvec
        J[:, 0, 5] = np.einsum("ka,ka->k", Bn, d) - np.einsum("ka,ka->k", nvec,
                                                              drot(q[:, 5], self.sl))
        return J

    def hess(self, qx):
        """Local Hessian, shape (k, 1, 6, 6)."""
        q, nvec, d = self._parts(qx)
        Bn = drot(q[:, 5], self.n0)
        BsP = drot(q[:, 2], self.sp)
        BsL = drot(q[:, 5], self.sl)
        AsL = rot(q[:, 5], self.sl)
        AsP = rot(q[:, 2], self.sp)
        H = self._hess
        H[:, 0, 0:2, 5] = H[:, 0, 5, 0:2] = Bn
        H[:, 0, 3:5, 5] = H[:, 0, 5, 3:5] = -Bn
        H[:, 0, 2, 2] = -np.einsum("ka,ka->k", nvec, AsP)
        H[:, 0, 2, 5] = H[:, 0, 5, 2] = np.einsum("ka,ka->k", Bn, BsP)
        H[:, 0, 5, 5] = (-np.einsum("ka,ka->k", nvec, d)
                         - 2.0 * np.einsum("ka,ka->k", Bn, BsL)
                         + np.einsum("ka,ka->k", nvec, AsL))
        return H


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
    hess = None

    def __init__(self, n, rows, cols, coefs, offset, functions):
        self.rows = np.asarray(rows, dtype=np.intp).reshape(-1, 1)
        self.cols = np.asarray(cols, dtype=np.intp).reshape(-1, 2)
        self.coefs = np.asarray(coefs, float).reshape(-1, 2)
        self.offset = np.asarray(offset, float)
        self.functions = list(functions)
        self._jac = self.coefs[:, None, :].copy()
        self.time_dependent = any(f is not None for f in self.functions)

    def _f(self, t, which):
        return np.array([0.0 if f is None else getattr(f, which)(t) for f in self.functions])

    def phi(self, qx, t):
        """Constraint values, shape (k, 1) [m or rad]."""
        val = np.einsum("kj,kj->k", self.coefs, qx[self.cols]) - self.offset
        if self.time_dependent:
            val = val - self._f(t, "f")
        return val[:, None]

    def jac(self, qx):
        """Constant local Jacobian, shape (k, 1, 2)."""
        return self._jac

    def phi_t(self, t):
        """d Phi / dt, shape (k, 1)."""
        return -self._f(t, "df")[:, None]

    def phi_tt(self, t):
        """d^2 Phi / dt^2, shape (k, 1)."""
        return -self._f(t, "ddf")[:, None]


# ---------------------------------------------------------------------------
# Force groups: local generalized forces Q (k, c) and their derivatives
# Q_q, Q_v (k, c, c), scattered by the system with accumulation.
# ---------------------------------------------------------------------------

class SpringDamperGroup:
    """Translational spring-dampers between point pairs.

    d = r2 + A2 s2 - r1 - A1 s1, l = |d|, e = d / l, ldot = e . d',
    tension f = k (l - l0) + c ldot, generalized force Q = -G^T (f e) with
    G = dd/dq_local (2 x 6). Q_q follows from the chain rule through e, l,
    ldot and the Hessians of d; Q_v = -c (G^T e)(G^T e)^T.
    """

    def __init__(self, n, body1, s1, body2, s2, k, c, length):
        self.cols = np.concatenate([body_columns(n, body1), body_columns(n, body2)], axis=1)
        self.s1, self.s2 = np.asarray(s1, float).reshape(-1, 2), np.asarray(s2, float).reshape(-1, 2)
        self.k, self.c, self.l0 = (np.asarray(x, float) for x in (k, c, length))
        self.damped = bool(np.any(self.c != 0.0))

    def _kin(self, qx, vx):
        q, v = qx[self.cols], vx[self.cols]
        As1, As2 = rot(q[:, 2], self.s1), rot(q[:, 5], self.s2)
        d = (q[:, 3:5] + As2) - (q[:, 0:2] + As1)
        kk = len(q)
        G = np.zeros((kk, 2, 6))
        G[:, 0, 0] = G[:, 1, 1] = -1.0
        G[:, 0, 3] = G[:, 1, 4] = 1.0
        G[:, :, 2] = -drot(q[:, 2], self.s1)
        G[:, :, 5] = drot(q[:, 5], self.s2)
        ddot = np.einsum("kaj,kj->ka", G, v)
        l = np.sqrt(np.einsum("ka,ka->k", d, d))
        e = d / l[:, None]
        return q, v, As1, As2, d, G, ddot, l, e

    def lengths(self, qx):
        """Current lengths l, shape (k,) [m]."""
        return self._kin(qx, np.zeros_like(qx))[7]

    def forces(self, qx, vx, t):
        """Local Q, shape (k, 6) [N, N m]."""
        _, _, _, _, d, G, ddot, l, e = self._kin(qx, vx)
        f = self.k * (l - self.l0)
        if self.damped:
            f = f + self.c * np.einsum("ka,ka->k", e, ddot)
        return -np.einsum("kaj,ka->kj", G, f[:, None] * e)

    def derivatives(self, qx, vx, t):
        """Local (Q_q, Q_v), each shape (k, 6, 6)."""
        q, v, As1, As2, d, G, ddot, l, e = self._kin(qx, vx)
        kk = len(q)
        # Hessians of d's components: only (phi1, phi1) = +A1 s1, (phi2, phi2) = -A2 s2.
        Hv = np.zeros((kk, 2, 6))            # [H_a v]_a, rows a
        Hv[:, :, 2] = As1 * v[:, 2:3]
        Hv[:, :, 5] = -As2 * v[:, 5:6]
        P = (np.eye(2)[None] - e[:, :, None] * e[:, None, :]) / l[:, None, None]
        de = np.einsum("kab,kbj->kaj", P, G)            # de/dq, (k, 2, 6)
        ldot = np.einsum("ka,ka->k", e, ddot)
        dl = np.einsum("ka,kaj->kj", e, G)              # dl/dq, (k, 6)
        f = self.k * (l - self.l0) + self.c * ldot
        dldot = np.einsum("ka,kaj->kj", ddot, de) + np.einsum("ka,kaj->kj", e, Hv)
        df = self.k[:, None] * dl + self.c[:, None] * dldot
        dF = e[:, :, None] * df[:, None, :] + f[:, None, None] * de   # d(f e)/dq
        F = f[:, None] * e
        Q_q = -np.einsum("kaj,kai->kji", G, dF)
        Q_q[:, 2, 2] -= np.einsum("ka,ka->k", F, As1)   # - sum_a F_a H_a
        Q_q[:, 5, 5] += np.einsum("ka,ka->k", F, As2)
        Ge = np.einsum("kaj,ka->kj", G, e)
        Q_v = -self.c[:, None, None] * Ge[:, :, None] * Ge[:, None, :]
        return Q_q, Q_v

    def energy(self, qx):
        """Potential energy of all springs [J]."""
        l = self.lengths(qx)
        return float(0.5 * np.sum(self.k * (l - self.l0) ** 2))


class RotationalSpringGroup:
    """Torsional spring-dampers on relative angles theta = phi2 - phi1 - angle.

    Torque -(k theta + c theta') on body 2, the opposite on body 1. Linear:
    Q_q and Q_v are constant. Local coordinates (phi1, phi2).
    """

    def __init__(self, n, body1, body2, k, c, angle):
        self.cols = np.stack([body_columns(n, body1)[:, 2], body_columns(n, body2)[:, 2]], axis=1)
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
        """Potential energy [J]."""
        q = qx[self.cols]
        return float(0.5 * np.sum(self.k * (q[:, 1] - q[:, 0] - self.angle) ** 2))


class TorqueGroup:
    """Applied torques tau(t) on bodies. No q or v dependence."""

    def __init__(self, n, body, functions):
        self.cols = body_columns(n, body)[:, 2:3]
        self.functions = list(functions)

    def forces(self, qx, vx, t):
        """Local Q, shape (k, 1) [N m]."""
        return np.array([[f.f(t)] for f in self.functions])

    derivatives = None


class PointForceGroup:
    """Forces F(t), fixed in the global frame, at body points.

    Q = (F, (B s) . F); Q_q has one entry, d/dphi (B s . F) = -(A s) . F.
    """

    def __init__(self, n, body, s, fx, fy):
        self.cols = body_columns(n, body)
        self.s = np.asarray(s, float).reshape(-1, 2)
        self.fx, self.fy = list(fx), list(fy)

    def _F(self, t):
        return np.array([[fx.f(t), fy.f(t)] for fx, fy in zip(self.fx, self.fy)])

    def forces(self, qx, vx, t):
        """Local Q, shape (k, 3) [N, N m]."""
        F = self._F(t)
        phi = qx[self.cols[:, 2]]
        return np.concatenate([F, np.einsum("ka,ka->k", drot(phi, self.s), F)[:, None]], axis=1)

    def derivatives(self, qx, vx, t):
        """Local (Q_q, None), Q_q shape (k, 3, 3)."""
        F = self._F(t)
        phi = qx[self.cols[:, 2]]
        Q_q = np.zeros((len(F), 3, 3))
        Q_q[:, 2, 2] = -np.einsum("ka,ka->k", rot(phi, self.s), F)
        return Q_q, None
