"""Spring-damper-actuators between two points of spatial bodies (TSDA):
Q = -D^T (f e), f = k (l - l0) + c ldot.

A spatial body's point is r + A s, linear in the director coordinates
(``model.spatial``): d = p2 - p1 = D q + d0 with D constant, so that
l = |d|, e = d / l, ldot = e . (D v), and

    Q_q = -D^T K_d D,  K_d = k e e^T + (c e d'^T P + f P) / l,
    Q_v = -D^T K_v D,  K_v = c e e^T,   P = I - e e^T,

with no term from a second derivative of d (Haug 1989, sec. 11.3.1, the
TSDA element; Nikravesh, sec. 9.4). The points must stay apart: at l = 0
the direction is undefined (the planar spring's event there is not
implemented for spatial models).

Fields: WCOL (k, 2) the first column of each point's body (the second
point's, then the first's; -1: the ground), WS (k, 8) their weights
(1, s1, s2, s3), the first point's negated, W0 (k, 3) the ground's part of d
[m], WPAR (k, 3) (k [N/m], c [N s/m], l0 [m]).
"""

from __future__ import annotations

import math

import numpy as np

from ..schema import W0, WCOL, WPAR, WS, _f, _i, _inline, _jit, _put, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("wcol", "ws", "w0", "wpar")
#: Newton-matrix triplets per instance of a force block: a 3 x 3 block per pair of
#: the points' weights (four per body, two bodies) at most.
FORCE_TRIPLETS = 576
#: The loads it holds (``model.spatial.SpatialSpring.kind``).
LOADS = ("tsda",)


def _point_part(tables, ref, sign):
    """(first column or -1, weights (4,), constant (3,)) of one point."""
    if ref.body < 0:
        return -1, np.zeros(4), sign * np.asarray(ref.local, float)
    return tables.cmap.spatial[ref.body], sign * np.r_[1.0, ref.local], np.zeros(3)


def pack(items, tables) -> dict:
    """Its fields from the model's spatial spring-dampers.

    Parameters
    ----------
    items : list of SpatialSpring
        The model's loads of the kinds of ``LOADS``, in its order.
    tables : packing context
        ``cmap.spatial`` (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    cols, weights, consts = [], [], []
    for s in items:
        c2, w2, k2 = _point_part(tables, s.second, 1.0)
        c1, w1, k1 = _point_part(tables, s.first, -1.0)
        cols.append((c2, c1))
        weights.append(np.r_[w2, w1])
        consts.append(k2 + k1)
    return {"wcol": np.array(cols, np.int64).reshape(-1, 2),
            "ws": np.array(weights, np.float64).reshape(-1, 8),
            "w0": np.array(consts, np.float64).reshape(-1, 3),
            "wpar": np.array([(s.k, s.c, s.length) for s in items], np.float64).reshape(-1, 3)}


def pattern(items, tables) -> tuple:
    """(columns (k, 24) in q_ext whose Q_q, Q_v entries a spring may fill, both
    bodies' twelve, the ground's none (n + 2); whether any is damped)."""
    rows = [body_columns([s.second.body, s.first.body], tables) for s in items]
    return np.array(rows, np.int64).reshape(-1, 24), any(s.c != 0.0 for s in items)


def body_columns(bodies, tables) -> list:
    """The columns in q_ext of spatial bodies, twelve each in their order (the
    ground's, and those a particle does not have beyond its three: n + 2,
    never written): a force block's pattern."""
    cols = []
    for body in bodies:
        base = tables.cmap.spatial.get(body)
        width = 0 if base is None else tables.cmap.spatial_width[body]
        cols += list(range(base or 0, (base or 0) + width)) + [tables.n + 2] * (12 - width)
    return cols


@_inline
def _d(I, Fl, x, i, out, constant):
    """d = D x (+ d0 with ``constant``) of spring i into out (3,)."""
    for c in range(3):
        out[c] = _f(I, Fl, W0, i, c) if constant else 0.0
    for s in range(2):
        base = _i(I, WCOL, i, s)
        if base >= 0:
            for j in range(4):
                w = _f(I, Fl, WS, i, 4 * s + j)
                if w != 0.0:
                    for c in range(3):
                        out[c] += w * x[base + 3 * j + c]


@_jit
def _state(I, Fl, qx, vx, i, d, dd):
    """(l, ldot, f) of spring i, d and d' into d, dd (3,) and e into d (unit;
    zero at l = 0)."""
    _d(I, Fl, qx, i, d, True)
    _d(I, Fl, vx, i, dd, False)
    l = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if l > 0.0:
        for c in range(3):
            d[c] /= l
    ld = d[0] * dd[0] + d[1] * dd[1] + d[2] * dd[2]
    f = _f(I, Fl, WPAR, i, 0) * (l - _f(I, Fl, WPAR, i, 2)) + _f(I, Fl, WPAR, i, 1) * ld
    return l, ld, f


@_inline
def forces_add(I, Fl, qx, vx, out):
    """The springs' Q = -D^T (f e) added to out (n+3,) [N, N m]."""
    if _rows(I, WCOL) == 0:
        return
    e, dd = np.empty(3), np.empty(3)
    for i in range(_rows(I, WCOL)):
        l, ld, f = _state(I, Fl, qx, vx, i, e, dd)
        for s in range(2):
            base = _i(I, WCOL, i, s)
            if base >= 0:
                for j in range(4):
                    w = _f(I, Fl, WS, i, 4 * s + j)
                    if w != 0.0:
                        for c in range(3):
                            out[base + 3 * j + c] -= f * w * e[c]


@_inline
def emit_force(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) of the springs at (r0, c0): D^T (cq K_d + cv K_v) D
    (the module notes); returns p."""
    if _rows(I, WCOL) == 0:
        return p
    e, dd, K = np.empty(3), np.empty(3), np.empty((3, 3))
    for i in range(_rows(I, WCOL)):
        l, ld, f = _state(I, Fl, qx, vx, i, e, dd)
        k, c = _f(I, Fl, WPAR, i, 0), _f(I, Fl, WPAR, i, 1)
        inv = 1.0 / l if l > 0.0 else 0.0
        for a in range(3):
            for b in range(3):
                P = (1.0 if a == b else 0.0) - e[a] * e[b]
                Kd = k * e[a] * e[b] + (c * e[a] * (dd[b] - ld * e[b]) + f * P) * inv
                K[a, b] = cq * Kd + cv * c * e[a] * e[b]
        for sa in range(2):
            ba = _i(I, WCOL, i, sa)
            if ba < 0:
                continue
            for ja in range(4):
                wa = _f(I, Fl, WS, i, 4 * sa + ja)
                if wa == 0.0:
                    continue
                for sb in range(2):
                    bb = _i(I, WCOL, i, sb)
                    if bb < 0:
                        continue
                    for jb in range(4):
                        wb = _f(I, Fl, WS, i, 4 * sb + jb)
                        if wb == 0.0:
                            continue
                        for ca in range(3):
                            for cb in range(3):
                                p = _put(R, C, V, p, r0 + ba + 3 * ja + ca,
                                         c0 + bb + 3 * jb + cb, wa * wb * K[ca, cb])
    return p


@_inline
def energy_add(I, Fl, qx, e):
    """e + the springs' potential k (l - l0)^2 / 2 [J]."""
    if _rows(I, WCOL) == 0:
        return e
    d = np.empty(3)
    for i in range(_rows(I, WCOL)):
        _d(I, Fl, qx, i, d, True)
        l = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        x = l - _f(I, Fl, WPAR, i, 2)
        e += 0.5 * _f(I, Fl, WPAR, i, 0) * x * x
    return e


@_inline
def power_add(I, Fl, qx, vx, p):
    """p + the power the dampers dissipate, c ldot^2 [W]."""
    if _rows(I, WCOL) == 0:
        return p
    e, dd = np.empty(3), np.empty(3)
    for i in range(_rows(I, WCOL)):
        c = _f(I, Fl, WPAR, i, 1)
        if c != 0.0:
            l, ld, f = _state(I, Fl, qx, vx, i, e, dd)
            p += c * ld * ld
    return p
