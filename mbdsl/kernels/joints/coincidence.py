"""Coincidence of two points (the revolute joint): Phi = p2 - p1, two rows.

A body point is at p = r + A(phi) u, u = s + sum_k S_k q_k (``geometry._Au``;
S on a flexible beam only): d/dphi (A u) = B u = (-(A u)_y, (A u)_x) and
d^2/dphi^2 (A u) = -A u (Haug, Computer-Aided Kinematics and Dynamics of
Mechanical Systems, sec. 3.3; Nikravesh, sec. 4.4). The elastic columns of a
point on a beam are added by ``beams.elastic_points``.

Fields (``schema.MODEL_SCHEMA``): CROW (k, 2) the rows, CCOL1, CCOL2 (k, 3)
the columns of x, y, phi of both bodies, CS1, CS2 (k, 2) the points' local
positions [m], CEL (k, 4) the spans of their elastic terms.
"""

from __future__ import annotations

import numpy as np

from ..geometry import _Au
from ..schema import CCOL1, CCOL2, CEL, CROW, CS1, CS2, _i, _inline, _put, _put_phiq, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("crow", "ccol1", "cs1", "ccol2", "cs2", "cel")
#: The joints whose rows it holds: kind -> the first of them among the joint's rows.
ELEMENT_ROWS = {"revolute": 0, "fixed": 0}


def pack(items, tables) -> dict:
    """Its fields from the model's joints.

    Parameters
    ----------
    items : list of (int, Joint)
        Per instance, its first row of lambda and the joint (a kind of
        ``ELEMENT_ROWS``), in the model's order.
    tables : packing context
        ``joint_points`` (body columns and local positions of the joints' two
        points, and the terms of points on flexible beams):
        ``assembly.packing.PackingContext``.

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    ccol1, cs1, ccol2, cs2 = tables.joint_points("cel", [j for _, j in items])
    return {"crow": np.array([(r, r + 1) for r, _ in items], np.int64).reshape(-1, 2),
            "ccol1": ccol1, "cs1": cs1, "ccol2": ccol2, "cs2": cs2}
#: Newton-matrix triplets per instance: Phi_q, (Phi_q^T lambda)_q, (Phi_q v)_q.
PHIQ_TRIPLETS, HESS_TRIPLETS, G_TRIPLETS = 8, 2, 4


@_inline
def _phi_rows(I, qx, i, ax1, ay1, ax2, ay2, out):
    """Instance i's two rows of Phi into out, its points' A u given."""
    out[_i(I, CROW, i, 0)] = (qx[_i(I, CCOL2, i, 0)] - qx[_i(I, CCOL1, i, 0)]) + (ax2 - ax1)
    out[_i(I, CROW, i, 1)] = (qx[_i(I, CCOL2, i, 1)] - qx[_i(I, CCOL1, i, 1)]) + (ay2 - ay1)


@_inline
def _phiqT_rows_add(I, lam, coef, i, ax1, ay1, ax2, ay2, out):
    """out += coef (instance i's rows of Phi_q)^T lambda, its points' A u given."""
    l0, l1 = coef * lam[_i(I, CROW, i, 0)], coef * lam[_i(I, CROW, i, 1)]
    out[_i(I, CCOL1, i, 0)] -= l0
    out[_i(I, CCOL1, i, 1)] -= l1
    out[_i(I, CCOL1, i, 2)] -= -ay1 * l0 + ax1 * l1
    out[_i(I, CCOL2, i, 0)] += l0
    out[_i(I, CCOL2, i, 1)] += l1
    out[_i(I, CCOL2, i, 2)] += -ay2 * l0 + ax2 * l1


@_inline
def phi(I, Fl, t, qx, out):
    """Phi into out (m,) [m]."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        _phi_rows(I, qx, i, ax1, ay1, ax2, ay2, out)


@_inline
def phiqT_add(I, Fl, qx, lam, coef, out):
    """out (n+3,) += coef Phi_q^T lambda [N, N m] (rigid columns)."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        _phiqT_rows_add(I, lam, coef, i, ax1, ay1, ax2, ay2, out)


@_inline
def phi_phiqT_add(I, Fl, qx, lam, out_phi, out):
    """:func:`phi` into out_phi and :func:`phiqT_add` (coef 1) into out in
    one pass: each instance's points rotated once for both (the index-3
    residual's two joint terms; ``system.phi_phiqT_add``)."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        _phi_rows(I, qx, i, ax1, ay1, ax2, ay2, out_phi)
        _phiqT_rows_add(I, lam, 1.0, i, ax1, ay1, ax2, ay2, out)


@_inline
def phiq_times(I, Fl, qx, vx, out):
    """Phi_q v into out (m,) [m/s] (rigid columns)."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        w1, w2 = vx[_i(I, CCOL1, i, 2)], vx[_i(I, CCOL2, i, 2)]
        out[_i(I, CROW, i, 0)] = (vx[_i(I, CCOL2, i, 0)] - vx[_i(I, CCOL1, i, 0)]) + (-ay2 * w2 + ay1 * w1)
        out[_i(I, CROW, i, 1)] = (vx[_i(I, CCOL2, i, 1)] - vx[_i(I, CCOL1, i, 1)]) + (ax2 * w2 - ax1 * w1)


@_inline
def emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """coef Phi_q at (r0, c0), or coef Phi_q^T when transpose; returns p."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        for a in range(2):
            row = _i(I, CROW, i, a)
            # d(p2 - p1)_a / d(x1, y1, phi1, x2, y2, phi2): -e_a, -(B s1)_a, e_a, (B s2)_a
            for which in range(4):
                if which == 0:
                    col, g = _i(I, CCOL1, i, a), -1.0
                elif which == 1:
                    col, g = _i(I, CCOL1, i, 2), (ay1 if a == 0 else -ax1)
                elif which == 2:
                    col, g = _i(I, CCOL2, i, a), 1.0
                else:
                    col, g = _i(I, CCOL2, i, 2), (-ay2 if a == 0 else ax2)
                if col < n:
                    p = _put_phiq(R, C, V, p, r0, c0, row, col, coef * g, transpose)
    return p


@_inline
def emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """coef (Phi_q^T lambda)_q at (r0, c0): -(A u)^T lambda on each angle's diagonal."""
    for i in range(_rows(I, CROW)):
        l0, l1 = lam[_i(I, CROW, i, 0)], lam[_i(I, CROW, i, 1)]
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        c1, c2 = _i(I, CCOL1, i, 2), _i(I, CCOL2, i, 2)
        if c1 < n:
            p = _put(R, C, V, p, r0 + c1, c0 + c1, coef * (l0 * ax1 + l1 * ay1))
        if c2 < n:
            p = _put(R, C, V, p, r0 + c2, c0 + c2, -coef * (l0 * ax2 + l1 * ay2))
    return p


@_inline
def emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """coef (Phi_q v)_q at (r0, c0)."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        c1, c2 = _i(I, CCOL1, i, 2), _i(I, CCOL2, i, 2)
        w1, w2 = vx[c1], vx[c2]
        for a in range(2):
            s1 = ax1 if a == 0 else ay1
            s2 = ax2 if a == 0 else ay2
            if c1 < n:
                p = _put(R, C, V, p, r0 + _i(I, CROW, i, a), c0 + c1, coef * s1 * w1)
            if c2 < n:
                p = _put(R, C, V, p, r0 + _i(I, CROW, i, a), c0 + c2, -coef * s2 * w2)
    return p
