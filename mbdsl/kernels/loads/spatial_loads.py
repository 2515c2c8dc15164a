"""Forces on points and torques on spatial bodies (``model.spatial.SpatialLoad``),
constant or of time, in world or body axes.

A spatial body's point is p = r + sum_k s_k a_k (``model.spatial``: r and
the directors a_k, linear coordinates), so a force F at s has the
generalized force F on r and s_k F on a_k. A torque T acts on the
directors as T x a_k / 2: for orthonormal a_k, sum_k a_k x (T x a_k) / 2 =
T, so on a virtual rotation (d a_k = d theta x a_k) its work is T . d theta.
In body axes the load turns with the body: F = sum_l f_l a_l (T likewise),
linear in the directors, which gives Q_q (no Q_v):

    force, body axes:   dQ_r / da_l = f_l I,   dQ_ak / da_l = s_k f_l I;
    torque, world axes: dQ_ak / da_k = [T]x / 2;
    torque, body axes:  dQ_ak / da_l = (delta_kl [T]x - t_l [a_k]x) / 2,

[u]x the cross-product matrix (u x v = [u]x v). Sources: Haug 1989, sec.
11.3 (generalized forces of applied loads); Garcia de Jalon and Bayo 1994,
ch. 3 (natural coordinates).

Fields: YCOL (k, 2) the body's first column and the kind (0 force in world
axes, 1 force in body axes, 2 torque in world axes, 3 torque in body axes),
YPAR (k, 6) the point s [m] then the constant components, YFN (k, 3) the
components' programs of time (-1: the constant).
"""

from __future__ import annotations

import numpy as np

from ..programs import _eval
from ..schema import YCOL, YFN, YPAR, _f, _i, _inline, _jit, _put, _rows
from .spatial_springs import body_columns

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("ycol", "ypar", "yfn")
#: Newton-matrix triplets per instance of a force block: a force in body axes fills
#: 12 rows by the 9 director columns.
FORCE_TRIPLETS = 108
#: The loads it holds (``model.spatial.SpatialLoad.kind``).
LOADS = ("spatial_force", "spatial_torque")


def pack(items, tables) -> dict:
    """Its fields from the model's spatial loads.

    Parameters
    ----------
    items : list of SpatialLoad
        The model's loads of the kinds of ``LOADS``, in its order.
    tables : packing context
        ``cmap.spatial``, ``timed`` and ``program``
        (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    cols, pars, fns = [], [], []
    for ld in items:
        kind = (2 if ld.kind == "spatial_torque" else 0) + (ld.frame == "body")
        cols.append((tables.cmap.spatial[ld.body], kind))
        values, programs = [], []
        for f in ld.components:
            timed = tables.timed(f)
            values.append(0.0 if timed else f.f(0.0))
            programs.append(tables.program(f.expr) if timed else -1)
        pars.append(np.r_[np.asarray(ld.local, float), values])
        fns.append(programs)
    return {"ycol": np.array(cols, np.int64).reshape(-1, 2),
            "ypar": np.array(pars, np.float64).reshape(-1, 6),
            "yfn": np.array(fns, np.int64).reshape(-1, 3)}


def pattern(items, tables) -> tuple:
    """(columns (k, 12) in q_ext whose Q_q entries a load may fill: its
    body's twelve (a particle's three); none reads the velocities)."""
    rows = [body_columns([ld.body], tables) for ld in items]
    return np.array(rows, np.int64).reshape(-1, 12), False


@_jit
def _components(I, Fl, t, i, out):
    """The three components [N or N m] of load i at time t into out (3,)."""
    for c in range(3):
        prog = _i(I, YFN, i, c)
        out[c] = _eval(I, Fl, prog, t) if prog >= 0 else _f(I, Fl, YPAR, i, 3 + c)


@_jit
def _world(qx, base, comp, kind, out):
    """The load's vector in world axes into out (3,): its components, or
    turned by the body's directors (body axes: sum_l comp_l a_l)."""
    if kind % 2 == 0:
        for c in range(3):
            out[c] = comp[c]
        return
    for c in range(3):
        out[c] = 0.0
        for j in range(3):
            out[c] += comp[j] * qx[base + 3 + 3 * j + c]


@_inline
def forces_add(I, Fl, t, qx, out):
    """out (n+3,) += Q(t, q) [N, N m] of every spatial load (module notes)."""
    if _rows(I, YCOL) == 0:
        return
    comp, F = np.empty(3), np.empty(3)
    for i in range(_rows(I, YCOL)):
        base, kind = _i(I, YCOL, i, 0), _i(I, YCOL, i, 1)
        _components(I, Fl, t, i, comp)
        _world(qx, base, comp, kind, F)
        if kind < 2:                        # a force at s: F on r, s_k F on a_k
            for c in range(3):
                out[base + c] += F[c]
            for k in range(3):
                s = _f(I, Fl, YPAR, i, k)
                if s != 0.0:                # a particle has no a_k: its point is s = 0
                    for c in range(3):
                        out[base + 3 + 3 * k + c] += s * F[c]
        else:                               # a torque: T x a_k / 2 on a_k
            for k in range(3):
                a0 = qx[base + 3 + 3 * k]
                a1 = qx[base + 4 + 3 * k]
                a2 = qx[base + 5 + 3 * k]
                out[base + 3 + 3 * k] += 0.5 * (F[1] * a2 - F[2] * a1)
                out[base + 4 + 3 * k] += 0.5 * (F[2] * a0 - F[0] * a2)
                out[base + 5 + 3 * k] += 0.5 * (F[0] * a1 - F[1] * a0)


@_jit
def _skew_put(R, C, V, p, r, c, u, scale):
    """Triplets of scale [u]x at (r, c) (3 x 3, its six off-diagonal entries)."""
    p = _put(R, C, V, p, r + 0, c + 1, -scale * u[2])
    p = _put(R, C, V, p, r + 0, c + 2, scale * u[1])
    p = _put(R, C, V, p, r + 1, c + 0, scale * u[2])
    p = _put(R, C, V, p, r + 1, c + 2, -scale * u[0])
    p = _put(R, C, V, p, r + 2, c + 0, -scale * u[1])
    p = _put(R, C, V, p, r + 2, c + 1, scale * u[0])
    return p


@_inline
def emit_force(I, Fl, t, qx, R, C, V, p, r0, c0, cq):
    """-cq Q_q of the spatial loads at (r0, c0) (module notes); returns p."""
    if _rows(I, YCOL) == 0:
        return p
    comp, T, a = np.empty(3), np.empty(3), np.empty(3)
    for i in range(_rows(I, YCOL)):
        base, kind = _i(I, YCOL, i, 0), _i(I, YCOL, i, 1)
        if kind == 0:                       # a force in world axes: Q constant in q
            continue
        _components(I, Fl, t, i, comp)
        if kind == 1:                       # a force in body axes
            for l in range(3):
                cl = c0 + base + 3 + 3 * l
                for c in range(3):
                    p = _put(R, C, V, p, r0 + base + c, cl + c, -cq * comp[l])
                    for k in range(3):
                        s = _f(I, Fl, YPAR, i, k)
                        if s != 0.0:
                            p = _put(R, C, V, p, r0 + base + 3 + 3 * k + c, cl + c,
                                     -cq * s * comp[l])
            continue
        _world(qx, base, comp, kind, T)
        for k in range(3):
            rk = r0 + base + 3 + 3 * k
            p = _skew_put(R, C, V, p, rk, c0 + base + 3 + 3 * k, T, -0.5 * cq)
            if kind == 3:                   # the torque turns with the directors
                for c in range(3):
                    a[c] = qx[base + 3 + 3 * k + c]
                for l in range(3):
                    p = _skew_put(R, C, V, p, rk, c0 + base + 3 + 3 * l, a, 0.5 * cq * comp[l])
    return p
