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
  r + sum_k s_k a_k and velocity;
* ``J.angle`` and ``J.rate`` of a revolute or cylindrical joint: the output
  column's atan2(G1 . F2, F1 . F2) (``kernels.joints.spatial_angles``),
  within +-pi, written 2 atan(s / (c + sqrt(s^2 + c^2))), and its rate
  (c s' - s c') / (s^2 + c^2); ``J.distance`` and ``J.speed`` of a
  prismatic, cylindrical or point_on_line joint, u . (p1 - p2) and its rate.

The load's generalized force is written entry by entry as expressions of
these (``SpatialLoad``'s: F on r and s_k F on a_k, T x a_k / 2 on a_k, with
components in body axes turned by the directors, F = sum_l f_l a_l), and
each entry is differentiated symbolically, so that the Newton matrix has
its exact Q_q and Q_v. ``joint_torque(J, tau)`` and ``joint_force(J, F)``
are loads of this kind too (``spatial_joint_load``). Diagnostics: E201 (an
unknown body, joint or point), E304 (a field a body, point or joint does
not have in a load), E305 (a joint load in a joint of another kind).
"""

from __future__ import annotations

import numpy as np

from ...model.elements import GROUND
from ...model.functions import StateVariable
from ...model.spatial import DIRECTORS, SPATIAL_COORDINATES, SpatialStateLoad, reference_vectors
from ..expressions import (Binary, Call, Dotted, ExprError, Name, Num, children, diff, free_names,
                           simplify, substitute, sum_of)
from .context import BrokenReference, did_you_mean
from .state_functions import state_function

__all__ = ["BODY_FIELDS", "POINT_FIELDS", "reads_motion", "spatial_state_load",
           "spatial_joint_load"]

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


def _dot(u, w):
    """u . w of two 3-vectors of expressions."""
    return sum_of(Binary("*", a, b) for a, b in zip(u, w))


def _scale(a, u):
    """a u, a an expression or a number, u a 3-vector of expressions."""
    a = Num(float(a)) if isinstance(a, (int, float)) else a
    return [Binary("*", a, x) for x in u]


#: The spatial joints with an angle, and with a distance along a line
#: (``check.spatial``: ANGLE_JOINTS, DISTANCE_JOINTS).
ANGLE_KINDS = ("revolute", "cylindrical")
DISTANCE_KINDS = ("prismatic", "cylindrical", "point_on_line")


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

    def vector(self, index, local, point=False, rate=False) -> list:
        """World components (3 expressions) of the body-fixed vector ``local``
        of body ``index`` (a point: r + sum_k s_k a_k; else sum_k s_k a_k),
        or with ``rate`` their rates; the ground's: constants."""
        local = np.asarray(local, float)
        if index == GROUND:
            return [Num(0.0 if rate else float(x)) for x in local]
        body = self.c.model_body(index)
        out = []
        for i in range(3):
            terms = [self.variable(body, ("v" if rate else "") + "xyz"[i])] if point else []
            terms += [Binary("*", Num(float(s)), self.variable(
                body, _director(i, k) + ("_t" if rate else "")))
                for k, s in enumerate(local) if s != 0.0]
            out.append(sum_of(terms))
        return out

    def body_field(self, body, field: str, span):
        """A body's field as an expression in its state variables."""
        if field not in BODY_FIELDS:
            raise ExprError(f"'{body.name}.{field}': a spatial load reads a body's "
                            "x, y, z, vx, vy, vz, wx, wy, wz, A11 .. A33 or their rates "
                            "(A11_t ..)", "E304", span,
                            hint=did_you_mean(field, BODY_FIELDS)
                            or "yaw, pitch, roll and e0 .. e3 are output columns, not load inputs")
        if getattr(body, "particle", False) and field not in POINT_FIELDS:
            raise ExprError(f"'{body.name}.{field}': particle '{body.name}' does not turn: "
                            f"a load reads its {', '.join(POINT_FIELDS)}", "E304", span,
                            hint=did_you_mean(field, POINT_FIELDS))
        if field in ("wx", "wy", "wz"):      # w'_k = a_(k+2) . da_(k+1)/dt, cyclic
            k = "xyz".index(field[1])
            e = np.eye(3)
            return simplify(_dot(self.vector(body.index, e[(k + 2) % 3]),
                                 self.vector(body.index, e[(k + 1) % 3], rate=True)))
        return self.variable(body, field)

    def point_field(self, ref: Dotted):
        """A point's world position or velocity component as an expression."""
        if ref.attr not in POINT_FIELDS:
            raise ExprError(f"'{ref.text}': a spatial load reads a point's "
                            f"{', '.join(POINT_FIELDS)}", "E304", ref.span,
                            hint=did_you_mean(ref.attr, POINT_FIELDS))
        p = self.c.point(ref.obj, ref.span, f"'{ref.text}'")
        if p is None:
            raise BrokenReference(ref.text, "E201", ref.span)
        axis, rate = "xyz".index(ref.attr[-1]), ref.attr.startswith("v")
        return simplify(self.vector(p.body, p.local, point=True, rate=rate)[axis])

    def joint_field(self, joint, field: str, span):
        """A spatial joint's angle theta (revolute, cylindrical: the output
        column's, atan2(G1 . F2, F1 . F2) of ``kernels.joints.spatial_angles``,
        written 2 atan(s / (c + sqrt(s^2 + c^2)))) or its rate (c s' - s c')
        / (s^2 + c^2); a sliding joint's distance u . (p1 - p2) or speed."""
        if field in ("angle", "rate") and joint.kind in ANGLE_KINDS:
            (b1, a1), (b2, a2) = joint.axes
            v9 = reference_vectors(a1, a2)
            F1, G1, F2 = (self.vector(b, v) for b, v in ((b1, v9[:3]), (b1, v9[3:6]),
                                                        (b2, v9[6:])))
            s, c = _dot(G1, F2), _dot(F1, F2)
            if field == "angle":
                r = Call("sqrt", Binary("+", Binary("*", s, s), Binary("*", c, c)))
                return simplify(Binary("*", Num(2.0), Call("atan", Binary(
                    "/", s, Binary("+", c, r)))))
            dF1, dG1, dF2 = (self.vector(b, v, rate=True) for b, v in (
                (b1, v9[:3]), (b1, v9[3:6]), (b2, v9[6:])))
            ds = Binary("+", _dot(dG1, F2), _dot(G1, dF2))
            dc = Binary("+", _dot(dF1, F2), _dot(F1, dF2))
            return simplify(Binary("/", Binary("-", Binary("*", c, ds), Binary("*", s, dc)),
                                   Binary("+", Binary("*", s, s), Binary("*", c, c))))
        if field in ("distance", "speed") and joint.kind in DISTANCE_KINDS:
            bu, u = joint.axes[-1]
            p1, p2 = joint.first, joint.second
            d = [Binary("-", a, b) for a, b in zip(self.vector(p1.body, p1.local, point=True),
                                                   self.vector(p2.body, p2.local, point=True))]
            U = self.vector(bu, u)
            if field == "distance":
                return simplify(_dot(U, d))
            dd = [Binary("-", a, b) for a, b in zip(
                self.vector(p1.body, p1.local, point=True, rate=True),
                self.vector(p2.body, p2.local, point=True, rate=True))]
            return simplify(Binary("+", _dot(self.vector(bu, u, rate=True), d), _dot(U, dd)))
        fields = (("angle", "rate") if joint.kind in ANGLE_KINDS else ()) + (
            ("distance", "speed") if joint.kind in DISTANCE_KINDS else ())
        raise ExprError(f"'{joint.name}.{field}': a load reads a spatial {joint.kind} "
                        f"joint's {', '.join(fields) or 'nothing'}", "E304", span,
                        hint=did_you_mean(field, fields) or "read its bodies' coordinates")

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
            return self.joint_field(c.joints[obj], ref.attr, ref.span)
        if obj in c.broken_bodies or obj in c.broken_names:
            raise BrokenReference(ref.text, "E201", ref.span)
        raise ExprError(f"unknown body or joint '{obj}' in '{ref.text}'", "E201", ref.span,
                        name=obj, hint=did_you_mean(obj, list(c.bodies) + list(c.joints)))

    def read(self, expr, span, ctx, unit):
        """The expression with its reads substituted; None after reporting
        (its dimension against ``unit`` too)."""
        if not self.c.dimension(expr, unit, span, ctx):
            return None
        try:
            return substitute(expr, self.c.params, self.resolve, self.c.tables)
        except BrokenReference:
            return None
        except ExprError as err:
            self.c.expr_error(err, span, ctx)
            return None


def _force_entries(index, local, F, sign=1.0):
    """(body, coordinate, expression) of a force F (world, 3 expressions) at
    the body point ``local``: F on r and s_k F on a_k (``sign`` -1: -F);
    none on the ground."""
    if index == GROUND:
        return []
    F = _scale(sign, F) if sign != 1.0 else F
    out = [(index, i, F[i]) for i in range(3)]
    for k, s in enumerate(np.asarray(local, float)):
        if s != 0.0:
            out += [(index, 3 + 3 * k + i, Binary("*", Num(float(s)), F[i])) for i in range(3)]
    return out


def _torque_entries(reader, index, T, sign=1.0):
    """(body, coordinate, expression) of a torque T (world, 3 expressions)
    on a body: T x a_k / 2 on a_k (``sign`` -1: -T); none on the ground."""
    if index == GROUND:
        return []
    out = []
    for k in range(3):
        a = reader.vector(index, np.eye(3)[k])
        for i in range(3):      # (T x a_k)_i = T_(i+1) A_(i+2)k - T_(i+2) A_(i+1)k
            j, m = (i + 1) % 3, (i + 2) % 3
            cross = Binary("-", Binary("*", T[j], a[m]), Binary("*", T[m], a[j]))
            out.append((index, 3 + 3 * k + i, Binary("*", Num(0.5 * sign), cross)))
    return out


def _product_grads(tau, dtau, e, variables):
    """The partial derivatives of tau e by the product rule, dtau_k e + tau
    de/dx_k, with tau's (``dtau``: name -> derivative) taken once for all
    the entries of a joint's load: tau, the joint's law, reads the joint's
    angle and rate, expressions of some thousand nodes in the directors,
    and differentiating each entry tau e whole took 2 s on
    models/spatial_arm.mbd."""
    read, out = free_names(e), []
    for v in variables:
        parts = []
        if v.name in dtau:
            parts.append(Binary("*", dtau[v.name], e))
        if v.name in read:
            parts.append(Binary("*", tau, simplify(diff(e, v.name))))
        out.append(sum_of(parts))
    return out


def _load(c, reader, name, entries, torque, span, ctx, tau=None):
    """The SpatialStateLoad of (body, coordinate, expression) entries, each
    compiled with the partial derivatives of what it reads (with ``tau``, the
    entries are tau times theirs); None after reporting."""
    dtau = {}
    if tau is not None:
        tau = simplify(tau)
        try:
            dtau = {v: diff(tau, v) for v in free_names(tau) if v in reader.found}
        except ExprError as err:
            c.expr_error(err, span, ctx)
            return None
    out = []
    for body, coord, e in entries:
        e = simplify(e)
        read = free_names(e) | set(dtau)       # each entry differentiated by what it reads
        variables = tuple(v for key, v in reader.found.items() if key in read)
        grads = None if tau is None else _product_grads(tau, dtau, e, variables)
        fn = state_function(c, e if tau is None else Binary("*", tau, e), variables, span,
                            ctx, grads)
        if fn is None:
            return None
        out.append((body, coord, fn))
    return SpatialStateLoad(name, tuple(out), torque, span)


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
        The components' axes: in body axes F = sum_l f_l a_l.
    span : Span
    ctx : str
        The element, for messages.
    """
    reader = _Reader(c)
    read = [reader.read(e, span, ctx, "N*m" if torque else "N") for e in parts]
    if any(e is None for e in read):
        return None
    if frame == "body":
        e = np.eye(3)
        read = [sum_of(Binary("*", reader.vector(index, e[l])[i], read[l]) for l in range(3))
                for i in range(3)]
    entries = (_torque_entries(reader, index, read) if torque
               else _force_entries(index, local, read))
    return _load(c, reader, name, entries, torque, span, ctx)


def spatial_joint_load(c, f, pos, ctx):
    """``joint_torque(J, tau)`` [N m] in a spatial revolute or cylindrical
    joint, tau u on its second body and -tau u on its first, u the first
    body's joint axis (so that tau does the work tau theta'); or
    ``joint_force(J, F)`` [N] along a prismatic, cylindrical or
    point_on_line joint, F u on its first point and -F u on its second, u
    the line's direction (so that F does the work F s'): a
    :class:`SpatialStateLoad`, tau and F constants, of time or of the
    motion. None after reporting (E305 a joint of another kind)."""
    joint = c.joint_argument(pos[0], f, ctx)
    if joint is None:
        return None
    torque = f.kind == "joint_torque"
    kinds = ANGLE_KINDS if torque else DISTANCE_KINDS
    if joint.kind not in kinds:
        c.error("E305", f"{ctx}: a {f.kind} acts in a {' or '.join(kinds)} joint; "
                f"'{joint.name}' is a {joint.kind} joint",
                getattr(pos[0].value, "span", None) or f.span, f"not a {kinds[0]} joint",
                hint="joint_torque in a revolute or cylindrical joint, joint_force along "
                "a prismatic, cylindrical or point_on_line joint")
        return None
    reader = _Reader(c)
    value = reader.read(pos[1].value, pos[1].span or f.span, ctx, "N*m" if torque else "N")
    if value is None:
        return None
    if torque:                 # the entries of the unit torque u, each times tau
        (b1, a1), (b2, _) = joint.axes
        u = reader.vector(b1, a1)
        entries = (_torque_entries(reader, b2, u) + _torque_entries(reader, b1, u, -1.0))
    else:                      # of the unit force u, each times F
        bu, u = joint.axes[-1]
        u = reader.vector(bu, u)
        p1, p2 = joint.first, joint.second
        entries = (_force_entries(p1.body, p1.local, u)
                   + _force_entries(p2.body, p2.local, u, -1.0))
    return _load(c, reader, f.name, entries, torque, f.span, ctx, tau=value)
