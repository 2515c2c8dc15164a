"""Load groups: every instance of one applied load type at once.

Each group stores its instances as a struct of arrays (body columns,
body-fixed vectors, parameters) built once: the model data
``packing.PackedModel`` packs for the kernels. A group (columns ``cols``
(k, c) into the extended coordinate vector q_ext = [q, 0, 0, 0], where the
three trailing zeros are the ground) holds data only, and states its
element's equations: the kernels of ``mbdsl/kernels`` are the one evaluation
of Q and its derivatives (``AssembledSystem.Q`` and the functions after it),
and ``tests/assembly/force_oracle.py`` an independent numpy one they are
tested against. The joints and drivers have no group: their kernel families
pack them from the model (``kernels/joints``). All formulas are in absolute planar
coordinates (Haug, Computer-Aided Kinematics and Dynamics of Mechanical
Systems, ch. 3; Nikravesh, Computer-Aided Analysis of Mechanical Systems,
ch. 4): A(phi) is the rotation matrix, B(phi) = dA/dphi, and
d^2(A s)/dphi^2 = -A s.

Shapes: k instances, r rows per instance, c local coordinates.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rot", "drot", "body_columns", "PointSet", "SpringDamperGroup", "RotationalSpringGroup",
           "TorqueGroup", "StateTorqueGroup", "PointForceGroup", "FrictionGroup"]


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
    * jacobian: [I, B u, A S]                             (k, 2, 3 + e)
    * Hessian:  d2/dphi2 = -A u, d2/dphi dq_e = B S       (k, 2, 3 + e, 3 + e)

    (the jacobian and Hessian are the kernels', ``kernels.geometry._Au`` and the
    elastic terms of the joints and loads)

    (Shabana, Dynamics of Multibody Systems, sec. 5.3: the position of an
    arbitrary point of a deformable body in the floating frame.)
    """

    def __init__(self, cmap, points):
        n = cmap.n
        points = list(points)
        #: the points (``model.elements.PointRef``), for the kernels' packing
        self.refs = points
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

    def local(self, q) -> np.ndarray:
        """u = s + S q_e in the body frame, shape (k, 2), from local coordinates q (k, c)."""
        if not self.flexible:
            return self.s
        return self.s + np.einsum("kaj,...kj->...ka", self.S, q[..., 3:])

    def position(self, q) -> np.ndarray:
        """Global positions, shape (..., k, 2) for q of shape (..., k, c)."""
        return q[..., 0:2] + rot(q[..., 2], self.local(q))


class _PointPair:
    """Two point sets side by side, local coordinates (q_1 [c1], q_2 [c2]):
    d = p2 - p1 of a spring-damper."""

    def __init__(self, cmap, first, second):
        self.P1, self.P2 = PointSet(cmap, first), PointSet(cmap, second)
        self.c1 = self.P1.c
        self.cols = np.concatenate([self.P1.cols, self.P2.cols], axis=1)


# ---------------------------------------------------------------------------
# Force groups: local generalized forces Q (k, c) and their derivatives
# Q_q, Q_v (k, c, c), scattered by the system with accumulation.
# ---------------------------------------------------------------------------

class SpringDamperGroup:
    """Translational spring-dampers between point pairs.

    d = p2 - p1, l = |d|, e = d / l, ldot = e . d', tension
    f = k (l - l0) + c ldot, generalized force Q = -D^T (f e) with
    D = dd/dq_local. Q_q follows from the chain rule through e, l, ldot and
    the Hessians of d; Q_v = -c (D^T e)(D^T e)^T. Two coincident points have
    no direction and no force along it (the time loop lands a step there as
    an event, docs/contact.md). The points may lie on flexible beams
    (``PointSet``). Evaluated by ``kernels.loads.spring_damper._springs_add`` and
    ``_emit_force``.
    """

    state_dependent = True

    def __init__(self, cmap, first, second, k, c, length):
        self.pair = _PointPair(cmap, first, second)
        self.cols = self.pair.cols
        self.k, self.c, self.l0 = (np.asarray(x, float) for x in (k, c, length))
        #: the direction held while a step is landed on a pass of the points
        #: (``kernels.loads.spring_damper._free_length``), (k, 2); zeros: none, the physical law
        self.held = np.zeros((len(self.k), 2))
        self.damped = bool(np.any(self.c != 0.0))


class RotationalSpringGroup:
    """Torsional spring-dampers on relative angles theta = phi2 - phi1 - angle.

    Torque -(k theta + c theta') on body 2, the opposite on body 1. Linear:
    Q_q = k [[-1, 1], [1, -1]] and Q_v = c [[-1, 1], [1, -1]] over the local
    coordinates (phi1, phi2).
    """

    state_dependent = True

    def __init__(self, cmap, body1, body2, k, c, angle):
        self.cols = np.stack([body_columns(cmap, body1)[:, 2], body_columns(cmap, body2)[:, 2]], axis=1)
        self.k, self.c, self.angle = (np.asarray(x, float) for x in (k, c, angle))
        self.damped = bool(np.any(self.c != 0.0))


class TorqueGroup:
    """Applied torques tau(t) on bodies (functions of time, or constant). No
    q or v dependence."""

    state_dependent = False

    def __init__(self, cmap, body, functions):
        self.cols = body_columns(cmap, body)[:, 2:3]
        self.functions = list(functions)


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
    derivatives, symbolic: ``StateFunction.grad_exprs``; dx/dq of a distance
    is grad s, of a speed grad s . v is (d^2 s) v and dx/dv = grad s), and
    dw/dq = d^2 s for a force, 0 for a torque. Local coordinates per
    instance: the coordinates of its direction, then those its variables
    read, padded by the ground's dummy column.

    Attributes
    ----------
    cols : ndarray of intp, shape (k, c)
    targets : list of (int, int) or None
        Per torque, the local columns of the +tau and the -tau body (the
        ground's dummy column for a torque on one body); None for a force.
    """

    state_dependent = True

    def __init__(self, cmap, plus, minus, functions, lines=None):
        n = cmap.n
        from ..model.elements import line_columns
        self.cmap = cmap
        self.functions = list(functions)
        self.lines = list(lines) if lines is not None else [None] * len(self.functions)
        ground_phi = n + 2
        per, self.targets, self.line_cols, self.variables = [], [], [], []
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
            self.line_cols.append([where[c] for c in own] if line is not None else None)
            self.variables.append([(var, [where[c] for c in var.columns(cmap)])
                                   for var in getattr(f, "variables", ())])
            per.append(cols)
        width = max(len(c) for c in per)
        self.cols = np.array([c + [ground_phi] * (width - len(c)) for c in per], dtype=np.intp)
        self.damped = any(var.level == 1 for v in self.variables for var, _ in v)


class PointForceGroup:
    """Forces F(t), fixed in the global frame, at body points.

    Q = J^T F with J = d p / d q_local (``PointSet``): (F, (B u) . F,
    S^T A^T F); Q_q = sum_a F_a d2 p_a / dq2 (for a rigid body the one
    entry d/dphi (B s . F) = -(A s) . F).
    """

    state_dependent = True

    def __init__(self, cmap, points, fx, fy):
        self.points = PointSet(cmap, points)
        self.cols = self.points.cols
        self.fx, self.fy = list(fx), list(fy)


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
    state_dependent = True

    def __init__(self, cmap, plus, minus, lines, rows, params):
        n = cmap.n
        from ..model.elements import line_columns
        self.n, self.cmap, self.lines = n, cmap, list(lines)
        ground_phi = n + 2
        per = []
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

    def regularisation(self):
        """v_reg per instance, shape (k,)."""
        return self.params[:, 4].copy()
