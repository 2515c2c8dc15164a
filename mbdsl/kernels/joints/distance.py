"""A distance between two points: Phi = (d . d - L^2) / (2 L), d = p2 - p1, one
row (a massless link; the scaling by 2 L makes Phi a length near the
constraint, and its multiplier the link's tension [N]).

Gradient d^T D / L and Hessian (D^T D + sum_a d_a D_a,qq) / L over (x1, y1,
phi1, x2, y2, phi2), D = dd/dq (Haug, sec. 3.2, the distance constraint).
Points on flexible beams add their elastic columns (``_dist_local``, used by
``beams.elastic_points``).

Fields: DROW (k,) the rows, DCOL1, DCOL2 (k, 3) the bodies' columns, DS1,
DS2 (k, 2) the local positions [m], DLEN (k,) L [m], DSP (k, 4) elastic spans.

Besides its kernels, the joint's module holds what the assembly asks of the
joint kind (``docs/architecture.md``, "Adding a joint"): how it packs from the
model (:func:`pack`), where the first guess of the initial conditions puts the
far body (:func:`start_point`: both points at one place would leave the row
without a gradient) and how far the joint is from holding, from its row's
residual (:func:`miss`).
"""

from __future__ import annotations

import math

import numpy as np

from ..beams.elastic_points import (_scalar_row_terms, apply_phiq, apply_phiqT, grad_buffers,
                                    put_grad)
from ..geometry import _Au, _eshape, _span
from ..schema import (DCOL1, DCOL2, DLEN, DROW, DS1, DS2, DSP, ECOL, _f, _i, _inline, _jit, _put,
                      _put_phiq, _rows)

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("drow", "dcol1", "ds1", "dcol2", "ds2", "dlen", "dsp")
#: Newton-matrix triplets per instance: Phi_q, (Phi_q^T lambda)_q, (Phi_q v)_q.
PHIQ_TRIPLETS, HESS_TRIPLETS, G_TRIPLETS = 6, 36, 6
#: The joints whose rows it holds: kind -> the first of them among the joint's rows.
ELEMENT_ROWS = {"distance": 0}


def pack(items, tables) -> dict:
    """Its fields from the model's joints.

    Parameters
    ----------
    items : list of (int, Joint)
        Per instance, its row of lambda and the joint, in the model's order.
    tables : packing context
        ``joint_points`` (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    dcol1, ds1, dcol2, ds2 = tables.joint_points("dsp", [j for _, j in items])
    return {"drow": np.array([r for r, _ in items], np.int64), "dcol1": dcol1, "ds1": ds1,
            "dcol2": dcol2, "ds2": ds2,
            "dlen": np.array([j.length for _, j in items], np.float64)}


def start_point(joint, centre, offset, down, along, x=None, y=None):
    """Where the first guess of the initial conditions puts the far point.

    Parameters
    ----------
    joint : Joint
        The distance joint; ``joint.length`` L [m].
    centre : ndarray, shape (2,) [m]
        The near point (on the body already placed).
    offset : ndarray, shape (2,) [m]
        The far point relative to its body's reference point.
    down : ndarray, shape (2,)
        The default unit direction (along gravity, else -y).
    along : str
        Its name ("gravity" or "-y"), for ``how``.
    x, y : float or None [m]
        The far body's x or y, when the initial conditions give them.

    Returns
    -------
    point : ndarray, shape (2,) [m]
        With x (or y) given, the point of the circle of radius L about
        ``centre`` at that x (or y) on the side of ``down``; else ``centre +
        L down``.
    how : str
        Which, for the "solved for" line (empty when x and y are both given:
        the user placed the body).
    """
    length = joint.length
    if x is not None and y is not None:
        return centre, ""
    if x is not None or y is not None:
        k = 0 if x is not None else 1           # the given coordinate
        p_k = (x if x is not None else y) + offset[k]
        rest = length ** 2 - (p_k - centre[k]) ** 2
        if rest >= 0.0:
            p = np.array(centre, dtype=float)
            p[k] = p_k
            side = down[1 - k] if down[1 - k] != 0.0 else -1.0
            p[1 - k] = centre[1 - k] + np.copysign(np.sqrt(rest), side)
            return p, f"on its circle at the given {'xy'[k]}"
    return (np.asarray(centre, float) + length * down, f"{length:.6g} m along {along}")


def miss(joint, residual) -> float:
    """How far the joint is from holding [m]: its row is (|d|^2 - L^2) / (2 L),
    so the miss is | |d| - L | = | sqrt(L^2 + 2 L Phi) - L |, not Phi.

    Parameters
    ----------
    joint : Joint
    residual : ndarray, shape (1,) [m]
        The joint's row of Phi.
    """
    L = joint.length
    if not L > 0.0:
        return float(np.max(np.abs(residual), initial=0.0))
    return float(abs(math.sqrt(max(L * L + 2.0 * L * float(residual[0]), 0.0)) - L))


@_jit
def _dist(I, Fl, qx, i, g):
    """Distance joint i: d = p2 - p1 and A1 u1, A2 u2 (u = s + S q_e on a
    flexible beam), its length L; the gradient of Phi over (x1, y1, phi1,
    x2, y2, phi2) into g (6,) (the elastic columns: ``_dist_local``).
    Returns (dx, dy, ax1, ay1, ax2, ay2, L)."""
    ax1, ay1 = _Au(I, Fl, qx, DCOL1, DS1, DSP, 0, i)
    ax2, ay2 = _Au(I, Fl, qx, DCOL2, DS2, DSP, 1, i)
    dx = (qx[_i(I, DCOL2, i, 0)] - qx[_i(I, DCOL1, i, 0)]) + (ax2 - ax1)
    dy = (qx[_i(I, DCOL2, i, 1)] - qx[_i(I, DCOL1, i, 1)]) + (ay2 - ay1)
    L = _f(I, Fl, DLEN, i, 0)
    g[0], g[1], g[2] = -dx / L, -dy / L, (dx * ay1 - dy * ax1) / L
    g[3], g[4], g[5] = dx / L, dy / L, (-dx * ay2 + dy * ax2) / L
    return dx, dy, ax1, ay1, ax2, ay2, L


@_jit
def _dist_col(I, i, j):
    """Column of local entry j (x1, y1, phi1, x2, y2, phi2) of distance joint i."""
    return _i(I, DCOL1, i, j) if j < 3 else _i(I, DCOL2, i, j - 3)


@_jit
def _dist_hess(dx, dy, ax1, ay1, ax2, ay2, L, H):
    """Hessian of the distance row, (D^T D + sum_a d_a D_a,qq) / L, into H (6, 6);
    D = dd/dq = [[-1, 0, ay1, 1, 0, -ay2], [0, -1, -ax1, 0, 1, ax2]]."""
    D0 = (-1.0, 0.0, ay1, 1.0, 0.0, -ay2)
    D1 = (0.0, -1.0, -ax1, 0.0, 1.0, ax2)
    for a in range(6):
        for b in range(6):
            H[a, b] = (D0[a] * D0[b] + D1[a] * D1[b]) / L
    H[2, 2] += (dx * ax1 + dy * ay1) / L
    H[5, 5] -= (dx * ax2 + dy * ay2) / L


@_jit
def _dist_local(I, Fl, qx, i, cols, D, Hd):
    """Distance joint i with points on flexible beams over its local
    columns (x, y, phi of both bodies, then each point's elastic terms):
    their columns into cols, D = dd/dq_local (2, nc) and Hd = d^2 d/dq_local^2
    (2, nc, nc) into D, Hd (zeroed; d^2 p/dphi^2 = -A u, d^2 p/dphi dq_k =
    B S_k). Returns (nc, dx, dy, L); Phi's Hessian is (D^T D + d . Hd) / L."""
    g = np.empty(6)
    dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
    D[:, :] = 0.0
    Hd[:, :, :] = 0.0
    for j in range(3):
        cols[j] = _i(I, DCOL1, i, j)
        cols[3 + j] = _i(I, DCOL2, i, j)
    D[0, 0], D[1, 1], D[0, 3], D[1, 4] = -1.0, -1.0, 1.0, 1.0
    D[0, 2], D[1, 2], D[0, 5], D[1, 5] = ay1, -ax1, -ay2, ax2
    Hd[0, 2, 2], Hd[1, 2, 2], Hd[0, 5, 5], Hd[1, 5, 5] = ax1, ay1, -ax2, -ay2
    j = 6
    for sd in range(2):
        sg, cph = (-1.0, 2) if sd == 0 else (1.0, 5)
        k0, k1 = _span(I, DSP, i, sd)
        for k in range(k0, k1):
            cols[j] = _i(I, ECOL, k, 0)
            ax, ay, bx, by = _eshape(I, Fl, k, qx[cols[cph]])
            D[0, j], D[1, j] = sg * ax, sg * ay
            Hd[0, cph, j], Hd[1, cph, j] = sg * bx, sg * by
            Hd[0, j, cph], Hd[1, j, cph] = sg * bx, sg * by
            j += 1
    return j, dx, dy, L


@_jit
def _dist_columns(I):
    """The most local columns of a distance joint (``_dist_local``)."""
    out = 6
    for i in range(_rows(I, DROW)):
        a0, a1 = _span(I, DSP, i, 0)
        b0, b1 = _span(I, DSP, i, 1)
        out = max(out, 6 + (a1 - a0) + (b1 - b0))
    return out


@_inline
def _dist_h(D, Hd, dx, dy, L, a, b):
    """Entry (a, b) of a distance row's Hessian (``_dist_local``)."""
    return (D[0, a] * D[0, b] + D[1, a] * D[1, b] + dx * Hd[0, a, b] + dy * Hd[1, a, b]) / L


@_inline
def phi(I, Fl, t, qx, out):
    """Phi into out (m,) [m]."""
    if _rows(I, DROW) == 0:
        return
    g = np.empty(6)
    for i in range(_rows(I, DROW)):
        dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
        out[_i(I, DROW, i, 0)] = (dx * dx + dy * dy - L * L) / (2.0 * L)


@_inline
def phiqT_add(I, Fl, qx, lam, coef, out):
    """out (n+3,) += coef Phi_q^T lambda [N, N m] (rigid columns)."""
    if _rows(I, DROW) == 0:
        return
    g = np.empty(6)
    for i in range(_rows(I, DROW)):
        _dist(I, Fl, qx, i, g)
        lv = coef * lam[_i(I, DROW, i, 0)]
        for j in range(6):
            out[_dist_col(I, i, j)] += lv * g[j]


@_inline
def phiq_times(I, Fl, qx, vx, out):
    """Phi_q v into out (m,) [m/s] (rigid columns)."""
    if _rows(I, DROW) == 0:
        return
    g = np.empty(6)
    for i in range(_rows(I, DROW)):
        _dist(I, Fl, qx, i, g)
        acc = 0.0
        for j in range(6):
            acc += g[j] * vx[_dist_col(I, i, j)]
        out[_i(I, DROW, i, 0)] = acc


@_inline
def emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """coef Phi_q at (r0, c0), or coef Phi_q^T when transpose; returns p."""
    if _rows(I, DROW) == 0:
        return p
    g = np.empty(6)
    for i in range(_rows(I, DROW)):
        _dist(I, Fl, qx, i, g)
        row = _i(I, DROW, i, 0)
        for j in range(6):
            col = _dist_col(I, i, j)
            if col < n:
                p = _put_phiq(R, C, V, p, r0, c0, row, col, coef * g[j], transpose)
    return p


@_inline
def emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """coef (Phi_q^T lambda)_q at (r0, c0); returns p."""
    if _rows(I, DROW) == 0:
        return p
    g, H = np.empty(6), np.empty((6, 6))
    for i in range(_rows(I, DROW)):
        dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
        _dist_hess(dx, dy, ax1, ay1, ax2, ay2, L, H)
        lv = coef * lam[_i(I, DROW, i, 0)]
        for a in range(6):
            ca = _dist_col(I, i, a)
            for b in range(6):
                cb = _dist_col(I, i, b)
                if ca < n and cb < n:
                    p = _put(R, C, V, p, r0 + ca, c0 + cb, lv * H[a, b])
    return p


@_inline
def emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """coef (Phi_q v)_q at (r0, c0); returns p."""
    if _rows(I, DROW) == 0:
        return p
    g, H = np.empty(6), np.empty((6, 6))
    v6 = np.empty(6)
    for i in range(_rows(I, DROW)):
        dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
        _dist_hess(dx, dy, ax1, ay1, ax2, ay2, L, H)
        for j in range(6):
            v6[j] = vx[_dist_col(I, i, j)]
        row = _i(I, DROW, i, 0)
        for a in range(6):
            col = _dist_col(I, i, a)
            if col < n:
                hv = 0.0
                for b in range(6):
                    hv += H[a, b] * v6[b]
                p = _put(R, C, V, p, r0 + row, c0 + col, coef * hv)
    return p


# --------------------------------------------------------------------------------------------
# Points on flexible beams: the entries of the elastic columns (u = s + S q_e), emitted
# after the other joints' (``system``: the order of every aggregate); the gradient's
# triplets are applied by ``beams.elastic_points``' appliers.
# --------------------------------------------------------------------------------------------


@_jit
def _elastic_grad(I, Fl, qx, rows, cols, vals):
    """The elastic entries of the distance rows' Phi_q, -+(d / L) . (A S_k) of
    each point's terms: (row, column, value) into rows, cols, vals (each of 2
    x the elastic terms); returns their count."""
    p = 0
    g = np.empty(6)
    for i in range(_rows(I, DROW)):
        dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
        p = _scalar_row_terms(I, Fl, qx, DCOL1, DCOL2, DSP, i, _i(I, DROW, i, 0), dx / L,
                              dy / L, rows, cols, vals, p)
    return p


@_jit
def elastic_phiqT_add(I, Fl, qx, lam, coef, out):
    """out += coef Phi_q^T lambda in the elastic columns of the distance rows."""
    if _rows(I, DSP) == 0:
        return
    rows, cols, vals = grad_buffers(I)
    apply_phiqT(rows, cols, vals, _elastic_grad(I, Fl, qx, rows, cols, vals), lam, coef, out)


@_jit
def elastic_phiq_times(I, Fl, qx, vx, out):
    """out += Phi_q v of the distance rows' elastic columns."""
    if _rows(I, DSP) == 0:
        return
    rows, cols, vals = grad_buffers(I)
    apply_phiq(rows, cols, vals, _elastic_grad(I, Fl, qx, rows, cols, vals), vx, out)


@_jit
def emit_elastic_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """The elastic columns of the distance rows of coef Phi_q at (r0, c0) (or of
    Phi_q^T)."""
    if _rows(I, DSP) == 0:
        return p
    rows, cols, vals = grad_buffers(I)
    return put_grad(rows, cols, vals, _elastic_grad(I, Fl, qx, rows, cols, vals), R, C, V, p,
                    r0, c0, coef, transpose)


@_jit
def emit_elastic_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """The distance rows' entries of coef (Phi_q^T lambda)_q at (r0, c0) with an
    elastic column (``_dist_local``)."""
    if _rows(I, DSP) > 0:      # distance rows: every entry with an elastic column
        nmax = _dist_columns(I)
        cols = np.empty(nmax, np.int64)
        D, Hd = np.empty((2, nmax)), np.empty((2, nmax, nmax))
        for i in range(_rows(I, DROW)):
            nc, dx, dy, L = _dist_local(I, Fl, qx, i, cols, D, Hd)
            lv = coef * lam[_i(I, DROW, i, 0)]
            for a in range(nc):
                for b in range(nc):
                    if (a >= 6 or b >= 6) and cols[a] < n and cols[b] < n:
                        p = _put(R, C, V, p, r0 + cols[a], c0 + cols[b],
                                 lv * _dist_h(D, Hd, dx, dy, L, a, b))
    return p


@_jit
def emit_elastic_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """The distance rows' entries of coef (Phi_q v)_q at (r0, c0) with an
    elastic column: v^T Hess."""
    if _rows(I, DSP) > 0:      # distance rows: v^T Hess, the terms with an elastic column
        nmax = _dist_columns(I)
        cols = np.empty(nmax, np.int64)
        D, Hd = np.empty((2, nmax)), np.empty((2, nmax, nmax))
        for i in range(_rows(I, DROW)):
            nc, dx, dy, L = _dist_local(I, Fl, qx, i, cols, D, Hd)
            row = _i(I, DROW, i, 0)
            for b in range(nc):
                if cols[b] >= n:
                    continue
                acc = 0.0
                for a in range(nc):
                    if a >= 6 or b >= 6:
                        acc += _dist_h(D, Hd, dx, dy, L, a, b) * vx[cols[a]]
                if nc > 6:
                    p = _put(R, C, V, p, r0 + row, c0 + cols[b], coef * acc)
    return p


def elastic_triplets(I) -> int:
    """Triplets beyond ``PHIQ/HESS/G_TRIPLETS`` of the distance joints with
    points on beams, per force-block pair (``system.triplet_bound``): four
    (6 + e)^2 Hessian and two 6 + e G blocks, e the elastic terms of the
    joint's points (its spans into ECOL), counted as 2 c^2 + c, c = 6 + e."""
    out = 0
    for i in range(int(I[3 * DSP + 1])):
        o = int(I[3 * DSP]) + 4 * i
        c = 6 + int(I[o + 1] - I[o] + I[o + 3] - I[o + 2])
        out += 2 * c * c + c
    return out
