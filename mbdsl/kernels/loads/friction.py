"""Coulomb friction in joints, from each joint's own reaction.

A friction load tau acts along the joint's motion coordinate z with
direction w: in a revolute joint z is the relative rate omega_2 - omega_1
and w = e_phi2 - e_phi1 (a torque, +tau on the second body, -tau on the
first); in a prismatic or point_on_line joint z is the sliding speed ds/dt
and w = grad s (a force along the line, ``geometry._line``). The law is the
regularised Coulomb-Stribeck law of Andersson, Soderberg & Bjorklund (2007),
eq. (8), with a viscous term:

    tau = -N mu(z) tanh(z / v_reg) - c z,
    mu(z) = mu_k + (mu_s - mu_k) exp(-(z / v_s)^2)

with N the normal load, from the joint's multipliers lambda_J: r |lambda_J|
for a revolute (r the pin radius: the friction torque of a pin pressed with
the reaction |lambda_J|), |lambda_J| for a sliding joint (its normal row's
multiplier is the normal force: the row's normal is a unit vector). So Q
reads lambda, and Q_lambda sits beside Phi_q^T in the Newton matrix.
tanh(z/v_reg) replaces sign(z): a joint under a load below mu N "sticks" at
the creep speed z = v_reg atanh(load / (mu N)), below 2 v_reg for a load
below 0.96 mu N.

Derivatives (exact, for the Newton matrix):

    Q = tau w,  Q_q = tau dw/dq + w (dtau/dz) (dz/dq),
    Q_v = w (dtau/dz) w^T,  Q_lambda = w (dtau/dlambda_J)^T

with dz/dq = (d^2 s) v for a sliding joint (0 for a revolute) and
dtau/dlambda_J = -mu(z) tanh(z/v_reg) dN/dlambda_J, dN/dlambda_J = r
lambda_J/|lambda_J| (0 at |lambda_J| = 0, the subgradient). Units: v_s,
v_reg in m/s (sliding) or rad/s (revolute); c in N s/m or N m s/rad; r in m
(1 for a sliding joint).

Andersson, Soderberg & Bjorklund (2007), "Friction models for sliding dry,
boundary and fluid lubricated contacts", Tribology International 40,
580-587.

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
#: The loads it holds (``model.elements.Friction.kind``).
LOADS = ("friction",)


def _reaction_rows(f, tables) -> list:
    """The rows of lambda that carry a friction joint's normal reaction: a
    revolute's two, a sliding joint's normal row."""
    r0 = tables.system.joint_rows[f.joint.name]
    return [r0, r0 + 1] if f.joint.kind == "revolute" else [r0]


def pack(items, tables) -> dict:
    """Its fields from the model's friction elements.

    Parameters
    ----------
    items : list of Friction
        The model's friction elements, in its order.
    tables : packing context
        ``cmap``, ``line_row`` and the system's ``joint_rows``
        (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        FRI per joint (+column, -column, line row or -1, first reaction row,
        rows), FRP the law's (mu_k, mu_s, v_s, c, v_reg, r).
    """
    ground_phi, fri = tables.n + 2, []
    for f in items:
        rows = _reaction_rows(f, tables)
        j = f.joint
        if j.kind == "revolute":
            a, b = (int(c) for c in tables.cmap([j.second.body, j.first.body])[:, 2])
            fri.append((a, b, -1, rows[0], len(rows)))
        else:
            fri.append((ground_phi, ground_phi, tables.line_row(j.line), rows[0], len(rows)))
    frp = [(f.mu, f.mu_static, f.v_stribeck, f.viscous, f.v_reg, f.radius) for f in items]
    return {"fri": np.array(fri, np.int64).reshape(-1, 5),
            "frp": np.array(frp, np.float64).reshape(-1, 6)}


def pattern(items, tables) -> tuple:
    """(columns (k, c) whose Q_q, Q_v entries friction fills: a revolute's two
    angles, a sliding line's six; True: it is damped)."""
    per = [[int(c) for c in tables.cmap([f.joint.second.body, f.joint.first.body])[:, 2]]
           if f.joint.kind == "revolute" else tables.line_columns(f.joint.line)
           for f in items]
    return tables.padded(per), True


def multiplier_pattern(items, tables) -> tuple:
    """(columns (k, c), rows of lambda per instance): where Q_lambda may be
    nonzero, each instance's columns times its reaction rows."""
    return pattern(items, tables)[0], [_reaction_rows(f, tables) for f in items]


@_jit
def _friction_law(I, Fl, i, z, lam, slip):
    """(tau, dtau/dz, dtau/dN_raw, R) of friction instance i at joint speed z,
    the law of the module notes, with R = |lambda_J| (N = r R).
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
    (d^2 s v)^T, Q_v = w dtau/dz w^T (the module notes)."""
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
    joint's reaction rows (the module notes)."""
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
