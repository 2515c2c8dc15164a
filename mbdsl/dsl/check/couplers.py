"""Pass 7, couplers: gears, racks and linear couplers between joint coordinates
(declared as joints, ``tables.COUPLER_KINDS``), after every joint is resolved
so that a coupler may name a joint declared after it. Diagnostics: E201 (not
a joint), E305 (a joint of the wrong kind; a relation that is not linear in
joint coordinates), E304 (an option), E303 (a value out of range), E307 (a
unit).

A gear of ratio n between revolute joints J1 and J2 holds theta1 - theta1_0
= n (theta2 - theta2_0); a rack between a sliding joint Jr and a revolute
Jp (the pinion, radius r) holds s - s_0 = r (theta - theta_0); a coupler
holds a linear relation sum_k a_k x_k = value of revolute angles, sliding
distances and body coordinates (Haug, Computer Aided Kinematics and
Dynamics of Mechanical Systems, sec. 3.4). Without ``value`` the relation's
value as placed is held (``model.elements.Coupler``).
"""

from __future__ import annotations

import math

import numpy as np

from ...model.elements import Coupler
from ..expressions import Dotted, ExprError, compile_state_function, diff, free_names
from .context import BrokenReference
from .forces import state_expression, state_variable
from .tables import COUPLER_KINDS

#: the SI unit of a coupler's value: by its first joint's quantity
_UNITS = {"angle": "rad", "distance": "m"}


def check_couplers(c):
    """Build the couplers declared among the joints."""
    c.couplers = []
    for j in c.items["joints"]:
        if j.kind not in COUPLER_KINDS:
            continue
        ok = c.claim(j.name, j.span, "joint")
        ctx = f"{j.kind} '{j.name}'"
        npos, allowed, quantities = COUPLER_KINDS[j.kind]
        pos, kw = c.split_args(j, allowed, npos, ctx)
        if pos is None:
            continue
        if j.kind == "coupler":
            built = _relation(c, j, pos[0], ctx)
        else:
            built = _pair(c, j, pos, kw, quantities, ctx)
        if built is None:
            continue
        variables, coefs, constant = built
        value = None
        if "value" in kw:
            unit = _UNITS.get(quantities[0]) if quantities else None
            given = c.number(kw["value"].value, kw["value"].span, f"{ctx}: value", unit=unit)
            if given is None:
                continue
            value = given - constant
        if ok:
            c.couplers.append(Coupler(j.name, j.kind, tuple(variables), tuple(coefs), value,
                                      j.span))


def _pair(c, j, pos, kw, quantities, ctx):
    """A gear's or a rack's two terms: (variables, coefficients, 0), or None
    after reporting."""
    joints = []
    for arg, quantity in zip(pos, quantities):
        joint = c.joint_argument(arg, j, ctx)
        if joint is None:
            return None
        span = getattr(arg.value, "span", None) or j.span
        want = ("revolute",) if quantity == "angle" else ("prismatic", "point_on_line")
        if joint.kind not in want:
            c.error("E305", f"{ctx}: '{joint.name}' is a {joint.kind} joint; a {j.kind} "
                    f"couples {' and '.join(_what(q) for q in quantities)}", span,
                    f"not a {' or '.join(want)} joint",
                    hint=("gear(J1, J2, ratio = n): two revolute joints" if j.kind == "gear"
                          else "rack(Jr, Jp, radius = r): the rack's sliding joint, then "
                          "the pinion's revolute joint"))
            return None
        joints.append(joint)
    variables = []
    for joint, quantity, arg in zip(joints, quantities, pos):
        try:
            variables.append(state_variable(c, Dotted(joint.name, quantity,
                                                      getattr(arg.value, "span", None))))
        except BrokenReference:
            return None
        except ExprError as err:
            c.expr_error(err, j.span, ctx)
            return None
    key, unit, allowed, what, label, hint = _FACTOR[j.kind]
    x = c.number(kw[key].value, kw[key].span, f"{ctx}: {key}", unit=unit)
    if x is None:
        return None
    if not (allowed(x) and math.isfinite(x)):
        c.error("E303", f"{ctx}: {what}, got {x:g}{' m' if unit == 'm' else ''}",
                _value_span(kw[key], j), label, hint=hint)
        return None
    return variables, (1.0, -x), 0.0


#: a gear's ratio and a rack's radius: (keyword, unit, the values allowed, the
#: message, its label and hint when the value is not one of them)
_FACTOR = {
    "gear": ("ratio", "1", lambda x: x != 0.0, "the ratio must be a finite non-zero number",
             "not a ratio", "theta1 - theta1_0 = ratio (theta2 - theta2_0); a negative ratio "
             "turns the shafts opposite ways (an external gear pair)"),
    "rack": ("radius", "m", lambda x: x > 0.0, "the pinion's radius must be positive",
             "not positive", "the rack moves radius * angle along its line as the pinion "
             "turns; for the other sense, reverse the rack's direction"),
}


def _value_span(arg, j):
    """Where an option's value is written (else the option, else the joint)."""
    return getattr(arg.value, "span", None) or arg.span or j.span


def _what(quantity: str) -> str:
    """The joint quantity a coupler reads, in words."""
    return "a revolute joint's angle" if quantity == "angle" else "a sliding joint's distance"


def _relation(c, j, arg, ctx):
    """A coupler's terms from its expression, linear in joint angles,
    sliding distances and body coordinates: (variables, coefficients, the
    constant term), or None after reporting."""
    span = getattr(arg.value, "span", None) or j.span
    read = state_expression(c, arg.value, span, ctx)
    if read is None:
        return None
    e, found = read
    variables = tuple(found.values())
    names = tuple(v.name for v in variables)
    bad = [v.name for v in variables if v.level != 0]
    if not variables or bad or "t" in free_names(e):
        c.error("E305", f"{ctx}: the relation must be linear in joint angles, sliding "
                "distances or body coordinates"
                + (f"; '{bad[0]}' is a rate" if bad else
                   "; it reads time" if variables else "; it reads none"), span,
                "not a coupler's relation",
                hint="coupler(J1.angle - 2 * J2.angle, value = 0); a prescribed motion is "
                "a driver")
        return None
    coefs = []
    try:
        for name in names:
            g = diff(e, name)
            if free_names(g):
                c.error("E305", f"{ctx}: the relation is not linear in '{name}'", span,
                        "not linear",
                        hint="a coupler holds sum a_k x_k = value with constant a_k")
                return None
            coefs.append(float(compile_state_function(g, names)(0.0, np.zeros(len(names)))))
        constant = float(compile_state_function(e, names)(0.0, np.zeros(len(names))))
    except ExprError as err:
        c.expr_error(err, span, ctx)
        return None
    if not all(math.isfinite(a) for a in coefs + [constant]) or not any(coefs):
        c.error("E303", f"{ctx}: the relation's coefficients must be finite and not all "
                "zero", span, "no relation")
        return None
    return variables, coefs, constant
