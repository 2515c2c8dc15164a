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
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ..errors import Span
from .elements import GROUND, line_distance

__all__ = ["Contact", "damping_factor", "gap", "gap_columns", "slip",
           "SPEED_FLOOR"]

#: Approach speeds below this [m/s or rad/s] are taken as this speed in the
#: damping term chi ddelta/dt / v_impact: a contact that closes at rest (a body
#: settling on a floor, a run starting in contact) gets the damping of a
#: 1 mm/s impact rather than an unbounded one.
SPEED_FLOOR = 1e-3


@dataclass(frozen=True)
class Contact:
    """A compliant contact (``contact``) or joint limit (``limit``).

    Attributes
    ----------
    name : str
    kind : {"contact", "limit"}
    gaps : tuple of (geometry, data, label)
        One-sided gaps (module notes): geometry in {"line", "circle",
        "angle", "slide"}; data as :func:`gap` reads it; label names the gap
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


def gap_columns(geometry: str, data, cmap) -> list[int]:
    """The six columns (x, y, phi of the first body, then of the second) in
    q extended by the ground's three, that a gap reads."""
    return [int(c) for c in cmap([data[0], data[2]]).ravel()]


def _rot(phi, v):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def gap(geometry: str, data, qx, cmap):
    """A one-sided gap and its derivatives over :func:`gap_columns`.

    Parameters
    ----------
    geometry : {"line", "circle", "angle", "slide"}
    data : tuple
        ``line``: (body L, s_L, body P, s_P, n0, r); ``circle``: (body C, s_C,
        body P, s_P, clearance, r); ``angle``: (body 1, None, body 2, None, bound,
        sign); ``slide``: (body L, s_L, body P, s_P, u0, bound, sign).
    qx : ndarray, shape (n + 3,)
        q extended by the ground's three zero coordinates.
    cmap : CoordinateMap

    Returns
    -------
    g : float [m or rad]
    grad : ndarray, shape (6,)
    hess : ndarray, shape (6, 6)
    """
    if geometry == "line":
        s, grad, H = line_distance(data[:5], qx, cmap)
        return s - data[5], grad, H
    if geometry == "slide":
        s, grad, H = line_distance(data[:5], qx, cmap)
        sign = data[6]
        return sign * (s - data[5]), sign * grad, sign * H
    q = qx[gap_columns(geometry, data, cmap)]
    if geometry == "angle":
        _, _, _, _, bound, sign = data
        grad = np.zeros(6)
        grad[2], grad[5] = -sign, sign
        return sign * (q[5] - q[2] - bound), grad, np.zeros((6, 6))
    # circle: g = c - |d|, d = p_P - p_C = r_P + A_P s_P - r_C - A_C s_C
    _, sC, _, sP, clearance = data[:5]
    aC, aP = _rot(q[2], sC), _rot(q[5], sP)
    BaC, BaP = np.array([-aC[1], aC[0]]), np.array([-aP[1], aP[0]])
    d = q[3:5] + aP - q[0:2] - aC
    l = math.hypot(d[0], d[1])
    D = np.zeros((2, 6))                     # dd/dq
    D[:, 0:2], D[:, 2], D[:, 3:5], D[:, 5] = -np.eye(2), -BaC, np.eye(2), BaP
    if l == 0.0:                             # centred: the gap is open by c, no normal
        return clearance, np.zeros(6), np.zeros((6, 6))
    e = d / l
    dl = e @ D
    P = (np.eye(2) - np.outer(e, e)) / l
    H = D.T @ P @ D
    H[2, 2] += e @ aC                        # d2d/dphi_C^2 = +A_C s_C
    H[5, 5] -= e @ aP                        # d2d/dphi_P^2 = -A_P s_P
    return clearance - l, -dl, -H


def contact_geometry_line(centre, radius, line_point, direction):
    """Gap data of a circle (PointRef ``centre``, radius [m]) against a line
    through the PointRef ``line_point`` along ``direction`` (body frame)."""
    u = np.asarray(direction, float)
    u = u / np.linalg.norm(u)
    normal = (float(-u[1]), float(u[0]))
    return ("line", (line_point.body, tuple(line_point.local), centre.body,
                     tuple(centre.local), normal, float(radius)), "")


def contact_geometry_circle(pin, radius, hole_centre, hole_radius):
    """Gap data of a pin (PointRef, radius [m]) in a hole (PointRef, radius [m])."""
    return ("circle", (hole_centre.body, tuple(hole_centre.local), pin.body,
                       tuple(pin.local), float(hole_radius) - float(radius), float(radius)), "")


__all__ += ["contact_geometry_line", "contact_geometry_circle", "GROUND"]


def slip(geometry: str, data, qx, cmap):
    """The tangential slip speed at a contact, v_t = w(q) . v, and dw/dq.

    The contact normal nu (unit, from the first body's surface toward the
    circle's centre: the line's normal, or -e from the pin's centre towards
    the hole's for a pin in a hole), the contact point c = p_P - r nu and the
    tangent tau = (-nu_y, nu_x); v_t = tau . (v_c2 - v_c1), the velocities of
    the two bodies' material points at c. With tau . (omega k x d) = omega
    nu . d:

        w = (-tau, -nu . (c - r_1), tau, nu . (A_2 s_P) - r)

    over (x, y, phi of the first body, then of the second). dnu/dq: B(phi_1)
    n0 = J nu on phi_1 for a line; -(I - e e^T) D / l for a hole (D = dd/dq
    of d = p_P - p_C).

    Parameters
    ----------
    geometry : {"line", "circle"}
    data, qx, cmap : as for :func:`gap`

    Returns
    -------
    w : ndarray, shape (6,)
    dw : ndarray, shape (6, 6)
        dw[i, j] = dw_i / dq_j.
    """
    q = qx[gap_columns(geometry, data, cmap)]
    a2 = _rot(q[5], data[3])
    B2 = np.array([-a2[1], a2[0]])
    J = np.array([[0.0, -1.0], [1.0, 0.0]])
    if geometry == "line":
        r = data[5]
        nu = _rot(q[2], data[4])
        dnu = np.zeros((2, 6))
        dnu[:, 2] = J @ nu
    else:
        a1 = _rot(q[2], data[1])
        d = q[3:5] + a2 - q[0:2] - a1
        l = math.hypot(d[0], d[1])
        r = data[5]
        if l == 0.0:
            return np.zeros(6), np.zeros((6, 6))
        e = d / l
        D = np.zeros((2, 6))
        D[:, 0:2], D[:, 2], D[:, 3:5], D[:, 5] = -np.eye(2), -np.array([-a1[1], a1[0]]), \
            np.eye(2), B2
        nu = -e
        dnu = -((np.eye(2) - np.outer(e, e)) / l) @ D
    tau = J @ nu
    dtau = J @ dnu
    # c - r_1 = (p_P - r nu) - r_1 = (q2 + a2 - r nu) - q1
    c1 = q[3:5] + a2 - r * nu - q[0:2]
    dc1 = np.zeros((2, 6))
    dc1[:, 0:2], dc1[:, 3:5] = -np.eye(2), np.eye(2)
    dc1[:, 5] = B2
    dc1 -= r * dnu
    w = np.array([-tau[0], -tau[1], -(nu @ c1), tau[0], tau[1], nu @ a2 - r])
    dw = np.zeros((6, 6))
    dw[0], dw[1] = -dtau[0], -dtau[1]
    dw[2] = -(dnu.T @ c1 + dc1.T @ nu)
    dw[3], dw[4] = dtau[0], dtau[1]
    dw[5] = dnu.T @ a2
    dw[5, 5] += nu @ B2
    return w, dw
