"""The language's tables: the joint and force kinds with their keywords, what a
force expression may read of the motion, the simulate section's settings.

A new joint or load kind starts with its entry here (``docs/architecture.md``,
"Adding a joint"); its check lives in the pass of its family (``joints.py``,
``forces.py``, ``contact.py``).
"""

from __future__ import annotations

from ...registry import COEFFICIENTS, METHOD_NAMES

__all__ = ["MAX_REPEAT", "JOINT_KINDS", "COUPLER_KINDS", "JOINT_MOTION", "UNSET", "FORCE_KINDS",
           "GEOMETRY_OPTIONS", "WORD_OPTIONS", "FORCE_FRAMES", "BODY_STATE",
           "REVOLUTE_STATE", "SLIDING_STATE", "KNOWN_METHODS", "SETTINGS"]


#: most instances one for block may create
MAX_REPEAT = 1_000_000

#: joint kind -> (positional points, allowed keywords, rows)
JOINT_KINDS = {
    "revolute": (2, {}, 2),
    "fixed": (2, {"angle": 0.0}, 3),
    "prismatic": (2, {"direction": None, "angle": 0.0}, 2),
    "point_on_line": (2, {"direction": None}, 1),
    "distance": (2, {"length": None}, 1),
}

#: a coupler between joint coordinates, declared as a joint -> (positional arguments:
#: joints, or the relation's expression for ``coupler``; allowed keywords; the
#: quantities of its joints, "angle" or "distance"). ``value`` (c) is optional: by
#: default the relation's value as placed.
COUPLER_KINDS = {
    "gear": (2, {"ratio": None, "value": float("nan")}, ("angle", "angle")),
    "rack": (2, {"radius": None, "value": float("nan")}, ("distance", "angle")),
    "coupler": (1, {"value": float("nan")}, ()),
}

#: joint kind -> the relative motion it leaves free, which friction brakes and a limit
#: bounds: a revolute's turning, a sliding joint's sliding along its line (the kinds
#: not listed leave no single one)
JOINT_MOTION = {"revolute": "turning", "prismatic": "sliding", "point_on_line": "sliding"}

#: an optional keyword without a default value (``friction``'s radius, mu_static)
UNSET = float("nan")

#: force kind -> allowed keywords with defaults (None: required; UNSET: optional)
FORCE_KINDS = {
    "spring_damper": {"k": None, "c": 0.0, "length": None},
    "rotational_spring_damper": {"k": None, "c": 0.0, "angle": 0.0},
    "torque": {"frame": "world"},          # frame: a spatial torque's axes
    "joint_torque": {},
    "joint_force": {},
    "friction": {"mu": None, "radius": UNSET, "mu_static": UNSET, "v_stribeck": 0.0,
                 "viscous": 0.0, "v_reg": 1e-4},
    "force": {"frame": "world"},
    # a circle against a line or in a hole (``model.contact``); line/circle: one of them
    "contact": {"radius": None, "line": UNSET, "circle": UNSET, "plane": UNSET, "k": None,
                "exponent": 1.5,
                "restitution": 1.0, "mu": 0.0, "v_reg": 1e-4},
    # a revolute's angle or a sliding joint's distance between bounds (one of them or both)
    "limit": {"lower": UNSET, "upper": UNSET, "k": None, "exponent": 1.0, "restitution": 1.0},
    # a tension-only spring-damper between two points: k [N/m], or EA [N] per length
    "rope": {"length": None, "k": None, "c": 0.0},
    "cable": {"length": None, "EA": None, "c": 0.0},
}

#: keywords whose value is a geometry, read by the element, not a number
GEOMETRY_OPTIONS = ("line", "circle", "plane")
#: ... or a word (a point force's axes)
WORD_OPTIONS = ("frame",)

#: the axes a point force's components may be written in
FORCE_FRAMES = ("world", "body")

#: What a force expression may read of the motion: body field -> (level, coordinate),
#: and revolute-joint field -> level (angle, rate: phi2 - phi1 and its rate).
BODY_STATE = {"x": (0, 0), "y": (0, 1), "phi": (0, 2), "vx": (1, 0), "vy": (1, 1),
              "omega": (1, 2)}

REVOLUTE_STATE = {"angle": 0, "rate": 1}

#: ... and a prismatic or point_on_line joint's distance along its line and its rate.
SLIDING_STATE = {"distance": 0, "speed": 1}

KNOWN_METHODS = METHOD_NAMES

#: simulate-section settings: name -> must be positive (the methods' coefficients: no)
SETTINGS = {"h": True, "t_end": True, **{c: False for c in COEFFICIENTS}, "t_start": False,
            "rtol": True, "atol": True, "tol": True,     # error-controlled steps
            "output_dt": True}                           # rows at requested times
