"""Pass 6, joints: kinds and arguments against ``tables.JOINT_KINDS``, points
resolved, directions and angles read. Diagnostics: E205 (unknown kind), E305
(arguments), E306 (a zero direction), E303 (a value out of range), E402 (a body
joined to itself).
"""

from __future__ import annotations

import math

import numpy as np

from ...model.elements import GROUND, Joint
from .spatial import check_spatial_joints
from .tables import COUPLER_KINDS, JOINT_KINDS


def check_joints(c):
    """Resolve joint points and options; reject joints of a body to itself.
    Couplers between joints (``COUPLER_KINDS``) are the next pass's; a
    spatial model's joints are ``spatial.check_spatial_joints``'."""
    if c.space == 3:
        return check_spatial_joints(c)
    for j in c.items["joints"]:
        if j.kind in COUPLER_KINDS:
            continue
        ok = c.claim(j.name, j.span, "joint")
        ctx = f"joint '{j.name}'"
        if not c.known_kind(j, {**JOINT_KINDS, **COUPLER_KINDS}, "joint", ctx):
            continue
        npos, allowed, rows = JOINT_KINDS[j.kind]
        pos, kw = c.split_args(j, allowed, npos, ctx)
        if pos is None:
            continue
        first = c.point(pos[0].value, pos[0].span or j.span, ctx)
        second = c.point(pos[1].value, pos[1].span or j.span, ctx)
        direction, angle = None, 0.0
        if "direction" in kw:
            direction = c.vector(kw["direction"].value, kw["direction"].span, ctx,
                                 unit=None)
            if direction is not None:
                norm = float(np.hypot(*direction))
                if norm == 0.0 or not math.isfinite(norm):
                    c.error("E306", f"{ctx}: the direction must be a non-zero vector",
                            kw["direction"].span, "zero direction")
                    direction = None
                else:
                    direction = direction / norm
            if direction is None:
                continue
        if "angle" in kw:
            angle = c.angle(kw["angle"].value, kw["angle"].span, f"{ctx}: angle")
            if angle is None:
                continue
        length = 0.0
        if "length" in kw:
            length = c.number(kw["length"].value, kw["length"].span, ctx, unit="m")
            if length is None:
                continue
            if not length > 0:
                c.error("E303", f"{ctx}: the length must be positive, got {length:g} m",
                        kw["length"].span, "not positive",
                        hint="a distance joint holds two points a positive distance "
                        "apart; for coincident points use a revolute joint")
                continue
        if first is None or second is None or not ok:
            continue
        locks = {"fixed": (first.body, second.body), "prismatic": (first.body, second.body),
                 "point_on_line": (second.body,)}.get(j.kind, ())
        if not c.turning(locks, ctx, j.span, f"a {j.kind} joint "
                         + ("holds its line in the second body's frame"
                            if j.kind == "point_on_line" else "locks a relative angle")):
            continue
        if first.body == second.body:
            what = "the ground" if first.body == GROUND else f"body '{pos[0].value.obj}'"
            c.error("E402", f"{ctx} connects {what} to itself", j.span,
                    "both points on one body",
                    hint="a joint connects two different bodies")
            continue
        c.joints[j.name] = Joint(j.name, j.kind, first, second, direction, angle,
                                 rows, j.span, length)
