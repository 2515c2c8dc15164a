"""Pass 5 (gravity) and pass 9, loads: spring-dampers, torques, joint forces and
torques, point forces, friction, joint limits and (``contact.py``) contact;
force expressions of time and of the motion compiled with their gradients.
Diagnostics: E205 (unknown kind), E304/E305 (options and arguments), E201 (a
name the expression cannot read), E303 (a value out of range), E402 (a body
acting on itself).
"""

from __future__ import annotations

import numpy as np

from ...model.spatial import SpatialRotationalSpring, SpatialSpring
from ...model.elements import (GROUND, FlexibleBeam, Friction, JointForce, JointTorque, PointForce,
                               RotationalSpringDamper, SpringDamper, StateVariable, Torque)
from ..expressions import (Binary, Call, Dotted, ExprError, Name, Num, simplify, substitute,
                           sum_of, Unary, Vec)
from .contact import contact_element, rope_element
from .spatial_state import spatial_joint_load
from .state_functions import state_function
from .spatial import ANGLE_JOINTS, spatial_load
from .context import BrokenReference, did_you_mean, point_ref
from .tables import (BODY_STATE, FORCE_FRAMES, FORCE_KINDS, GEOMETRY_OPTIONS, JOINT_MOTION,
                     REVOLUTE_STATE, SLIDING_STATE, WORD_OPTIONS)


#: the SI unit of a force option (friction's speeds are m/s or rad/s by joint: unchecked)
FORCE_UNITS = {("spring_damper", "k"): "N/m", ("spring_damper", "c"): "N*s/m",
               ("spring_damper", "length"): "m", ("rotational_spring_damper", "k"): "N*m/rad",
               ("rotational_spring_damper", "c"): "N*m*s/rad",
               ("rotational_spring_damper", "angle"): "rad", ("friction", "mu"): "1",
               ("friction", "mu_static"): "1", ("friction", "radius"): "m",
               ("contact", "radius"): "m", ("contact", "exponent"): "1",
               ("contact", "restitution"): "1", ("contact", "mu"): "1",
               ("contact", "v_reg"): "m/s", ("limit", "exponent"): "1",
               ("limit", "restitution"): "1", ("rope", "length"): "m", ("rope", "k"): "N/m",
               ("rope", "c"): "N*s/m", ("cable", "length"): "m", ("cable", "EA"): "N",
               ("cable", "c"): "N*s/m"}


def check_forces(c):
    """Check force options (required, non-negative) and build force elements."""
    c.forces = []
    for f in c.items["forces"]:
        ok = c.claim(f.name, f.span, "force")
        ctx = f"force '{f.name}'"
        if not c.known_kind(f, FORCE_KINDS, "force", ctx):
            continue
        allowed = FORCE_KINDS[f.kind]
        npos = {"spring_damper": 2, "rotational_spring_damper": 1, "torque": 2,
                "joint_torque": 2, "joint_force": 2, "force": 2, "friction": 1,
                "contact": 1, "limit": 1, "rope": 2, "cable": 2}[f.kind]
        pos, kw = c.split_args(f, allowed, npos, ctx)
        if pos is None:
            continue
        opts = {}
        for name, default in allowed.items():
            if name in kw and name in GEOMETRY_OPTIONS + WORD_OPTIONS:
                opts[name] = kw[name]
            elif name in kw:
                v = (c.angle if name == "angle" else c.number)(
                    kw[name].value, kw[name].span, f"{ctx}: {name}",
                    unit=FORCE_UNITS.get((f.kind, name)))
                if v is None:
                    break
                if name in ("k", "c", "mu", "mu_static", "viscous", "v_stribeck",
                            "radius", "EA") and v < 0:
                    c.error("E303", f"{ctx}: '{name}' must not be negative, got {v:g}",
                            kw[name].span, "negative",
                            hint="a negative stiffness, damping or friction coefficient "
                            "feeds energy in")
                    break
                if name == "v_reg" and not v > 0:
                    c.error("E303", f"{ctx}: the regularisation speed 'v_reg' must be "
                            f"positive, got {v:g}", kw[name].span, "not positive",
                            hint="the friction force reaches mu N at a few v_reg: "
                            "1e-4 m/s (or rad/s) suits most machines")
                    break
                if name == "length" and v < 0:
                    c.error("E303", f"{ctx}: the free length must not be negative, got {v:g} m",
                            kw[name].span, "negative length")
                    break
                opts[name] = v
            elif default is not None:
                opts[name] = default
            else:
                break
        else:
            el = force_element(c, f, pos, opts, ctx)
            if el is not None and ok:
                c.forces.append(el)


def force_element(c, f, pos, opts, ctx):
    """Build one force element from checked arguments (by kind, :data:`BUILDERS`);
    None after reporting."""
    return BUILDERS[f.kind](c, f, pos, opts, ctx)


def _spring_damper(c, f, pos, opts, ctx):
    """A spring-damper-actuator between two points (``model.elements.SpringDamper``,
    in a spatial model ``model.spatial.SpatialSpring``)."""
    a = c.point(pos[0].value, pos[0].span or f.span, ctx)
    b = c.point(pos[1].value, pos[1].span or f.span, ctx)
    if a is None or b is None:
        return None
    if a.body == b.body:
        c.error("E402", f"{ctx} connects a body to itself", f.span, "no effect",
                hint="a spring-damper acts between two different bodies")
        return None
    element = SpatialSpring if c.space == 3 else SpringDamper
    return element(f.name, a, b, opts["k"], opts["c"], opts["length"], f.span)


def _rotational_spring_damper(c, f, pos, opts, ctx):
    """A rotational spring-damper on a revolute's relative angle (in a
    spatial model a revolute's or cylindrical's angle about its axis:
    ``model.spatial.SpatialRotationalSpring``)."""
    joint = c.joint_argument(pos[0], f, ctx)
    if joint is not None and c.space == 3:
        if joint.kind not in ANGLE_JOINTS:
            c.error("E201", f"{ctx}: a rotational spring-damper acts about a revolute's or "
                    f"cylindrical's axis, not on a {joint.kind} joint",
                    pos[0].span or f.span, "no joint angle",
                    hint="name a revolute or cylindrical joint")
            return None
        return SpatialRotationalSpring(f.name, joint, opts["k"], opts["c"], opts["angle"],
                                       f.span)
    if joint is None or not c.turning(joint.bodies, ctx, f.span,
                                      "a rotational spring acts on a relative angle"):
        return None
    return RotationalSpringDamper(f.name, joint, opts["k"], opts["c"], opts["angle"],
                                  f.span)


def _torque(c, f, pos, opts, ctx):
    """A torque on a body, of time and of the motion [N m] (in a spatial
    model a vector: ``check.spatial.spatial_load``)."""
    if c.space == 3:
        return spatial_load(c, f, pos, opts, ctx)
    if frame_span(f) is not None:
        c.error("E304", f"{ctx}: a planar torque has no 'frame' (it acts about the plane's "
                "normal)", frame_span(f), "unknown option")
        return None
    ref = pos[0].value
    if not isinstance(ref, Name) or ref.name not in c.bodies:
        name = ref.name if isinstance(ref, Name) else "?"
        if name not in c.broken_bodies:
            c.error("E201", f"{ctx}: expected the name of a body, got '{name}'",
                    getattr(ref, "span", None) or f.span, "not a body",
                    hint=did_you_mean(name, c.bodies))
        return None
    if not c.turning([c.bodies[ref.name].index], ctx, f.span,
                     "a torque turns a body"):
        return None
    fn = force_function(c, pos[1].value, pos[1].span or f.span, ctx, unit="N*m")
    return Torque(f.name, c.bodies[ref.name].index, fn, f.span) if fn else None


def _joint_torque(c, f, pos, opts, ctx):
    """A torque in a revolute joint, equal and opposite on its bodies [N m]
    (in a spatial model: ``check.spatial_state.spatial_joint_load``)."""
    if c.space == 3:
        return spatial_joint_load(c, f, pos, ctx)
    joint = c.joint_argument(pos[0], f, ctx)
    if joint is None:
        return None
    ref = pos[0].value
    if joint.kind != "revolute":
        c.error("E305", f"{ctx}: a joint torque acts in a revolute joint; "
                f"'{joint.name}' is a {joint.kind} joint",
                getattr(ref, "span", None) or f.span, "not a revolute joint",
                hint="apply torque(body, ...) to one of its bodies instead")
        return None
    if not c.turning(joint.bodies, ctx, f.span, "a joint torque turns its bodies"):
        return None
    fn = force_function(c, pos[1].value, pos[1].span or f.span, ctx, unit="N*m")
    return JointTorque(f.name, joint, fn, f.span) if fn else None


def _joint_force(c, f, pos, opts, ctx):
    """A force along a sliding joint's line, equal and opposite on its bodies [N]
    (in a spatial model: ``check.spatial_state.spatial_joint_load``)."""
    if c.space == 3:
        return spatial_joint_load(c, f, pos, ctx)
    joint = c.joint_argument(pos[0], f, ctx)
    if joint is None:
        return None
    if joint.kind not in ("prismatic", "point_on_line"):
        c.error("E305", f"{ctx}: a joint force acts along a prismatic or point_on_line "
                f"joint; '{joint.name}' is a {joint.kind} joint",
                getattr(pos[0].value, "span", None) or f.span, "not a sliding joint",
                hint="use joint_torque for a revolute joint")
        return None
    try:
        c.sliding_line(joint)
    except ExprError as err:
        c.expr_error(err, f.span, ctx)
        return None
    fn = force_function(c, pos[1].value, pos[1].span or f.span, ctx, unit="N")
    return JointForce(f.name, joint, fn, f.span) if fn else None


def _point_force(c, f, pos, opts, ctx):
    """A point force (fx, fy) [N] in world or body axes, of time and of the
    state (``model.elements.PointForce``): components in body axes turned to
    world axes by the body's angle (on a flexible beam the cross-section's
    at the point), so that the Newton matrix has their exact derivatives.
    In a spatial model: ``check.spatial.spatial_load``."""
    if c.space == 3:
        return spatial_load(c, f, pos, opts, ctx)
    p = c.point(pos[0].value, pos[0].span or f.span, ctx)
    vec, span = pos[1].value, pos[1].span or f.span
    frame = opts["frame"]
    if not isinstance(frame, str):
        word = frame.value.name if isinstance(frame.value, Name) else None
        if word not in FORCE_FRAMES:
            c.error("E305", f"{ctx}: 'frame' is {' or '.join(FORCE_FRAMES)}",
                    getattr(frame.value, "span", None) or frame.span or f.span, "not a frame",
                    hint="frame = body: the components turn with the body (a follower force)")
            return None
        frame = word
    if not isinstance(vec, Vec):
        c.error("E305", f"{ctx}: expected the force as a vector '(fx, fy)'", span,
                "not a vector")
        return None
    if not (c.dimension(vec.x, "N", span, ctx) and c.dimension(vec.y, "N", span, ctx)):
        return None
    read = [state_expression(c, e, span, ctx) for e in (vec.x, vec.y)]
    if p is None or None in read:
        return None
    if p.body == GROUND:
        c.error("E402", f"{ctx} acts on the ground", f.span, "no effect",
                hint="apply the force to a moving body")
        return None
    found = {**read[0][1], **read[1][1]}
    ex, ey = read[0][0], read[1][0]
    if frame == "body":
        body = c.model_body(p.body)
        if getattr(body, "particle", False):
            c.error("E305", f"{ctx}: particle '{body.name}' does not turn: it has no body "
                    "axes", frame_span(f) or f.span, "a particle has no axes",
                    hint="give the components in world axes (frame = world)")
            return None
        theta = _section_angle(c, body, p, lambda v: found.setdefault(v.name, v).name)
        C, S = Call("cos", theta), Call("sin", theta)
        ex, ey = (Binary("-", Binary("*", ex, C), Binary("*", ey, S)),
                  Binary("+", Binary("*", ex, S), Binary("*", ey, C)))
    if not found:
        fx = c.time_function(vec.x, span, ctx, unit="N")
        fy = c.time_function(vec.y, span, ctx, unit="N")
    else:
        fx, fy = (state_function(c, e, tuple(found.values()), span, ctx) for e in (ex, ey))
    if fx is None or fy is None:
        return None
    return PointForce(f.name, p, fx, fy, f.span, frame)


def frame_span(f):
    """The span of a force's ``frame`` keyword, or None."""
    return next((a.span for a in f.args if a.keyword == "frame"), None)


def _section_angle(c, body, p, record):
    """The angle [rad] of a point's body axes as an expression in state
    variables (each registered by ``record``): the body's phi, on a flexible
    beam phi + v'(s), the cross-section's rotation (``BeamMesh.slope``)."""
    terms = [body_variable(c, body, "phi", record)]
    if isinstance(body, FlexibleBeam):
        slope = body.mesh.slope(float(p.local[0]))[0]
        names = body.mesh.names
        terms += [_scaled(float(s), body_variable(c, body, names[j], record))
                  for j, s in enumerate(slope) if s != 0.0]
    return simplify(sum_of(terms))


def body_variable(c, body, field, record, span=None) -> Name:
    """A body's state variable ``field`` (``phi``, ``vx``, an elastic
    coordinate ``theta3`` or its rate) as a :class:`Name` in an expression,
    the variable registered by ``record`` (variable -> its name)."""
    return Name(record(state_variable(c, Dotted(body.name, field, span))), span)


def friction_element(c, f, pos, opts, ctx):
    """A Friction element from checked options; None after reporting."""
    joint = c.joint_argument(pos[0], f, ctx)
    if joint is None:
        return None
    span = getattr(pos[0].value, "span", None) or f.span
    kw = {a.keyword: a for a in f.args if a.keyword is not None}
    if joint.kind not in JOINT_MOTION:
        kinds = list(JOINT_MOTION)
        kinds = ", ".join(kinds[:-1]) + " or " + kinds[-1]
        c.error("E305", f"{ctx}: friction acts in a {kinds} "
                f"joint; '{joint.name}' is a {joint.kind} joint", span,
                f"no sliding surface in a {joint.kind} joint",
                hint=f"friction(J, ...) takes a {kinds} joint")
        return None
    radius = opts["radius"]
    if joint.kind == "revolute" and not c.turning(
            joint.bodies, ctx, f.span, "friction in a revolute joint brakes a relative rotation"):
        return None
    if joint.kind == "revolute":
        if np.isnan(radius):
            c.error("E304", f"{ctx}: friction in a revolute joint needs the pin's "
                    "'radius' (m)", f.kind_span or f.span, "'radius = ...' is required",
                    hint="the friction torque is mu r |reaction|")
            return None
    else:
        if not np.isnan(radius):
            c.error("E304", f"{ctx}: 'radius' is for revolute joints; '{joint.name}' is "
                    f"a {joint.kind} joint", kw["radius"].span or f.span,
                    "not a revolute joint",
                    hint="a sliding joint's friction force is mu |normal reaction|")
            return None
        radius = 1.0
        try:
            c.sliding_line(joint)
        except ExprError as err:
            c.expr_error(err, f.span, ctx)
            return None
    mu = opts["mu"]
    mu_s = mu if np.isnan(opts["mu_static"]) else opts["mu_static"]
    if mu_s != mu and opts["v_stribeck"] == 0.0:
        c.error("E304", f"{ctx}: 'mu_static' differs from 'mu' but no 'v_stribeck' "
                "says at which speed", kw["mu_static"].span or f.span,
                "needs v_stribeck",
                hint="mu(z) = mu + (mu_static - mu) exp(-(z/v_stribeck)^2): "
                "give v_stribeck = ... (m/s or rad/s)")
        return None
    return Friction(f.name, joint, mu, mu_s, opts["v_stribeck"], opts["viscous"],
                    opts["v_reg"], radius, f.span)


def force_function(c, expr, span, context, unit=None):
    """A force magnitude: f(t) (TimeFunction) when the expression reads no
    state, else f(t, state) (StateFunction) with its exact partial
    derivatives; None after reporting. ``unit``: as in :meth:`number`."""
    if not c.dimension(expr, unit, span, context):
        return None
    read = state_expression(c, expr, span, context)
    if read is None:
        return None
    e, found = read
    if not found:
        return c.time_function(expr, span, context, unit)
    return state_function(c, e, tuple(found.values()), span, context)


def state_expression(c, expr, span, context):
    """(the expression with the parameters' values substituted and each
    reference to the motion named, the state variables it reads by name), or
    None after reporting (silently for a reference to a broken element,
    reported already)."""
    found: dict[str, StateVariable] = {}

    def record(var):
        """The variable's name; records it."""
        found.setdefault(var.name, var)
        return var.name

    def resolve(ref):
        """A variable's name, or a point's field as an expression in them; for a
        plain name, a first-order state's (None: not a state)."""
        if isinstance(ref, Name):
            var = first_order_variable(c, ref)
            return None if var is None else record(var)
        if isinstance(ref.obj, Dotted):
            return point_state(c, ref, record)
        return record(state_variable(c, ref))
    try:
        return substitute(expr, c.params, resolve, c.tables), found
    except BrokenReference:
        return None
    except ExprError as err:
        c.expr_error(err, span, context)
        return None


def first_order_variable(c, ref: Name) -> StateVariable | None:
    """The state variable of a first-order state read by its name (its value
    z, the velocity of its integral: ``model.elements.FirstOrderState``), or
    None for a name that is no state.

    Raises
    ------
    BrokenReference
        A state whose own error is reported.
    """
    k = c.states.get(ref.name)
    if k is None:
        return None
    if ref.name in c.broken_names:
        raise BrokenReference(ref.name, "E201", ref.span)
    return StateVariable(ref.name, 1, ((len(c.bodies) + k, 0, 1.0),))


def state_variable(c, ref: Dotted) -> StateVariable:
    """The state variable of a reference in a force expression
    (``crank.omega``, ``O.angle``).

    Raises
    ------
    ExprError
        E201 for an unknown body or joint, E304 for a field it does not have.
    """
    obj = ref.obj if isinstance(ref.obj, str) else getattr(ref.obj, "text", "?")
    if obj in c.bodies:
        body = c.bodies[obj]
        if isinstance(body, FlexibleBeam) and ref.attr not in BODY_STATE:
            return elastic_variable(body, ref)
        if ref.attr not in BODY_STATE:
            raise ExprError(f"'{ref.text}': a body's state in a force is one of "
                            f"{', '.join(BODY_STATE)}", "E304", ref.span,
                            hint=did_you_mean(ref.attr, BODY_STATE)
                            or f"fields are {', '.join(BODY_STATE)}")
        level, j = BODY_STATE[ref.attr]
        if j == 2 and getattr(body, "particle", False):
            raise ExprError(f"'{ref.text}': particle '{obj}' does not turn (it has x, y, "
                            "vx, vy)", "E304", ref.span)
        return StateVariable(ref.text, level, ((body.index, j, 1.0),))
    if obj in c.joints and c.joints[obj].kind in ("prismatic", "point_on_line"):
        joint = c.joints[obj]
        if ref.attr not in SLIDING_STATE:
            raise ExprError(f"'{ref.text}': a force reads a {joint.kind} joint's "
                            f"{', '.join(SLIDING_STATE)}", "E304", ref.span,
                            hint=did_you_mean(ref.attr, SLIDING_STATE)
                            or f"fields are {', '.join(SLIDING_STATE)}")
        line = c.sliding_line(joint, ref)
        return StateVariable(ref.text, SLIDING_STATE[ref.attr], (), line=line)
    if obj in c.joints:
        joint = c.joints[obj]
        if joint.kind != "revolute" or ref.attr not in REVOLUTE_STATE:
            allowed = ", ".join(REVOLUTE_STATE)
            raise ExprError(f"'{ref.text}': a force reads a revolute joint's {allowed}",
                            "E304", ref.span,
                            hint=(f"'{obj}' is a {joint.kind} joint"
                                  if joint.kind != "revolute" else
                                  did_you_mean(ref.attr, REVOLUTE_STATE)
                                  or f"fields are {allowed}"))
        b1, b2 = joint.bodies
        for b in (b1, b2):
            if c.is_particle(b):
                raise ExprError(f"'{ref.text}': the joint holds particle "
                                f"'{c.model_body(b).name}', which does not turn", "E304",
                                ref.span)
            if b != GROUND and isinstance(c.model_body(b), FlexibleBeam):
                raise ExprError(f"'{ref.text}': the joint holds a flexible beam, whose "
                                "rotation at the joint is not its frame's", "E304",
                                ref.span)
        terms = tuple((b, 2, c) for b, c in ((b2, 1.0), (b1, -1.0)) if b != GROUND)
        return StateVariable(ref.text, REVOLUTE_STATE[ref.attr], terms)
    if obj in c.broken_bodies or obj in c.broken_names:
        raise BrokenReference(ref.text, "E201", ref.span)
    raise ExprError(f"unknown body or joint '{obj}' in '{ref.text}'", "E201", ref.span,
                    name=obj, hint=(f"a first-order state is read by its name: write "
                                    f"'{ref.attr}'" if obj == "state" and ref.attr in c.states
                                    else did_you_mean(obj, list(c.bodies) + list(c.joints))
                                    or "a force reads the state of a body or a revolute joint"))


def elastic_variable(beam, ref: Dotted) -> StateVariable:
    """The state variable of a flexible beam's elastic coordinate (``rod.theta4``,
    ``rod.eta1``) or of its rate (``rod.theta4_t``).

    Raises
    ------
    ExprError
        E304 for a field the beam does not have.
    """
    names = beam.mesh.names
    base, level = (ref.attr[:-2], 1) if ref.attr.endswith("_t") else (ref.attr, 0)
    if base not in names:
        fields = list(BODY_STATE) + [names[0], names[0] + "_t"]
        raise ExprError(f"'{ref.text}': a flexible beam's state in a force is its frame's "
                        f"{', '.join(BODY_STATE)} or an elastic coordinate "
                        f"({', '.join(names[:3])}, ...) or its rate (name_t)", "E304",
                        ref.span, hint=did_you_mean(ref.attr, list(BODY_STATE) + names)
                        or f"e.g. {', '.join(fields)}")
    return StateVariable(ref.text, level, ((beam.index, 3 + names.index(base), 1.0),))


#: a point's fields a force expression reads: its position and velocity in world axes
POINT_STATE = ("x", "y", "vx", "vy")


def _scaled(coef: float, e):
    """coef * e as an expression (None for coef 0, e for coef 1)."""
    if coef == 0.0:
        return None
    return e if coef == 1.0 else Binary("*", Num(float(coef)), e)


def point_state(c, ref: Dotted, record):
    """A point's world position or velocity component (``arm.T.vx``) as an
    expression in its body's state variables: p = r + A(phi) u, dp/dt =
    r' + omega A' u + A S e', u = u0 + S(s) e on a flexible beam (Shabana,
    Dynamics of Multibody Systems, 5.2); ``record`` registers a variable
    and returns its name.

    Raises
    ------
    ExprError
        E201 for an unknown body or point, E304 for a field a point does not
        have.
    """
    pt = ref.obj
    if ref.attr not in POINT_STATE:
        raise ExprError(f"'{ref.text}': a force reads a point's "
                        f"{', '.join(POINT_STATE)}", "E304", ref.span,
                        hint=did_you_mean(ref.attr, POINT_STATE)
                        or f"fields are {', '.join(POINT_STATE)}")
    if not isinstance(pt.obj, str):
        raise ExprError(f"'{ref.text}' is not a point's field", "E304", ref.span,
                        hint="write body.point.x")
    if pt.obj == "ground":
        if pt.attr not in c.ground_points:
            raise ExprError(f"the ground has no point '{pt.attr}' in '{ref.text}'", "E201",
                            ref.span, name=pt.attr,
                            hint=did_you_mean(pt.attr, c.ground_points))
        p = c.ground_points[pt.attr]
        return Num(float({"x": p[0], "y": p[1]}.get(ref.attr, 0.0)), ref.span)
    if pt.obj not in c.bodies:
        if pt.obj in c.broken_bodies or pt.obj in c.broken_names:
            raise BrokenReference(ref.text, "E201", ref.span)
        raise ExprError(f"unknown body '{pt.obj}' in '{ref.text}'", "E201", ref.span,
                        name=pt.obj, hint=did_you_mean(pt.obj, list(c.bodies) + ["ground"]))
    body = c.bodies[pt.obj]
    if pt.attr not in body.points:
        if (body.name, pt.attr) in c.broken_points:
            raise BrokenReference(ref.text, "E201", ref.span)
        raise ExprError(f"body '{body.name}' has no point '{pt.attr}' in '{ref.text}'",
                        "E201", ref.span, name=pt.attr,
                        hint=did_you_mean(pt.attr, body.points)
                        or f"its points are {', '.join(sorted(body.points))}")

    def var(field):
        """The body's state variable ``field`` as a name."""
        return body_variable(c, body, field, record, ref.span)
    level = 1 if ref.attr.startswith("v") else 0
    axis = ref.attr[-1]
    own = var(("v" if level else "") + axis)
    if getattr(body, "particle", False):
        return own
    p = point_ref(body, pt.attr, pt.text)
    ux, uy = (float(v) for v in p.local)
    ex, ey, dex, dey = [Num(ux)], [Num(uy)], [], []
    names = body.mesh.names if isinstance(body, FlexibleBeam) else ()
    for j, col in enumerate(p.elastic_columns):
        e = names[int(col) - body.elastic_offset]
        sx, sy = (float(v) for v in p.elastic_shape[:, j])
        for terms, rates, s in ((ex, dex, sx), (ey, dey, sy)):
            terms.append(_scaled(s, var(e)))
            rates.append(_scaled(s, var(e + "_t")))
    ex, ey = sum_of([t for t in ex if t is not None]), sum_of([t for t in ey if t is not None])
    dex, dey = sum_of([t for t in dex if t is not None]), sum_of([t for t in dey if t is not None])
    phi = var("phi")
    C, S = Call("cos", phi), Call("sin", phi)

    def rot(a, b, first):
        """(A (a, b))_x (first) or _y."""
        return (Binary("-", Binary("*", C, a), Binary("*", S, b)) if first
                else Binary("+", Binary("*", S, a), Binary("*", C, b)))
    if level == 0:
        return simplify(Binary("+", own, rot(ex, ey, axis == "x")))
    # omega A' u = omega (-(A u)_y, (A u)_x)
    turn = Binary("*", var("omega"), rot(ex, ey, axis == "y"))
    turn = Unary("-", turn) if axis == "x" else turn
    return simplify(sum_of([own, turn, rot(dex, dey, axis == "x")]))


def check_gravity(c):
    """Evaluate the gravity vector, or None when not declared."""
    if c.spec.gravity is None:
        return None
    return c.vector(c.spec.gravity, c.spec.gravity_span, "gravity", unit="m/s^2")


#: force kind -> the function that builds its element (c, f, pos, opts, ctx) -> element or None
BUILDERS = {"spring_damper": _spring_damper, "rotational_spring_damper": _rotational_spring_damper,
            "torque": _torque, "joint_torque": _joint_torque, "joint_force": _joint_force,
            "friction": friction_element, "contact": contact_element, "limit": contact_element,
            "rope": rope_element, "cable": rope_element,
            "force": _point_force}
