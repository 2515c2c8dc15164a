"""A spatial revolute's (or cylindrical's) angle, and its drivers:
Phi = wrap(theta(q) - f(t)), one row each.

The joint holds axis a_1 of the first body parallel to axis a_2 of the
second. Its angle theta is the second body's turn about a_1 relative to
the first: with f_1 a unit vector across a_1 (body 1), g_1 = a_1 x f_1 and
f_2 = R_m f_1 in body 2 (R_m the least rotation taking a_1 to a_2 in body
axes, so that theta = 0 where the bodies' frames differ by R_m alone: where
a_1 = a_2, where the frames coincide), in world axes

    s = G_1 . F_2,   c = F_1 . F_2,   theta = atan2(s, c),

each of s and c the dot product of two director-linear vectors
(``model.spatial``), so that its gradient and Hessian are those of a dot
row (``joints.spatial``), and with rho = s^2 + c^2

    theta_q  = (c s_q - s c_q) / rho,
    theta_qq = (s_q c_q^T - c_q s_q^T + c s_qq - s c_qq) / rho
               - (c s_q - s c_q)(2 s s_q + 2 c c_q)^T / rho^2.

It does not depend on the choice of f_1. Only the directors enter (18
columns: body 1's a_1..a_3, then body 2's). A driver's row is theta - f(t)
brought within [-pi, pi) (so that a motor may turn any number of times);
its gradient is theta_q, Phi_t = -f'(t), Phi_tt = -f''(t), Phi_qt = 0, and
its multiplier lambda is the torque about a_1 the driver puts on the second
body, negated (Haug 1989, sec. 11.4.2: the rotational driver; the angle as
in sec. 11.2.4, there by Euler angles).

Fields: AROW (k,) the rows, ACOL (k, 2) the bodies' first columns (-1:
the ground, whose vectors are in world axes), AV (k, 9) f_1, g_1 (the
first body's axes) and f_2 (the second's), AFN (k, 3) the programs of f,
f', f'' (-1: none).
"""

from __future__ import annotations

import math

import numpy as np

from mbdsl.model.spatial import reference_vectors

from ..programs import _eval
from ..schema import ACOL, AFN, AROW, AV, _f, _i, _inline, _jit, _put, _put_phiq, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("arow", "acol", "av", "afn")
#: Newton-matrix triplets per instance: Phi_q and (Phi_q v)_q over the 18 director
#: columns, (Phi_q^T lambda)_q their 18 x 18 block.
PHIQ_TRIPLETS, HESS_TRIPLETS, G_TRIPLETS = 18, 324, 18
#: The drivers whose rows it holds: kind -> the first of them among the element's rows.
ELEMENT_ROWS = {"joint_angle": 0}
#: The model space whose drivers it holds (``assembly.packing``).
SPACE = 3
TWO_PI = 2.0 * math.pi


def pack(items, tables) -> dict:
    """Its fields from the model's spatial joint-angle drivers.

    Parameters
    ----------
    items : list of (int, Driver)
        Per driver, its row of lambda and the driver (its ``joint`` a
        spatial revolute or cylindrical joint), in the model's order.
    tables : packing context
        ``cmap.spatial`` and ``driver_programs``.

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    rows, cols, vecs, fns = [], [], [], []
    for row, d in items:
        j = d.joint
        (b1, a1), (b2, a2) = j.axes
        rows.append(row)
        cols.append([tables.cmap.spatial.get(b, -1) for b in (b1, b2)])
        vecs.append(reference_vectors(a1, a2))
        fns.append(tables.driver_programs(d.function))
    return {"arow": np.array(rows, np.int64), "acol": np.array(cols, np.int64).reshape(-1, 2),
            "av": np.array(vecs, np.float64).reshape(-1, 9),
            "afn": np.array(fns, np.int64).reshape(-1, 3)}


@_inline
def column(b1, b2, k):
    """The column in q_ext of director entry k (0..17) of an angle whose
    bodies' first columns are b1, b2; -1 for the ground's."""
    if k < 9:
        return b1 + 3 + k if b1 >= 0 else -1
    return b2 + 3 + k - 9 if b2 >= 0 else -1


@_jit
def angle(I, Fl, COL, VEC, i, qx, sq, cq):
    """(theta, s, c) of instance i of a field pair (COL (k, 2), VEC (k, 9):
    the bodies' first columns, f_1, g_1, f_2), and s_q, c_q over the 18
    director entries into sq, cq (18,) (module notes)."""
    b1, b2 = _i(I, COL, i, 0), _i(I, COL, i, 1)
    F1, G1, F2 = np.zeros(3), np.zeros(3), np.zeros(3)
    for d in range(3):
        if b1 < 0:
            F1[d] = _f(I, Fl, VEC, i, d)
            G1[d] = _f(I, Fl, VEC, i, 3 + d)
        if b2 < 0:
            F2[d] = _f(I, Fl, VEC, i, 6 + d)
    for j in range(3):
        for d in range(3):
            if b1 >= 0:
                a = qx[b1 + 3 + 3 * j + d]
                F1[d] += _f(I, Fl, VEC, i, j) * a
                G1[d] += _f(I, Fl, VEC, i, 3 + j) * a
            if b2 >= 0:
                F2[d] += _f(I, Fl, VEC, i, 6 + j) * qx[b2 + 3 + 3 * j + d]
    s = G1[0] * F2[0] + G1[1] * F2[1] + G1[2] * F2[2]
    c = F1[0] * F2[0] + F1[1] * F2[1] + F1[2] * F2[2]
    for j in range(3):
        for d in range(3):
            k = 3 * j + d
            on1, on2 = 1.0 if b1 >= 0 else 0.0, 1.0 if b2 >= 0 else 0.0
            sq[k] = on1 * _f(I, Fl, VEC, i, 3 + j) * F2[d]
            cq[k] = on1 * _f(I, Fl, VEC, i, j) * F2[d]
            sq[9 + k] = on2 * _f(I, Fl, VEC, i, 6 + j) * G1[d]
            cq[9 + k] = on2 * _f(I, Fl, VEC, i, 6 + j) * F1[d]
    return math.atan2(s, c), s, c


@_inline
def _rho(s, c):
    """s^2 + c^2, or 1 where both are zero (a state with the frames' vectors
    zero, as a sparsity pattern's probe: s_q and c_q are zero there)."""
    rho = s * s + c * c
    return rho if rho > 0.0 else 1.0


@_inline
def rate(b1, b2, g, vx):
    """theta' = theta_q v [rad/s] from theta_q over the 18 director entries g
    (18,) of bodies whose first columns are b1, b2."""
    acc = 0.0
    for k in range(18):
        col = column(b1, b2, k)
        if col >= 0:
            acc += g[k] * vx[col]
    return acc


@_inline
def hessian_times(b1, b2, H, vx, out):
    """v^T theta_qq (the rate's gradient in q) into out (18,), from theta_qq
    H (18, 18) of bodies whose first columns are b1, b2."""
    for b in range(18):
        out[b] = 0.0
        for a in range(18):
            ca = column(b1, b2, a)
            if ca >= 0:
                out[b] += vx[ca] * H[a, b]


@_jit
def gradient(s, c, sq, cq, grad):
    """theta_q into grad (18,) from s, c and their gradients."""
    rho = _rho(s, c)
    for k in range(18):
        grad[k] = (c * sq[k] - s * cq[k]) / rho


@_jit
def hessian(I, Fl, VEC, i, s, c, sq, cq, H):
    """theta_qq into H (18, 18) (module notes): s_qq and c_qq are constant,
    g_1j f_2l (f_1j f_2l) I_3 between body 1's director j and body 2's l."""
    rho = _rho(s, c)
    for a in range(18):
        n = c * sq[a] - s * cq[a]
        for b in range(18):
            H[a, b] = ((sq[a] * cq[b] - cq[a] * sq[b]) / rho
                       - n * 2.0 * (s * sq[b] + c * cq[b]) / (rho * rho))
    for j in range(3):
        for l in range(3):
            f2 = _f(I, Fl, VEC, i, 6 + l)
            v = (c * _f(I, Fl, VEC, i, 3 + j) - s * _f(I, Fl, VEC, i, j)) * f2 / rho
            for d in range(3):
                H[3 * j + d, 9 + 3 * l + d] += v
                H[9 + 3 * l + d, 3 * j + d] += v


@_jit
def wrap(x):
    """x brought within [-pi, pi) [rad]."""
    return x - TWO_PI * math.floor((x + math.pi) / TWO_PI)


@_jit
def _driven(I, Fl, t, i):
    """f(t) [rad] of driver i."""
    prog = _i(I, AFN, i, 0)
    return _eval(I, Fl, prog, t) if prog >= 0 else 0.0


@_inline
def phi(I, Fl, t, qx, out):
    """Phi = wrap(theta - f(t)) into out (m,) [rad]."""
    sq, cq = np.empty(18), np.empty(18)
    for i in range(_rows(I, AROW)):
        th, s, c = angle(I, Fl, ACOL, AV, i, qx, sq, cq)
        out[_i(I, AROW, i, 0)] = wrap(th - _driven(I, Fl, t, i))


@_inline
def phi_time_add(I, Fl, t, out, order):
    """out (m,) += -f'(t) (order 1) or -f''(t) (order 2) of every driver."""
    for i in range(_rows(I, AROW)):
        prog = _i(I, AFN, i, order)
        if prog >= 0:
            out[_i(I, AROW, i, 0)] -= _eval(I, Fl, prog, t)


@_inline
def phiqT_add(I, Fl, qx, lam, coef, out):
    """out (n+3,) += coef Phi_q^T lambda [N m]."""
    sq, cq, g = np.empty(18), np.empty(18), np.empty(18)
    for i in range(_rows(I, AROW)):
        th, s, c = angle(I, Fl, ACOL, AV, i, qx, sq, cq)
        gradient(s, c, sq, cq, g)
        lv = coef * lam[_i(I, AROW, i, 0)]
        b1, b2 = _i(I, ACOL, i, 0), _i(I, ACOL, i, 1)
        for k in range(18):
            col = column(b1, b2, k)
            if col >= 0:
                out[col] += lv * g[k]


@_inline
def phiq_times(I, Fl, qx, vx, out):
    """Phi_q v into out (m,) [rad/s]."""
    sq, cq, g = np.empty(18), np.empty(18), np.empty(18)
    for i in range(_rows(I, AROW)):
        th, s, c = angle(I, Fl, ACOL, AV, i, qx, sq, cq)
        gradient(s, c, sq, cq, g)
        out[_i(I, AROW, i, 0)] = rate(_i(I, ACOL, i, 0), _i(I, ACOL, i, 1), g, vx)


@_inline
def products(I, Fl, qx, vx, lam, mu, out_l, out_mu, out_v):
    """out_l (n+3,) += Phi_q^T lambda, out_mu (n+3,) += Phi_q^T mu, out_v
    (m,) = Phi_q v [rad/s] at one gradient per row: the sums of
    :func:`phiqT_add` (coef 1) and :func:`phiq_times`, in their order."""
    sq, cq, g = np.empty(18), np.empty(18), np.empty(18)
    for i in range(_rows(I, AROW)):
        th, s, c = angle(I, Fl, ACOL, AV, i, qx, sq, cq)
        gradient(s, c, sq, cq, g)
        row = _i(I, AROW, i, 0)
        lv, mv = 1.0 * lam[row], 1.0 * mu[row]
        b1, b2 = _i(I, ACOL, i, 0), _i(I, ACOL, i, 1)
        for k in range(18):
            col = column(b1, b2, k)
            if col >= 0:
                out_l[col] += lv * g[k]
                out_mu[col] += mv * g[k]
        out_v[row] = rate(b1, b2, g, vx)


@_inline
def emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """coef Phi_q at (r0, c0), or coef Phi_q^T when transpose; returns p."""
    if _rows(I, AROW) == 0:
        return p
    sq, cq, g = np.empty(18), np.empty(18), np.empty(18)
    for i in range(_rows(I, AROW)):
        th, s, c = angle(I, Fl, ACOL, AV, i, qx, sq, cq)
        gradient(s, c, sq, cq, g)
        b1, b2 = _i(I, ACOL, i, 0), _i(I, ACOL, i, 1)
        row = _i(I, AROW, i, 0)
        for k in range(18):
            col = column(b1, b2, k)
            if col >= 0:
                p = _put_phiq(R, C, V, p, r0, c0, row, col, coef * g[k], transpose)
    return p


@_inline
def emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """coef lambda theta_qq at (r0, c0) (every entry of the bodies' director
    block, zero or not: the pattern is the model's); returns p."""
    if _rows(I, AROW) == 0:
        return p
    sq, cq, H = np.empty(18), np.empty(18), np.empty((18, 18))
    for i in range(_rows(I, AROW)):
        th, s, c = angle(I, Fl, ACOL, AV, i, qx, sq, cq)
        hessian(I, Fl, AV, i, s, c, sq, cq, H)
        lv = coef * lam[_i(I, AROW, i, 0)]
        b1, b2 = _i(I, ACOL, i, 0), _i(I, ACOL, i, 1)
        for a in range(18):
            ca = column(b1, b2, a)
            if ca < 0:
                continue
            for b in range(18):
                cb = column(b1, b2, b)
                if cb >= 0:
                    p = _put(R, C, V, p, r0 + ca, c0 + cb, lv * H[a, b])
    return p


@_inline
def emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """coef (Phi_q v)_q = coef v^T theta_qq at (r0, c0); returns p."""
    if _rows(I, AROW) == 0:
        return p
    sq, cq, H, hv = np.empty(18), np.empty(18), np.empty((18, 18)), np.empty(18)
    for i in range(_rows(I, AROW)):
        th, s, c = angle(I, Fl, ACOL, AV, i, qx, sq, cq)
        hessian(I, Fl, AV, i, s, c, sq, cq, H)
        b1, b2 = _i(I, ACOL, i, 0), _i(I, ACOL, i, 1)
        hessian_times(b1, b2, H, vx, hv)
        row = _i(I, AROW, i, 0)
        for b in range(18):
            cb = column(b1, b2, b)
            if cb >= 0:
                p = _put(R, C, V, p, r0 + row, c0 + cb, coef * hv[b])
    return p
