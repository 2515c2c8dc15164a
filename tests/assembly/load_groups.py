"""The applied loads as structs of arrays, built from the model for the
oracle (``force_oracle``): every instance of one load type at once, with its
columns ``cols`` (k, c) into q_ext = [q, 0, 0, 0] (the ground's three zeros
last). The package packs its loads from the model by its kernel families
(``mbdsl/kernels/loads``); these are the test's own reading of the same
model, so that the kernels are checked against data they did not pack.

The equations each group's docstring states are the oracle's; the kernels'
modules state the same ones.
"""

from __future__ import annotations

import numpy as np

from mbdsl.assembly.points import PointSet, body_columns
from mbdsl.model.elements import GROUND, JointForce, JointTorque

__all__ = ["load_groups", "SpringDamperGroup", "RotationalSpringGroup", "TorqueGroup",
           "StateTorqueGroup", "StateRateGroup", "PointForceGroup", "FrictionGroup"]


def load_groups(system) -> list:
    """The groups of the system's model's loads (contacts and flexible beams
    aside: the system's own groups), in the kernels' order."""
    cmap, forces = system.cmap, system.model.forces
    kinds = lambda *k: [f for f in forces if f.kind in k]     # noqa: E731
    out = []
    springs = kinds("spring")
    if springs:
        out.append(SpringDamperGroup(cmap, [s.first for s in springs], [s.second for s in springs],
                                     [s.k for s in springs], [s.c for s in springs],
                                     [s.length for s in springs]))
    rsprings = kinds("rotational")
    if rsprings:
        out.append(RotationalSpringGroup(
            cmap, [s.joint.first.body for s in rsprings], [s.joint.second.body for s in rsprings],
            [s.k for s in rsprings], [s.c for s in rsprings], [s.angle for s in rsprings]))
    torques = kinds("torque")
    if torques:
        out.append(TorqueGroup(cmap, [f.body for f in torques], [f.function for f in torques]))
    state = kinds("state_torque", "joint_torque", "joint_force")
    if state:
        out.append(StateTorqueGroup(
            cmap, [f.joint.second.body if isinstance(f, JointTorque) else getattr(f, "body", GROUND)
                   for f in state],
            [f.joint.first.body if isinstance(f, JointTorque) else GROUND for f in state],
            [f.function for f in state],
            [f.joint.line if isinstance(f, JointForce) else None for f in state]))
    if system.model.states:
        out.append(StateRateGroup(cmap, system.model.states))
    pforces = kinds("point_force")
    if pforces:
        out.append(PointForceGroup(cmap, [f.point for f in pforces], [f.fx for f in pforces],
                                   [f.fy for f in pforces]))
    frictions = kinds("friction")
    if frictions:
        def rows(j):
            r0 = system.joint_rows[j.name]
            return [r0, r0 + 1] if j.kind == "revolute" else [r0]
        out.append(FrictionGroup(
            cmap, [f.joint.second.body for f in frictions], [f.joint.first.body for f in frictions],
            [None if f.joint.kind == "revolute" else f.joint.line for f in frictions],
            [rows(f.joint) for f in frictions],
            [(f.mu, f.mu_static, f.v_stribeck, f.viscous, f.v_reg, f.radius) for f in frictions]))
    return out


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

    def __init__(self, cmap, plus, minus, functions, lines=None, columns=None):
        n = cmap.n
        from mbdsl.model.elements import line_columns
        self.cmap = cmap
        self.functions = list(functions)
        self.lines = list(lines) if lines is not None else [None] * len(self.functions)
        ground_phi = n + 2
        per, self.targets, self.line_cols, self.variables = [], [], [], []
        columns = columns or [None] * len(self.functions)
        for p, m, f, line, pair in zip(plus, minus, self.functions, self.lines, columns):
            if pair is not None:
                own = list(pair)
            elif line is None:
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


class StateRateGroup(StateTorqueGroup):
    """The rates f(t, x) of first-order states: the generalized force on the
    state's integral's column, the last n_states of q (``FirstOrderState``):
    Q = f e_s, Q_q = e_s (df/dq)^T, Q_v = e_s (df/dv)^T; no power (a rate is
    no load)."""

    def __init__(self, cmap, states):
        n = cmap.n
        first = n - len(states)
        super().__init__(cmap, [None] * len(states), [None] * len(states),
                         [s.function for s in states],
                         columns=[(first + k, n + 2) for k in range(len(states))])


class PointForceGroup:
    """Forces F in world axes at body points, of time or of time and the state.

    Q = J^T F with J = d p / d q_local (``PointSet``): (F, (B u) . F,
    S^T A^T F); Q_q = sum_a F_a d2 p_a / dq2 (for a rigid body the one
    entry d/dphi (B s . F) = -(A s) . F).
    """

    state_dependent = True

    def __init__(self, cmap, points, fx, fy):
        self.cmap = cmap
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
        from mbdsl.model.elements import line_columns
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
