"""Torques on bodies: rotational spring-damper-actuators between two bodies,
tau = k (phi2 - phi1 - angle) + c (w2 - w1), and torques tau(t) of time.

Fields: RCOL (k, 2) the two angles' columns, RPAR (k, 3) (k [N m/rad],
c [N m s/rad], angle [rad]); TCOL (j,) a torque's column, TFN (j,) its
program.
"""

from __future__ import annotations

import numpy as np

from ..programs import _eval
from ..schema import RCOL, RPAR, TCOL, TFN, _f, _i, _inline, _jit, _put, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("rcol", "rpar", "tcol", "tfn")
#: Newton-matrix triplets per instance of a force block: a rotational spring-damper's 2 x 2 block
#: (torques of time have none).
FORCE_TRIPLETS = 4
#: The loads it holds (``model.elements.RotationalSpringDamper.kind``, ``Torque.kind``).
LOADS = ("rotational", "torque")


def pack(items, tables) -> dict:
    """Its fields from the model's rotational spring-dampers and torques of
    time (a constant torque as the program of its value: the power it puts
    in is that of the loads of ``system._inputs_add``).

    Parameters
    ----------
    items : list of RotationalSpringDamper or Torque
        The model's loads of the kinds of ``LOADS``, in its order.
    tables : packing context
        ``cmap`` and ``value_program`` (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    springs = [s for s in items if s.kind == "rotational"]
    torques = [f for f in items if f.kind == "torque"]
    out = {}
    if springs:
        out["rcol"] = _angles(springs, tables)
        out["rpar"] = np.array([(s.k, s.c, s.angle) for s in springs], np.float64)
    if torques:
        out["tcol"] = tables.cmap([f.body for f in torques])[:, 2].astype(np.int64)
        out["tfn"] = np.array([tables.value_program(f.function) for f in torques], np.int64)
    return out


def _angles(springs, tables) -> np.ndarray:
    """Columns (phi1, phi2) of the rotational springs' joints' bodies, (k, 2)."""
    return np.stack([tables.cmap([s.joint.first.body for s in springs])[:, 2],
                     tables.cmap([s.joint.second.body for s in springs])[:, 2]],
                    axis=1).astype(np.int64)


def pattern(items, tables) -> tuple:
    """(columns (k, 2) whose Q_q, Q_v entries a rotational spring fills, its
    two angles; whether any is damped), or None (torques of time only: no
    derivative)."""
    springs = [s for s in items if s.kind == "rotational"]
    if not springs:
        return None
    return _angles(springs, tables), any(s.c != 0.0 for s in springs)


@_jit
def _rotational_energy(I, Fl, qx, i):
    """(relative angle theta_2 - theta_1 [rad], k (theta - theta0)^2 / 2 [J])
    of rotational spring-damper i at qx."""
    a = qx[_i(I, RCOL, i, 1)] - qx[_i(I, RCOL, i, 0)]
    th = a - _f(I, Fl, RPAR, i, 2)
    return a, 0.5 * _f(I, Fl, RPAR, i, 0) * th * th


@_inline
def forces_add(I, Fl, qx, vx, out):
    """out (n+3,) += the rotational spring-dampers' torques [N m]:
    tau = k (phi2 - phi1 - angle) + c (w2 - w1), +tau on body 1, -tau on body 2."""
    for i in range(_rows(I, RCOL)):
        tau = (_f(I, Fl, RPAR, i, 0) * (qx[_i(I, RCOL, i, 1)] - qx[_i(I, RCOL, i, 0)] - _f(I, Fl, RPAR, i, 2))
               + _f(I, Fl, RPAR, i, 1) * (vx[_i(I, RCOL, i, 1)] - vx[_i(I, RCOL, i, 0)]))
        out[_i(I, RCOL, i, 0)] += tau
        out[_i(I, RCOL, i, 1)] -= tau


@_inline
def time_torques_add(I, Fl, t, out):
    """out (n+3,) += the torques tau(t) on bodies [N m]."""
    for i in range(_rows(I, TCOL)):
        out[_i(I, TCOL, i, 0)] += _eval(I, Fl, _i(I, TFN, i, 0), t)


@_inline
def emit_force(I, Fl, n, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) of the rotational spring-dampers at (r0, c0):
    Q_q = k [[-1, 1], [1, -1]], Q_v = c [[-1, 1], [1, -1]]; returns p."""
    for i in range(_rows(I, RCOL)):
        for a in range(2):
            for b in range(2):
                if _i(I, RCOL, i, a) < n and _i(I, RCOL, i, b) < n:
                    sgn = -1.0 if a == b else 1.0      # Q_q = k [[-1, 1], [1, -1]]
                    val = sgn * (cq * _f(I, Fl, RPAR, i, 0) + cv * _f(I, Fl, RPAR, i, 1))
                    p = _put(R, C, V, p, r0 + _i(I, RCOL, i, a), c0 + _i(I, RCOL, i, b), -val)
    return p


@_inline
def energy_add(I, Fl, qx, e):
    """e + the rotational springs' potential k theta^2 / 2 [J]."""
    for i in range(_rows(I, RCOL)):
        e += _rotational_energy(I, Fl, qx, i)[1]
    return e


@_inline
def power_add(I, Fl, vx, p):
    """p + the power the rotational dampers dissipate, c theta'^2 [W]."""
    for i in range(_rows(I, RCOL)):
        w = vx[_i(I, RCOL, i, 1)] - vx[_i(I, RCOL, i, 0)]
        p += _f(I, Fl, RPAR, i, 1) * w * w
    return p
