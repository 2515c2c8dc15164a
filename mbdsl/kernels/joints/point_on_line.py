"""A point on a line (the prismatic joint's rows, a slot): Phi = n . (p_P - p_L),
n = A_L n0 the line's normal, one row; a distance driver subtracts f(t).

With d = p_P - p_L and D = dd/dq over (x_L, y_L, phi_L, x_P, y_P, phi_P):

    Phi_q  = n^T D + (B_L n0 . d) e_phiL^T
    Phi_qq = n . D_qq + e_phiL (B_L n0)^T D + D^T (B_L n0) e_phiL^T
             - (n . d) e_phiL e_phiL^T
    Phi_t  = -f'(t),  Phi_tt = -f''(t),  Phi_qt = 0

(only row and column phi_L and the entry (phi_P, phi_P) of the Hessian are
nonzero; Haug, sec. 3.3, the translational joint; Nikravesh, sec. 4.5). With
n0 the line's unit normal and no f, P stays on the line (point_on_line,
prismatic); a distance driver along a sliding joint puts the line's unit
direction in n0, so that n . d is the distance of P along the line. The
elastic columns of a point on a beam are added by ``beams.elastic_points``.

Fields: PROW (k,) the rows, PCOLL, PCOLP (k, 3) the columns of the line's
and the point's bodies, PSL, PSP (k, 2) the local positions [m], PN0 (k, 2)
the normal in the line's body, PEL (k, 4) elastic spans, PFN (k, 3) the
programs of a driver f, f', f'' (-1: none).
"""

from __future__ import annotations

import numpy as np

from ..geometry import _As, _Au
from ..programs import _eval
from ..schema import (PCOLL, PCOLP, PEL, PFN, PN0, PROW, PSL, PSP, _i, _inline, _jit, _put,
                      _put_phiq, _rows)

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("prow", "pcolL", "psL", "pcolP", "psP", "pn0", "pfn", "pel")
#: Newton-matrix triplets per instance: Phi_q, (Phi_q^T lambda)_q, (Phi_q v)_q.
PHIQ_TRIPLETS, HESS_TRIPLETS, G_TRIPLETS = 6, 12, 6
#: The joints and drivers whose rows it holds: kind -> the first of them among the
#: element's rows (a driver of a sliding joint's distance: ``joint_distance``).
ELEMENT_ROWS = {"point_on_line": 0, "prismatic": 0, "joint_distance": 0}


def pack(items, tables) -> dict:
    """Its fields from the model's joints and drivers: the line through the
    joint's second point, the first point on it (its normal in the line's
    body), or driven along it by f(t) (its direction, the programs of f, f',
    f'').

    Parameters
    ----------
    items : list of (int, Joint or Driver)
        Per instance, its row of lambda and the element (a kind of
        ``ELEMENT_ROWS``), in the model's order.
    tables : packing context
        ``points``, ``elastic_spans`` and ``driver_programs``
        (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    joints = [e.joint if e.kind == "joint_distance" else e for _, e in items]
    line, point = [j.second for j in joints], [j.first for j in joints]
    (colL, sL), (colP, sP) = tables.points(line), tables.points(point)
    tables.elastic_spans("pel", line, point)
    n0 = [np.asarray(e.joint.direction, float) if e.kind == "joint_distance"
          else np.array([-e.direction[1], e.direction[0]]) for _, e in items]
    fn = [tables.driver_programs(e.function) if e.kind == "joint_distance" else (-1, -1, -1)
          for _, e in items]
    return {"prow": np.array([r for r, _ in items], np.int64), "pcolL": colL, "psL": sL,
            "pcolP": colP, "psP": sP, "pn0": np.array(n0, np.float64).reshape(-1, 2),
            "pfn": np.array(fn, np.int64).reshape(-1, 3)}


@_jit
def _pol(I, Fl, qx, i):
    """Point-on-line parts: n, d = p_P - p_L, A u_L, A u_P."""
    axL, ayL = _Au(I, Fl, qx, PCOLL, PSL, PEL, 0, i)
    axP, ayP = _Au(I, Fl, qx, PCOLP, PSP, PEL, 1, i)
    dx = (qx[_i(I, PCOLP, i, 0)] - qx[_i(I, PCOLL, i, 0)]) + (axP - axL)
    dy = (qx[_i(I, PCOLP, i, 1)] - qx[_i(I, PCOLL, i, 1)]) + (ayP - ayL)
    nx, ny = _As(I, Fl, qx, PCOLL, PN0, i)
    return nx, ny, dx, dy, axL, ayL, axP, ayP


@_jit
def _pol_grad(nx, ny, dx, dy, axL, ayL, axP, ayP):
    """Local gradient of n . d over (x_L, y_L, phi_L, x_P, y_P, phi_P): six
    scalars (no array: an allocation costs more than the arithmetic here)."""
    return (-nx, -ny, -(-nx * ayL + ny * axL) + (-ny * dx + nx * dy),
            nx, ny, -nx * ayP + ny * axP)


@_jit
def _pol_hess(nx, ny, dx, dy, axL, ayL, axP, ayP, bnd):
    """Hessian of n . d: (Bn . D) into bnd (6,); returns (H[phiL, phiL], H[phiP, phiP]).

    H = n . D_qq + e_L (Bn)^T D + D^T Bn e_L^T - (n . d) e_L e_L^T
    (the module's docstring): its only nonzeros are row and column phi_L and
    the entry (phi_P, phi_P).
    """
    bx, by = -ny, nx
    bnd[0] = -bx
    bnd[1] = -by
    bnd[2] = -(bx * (-ayL) + by * axL)
    bnd[3] = bx
    bnd[4] = by
    bnd[5] = bx * (-ayP) + by * axP
    hLL = (nx * axL + ny * ayL) + 2.0 * bnd[2] - (nx * dx + ny * dy)
    hPP = -(nx * axP + ny * ayP)
    return hLL, hPP


@_inline
def phi(I, Fl, t, qx, out):
    """Phi into out (m,) [m]."""
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        out[_i(I, PROW, i, 0)] = nx * dx + ny * dy
        if _i(I, PFN, i, 0) >= 0:                  # a distance driver f(t)
            out[_i(I, PROW, i, 0)] -= _eval(I, Fl, _i(I, PFN, i, 0), t)


@_inline
def phi_time_add(I, Fl, t, out, order):
    """out (m,) += the order-th time derivative of Phi: -f'(t), -f''(t) of drivers."""
    for i in range(_rows(I, PROW)):
        if _i(I, PFN, i, order) >= 0:
            out[_i(I, PROW, i, 0)] -= _eval(I, Fl, _i(I, PFN, i, order), t)


@_inline
def phiqT_add(I, Fl, qx, lam, coef, out):
    """out (n+3,) += coef Phi_q^T lambda [N, N m] (rigid columns)."""
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        g0, g1, g2, g3, g4, g5 = _pol_grad(nx, ny, dx, dy, axL, ayL, axP, ayP)
        lv = coef * lam[_i(I, PROW, i, 0)]
        out[_i(I, PCOLL, i, 0)] += lv * g0
        out[_i(I, PCOLL, i, 1)] += lv * g1
        out[_i(I, PCOLL, i, 2)] += lv * g2
        out[_i(I, PCOLP, i, 0)] += lv * g3
        out[_i(I, PCOLP, i, 1)] += lv * g4
        out[_i(I, PCOLP, i, 2)] += lv * g5


@_inline
def phiq_times(I, Fl, qx, vx, out):
    """Phi_q v into out (m,) [m/s] (rigid columns)."""
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        g0, g1, g2, g3, g4, g5 = _pol_grad(nx, ny, dx, dy, axL, ayL, axP, ayP)
        out[_i(I, PROW, i, 0)] = (g0 * vx[_i(I, PCOLL, i, 0)] + g1 * vx[_i(I, PCOLL, i, 1)] + g2 * vx[_i(I, PCOLL, i, 2)]
                        + g3 * vx[_i(I, PCOLP, i, 0)] + g4 * vx[_i(I, PCOLP, i, 1)] + g5 * vx[_i(I, PCOLP, i, 2)])


@_inline
def emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """coef Phi_q at (r0, c0), or coef Phi_q^T when transpose; returns p."""
    if _rows(I, PROW) == 0:
        return p
    g = np.empty(6)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        g[0], g[1], g[2], g[3], g[4], g[5] = _pol_grad(nx, ny, dx, dy, axL, ayL, axP, ayP)
        row = _i(I, PROW, i, 0)
        for j in range(6):
            col = _i(I, PCOLL, i, j) if j < 3 else _i(I, PCOLP, i, j - 3)
            if col < n:
                p = _put_phiq(R, C, V, p, r0, c0, row, col, coef * g[j], transpose)
    return p


@_inline
def emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """coef (Phi_q^T lambda)_q at (r0, c0); returns p."""
    if _rows(I, PROW) == 0:
        return p
    bnd = np.empty(6)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        hLL, hPP = _pol_hess(nx, ny, dx, dy, axL, ayL, axP, ayP, bnd)
        lv = coef * lam[_i(I, PROW, i, 0)]
        cL, cP = _i(I, PCOLL, i, 2), _i(I, PCOLP, i, 2)
        for j in range(6):
            col = _i(I, PCOLL, i, j) if j < 3 else _i(I, PCOLP, i, j - 3)
            if j == 2 or col >= n or cL >= n:
                continue
            p = _put(R, C, V, p, r0 + cL, c0 + col, lv * bnd[j])
            p = _put(R, C, V, p, r0 + col, c0 + cL, lv * bnd[j])
        if cL < n:
            p = _put(R, C, V, p, r0 + cL, c0 + cL, lv * hLL)
        if cP < n:
            p = _put(R, C, V, p, r0 + cP, c0 + cP, lv * hPP)
    return p


@_inline
def emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """coef (Phi_q v)_q at (r0, c0); returns p."""
    if _rows(I, PROW) == 0:
        return p
    bnd = np.empty(6)
    v6 = np.empty(6)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        hLL, hPP = _pol_hess(nx, ny, dx, dy, axL, ayL, axP, ayP, bnd)
        for j in range(3):
            v6[j] = vx[_i(I, PCOLL, i, j)]
            v6[3 + j] = vx[_i(I, PCOLP, i, j)]
        row = _i(I, PROW, i, 0)
        for j in range(6):       # (H v)_j, H symmetric
            col = _i(I, PCOLL, i, j) if j < 3 else _i(I, PCOLP, i, j - 3)
            if j == 2:
                hv = hLL * v6[2]
                for k in range(6):
                    if k != 2:
                        hv += bnd[k] * v6[k]
            else:
                hv = bnd[j] * v6[2]
                if j == 5:
                    hv += hPP * v6[5]
            if col < n:
                p = _put(R, C, V, p, r0 + row, c0 + col, coef * hv)
    return p
