"""Linear rows: Phi = c1 q[i1] + c2 q[i2] - offset - f(t), one row each: locked
and driven angles and coordinates (a body coordinate's driver, an angle
between two bodies held or driven). Constant gradient, no Hessian.

Fields: LROW (k,) the rows, LCOL (k, 2) the two columns (the ground's when
one is unused), LCOEF (k, 2) their coefficients, LOFF (k,) the offset [m or
rad], LFN (k, 3) the programs of a driver f, f', f'' (-1: none).
"""

from __future__ import annotations

import numpy as np

from ..programs import _eval
from ..schema import LCOEF, LCOL, LFN, LOFF, LROW, _f, _i, _inline, _put_phiq, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("lrow", "lcol", "lcoef", "loff", "lfn")
#: Newton-matrix triplets per instance: Phi_q, (Phi_q^T lambda)_q, (Phi_q v)_q.
PHIQ_TRIPLETS, HESS_TRIPLETS, G_TRIPLETS = 2, 0, 0
#: The joints and drivers whose rows it holds: kind -> the first of them among the
#: element's rows (the locked angle after a fixed joint's coincidence, a prismatic
#: joint's line; a body coordinate's or a joint angle's driver).
ELEMENT_ROWS = {"fixed": 2, "prismatic": 1, "coordinate": 0, "joint_angle": 0}


def pack(items, tables) -> dict:
    """Its fields from the model's joints and drivers: a locked angle phi2 -
    phi1 - angle, a driven one phi2 - phi1 - f(t), a driven coordinate q_c -
    f(t) (its first column the ground's, coefficient 0). A constant f is
    folded into the offset; a function of time becomes the programs of f, f',
    f''.

    Parameters
    ----------
    items : list of (int, Joint or Driver)
        Per instance, its row of lambda and the element (a kind of
        ``ELEMENT_ROWS``), in the model's order.
    tables : packing context
        ``cmap`` (the model's coordinate map), ``n`` and ``programs``
        (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    cmap, n = tables.cmap, tables.n
    cols, coefs, off, fn = [], [], [], []
    for _, e in items:
        if e.kind == "coordinate":
            cols.append((n, cmap.column(e.body, e.coord)))
            coefs.append((0.0, 1.0))
        else:
            joint = e if e.kind in ("fixed", "prismatic") else e.joint
            cols.append((cmap.column(joint.first.body, 2), cmap.column(joint.second.body, 2)))
            coefs.append((-1.0, 1.0))
        f = getattr(e, "function", None)
        constant = f.f(0.0) if f is not None and f.constant else 0.0
        off.append((e.angle if e.kind in ("fixed", "prismatic") else 0.0) + constant)
        fn.append(tables.programs(f))
    return {"lrow": np.array([r for r, _ in items], np.int64),
            "lcol": np.array(cols, np.int64).reshape(-1, 2),
            "lcoef": np.array(coefs, np.float64).reshape(-1, 2),
            "loff": np.array(off, np.float64), "lfn": np.array(fn, np.int64).reshape(-1, 3)}


@_inline
def phi(I, Fl, t, qx, out):
    """Phi into out (m,) [m or rad]."""
    for i in range(_rows(I, LROW)):
        val = (_f(I, Fl, LCOEF, i, 0) * qx[_i(I, LCOL, i, 0)]
               + _f(I, Fl, LCOEF, i, 1) * qx[_i(I, LCOL, i, 1)] - _f(I, Fl, LOFF, i, 0))
        if _i(I, LFN, i, 0) >= 0:                  # a driver f(t)
            val -= _eval(I, Fl, _i(I, LFN, i, 0), t)
        out[_i(I, LROW, i, 0)] = val


@_inline
def phi_time_add(I, Fl, t, out, order):
    """out (m,) += the order-th time derivative of Phi: -f'(t), -f''(t) of drivers."""
    for i in range(_rows(I, LROW)):
        if _i(I, LFN, i, order) >= 0:
            out[_i(I, LROW, i, 0)] -= _eval(I, Fl, _i(I, LFN, i, order), t)


@_inline
def phiqT_add(I, Fl, qx, lam, coef, out):
    """out (n+3,) += coef Phi_q^T lambda."""
    for i in range(_rows(I, LROW)):
        lv = coef * lam[_i(I, LROW, i, 0)]
        out[_i(I, LCOL, i, 0)] += _f(I, Fl, LCOEF, i, 0) * lv
        out[_i(I, LCOL, i, 1)] += _f(I, Fl, LCOEF, i, 1) * lv


@_inline
def phiq_times(I, Fl, qx, vx, out):
    """Phi_q v into out (m,)."""
    for i in range(_rows(I, LROW)):
        out[_i(I, LROW, i, 0)] = _f(I, Fl, LCOEF, i, 0) * vx[_i(I, LCOL, i, 0)] + _f(I, Fl, LCOEF, i, 1) * vx[_i(I, LCOL, i, 1)]


@_inline
def emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """coef Phi_q at (r0, c0), or coef Phi_q^T when transpose; returns p."""
    for i in range(_rows(I, LROW)):
        for j in range(2):
            col = _i(I, LCOL, i, j)
            if col < n:
                p = _put_phiq(R, C, V, p, r0, c0, _i(I, LROW, i, 0), col, coef * _f(I, Fl, LCOEF, i, j), transpose)
    return p
