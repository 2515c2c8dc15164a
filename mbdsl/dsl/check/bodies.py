"""Passes 3 and 4, the ground's points and the bodies: rigid bodies, particles
and flexible beams with their points and drawing shapes. Diagnostics: E202
(duplicate names), E302 (no mass or inertia), E301/E303 (values and ranges),
E304 (an unknown or missing property), E305 (a shape's arguments), E306 (a zero
direction), E205 (an unknown shape), E201 (an unknown name).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...model.beam import FRAMES
from ...model.coordinates import _fields
from ...model.elements import COORDINATES, FlexibleBeam, RigidBody, Shape
from ...model.spatial import SpatialParticle
from ..expressions import Name, Vec
from ..spec import BeamSpec
from .context import did_you_mean
from .spatial import check_axis, check_spatial_body, spatial_shape


#: shape kind -> (fewest points, most points, takes a radius)
SHAPES = {"line": (2, 2, False), "circle": (1, 1, True), "polygon": (3, None, False)}


#: flexible beam properties -> (unit, must be an integer)
#: The most elements one flexible beam may have. Its set-up stores each element's
#: strain data over all 3 N elastic coordinates (``BeamMesh.strain_gradients``: N^3
#: numbers); measured on the flexible slider crank (``--set N=``, five steps): 50
#: elements 0.27 GB and 1.3 s, 200 elements 1.8 GB and 7.6 s. A mistyped 1e12 used to
#: run the machine out of memory.
MAX_BEAM_ELEMENTS = 300
BEAM_PROPERTIES = {"length": ("m", False), "E": ("Pa", False), "area": ("m^2", False),
                   "second_moment": ("m^4", False), "elements": ("", True),
                   "mass": ("kg", False), "density": ("kg/m^3", False),
                   "modes": ("", True)}


def check_ground(c):
    """Collect the ground's named points (and, in a spatial model, its axes)."""
    for p in c.items["ground_points"]:
        if p.axis:
            check_axis(c, "ground", p, c.ground_axes)
            continue
        if p.name in c.ground_points:
            c.error("E202", f"duplicate ground point '{p.name}'", p.span, "declared again")
            continue
        v = c.vector(p.position, p.span, f"ground point '{p.name}'")
        if v is not None:
            c.ground_points[p.name] = v
        else:
            c.broken_points.add(("ground", p.name))


def check_bodies(c):
    """Check mass, inertia and points of every rigid body, and every
    flexible beam (``check_beam``); then place the beams' elastic
    coordinates after the reference coordinates of all bodies."""
    c.broken_bodies = set()
    for b in c.items["bodies"]:
        if not c.claim(b.name, b.span, "body"):
            continue
        if c.space == 3 and not getattr(b, "particle", False):
            check_spatial_body(c, b)
            continue
        if isinstance(b, BeamSpec):
            check_beam(c, b)
            continue
        if b.particle:
            check_particle(c, b)
            continue
        props = {}
        for prop in b.properties:
            if prop.name not in ("mass", "inertia"):
                c.error("E304", f"body '{b.name}': unknown property '{prop.name}'", prop.span,
                        "unknown property",
                        hint=did_you_mean(prop.name, ["mass", "inertia", "point"])
                        or "a rigid body has 'mass', 'inertia' and 'point' lines")
                continue
            if prop.name in props:
                c.error("E202", f"body '{b.name}': '{prop.name}' given twice", prop.span,
                        "given again")
                continue
            props[prop.name] = prop
        values = {}
        for key, unit in (("mass", "kg"), ("inertia", "kg m^2")):
            if key not in props:
                c.error("E302", f"body '{b.name}' has no {key}", b.span, f"{key} missing",
                        hint=f"add '{key} VALUE' [{unit}]; there is no default")
                continue
            v = c.number(props[key].value, props[key].span, f"{key} of body '{b.name}'",
                         unit=unit.replace(" ", "*"))
            if v is None:
                continue
            if v <= 0:
                c.error("E303", f"the {key} of body '{b.name}' must be positive, got {v:g} {unit}",
                        getattr(props[key].value, "span", None) or props[key].span,
                        "not positive", hint=f"a rigid body has positive {key}")
                continue
            values[key] = v
        points = {"cm": np.zeros(2)}
        for p in b.points:
            if p.axis:
                check_axis(c, b.name, p, {})
                continue
            if p.name in points:
                c.error("E202", f"body '{b.name}': duplicate point '{p.name}'", p.span,
                        "declared again" if p.name != "cm" else "'cm' is the centre of mass, always defined")
                continue
            v = c.vector(p.position, p.span, f"point '{b.name}.{p.name}'")
            if v is not None:
                points[p.name] = v
            else:
                c.broken_points.add((b.name, p.name))
        shapes = tuple(s for s in (shape(c, b.name, sp, points) for sp in b.shapes)
                       if s is not None)
        if len(values) == 2:
            c.bodies[b.name] = RigidBody(b.name, len(c.bodies), values["mass"],
                                         values["inertia"], points, b.span, shapes)
        else:
            c.broken_bodies.add(b.name)
    offset = sum(len(_fields(b, COORDINATES)) for b in c.bodies.values())
    for name, b in c.bodies.items():
        if isinstance(b, FlexibleBeam):
            c.bodies[name] = dataclasses.replace(b, elastic_offset=offset)
            offset += b.n_elastic


def check_particle(c, b):
    """A particle (point mass): a positive mass, no inertia, no points
    but ``cm``; shapes are drawn at its position without turning. In a
    spatial model a :class:`~mbdsl.model.spatial.SpatialParticle` (x, y, z)."""
    ctx = f"particle '{b.name}'"
    mass = None
    for prop in b.properties:
        if prop.name != "mass":
            c.error("E304", f"{ctx}: unknown property '{prop.name}'", prop.span,
                    "unknown property",
                    hint="a particle has a mass only: it does not turn, so it has no "
                    "inertia (declare a body for that)" if prop.name == "inertia"
                    else did_you_mean(prop.name, ["mass"]) or "a particle has a 'mass'")
            continue
        if mass is not None:
            c.error("E202", f"{ctx}: 'mass' given twice", prop.span, "given again")
            continue
        mass = c.number(prop.value, prop.span, f"mass of {ctx}", unit="kg")
        if mass is not None and not mass > 0:
            c.error("E303", f"the mass of {ctx} must be positive, got {mass:g} kg",
                    getattr(prop.value, "span", None) or prop.span, "not positive")
            mass = None
        mass = mass if mass is not None else float("nan")
    if mass is None:
        c.error("E302", f"{ctx} has no mass", b.span, "mass missing",
                hint="add 'mass VALUE' [kg]; there is no default")
    for p in b.points:
        c.error("E304", f"{ctx}: a particle has one point, 'cm' (its position)", p.span,
                "a point off the particle",
                hint="joints and forces attach at NAME.cm; for points that turn with "
                "the mass, declare a body")
    points = {"cm": np.zeros(c.space)}
    drawn = spatial_shape if c.space == 3 else shape
    shapes = tuple(s for s in (drawn(c, b.name, sp, points) for sp in b.shapes)
                   if s is not None)
    if mass is None or not math.isfinite(mass) or b.points:
        c.broken_bodies.add(b.name)
        return
    if c.space == 3:
        c.bodies[b.name] = SpatialParticle(b.name, len(c.bodies), mass, points, b.span, shapes)
        return
    c.bodies[b.name] = RigidBody(b.name, len(c.bodies), mass, 0.0, points, b.span,
                                 shapes, particle=True)


def shape(c, body, sp, points):
    """A Shape of body ``body`` from its ShapeSpec; None after reporting.
    Points are the body's point names (``points``) or (x, y) in its frame."""
    ctx = f"shape {sp.kind} of body '{body}'"
    if sp.kind not in SHAPES:
        c.error("E205", f"body '{body}': unknown shape '{sp.kind}'", sp.kind_span or sp.span,
                "unknown shape", hint=did_you_mean(sp.kind, SHAPES)
                or f"shapes are {', '.join(SHAPES)}")
        return None
    lo, hi, has_radius = SHAPES[sp.kind]
    args = list(sp.args)
    if any(a.keyword is not None for a in args):
        a = next(a for a in args if a.keyword is not None)
        c.error("E304", f"{ctx}: shapes take no options, got '{a.keyword}'",
                a.span or sp.span, "unknown option",
                hint="write the points, then a circle's radius: circle(cm, 0.05)")
        return None
    radius = 0.0
    if has_radius:
        if len(args) != 2:
            c.error("E305", f"{ctx}: expected a centre point and a radius, got "
                    f"{len(args)} argument{'s' if len(args) != 1 else ''}",
                    sp.kind_span or sp.span, "circle(point, radius)")
            return None
        r = c.number(args[1].value, args[1].span or sp.span, ctx, unit="m")
        if r is None:
            return None
        if not r > 0:
            c.error("E303", f"{ctx}: the radius must be positive, got {r:g} m",
                    args[1].span or sp.span, "not positive")
            return None
        radius, args = r, args[:1]
    if len(args) < lo or (hi is not None and len(args) > hi):
        want = f"{lo}" if lo == hi else f"at least {lo}"
        c.error("E305", f"{ctx}: expected {want} points, got {len(args)}",
                sp.kind_span or sp.span, "wrong number of points")
        return None
    xy = []
    for a in args:
        v = a.value
        if isinstance(v, Name) and not isinstance(v, Vec):
            if v.name not in points:
                c.error("E201", f"{ctx}: body '{body}' has no point '{v.name}'",
                        a.span or sp.span, "unknown point",
                        hint=did_you_mean(v.name, points)
                        or "name a point of the body, or give (x, y) in its frame")
                return None
            xy.append(np.asarray(points[v.name], float))
            continue
        if not isinstance(v, Vec):
            c.error("E305", f"{ctx}: expected a point name or (x, y), got an expression",
                    a.span or sp.span, "not a point")
            return None
        p = c.vector(v, a.span or sp.span, ctx)
        if p is None:
            return None
        xy.append(p)
    return Shape(sp.kind, np.array(xy, float).reshape(-1, 2), radius)


def check_beam(c, b: BeamSpec):
    """Check a flexible beam: positive properties, mass or density (one),
    an integer element count, a known frame, points on the beam."""
    ctx = f"flexible beam '{b.name}'"
    props, values, stiffening = _beam_properties(c, b, ctx)
    ok = True
    for key in ("length", "E", "area", "second_moment", "elements"):
        if key not in props:
            unit = BEAM_PROPERTIES[key][0]
            c.error("E302", f"{ctx} has no {key}", b.span, f"{key} missing",
                    hint=f"add '{key} VALUE'" + (f" [{unit}]" if unit else "")
                    + "; there is no default")
            ok = False
    if ("mass" in props) == ("density" in props):
        c.error("E302", f"{ctx} needs exactly one of 'mass' [kg] and 'density' [kg/m^3]",
                b.span, "give mass or density",
                hint="the mass per length is mass/length or density*area")
        ok = False
    frame = b.frame or "first_node"
    if frame not in FRAMES:
        c.error("E304", f"{ctx}: unknown frame '{frame}'", b.frame_span or b.span,
                "unknown frame", hint=did_you_mean(frame, FRAMES)
                or f"frames are {', '.join(FRAMES)}")
        ok = False
    mass = _beam_mass(c, b, ctx, props, values) if ok and len(values) == len(props) else None
    if mass is None:
        c.broken_bodies.add(b.name)
        return
    length = values["length"]
    points = _beam_points(c, b, ctx, length)
    c.bodies[b.name] = FlexibleBeam(b.name, len(c.bodies), mass, length, values["E"],
                                    values["area"], values["second_moment"],
                                    int(values["elements"]), frame, points, span=b.span,
                                    stiffening=stiffening, modes=int(values.get("modes", 0)))


def _beam_properties(c, b: BeamSpec, ctx: str):
    """The beam's property lines (each once, known) and their values (positive,
    integers where counted); ``stiffening on | off``."""
    props, values = {}, {}
    stiffening = True
    for prop in b.properties:
        if prop.name == "stiffening":         # stiffening on | off
            v = prop.value
            if isinstance(v, Name) and v.name in ("on", "off"):
                stiffening = v.name == "on"
            else:
                c.error("E304", f"{ctx}: 'stiffening' is 'on' or 'off'",
                        getattr(v, "span", None) or prop.span, "expected on or off",
                        hint="geometric stiffening (the axial force's bending stiffness) "
                        "is on by default; 'stiffening off' keeps the linear beam")
            continue
        if prop.name not in BEAM_PROPERTIES:
            c.error("E304", f"{ctx}: unknown property '{prop.name}'", prop.span,
                    "unknown property", hint=did_you_mean(prop.name, BEAM_PROPERTIES)
                    or "a flexible beam has " + ", ".join(BEAM_PROPERTIES)
                    + ", 'frame' and 'point NAME at x' lines")
            continue
        if prop.name in props:
            c.error("E202", f"{ctx}: '{prop.name}' given twice", prop.span, "given again")
            continue
        props[prop.name] = prop
    for key, (unit, integer) in BEAM_PROPERTIES.items():
        if key not in props:
            continue
        v = c.number(props[key].value, props[key].span, f"{key} of {ctx}",
                     unit=unit or None)
        if v is None:
            continue
        sp = getattr(props[key].value, "span", None) or props[key].span
        if not v > 0 or not math.isfinite(v):
            c.error("E303", f"the {key} of {ctx} must be positive, got {v:g} {unit}".rstrip(),
                    sp, "not positive")
            continue
        if integer and v != int(v):
            what = "number of elements" if key == "elements" else "number of modes"
            c.error("E301", f"the {what} of {ctx} must be an integer, got {v:g}",
                    sp, "not an integer")
            continue
        if key == "elements" and v > MAX_BEAM_ELEMENTS:
            c.error("E303", f"{ctx} has {v:g} elements, more than {MAX_BEAM_ELEMENTS}", sp,
                    "too many elements", hint="a beam's set-up keeps its strain data over all "
                    "its elastic coordinates, per element (N^3 numbers: 200 elements take "
                    "1.8 GB); split the beam into beams joined by fixed joints, or use fewer "
                    "elements ('modes K' reduces the coordinates, not the mesh)")
            continue
        values[key] = v
    return props, values, stiffening


def _beam_mass(c, b: BeamSpec, ctx: str, props: dict, values: dict) -> float | None:
    """The beam's mass [kg], after checking that its mass, inertia and element
    stiffness are representable and its modes no more than its elastic
    coordinates; None after reporting."""
    length = values["length"]
    with np.errstate(all="ignore"):
        mass = np.float64(values["mass"]) if "mass" in values else \
            np.float64(values["density"]) * values["area"] * length
        l = np.float64(length) / values["elements"]
        derived = [mass, mass / length, mass * np.float64(length) ** 2,
                   values["E"] * np.float64(values["area"]) / l,
                   values["E"] * np.float64(values["second_moment"]) / l ** 3]
    tiny = np.finfo(float).tiny * 1e10       # far from subnormal: K must be factorable
    if not all(np.isfinite(x) and x > tiny for x in derived):
        c.error("E303", f"{ctx}: its mass, inertia or element stiffness is out of the "
                "floating-point range (overflows or vanishes)", b.span, "out of range",
                hint="check the units (SI: m, kg, Pa, m^2, m^4) and the number of elements")
        return None
    modes = int(values.get("modes", 0))
    nf = 3 * int(values["elements"])         # 3 per node, less the frame's three
    if modes > nf:
        c.error("E303", f"{ctx}: {modes} modes, but its {int(values['elements'])} "
                f"elements have {nf} elastic coordinates", props["modes"].span,
                "too many modes", hint=f"give at most {nf} modes, or more elements")
        return None
    return float(mass)


def _beam_points(c, b: BeamSpec, ctx: str, length: float) -> dict[str, float]:
    """The beam's named points by arc length [m]: start, end and its ``point
    NAME at x`` lines (on the beam)."""
    points = {"start": 0.0, "end": length}
    for p in b.points:
        if p.name in points:
            c.error("E202", f"{ctx}: duplicate point '{p.name}'", p.span,
                    "declared again" if p.name not in ("start", "end")
                    else f"'{p.name}' is always defined")
            continue
        at = p.at
        if isinstance(at, Name) and at.name in ("start", "end") and at.name not in c.params:
            x = 0.0 if at.name == "start" else length
        else:
            x = c.number(at, p.span, f"point '{b.name}.{p.name}'", unit="m")
            if x is None:
                continue
        if not -1e-12 * length <= x <= length * (1 + 1e-12):
            c.error("E306", f"point '{b.name}.{p.name}' at {x:g} m is not on the beam "
                    f"(0 .. {length:g} m)", getattr(at, "span", None) or p.span,
                    "off the beam", hint="give the arc length from the first node, "
                    "'start' or 'end'")
            continue
        points[p.name] = min(max(x, 0.0), length)
    return points