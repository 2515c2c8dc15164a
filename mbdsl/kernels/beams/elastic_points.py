"""Joint points on flexible beams: the elastic columns of coincidence and
point-on-line joints (a distance joint's are in its own module, which calls
:func:`_scalar_row_terms`).

A point of a flexible beam is at r + A(phi) u, u = s + sum_k S_k q_k. Its
position's derivative by q_k is A S_k, and the only second derivatives the
elastic terms add are d^2/dphi dq_k = B S_k (Shabana, Dynamics of Multibody
Systems, sec. 5.3). The rigid kernels above already read u (``_Au``) where
they read s; the functions below add the entries of the elastic columns.
Coincidence: Phi = p2 - p1, sign -1 for point 1. Point on line: Phi = n . (p_P
- p_L), n = A_L n0: d/dq_k = +-n . (A S_k), and for a term of P the mixed
entries (phi_L, q_k) = (B_L n0) . (A_P S_k) and (phi_P, q_k) = n . (B_P S_k);
a term of L has the constant gradient -n0 . S_k and no second derivative.
"""

from __future__ import annotations

import numpy as np

from ..geometry import _eshape, _span
from ..joints.point_on_line import _pol
from ..schema import (CCOL1, CCOL2, CEL, CROW, ECOL, PCOLL, PCOLP, PEL, PROW, _i, _inline, _jit,
                      _put, _put_phiq, _rows)

#: Its fields in ``schema.MODEL_SCHEMA``: the elastic terms of points on beams (column, S_k);
#: each element's spans into them are the element's own fields (CEL, PEL, SEL, FEL, DSP).
FIELDS = ("ecol", "eshp")


@_jit
def _elastic_grad(I, Fl, qx, rows, cols, vals):
    """The elastic entries of Phi_q: (constraint row, column, value) into rows,
    cols, vals (each of 2 x the elastic terms); returns their count.
    Coincidence: +-A S_k per row; point on line: +-n . (A S_k)."""
    p = 0
    for i in range(_rows(I, CROW)):
        for sd in range(2):
            sg, ph = (-1.0 if sd == 0 else 1.0), qx[_i(I, CCOL1 if sd == 0 else CCOL2, i, 2)]
            k0, k1 = _span(I, CEL, i, sd)
            for k in range(k0, k1):
                ax, ay, bx, by = _eshape(I, Fl, k, ph)
                for a in range(2):
                    rows[p], cols[p] = _i(I, CROW, i, a), _i(I, ECOL, k, 0)
                    vals[p] = sg * (ax if a == 0 else ay)
                    p += 1
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        p = _scalar_row_terms(I, Fl, qx, PCOLL, PCOLP, PEL, i, _i(I, PROW, i, 0), nx, ny,
                              rows, cols, vals, p)
    return p


@_jit
def _scalar_row_terms(I, Fl, qx, col1, col2, el, i, row, nx, ny, rows, cols, vals, p):
    """The elastic entries of a scalar row whose gradient is n . dd/dq (a point
    on a line: its normal; a distance joint: d / L): -+n . (A S_k) of the
    terms of instance i's first and second point, from p on; returns p."""
    for sd in range(2):
        sg, ph = (-1.0 if sd == 0 else 1.0), qx[_i(I, col1 if sd == 0 else col2, i, 2)]
        k0, k1 = _span(I, el, i, sd)
        for k in range(k0, k1):
            ax, ay, bx, by = _eshape(I, Fl, k, ph)
            rows[p], cols[p] = row, _i(I, ECOL, k, 0)
            vals[p] = sg * (nx * ax + ny * ay)
            p += 1
    return p


# The entries of the elastic columns of Phi_q as triplets (row, column, value), each
# family's gradient (this module's ``_elastic_grad``, the distance joint's own) written
# into the buffers of ``grad_buffers`` and applied by the three functions after it:
# the gradient is their argument as arrays, not as a function (numba caches no
# function that takes a function, nor any of its callers up to the time loop).
@_inline
def grad_buffers(I):
    """(rows, cols, vals) for the elastic entries of Phi_q: two per elastic term."""
    k = 2 * _rows(I, ECOL)
    return np.empty(k, np.int64), np.empty(k, np.int64), np.empty(k)


@_inline
def apply_phiqT(rows, cols, vals, count, lam, coef, out):
    """out += coef Phi_q^T lambda over the first ``count`` triplets."""
    for e in range(count):
        out[cols[e]] += coef * lam[rows[e]] * vals[e]


@_inline
def apply_phiq(rows, cols, vals, count, vx, out):
    """out += Phi_q v over the first ``count`` triplets."""
    for e in range(count):
        out[rows[e]] += vals[e] * vx[cols[e]]


@_inline
def put_grad(rows, cols, vals, count, R, C, V, p, r0, c0, coef, transpose):
    """The first ``count`` triplets times coef at (r0, c0) (transposed: of
    Phi_q^T); returns p."""
    for e in range(count):
        p = _put_phiq(R, C, V, p, r0, c0, rows[e], cols[e], coef * vals[e], transpose)
    return p


@_jit
def _elastic_phiqT_add(I, Fl, qx, lam, coef, out):
    """out += coef Phi_q^T lambda in the elastic columns."""
    rows, cols, vals = grad_buffers(I)
    apply_phiqT(rows, cols, vals, _elastic_grad(I, Fl, qx, rows, cols, vals), lam, coef, out)


@_jit
def _elastic_phiq_times(I, Fl, qx, vx, out):
    """out += Phi_q v of the elastic columns."""
    rows, cols, vals = grad_buffers(I)
    apply_phiq(rows, cols, vals, _elastic_grad(I, Fl, qx, rows, cols, vals), vx, out)


@_jit
def _emit_elastic_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """The elastic columns of coef Phi_q at (r0, c0) (or of Phi_q^T)."""
    rows, cols, vals = grad_buffers(I)
    return put_grad(rows, cols, vals, _elastic_grad(I, Fl, qx, rows, cols, vals), R, C, V, p,
                    r0, c0, coef, transpose)


@_jit
def _emit_elastic_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """The elastic entries of coef (Phi_q^T lambda)_q at (r0, c0): the mixed
    (phi, q_k) second derivatives, both triangles."""
    for i in range(_rows(I, CROW)):
        l0, l1 = coef * lam[_i(I, CROW, i, 0)], coef * lam[_i(I, CROW, i, 1)]
        for sd in range(2):
            cph = _i(I, CCOL1 if sd == 0 else CCOL2, i, 2)
            sg, ph = (-1.0 if sd == 0 else 1.0), qx[cph]
            k0, k1 = _span(I, CEL, i, sd)
            for k in range(k0, k1):
                ax, ay, bx, by = _eshape(I, Fl, k, ph)
                col, val = _i(I, ECOL, k, 0), sg * (l0 * bx + l1 * by)
                if cph < n:
                    p = _put(R, C, V, p, r0 + cph, c0 + col, val)
                    p = _put(R, C, V, p, r0 + col, c0 + cph, val)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        lv = coef * lam[_i(I, PROW, i, 0)]
        cL, cP = _i(I, PCOLL, i, 2), _i(I, PCOLP, i, 2)
        k0, k1 = _span(I, PEL, i, 1)
        for k in range(k0, k1):
            ax, ay, bx, by = _eshape(I, Fl, k, qx[cP])
            col = _i(I, ECOL, k, 0)
            hL, hP = -ny * ax + nx * ay, nx * bx + ny * by
            if cL < n:
                p = _put(R, C, V, p, r0 + cL, c0 + col, lv * hL)
                p = _put(R, C, V, p, r0 + col, c0 + cL, lv * hL)
            if cP < n:
                p = _put(R, C, V, p, r0 + cP, c0 + col, lv * hP)
                p = _put(R, C, V, p, r0 + col, c0 + cP, lv * hP)
    return p


@_jit
def _emit_elastic_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """The elastic entries of coef (Phi_q v)_q at (r0, c0)."""
    for i in range(_rows(I, CROW)):
        for sd in range(2):
            cph = _i(I, CCOL1 if sd == 0 else CCOL2, i, 2)
            sg, ph, w = (-1.0 if sd == 0 else 1.0), qx[cph], vx[cph]
            k0, k1 = _span(I, CEL, i, sd)
            for k in range(k0, k1):
                ax, ay, bx, by = _eshape(I, Fl, k, ph)
                col, vk = _i(I, ECOL, k, 0), vx[_i(I, ECOL, k, 0)]
                for a in range(2):
                    row, b = _i(I, CROW, i, a), (bx if a == 0 else by)
                    if cph < n:
                        p = _put(R, C, V, p, r0 + row, c0 + cph, coef * sg * b * vk)
                    p = _put(R, C, V, p, r0 + row, c0 + col, coef * sg * b * w)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        row = _i(I, PROW, i, 0)
        cL, cP = _i(I, PCOLL, i, 2), _i(I, PCOLP, i, 2)
        k0, k1 = _span(I, PEL, i, 1)
        for k in range(k0, k1):
            ax, ay, bx, by = _eshape(I, Fl, k, qx[cP])
            col, vk = _i(I, ECOL, k, 0), vx[_i(I, ECOL, k, 0)]
            hL, hP = -ny * ax + nx * ay, nx * bx + ny * by
            if cL < n:
                p = _put(R, C, V, p, r0 + row, c0 + cL, coef * hL * vk)
            if cP < n:
                p = _put(R, C, V, p, r0 + row, c0 + cP, coef * hP * vk)
            p = _put(R, C, V, p, r0 + row, c0 + col, coef * (hL * vx[cL] + hP * vx[cP]))
    return p
