"""Loads of a spatial model that read the motion: ``force(B.p, (fx, fy, fz))``
and ``torque(B, (tx, ty, tz))`` whose components read bodies' and points'
positions and velocities (``model.spatial.SpatialStateLoad``).

A spatial body's coordinates are linear: its centre of mass r and its
directors a_k (``model.spatial``), so that every quantity a load reads is a
polynomial in them and their rates, each of which is a state variable of one
column (``model.functions.StateVariable``):

* ``B.x, y, z`` and ``B.vx, vy, vz``: r and dr/dt;
* ``B.A11 .. A33`` and ``B.A11_t ..``: the directors (A_ij, world axis i of
  body axis j) and their rates;
* ``B.wx, wy, wz``: the body-axis angular velocity, w'_1 = a_3 . da_2/dt,
  w'_2 = a_1 . da_3/dt, w'_3 = a_2 . da_1/dt (from [w']x = A^T dA/dt,
  Haug 1989, sec. 9.2);
* ``B.P.x, y, z`` and ``B.P.vx, vy, vz``: a point's world position
  r + sum_k s_k a_k and velocity.

The load's generalized force is written entry by entry as expressions of
these (``SpatialLoad``'s: F on r and s_k F on a_k, T x a_k / 2 on a_k, with
components in body axes turned by the directors, F = sum_l f_l a_l), and
each entry is differentiated symbolically, so that the Newton matrix has
its exact Q_q and Q_v. Diagnostics: E201 (an unknown body or point), E304
(a field a body or point does not have in a load), E205 (a joint's angle or
distance, not yet read by spatial loads).
"""

from __future__ import annotations

import numpy as np

from ...model.elements import GROUND
from ...model.functions import StateVariable
from ...model.spatial import DIRECTORS, SPATIAL_COORDINATES, SpatialStateLoad
from ..expressions import (Binary, Dotted, ExprError, Name, Num, children, free_names, simplify,
                           substitute)
from .context import BrokenReference, did_you_mean
from .state_functions import state_function

__all__ = ["BODY_FIELDS", "POINT_FIELDS", "reads_motion", "spatial_state_load"]

#: A spatial body's fields a load reads: its coordinates, their rates, the
#: body-axis angular velocity.
BODY_FIELDS = (SPATIAL_COORDINATES + ("vx", "vy", "vz") + tuple(f"{d}_t" for d in DIRECTORS)
               + ("wx", "wy", "wz"))
#: A point's fields a load reads: its world position and velocity.
POINT_FIELDS = ("x", "y", "z", "vx", "vy", "vz")


def reads_motion(e) -> bool:
    """Whether an expression reads a ``body.field`` or ``body.point.field``."""
    if isinstance(e, Dotted):
        return True
    return any(reads_motion(sub) for sub in children(e))


def _director(i: int, k: int) -> str:
    """The name of A_ik (world axis i of body axis k, both 0-based)."""
    return f"A{i + 1}{k + 1}"


class _Reader:
    """Names the state variables of one load's expressions (``record``) and
    writes its reads of the motion as expressions in them (``resolve``)."""

    def __init__(self, c):
        self.c = c
        self.found: dict[str, StateVariable] = {}

    def variable(self, body, field: str) -> Name:
        """The body's coordinate (``z``, ``A12``) or its rate (``vz``,
        ``A12_t``) as a named state variable."""
        level, base = 0, field
        if field in ("vx", "vy", "vz"):
            level, base = 1, field[1]
        elif field.endswith("_t"):
            level, base = 1, field[:-2]
        name = f"{body.name}.{field}"
        self.found.setdefault(name, StateVariable(
            name, level, ((body.index, SPATIAL_COORDINATES.index(base), 1.0),)))
        return Name(name)

    def body_field(self, body, field: str, span):
        """A body's field as an expression in its state variables."""
        if field not in BODY_FIELDS:
            raise ExprError(f"'{body.name}.{field}': a spatial load reads a body's "
                            "x, y, z, vx, vy, vz, wx, wy, wz, A11 .. A33 or their rates "
                            "(A11_t ..)", "E304", span,
                            hint=did_you_mean(field, BODY_FIELDS)
                            or "yaw, pitch, roll and e0 .. e3 are output columns, not load inputs")
        if field in ("wx", "wy", "wz"):      # w'_k = a_(k+2) . da_(k+1)/dt, cyclic
            k = "xyz".index(field[1])
            a, b = (k + 2) % 3, (k + 1) % 3
            terms = [Binary("*", self.variable(body, _director(i, a)),
                            self.variable(body, _director(i, b) + "_t")) for i in range(3)]
            return simplify(Binary("+", Binary("+", terms[0], terms[1]), terms[2]))
        return self.variable(body, field)

    def point_field(self, ref: Dotted):
        """A point's world position or velocity component as an expression."""
        c, pt = self.c, ref.obj
        if ref.attr not in POINT_FIELDS:
            raise ExprError(f"'{ref.text}': a spatial load reads a point's "
                            f"{', '.join(POINT_FIELDS)}", "E304", ref.span,
                            hint=did_you_mean(ref.attr, POINT_FIELDS))
        p = c.point(pt, ref.span, f"'{ref.text}'")
        if p is None:
            raise BrokenReference(ref.text, "E201", ref.span)
        axis, rate = "xyz".index(ref.attr[-1]), ref.attr.startswith("v")
        if p.body == GROUND:
            return Num(0.0 if rate else float(np.asarray(p.local, float)[axis]))
        body = c.model_body(p.body)
        out = self.variable(body, ("v" if rate else "") + "xyz"[axis])
        for k, s in enumerate(np.asarray(p.local, float)):
            if s != 0.0:
                d = self.variable(body, _director(axis, k) + ("_t" if rate else ""))
                out = Binary("+", out, Binary("*", Num(float(s)), d))
        return out

    def resolve(self, ref):
        """What ``substitute`` puts for a reference (None: no state)."""
        c = self.c
        if isinstance(ref, Name):
            return None
        if isinstance(ref.obj, Dotted):
            return self.point_field(ref)
        obj = ref.obj if isinstance(ref.obj, str) else getattr(ref.obj, "text", "?")
        if obj in c.bodies:
            return self.body_field(c.bodies[obj], ref.attr, ref.span)
        if obj in c.joints:
            raise ExprError(f"'{ref.text}': a spatial load does not read a joint's "
                            f"{ref.attr} yet", "E205", ref.span,
                            hint="read the bodies' coordinates and angular velocities "
                            "(B.wx, ...) or a point's (B.P.vz)")
        if obj in c.broken_bodies or obj in c.broken_names:
            raise BrokenReference(ref.text, "E201", ref.span)
        raise ExprError(f"unknown body '{obj}' in '{ref.text}'", "E201", ref.span, name=obj,
                        hint=did_you_mean(obj, list(c.bodies)))

    def read(self, expr, span, ctx):
        """The expression with its reads substituted; None after reporting."""
        try:
            return substitute(expr, self.c.params, self.resolve, self.c.tables)
        except BrokenReference:
            return None
        except ExprError as err:
            self.c.expr_error(err, span, ctx)
            return None


def _world(reader, body, parts, frame):
    """The load's world components (3 expressions): as written, or in body
    axes turned by the directors, F_i = sum_l A_il f_l."""
    if frame != "body":
        return list(parts)
    out = []
    for i in range(3):
        terms = [Binary("*", reader.variable(body, _director(i, l)), parts[l]) for l in range(3)]
        out.append(Binary("+", Binary("+", terms[0], terms[1]), terms[2]))
    return out


def _entries(reader, body, world, local, torque):
    """(coordinate, expression) of the generalized force: F on r and s_k F
    on a_k (a force at s), T x a_k / 2 on a_k (a torque)."""
    out = []
    if not torque:
        out += [(i, world[i]) for i in range(3)]
        for k, s in enumerate(local):
            if s != 0.0:
                out += [(3 + 3 * k + i, Binary("*", Num(float(s)), world[i])) for i in range(3)]
        return out
    for k in range(3):
        for i in range(3):      # (T x a_k)_i = T_(i+1) A_(i+2)k - T_(i+2) A_(i+1)k
            j, m = (i + 1) % 3, (i + 2) % 3
            cross = Binary("-", Binary("*", world[j], reader.variable(body, _director(m, k))),
                           Binary("*", world[m], reader.variable(body, _director(j, k))))
            out.append((3 + 3 * k + i, Binary("*", Num(0.5), cross)))
    return out


def spatial_state_load(c, name, torque, index, local, parts, frame, span, ctx):
    """The :class:`SpatialStateLoad` of a spatial force or torque whose
    components ``parts`` (3 expressions, as written) read the motion; None
    after reporting.

    Parameters
    ----------
    c : check context
    name : str
    torque : bool
    index : int
        The body's index.
    local : ndarray, shape (3,) [m]
        The force's point in body axes (zeros for a torque).
    parts : sequence of 3 Expr
    frame : {"world", "body"}
    span : Span
    ctx : str
        The element, for messages.
    """
    unit = "N*m" if torque else "N"
    reader = _Reader(c)
    read = []
    for e in parts:
        if not c.dimension(e, unit, span, ctx):
            return None
        got = reader.read(e, span, ctx)
        if got is None:
            return None
        read.append(got)
    body = c.model_body(index)
    entries = []
    for coord, e in _entries(reader, body, _world(reader, body, read, frame), local, torque):
        e = simplify(e)
        read = free_names(e)                 # each entry differentiated by what it reads
        variables = tuple(v for name, v in reader.found.items() if name in read)
        fn = state_function(c, e, variables, span, ctx)
        if fn is None:
            return None
        entries.append((coord, fn))
    return SpatialStateLoad(name, index, tuple(entries), torque, span)
