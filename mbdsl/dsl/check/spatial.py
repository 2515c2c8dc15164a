"""The checks of a spatial model (``space 3d``): its bodies, joints and
initial lines, and what a spatial model does not have yet. Diagnostics:
E205 (an element kind planar only, or a joint kind unknown in 3D), E302/E303
(mass and inertia), E304 (an unknown property), E305 (arguments, vectors),
E402 (a body joined to itself), E502 (initial lines), E201 (an unknown
body or axis), E202 (a duplicate point or axis), E306 (a zero axis).

A spatial body is held in director coordinates (``model.spatial``); its
``initial`` lines give x, y, z, vx, vy, vz, an ``orientation`` (z-y'-x''
angles, ``zyx(yaw, pitch, roll)``) and an angular velocity ``omega`` (world
axes) or ``omega_body`` (body axes), which the check turns into the
directors and their rates.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...model.elements import GROUND, InitialCondition, Joint, Shape
from ...model.spatial import DIRECTORS, SpatialBody, SpatialLoad, axis_angle, zyx
from ..expressions import Call, Dotted, Vec
from .context import did_you_mean, plain_target
from .spatial_state import reads_motion, spatial_state_load

#: spatial joint kind -> (points, then axes, as positional arguments; allowed keywords;
#: rows). Axes are ``body.axis`` references: a body's x, y, z or its ``axis`` lines.
SPATIAL_JOINT_KINDS = {
    "spherical": (2, 0, {}, 3),          # the points coincide
    "revolute": (2, 2, {}, 5),           # ... and the two axes are parallel
    "universal": (2, 2, {}, 4),          # ... and the two axes are perpendicular (Cardan)
    "cylindrical": (2, 2, {}, 4),        # the axes parallel, the first point on the second's line
    "point_on_line": (2, 1, {}, 2),      # the first point on the line through the second
    "point_on_plane": (2, 1, {}, 1),     # ... on the plane through the second, normal to the axis
    "distance": (2, 0, {"length": None}, 1),
    "fixed": (2, 0, {}, 6),              # the points together, the bodies' axes parallel
    "prismatic": (2, 1, {}, 5),          # the axes parallel, the first point on the second's line
}

#: the declarations a spatial model does not have yet: items key -> what they are
PLANAR_ONLY = {"states": "first-order states"}
#: the force kinds of a spatial model (the planar check reads their options)
SPATIAL_FORCE_KINDS = ("spring_damper", "rotational_spring_damper", "force", "torque",
                       "joint_torque", "joint_force", "contact", "limit")
#: the spatial joints with an angle (drivers, rotational spring-dampers) and with a
#: distance along a line (drivers)
ANGLE_JOINTS = ("revolute", "cylindrical")
DISTANCE_JOINTS = ("prismatic", "cylindrical", "point_on_line")
#: initial fields of a spatial body and their SI units (besides the directors)
SPATIAL_INITIALS = {"x": "m", "y": "m", "z": "m", "vx": "m/s", "vy": "m/s", "vz": "m/s"}
ROTATIONS = ("orientation", "omega", "omega_body")
#: spatial shape kind -> (points, what follows them, usage): what ``mbdsl animate`` draws
SPATIAL_SHAPES = {
    "line": (2, None, "two points: line(A, B)"),
    "sphere": (1, "radius", "a centre point and a radius: sphere(cm, 0.05)"),
    "cylinder": (2, "radius", "the two ends' centres and a radius: cylinder(A, B, 0.01)"),
    "box": (1, "sides", "a centre point and the sides along the body axes: "
            "box(cm, (0.1, 0.02, 0.02))"),
}


def check_space(c):
    """In a spatial model, report the declarations it does not have yet
    (E205) and drop them, so that the planar passes never see them."""
    if c.space != 3:
        return
    for key, what in PLANAR_ONLY.items():
        found = c.items.get(key) or getattr(c.spec, key, ())
        for it in found:
            c.error("E205", f"a spatial model ('space 3d') has no {what} yet",
                    getattr(it, "span", None), "planar only",
                    hint="spatial models have bodies, joints, drivers, forces, gravity "
                    "and initial lines; remove 'space 3d' for a planar model")
        if key in c.items:
            c.items[key] = []
    kept = []
    for f in c.items.get("forces", ()):
        if f.kind in SPATIAL_FORCE_KINDS:
            kept.append(f)
        else:
            c.error("E205", f"a spatial model ('space 3d') has no force '{f.kind}' yet",
                    getattr(f, "kind_span", None) or f.span, "planar only",
                    hint="spatial forces: " + ", ".join(SPATIAL_FORCE_KINDS))
    if "forces" in c.items:
        c.items["forces"] = kept
    c.spec = dataclasses.replace(c.spec, states=())


def check_spatial_body(c, b):
    """A spatial rigid body: a positive mass, principal moments of inertia
    ``inertia (J1, J2, J3)`` [kg m^2] about body axes through the centre of
    mass, which a rigid body's satisfy (J_k <= J_l + J_m), and points (x, y,
    z) in body axes."""
    ctx = f"body '{b.name}'"
    if not hasattr(b, "points"):
        c.error("E205", f"{ctx}: a spatial model has rigid bodies and particles only (no "
                "flexible beams yet)", b.span, "planar only",
                hint="declare 'body NAME { mass m; inertia (J1, J2, J3) }'")
        c.broken_bodies.add(b.name)
        return
    props = {}
    for prop in b.properties:
        if prop.name not in ("mass", "inertia") or prop.name in props:
            c.error("E304", f"{ctx}: unknown or repeated property '{prop.name}'", prop.span,
                    "unknown property", hint=did_you_mean(prop.name, ["mass", "inertia"])
                    or "a spatial body has 'mass', 'inertia (J1, J2, J3)' and 'point' lines")
            continue
        props[prop.name] = prop
    mass = inertia = None
    if "mass" in props:
        mass = c.number(props["mass"].value, props["mass"].span, f"mass of {ctx}", unit="kg")
        if mass is not None and not mass > 0:
            c.error("E303", f"the mass of {ctx} must be positive, got {mass:g} kg",
                    props["mass"].span, "not positive")
            mass = None
    else:
        c.error("E302", f"{ctx} has no mass", b.span, "mass missing",
                hint="add 'mass VALUE' [kg]; there is no default")
    if "inertia" not in props:
        c.error("E302", f"{ctx} has no inertia", b.span, "inertia missing",
                hint="add 'inertia (J1, J2, J3)' [kg m^2], the principal moments about "
                "the body axes through the centre of mass")
    elif not isinstance(props["inertia"].value, Vec):
        c.error("E305", f"{ctx}: a spatial body's inertia is '(J1, J2, J3)'",
                props["inertia"].span, "not three moments",
                hint="the principal moments of inertia [kg m^2] about the body axes")
    else:
        inertia = c.vector(props["inertia"].value, props["inertia"].span,
                           f"inertia of {ctx}", unit="kg*m^2")
        if inertia is not None and (not np.all(inertia > 0)
                                    or np.any(2 * inertia > inertia.sum() * (1 + 1e-12))):
            c.error("E303", f"{ctx}: the principal moments {tuple(inertia.tolist())} kg m^2 "
                    "are not a rigid body's", props["inertia"].span, "not a rigid body",
                    hint="each must be positive and at most the sum of the other two")
            inertia = None
    points = {"cm": np.zeros(3)}
    axes = {k: v for k, v in zip("xyz", np.eye(3))}
    for p in b.points:
        if p.axis:
            check_axis(c, b.name, p, axes)
            continue
        if p.name in points:
            c.error("E202", f"{ctx}: duplicate point '{p.name}'", p.span, "declared again")
            continue
        v = c.vector(p.position, p.span, f"point '{b.name}.{p.name}'")
        if v is None:
            c.broken_points.add((b.name, p.name))
        else:
            points[p.name] = v
    shapes = tuple(s for s in (spatial_shape(c, b.name, sp, points)
                               for sp in getattr(b, "shapes", ())) if s is not None)
    if mass is None or inertia is None:
        c.broken_bodies.add(b.name)
        return
    c.bodies[b.name] = SpatialBody(b.name, len(c.bodies), mass, inertia, points, b.span,
                                   shapes=shapes, axes=axes)


def spatial_shape(c, body, sp, points):
    """A spatial body's drawn Shape from its ShapeSpec (``SPATIAL_SHAPES``),
    in its frame; None after reporting (E205 an unknown kind, E305 wrong
    arguments, E201 an unknown point, E303 a size not positive). A box's
    points are its eight corners."""
    ctx = f"shape {sp.kind} of body '{body}'"
    if sp.kind not in SPATIAL_SHAPES:
        c.error("E205", f"body '{body}': unknown shape '{sp.kind}' of a spatial body",
                sp.kind_span or sp.span, "unknown shape",
                hint=did_you_mean(sp.kind, SPATIAL_SHAPES)
                or f"spatial shapes are {', '.join(SPATIAL_SHAPES)}")
        return None
    npoints, last, usage = SPATIAL_SHAPES[sp.kind]
    args = list(sp.args)
    if len(args) != npoints + (last is not None) or any(a.keyword for a in args):
        c.error("E305", f"{ctx}: expected {usage}", sp.kind_span or sp.span,
                "wrong arguments")
        return None
    xyz = []
    for a in args[:npoints]:
        v = a.value
        if isinstance(v, Vec):
            p = c.vector(v, a.span or sp.span, ctx)
        elif getattr(v, "name", None) in points:
            p = np.asarray(points[v.name], float)
        else:
            c.error("E201", f"{ctx}: body '{body}' has no point '{getattr(v, 'name', v)}'",
                    a.span or sp.span, "unknown point",
                    hint=did_you_mean(getattr(v, "name", ""), points)
                    or "name a point of the body, or give (x, y, z) in its frame")
            return None
        if p is None:
            return None
        xyz.append(p)
    radius = 0.0
    if last == "radius":
        radius = c.number(args[-1].value, args[-1].span or sp.span, ctx, unit="m")
        if radius is None or not radius > 0:
            if radius is not None:
                c.error("E303", f"{ctx}: the radius must be positive, got {radius:g} m",
                        args[-1].span or sp.span, "not positive")
            return None
    elif last == "sides":
        sides = c.vector(args[-1].value, args[-1].span or sp.span, ctx)
        if sides is None or not np.all(sides > 0):
            if sides is not None:
                c.error("E303", f"{ctx}: the sides must be positive, got "
                        f"{tuple(sides.tolist())} m", args[-1].span or sp.span, "not positive")
            return None
        signs = np.array([(i, j, k) for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)])
        xyz = list(xyz[0] + 0.5 * signs * sides)
    return Shape(sp.kind, np.array(xyz), radius)


def check_spatial_joints(c):
    """The joints of a spatial model (``SPATIAL_JOINT_KINDS``)."""
    for j in c.items["joints"]:
        ok = c.claim(j.name, j.span, "joint")
        ctx = f"joint '{j.name}'"
        if not c.known_kind(j, SPATIAL_JOINT_KINDS, "spatial joint", ctx):
            continue
        npoints, naxes, allowed, rows = SPATIAL_JOINT_KINDS[j.kind]
        pos, kw = c.split_args(j, allowed, npoints + naxes, ctx)
        if pos is None:
            continue
        first = c.point(pos[0].value, pos[0].span or j.span, ctx)
        second = c.point(pos[1].value, pos[1].span or j.span, ctx)
        axes = [_axis_ref(c, a.value, a.span or j.span, ctx) for a in pos[npoints:]]
        length = 0.0
        if "length" in kw:
            length = c.number(kw["length"].value, kw["length"].span, ctx, unit="m")
            if length is not None and not length > 0:
                c.error("E303", f"{ctx}: the length must be positive, got {length:g} m",
                        kw["length"].span, "not positive")
                length = None
        if first is None or second is None or not ok or length is None or None in axes:
            continue
        if first.body == second.body:
            what = "the ground" if first.body == GROUND else f"body '{pos[0].value.obj}'"
            c.error("E402", f"{ctx} connects {what} to itself", j.span,
                    "both points on one body", hint="a joint connects two different bodies")
            continue
        held = [b for b in (first.body, second.body) if c.is_particle(b)]
        if held and j.kind in ("fixed", "prismatic"):
            c.error("E305", f"{ctx}: particle '{c.model_body(held[0]).name}' does not turn, "
                    f"and a {j.kind} joint holds its axes parallel to the other body's", j.span,
                    "a particle's axes", hint="a particle on a line: point_on_line(P.cm, B.q, "
                    "B.b); at a point: spherical")
            continue
        if naxes == 2 and (axes[0][0], axes[1][0]) != (first.body, second.body):
            c.error("E305", f"{ctx}: its axes are the first body's, then the second's",
                    pos[npoints].span or j.span, "axes of other bodies",
                    hint=f"write {j.kind}(A.p, B.q, A.a, B.b): points, then axes, of A then B")
            continue
        if naxes == 1 and axes[0][0] != second.body:
            c.error("E305", f"{ctx}: its axis is the second body's (the line's or "
                    "the plane's)", pos[npoints].span or j.span, "an axis of another body",
                    hint=f"write {j.kind}(A.p, B.q, B.a)")
            continue
        c.joints[j.name] = Joint(j.name, j.kind, first, second, None, 0.0, rows, j.span,
                                 length, axes=tuple(axes), space=3)


def check_axis(c, owner, p, axes):
    """An ``axis NAME (x, y, z)`` line of body ``owner`` (or of the ground):
    its unit direction into ``axes``; E205 in a planar model, E306 for a
    zero direction, E202 for a repeated name."""
    if c.space != 3:
        c.error("E205", f"'{owner}': an axis line is for spatial models ('space 3d')", p.span,
                "planar model", hint="a planar joint takes its direction as 'direction = (x, y)'")
        return
    if p.name in axes and p.name not in "xyz":
        c.error("E202", f"'{owner}': duplicate axis '{p.name}'", p.span, "declared again")
        return
    v = c.vector(p.position, p.span, f"axis '{owner}.{p.name}'", unit=None)
    if v is None:
        return
    norm = float(np.linalg.norm(v))
    if not norm > 0.0 or not np.isfinite(norm):
        c.error("E306", f"axis '{owner}.{p.name}' must be a non-zero vector", p.span,
                "zero direction")
        return
    axes[p.name] = v / norm


def _axis_ref(c, expr, span, ctx):
    """(body index, unit direction (3,) in its frame) of an axis reference
    ``body.axis`` (the ground's in the world frame); None after reporting."""
    from ..expressions import Dotted
    if not isinstance(expr, Dotted) or not isinstance(expr.obj, str):
        c.error("E305", f"{ctx}: expected an axis like 'body.z'", getattr(expr, "span", None)
                or span, "not an axis", hint="a body's x, y, z, or one of its 'axis' lines")
        return None
    if expr.obj == "ground":
        body, axes = GROUND, c.ground_axes
    else:
        b = c.bodies.get(expr.obj)
        if b is None:
            if expr.obj not in c.broken_bodies:
                c.error("E201", f"{ctx}: unknown body '{expr.obj}'", expr.span or span,
                        "no body with this name", hint=did_you_mean(expr.obj, c.bodies))
            return None
        body, axes = b.index, b.axes
        if getattr(b, "particle", False):
            c.error("E305", f"{ctx}: particle '{expr.obj}' does not turn: it has no axes",
                    expr.span or span, "a particle's axis",
                    hint="join a particle at its cm by a spherical, distance, point_on_line "
                    "or point_on_plane joint (the line or plane on the other body)")
            return None
    if expr.attr not in axes:
        c.error("E201", f"{ctx}: '{expr.obj}' has no axis '{expr.attr}'", expr.span or span,
                "unknown axis", hint=did_you_mean(expr.attr, axes)
                or f"its axes are {', '.join(sorted(axes))}")
        return None
    return body, axes[expr.attr]


def check_spatial_initials(c):
    """``initial`` and ``guess`` lines of spatial bodies: x, y, z and their
    rates, ``orientation = zyx(yaw, pitch, roll)`` (the nine directors), and
    ``omega = (wx, wy, wz)`` in world axes or ``omega_body`` in body axes
    (the directors' rates A' = [omega]x A = A [omega_body]x; they need the
    body's orientation in the same kind of line)."""
    c.initials = []
    seen, rotations = {}, {}
    for ic in c.items["initials"]:
        tgt = plain_target(ic.target)
        kw = "guess" if ic.guess else "initial"
        body = c.bodies.get(tgt.obj)
        if body is None:
            if tgt.obj not in c.broken_bodies:
                c.error("E201", f"{kw}: unknown body '{tgt.obj}'", tgt.span or ic.span,
                        "no body with this name", hint=did_you_mean(tgt.obj, c.bodies))
            continue
        particle = getattr(body, "particle", False)
        fields = tuple(SPATIAL_INITIALS) + (() if particle else ROTATIONS)
        if tgt.attr not in fields:
            c.error("E502", f"{kw}: '{tgt.attr}' is not a field of spatial "
                    f"{'particle' if particle else 'body'} '{tgt.obj}'", tgt.span or ic.span,
                    "unknown field", hint=did_you_mean(tgt.attr, fields)
                    or f"use {', '.join(fields)}" + (" (a particle does not turn)"
                                                      if particle else ""))
            continue
        key = (tgt.obj, "omega" if tgt.attr == "omega_body" else tgt.attr)
        if key in seen:
            c.error("E502", f"{kw}: '{tgt.text}' is given twice (or with its other axes)",
                    ic.span, "given again")
            continue
        seen[key] = ic.span
        if tgt.attr in SPATIAL_INITIALS:
            v = c.number(ic.value, ic.span, f"{kw} {tgt.text}", unit=SPATIAL_INITIALS[tgt.attr])
            if v is not None:
                c.initials.append(InitialCondition(body.index, tgt.attr, v, ic.guess, ic.span))
            continue
        value = _rotation_value(c, tgt, ic, kw)
        if value is not None:
            rotations[(body.index, tgt.attr)] = (value, ic)
    c.body_names = {b.index: name for name, b in c.bodies.items()}
    for (index, attr), (value, ic) in rotations.items():
        if attr == "orientation":
            A = value
        elif (index, "orientation") in rotations:
            A = rotations[(index, "orientation")][0]
            W = np.cross(np.eye(3), value)           # the skew matrix [w]x: rows e_k x w
            value = W @ A if attr == "omega" else A @ W
        else:
            c.error("E502", f"the {attr} of body '{c.body_names[index]}' needs its orientation",
                    ic.span, "no orientation",
                    hint="add 'initial BODY.orientation = zyx(yaw, pitch, roll)'")
            continue
        fields = DIRECTORS if attr == "orientation" else tuple(f"{d}_t" for d in DIRECTORS)
        for k, name in enumerate(fields):
            c.initials.append(InitialCondition(index, name, float(value[k % 3, k // 3]),
                                               ic.guess, ic.span, counted=k < 3))


def _rotation_value(c, tgt, ic, kw):
    """The rotation matrix of an orientation line, or the angular velocity
    (3,) [rad/s] of an omega line; None after reporting."""
    if tgt.attr == "orientation":
        v = ic.value
        ctx = f"{kw} {tgt.text}"
        if isinstance(v, Call) and v.func == "axis_angle" and isinstance(v.arg, Vec):
            axis = c.vector(v.arg.x, ic.span, ctx, unit=None)
            angle = c.angle(v.arg.y, ic.span, ctx)
            if axis is None or angle is None:
                return None
            if not np.linalg.norm(axis) > 0.0:
                c.error("E306", f"{ctx}: the rotation axis is zero",
                        getattr(v.arg.x, "span", None) or ic.span, "zero axis")
                return None
            return axis_angle(axis, angle)
        if not (isinstance(v, Call) and v.func == "zyx" and isinstance(v.arg, Vec)):
            c.error("E305", f"{ctx}: expected 'zyx(yaw, pitch, roll)' or "
                    "'axis_angle(x, y, z, angle)'",
                    getattr(v, "span", None) or ic.span, "not an orientation",
                    hint="z-y'-x'' angles: yaw about z, then pitch, then roll; or a turn "
                    "by an angle about an axis (world axes)")
            return None
        angles = [c.angle(e, ic.span, ctx) for e in (v.arg.x, v.arg.y, v.arg.z)]
        return None if any(a is None for a in angles) else zyx(*angles)
    return c.vector(ic.value, ic.span, f"{kw} {tgt.text}", unit="rad/s")



def spatial_load(c, f, pos, opts, ctx):
    """``force(B.p, (fx, fy, fz) [, frame = body])`` [N] or ``torque(B, (tx,
    ty, tz) [, frame = body])`` [N m] in a spatial model
    (``model.spatial.SpatialLoad``): components constant or of time, or,
    where one reads the motion, ``check.spatial_state.spatial_state_load``;
    None after reporting (E201 an unknown body, E305 not a vector or frame,
    E402 on the ground)."""
    torque = f.kind == "torque"
    if torque:
        ref = pos[0].value
        body = c.bodies.get(getattr(ref, "name", None)) if not isinstance(ref, Dotted) else None
        if body is None:
            name = getattr(ref, "name", "?")
            if name not in c.broken_bodies:
                c.error("E201", f"{ctx}: expected the name of a body, got '{name}'",
                        getattr(ref, "span", None) or f.span, "not a body",
                        hint=did_you_mean(name, c.bodies))
            return None
        index, local = body.index, np.zeros(3)
    else:
        p = c.point(pos[0].value, pos[0].span or f.span, ctx)
        if p is None:
            return None
        if p.body == GROUND:
            c.error("E402", f"{ctx} acts on the ground", f.span, "no effect",
                    hint="apply the force to a moving body")
            return None
        index, local = p.body, np.asarray(p.local, float)
    frame = opts.get("frame", "world")
    if not isinstance(frame, str):
        frame = getattr(frame.value, "name", None)
        if frame not in ("world", "body"):
            c.error("E305", f"{ctx}: 'frame' is world or body", f.span, "not a frame",
                    hint="frame = body: the components turn with the body (a follower load)")
            return None
    if c.is_particle(index) and (torque or frame == "body"):
        c.error("E305", f"{ctx}: particle '{c.model_body(index).name}' does not turn: it "
                f"takes no {'torque' if torque else 'force in body axes'}", f.span,
                "a particle's rotation", hint="a force on a particle is in world axes")
        return None
    vec, span = pos[1].value, pos[1].span or f.span
    unit = "N*m" if torque else "N"
    if not isinstance(vec, Vec) or vec.z is None:
        c.error("E305", f"{ctx}: expected the {'torque' if torque else 'force'} as a vector "
                f"'({'tx, ty, tz' if torque else 'fx, fy, fz'})' [{unit}]", span, "not a vector")
        return None
    if any(reads_motion(e) for e in (vec.x, vec.y, vec.z)):
        return spatial_state_load(c, f.name, torque, index, local, (vec.x, vec.y, vec.z),
                                  frame, span, ctx)
    parts = []
    for e in (vec.x, vec.y, vec.z):
        fn = c.time_function(e, span, ctx, unit=unit)
        if fn is None:
            return None
        parts.append(fn)
    kind = "spatial_torque" if torque else "spatial_force"
    return SpatialLoad(f.name, kind, index, local, tuple(parts), frame, f.span)
