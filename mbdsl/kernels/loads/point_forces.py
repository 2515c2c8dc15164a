"""Point forces F on body points: Q = J^T F, J = dr_P/dq = [I, B u] (and A S_k
on a flexible beam's point); F constant, of time, or of time and the state
(a follower force, a drag: ``model.elements.PointForce``).

Q_q = (dJ^T/dq) F + J^T (dF/dx)(dx/dq), Q_v = J^T (dF/dx)(dx/dv), x the state
variables the components read (``programs._state_values``), dF/dx their
partial derivatives taken symbolically at check time (one program per
component and variable, FDV).

Fields: FCOL (k, 3) the body's columns, FS (k, 2) the local point [m], FF
(k, 2) a constant force [N], FFN (k, 2) the programs of fx, fy (-1: the
constant), FEL (k, 2) elastic spans, FDV (j, 4) (force, component 0/1,
state variable, program of dF_component/dx).
"""

from __future__ import annotations

import numpy as np

from ..geometry import _Au, _eshape, _line, _span
from ..programs import _eval, _state_values, emit_variable
from ..schema import (ECOL, FCOL, FDV, FEL, FF, FFN, FS, VAR, _f, _i, _inline, _jit, _put,
                      _rows)

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("fcol", "fs", "fF", "ffn", "fel", "fdv")
#: Newton-matrix triplets per instance of a force block: the body angle's diagonal (a point on a
#: beam, and the derivatives of forces of the state: :func:`triplets`).
FORCE_TRIPLETS = 1
#: The loads it holds (``model.elements.PointForce.kind``).
LOADS = ("point_force",)


def _reads_state(f) -> bool:
    """Whether a component is a function of the state (``StateFunction``)."""
    return bool(getattr(f, "variables", ()))


def pack(items, tables) -> dict:
    """Its fields from the model's point forces: a constant component as its
    value, one of time or of the state as its program, and the programs of
    the partial derivatives of the components of the state.

    Parameters
    ----------
    items : list of PointForce
        The model's point forces, in its order.
    tables : packing context
        ``points``, ``elastic_spans``, ``timed``, ``program``,
        ``value_program`` and ``variable_rows``
        (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    from mbdsl.dsl.expressions import Num     # absolute: the uncompiled copy shares the class
    points = [f.point for f in items]
    tables.elastic_spans("fel", points)
    fcol, fs = tables.points(points)
    timed = tables.timed
    fF, ffn, fdv = [], [], []
    for i, f in enumerate(items):
        values, programs = [], []
        for k, c in enumerate((f.fx, f.fy)):
            if _reads_state(c):
                names = tables.variable_rows(c)
                values.append(0.0)
                programs.append(tables.value_program(c, names))
                for v, ge in zip(c.variables, c.grad_exprs):
                    if not (isinstance(ge, Num) and ge.value == 0.0):
                        fdv.append((i, k, names[v.name], tables.program(ge, names)))
            else:
                values.append(0.0 if timed(c) else c.f(0.0))
                programs.append(tables.program(c.expr) if timed(c) else -1)
        fF.append(values)
        ffn.append(programs)
    return {"fcol": fcol, "fs": fs, "fF": np.array(fF, np.float64).reshape(-1, 2),
            "ffn": np.array(ffn, np.int64).reshape(-1, 2),
            "fdv": np.array(fdv, np.int64).reshape(-1, 4)}


def pattern(items, tables) -> tuple:
    """(columns (k, c) whose Q_q, Q_v entries a point force may fill: its
    body's and, on a flexible beam, its elastic coordinates, then those the
    state variables of its components read; whether any reads a rate)."""
    base = tables.point_columns([f.point for f in items])
    per, damped = [], False
    for f, cols in zip(items, base):
        cols = [int(c) for c in cols]
        for c in (f.fx, f.fy):
            for var in getattr(c, "variables", ()):
                cols += var.columns(tables.cmap)
                damped = damped or var.level == 1
        per.append(list(dict.fromkeys(cols)))
    return tables.padded(per), damped


def triplets(I) -> int:
    """The most triplets the derivatives of forces of the state add to a
    force block: per row of FDV, 3 + e rows (e: the force's elastic terms on
    a flexible beam) by the variable's columns (6 at most, a sliding line's)."""
    def field(k):
        """(offset, rows) of field k in I (the schema's header; read in Python
        here, where the jitted accessors ``_i``/``_rows`` would compile)."""
        return int(I[3 * k]), int(I[3 * k + 1])
    off, rows = field(FDV)
    fel_off, fel_rows = field(FEL)
    total = 0
    for r in range(rows):
        i = int(I[off + 4 * r])
        e = int(I[fel_off + 2 * i + 1] - I[fel_off + 2 * i]) if fel_rows > 0 else 0
        total += 6 * (3 + e)
    return total


@_jit
def _point_force(I, Fl, t, i):
    """(fx, fy) [N] of point force i at time t: constant, or its programs (of
    the state: the variables' values in XVAL, ``_state_values``)."""
    fx, fy = _f(I, Fl, FF, i, 0), _f(I, Fl, FF, i, 1)
    if _i(I, FFN, i, 0) >= 0:
        fx = _eval(I, Fl, _i(I, FFN, i, 0), t)
    if _i(I, FFN, i, 1) >= 0:
        fy = _eval(I, Fl, _i(I, FFN, i, 1), t)
    return fx, fy


@_inline
def forces_add(I, Fl, t, qx, vx, out):
    """out (n+3,) += J^T F(t, x) [N, N m] of every point force (on a flexible
    beam's point also (A S_k) . F in its elastic columns)."""
    if _rows(I, FDV) > 0:                  # forces of the state: the variables' values
        _state_values(I, Fl, qx, vx, np.empty(6), np.empty((6, 6)))
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


@_jit
def _emit_state(I, Fl, t, n, qx, vx, R, C, V, p, r0, c0, cq, cv):
    """-J^T (dF/dx)(cq dx/dq + cv dx/dv) of the forces of the state at (r0,
    c0): per partial derivative dF_c/dx_k, the row J^T e_c (1 in the body's
    x or y, -(A u)_y or (A u)_x in its angle, (A S_j)_c in its elastic
    columns) times the variable's derivative (``programs.emit_variable``);
    returns p."""
    grad, H = np.empty(6), np.empty((6, 6))
    for e in range(_rows(I, FDV)):
        i, comp, kv = _i(I, FDV, e, 0), _i(I, FDV, e, 1), _i(I, FDV, e, 2)
        gk = _eval(I, Fl, _i(I, FDV, e, 3), t)
        gv = _i(I, VAR, kv, 3)
        if gv >= 0:
            _line(I, Fl, qx, gv, grad, H)
        p = emit_variable(I, Fl, n, vx, R, C, V, p, r0, c0, cq, cv, _i(I, FCOL, i, comp),
                          1.0, gk, kv, grad, H)
        cph = _i(I, FCOL, i, 2)
        if cph < n:                        # a particle's angle is the ground's
            ax, ay = _Au(I, Fl, qx, FCOL, FS, FEL, 0, i)
            p = emit_variable(I, Fl, n, vx, R, C, V, p, r0, c0, cq, cv, cph,
                              -ay if comp == 0 else ax, gk, kv, grad, H)
        k0, k1 = _span(I, FEL, i, 0)
        for k in range(k0, k1):
            Ax, Ay, Bx, By = _eshape(I, Fl, k, qx[cph])
            p = emit_variable(I, Fl, n, vx, R, C, V, p, r0, c0, cq, cv, _i(I, ECOL, k, 0),
                              Ax if comp == 0 else Ay, gk, kv, grad, H)
    return p


@_inline
def emit_force(I, Fl, t, n, qx, vx, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) at (r0, c0): (d^2 p/dphi^2) . F = -(A u) . F on the
    body's angle, B S_k . F between the angle and an elastic coordinate, and
    for forces of the state J^T (dF/dx)(dx/dq, dx/dv) (:func:`_emit_state`);
    returns p."""
    if _rows(I, FDV) > 0:
        _state_values(I, Fl, qx, vx, np.empty(6), np.empty((6, 6)))
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
    if _rows(I, FDV) > 0:
        p = _emit_state(I, Fl, t, n, qx, vx, R, C, V, p, r0, c0, cq, cv)
    return p
