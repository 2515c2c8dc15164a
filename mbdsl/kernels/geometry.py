"""Body points and lines in the plane: r + A(phi) u and a sliding joint's distance.

A body point is at r + A(phi) s, with d/dphi (A s) = B s = (-(A s)_y,
(A s)_x) and d^2/dphi^2 (A s) = -A s (Haug, Computer-Aided Kinematics and
Dynamics of Mechanical Systems, ch. 3; Nikravesh, Computer-Aided Analysis of
Mechanical Systems, ch. 4); on a flexible beam u = s + sum_k S_k q_k
(Shabana, Dynamics of Multibody Systems, sec. 5.3).
"""

from __future__ import annotations

import math

from .schema import ECOL, ESHP, GEO, GEOF, MASS, _f, _i, _inline, _jit, _rows

#: Its fields in ``schema.MODEL_SCHEMA``: the sliding joints' lines (columns; s_L, s_P, u0).
FIELDS = ("geo", "geof")

#: The slots of a column's memo of (phi, cos phi, sin phi) in a memo-carrying qx.
MEMO = 3


@_inline
def _cos_sin(I, qx, col):
    """(cos phi, sin phi) of the angle phi = qx[col].

    An extended q of n + 3 entries gets them from ``math``. The time loop's
    own (``integrators.compiled.loop._workspace``) carries a memo after its
    n + 3 entries, MEMO slots per column (phi, cos phi, sin phi), so that
    the joints that share a body do not evaluate its rotation again: a
    residual evaluated each body's sine and cosine about eight times, 17 %
    of the 1 000-link chain's step (perf). The memo answers only for the
    same phi to the bit (its sign too), so that every result is the one
    ``math`` gives, whoever wrote qx since.
    """
    ph = qx[col]
    base = _rows(I, MASS) + 3
    if qx.shape[0] != (MEMO + 1) * base:
        return math.cos(ph), math.sin(ph)
    k = base + MEMO * col
    if qx[k] == ph and math.copysign(1.0, qx[k]) == math.copysign(1.0, ph):
        return qx[k + 1], qx[k + 2]
    c, sn = math.cos(ph), math.sin(ph)
    qx[k], qx[k + 1], qx[k + 2] = ph, c, sn
    return c, sn


@_jit
def _As(I, Fl, qx, cols, s, i):
    """A(phi) s of instance i of the element whose body columns are integer
    field ``cols`` and whose local vectors are float field ``s``: (x, y)."""
    c, sn = _cos_sin(I, qx, _i(I, cols, i, 2))
    s0, s1 = _f(I, Fl, s, i, 0), _f(I, Fl, s, i, 1)
    return c * s0 - sn * s1, sn * s0 + c * s1


@_inline
def _span(I, el, i, side):
    """(first, end) of the elastic terms of point ``side`` (0, 1) of instance i
    of an element whose spans are field ``el`` (CEL, PEL, SEL, FEL, DSP); (0, 0)
    when the model has no point on a flexible beam (the field is then empty)."""
    if _rows(I, el) == 0:
        return 0, 0
    return _i(I, el, i, 2 * side), _i(I, el, i, 2 * side + 1)


@_inline
def _Au(I, Fl, qx, cols, s, el, side, i):
    """A(phi) u of point ``side`` of joint instance i, u = s + sum_k S_k q_k:
    s its undeformed local position (field ``s``), S_k (2,) the shape column
    of elastic coordinate q_k of a point on a flexible beam (``PointSet``;
    none on a rigid body). Returns (x, y).

    Inlined where it is called (numba's IR): a joint evaluates it for both
    its points in every residual and Newton-matrix term, and as a function
    of its own it was called, not inlined by LLVM, 13 % of the 1 000-link
    chain's step (perf)."""
    ux, uy = _f(I, Fl, s, i, 0), _f(I, Fl, s, i, 1)
    k0, k1 = _span(I, el, i, side)
    for k in range(k0, k1):
        qk = qx[_i(I, ECOL, k, 0)]
        ux += _f(I, Fl, ESHP, k, 0) * qk
        uy += _f(I, Fl, ESHP, k, 1) * qk
    c, sn = _cos_sin(I, qx, _i(I, cols, i, 2))
    return c * ux - sn * uy, sn * ux + c * uy


@_inline
def _eshape(I, Fl, k, ph):
    """A S_k and B S_k = d(A S_k)/dphi of elastic term k on a body at angle ph:
    (Ax, Ay, Bx, By)."""
    sx, sy = _f(I, Fl, ESHP, k, 0), _f(I, Fl, ESHP, k, 1)
    c, sn = math.cos(ph), math.sin(ph)
    ax, ay = c * sx - sn * sy, sn * sx + c * sy
    return ax, ay, -ay, ax


@_jit
def _line(I, Fl, qx, g, grad, H):
    """Distance s along sliding line g (fields GEO, GEOF: columns of the line's
    body and of the point's body, s_L, s_P, u0) with ds/dq into grad (6,) and
    d^2 s/dq^2 into H (6, 6) over (x_L, y_L, phi_L, x_P, y_P, phi_P):
    s = u . (p_P - p_L), u = A(phi_L) u0, p = r + A(phi) s_body (as
    ``model.elements.line_distance``, which gives the output columns s and
    its rate). Returns s."""
    cL, sL_ = _cos_sin(I, qx, _i(I, GEO, g, 2))
    cP, sP_ = _cos_sin(I, qx, _i(I, GEO, g, 5))
    u0x, u0y = _f(I, Fl, GEOF, g, 4), _f(I, Fl, GEOF, g, 5)
    ux, uy = cL * u0x - sL_ * u0y, sL_ * u0x + cL * u0y
    bux, buy = -uy, ux                                   # B(phi_L) u0
    lx, ly = _f(I, Fl, GEOF, g, 0), _f(I, Fl, GEOF, g, 1)
    px, py = _f(I, Fl, GEOF, g, 2), _f(I, Fl, GEOF, g, 3)
    aLx, aLy = cL * lx - sL_ * ly, sL_ * lx + cL * ly
    aPx, aPy = cP * px - sP_ * py, sP_ * px + cP * py
    dx = qx[_i(I, GEO, g, 3)] + aPx - qx[_i(I, GEO, g, 0)] - aLx
    dy = qx[_i(I, GEO, g, 4)] + aPy - qx[_i(I, GEO, g, 1)] - aLy
    s = ux * dx + uy * dy
    grad[0] = -ux
    grad[1] = -uy
    grad[2] = (bux * dx + buy * dy) - (ux * -aLy + uy * aLx)
    grad[3] = ux
    grad[4] = uy
    grad[5] = ux * -aPy + uy * aPx
    H[:, :] = 0.0
    row0, row1, row2 = -bux, -buy, -(bux * -aLy + buy * aLx)
    row3, row4, row5 = bux, buy, bux * -aPy + buy * aPx
    for j, r in enumerate((row0, row1, row2, row3, row4, row5)):
        H[2, j] += r
        H[j, 2] += r
    H[2, 2] += (ux * aLx + uy * aLy) - s
    H[5, 5] -= ux * aPx + uy * aPy
    return s


@_jit
def _direction(dx, dy, l):
    """e = d / l of a spring-damper, (0, 0) at l = 0: two coincident points
    have no direction, and no force along it (``loads.spring_damper``)."""
    if l > 0.0:
        return dx / l, dy / l
    return 0.0, 0.0


@_jit
def _direction_derivative(ex, ey, l):
    """(P00, P01, P11) of de/dd = (I - e e^T) / l, 0 at l = 0."""
    if l > 0.0:
        return (1.0 - ex * ex) / l, -ex * ey / l, (1.0 - ey * ey) / l
    return 0.0, 0.0, 0.0
