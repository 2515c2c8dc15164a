"""Pass 8, drivers: a body coordinate, a revolute's angle or a sliding joint's
distance prescribed as a function of time. Diagnostics: E201 (an unknown
target), E202 (driven twice), E307 (a value of the wrong dimension).

In a spatial model a body is driven by x, y or z and a joint by its angle
(revolute, cylindrical) or distance (prismatic, cylindrical, point_on_line).
"""

from __future__ import annotations

from ...model.elements import COORDINATES, Driver
from .context import did_you_mean, plain_target
from .spatial import ANGLE_JOINTS, DISTANCE_JOINTS


#: the SI unit of a driven quantity
DRIVER_UNITS = {"x": "m", "y": "m", "z": "m", "phi": "rad", "angle": "rad", "distance": "m"}
#: the driven coordinates of a spatial body (its centre of mass)
SPATIAL_COORDINATES = ("x", "y", "z")


def check_drivers(c):
    """Resolve driver targets (body coordinate or joint angle) and compile f(t)."""
    c.drivers = []
    for d in c.items["drivers"]:
        ok = c.claim(d.name, d.span, "driver")
        ctx = f"driver '{d.name}'"
        tgt = plain_target(d.target)
        fn = c.time_function(d.value, d.span, ctx, unit=DRIVER_UNITS.get(tgt.attr))
        if tgt.obj in c.joints:
            joint = c.joints[tgt.obj]
            if c.space == 3:
                _spatial_joint_driver(c, d, tgt, joint, fn, ok)
                continue
            sliding = joint.kind in ("prismatic", "point_on_line")
            if tgt.attr not in ("angle", "distance") or (tgt.attr == "distance"
                                                         and not sliding):
                c.error("E201", f"{ctx}: a {joint.kind} joint is driven by its "
                        + ("'angle' or 'distance'" if sliding else "'angle'"),
                        tgt.span or d.span, "unknown joint quantity",
                        hint=f"write '{tgt.obj}.angle'" if not sliding else
                        f"write '{tgt.obj}.distance' (along the line, from its point)")
                continue
            if tgt.attr == "angle" and not c.turning(joint.bodies, ctx, tgt.span or d.span,
                                                     "a joint angle is a relative rotation"):
                continue
            if ok and fn:
                kind = "joint_distance" if tgt.attr == "distance" else "joint_angle"
                c.drivers.append(Driver(d.name, kind, fn, joint=joint, span=d.span))
            continue
        body = c.bodies.get(tgt.obj)
        if body is None:
            if tgt.obj not in c.broken_bodies and tgt.obj not in c.element_spans:
                c.error("E201", f"{ctx}: unknown body or joint '{tgt.obj}'", tgt.span or d.span,
                        "not declared",
                        hint=did_you_mean(tgt.obj, list(c.bodies) + list(c.joints)))
            continue
        coordinates = SPATIAL_COORDINATES if c.space == 3 else COORDINATES
        if tgt.attr not in coordinates:
            c.error("E201", f"{ctx}: '{tgt.attr}' is not a coordinate", tgt.span or d.span,
                    "unknown coordinate", hint=did_you_mean(tgt.attr, coordinates)
                    or "a body is driven by its " + ("x, y or z" if c.space == 3
                                                     else "x, y or phi"))
            continue
        if c.space == 3:
            if ok and fn:
                c.drivers.append(Driver(d.name, "coordinate", fn, body=body.index,
                                        coord=coordinates.index(tgt.attr), span=d.span, space=3))
            continue
        if tgt.attr == "phi" and not c.turning([body.index], ctx, tgt.span or d.span,
                                               "a driven angle needs a body that turns"):
            continue
        if ok and fn:
            c.drivers.append(Driver(d.name, "coordinate", fn, body=body.index,
                                    coord=COORDINATES.index(tgt.attr), span=d.span))


def _spatial_joint_driver(c, d, tgt, joint, fn, ok):
    """A spatial joint's driver: a revolute's or cylindrical's ``angle``
    [rad], a prismatic's, cylindrical's or point_on_line's ``distance`` [m]
    (E201 another quantity or joint kind)."""
    kinds = {"angle": ANGLE_JOINTS, "distance": DISTANCE_JOINTS}
    if tgt.attr not in kinds or joint.kind not in kinds[tgt.attr]:
        has = [q for q in kinds if joint.kind in kinds[q]]
        c.error("E201", f"driver '{d.name}': a spatial {joint.kind} joint has "
                + (" or ".join(f"'{q}'" for q in has) if has else "nothing to drive"),
                tgt.span or d.span, "unknown joint quantity",
                hint="drive a revolute's or cylindrical's 'angle', or a prismatic's, "
                "cylindrical's or point_on_line's 'distance'")
        return
    if ok and fn:
        kind = "joint_distance" if tgt.attr == "distance" else "joint_angle"
        c.drivers.append(Driver(d.name, kind, fn, joint=joint, span=d.span, space=3))
