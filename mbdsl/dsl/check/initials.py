"""Pass 10, initial conditions: ``initial`` (held) and ``guess`` (a starting point)
lines on body coordinates and velocities. Diagnostics: E201 (an unknown body),
E502 (an unknown field, or given twice).
"""

from __future__ import annotations

from ...model.elements import COORDINATES, VELOCITIES, InitialCondition
from .context import did_you_mean, plain_target
from .spatial import check_spatial_initials


#: the SI unit of a body coordinate or velocity
INITIAL_UNITS = {"x": "m", "y": "m", "phi": "rad", "vx": "m/s", "vy": "m/s", "omega": "rad/s"}


def check_initials(c):
    """Resolve initial and guess lines; reject unknown fields and repeats
    (a spatial model's: ``spatial.check_spatial_initials``)."""
    if c.space == 3:
        return check_spatial_initials(c)
    c.initials = []
    seen = {}
    for ic in c.items["initials"]:
        tgt = plain_target(ic.target)
        kw = "guess" if ic.guess else "initial"
        body = c.bodies.get(tgt.obj)
        if body is None:
            if tgt.obj not in c.broken_bodies:
                c.error("E201", f"{kw}: unknown body '{tgt.obj}'", tgt.span or ic.span,
                        "no body with this name",
                        hint=did_you_mean(tgt.obj, c.bodies))
            continue
        if tgt.attr not in COORDINATES + VELOCITIES:
            c.error("E502", f"{kw}: '{tgt.attr}' is not a coordinate or velocity of a body",
                    tgt.span or ic.span, "unknown field",
                    hint=did_you_mean(tgt.attr, COORDINATES + VELOCITIES)
                    or "use x, y, phi, vx, vy or omega")
            continue
        if getattr(body, "particle", False) and tgt.attr in ("phi", "omega"):
            c.error("E502", f"{kw}: particle '{tgt.obj}' does not turn: it has x, y, vx "
                    "and vy", tgt.span or ic.span, "a particle has no angle")
            continue
        key = (tgt.obj, tgt.attr)
        if key in seen:
            c.error("E502", f"{kw}: '{tgt.text}' is given twice", ic.span, "given again",
                    secondary=((seen[key], "first given here"),) if seen[key] else ())
            continue
        seen[key] = ic.span
        if tgt.attr == "phi":
            v = c.angle(ic.value, ic.span, f"{kw} {tgt.text}")
        else:
            v = c.number(ic.value, ic.span, f"{kw} {tgt.text}",
                         unit=INITIAL_UNITS[tgt.attr])
        if v is not None:
            c.initials.append(InitialCondition(body.index, tgt.attr, v, ic.guess, ic.span))
