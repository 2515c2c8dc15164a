"""Point forces F(t) on body points: Q = J^T F, J = [I, B u] (and A S_k on a
flexible beam's point); constant or programs of time.

Fields: FCOL (k, 3) the body's columns, FS (k, 2) the local point [m], FF
(k, 2) a constant force [N], FFN (k, 2) the programs of fx, fy (-1: the
constant), FEL (k, 2) elastic spans.
"""

from __future__ import annotations

import numpy as np

from ..geometry import _Au, _eshape, _span
from ..programs import _eval
from ..schema import ECOL, FCOL, FEL, FF, FFN, FS, _f, _i, _inline, _jit, _put, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("fcol", "fs", "fF", "ffn", "fel")
#: Newton-matrix triplets per instance of a force block: the body angle's diagonal (a point on a
#: beam: ``triplet_bound``).
FORCE_TRIPLETS = 1
#: The loads it holds (``model.elements.PointForce.kind``).
LOADS = ("point_force",)


def pack(items, tables) -> dict:
    """Its fields from the model's point forces: a constant component as its
    value, one of time as its program.

    Parameters
    ----------
    items : list of PointForce
        The model's point forces, in its order.
    tables : packing context
        ``points``, ``elastic_spans``, ``timed`` and ``program``
        (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    points = [f.point for f in items]
    tables.elastic_spans("fel", points)
    fcol, fs = tables.points(points)
    timed = tables.timed
    fF = [[0.0 if timed(c) else c.f(0.0) for c in (f.fx, f.fy)] for f in items]
    ffn = [[tables.program(c.expr) if timed(c) else -1 for c in (f.fx, f.fy)] for f in items]
    return {"fcol": fcol, "fs": fs, "fF": np.array(fF, np.float64).reshape(-1, 2),
            "ffn": np.array(ffn, np.int64).reshape(-1, 2)}


def pattern(items, tables) -> tuple:
    """(columns (k, c) whose Q_q entries a point force may fill: its body's
    and, on a flexible beam, its elastic coordinates; False: none damped)."""
    return tables.point_columns([f.point for f in items]), False


@_jit
def _point_force(I, Fl, t, i):
    """(fx, fy) [N] of point force i at time t: constant, or its programs."""
    fx, fy = _f(I, Fl, FF, i, 0), _f(I, Fl, FF, i, 1)
    if _i(I, FFN, i, 0) >= 0:
        fx = _eval(I, Fl, _i(I, FFN, i, 0), t)
    if _i(I, FFN, i, 1) >= 0:
        fy = _eval(I, Fl, _i(I, FFN, i, 1), t)
    return fx, fy


@_inline
def forces_add(I, Fl, t, qx, out):
    """out (n+3,) += J^T F(t) [N, N m] of every point force (on a flexible
    beam's point also (A S_k) . F in its elastic columns)."""
    for i in range(_rows(I, FCOL)):
        ax, ay = _Au(I, Fl, qx, FCOL, FS, FEL, 0, i)
        fx, fy = _point_force(I, Fl, t, i)
        out[_i(I, FCOL, i, 0)] += fx
        out[_i(I, FCOL, i, 1)] += fy
        out[_i(I, FCOL, i, 2)] += -ay * fx + ax * fy
        k0, k1 = _span(I, FEL, i, 0)
        for k in range(k0, k1):            # a point on a flexible beam: (A S_k) . F
            Ax, Ay, Bx, By = _eshape(I, Fl, k, qx[_i(I, FCOL, i, 2)])
            out[_i(I, ECOL, k, 0)] += Ax * fx + Ay * fy


@_inline
def emit_force(I, Fl, t, n, qx, R, C, V, p, r0, c0, cq):
    """-cq Q_q at (r0, c0): (d^2 p/dphi^2) . F = -(A u) . F on the body's angle,
    B S_k . F between the angle and an elastic coordinate; returns p."""
    for i in range(_rows(I, FCOL)):
        cph = _i(I, FCOL, i, 2)
        if cph < n:
            ax, ay = _Au(I, Fl, qx, FCOL, FS, FEL, 0, i)
            fx, fy = _point_force(I, Fl, t, i)
            val = cq * -(ax * fx + ay * fy)
            p = _put(R, C, V, p, r0 + cph, c0 + cph, -val)
            k0, k1 = _span(I, FEL, i, 0)
            for k in range(k0, k1):        # d2p/dphi dq_k = B S_k
                Ax, Ay, Bx, By = _eshape(I, Fl, k, qx[cph])
                val = cq * (Bx * fx + By * fy)
                ck = _i(I, ECOL, k, 0)
                p = _put(R, C, V, p, r0 + cph, c0 + ck, -val)
                p = _put(R, C, V, p, r0 + ck, c0 + cph, -val)
    return p
