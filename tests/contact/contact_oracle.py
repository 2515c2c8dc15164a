"""An independent numpy evaluation of the contacts and joint limits: the
oracle the contact kernels of ``mbdsl.kernels`` (``_gap``,
``_slip``, ``_contact_law``, ``_contacts_add``, ``_emit_contacts`` and the
contacts' terms of ``_potential`` and ``_power``) are tested against. Not
part of the package: mbdsl evaluates its contacts with the kernels only.

The geometries and the law are those of ``mbdsl.model.contact`` and
``mbdsl.assembly.contact`` (their module notes): the gap g(q) of a circle
against a line or in a hole, one side of a sliding or an angular limit; the
Hunt-Crossley force f = K delta^n (1 + chi ddelta/dt / v_impact) (+ a rope's
c ddelta/dt, within +-K delta^n) >= 0 along
grad g, and with a friction coefficient the regularised Coulomb force
-mu f tanh(v_t / v_reg) along the slip direction w.
"""

from __future__ import annotations

import math

import numpy as np

from mbdsl.model.contact import SPEED_FLOOR, gap_columns

from ..assembly.constraint_oracle import line_distance

__all__ = ["gap", "slip", "ContactOracle"]


def _rot(phi, v):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def gap(geometry: str, data, qx, cmap):
    """A one-sided gap and its derivatives over ``gap_columns``.

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


class ContactOracle:
    """The contact law of a system's contacts and limits, gap by gap, from
    the model's ``Contact`` elements (read here, not from the package's
    packing).

    Parameters
    ----------
    system : mbdsl.AssembledSystem
        Its model's contacts, and its impact speeds (``contact_state``, the
        contacts' state) as they are when an evaluation is asked for.
    """

    def __init__(self, system):
        from mbdsl.model.contact import Contact, gap_columns
        self.cmap, self.state = system.cmap, system.contact_state
        self.geometry, self.names, cols, law = [], [], [], []
        for c in (f for f in system.model.loads if isinstance(f, Contact)):
            for geometry, data, label in c.gaps:
                self.geometry.append((geometry, data))
                self.names.append(c.name + ("." + label if label else ""))
                cols.append(gap_columns(geometry, data, self.cmap)[:6])   # planar: six
                law.append((c.k, c.exponent, c.damping, c.mu, c.v_reg, c.viscous))
        self.cols = np.array(cols, dtype=np.intp).reshape(-1, 6)
        self.k_, self.n_, self.chi, self.mu, self.v_reg, self.c_ = np.array(law).reshape(-1, 6).T

    @property
    def impact_speed(self) -> np.ndarray:
        """The impact speeds in force (the system's contact state), shape (k,)."""
        return self.state.impact_speed

    def gap(self, i, qx):
        """(g, grad, H) of gap i."""
        geo, data = self.geometry[i]
        return gap(geo, data, qx, self.cmap)

    def law(self, i, qx, vx, speed):
        """(g, grad, H, delta, ddelta, f, elastic part K delta^n) of gap i."""
        g, grad, H = self.gap(i, qx)
        if g >= 0.0:
            return g, grad, H, 0.0, 0.0, 0.0, 0.0
        delta = -g
        ddelta = -(grad @ vx[self.cols[i]])
        elastic = self.k_[i] * delta ** self.n_[i]
        v_imp = speed if speed > 0.0 else max(ddelta, SPEED_FLOOR)
        f = elastic * (1.0 + self.chi[i] * ddelta / v_imp)
        f += np.clip(self.c_[i] * ddelta, -elastic, elastic)      # a rope's damping
        return g, grad, H, delta, ddelta, max(f, 0.0), elastic

    def friction(self, i, qx, vx, f):
        """(F_t, w, dw, v_t, T) of gap i under normal force f."""
        w, dw = slip(*self.geometry[i], qx, self.cmap)
        vt = w @ vx[self.cols[i]]
        T = np.tanh(vt / self.v_reg[i])
        return -self.mu[i] * f * T, w, dw, vt, T

    def forces(self, qx, vx, t):
        """Local Q, shape (k, 6) [N, N m]."""
        out = np.zeros(self.cols.shape)
        for i in range(len(self.names)):
            _, grad, _, _, _, f, _ = self.law(i, qx, vx, self.impact_speed[i])
            if f > 0.0:
                out[i] = f * grad
                if self.mu[i] > 0.0:
                    Ft, w, _, _, _ = self.friction(i, qx, vx, f)
                    out[i] += Ft * w
        return out

    def derivatives(self, qx, vx, t):
        """Local (Q_q, Q_v), each shape (k, 6, 6)."""
        k = len(self.names)
        Qq, Qv = np.zeros((k, 6, 6)), np.zeros((k, 6, 6))
        for i in range(k):
            imp = self.impact_speed[i]
            g, grad, H, delta, ddelta, f, elastic = self.law(i, qx, vx, imp)
            if f <= 0.0:
                continue
            n, chi = self.n_[i], self.chi[i]
            armed = imp > 0.0 or ddelta <= SPEED_FLOOR
            speed = imp if imp > 0.0 else max(ddelta, SPEED_FLOOR)
            damp = elastic * chi / speed if armed else 0.0
            dK = n * self.k_[i] * delta ** (n - 1.0)
            df_ddelta = dK * (1.0 + chi * ddelta / speed)
            fc = self.c_[i] * ddelta
            if abs(fc) < elastic:
                damp += self.c_[i]
            elif self.c_[i] > 0.0:
                df_ddelta += dK * np.sign(fc)
            v = vx[self.cols[i]]
            dfdq = -df_ddelta * grad - damp * (H @ v)
            dfdv = -damp * grad
            Qq[i] = np.outer(grad, dfdq) + f * H
            Qv[i] = np.outer(grad, dfdv)
            if self.mu[i] > 0.0:
                Ft, w, dw, vt, T = self.friction(i, qx, vx, f)
                dT = (1.0 - T * T) / self.v_reg[i]
                dFt_dq = -self.mu[i] * (T * dfdq + f * dT * (dw.T @ v))
                dFt_dv = -self.mu[i] * (T * dfdv + f * dT * w)
                Qq[i] += np.outer(w, dFt_dq) + Ft * dw
                Qv[i] += np.outer(w, dFt_dv)
        return Qq, Qv

    def energy(self, qx):
        """Elastic energy K delta^(n+1) / (n+1) [J] at one extended
        configuration qx (nx,)."""
        out = 0.0
        for i in range(len(self.names)):
            g = self.gap(i, qx)[0]
            if g < 0.0:
                out += self.k_[i] * (-g) ** (self.n_[i] + 1.0) / (self.n_[i] + 1.0)
        return out

    def dissipation(self, qx, vx, speeds):
        """Power dissipated [W] at (qx, vx) with the impact speeds ``speeds``
        (k,): (f - K delta^n) ddelta/dt - F_t v_t."""
        out = 0.0
        for i in range(len(self.names)):
            _, _, _, delta, ddelta, f, elastic = self.law(i, qx, vx, speeds[i])
            if delta > 0.0:
                out += (f - elastic) * ddelta
                if self.mu[i] > 0.0 and f > 0.0:
                    Ft, _, _, vt, _ = self.friction(i, qx, vx, f)
                    out -= Ft * vt
        return out
