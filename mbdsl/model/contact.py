"""Compliant contact and joint limits: one-sided gaps and their force law.

A contact or a joint limit is a set of one-sided *gaps* g(q) [m or rad]:
open for g > 0, penetrated by delta = -g for g < 0. Four gap geometries,
between rigid bodies (or the ground):

* ``line``: a circle (centre P on one body, radius r) and a line fixed in
  another body (point L, direction u0): g = n . (p_P - p_L) - r with n =
  A(phi_L) (-u0_y, u0_x), the line's left normal (the circle stays on the
  left of the line's direction; a floor along +x has the circle above it);
* ``circle``: a pin (centre P, radius r) in a circular hole (centre C,
  radius R): g = (R - r) - |p_P - p_C|, a revolute joint with radial
  clearance R - r (Flores, Ambrosio, Claro & Lankarani, Kinematics and
  Dynamics of Multibody Systems with Imperfect Joints, Springer 2008, ch. 3);
* ``angle``: a revolute joint's relative angle theta = phi_2 - phi_1 against a
  bound: g = theta - lower, or upper - theta;
* ``slide``: a sliding joint's distance s (:func:`~.elements.line_distance`)
  against a bound, likewise.

and two between spatial bodies, held in director coordinates
(``model.spatial``: r and the body axes a_1..a_3, so that a body's point
r + A s and direction A s are linear in q):

* ``dot``: sign (U . W - offset), U and W each a sum of the two bodies'
  points or directions and a constant: a sphere (centre P, radius r) on a
  plane fixed in a body or the ground (point L, unit normal n0 in its
  frame), g = (A_L n0) . (p_P - p_L) - r, the sphere on the normal's side;
  and a sliding joint's distance u . (p_1 - p_2) (u the line's direction,
  turning with the second body, as ``J.distance``) against a bound. Its
  gradient is linear in q and its Hessian constant (Haug 1989, sec. 9.4: the
  dot-2 constraint);
* ``spatial_angle``: a spatial revolute's (or cylindrical's) angle
  theta = atan2(G_1 . F_2, F_1 . F_2) about its axis
  (``kernels/joints/spatial_angles.py``, as ``J.angle``) against a bound,
  within (-pi, pi).

The force law, along the gap's normal, is Hunt and Crossley's (Hunt &
Crossley 1975, J. Appl. Mech. 42, 440) with a restitution-derived damping as
in Lankarani & Nikravesh (1990, J. Mech. Des. 112, 369) and Flores et al.
(2011, Nonlinear Dyn. 65, 369):

    f = K delta^n (1 + chi ddelta/dt / v_impact),   f >= 0,

with v_impact the approach speed ddelta/dt when the gap closed (a state of the
contact, set by the event that closes it), K the stiffness [N/m^n, or N m/rad^n
for an angle] and n the exponent (1.5: Hertz's sphere). The force is cut at
zero (no adhesion) in the restitution phase.

chi follows from the coefficient of restitution e exactly. Scaled by the
impact speed and the stiffness, the impact of a one-degree-of-freedom body
under this law is x'' = -x^n (1 + chi x'), x(0) = 0, x'(0) = 1; dividing by x'
and integrating over the contact, the stiffness terms cancel (x returns to 0)
and the exit speed e satisfies

    chi (1 + e) = ln((1 + chi) / (1 - chi e)),

independent of n (the force stays positive: 1 - chi e > 0). Its root chi > 0
is :func:`damping_factor`. Lankarani-Nikravesh's chi = 3 (1 - e^2) / 4 is its
limit for e -> 1 and Flores et al.'s chi = 8 (1 - e) / (5 e) a fit of it
(7 % high at e = 0.8, 30 % at e = 0.2). A contact in a mechanism deviates from
the one-body impact only through the other forces acting during the
millisecond of contact.

A friction coefficient mu adds the regularised Coulomb force -mu f
tanh(v_t / v_reg) along the contact's tangent, v_t = w(q) . v the slip speed
of the two bodies' material points at the contact point c = p_P - r nu (nu
the unit normal from the first body's surface: the line's normal, or -e from
the pin's centre towards the hole's), tau = (-nu_y, nu_x) and

    w = (-tau, -nu . (c - r_1), tau, nu . (A_2 s_P) - r)

over (x, y, phi of the first body, then of the second). The kernels of
``kernels/loads/contact.py`` evaluate the gaps and the law (``_gap``,
``_slip``, ``_contact_law``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import Span
from .elements import GROUND

__all__ = ["Contact", "damping_factor", "gap_columns", "contact_duration", "SPEED_FLOOR"]

#: Approach speeds below this [m/s or rad/s] are taken as this speed in the
#: damping term chi ddelta/dt / v_impact: a contact that closes at rest (a body
#: settling on a floor, a run starting in contact) gets the damping of a
#: 1 mm/s impact rather than an unbounded one.
SPEED_FLOOR = 1e-3


@dataclass(frozen=True)
class Contact:
    """A compliant contact (``contact``), joint limit (``limit``) or a rope
    (``rope``, ``cable``: a tension-only spring-damper between two points,
    a point in a hole of the rope's length about the other).

    Attributes
    ----------
    name : str
    kind : {"contact", "limit", "rope", "cable"}
    gaps : tuple of (geometry, data, label)
        One-sided gaps (module notes): geometry in {"line", "circle",
        "angle", "slide"}; data: ``line`` (body L, s_L, body P, s_P, n0, r),
        ``circle`` (body C, s_C, body P, s_P, clearance, r), ``angle`` (body
        1, None, body 2, None, bound, sign), ``slide`` (body L, s_L, body P,
        s_P, u0, bound, sign); label names the gap
        in events (``"lower"``/``"upper"`` for a limit, ``""`` for a contact).
    k : float
        Stiffness K [N/m^n; N m/rad^n for an angle].
    exponent : float
        n (1.5: Hertz; 1: linear).
    restitution : float
        Coefficient of restitution e in (0, 1].
    span : Span or None
    mu : float
        Coulomb friction coefficient at a contact (0: frictionless; limits
        have none).
    v_reg : float [m/s]
        Regularisation speed of the friction law -mu f tanh(v_t / v_reg).
    viscous : float [N s/m]
        A linear damping c ddelta/dt added to the law (a rope's c; 0 for
        contacts and limits, whose damping is the restitution's).
    """

    name: str
    kind: str
    gaps: tuple
    k: float
    exponent: float
    restitution: float
    span: Span | None = None
    mu: float = 0.0
    v_reg: float = 1e-4
    viscous: float = 0.0

    @property
    def damping(self) -> float:
        """chi of the force law (:func:`damping_factor`)."""
        return damping_factor(self.restitution, self.exponent)


@functools.lru_cache(maxsize=None)
def damping_factor(restitution: float, exponent: float = 1.5) -> float:
    """chi such that the Hunt-Crossley law restitutes e exactly (module notes).

    Parameters
    ----------
    restitution : float in (0, 1]
    exponent : float, >= 1
        Checked only: chi does not depend on it.

    Returns
    -------
    float, >= 0 (0 for e = 1)

    Raises
    ------
    ValueError
        For e outside (0, 1] or an exponent below 1.
    """
    from scipy.optimize import brentq
    e, n = float(restitution), float(exponent)
    if not (0.0 < e <= 1.0):
        raise ValueError(f"the coefficient of restitution must be in (0, 1], got {e:g}")
    if not n >= 1.0:
        raise ValueError(f"the contact exponent must be at least 1, got {n:g}")
    if e == 1.0:
        return 0.0
    if 1.0 - e < 1e-5:      # the series: chi = 3 (1 - e^2) / (2 (1 + e^3)) + O((1 - e)^2)
        return 3.0 * (1.0 - e * e) / (2.0 * (1.0 + e ** 3))

    # in s = -ln(1 - chi e), so that a small e (chi -> 1/e, 1 - chi e below
    # round-off) stays representable: chi = (1 - exp(-s)) / e
    def f(s):
        """The relation in s = -ln(1 - chi e); zero at the root."""
        chi = -math.expm1(-s) / e
        return chi * (1.0 + e) - math.log1p(chi) - s
    s = brentq(f, 1e-3 * (1.0 - e) * e, (1.0 + e) / e + 50.0, xtol=1e-15, rtol=1e-13)
    return -math.expm1(-s) / e


def contact_duration(k: float, exponent: float, mass: float, speed: float) -> float:
    """How long an undamped impact lasts under f = K delta^n [s].

    A mass m [kg] (or inertia [kg m^2] for an angle) meeting the contact at
    speed v [m/s or rad/s]: m x'' = -K x^n, x(0) = 0, x'(0) = v. Energy gives
    the largest penetration x_max = ((n + 1) m v^2 / (2 K))^(1/(n+1)) and the
    time in contact T = 2 (x_max / v) sqrt(pi) Gamma(1 + 1/(n+1)) /
    Gamma(1/2 + 1/(n+1)) (Goldsmith, Impact, 1960, ch. 4; for n = 3/2, Hertz's
    T = 2.94 x_max / v); for n = 1 it is pi sqrt(m / K) at any speed. The
    law's damping is left out: an estimate, for diagnostics.
    ``speed`` is floored at :data:`SPEED_FLOOR`.
    """
    n = float(exponent)
    v = max(abs(float(speed)), SPEED_FLOOR)
    p = 1.0 / (n + 1.0)
    x_max = ((n + 1.0) * mass * v * v / (2.0 * k)) ** p
    return 2.0 * x_max / v * math.sqrt(math.pi) * math.gamma(1.0 + p) / math.gamma(0.5 + p)


#: The columns a gap reads at most (``gap_columns``): two spatial bodies' twelve.
GAP_WIDTH = 24
#: The gap geometries between spatial bodies (the module notes).
SPATIAL_GAPS = ("dot", "spatial_angle")


def gap_columns(geometry: str, data, cmap) -> list[int]:
    """The ``GAP_WIDTH`` columns in q extended by the ground's three that a
    gap reads: a planar gap's six (x, y, phi of the first body, then of the
    second), a spatial gap's twelve of each of its two bodies; the rest, and a
    spatial ground's, the ground's last column n + 2 (outside q: never read
    or written)."""
    if geometry in SPATIAL_GAPS:
        cols = []
        for body in data[:2]:          # a particle's three, then the ground's n + 2
            base = cmap.spatial.get(body)
            width = 0 if base is None else cmap.spatial_width[body]
            cols += list(range(base or 0, (base or 0) + width)) + [cmap.n + 2] * (12 - width)
        return cols
    cols = [int(c) for c in cmap([data[0], data[2]]).ravel()]
    return cols + [cmap.n + 2] * (GAP_WIDTH - len(cols))


def spatial_dot_gap(u_terms, w_terms, offset, sign, label=""):
    """A ``dot`` gap sign (U . W - offset) between spatial bodies (module
    notes): U and W sums of terms (body, alpha, s (3,), factor), each
    factor (alpha r + A s) of a body (GROUND: s in world axes, a constant).

    Returns
    -------
    tuple
        ("dot", (body A, body B, U's weights (8,), U's constant (3,), W's
        weights (8,), W's constant (3,), offset, sign), label): each side's
        weights (alpha, s1, s2, s3) on body A, then on body B (GROUND -1
        where the gap reads one body only).

    Raises
    ------
    ValueError
        Terms on more than two bodies.
    """
    bodies = []
    for body, *_ in list(u_terms) + list(w_terms):
        if body != GROUND and body not in bodies:
            bodies.append(body)
    if len(bodies) > 2:
        raise ValueError("a dot gap reads two bodies at most")
    bodies += [GROUND] * (2 - len(bodies))

    def side(terms):
        """(weights (8,): (alpha, s) on body A, then on body B; constant (3,)
        [m]: the ground's terms) of one side's sum of terms."""
        weights, const = np.zeros(8), np.zeros(3)
        for body, alpha, local, factor in terms:
            if body == GROUND:
                const += factor * np.asarray(local, float)
            else:
                k = bodies.index(body)
                weights[4 * k:4 * k + 4] += factor * np.r_[alpha, local]
        return tuple(weights), tuple(const)

    (wu, u0), (ww, w0) = side(u_terms), side(w_terms)
    return ("dot", (bodies[0], bodies[1], wu, u0, ww, w0, float(offset), float(sign)), label)


def contact_geometry_plane(centre, radius, plane_point, normal):
    """The ``dot`` gap of a sphere (PointRef ``centre`` of a spatial body,
    radius [m]) on a plane through the PointRef ``plane_point`` with
    ``normal`` (3,) in that body's frame (world axes on the ground):
    g = n . (p_P - p_L) - r, open on the normal's side."""
    n0 = np.asarray(normal, float) / np.linalg.norm(normal)
    return spatial_dot_gap([(plane_point.body, 0.0, n0, 1.0)],
                           [(centre.body, 1.0, centre.local, 1.0),
                            (plane_point.body, 1.0, plane_point.local, -1.0)], radius, 1.0)


def spatial_limit_gaps(joint, lower, upper):
    """The gaps of a limit on a spatial joint (``model.spatial.SpatialJoint``)
    between ``lower`` and ``upper`` (NaN: none), one per bound given: a
    revolute's angle (``spatial_angle``: (body 1, body 2, axis 1, axis 2,
    bound, sign)), a prismatic's or point_on_line's distance u . (p_1 - p_2)
    along the second body's line (``dot``, as ``kernels/joints/spatial.py``'s
    joint_distance row); sign 1 for the lower bound (g = s - lower), -1 for
    the upper (g = upper - s)."""
    bounds = [(b, sign, label) for b, sign, label in
              ((lower, 1.0, "lower"), (upper, -1.0, "upper")) if not math.isnan(b)]
    if joint.kind == "revolute":
        (b1, a1), (b2, a2) = joint.axes
        return tuple(("spatial_angle", (b1, b2, tuple(a1), tuple(a2), b, sign), label)
                     for b, sign, label in bounds)
    b2, u = joint.axes[-1]
    p1 = (joint.first.body, 1.0, joint.first.local, 1.0)
    p2 = (joint.second.body, 1.0, joint.second.local, -1.0)
    return tuple(spatial_dot_gap([p1, p2], [(b2, 0.0, u, 1.0)], b, sign, label)
                 for b, sign, label in bounds)


def contact_geometry_line(centre, radius, line_point, direction):
    """Gap data of a circle (PointRef ``centre``, radius [m]) against a line
    through the PointRef ``line_point`` along ``direction`` (body frame)."""
    u = np.asarray(direction, float)
    u = u / np.linalg.norm(u)
    normal = (float(-u[1]), float(u[0]))
    return ("line", (line_point.body, tuple(line_point.local), centre.body,
                     tuple(centre.local), normal, float(radius)), "")


def rope_geometry(first, second, length):
    """Gap data of a rope of ``length`` [m] between two PointRefs: the second
    point in a hole of that radius about the first, g = L - |p2 - p1|,
    closed (taut) where the points are farther apart than L."""
    return ("circle", (first.body, tuple(first.local), second.body, tuple(second.local),
                       float(length), 0.0), "")


def contact_geometry_circle(pin, radius, hole_centre, hole_radius):
    """Gap data of a pin (PointRef, radius [m]) in a hole (PointRef, radius [m])."""
    return ("circle", (hole_centre.body, tuple(hole_centre.local), pin.body,
                       tuple(pin.local), float(hole_radius) - float(radius), float(radius)), "")


__all__ += ["contact_geometry_line", "contact_geometry_circle", "rope_geometry", "GROUND",
            "GAP_WIDTH", "SPATIAL_GAPS", "spatial_dot_gap", "contact_geometry_plane",
            "spatial_limit_gaps"]
