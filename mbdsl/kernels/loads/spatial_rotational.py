"""Rotational spring-damper-actuators about a spatial revolute's (or
cylindrical's) axis (RSDA): torque tau = k wrap(theta - theta_0) + c
theta' about the first body's axis a_1, -tau on the second body, +tau on
the first.

theta is the joint's angle (``joints.spatial_angles``: atan2 of two dot
products of director-linear vectors) and theta' = theta_q v. The
generalized force and its derivatives (Haug 1989, sec. 11.3.2, the RSDA
element):

    Q   = -tau theta_q^T,
    Q_q = -theta_q^T (k theta_q + c v^T theta_qq) - tau theta_qq,
    Q_v = -c theta_q^T theta_q.

The spring acts on the angle within half a turn of theta_0 (wrap brings
theta - theta_0 within [-pi, pi)): a spring wound further than half a turn
from its rest angle would jump. The damper acts at any angle.

Fields: HCOL (k, 2) the bodies' first columns (-1: the ground), HV (k, 9)
f_1, g_1, f_2 as ``joints.spatial_angles``, HPAR (k, 3) (k [N m/rad], c
[N m s/rad], theta_0 [rad]).
"""

from __future__ import annotations

import numpy as np

from ..joints.spatial_angles import (angle, column, gradient, hessian, hessian_times, rate,
                                     reference_vectors, wrap)
from .spatial_springs import body_columns
from ..schema import HCOL, HPAR, HV, _f, _i, _inline, _jit, _put, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("hcol", "hv", "hpar")
#: Newton-matrix triplets per instance of a force block: the bodies' 18 x 18 director block.
FORCE_TRIPLETS = 324
#: The loads it holds (``model.spatial.SpatialRotationalSpring.kind``).
LOADS = ("rsda",)


def pack(items, tables) -> dict:
    """Its fields from the model's spatial rotational spring-dampers.

    Parameters
    ----------
    items : list of SpatialRotationalSpring
        The model's loads of the kinds of ``LOADS``, in its order.
    tables : packing context
        ``cmap.spatial`` (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    cols, vecs = [], []
    for s in items:
        (b1, a1), (b2, a2) = s.joint.axes
        cols.append([tables.cmap.spatial.get(b, -1) for b in (b1, b2)])
        vecs.append(reference_vectors(a1, a2))
    return {"hcol": np.array(cols, np.int64).reshape(-1, 2),
            "hv": np.array(vecs, np.float64).reshape(-1, 9),
            "hpar": np.array([(s.k, s.c, s.angle) for s in items], np.float64).reshape(-1, 3)}


def pattern(items, tables) -> tuple:
    """(columns (k, 24) in q_ext whose Q_q, Q_v entries a spring may fill, both
    bodies' twelve, the ground's none (n + 2); whether any is damped)."""
    rows = [body_columns([body for body, _ in s.joint.axes], tables) for s in items]
    return np.array(rows, np.int64).reshape(-1, 24), any(s.c != 0.0 for s in items)


@_jit
def _state(I, Fl, qx, vx, i, sq, cq, g):
    """(theta, theta', tau, s, c) of spring i, theta_q into g (18,)."""
    th, s, c = angle(I, Fl, HCOL, HV, i, qx, sq, cq)
    gradient(s, c, sq, cq, g)
    thd = rate(_i(I, HCOL, i, 0), _i(I, HCOL, i, 1), g, vx)
    tau = (_f(I, Fl, HPAR, i, 0) * wrap(th - _f(I, Fl, HPAR, i, 2))
           + _f(I, Fl, HPAR, i, 1) * thd)
    return th, thd, tau, s, c


@_inline
def forces_add(I, Fl, qx, vx, out):
    """The springs' Q = -tau theta_q^T added to out (n+3,) [N, N m]."""
    if _rows(I, HCOL) == 0:
        return
    sq, cq, g = np.empty(18), np.empty(18), np.empty(18)
    for i in range(_rows(I, HCOL)):
        th, thd, tau, s, c = _state(I, Fl, qx, vx, i, sq, cq, g)
        b1, b2 = _i(I, HCOL, i, 0), _i(I, HCOL, i, 1)
        for k in range(18):
            col = column(b1, b2, k)
            if col >= 0:
                out[col] -= tau * g[k]


@_inline
def emit_force(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) of the springs at (r0, c0) (module notes; every
    entry of the bodies' director block); returns p."""
    if _rows(I, HCOL) == 0:
        return p
    sq, cqq, g = np.empty(18), np.empty(18), np.empty(18)
    H, hv = np.empty((18, 18)), np.empty(18)
    for i in range(_rows(I, HCOL)):
        th, thd, tau, s, c = _state(I, Fl, qx, vx, i, sq, cqq, g)
        hessian(I, Fl, HV, i, s, c, sq, cqq, H)
        k, damping = _f(I, Fl, HPAR, i, 0), _f(I, Fl, HPAR, i, 1)
        b1, b2 = _i(I, HCOL, i, 0), _i(I, HCOL, i, 1)
        hessian_times(b1, b2, H, vx, hv)              # the rate's gradient in q
        for a in range(18):
            ca = column(b1, b2, a)
            if ca < 0:
                continue
            for b in range(18):
                cb = column(b1, b2, b)
                if cb >= 0:
                    v = (cq * (g[a] * (k * g[b] + damping * hv[b]) + tau * H[a, b])
                         + cv * damping * g[a] * g[b])
                    p = _put(R, C, V, p, r0 + ca, c0 + cb, v)
    return p


@_inline
def energy_add(I, Fl, qx, e):
    """e + the springs' potential k wrap(theta - theta_0)^2 / 2 [J]."""
    if _rows(I, HCOL) == 0:
        return e
    sq, cq = np.empty(18), np.empty(18)
    for i in range(_rows(I, HCOL)):
        th, s, c = angle(I, Fl, HCOL, HV, i, qx, sq, cq)
        x = wrap(th - _f(I, Fl, HPAR, i, 2))
        e += 0.5 * _f(I, Fl, HPAR, i, 0) * x * x
    return e


@_inline
def power_add(I, Fl, qx, vx, p):
    """p + the power the dampers dissipate, c theta'^2 [W]."""
    if _rows(I, HCOL) == 0:
        return p
    sq, cq, g = np.empty(18), np.empty(18), np.empty(18)
    for i in range(_rows(I, HCOL)):
        damping = _f(I, Fl, HPAR, i, 1)
        if damping != 0.0:
            th, thd, tau, s, c = _state(I, Fl, qx, vx, i, sq, cq, g)
            p += damping * thd * thd
    return p
