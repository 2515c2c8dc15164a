"""Loads of the state: a torque tau(t, x) between a joint's two bodies, or a force
tau(t, x) along a sliding joint's line, x the state variables the expression
reads (a joint's angle or distance and their rates, body coordinates); the
rates f(t, x) of the first-order states, each the generalized force on its
integral's column (``model.elements.FirstOrderState``); and a spatial force or
torque of the state, entry by entry of its generalized force, each on one
column of its body (``model.spatial.SpatialStateLoad``).

Q = tau w, w = (+1, -1) on the two bodies' angles (a spatial entry: +1 on its
column) or grad s of the line (``geometry._line``); its derivatives: tau dw/dq
(a line's Hessian) and w (dtau/dx_k) (dx_k/dq, dx_k/dv) for every partial
derivative the checker wrote as a program (SDV).

Fields: STQ (k, 4) (program of tau, +column, -column, line row or -1), SDV
(j, 3) (load, variable, program of dtau/dx_k), VAR, VARC, XVAL the state
variables (``programs._state_values``).
"""

from __future__ import annotations

import numpy as np

from ..geometry import _line
from ..programs import _eval, _state_values, emit_variable
from ..schema import GEO, SDV, STQ, VAR, _i, _inline, _put, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("stq", "sdv")
#: Newton-matrix triplets per instance of a force block: per load and per partial derivative (SDV):
#: a 6 x 6 block.
FORCE_TRIPLETS = 36
#: The loads it holds (``model.elements``: ``Torque.kind`` of a torque that reads
#: the motion, ``JointTorque.kind``, ``JointForce.kind``, ``FirstOrderState.kind``;
#: ``model.spatial.SpatialStateLoad.kind``).
LOADS = ("state_torque", "joint_torque", "joint_force", "state_rate", "spatial_state_load")


def _instances(items):
    """The field's instances: (load, (body, coordinate) or None, function) per
    load, and per entry of a spatial load's generalized force."""
    for f in items:
        if f.kind == "spatial_state_load":
            for body, coord, fn in f.entries:
                yield f, (body, coord), fn
        else:
            yield f, None, f.function


def _direction(f, coord, cmap) -> tuple:
    """(+column, -column, line) of a load: the angles of the bodies tau acts
    on with + and - (a joint's second and first body, or one body and the
    ground's phi), or the ground's and a sliding joint's line; a first-order
    state's rate: its column and the ground's phi; a spatial entry: the
    column of ``coord`` = (body, coordinate) and the ground's phi."""
    if f.kind == "spatial_state_load":
        return cmap.column(*coord), cmap.n + 2, None
    if f.kind == "joint_force":
        return None, None, f.joint.line
    if f.kind == "state_rate":
        return cmap.state_column(f.index), cmap.n + 2, None
    plus, minus = (f.joint.second.body, f.joint.first.body) if f.kind == "joint_torque" \
        else (f.body, -1)
    a, b = (int(c) for c in cmap([plus, minus])[:, 2])
    return a, b, None


def pack(items, tables) -> dict:
    """Its fields from the model's loads of the state: per load the program of
    tau(t, x) on the state variables it reads, where it acts, and the
    programs of its partial derivatives dtau/dx_k.

    Parameters
    ----------
    items : list of Torque, JointTorque, JointForce, FirstOrderState or SpatialStateLoad
        The model's loads of the kinds of ``LOADS``, in its order.
    tables : packing context
        ``variable_rows``, ``value_program``, ``program`` and ``line_row``
        (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    ground_phi = tables.n + 2
    stq, sdv = [], []
    for f, coord, fn in _instances(items):
        names = tables.variable_rows(fn)
        program = tables.value_program(fn, names)
        a, b, line = _direction(f, coord, tables.cmap)
        stq.append((program, a, b, -1) if line is None
                   else (program, ground_phi, ground_phi, tables.line_row(line)))
        for v, ge in zip(getattr(fn, "variables", ()), getattr(fn, "grad_exprs", ())):
            sdv.append((len(stq) - 1, names[v.name], tables.program(ge, names)))
    return {"stq": np.array(stq, np.int64).reshape(-1, 4),
            "sdv": np.array(sdv, np.int64).reshape(-1, 3)}


def pattern(items, tables) -> tuple:
    """(columns (k, c) whose Q_q, Q_v entries a load may fill: those of its
    direction (two angles, or a line's six), then those its state variables
    read; whether any reads a rate)."""
    cmap, per, damped = tables.cmap, [], False
    for f, coord, fn in _instances(items):
        a, b, line = _direction(f, coord, cmap)
        cols = [a, b] if line is None else tables.line_columns(line)
        for var in getattr(fn, "variables", ()):
            cols += var.columns(cmap)
            damped = damped or var.level == 1
        per.append(list(dict.fromkeys(cols)))
    return tables.padded(per), damped


@_inline
def forces_add(I, Fl, t, qx, vx, out):
    """out (n+3,) += tau w of every load of the state [N, N m]."""
    if _rows(I, STQ) > 0:                          # loads of the state, in joints
        grad, H = np.empty(6), np.empty((6, 6))
        _state_values(I, Fl, qx, vx, grad, H)
        for i in range(_rows(I, STQ)):
            tau = _eval(I, Fl, _i(I, STQ, i, 0), t)
            g = _i(I, STQ, i, 3)
            if g < 0:                              # a torque: +tau, -tau
                out[_i(I, STQ, i, 1)] += tau
                out[_i(I, STQ, i, 2)] -= tau
            else:                                  # a force along a sliding line: tau grad s
                _line(I, Fl, qx, g, grad, H)
                for j in range(6):
                    out[_i(I, GEO, g, j)] += tau * grad[j]


@_inline
def emit_force(I, Fl, t, n, qx, vx, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) of the loads of the state at (r0, c0); returns p."""
    if _rows(I, STQ) > 0:      # loads of the state: Q = tau w, w = +-e_phi or grad s
        grad, H = np.empty(6), np.empty((6, 6))
        wg, wH = np.empty(6), np.empty((6, 6))
        _state_values(I, Fl, qx, vx, grad, H)
        if cq != 0.0:          # tau dw/dq of a force along a sliding line
            for i in range(_rows(I, STQ)):
                g = _i(I, STQ, i, 3)
                if g < 0:
                    continue
                tau = _eval(I, Fl, _i(I, STQ, i, 0), t)
                _line(I, Fl, qx, g, wg, wH)
                for a in range(6):
                    ra = _i(I, GEO, g, a)
                    for b in range(6):
                        cb = _i(I, GEO, g, b)
                        if ra < n and cb < n and wH[a, b] != 0.0:
                            p = _put(R, C, V, p, r0 + ra, c0 + cb, -cq * tau * wH[a, b])
        for e in range(_rows(I, SDV)):   # w (dtau/dx_k) (dx_k/dq, dx_k/dv)
            si, kv = _i(I, SDV, e, 0), _i(I, SDV, e, 1)
            gk = _eval(I, Fl, _i(I, SDV, e, 2), t)
            gs = _i(I, STQ, si, 3)
            if gs >= 0:
                _line(I, Fl, qx, gs, wg, wH)
            nrow = 2 if gs < 0 else 6
            gv = _i(I, VAR, kv, 3)
            if gv >= 0:
                _line(I, Fl, qx, gv, grad, H)
            for a in range(nrow):
                if gs < 0:
                    row, w = _i(I, STQ, si, 1 + a), (1.0 if a == 0 else -1.0)
                else:
                    row, w = _i(I, GEO, gs, a), wg[a]
                if row >= n or w == 0.0:
                    continue
                p = emit_variable(I, Fl, n, vx, R, C, V, p, r0, c0, cq, cv, row, w, gk, kv,
                                  grad, H)
    return p
