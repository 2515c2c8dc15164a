"""Friction in joints: tau = -N mu(z) tanh(z / v_reg) - c z along w.

z the joint's relative speed (an angle's rate or a sliding speed along
``geometry._line``), N the normal force from the joint's multipliers, so Q
reads lambda and Q_lambda sits beside Phi_q^T in the Newton matrix
(``assembly.groups.FrictionGroup``; a regularised Coulomb law with a
Stribeck curve).

Fields: FRI (k, 5) (+column, -column, line row or -1, first multiplier row,
rows), FRP (k, 6) the law's parameters.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry import _line
from ..schema import FRI, FRP, GEO, _f, _i, _inline, _jit, _put, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("fri", "frp")
#: Newton-matrix triplets per instance of a force block: Q_q and Q_v over a sliding line's 6
#: columns (and 12 of Q_lambda).
FORCE_TRIPLETS = 36


@_jit
def _friction_law(I, Fl, i, z, lam, slip):
    """(tau, dtau/dz, dtau/dN_raw, R) of friction instance i at joint speed z,
    the law of the ``FrictionGroup`` notes, with R = |lambda_J| (N = r R).
    dtau/dlambda_J = dtau/dN_raw lambda_J / R (0 at R = 0). ``slip`` (k,),
    read where it is not NaN, replaces tanh(z/v_reg) (and mu(z) by mu_s):
    the Coulomb limit at rest of the initial conditions; empty: the law."""
    mu_k, mu_s, v_s = _f(I, Fl, FRP, i, 0), _f(I, Fl, FRP, i, 1), _f(I, Fl, FRP, i, 2)
    c, v_reg, rad = _f(I, Fl, FRP, i, 3), _f(I, Fl, FRP, i, 4), _f(I, Fl, FRP, i, 5)
    e, dmu = 0.0, 0.0
    if v_s > 0.0:
        e = math.exp(-(z / v_s) ** 2)
        dmu = (mu_s - mu_k) * e * (-2.0 * z / (v_s * v_s))
    mu = mu_k + (mu_s - mu_k) * e
    th = math.tanh(z / v_reg)
    if i < slip.shape[0] and not math.isnan(slip[i]):
        th, mu, dmu = slip[i], mu_s, 0.0
    row, nr = _i(I, FRI, i, 3), _i(I, FRI, i, 4)
    R2 = 0.0
    for k in range(nr):
        R2 += lam[row + k] * lam[row + k]
    R = math.sqrt(R2)
    N = rad * R
    tau = -N * mu * th - c * z
    dz = -N * (dmu * th + mu * (1.0 - th * th) / v_reg) - c
    return tau, dz, -mu * th * rad, R


@_jit
def _friction_kin(I, Fl, i, qx, vx, grad, H):
    """Joint speed z of friction instance i; its direction w into grad (6,)
    (revolute: (1, -1) on its +col, -col) and, for a sliding line, d^2 s
    into H. Returns (z, g): g the line's row, -1 for a revolute."""
    g = _i(I, FRI, i, 2)
    if g < 0:
        grad[0], grad[1] = 1.0, -1.0
        return vx[_i(I, FRI, i, 0)] - vx[_i(I, FRI, i, 1)], g
    _line(I, Fl, qx, g, grad, H)
    z = 0.0
    for j in range(6):
        z += grad[j] * vx[_i(I, GEO, g, j)]
    return z, g


@_jit
def _friction_col(I, i, g, a):
    """Column of local entry a of friction instance i (line g, or a revolute)."""
    return _i(I, FRI, i, a) if g < 0 else _i(I, GEO, g, a)


@_jit
def _emit_friction(I, Fl, n, qx, vx, lam, R, C, V, p, r0, c0, cq, cv):
    """Friction's -(cq Q_q + cv Q_v) at (r0, c0): Q_q = tau d^2 s + w dtau/dz
    (d^2 s v)^T, Q_v = w dtau/dz w^T (``FrictionGroup`` notes)."""
    w, H = np.empty(6), np.empty((6, 6))
    Hv = np.empty(6)
    for i in range(_rows(I, FRI)):
        z, g = _friction_kin(I, Fl, i, qx, vx, w, H)
        tau, dz, dN, Rn = _friction_law(I, Fl, i, z, lam, Fl[:0])
        k = 2 if g < 0 else 6
        for b in range(k):
            Hv[b] = 0.0
            if g >= 0:
                for j in range(6):
                    Hv[b] += H[b, j] * vx[_i(I, GEO, g, j)]
        for a in range(k):
            ra = _friction_col(I, i, g, a)
            if ra >= n:
                continue
            for b in range(k):
                cb = _friction_col(I, i, g, b)
                if cb >= n:
                    continue
                val = cv * dz * w[a] * w[b]
                if g >= 0:
                    val += cq * (tau * H[a, b] + dz * w[a] * Hv[b])
                p = _put(R, C, V, p, r0 + ra, c0 + cb, -val)
    return p


@_jit
def _emit_friction_lam(I, Fl, n, qx, vx, lam, R, C, V, p, r0, c0, coef):
    """-coef Q_lambda at (r0, c0), Q_lambda = w (dtau/dlambda_J)^T over the
    joint's reaction rows (``FrictionGroup`` notes)."""
    w, H = np.empty(6), np.empty((6, 6))
    for i in range(_rows(I, FRI)):
        z, g = _friction_kin(I, Fl, i, qx, vx, w, H)
        tau, dz, dN, Rn = _friction_law(I, Fl, i, z, lam, Fl[:0])
        row, nr = _i(I, FRI, i, 3), _i(I, FRI, i, 4)
        for a in range(2 if g < 0 else 6):
            ra = _friction_col(I, i, g, a)
            if ra >= n:
                continue
            for k in range(nr):
                d = dN * lam[row + k] / Rn if Rn > 0.0 else 0.0
                p = _put(R, C, V, p, r0 + ra, c0 + row + k, -coef * w[a] * d)
    return p


@_inline
def forces_add(I, Fl, qx, vx, lam, slip, out):
    """out (n+3,) += tau w of every friction joint [N, N m] (``_friction_law``)."""
    grad, H = np.empty(6), np.empty((6, 6))
    for i in range(_rows(I, FRI)):
        z, g = _friction_kin(I, Fl, i, qx, vx, grad, H)
        tau, dz, dN, Rn = _friction_law(I, Fl, i, z, lam, slip)
        for a in range(2 if g < 0 else 6):
            out[_friction_col(I, i, g, a)] += tau * grad[a]


@_inline
def power_add(I, Fl, qx, vx, lam, p):
    """p + the power friction dissipates, -tau z [W]."""
    if _rows(I, FRI) == 0:
        return p
    grad, H = np.empty(6), np.empty((6, 6))
    for i in range(_rows(I, FRI)):
        z, g = _friction_kin(I, Fl, i, qx, vx, grad, H)
        tau, dz, dN, Rn = _friction_law(I, Fl, i, z, lam, Fl[:0])
        p -= tau * z
    return p
