"""Pass 11, outputs: each ``output`` expression's references (body and point
coordinates, joint reactions, multipliers, sensors of loads, energies) resolved
to the columns the run writes, and the expression's unit. Diagnostics: E201
(an unknown reference, with did-you-mean), E202 (a duplicate output), E304 (an
unknown field), E307 (units that do not add up).
"""

from __future__ import annotations

from functools import partial

from ...model.spatial import (SPATIAL_ACCELERATIONS, SPATIAL_COORDINATES, SPATIAL_VELOCITIES,
                              SpatialRotationalSpring, SpatialSpring)
from ...model.elements import (ACCELERATIONS, COORDINATES, VELOCITIES, FlexibleBeam, Friction,
                               Output, OutputVariable, RotationalSpringDamper, SpringDamper)
from .. import units
from ..expressions import Dotted, ExprError, Name, substitute
from .context import BrokenReference, did_you_mean, point_ref
from .loops import instantiate
from .spatial import ANGLE_JOINTS, DISTANCE_JOINTS
from .tables import SLIDING_STATE


#: What an output may read besides bodies, points and joints: result columns.
OUTPUT_GROUPS = {"energy": ("kinetic", "potential", "total", "work", "dissipated", "balance"),
                 "constraint": ("position", "velocity")}


#: An angle limit's gap sensors, in its units (a gap between points: SENSOR_UNITS).
ANGLE_GAP_UNITS = {"gap": "rad", "gap_rate": "rad/s", "normal": "N*m", "friction": "",
                   "power": "W", "energy": "J"}


def output_variable(c, ref: Dotted) -> OutputVariable:
    """The quantity of a reference in an ``output`` expression.

    Raises
    ------
    ExprError
        E201 for an unknown body, point, joint or driver; E304 for a
        field it does not have.
    """
    def fail(msg, code="E304", hint=""):
        """The error of this reference."""
        return ExprError(f"'{ref.text}': {msg}", code, ref.span, hint=hint)
    if isinstance(ref.obj, Dotted):            # body.point.field, reaction.J.fx, driver.D.force
        return _dotted_variable(c, ref, fail)
    obj, attr = ref.obj, ref.attr
    if obj in OUTPUT_GROUPS:
        if attr not in OUTPUT_GROUPS[obj]:
            raise fail(f"{obj} columns are {', '.join(OUTPUT_GROUPS[obj])}",
                       hint=did_you_mean(attr, OUTPUT_GROUPS[obj]))
        return OutputVariable(ref.text, "column", column=ref.text)
    sensors = _sensor_elements(c)
    if obj in sensors:
        return _sensor_variable(c, ref, sensors[obj], None, attr, fail)
    if obj in c.bodies:
        return _body_variable(c, ref, fail)
    if obj in c.joints:
        return _joint_variable(c, ref, fail)
    if obj in c.element_spans or obj in c.broken_bodies:
        raise BrokenReference(ref.text, "E201", ref.span)     # its own error is reported
    if obj == "state" and attr in c.states:
        raise fail(f"a first-order state is read by its name, '{attr}'", "E201",
                   f"write '{attr}' (its column is state.{attr})")
    raise fail(f"unknown body or joint '{obj}'", "E201",
               did_you_mean(str(obj), list(c.bodies) + list(c.joints)
                            + list(OUTPUT_GROUPS)))


def _dotted_variable(c, ref: Dotted, fail) -> OutputVariable:
    """A three-part reference: body.point.field, reaction.J.fx, driver.D.force,
    lambda.J.k or a sensor of a load (stop.lower.gap)."""
    head, mid, attr = ref.obj.obj, ref.obj.attr, ref.attr
    if head == "lambda":
        return _multiplier_variable(c, ref, mid, attr, fail)
    sensors = _sensor_elements(c)
    if isinstance(head, str) and head in sensors:       # stop.lower.gap
        return _sensor_variable(c, ref, sensors[head], mid, attr, fail)
    kind = {"reaction": "joints", "driver": "drivers"}.get(head)
    if kind and mid in {x.name for x in c.items[kind]} \
            and mid not in c.joints and mid not in {d.name for d in c.drivers}:
        # declared, but left out after an error reported at its declaration
        raise BrokenReference(ref.text, "E201", ref.span)
    if head == "reaction":
        fields = ("fx", "fy", "fz", "tx", "ty", "tz") if c.space == 3 else ("fx", "fy", "torque")
        if mid not in c.joints or attr not in fields:
            raise fail("a reaction is reaction.<joint>." + "|".join(fields),
                       "E201" if mid not in c.joints else "E304",
                       did_you_mean(mid, c.joints))
        return OutputVariable(ref.text, "column", column=ref.text)
    if head == "driver":
        drivers = {d.name: d for d in c.drivers}
        if mid not in drivers:
            raise fail("no such driver", "E201", did_you_mean(mid, drivers))
        d = drivers[mid]
        want = d.load
        if attr != want:
            raise fail(f"driver '{mid}' applies a {want}", hint=f"write driver.{mid}.{want}")
        return OutputVariable(ref.text, "column", column=ref.text)
    body = c.bodies.get(head) if isinstance(head, str) else None
    if body is None:
        raise fail(f"unknown body '{head}'", "E201",
                   did_you_mean(str(head), list(c.bodies) + ["reaction", "driver"]))
    if mid not in body.points:
        raise fail(f"body '{head}' has no point '{mid}'", "E201",
                   did_you_mean(mid, body.points))
    if isinstance(body, FlexibleBeam):
        fields = ("x", "y", "vx", "vy", "deflection")
        if attr not in fields:
            raise fail("a beam point's field is x, y, vx, vy or deflection",
                       hint=did_you_mean(attr, fields))
        c.output_units[ref.text] = "m/s" if attr[0] == "v" else "m"
        return OutputVariable(ref.text, "beam_point", field=attr,
                              bodies=(body.index,), arc=float(body.points[mid]))
    fields = ("x", "y", "z", "vx", "vy", "vz") if c.space == 3 else ("x", "y", "vx", "vy")
    if attr not in fields:
        raise fail(f"a point's field is {', '.join(fields[:-1])} or {fields[-1]}",
                   hint=did_you_mean(attr, fields))
    return OutputVariable(ref.text, "point", point=point_ref(body, mid, ref.text),
                          field=attr)


def _body_variable(c, ref: Dotted, fail) -> OutputVariable:
    """A body's coordinate, velocity or acceleration (a beam's: also its
    elastic coordinates and their rates)."""
    obj, attr = ref.obj, ref.attr
    fields = COORDINATES + VELOCITIES + ACCELERATIONS
    if c.space == 3:                    # its coordinates, their rates, the derived columns
        fields = (SPATIAL_COORDINATES + SPATIAL_VELOCITIES + SPATIAL_ACCELERATIONS
                  + ("e0", "e1", "e2", "e3", "yaw", "pitch", "roll", "wx", "wy", "wz"))
    if getattr(c.bodies[obj], "particle", False):       # a point mass: its position's
        fields = ("x", "y", "vx", "vy", "ax", "ay")
        if c.space == 3:
            fields = ("x", "y", "z", "vx", "vy", "vz", "ax", "ay", "az")
    if isinstance(c.bodies[obj], FlexibleBeam):     # and its elastic coordinates
        names = c.bodies[obj].mesh.names
        elastic = tuple(names) + tuple(f"{x}_t" for x in names) + tuple(
            f"{x}_tt" for x in names)
        if attr in elastic:
            c.output_units[ref.text] = units.column_unit(ref.text)
            return OutputVariable(ref.text, "column", column=ref.text)
        fields = fields + elastic
    if attr not in fields:
        raise fail(f"a body's fields are {', '.join(fields)}",
                   hint=did_you_mean(attr, fields) or "or a point: body.point.x")
    return OutputVariable(ref.text, "column", column=ref.text)


def _joint_variable(c, ref: Dotted, fail) -> OutputVariable:
    """A revolute's angle or rate, a sliding joint's distance or speed."""
    obj, attr = ref.obj, ref.attr
    j = c.joints[obj]
    if c.space == 3:
        return _spatial_joint_variable(ref, j, attr, fail)
    if j.kind in ("prismatic", "point_on_line"):
        if attr not in SLIDING_STATE:
            raise fail("an output reads a sliding joint's distance or speed",
                       hint=did_you_mean(attr, SLIDING_STATE))
        try:
            line = c.sliding_line(j, ref)
        except ExprError as err:
            raise fail(str(err.args[0]))
        return OutputVariable(ref.text, "joint", field=attr, bodies=j.bodies, line=line)
    if j.kind != "revolute" or attr not in ("angle", "rate"):
        raise fail("an output reads a revolute joint's angle or rate, or a sliding "
                   "joint's distance or speed",
                   hint=f"'{obj}' is a {j.kind} joint" if j.kind != "revolute"
                   else did_you_mean(attr, ("angle", "rate")))
    if any(c.is_particle(b) for b in j.bodies):
        raise fail("the joint holds a particle, which does not turn")
    return OutputVariable(ref.text, "joint", field=attr, bodies=j.bodies)


def _spatial_joint_variable(ref, j, attr, fail) -> OutputVariable:
    """A spatial revolute's or cylindrical's angle or rate (the angle of its
    drivers and rotational spring-dampers: ``kernels.joints.spatial_angles``),
    a prismatic's, cylindrical's or point_on_line's distance u . (p1 - p2) or
    speed: kind "spatial_joint", its geometry in ``line`` (``io.derived``)."""
    if attr in ("angle", "rate") and j.kind in ANGLE_JOINTS:
        (b1, a1), (b2, a2) = j.axes
        line = ("angle", b1, b2, tuple(a1), tuple(a2))
    elif attr in SLIDING_STATE and j.kind in DISTANCE_JOINTS:
        b2, u = j.axes[-1]
        line = ("distance", j.first.body, tuple(j.first.local), j.second.body,
                tuple(j.second.local), b2, tuple(u))
    else:
        fields = ((("angle", "rate") if j.kind in ANGLE_JOINTS else ())
                  + (tuple(SLIDING_STATE) if j.kind in DISTANCE_JOINTS else ()))
        raise fail(f"a spatial {j.kind} joint's outputs are "
                   + (", ".join(fields) if fields else "its reactions only"),
                   hint=did_you_mean(attr, fields) or f"reaction.{j.name}.fx, ...")
    return OutputVariable(ref.text, "spatial_joint", field=attr, bodies=j.bodies, line=line)


def _sensor_elements(c) -> dict:
    """Contacts, limits, friction elements and spring-dampers by name (what
    sensors read)."""
    from ...model.contact import Contact
    return {f.name: f for f in c.forces
            if isinstance(f, (Contact, Friction, SpringDamper, RotationalSpringDamper,
                              SpatialSpring, SpatialRotationalSpring))}


def _multiplier_variable(c, ref, mid, attr, fail) -> OutputVariable:
    """``lambda.<joint or driver>.<row>``: a Lagrange multiplier by name."""
    from ...model.elements import multiplier_unit
    elements = dict(c.joints)
    elements.update({d.name: d for d in c.drivers})
    if mid not in elements:
        raise fail("a multiplier is lambda.<joint or driver>.<row>", "E201",
                   did_you_mean(str(mid), elements))
    rows = getattr(elements[mid], "rows", 1)
    if not (isinstance(attr, str) and attr.isdigit() and int(attr) < rows):
        raise fail(f"'{mid}' has multiplier rows 0 .. {rows - 1}")
    column = f"lambda.{mid}.{int(attr)}"
    c.output_units[ref.text] = multiplier_unit(elements[mid], int(attr))
    return OutputVariable(ref.text, "column", column=column)


def _sensor_variable(c, ref, element, label, attr, fail) -> OutputVariable:
    """What a contact, limit (``floor.normal``, ``stop.upper.gap``),
    friction element (``f.friction``) or spring-damper (``spring.tension``)
    does at the stored rows."""
    from ...model.contact import Contact
    from ...model.elements import SENSOR_UNITS
    kind = {Friction: "friction", SpringDamper: "spring", RotationalSpringDamper: "rotational",
            SpatialSpring: "spatial_spring",
            SpatialRotationalSpring: "spatial_rotational"}.get(type(element))
    if kind is not None:
        fields = SENSOR_UNITS[kind.replace("spatial_", "")]
        if label is not None or attr not in fields:
            raise fail(f"a {kind} element's fields are {', '.join(fields)}",
                       hint=did_you_mean(str(attr), fields))
        index = [f.name for f in c.forces if type(f) is type(element)].index(element.name)
        unit = fields[attr]
        if kind == "friction" and element.joint.kind == "revolute":
            unit = {"speed": "rad/s", "friction": "N*m", "power": "W"}[attr]
        c.output_units[ref.text] = unit
        return OutputVariable(ref.text, kind, field=attr, index=index)
    labels = [g[2] for g in element.gaps]
    if label is None and len(labels) > 1:
        raise fail(f"'{element.name}' has gaps {', '.join(labels)}: name one",
                   hint=f"write {element.name}.{labels[0]}.{attr}")
    if label is not None and label not in labels:
        raise fail(f"'{element.name}' has no gap '{label}'", "E201",
                   did_you_mean(str(label), labels))
    if attr not in SENSOR_UNITS["gap"]:
        raise fail("a gap's fields are " + ", ".join(SENSOR_UNITS["gap"]),
                   hint=did_you_mean(str(attr), SENSOR_UNITS["gap"]))
    k = labels.index(label) if label is not None else 0
    index = sum(len(f.gaps) for f in c.forces[:c.forces.index(element)]
                if isinstance(f, Contact)) + k
    angle = element.gaps[k][0] == "angle"
    c.output_units[ref.text] = (ANGLE_GAP_UNITS if angle
                                else SENSOR_UNITS["gap"])[attr]
    return OutputVariable(ref.text, "gap", field=attr, index=index)


def check_outputs(c):
    """``output NAME = expr`` lines: names unique, references resolved."""
    c.outputs = []
    c.output_units = {}      # reference -> SI unit, where its element decides it
    seen = {}
    for o in c.spec.outputs:
        if o.name in seen:
            c.error("E202", f"output '{o.name}' is declared twice", o.span, "second one",
                    secondary=((seen[o.name], "first declared here"),) if seen[o.name]
                    else ())
            continue
        seen[o.name] = o.span
        found = {}

        def resolve(ref):
            """The variable's name; records it (a plain name: a first-order
            state's column, or None for a name that is no state)."""
            if isinstance(ref, Name):
                if ref.name not in c.states:
                    return None
                var = OutputVariable(ref.name, "column", column=f"state.{ref.name}")
                found.setdefault(var.name, var)
                return var.name
            var = output_variable(c, ref)
            found.setdefault(var.name, var)
            return var.name
        value = instantiate(c, o.value, {}, o.span)      # crank[1].T.x -> "crank[1]"
        if value is None:
            continue
        try:
            e = substitute(value, c.params, resolve, c.tables)
        except BrokenReference:
            continue                # a reference to a broken element: reported already
        except ExprError as err:
            c.expr_error(err, o.span, f"output '{o.name}'")
            continue
        try:
            dim = units.dimension(value, c.param_dims, partial(_reference_dimension, c))
        except units.DimensionError as err:
            c.error("E307", f"output '{o.name}': {err}", err.span or o.span,
                    "dimensions differ")
            continue
        unit = units.unit_text(dim)
        named = c.output_units.get(getattr(value, "text", None))
        if named and isinstance(value, Dotted):      # a sensor alone: its own unit (J, not N*m)
            unit = named
        c.outputs.append(Output(o.name, e, tuple(found.values()), o.span, unit))


def _reference_dimension(c, ref):
    """The dimension of an output's reference: by its element where that
    decides it (``output_units``), else by its last part."""
    unit = c.output_units.get(getattr(ref, "text", None))
    if unit is not None:
        return units.expected(unit) if unit else None
    return units.reference_dimension(ref)
