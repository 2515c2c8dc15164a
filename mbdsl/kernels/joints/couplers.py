"""Couplers: one row Phi = sum_k a_k x_k(q) - c relating joint coordinates (a
gear pair or a belt between two revolute angles, a rack and pinion, any
linear combination: ``model.elements.Coupler``).

Each x_k is a state variable (``programs._state_values``): a revolute
joint's angle phi2 - phi1, linear in q (two columns, constant gradient), or
a sliding joint's distance s = u . (p_P - p_L) along its line
(``geometry._line``: gradient and Hessian over the six columns of the
line's two bodies). So

    Phi_q  = sum_k a_k dx_k/dq
    Phi_qq = sum_k a_k d2x_k/dq2    (nonzero only for distances: row and
                                     column phi_L, and (phi_P, phi_P))
    Phi_t = Phi_tt = 0

(Haug, Computer Aided Kinematics and Dynamics of Mechanical Systems, sec.
3.4, gears and rack-and-pinion as constraints between joint coordinates).
A coupler's rows are written after every other family's (it sums its terms
into them), so it comes last in ``kernels.system.JOINTS``. Its kernels are
compiled apart, not inlined, and the aggregates call them only for a model
with couplers: inlined into every aggregate they cost the double pendulum,
which has none, 0.1 us of its 4.3 us per step.

Fields: XTRM (j, 2) per term (row of lambda, row of the variable in VAR),
XTC (j,) its coefficient a_k, XROW (k,) the couplers' rows, XOFF (k,) their
constant c [rad or m].
"""

from __future__ import annotations

import numpy as np

from ..geometry import _line
from ..schema import GEO, VAR, VARC, XOFF, XROW, XTC, XTRM, _f, _i, _inline, _jit, _put, _put_phiq, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances: the terms).
FIELDS = ("xtrm", "xtc", "xrow", "xoff")
#: Newton-matrix triplets per term: Phi_q (six columns of a distance, two of an angle),
#: (Phi_q^T lambda)_q (a distance's Hessian: row and column phi_L, and (phi_P, phi_P)),
#: (Phi_q v)_q (six).
PHIQ_TRIPLETS, HESS_TRIPLETS, G_TRIPLETS = 6, 12, 6
#: The elements whose rows it holds (``Coupler.kind``).
ELEMENT_ROWS = {"gear": 0, "rack": 0, "coupler": 0}


def pack(items, tables) -> dict:
    """Its fields from the model's couplers: per term its variable's row in
    the shared state-variable table and its coefficient; per coupler its row
    and c (given, or the relation's value in the configuration as placed,
    ``Coupler.placed_value``).

    Parameters
    ----------
    items : list of (int, Coupler)
        Per instance, its row of lambda and the element, in the model's order.
    tables : packing context
        ``variable_rows``, ``placed`` and ``cmap``
        (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    terms, coefs, rows, off = [], [], [], []
    for row, e in items:
        names = tables.variable_rows(e)
        for v, a in zip(e.variables, e.coefficients):
            terms.append((row, names[v.name]))
            coefs.append(float(a))
        rows.append(row)
        off.append(e.value if e.value is not None else e.placed_value(tables.placed(), tables.cmap))
    return {"xtrm": np.array(terms, np.int64).reshape(-1, 2),
            "xtc": np.array(coefs, np.float64), "xrow": np.array(rows, np.int64),
            "xoff": np.array(off, np.float64)}


@_inline
def _linear(I, Fl, k, qx):
    """(column 1, coefficient 1, column 2, coefficient 2, value) of a linear
    state variable k (a revolute's angle)."""
    c1, c2 = _i(I, VAR, k, 1), _i(I, VAR, k, 2)
    a1, a2 = _f(I, Fl, VARC, k, 0), _f(I, Fl, VARC, k, 1)
    return c1, a1, c2, a2, a1 * qx[c1] + a2 * qx[c2]


@_jit
def phi(I, Fl, t, qx, out):
    """Phi into out (m,) [rad or m]: -c, then each term's a_k x_k added."""
    if _rows(I, XTRM) == 0:
        return
    for i in range(_rows(I, XROW)):
        out[_i(I, XROW, i, 0)] = -_f(I, Fl, XOFF, i, 0)
    grad, H = np.empty(6), np.empty((6, 6))
    for j in range(_rows(I, XTRM)):
        k, a = _i(I, XTRM, j, 1), _f(I, Fl, XTC, j, 0)
        g = _i(I, VAR, k, 3)
        if g >= 0:
            x = _line(I, Fl, qx, g, grad, H)
        else:
            x = _linear(I, Fl, k, qx)[4]
        out[_i(I, XTRM, j, 0)] += a * x


@_jit
def phiqT_add(I, Fl, qx, lam, coef, out):
    """out (n+3,) += coef Phi_q^T lambda [N m, N]."""
    if _rows(I, XTRM) == 0:
        return
    grad, H = np.empty(6), np.empty((6, 6))
    for j in range(_rows(I, XTRM)):
        k = _i(I, XTRM, j, 1)
        lv = coef * lam[_i(I, XTRM, j, 0)] * _f(I, Fl, XTC, j, 0)
        g = _i(I, VAR, k, 3)
        if g >= 0:
            _line(I, Fl, qx, g, grad, H)
            for c in range(6):
                out[_i(I, GEO, g, c)] += lv * grad[c]
        else:
            c1, a1, c2, a2, _ = _linear(I, Fl, k, qx)
            out[c1] += lv * a1
            out[c2] += lv * a2


@_jit
def phiq_times(I, Fl, qx, vx, out):
    """Phi_q v into out (m,) [rad/s or m/s]."""
    if _rows(I, XTRM) == 0:
        return
    for i in range(_rows(I, XROW)):
        out[_i(I, XROW, i, 0)] = 0.0
    grad, H = np.empty(6), np.empty((6, 6))
    for j in range(_rows(I, XTRM)):
        k, a = _i(I, XTRM, j, 1), _f(I, Fl, XTC, j, 0)
        g = _i(I, VAR, k, 3)
        acc = 0.0
        if g >= 0:
            _line(I, Fl, qx, g, grad, H)
            for c in range(6):
                acc += grad[c] * vx[_i(I, GEO, g, c)]
        else:
            c1, a1, c2, a2, _ = _linear(I, Fl, k, qx)
            acc = a1 * vx[c1] + a2 * vx[c2]
        out[_i(I, XTRM, j, 0)] += a * acc


@_jit
def emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """coef Phi_q at (r0, c0), or coef Phi_q^T when transpose; returns p.
    Terms that share a column (two joints on one body) give two triplets
    there, summed by the matrix's pattern."""
    if _rows(I, XTRM) == 0:
        return p
    grad, H = np.empty(6), np.empty((6, 6))
    for j in range(_rows(I, XTRM)):
        k, row = _i(I, XTRM, j, 1), _i(I, XTRM, j, 0)
        a = coef * _f(I, Fl, XTC, j, 0)
        g = _i(I, VAR, k, 3)
        if g >= 0:
            _line(I, Fl, qx, g, grad, H)
            for c in range(6):
                col = _i(I, GEO, g, c)
                if col < n:
                    p = _put_phiq(R, C, V, p, r0, c0, row, col, a * grad[c], transpose)
        else:
            c1, a1, c2, a2, _ = _linear(I, Fl, k, qx)
            if c1 < n:
                p = _put_phiq(R, C, V, p, r0, c0, row, c1, a * a1, transpose)
            if c2 < n:
                p = _put_phiq(R, C, V, p, r0, c0, row, c2, a * a2, transpose)
    return p


@_jit
def emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """coef (Phi_q^T lambda)_q at (r0, c0): a_k lambda d2s/dq2 of each
    distance term, its structural nonzeros only; returns p."""
    if _rows(I, XTRM) == 0:
        return p
    grad, H = np.empty(6), np.empty((6, 6))
    for j in range(_rows(I, XTRM)):
        g = _i(I, VAR, _i(I, XTRM, j, 1), 3)
        if g < 0:                            # an angle: no second derivative
            continue
        _line(I, Fl, qx, g, grad, H)
        lv = coef * lam[_i(I, XTRM, j, 0)] * _f(I, Fl, XTC, j, 0)
        cL = _i(I, GEO, g, 2)
        for c in range(6):
            col = _i(I, GEO, g, c)
            if c == 2 or col >= n or cL >= n:
                continue
            p = _put(R, C, V, p, r0 + cL, c0 + col, lv * H[2, c])
            p = _put(R, C, V, p, r0 + col, c0 + cL, lv * H[c, 2])
        if cL < n:
            p = _put(R, C, V, p, r0 + cL, c0 + cL, lv * H[2, 2])
        cP = _i(I, GEO, g, 5)
        if cP < n:
            p = _put(R, C, V, p, r0 + cP, c0 + cP, lv * H[5, 5])
    return p


@_jit
def emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """coef (Phi_q v)_q at (r0, c0): a_k (d2s/dq2 v) in the coupler's row for
    each distance term; returns p."""
    if _rows(I, XTRM) == 0:
        return p
    grad, H = np.empty(6), np.empty((6, 6))
    for j in range(_rows(I, XTRM)):
        g = _i(I, VAR, _i(I, XTRM, j, 1), 3)
        if g < 0:
            continue
        _line(I, Fl, qx, g, grad, H)
        a = coef * _f(I, Fl, XTC, j, 0)
        row = _i(I, XTRM, j, 0)
        for c in range(6):
            col = _i(I, GEO, g, c)
            if col >= n:
                continue
            hv = 0.0
            for b in range(6):
                hv += H[c, b] * vx[_i(I, GEO, g, b)]
            p = _put(R, C, V, p, r0 + row, c0 + col, a * hv)
    return p
