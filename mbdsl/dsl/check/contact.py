"""One-sided elements (part of the loads' pass): contact, a circle on a body
point against a line or in a circular hole of another body or the ground;
limit, a revolute's angle or a sliding joint's distance between bounds; in a
spatial model a sphere on a body point against a plane and the same limits
on spatial joints; all with the Hunt-Crossley law of ``model.contact``; and
rope (or cable), a tension-only linear spring-damper between two points.
Diagnostics: E305 (neither or both of ``line`` and ``circle``, ``plane`` in
the other space, their arguments, a limit without bounds or on another
joint), E304 (a contact or rope on a flexible beam), E303 (radius,
stiffness, exponent, restitution, bounds, a rope's length out of range, a
zero normal), E402 (a body against itself), E205 (friction at a spatial
contact).
"""

from __future__ import annotations

import math

import numpy as np

from ...model.contact import (Contact, contact_geometry_circle, contact_geometry_line,
                              contact_geometry_plane, rope_geometry, spatial_limit_gaps)
from ...model.elements import GROUND, FlexibleBeam
from ..expressions import ExprError, Vec
from .tables import GEOMETRY_OPTIONS


def contact_element(c, f, pos, opts, ctx):
    """A ``contact`` (a circle against a line or in a hole) or a ``limit``
    (a joint's angle or distance between bounds): one-sided gaps of
    :mod:`mbdsl.model.contact`; None after reporting."""
    for name, hint in (("restitution", "a coefficient of restitution is in (0, 1]: 1 keeps "
                        "the energy, 0.8 is a hard ball, small values a dead impact"),
                       ("exponent", "1 for a linear law, 1.5 for Hertz's sphere")):
        v = opts[name]
        bad = not (0.0 < v <= 1.0) if name == "restitution" else not v >= 1.0
        if bad:
            span = next((a.span for a in f.args if a.keyword == name), f.span)
            c.error("E303", f"{ctx}: '{name}' = {v:g} is out of range", span,
                    "out of range", hint=hint)
            return None
    if not opts["k"] > 0:
        c.error("E303", f"{ctx}: the contact stiffness 'k' must be positive",
                next((a.span for a in f.args if a.keyword == "k"), f.span), "not positive")
        return None
    common = (opts["k"], opts["exponent"], opts["restitution"], f.span)
    if f.kind == "limit":
        gaps = (_spatial_limit_gaps if c.space == 3 else _limit_gaps)(c, f, pos, opts, ctx)
        return None if gaps is None else Contact(f.name, "limit", gaps, *common)
    if c.space == 3:
        geometry = _plane_geometry(c, f, pos, opts, ctx)
        return None if geometry is None else Contact(f.name, "contact", (geometry,), *common)
    geometry = _contact_geometry(c, f, pos, opts, ctx)
    if geometry is None:
        return None
    return Contact(f.name, "contact", (geometry,), *common, mu=opts["mu"], v_reg=opts["v_reg"])


def rope_element(c, f, pos, opts, ctx):
    """A ``rope`` (stiffness k [N/m]) or ``cable`` (EA [N]: k = EA / length)
    between two points: pulls with k (l - L) + c dl/dt where l > L, never
    pushes (``model.contact.rope_geometry``: the second point in a hole of
    radius L about the first, the law f = K delta + c ddelta/dt cut at 0);
    None after reporting."""
    ends = [c.point(p.value, p.span or f.span, ctx) for p in pos]
    if any(p is None for p in ends):
        return None
    for p in ends:
        if p.body != GROUND and isinstance(c.model_body(p.body), FlexibleBeam):
            c.error("E304", f"{ctx}: a {f.kind} acts between rigid bodies; '{p.text}' is on "
                    "a flexible beam", f.span, "flexible beam",
                    hint="attach a rigid body to the beam and tie the rope to it")
            return None
    if ends[0].body == ends[1].body:
        c.error("E402", f"{ctx} ties a body to itself", f.span, "no effect")
        return None
    length = opts["length"]
    if not length > 0:
        c.error("E303", f"{ctx}: the {f.kind}'s length must be positive, got {length:g} m",
                next((a.span for a in f.args if a.keyword == "length"), f.span),
                "not positive", hint="the length at which it goes taut")
        return None
    stiffness = opts["k"] if f.kind == "rope" else opts["EA"] / length
    if not stiffness > 0:
        key = "k" if f.kind == "rope" else "EA"
        c.error("E303", f"{ctx}: '{key}' must be positive", next(
            (a.span for a in f.args if a.keyword == key), f.span), "not positive")
        return None
    return Contact(f.name, f.kind, (rope_geometry(ends[0], ends[1], length),), stiffness,
                   1.0, 1.0, f.span, viscous=opts["c"])


def _limit_gaps(c, f, pos, opts, ctx):
    """A limit's gaps: ("angle", (body1, None, body2, None, bound, sign), label)
    for a revolute, ("slide", line + (bound, sign), label) for a sliding joint,
    one per bound given; None after reporting."""
    target = _limit_target(c, f, pos, opts, ctx)
    if target is None:
        return None
    joint, (lower, upper) = target
    if joint.kind == "revolute":
        if not c.turning(joint.bodies, ctx, f.span, "a limit on an angle turns bodies"):
            return None
        pair = (joint.first.body, None, joint.second.body, None)
        gaps = tuple(("angle", pair + (b, sign), label)
                     for b, sign, label in ((lower, 1.0, "lower"), (upper, -1.0, "upper"))
                     if not math.isnan(b))
    elif joint.kind in ("prismatic", "point_on_line"):
        try:
            line = c.sliding_line(joint)
        except ExprError as err:
            c.expr_error(err, f.span, ctx)
            return None
        gaps = tuple(("slide", line + (b, sign), label)
                     for b, sign, label in ((lower, 1.0, "lower"), (upper, -1.0, "upper"))
                     if not math.isnan(b))
    else:
        c.error("E305", f"{ctx}: a limit acts on a revolute's angle or a prismatic or "
                f"point_on_line joint's distance; '{joint.name}' is a {joint.kind} joint",
                getattr(pos[0].value, "span", None) or f.span, "no motion to limit")
        return None
    return gaps


def _limit_target(c, f, pos, opts, ctx):
    """(the joint a limit names, (lower, upper): NaN where not given); None
    after reporting (an unknown joint, E305 no bound, E303 lower >= upper)."""
    joint = c.joint_argument(pos[0], f, ctx)
    if joint is None:
        return None
    lower, upper = opts["lower"], opts["upper"]
    if math.isnan(lower) and math.isnan(upper):
        c.error("E305", f"{ctx}: a limit needs 'lower', 'upper' or both", f.span,
                "no bound", hint="e.g. limit(O, lower = -pi/4, upper = pi/4, k = 1e5)")
        return None
    if not (math.isnan(lower) or math.isnan(upper)) and not lower < upper:
        c.error("E303", f"{ctx}: 'lower' ({lower:g}) must be below 'upper' ({upper:g})",
                f.span, "empty range")
        return None
    return joint, (lower, upper)


def _spatial_limit_gaps(c, f, pos, opts, ctx):
    """A spatial limit's gaps (``model.contact.spatial_limit_gaps``): a
    revolute's angle within (-pi, pi), a prismatic's or point_on_line's
    distance; None after reporting (E305 another joint, E303 an angle bound
    beyond +-pi)."""
    target = _limit_target(c, f, pos, opts, ctx)
    if target is None:
        return None
    joint, bounds = target
    if joint.kind not in ("revolute", "prismatic", "point_on_line"):
        c.error("E305", f"{ctx}: a limit acts on a revolute's angle or a prismatic or "
                f"point_on_line joint's distance; '{joint.name}' is a {joint.kind} joint",
                getattr(pos[0].value, "span", None) or f.span, "no motion to limit")
        return None
    if joint.kind == "revolute" and any(abs(b) >= math.pi for b in bounds if not math.isnan(b)):
        c.error("E303", f"{ctx}: a spatial revolute's angle is read within (-pi, pi); its "
                "bounds must be too", f.span, "beyond a half turn")
        return None
    return spatial_limit_gaps(joint, *bounds)


def _plane_geometry(c, f, pos, opts, ctx):
    """The gap of a sphere on a spatial body's point against a plane,
    ``plane = (point, (nx, ny, nz))`` (the normal in that body's frame, on
    the side the sphere stays); None after reporting (E305 another geometry or
    not a plane, E205 friction, E402 a body against itself, E303 a zero normal)."""
    centre = c.point(pos[0].value, pos[0].span or f.span, ctx)
    if centre is None:
        return None
    arg = opts["plane"]
    if isinstance(arg, float) or any(not isinstance(opts[g], float) for g in ("line", "circle")):
        c.error("E305", f"{ctx}: a contact in a spatial model is a sphere against a plane: "
                "'plane = (point, (nx, ny, nz))'", f.span, "not a plane",
                hint="a floor: plane = (ground.origin, (0, 0, 1))")
        return None
    if opts["mu"] != 0.0:
        c.error("E205", f"{ctx}: friction at a spatial contact is not supported yet",
                next((a.span for a in f.args if a.keyword == "mu"), f.span), "friction",
                hint="leave out 'mu': the contact is frictionless")
        return None
    val = arg.value
    if not (isinstance(val, Vec) and isinstance(val.y, Vec) and val.y.z is not None):
        c.error("E305", f"{ctx}: expected plane = (point, (nx, ny, nz))", arg.span or f.span,
                "not a plane")
        return None
    other = c.point(val.x, arg.span or f.span, ctx)
    normal = c.vector(val.y, arg.span or f.span, ctx, unit=None)
    if other is None or normal is None:
        return None
    if centre.body == other.body:
        c.error("E402", f"{ctx} puts a body in contact with itself", f.span, "no effect")
        return None
    if c.is_particle(other.body):
        c.error("E305", f"{ctx}: the plane is fixed in a body or the ground; "
                f"'{c.model_body(other.body).name}' is a particle, which has no axes",
                arg.span or f.span, "a plane on a particle",
                hint="put the sphere on the particle: contact(P.cm, radius = ..., plane = ...)")
        return None
    if not float(np.linalg.norm(normal)) > 0.0:
        c.error("E303", f"{ctx}: the plane's normal is zero", arg.span or f.span,
                "zero direction")
        return None
    return contact_geometry_plane(centre, opts["radius"], other, normal)


def _contact_geometry(c, f, pos, opts, ctx):
    """The gap of a circle on a body point against a line (``line = (point,
    (dx, dy))``) or in a hole (``circle = (point, radius)``) of another body or
    the ground (``model.contact``); None after reporting."""
    centre = c.point(pos[0].value, pos[0].span or f.span, ctx)
    if centre is None:
        return None
    if not isinstance(opts["plane"], float):
        c.error("E305", f"{ctx}: 'plane' is a spatial contact's ('space 3d'); a planar "
                "contact takes 'line' or 'circle'", opts["plane"].span or f.span, "planar model")
        return None
    given = [g for g in GEOMETRY_OPTIONS if not isinstance(opts[g], float)]
    if len(given) != 1:
        c.error("E305", f"{ctx}: a contact needs one of 'line = (point, (dx, dy))' or "
                "'circle = (point, radius)'", f.span,
                "no geometry" if not given else "two geometries",
                hint="a circle against a line: line = (ground.origin, (1, 0)); "
                "in a hole: circle = (slot.c, 0.0105)")
        return None
    arg = opts[given[0]]
    val = arg.value
    shape_ok = isinstance(val, Vec) and (isinstance(val.y, Vec) == (given[0] == "line"))
    if not shape_ok:
        c.error("E305", f"{ctx}: expected {given[0]} = "
                + ("(point, (dx, dy))" if given[0] == "line" else "(point, radius)"),
                arg.span or f.span, "not a " + given[0])
        return None
    other = c.point(val.x, arg.span or f.span, ctx)
    if other is None:
        return None
    for p in (centre, other):
        if p.body != GROUND and isinstance(c.model_body(p.body), FlexibleBeam):
            c.error("E304", f"{ctx}: contacts act between rigid bodies; '{p.text}' is on "
                    "a flexible beam", f.span, "flexible beam",
                    hint="attach a rigid body to the beam and put the contact on it")
            return None
    if centre.body == other.body:
        c.error("E402", f"{ctx} puts a body in contact with itself", f.span, "no effect")
        return None
    radius = opts["radius"]
    if given[0] == "line":
        dx = c.number(val.y.x, arg.span or f.span, ctx)
        dy = c.number(val.y.y, arg.span or f.span, ctx)
        if dx is None or dy is None:
            return None
        if dx == 0.0 and dy == 0.0:
            c.error("E303", f"{ctx}: the line's direction is zero", arg.span or f.span,
                    "zero direction")
            return None
        return contact_geometry_line(centre, radius, other, (dx, dy))
    hole = c.number(val.y, arg.span or f.span, ctx, unit="m")
    if hole is None:
        return None
    if not hole > radius:
        c.error("E303", f"{ctx}: the hole's radius ({hole:g} m) must exceed the pin's "
                f"({radius:g} m)", arg.span or f.span, "no clearance",
                hint="a pin as large as its hole is a revolute joint")
        return None
    return contact_geometry_circle(centre, radius, other, hole)
