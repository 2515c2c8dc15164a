"""Semantic checks: ModelSpec -> Model, or every diagnostic at once.

Small passes, each adding diagnostics: parameters, ground, bodies, joints,
drivers, forces, initial conditions, settings, structure (graph, DOF). All
passes run even after an error so that a user sees every problem of a file
in one go (sympy's validate_system); a pass skips only the elements whose
inputs were already reported broken.
"""

from __future__ import annotations

import difflib
import hashlib
import math

import numpy as np

from ..gcpause import paused
from ..errors import Diagnostic, MbdModelError, Span
from ..model import graph
from ..registry import COEFFICIENTS, METHOD_COEFFICIENTS, METHOD_NAMES, check_coefficient
from ..model.elements import (COORDINATES, GROUND, VELOCITIES, Driver, InitialCondition,
                              FlexibleBeam, Joint, Model, PointForce, PointRef, RigidBody, Shape,
                              Friction, JointForce, JointTorque, Output, OutputVariable,
                              RotationalSpringDamper,
                              SpringDamper,
                              StateFunction, StateVariable, TimeFunction, Torque)
import dataclasses

from .expressions import (Dotted, ExprError, IndexedName, Name, Num, Vec, compile_function,
                          compile_state_function, diff, evaluate, free_names, substitute)
from ..model.beam import FRAMES
from .spec import BeamSpec, ForSpec, GroundSpec, ModelSpec
from . import units

#: most instances one for block may create
MAX_REPEAT = 1_000_000
_KINDS = ("bodies", "joints", "forces", "drivers", "initials")

__all__ = ["check_spec", "JOINT_KINDS", "FORCE_KINDS", "SETTINGS", "KNOWN_METHODS"]

#: joint kind -> (positional points, allowed keywords, rows)
JOINT_KINDS = {
    "revolute": (2, {}, 2),
    "fixed": (2, {"angle": 0.0}, 3),
    "prismatic": (2, {"direction": None, "angle": 0.0}, 2),
    "point_on_line": (2, {"direction": None}, 1),
    "distance": (2, {"length": None}, 1),
}
#: an optional keyword without a default value (``friction``'s radius, mu_static)
_UNSET = float("nan")
#: force kind -> allowed keywords with defaults (None: required; _UNSET: optional)
FORCE_KINDS = {
    "spring_damper": {"k": None, "c": 0.0, "length": None},
    "rotational_spring_damper": {"k": None, "c": 0.0, "angle": 0.0},
    "torque": {},
    "joint_torque": {},
    "joint_force": {},
    "friction": {"mu": None, "radius": _UNSET, "mu_static": _UNSET, "v_stribeck": 0.0,
                 "viscous": 0.0, "v_reg": 1e-4},
    "force": {},
    # a circle against a line or in a hole (``model.contact``); line/circle: one of them
    "contact": {"radius": None, "line": _UNSET, "circle": _UNSET, "k": None, "exponent": 1.5,
                "restitution": 1.0, "mu": 0.0, "v_reg": 1e-4},
    # a revolute's angle or a sliding joint's distance between bounds (one of them or both)
    "limit": {"lower": _UNSET, "upper": _UNSET, "k": None, "exponent": 1.0, "restitution": 1.0},
}
#: keywords whose value is a geometry, read by the element, not a number
_GEOMETRY_OPTIONS = ("line", "circle")
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


def _did_you_mean(name: str, candidates) -> str:
    close = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.6)
    return f"did you mean '{close[0]}'?" if close else ""


class _BrokenReference(ExprError):
    """A reference to an element whose own error is reported (not reported again)."""


class _Checker:
    def __init__(self, spec: ModelSpec, overrides: dict | None):
        self.spec = spec
        self.overrides = dict(overrides or {})
        self.diags: list[Diagnostic] = []
        self.params: dict[str, float] = {}
        self.param_dims: dict[str, units.Dimension | None] = {}
        self.bodies: dict[str, RigidBody] = {}
        self.ground_points: dict[str, np.ndarray] = {"origin": np.zeros(2)}
        self.joints: dict[str, Joint] = {}
        self.element_spans: dict[str, Span | None] = {}
        # names whose own error is reported: their uses are not reported again
        self.broken_names: set[str] = set()
        self.broken_points: set[tuple[str, str]] = set()
        # per spec object (keyed by id, the object kept to check it is the same one):
        # what it holds (_scan), its fields a copy may change, its builders, its value
        self._scanned: dict = {}
        self._varying: dict = {}
        self._builders: dict = {}
        self._numbers: dict = {}

    # -- helpers -------------------------------------------------------------
    def error(self, code, message, span=None, label="", hint="", notes=(), secondary=()):
        """Record an error diagnostic."""
        self.diags.append(Diagnostic("error", code, message, span, label, hint,
                                     tuple(notes), tuple(secondary)))

    def warning(self, code, message, span=None, label="", hint=""):
        """Record a warning diagnostic."""
        self.diags.append(Diagnostic("warning", code, message, span, label, hint))

    def expr_error(self, err: ExprError, fallback: Span | None, context: str):
        """Record an expression evaluation error with a did-you-mean hint."""
        if err.code == "E201" and err.name in self.broken_names:
            return                    # a follow-on of the error that broke this parameter
        hint = err.hint
        if err.code == "E201" and not hint:
            hint = _did_you_mean(err.name, list(self.params) + ["pi"])
        self.error(err.code, f"{context}: {err}", err.span or fallback,
                   label=str(err), hint=hint)

    def dimension(self, expr, want, span, context) -> bool:
        """Check the dimension of ``expr`` against the SI unit ``want``
        (``"kg"``, ``"N/m"``; None: anything); False after reporting E307.
        Only a dimension the units written determine is checked (see
        :func:`mbdsl.dsl.units.dimension`)."""
        try:
            got = units.dimension(expr, self.param_dims)
        except units.DimensionError as err:
            self.error("E307", f"{context}: {err}", err.span or span, "dimensions differ",
                       hint="add quantities of one kind; write plain numbers in SI")
            return False
        if want is None or got is None or got == units.expected(want):
            return True
        self.error("E307", f"{context}: expected {units.describe(units.expected(want))} "
                   f"[{want}], got {units.describe(got)}",
                   getattr(expr, "span", None) or span, f"not {units.describe(units.expected(want))}",
                   hint=f"write the value in {want} or a unit of the same kind, "
                   "or as a plain SI number")
        return False

    def number(self, expr, span, context, allow_t=False, unit=None):
        """Evaluate a constant expression (in SI; ``unit``: the SI unit its
        dimension must have, if any is written); None after reporting.
        A value is remembered per expression object: the copies a ``for``
        block makes share the parts that do not read its variable
        (:meth:`instantiate`), so ``mass m`` of 10 000 links is evaluated once."""
        memo = self._numbers
        key = (id(expr), unit, allow_t, len(self.params))     # parameters only grow
        hit = memo.get(key)
        if hit is not None and hit[0] is expr:
            return hit[1]
        if not self.dimension(expr, unit, span, context):
            return None
        try:
            value = evaluate(expr, self.params, allow_t=allow_t)
        except ExprError as err:
            self.expr_error(err, span, context)
            return None
        memo[key] = (expr, value)
        return value

    def angle(self, expr, span, context, unit="rad"):
        """A constant angle [rad] (or None after reporting); a plain number
        above 2 pi in magnitude gets W301 (degrees are the usual mistake)."""
        v = self.number(expr, span, context, unit=unit)
        if v is not None and abs(v) > 2 * math.pi + 1e-12 and not units.has_unit(expr):
            self.warning("W301", f"{context}: {v:g} rad is more than a full turn",
                         getattr(expr, "span", None) or span, "radians",
                         hint=f"plain numbers are radians; for degrees write '{v:g} deg'")
        return v

    def time_function(self, expr, span, context, unit=None) -> TimeFunction | None:
        """Compile f(t) with its exact first and second derivatives (``unit``:
        the SI unit of its value, checked as in :meth:`number`); None after
        reporting."""
        if not self.dimension(expr, unit, span, context):
            return None
        try:
            e = substitute(expr, self.params)
            f, d1 = compile_function(e), diff(e)
            d2 = diff(d1)
            fn = TimeFunction(f, compile_function(d1), compile_function(d2),
                              constant="t" not in free_names(e), expr=e)
            value = fn.f(0.0)
            if not math.isfinite(value):
                raise ExprError(f"the value at t = 0 is not finite ({value})", "E301",
                                getattr(expr, "span", None))
            return fn
        except ExprError as err:
            self.expr_error(err, span, context)
        except (ValueError, OverflowError, ZeroDivisionError) as exc:
            self.error("E301", f"{context}: cannot evaluate at t = 0 ({exc})",
                       getattr(expr, "span", None) or span)
        return None

    def state_variable(self, ref: Dotted) -> StateVariable:
        """The state variable of a reference in a force expression
        (``crank.omega``, ``O.angle``).

        Raises
        ------
        ExprError
            E201 for an unknown body or joint, E304 for a field it does not have.
        """
        obj = ref.obj if isinstance(ref.obj, str) else getattr(ref.obj, "text", "?")
        if obj in self.bodies:
            body = self.bodies[obj]
            if isinstance(body, FlexibleBeam):
                raise ExprError(f"'{ref.text}': force expressions read the state of rigid "
                                "bodies and joints, not of flexible beams", "E304", ref.span,
                                hint="use a rigid body or a joint")
            if ref.attr not in BODY_STATE:
                raise ExprError(f"'{ref.text}': a body's state in a force is one of "
                                f"{', '.join(BODY_STATE)}", "E304", ref.span,
                                hint=_did_you_mean(ref.attr, BODY_STATE)
                                or f"fields are {', '.join(BODY_STATE)}")
            level, j = BODY_STATE[ref.attr]
            if j == 2 and getattr(body, "particle", False):
                raise ExprError(f"'{ref.text}': particle '{obj}' does not turn (it has x, y, "
                                "vx, vy)", "E304", ref.span)
            return StateVariable(ref.text, level, ((body.index, j, 1.0),))
        if obj in self.joints and self.joints[obj].kind in ("prismatic", "point_on_line"):
            joint = self.joints[obj]
            if ref.attr not in SLIDING_STATE:
                raise ExprError(f"'{ref.text}': a force reads a {joint.kind} joint's "
                                f"{', '.join(SLIDING_STATE)}", "E304", ref.span,
                                hint=_did_you_mean(ref.attr, SLIDING_STATE)
                                or f"fields are {', '.join(SLIDING_STATE)}")
            line = self.sliding_line(joint, ref)
            return StateVariable(ref.text, SLIDING_STATE[ref.attr], (), line=line)
        if obj in self.joints:
            joint = self.joints[obj]
            if joint.kind != "revolute" or ref.attr not in REVOLUTE_STATE:
                allowed = ", ".join(REVOLUTE_STATE)
                raise ExprError(f"'{ref.text}': a force reads a revolute joint's {allowed}",
                                "E304", ref.span,
                                hint=(f"'{obj}' is a {joint.kind} joint"
                                      if joint.kind != "revolute" else
                                      _did_you_mean(ref.attr, REVOLUTE_STATE)
                                      or f"fields are {allowed}"))
            b1, b2 = joint.bodies
            for b in (b1, b2):
                if self.is_particle(b):
                    raise ExprError(f"'{ref.text}': the joint holds particle "
                                    f"'{self.model_body(b).name}', which does not turn", "E304",
                                    ref.span)
                if b != GROUND and isinstance(self.model_body(b), FlexibleBeam):
                    raise ExprError(f"'{ref.text}': the joint holds a flexible beam, whose "
                                    "rotation at the joint is not its frame's", "E304",
                                    ref.span)
            terms = tuple((b, 2, c) for b, c in ((b2, 1.0), (b1, -1.0)) if b != GROUND)
            return StateVariable(ref.text, REVOLUTE_STATE[ref.attr], terms)
        if obj in self.broken_bodies or obj in self.broken_names:
            raise _BrokenReference(ref.text, "E201", ref.span)
        raise ExprError(f"unknown body or joint '{obj}' in '{ref.text}'", "E201", ref.span,
                        name=obj, hint=_did_you_mean(obj, list(self.bodies) + list(self.joints))
                        or "a force reads the state of a body or a revolute joint")

    def sliding_line(self, joint, ref=None):
        """The geometry (body L, s_L, body P, s_P, u0) of a sliding joint's
        line (``model.elements.line_distance``).

        Raises
        ------
        ExprError
            E304 when a body of the joint is a flexible beam.
        """
        for b in joint.bodies:
            if b != GROUND and isinstance(self.model_body(b), FlexibleBeam):
                raise ExprError(f"'{ref.text if ref is not None else joint.name}': the joint "
                                "holds a flexible beam (its distance is read on rigid bodies "
                                "only)", "E304", ref.span if ref is not None else joint.span)
        first, second = joint.first, joint.second
        return (second.body, tuple(float(x) for x in second.local), first.body,
                tuple(float(x) for x in first.local),
                tuple(float(x) for x in joint.direction))

    def model_body(self, index):
        """The body with this index."""
        return next(b for b in self.bodies.values() if b.index == index)

    def force_function(self, expr, span, context, unit=None):
        """A force magnitude: f(t) (TimeFunction) when the expression reads no
        state, else f(t, state) (StateFunction) with its exact partial
        derivatives; None after reporting. ``unit``: as in :meth:`number`."""
        if not self.dimension(expr, unit, span, context):
            return None
        found: dict[str, StateVariable] = {}

        def resolve(ref):
            """The variable's name; records it."""
            var = self.state_variable(ref)
            found.setdefault(var.name, var)
            return var.name
        try:
            e = substitute(expr, self.params, resolve)
        except _BrokenReference:
            return None                 # a reference to a broken element: reported already
        except ExprError as err:
            self.expr_error(err, span, context)
            return None
        if not found:
            return self.time_function(expr, span, context, unit)
        variables = tuple(found.values())
        names = tuple(v.name for v in variables)
        try:
            grads = tuple(diff(e, name) for name in names)
        except ExprError as err:
            self.expr_error(err, span, context)
            return None
        return StateFunction(compile_state_function(e, names),
                             tuple(compile_state_function(g, names) for g in grads),
                             variables, expr=e, grad_exprs=grads)

    def claim(self, name, span, what):
        """Reserve an element name; False (after reporting) if reserved or taken."""
        if name == "ground":
            self.error("E202", f"'ground' is reserved and cannot name a {what}", span,
                       "reserved name", hint="choose another name")
            return False
        if name in self.element_spans:
            first = self.element_spans[name]
            self.error("E202", f"duplicate name '{name}'", span, f"second {what} named '{name}'",
                       hint="bodies, joints, forces and drivers share one namespace",
                       secondary=((first, "first declared here"),) if first else ())
            return False
        self.element_spans[name] = span
        return True

    def point(self, expr, span, context) -> PointRef | None:
        """Resolve ``body.point`` to a PointRef; None after reporting."""
        if not isinstance(expr, Dotted) or not isinstance(expr.obj, str):
            self.error("E305", f"{context}: expected a point like 'body.point'",
                       getattr(expr, "span", None) or span, "not a point reference",
                       hint="write e.g. 'crank.A' or 'ground.origin'")
            return None
        sp = expr.span or span
        if expr.obj == "ground":
            if expr.attr in self.ground_points:
                return PointRef(GROUND, self.ground_points[expr.attr], expr.text)
            if ("ground", expr.attr) in self.broken_points:
                return None           # its own error was reported where it is declared
            self.error("E201", f"{context}: the ground has no point '{expr.attr}'", sp,
                       "unknown point", hint=_did_you_mean(expr.attr, self.ground_points)
                       or "declare it in a 'ground { point NAME (x, y) }' block")
            return None
        body = self.bodies.get(expr.obj)
        if body is None:
            if expr.obj not in self.broken_bodies:
                self.error("E201", f"{context}: unknown body '{expr.obj}'", sp, "no body with this name",
                           hint=_did_you_mean(expr.obj, list(self.bodies) + ["ground"]))
            return None
        if expr.attr not in body.points:
            if (body.name, expr.attr) in self.broken_points:
                return None           # its own error was reported where it is declared
            self.error("E201", f"{context}: body '{body.name}' has no point '{expr.attr}'", sp,
                       "unknown point", hint=_did_you_mean(expr.attr, body.points)
                       or f"its points are {', '.join(sorted(body.points))}")
            return None
        return point_ref(body, expr.attr, expr.text)

    def vector(self, vec, span, context, unit="m"):
        """Evaluate a Vec to an ndarray of shape (2,) (components in the SI
        ``unit``, checked as in :meth:`number`); None after reporting."""
        if not isinstance(vec, Vec):
            self.error("E305", f"{context}: expected a vector '(x, y)'",
                       getattr(vec, "span", None) or span, "not a vector")
            return None
        x = self.number(vec.x, span, context, unit=unit)
        y = self.number(vec.y, span, context, unit=unit)
        if x is None or y is None:
            return None
        return np.array([x, y])

    def split_args(self, el, allowed: dict, n_positional: int, context: str):
        """Positional args (list) and keyword values (dict of ArgSpec)."""
        pos, kw = [], {}
        for a in el.args:
            if a.keyword is None:
                if kw:
                    self.error("E305", f"{context}: a positional argument after keyword arguments",
                               a.span or el.span, "move it before the keywords")
                pos.append(a)
            elif a.keyword not in allowed:
                self.error("E304", f"{context}: unknown option '{a.keyword}'", a.span or el.span,
                           "unknown option", hint=_did_you_mean(a.keyword, allowed)
                           or (f"options are {', '.join(allowed)}" if allowed else
                               "this element takes no options"))
            elif a.keyword in kw:
                self.error("E202", f"{context}: option '{a.keyword}' given twice",
                           a.span or el.span, "repeated option")
            else:
                kw[a.keyword] = a
        if len(pos) != n_positional:
            self.error("E305", f"{context}: expected {n_positional} positional argument"
                       f"{'s' if n_positional != 1 else ''}, got {len(pos)}",
                       el.kind_span or el.span, "wrong number of arguments")
            return None, kw
        missing = False
        for name, default in allowed.items():
            if default is None and name not in kw:
                self.error("E304", f"{context}: missing option '{name}'",
                           el.kind_span or el.span, f"'{name} = ...' is required")
                missing = True
        return (None if missing else pos), kw       # no element without its required options

    # -- loops and indexed names ------------------------------------------------
    def resolve_name(self, name, env, span):
        """``link[i]`` -> ``"link[3]"`` with the loop variables in env; None after reporting."""
        if not isinstance(name, IndexedName):
            return name
        try:
            value = evaluate(name.index, {**self.params, **env})
        except ExprError as err:
            self.expr_error(err, name.span or span, f"index of '{name.base}[...]'")
            return None
        if value != int(value):
            self.error("E301", f"the index of '{name.base}[...]' must be an integer, got {value:g}",
                       name.span or span, "not an integer")
            return None
        return f"{name.base}[{int(value)}]"

    def _scan(self, obj):
        """(whether ``obj`` holds an indexed name, the plain names it holds),
        remembered per object: a declaration's parts that hold neither an
        indexed name nor a loop variable are shared by every copy a ``for``
        block makes, not copied again (:meth:`instantiate`)."""
        memo = self._scanned
        hit = memo.get(id(obj))
        if hit is not None and hit[0] is obj:
            return hit[1], hit[2]
        if isinstance(obj, Name):
            out = (False, frozenset((obj.name,)))
        elif isinstance(obj, IndexedName):
            out = (True, frozenset())
        elif isinstance(obj, (str, int, float, bool, type(None), Span)):
            out = (False, frozenset())
        else:
            fields = None
            if isinstance(obj, tuple):
                parts = obj
            elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
                fields = [f.name for f in dataclasses.fields(obj)]
                parts = tuple(getattr(obj, f) for f in fields)
            else:
                parts = ()
            indexed, names, varying = False, frozenset(), []
            for k, x in enumerate(parts):
                i, n = self._scan(x)
                indexed, names = indexed or i, names | n if n else names
                if fields is not None and (i or n or fields[k] == "name"):
                    varying.append((fields[k], i, n))
            out = (indexed, names)
            if fields is not None:        # the fields a copy may change (:meth:`instantiate`)
                self._varying[id(obj)] = varying
        memo[id(obj)] = (obj, *out)
        return out

    def instantiate(self, obj, env, span=None):
        """A copy of a spec or expression with the loop variables in env
        substituted and every indexed name resolved; None after reporting.
        Parts that hold neither are the original objects (specs are not
        changed after parsing).

        Each declaration of a ``for`` block is compiled once per set of loop
        variables into a builder (:meth:`_builder`) that copies only the
        parts that read them: a block repeated 100 000 times costs one
        name resolution and one shallow copy per changed part, not a walk of
        the whole declaration."""
        build = self._builder(obj, frozenset(env))
        return obj if build is None else build(env, span)

    def _builder(self, obj, keys: frozenset):
        """A function (env, span) -> the instance of ``obj`` (or None after
        reporting) for loop variables ``keys``; None when ``obj`` reads none
        of them and holds no indexed name (the instance is ``obj``)."""
        memo = self._builders
        hit = memo.get((id(obj), keys))
        if hit is not None and hit[0] is obj:
            return hit[1]
        indexed, names = self._scan(obj)
        build = None if not indexed and names.isdisjoint(keys) else self._compile(obj, keys)
        memo[(id(obj), keys)] = (obj, build)
        return build

    def _compile(self, obj, keys):
        """The builder of :meth:`_builder` for an ``obj`` that needs one: a
        loop variable becomes its number, an indexed name its resolved name
        (``link[3]``; in a reference ``link[i].B`` the element's name as a
        string), a tuple and any other spec or expression node a copy with its
        changed parts built. Each builder takes (env, span) and returns the
        instance, or None after reporting."""
        sub = self._builder

        def part(x):
            """A child's builder, or a constant function for a shared child."""
            b = sub(x, keys)
            return b if b is not None else (lambda env, span, x=x: x)
        resolve = self.resolve_name
        if isinstance(obj, Name):
            return lambda env, span: Num(float(env[obj.name]), obj.span)
        if isinstance(obj, IndexedName):
            def build(env, span):
                """The Name of the resolved ``base[index]``."""
                name = resolve(obj, env, span)
                return None if name is None else Name(name, obj.span)
            return build
        if isinstance(obj, Dotted) and not isinstance(obj.obj, Dotted):    # link[i].B, ground.P[i]
            def build(env, span):
                """The reference with its element's and point's names resolved."""
                where = obj.span or span
                name, attr = resolve(obj.obj, env, where), resolve(obj.attr, env, where)
                return None if name is None or attr is None else Dotted(name, attr, obj.span)
            return build
        if isinstance(obj, tuple):
            items = [part(x) for x in obj]

            def build(env, span):
                """The tuple of its items' instances."""
                out = tuple(b(env, span) for b in items)
                return None if any(x is None for x in out) else out
            return build
        if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
            own = getattr(obj, "span", None)
            fields = []
            for field, f_indexed, f_names in self._varying[id(obj)]:   # (_scan)
                if field == "name":
                    fields.append((field, None))
                elif f_indexed or not f_names.isdisjoint(keys):
                    fields.append((field, part(getattr(obj, field))))

            cls, state = type(obj), obj.__dict__

            def build(env, span):
                """A shallow copy with the changed fields built."""
                span = own or span
                # a shallow copy with the changed fields (the specs' __post_init__
                # only normalises what they were given, which the parts already are;
                # copy.copy's protocol cost three times as much)
                new_obj = object.__new__(cls)
                new_obj.__dict__.update(state)
                for field, b in fields:
                    value = (resolve(getattr(obj, field), env, span) if b is None
                             else b(env, span))
                    if value is None:
                        return None
                    object.__setattr__(new_obj, field, value)
                return new_obj
            return build
        return None

    def expand_loops(self):
        """Flatten for blocks into concrete declarations, in source order."""
        keyed = {k: [] for k in _KINDS + ("ground_points",)}
        buckets = {"bodies": "bodies", "joints": "joints", "forces": "forces",
                   "drivers": "drivers", "initials": "initials"}

        def _key(item, iteration):
            sp = getattr(item, "span", None)
            return (sp.line, sp.column) if sp else (0, 0), iteration

        def _add(item, env, iteration):
            if isinstance(item, GroundSpec):           # ground points of a for block
                for p in item.points:
                    inst = self.instantiate(p, env)
                    if inst is not None:
                        keyed["ground_points"].append((_key(p, iteration), inst))
                return
            kind = {"BodySpec": "bodies", "BeamSpec": "bodies", "JointSpec": "joints", "ForceSpec": "forces",
                    "DriverSpec": "drivers", "InitialSpec": "initials"}[type(item).__name__]
            inst = self.instantiate(item, env)
            if inst is not None:
                keyed[buckets[kind]].append((_key(item, iteration), inst))

        def _loop(spec: ForSpec, env, iteration):
            if spec.var in self.params or spec.var in ("t", "pi") or spec.var in env:
                self.error("E202", f"the loop variable '{spec.var}' hides a parameter or an "
                           "outer loop variable", spec.span, "choose another name")
                return
            try:
                ctx = {**self.params, **env}
                lo = evaluate(self.instantiate(spec.start, env, spec.span), ctx)
                hi = evaluate(self.instantiate(spec.end, env, spec.span), ctx)
            except (ExprError, TypeError) as err:
                if isinstance(err, ExprError):
                    self.expr_error(err, spec.span, f"bounds of 'for {spec.var}'")
                return
            if lo != int(lo) or hi != int(hi):
                self.error("E301", f"the bounds of 'for {spec.var}' must be integers, got "
                           f"{lo:g}..{hi:g}", spec.span, "not integers")
                return
            count = int(hi) - int(lo) + 1
            if count > MAX_REPEAT:
                self.error("E303", f"'for {spec.var}' would repeat {count} times, more than "
                           f"{MAX_REPEAT}", spec.span, "too many repetitions")
                return
            for value in range(int(lo), int(hi) + 1):
                inner = {**env, spec.var: value}
                for item in spec.items:
                    if isinstance(item, ForSpec):
                        _loop(item, inner, iteration + (value,))
                    else:
                        _add(item, inner, iteration + (value,))

        for kind in _KINDS:
            for item in getattr(self.spec, kind):
                _add(item, {}, ())
        for p in self.spec.ground_points:              # indexed names resolve here too
            inst = self.instantiate(p, {})
            if inst is not None:
                keyed["ground_points"].append((_key(p, ()), inst))
        for spec in self.spec.loops:
            _loop(spec, {}, ())
        self.items = {k: [inst for _, inst in sorted(v, key=lambda kv: kv[0])]
                      for k, v in keyed.items()}

    # -- passes ---------------------------------------------------------------
    def check_parameters(self):
        """Evaluate parameters in order, applying overrides."""
        spans = {}
        for p in self.spec.parameters:
            if p.name in spans:
                self.error("E202", f"duplicate parameter '{p.name}'", p.span,
                           "declared again", secondary=((spans[p.name], "first declared here"),)
                           if spans[p.name] else ())
                continue
            spans[p.name] = p.span
            if p.name in ("t", "pi"):
                self.error("E202", f"'{p.name}' is reserved and cannot be a parameter", p.span,
                           "reserved name")
                continue
            if p.name in self.overrides:
                value = self.overrides.pop(p.name)
                if isinstance(value, str):
                    from .expressions import as_expr
                    try:
                        value = evaluate(as_expr(value), self.params)
                    except ExprError as err:
                        self.error("E301", f"--set {p.name}={value}: {err}", None)
                        self.broken_names.add(p.name)
                        continue
                    except Exception as exc:  # noqa: BLE001 - MbdSyntaxError of the override text
                        self.error("E301", f"--set {p.name}={value}: not a valid expression ({exc})", None)
                        self.broken_names.add(p.name)
                        continue
                value = float(value)
                if not math.isfinite(value):
                    self.error("E301", f"--set {p.name}: the value is not finite", None)
                    self.broken_names.add(p.name)
                    continue
                self.params[p.name] = value
                continue
            v = self.number(p.value, p.span, f"parameter '{p.name}'")
            if v is not None:
                self.params[p.name] = v
                # a parameter written with units has their dimension wherever it is used
                self.param_dims[p.name] = units.dimension(p.value, self.param_dims)
            else:
                self.broken_names.add(p.name)
        for name in self.overrides:
            self.error("E201", f"--set {name}: the model has no parameter '{name}'", None,
                       hint=_did_you_mean(name, spans) or
                       f"its parameters are {', '.join(spans) or '(none)'}")

    def check_ground(self):
        """Collect the ground's named points."""
        for p in self.items["ground_points"]:
            if p.name in self.ground_points:
                self.error("E202", f"duplicate ground point '{p.name}'", p.span, "declared again")
                continue
            v = self.vector(p.position, p.span, f"ground point '{p.name}'")
            if v is not None:
                self.ground_points[p.name] = v
            else:
                self.broken_points.add(("ground", p.name))

    def check_bodies(self):
        """Check mass, inertia and points of every rigid body, and every
        flexible beam (``check_beam``); then place the beams' elastic
        coordinates after the reference coordinates of all bodies."""
        self.broken_bodies = set()
        for b in self.items["bodies"]:
            if not self.claim(b.name, b.span, "body"):
                continue
            if isinstance(b, BeamSpec):
                self.check_beam(b)
                continue
            if b.particle:
                self.check_particle(b)
                continue
            props = {}
            for prop in b.properties:
                if prop.name not in ("mass", "inertia"):
                    self.error("E304", f"body '{b.name}': unknown property '{prop.name}'", prop.span,
                               "unknown property",
                               hint=_did_you_mean(prop.name, ["mass", "inertia", "point"])
                               or "a rigid body has 'mass', 'inertia' and 'point' lines")
                    continue
                if prop.name in props:
                    self.error("E202", f"body '{b.name}': '{prop.name}' given twice", prop.span,
                               "given again")
                    continue
                props[prop.name] = prop
            values = {}
            for key, unit in (("mass", "kg"), ("inertia", "kg m^2")):
                if key not in props:
                    self.error("E302", f"body '{b.name}' has no {key}", b.span, f"{key} missing",
                               hint=f"add '{key} VALUE' [{unit}]; there is no default")
                    continue
                v = self.number(props[key].value, props[key].span, f"{key} of body '{b.name}'",
                                unit=unit.replace(" ", "*"))
                if v is None:
                    continue
                if v <= 0:
                    self.error("E303", f"the {key} of body '{b.name}' must be positive, got {v:g} {unit}",
                               getattr(props[key].value, "span", None) or props[key].span,
                               "not positive", hint=f"a rigid body has positive {key}")
                    continue
                values[key] = v
            points = {"cm": np.zeros(2)}
            for p in b.points:
                if p.name in points:
                    self.error("E202", f"body '{b.name}': duplicate point '{p.name}'", p.span,
                               "declared again" if p.name != "cm" else "'cm' is the centre of mass, always defined")
                    continue
                v = self.vector(p.position, p.span, f"point '{b.name}.{p.name}'")
                if v is not None:
                    points[p.name] = v
                else:
                    self.broken_points.add((b.name, p.name))
            shapes = tuple(s for s in (self.shape(b.name, sp, points) for sp in b.shapes)
                           if s is not None)
            if len(values) == 2:
                self.bodies[b.name] = RigidBody(b.name, len(self.bodies), values["mass"],
                                                values["inertia"], points, b.span, shapes)
            else:
                self.broken_bodies.add(b.name)
        offset = sum(2 if getattr(b, "particle", False) else 3 for b in self.bodies.values())
        for name, b in self.bodies.items():
            if isinstance(b, FlexibleBeam):
                self.bodies[name] = dataclasses.replace(b, elastic_offset=offset)
                offset += b.n_elastic

    def check_particle(self, b):
        """A particle (point mass): a positive mass, no inertia, no points
        but ``cm``; shapes are drawn at its position without turning."""
        ctx = f"particle '{b.name}'"
        mass = None
        for prop in b.properties:
            if prop.name != "mass":
                self.error("E304", f"{ctx}: unknown property '{prop.name}'", prop.span,
                           "unknown property",
                           hint="a particle has a mass only: it does not turn, so it has no "
                           "inertia (declare a body for that)" if prop.name == "inertia"
                           else _did_you_mean(prop.name, ["mass"]) or "a particle has a 'mass'")
                continue
            if mass is not None:
                self.error("E202", f"{ctx}: 'mass' given twice", prop.span, "given again")
                continue
            mass = self.number(prop.value, prop.span, f"mass of {ctx}", unit="kg")
            if mass is not None and not mass > 0:
                self.error("E303", f"the mass of {ctx} must be positive, got {mass:g} kg",
                           getattr(prop.value, "span", None) or prop.span, "not positive")
                mass = None
            mass = mass if mass is not None else float("nan")
        if mass is None:
            self.error("E302", f"{ctx} has no mass", b.span, "mass missing",
                       hint="add 'mass VALUE' [kg]; there is no default")
        for p in b.points:
            self.error("E304", f"{ctx}: a particle has one point, 'cm' (its position)", p.span,
                       "a point off the particle",
                       hint="joints and forces attach at NAME.cm; for points that turn with "
                       "the mass, declare a body")
        points = {"cm": np.zeros(2)}
        shapes = tuple(s for s in (self.shape(b.name, sp, points) for sp in b.shapes)
                       if s is not None)
        if mass is None or not math.isfinite(mass) or b.points:
            self.broken_bodies.add(b.name)
            return
        self.bodies[b.name] = RigidBody(b.name, len(self.bodies), mass, 0.0, points, b.span,
                                        shapes, particle=True)

    def is_particle(self, index) -> bool:
        """Whether body ``index`` is a particle (the ground is not)."""
        return index != GROUND and getattr(self.model_body(index), "particle", False)

    def turning(self, bodies, ctx, span, what) -> bool:
        """False (after reporting E305) when one of ``bodies`` is a particle:
        ``what`` (a rotation, a relative angle...) needs bodies that turn."""
        for b in bodies:
            if self.is_particle(b):
                name = self.model_body(b).name
                self.error("E305", f"{ctx}: {what}, and particle '{name}' does not turn",
                           span, "a particle has no angle",
                           hint="a particle has coordinates x, y only; declare a body "
                           "(mass and inertia) where a rotation matters")
                return False
        return True

    #: shape kind -> (fewest points, most points, takes a radius)
    SHAPES = {"line": (2, 2, False), "circle": (1, 1, True), "polygon": (3, None, False)}

    def shape(self, body, sp, points):
        """A Shape of body ``body`` from its ShapeSpec; None after reporting.
        Points are the body's point names (``points``) or (x, y) in its frame."""
        ctx = f"shape {sp.kind} of body '{body}'"
        if sp.kind not in self.SHAPES:
            self.error("E205", f"body '{body}': unknown shape '{sp.kind}'", sp.kind_span or sp.span,
                       "unknown shape", hint=_did_you_mean(sp.kind, self.SHAPES)
                       or f"shapes are {', '.join(self.SHAPES)}")
            return None
        lo, hi, has_radius = self.SHAPES[sp.kind]
        args = list(sp.args)
        if any(a.keyword is not None for a in args):
            a = next(a for a in args if a.keyword is not None)
            self.error("E304", f"{ctx}: shapes take no options, got '{a.keyword}'",
                       a.span or sp.span, "unknown option",
                       hint="write the points, then a circle's radius: circle(cm, 0.05)")
            return None
        radius = 0.0
        if has_radius:
            if len(args) != 2:
                self.error("E305", f"{ctx}: expected a centre point and a radius, got "
                           f"{len(args)} argument{'s' if len(args) != 1 else ''}",
                           sp.kind_span or sp.span, "circle(point, radius)")
                return None
            r = self.number(args[1].value, args[1].span or sp.span, ctx, unit="m")
            if r is None:
                return None
            if not r > 0:
                self.error("E303", f"{ctx}: the radius must be positive, got {r:g} m",
                           args[1].span or sp.span, "not positive")
                return None
            radius, args = r, args[:1]
        if len(args) < lo or (hi is not None and len(args) > hi):
            want = f"{lo}" if lo == hi else f"at least {lo}"
            self.error("E305", f"{ctx}: expected {want} points, got {len(args)}",
                       sp.kind_span or sp.span, "wrong number of points")
            return None
        xy = []
        for a in args:
            v = a.value
            if isinstance(v, Name) and not isinstance(v, Vec):
                if v.name not in points:
                    self.error("E201", f"{ctx}: body '{body}' has no point '{v.name}'",
                               a.span or sp.span, "unknown point",
                               hint=_did_you_mean(v.name, points)
                               or "name a point of the body, or give (x, y) in its frame")
                    return None
                xy.append(np.asarray(points[v.name], float))
                continue
            if not isinstance(v, Vec):
                self.error("E305", f"{ctx}: expected a point name or (x, y), got an expression",
                           a.span or sp.span, "not a point")
                return None
            p = self.vector(v, a.span or sp.span, ctx)
            if p is None:
                return None
            xy.append(p)
        return Shape(sp.kind, np.array(xy, float).reshape(-1, 2), radius)

    #: flexible beam properties -> (unit, must be an integer)
    BEAM_PROPERTIES = {"length": ("m", False), "E": ("Pa", False), "area": ("m^2", False),
                       "second_moment": ("m^4", False), "elements": ("", True),
                       "mass": ("kg", False), "density": ("kg/m^3", False),
                       "modes": ("", True)}

    def check_beam(self, b: BeamSpec):
        """Check a flexible beam: positive properties, mass or density (one),
        an integer element count, a known frame, points on the beam."""
        ctx = f"flexible beam '{b.name}'"
        props, values = {}, {}
        stiffening = True
        for prop in b.properties:
            if prop.name == "stiffening":         # stiffening on | off
                v = prop.value
                if isinstance(v, Name) and v.name in ("on", "off"):
                    stiffening = v.name == "on"
                else:
                    self.error("E304", f"{ctx}: 'stiffening' is 'on' or 'off'",
                               getattr(v, "span", None) or prop.span, "expected on or off",
                               hint="geometric stiffening (the axial force's bending stiffness) "
                               "is on by default; 'stiffening off' keeps the linear beam")
                continue
            if prop.name not in self.BEAM_PROPERTIES:
                self.error("E304", f"{ctx}: unknown property '{prop.name}'", prop.span,
                           "unknown property", hint=_did_you_mean(prop.name, self.BEAM_PROPERTIES)
                           or "a flexible beam has " + ", ".join(self.BEAM_PROPERTIES)
                           + ", 'frame' and 'point NAME at x' lines")
                continue
            if prop.name in props:
                self.error("E202", f"{ctx}: '{prop.name}' given twice", prop.span, "given again")
                continue
            props[prop.name] = prop
        for key, (unit, integer) in self.BEAM_PROPERTIES.items():
            if key not in props:
                continue
            v = self.number(props[key].value, props[key].span, f"{key} of {ctx}",
                            unit=unit or None)
            if v is None:
                continue
            sp = getattr(props[key].value, "span", None) or props[key].span
            if not v > 0 or not math.isfinite(v):
                self.error("E303", f"the {key} of {ctx} must be positive, got {v:g} {unit}".rstrip(),
                           sp, "not positive")
                continue
            if integer and v != int(v):
                what = "number of elements" if key == "elements" else "number of modes"
                self.error("E301", f"the {what} of {ctx} must be an integer, got {v:g}",
                           sp, "not an integer")
                continue
            values[key] = v
        ok = True
        for key in ("length", "E", "area", "second_moment", "elements"):
            if key not in props:
                unit = self.BEAM_PROPERTIES[key][0]
                self.error("E302", f"{ctx} has no {key}", b.span, f"{key} missing",
                           hint=f"add '{key} VALUE'" + (f" [{unit}]" if unit else "")
                           + "; there is no default")
                ok = False
        if ("mass" in props) == ("density" in props):
            self.error("E302", f"{ctx} needs exactly one of 'mass' [kg] and 'density' [kg/m^3]",
                       b.span, "give mass or density",
                       hint="the mass per length is mass/length or density*area")
            ok = False
        frame = b.frame or "first_node"
        if frame not in FRAMES:
            self.error("E304", f"{ctx}: unknown frame '{frame}'", b.frame_span or b.span,
                       "unknown frame", hint=_did_you_mean(frame, FRAMES)
                       or f"frames are {', '.join(FRAMES)}")
            ok = False
        if not ok or len(values) != len(props):
            self.broken_bodies.add(b.name)
            return
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
            self.error("E303", f"{ctx}: its mass, inertia or element stiffness is out of the "
                       "floating-point range (overflows or vanishes)", b.span, "out of range",
                       hint="check the units (SI: m, kg, Pa, m^2, m^4) and the number of elements")
            self.broken_bodies.add(b.name)
            return
        mass = float(mass)
        modes = int(values.get("modes", 0))
        nf = 3 * int(values["elements"])         # 3 per node, less the frame's three
        if modes > nf:
            self.error("E303", f"{ctx}: {modes} modes, but its {int(values['elements'])} "
                       f"elements have {nf} elastic coordinates", props["modes"].span,
                       "too many modes", hint=f"give at most {nf} modes, or more elements")
            self.broken_bodies.add(b.name)
            return
        points = {"start": 0.0, "end": length}
        for p in b.points:
            if p.name in points:
                self.error("E202", f"{ctx}: duplicate point '{p.name}'", p.span,
                           "declared again" if p.name not in ("start", "end")
                           else f"'{p.name}' is always defined")
                continue
            at = p.at
            if isinstance(at, Name) and at.name in ("start", "end") and at.name not in self.params:
                x = 0.0 if at.name == "start" else length
            else:
                x = self.number(at, p.span, f"point '{b.name}.{p.name}'", unit="m")
                if x is None:
                    continue
            if not -1e-12 * length <= x <= length * (1 + 1e-12):
                self.error("E306", f"point '{b.name}.{p.name}' at {x:g} m is not on the beam "
                           f"(0 .. {length:g} m)", getattr(at, "span", None) or p.span,
                           "off the beam", hint="give the arc length from the first node, "
                           "'start' or 'end'")
                continue
            points[p.name] = min(max(x, 0.0), length)
        self.bodies[b.name] = FlexibleBeam(b.name, len(self.bodies), mass, length, values["E"],
                                           values["area"], values["second_moment"],
                                           int(values["elements"]), frame, points, span=b.span,
                                           stiffening=stiffening, modes=modes)

    def check_joints(self):
        """Resolve joint points and options; reject joints of a body to itself."""
        for j in self.items["joints"]:
            ok = self.claim(j.name, j.span, "joint")
            ctx = f"joint '{j.name}'"
            if j.kind not in JOINT_KINDS:
                self.error("E205", f"{ctx}: unknown joint type '{j.kind}'", j.kind_span or j.span,
                           "unknown joint type", hint=_did_you_mean(j.kind, JOINT_KINDS)
                           or f"joint types are {', '.join(JOINT_KINDS)}")
                continue
            npos, allowed, rows = JOINT_KINDS[j.kind]
            pos, kw = self.split_args(j, allowed, npos, ctx)
            if pos is None:
                continue
            first = self.point(pos[0].value, pos[0].span or j.span, ctx)
            second = self.point(pos[1].value, pos[1].span or j.span, ctx)
            direction, angle = None, 0.0
            if "direction" in kw:
                direction = self.vector(kw["direction"].value, kw["direction"].span, ctx,
                                        unit=None)
                if direction is not None:
                    norm = float(np.hypot(*direction))
                    if norm == 0.0 or not math.isfinite(norm):
                        self.error("E306", f"{ctx}: the direction must be a non-zero vector",
                                   kw["direction"].span, "zero direction")
                        direction = None
                    else:
                        direction = direction / norm
                if direction is None:
                    continue
            if "angle" in kw:
                angle = self.angle(kw["angle"].value, kw["angle"].span, f"{ctx}: angle")
                if angle is None:
                    continue
            length = 0.0
            if "length" in kw:
                length = self.number(kw["length"].value, kw["length"].span, ctx, unit="m")
                if length is None:
                    continue
                if not length > 0:
                    self.error("E303", f"{ctx}: the length must be positive, got {length:g} m",
                               kw["length"].span, "not positive",
                               hint="a distance joint holds two points a positive distance "
                               "apart; for coincident points use a revolute joint")
                    continue
            if first is None or second is None or not ok:
                continue
            locks = {"fixed": (first.body, second.body), "prismatic": (first.body, second.body),
                     "point_on_line": (second.body,)}.get(j.kind, ())
            if not self.turning(locks, ctx, j.span, f"a {j.kind} joint "
                                + ("holds its line in the second body's frame"
                                   if j.kind == "point_on_line" else "locks a relative angle")):
                continue
            if first.body == second.body:
                what = "the ground" if first.body == GROUND else f"body '{pos[0].value.obj}'"
                self.error("E402", f"{ctx} connects {what} to itself", j.span,
                           "both points on one body",
                           hint="a joint connects two different bodies")
                continue
            self.joints[j.name] = Joint(j.name, j.kind, first, second, direction, angle,
                                        rows, j.span, length)

    #: the SI unit of a driven quantity
    DRIVER_UNITS = {"x": "m", "y": "m", "phi": "rad", "angle": "rad", "distance": "m"}

    def check_drivers(self):
        """Resolve driver targets (body coordinate or joint angle) and compile f(t)."""
        self.drivers = []
        for d in self.items["drivers"]:
            ok = self.claim(d.name, d.span, "driver")
            ctx = f"driver '{d.name}'"
            tgt = d.target
            fn = self.time_function(d.value, d.span, ctx, unit=self.DRIVER_UNITS.get(tgt.attr))
            if tgt.obj in self.joints:
                joint = self.joints[tgt.obj]
                sliding = joint.kind in ("prismatic", "point_on_line")
                if tgt.attr not in ("angle", "distance") or (tgt.attr == "distance"
                                                             and not sliding):
                    self.error("E201", f"{ctx}: a {joint.kind} joint is driven by its "
                               + ("'angle' or 'distance'" if sliding else "'angle'"),
                               tgt.span or d.span, "unknown joint quantity",
                               hint=f"write '{tgt.obj}.angle'" if not sliding else
                               f"write '{tgt.obj}.distance' (along the line, from its point)")
                    continue
                if tgt.attr == "angle" and not self.turning(joint.bodies, ctx, tgt.span or d.span,
                                                            "a joint angle is a relative rotation"):
                    continue
                if ok and fn:
                    kind = "joint_distance" if tgt.attr == "distance" else "joint_angle"
                    self.drivers.append(Driver(d.name, kind, fn, joint=joint, span=d.span))
                continue
            body = self.bodies.get(tgt.obj)
            if body is None:
                if tgt.obj not in self.broken_bodies and tgt.obj not in self.element_spans:
                    self.error("E201", f"{ctx}: unknown body or joint '{tgt.obj}'", tgt.span or d.span,
                               "not declared",
                               hint=_did_you_mean(tgt.obj, list(self.bodies) + list(self.joints)))
                continue
            if tgt.attr not in COORDINATES:
                self.error("E201", f"{ctx}: '{tgt.attr}' is not a coordinate", tgt.span or d.span,
                           "unknown coordinate", hint=_did_you_mean(tgt.attr, COORDINATES)
                           or "a body is driven by its x, y or phi")
                continue
            if tgt.attr == "phi" and not self.turning([body.index], ctx, tgt.span or d.span,
                                                      "a driven angle needs a body that turns"):
                continue
            if ok and fn:
                self.drivers.append(Driver(d.name, "coordinate", fn, body=body.index,
                                           coord=COORDINATES.index(tgt.attr), span=d.span))

    #: the SI unit of a force option (friction's speeds are m/s or rad/s by joint: unchecked)
    FORCE_UNITS = {("spring_damper", "k"): "N/m", ("spring_damper", "c"): "N*s/m",
                   ("spring_damper", "length"): "m", ("rotational_spring_damper", "k"): "N*m/rad",
                   ("rotational_spring_damper", "c"): "N*m*s/rad",
                   ("rotational_spring_damper", "angle"): "rad", ("friction", "mu"): "1",
                   ("friction", "mu_static"): "1", ("friction", "radius"): "m",
                   ("contact", "radius"): "m", ("contact", "exponent"): "1",
                   ("contact", "restitution"): "1", ("contact", "mu"): "1",
                   ("contact", "v_reg"): "m/s", ("limit", "exponent"): "1",
                   ("limit", "restitution"): "1"}

    def check_forces(self):
        """Check force options (required, non-negative) and build force elements."""
        self.forces = []
        for f in self.items["forces"]:
            ok = self.claim(f.name, f.span, "force")
            ctx = f"force '{f.name}'"
            if f.kind not in FORCE_KINDS:
                self.error("E205", f"{ctx}: unknown force type '{f.kind}'", f.kind_span or f.span,
                           "unknown force type", hint=_did_you_mean(f.kind, FORCE_KINDS)
                           or f"force types are {', '.join(FORCE_KINDS)}")
                continue
            allowed = FORCE_KINDS[f.kind]
            npos = {"spring_damper": 2, "rotational_spring_damper": 1, "torque": 2,
                    "joint_torque": 2, "joint_force": 2, "force": 2, "friction": 1,
                    "contact": 1, "limit": 1}[f.kind]
            pos, kw = self.split_args(f, allowed, npos, ctx)
            if pos is None:
                continue
            opts = {}
            for name, default in allowed.items():
                if name in kw and name in _GEOMETRY_OPTIONS:
                    opts[name] = kw[name]
                elif name in kw:
                    v = (self.angle if name == "angle" else self.number)(
                        kw[name].value, kw[name].span, f"{ctx}: {name}",
                        unit=self.FORCE_UNITS.get((f.kind, name)))
                    if v is None:
                        break
                    if name in ("k", "c", "mu", "mu_static", "viscous", "v_stribeck",
                                "radius") and v < 0:
                        self.error("E303", f"{ctx}: '{name}' must not be negative, got {v:g}",
                                   kw[name].span, "negative",
                                   hint="a negative stiffness, damping or friction coefficient "
                                   "feeds energy in")
                        break
                    if name == "v_reg" and not v > 0:
                        self.error("E303", f"{ctx}: the regularisation speed 'v_reg' must be "
                                   f"positive, got {v:g}", kw[name].span, "not positive",
                                   hint="the friction force reaches mu N at a few v_reg: "
                                   "1e-4 m/s (or rad/s) suits most machines")
                        break
                    if name == "length" and v < 0:
                        self.error("E303", f"{ctx}: the free length must not be negative, got {v:g} m",
                                   kw[name].span, "negative length")
                        break
                    opts[name] = v
                elif default is not None:
                    opts[name] = default
                else:
                    break
            else:
                el = self.force_element(f, pos, opts, ctx)
                if el is not None and ok:
                    self.forces.append(el)

    def contact_element(self, f, pos, opts, ctx):
        """A ``contact`` (a circle against a line or in a hole) or a ``limit``
        (a joint's angle or distance between bounds): one-sided gaps of
        :mod:`mbdsl.model.contact`; None after reporting."""
        from ..model.contact import Contact, contact_geometry_circle, contact_geometry_line
        for name, hint in (("restitution", "a coefficient of restitution is in (0, 1]: 1 keeps "
                            "the energy, 0.8 is a hard ball, small values a dead impact"),
                           ("exponent", "1 for a linear law, 1.5 for Hertz's sphere")):
            v = opts[name]
            bad = not (0.0 < v <= 1.0) if name == "restitution" else not v >= 1.0
            if bad:
                span = next((a.span for a in f.args if a.keyword == name), f.span)
                self.error("E303", f"{ctx}: '{name}' = {v:g} is out of range", span,
                           "out of range", hint=hint)
                return None
        if not opts["k"] > 0:
            self.error("E303", f"{ctx}: the contact stiffness 'k' must be positive",
                       next((a.span for a in f.args if a.keyword == "k"), f.span), "not positive")
            return None
        common = (opts["k"], opts["exponent"], opts["restitution"], f.span)
        if f.kind == "limit":
            joint = self.joint_argument(pos[0], f, ctx)
            if joint is None:
                return None
            lower, upper = opts["lower"], opts["upper"]
            if math.isnan(lower) and math.isnan(upper):
                self.error("E305", f"{ctx}: a limit needs 'lower', 'upper' or both", f.span,
                           "no bound", hint="e.g. limit(O, lower = -pi/4, upper = pi/4, k = 1e5)")
                return None
            if not (math.isnan(lower) or math.isnan(upper)) and not lower < upper:
                self.error("E303", f"{ctx}: 'lower' ({lower:g}) must be below 'upper' ({upper:g})",
                           f.span, "empty range")
                return None
            if joint.kind == "revolute":
                if not self.turning(joint.bodies, ctx, f.span, "a limit on an angle turns bodies"):
                    return None
                pair = (joint.first.body, None, joint.second.body, None)
                gaps = tuple(("angle", pair + (b, sign), label)
                             for b, sign, label in ((lower, 1.0, "lower"), (upper, -1.0, "upper"))
                             if not math.isnan(b))
            elif joint.kind in ("prismatic", "point_on_line"):
                try:
                    line = self.sliding_line(joint)
                except ExprError as err:
                    self.expr_error(err, f.span, ctx)
                    return None
                gaps = tuple(("slide", line + (b, sign), label)
                             for b, sign, label in ((lower, 1.0, "lower"), (upper, -1.0, "upper"))
                             if not math.isnan(b))
            else:
                self.error("E305", f"{ctx}: a limit acts on a revolute's angle or a prismatic or "
                           f"point_on_line joint's distance; '{joint.name}' is a {joint.kind} joint",
                           getattr(pos[0].value, "span", None) or f.span, "no motion to limit")
                return None
            return Contact(f.name, "limit", gaps, *common)
        centre = self.point(pos[0].value, pos[0].span or f.span, ctx)
        if centre is None:
            return None
        given = [g for g in _GEOMETRY_OPTIONS if not isinstance(opts[g], float)]
        if len(given) != 1:
            self.error("E305", f"{ctx}: a contact needs one of 'line = (point, (dx, dy))' or "
                       "'circle = (point, radius)'", f.span,
                       "no geometry" if not given else "two geometries",
                       hint="a circle against a line: line = (ground.origin, (1, 0)); "
                       "in a hole: circle = (slot.c, 0.0105)")
            return None
        arg = opts[given[0]]
        val = arg.value
        shape_ok = isinstance(val, Vec) and (isinstance(val.y, Vec) == (given[0] == "line"))
        if not shape_ok:
            self.error("E305", f"{ctx}: expected {given[0]} = "
                       + ("(point, (dx, dy))" if given[0] == "line" else "(point, radius)"),
                       arg.span or f.span, "not a " + given[0])
            return None
        other = self.point(val.x, arg.span or f.span, ctx)
        if other is None:
            return None
        for p in (centre, other):
            if p.body != GROUND and isinstance(self.model_body(p.body), FlexibleBeam):
                self.error("E304", f"{ctx}: contacts act between rigid bodies; '{p.text}' is on "
                           "a flexible beam", f.span, "flexible beam",
                           hint="attach a rigid body to the beam and put the contact on it")
                return None
        if centre.body == other.body:
            self.error("E402", f"{ctx} puts a body in contact with itself", f.span, "no effect")
            return None
        radius = opts["radius"]
        if given[0] == "line":
            dx = self.number(val.y.x, arg.span or f.span, ctx)
            dy = self.number(val.y.y, arg.span or f.span, ctx)
            if dx is None or dy is None:
                return None
            if dx == 0.0 and dy == 0.0:
                self.error("E303", f"{ctx}: the line's direction is zero", arg.span or f.span,
                           "zero direction")
                return None
            return Contact(f.name, "contact",
                           (contact_geometry_line(centre, radius, other, (dx, dy)),), *common,
                           mu=opts["mu"], v_reg=opts["v_reg"])
        hole = self.number(val.y, arg.span or f.span, ctx, unit="m")
        if hole is None:
            return None
        if not hole > radius:
            self.error("E303", f"{ctx}: the hole's radius ({hole:g} m) must exceed the pin's "
                       f"({radius:g} m)", arg.span or f.span, "no clearance",
                       hint="a pin as large as its hole is a revolute joint")
            return None
        return Contact(f.name, "contact",
                       (contact_geometry_circle(centre, radius, other, hole),), *common,
                       mu=opts["mu"], v_reg=opts["v_reg"])

    def joint_argument(self, arg, f, ctx) -> Joint | None:
        """The joint a force names as its first argument; None after reporting
        (silently for a joint whose own error is reported)."""
        ref = arg.value
        if isinstance(ref, Name) and ref.name in self.joints:
            return self.joints[ref.name]
        name = ref.name if isinstance(ref, Name) else "?"
        # a claimed name that is no body is a joint whose own error is reported
        if not (isinstance(ref, Name) and name in self.element_spans and name not in self.bodies):
            self.error("E201", f"{ctx}: expected the name of a joint, got '{name}'",
                       getattr(ref, "span", None) or f.span, "not a joint",
                       hint=_did_you_mean(name, self.joints)
                       or (f"'{name}' is a body" if name in self.bodies else ""))
        return None

    def force_element(self, f, pos, opts, ctx):
        """Build one force element from checked arguments; None after reporting."""
        if f.kind == "spring_damper":
            a = self.point(pos[0].value, pos[0].span or f.span, ctx)
            b = self.point(pos[1].value, pos[1].span or f.span, ctx)
            if a is None or b is None:
                return None
            if a.body == b.body:
                self.error("E402", f"{ctx} connects a body to itself", f.span, "no effect",
                           hint="a spring-damper acts between two different bodies")
                return None
            return SpringDamper(f.name, a, b, opts["k"], opts["c"], opts["length"], f.span)
        if f.kind == "rotational_spring_damper":
            joint = self.joint_argument(pos[0], f, ctx)
            if joint is None or not self.turning(joint.bodies, ctx, f.span,
                                                 "a rotational spring acts on a relative angle"):
                return None
            return RotationalSpringDamper(f.name, joint, opts["k"], opts["c"], opts["angle"],
                                          f.span)
        if f.kind == "torque":
            ref = pos[0].value
            if not isinstance(ref, Name) or ref.name not in self.bodies:
                name = ref.name if isinstance(ref, Name) else "?"
                if name not in self.broken_bodies:
                    self.error("E201", f"{ctx}: expected the name of a body, got '{name}'",
                               getattr(ref, "span", None) or f.span, "not a body",
                               hint=_did_you_mean(name, self.bodies))
                return None
            if not self.turning([self.bodies[ref.name].index], ctx, f.span,
                                "a torque turns a body"):
                return None
            fn = self.force_function(pos[1].value, pos[1].span or f.span, ctx, unit="N*m")
            return Torque(f.name, self.bodies[ref.name].index, fn, f.span) if fn else None
        if f.kind == "joint_torque":
            joint = self.joint_argument(pos[0], f, ctx)
            if joint is None:
                return None
            ref = pos[0].value
            if joint.kind != "revolute":
                self.error("E305", f"{ctx}: a joint torque acts in a revolute joint; "
                           f"'{joint.name}' is a {joint.kind} joint",
                           getattr(ref, "span", None) or f.span, "not a revolute joint",
                           hint="apply torque(body, ...) to one of its bodies instead")
                return None
            if not self.turning(joint.bodies, ctx, f.span, "a joint torque turns its bodies"):
                return None
            fn = self.force_function(pos[1].value, pos[1].span or f.span, ctx, unit="N*m")
            return JointTorque(f.name, joint, fn, f.span) if fn else None
        if f.kind == "joint_force":
            joint = self.joint_argument(pos[0], f, ctx)
            if joint is None:
                return None
            if joint.kind not in ("prismatic", "point_on_line"):
                self.error("E305", f"{ctx}: a joint force acts along a prismatic or point_on_line "
                           f"joint; '{joint.name}' is a {joint.kind} joint",
                           getattr(pos[0].value, "span", None) or f.span, "not a sliding joint",
                           hint="use joint_torque for a revolute joint")
                return None
            try:
                self.sliding_line(joint)
            except ExprError as err:
                self.expr_error(err, f.span, ctx)
                return None
            fn = self.force_function(pos[1].value, pos[1].span or f.span, ctx, unit="N")
            return JointForce(f.name, joint, fn, f.span) if fn else None
        if f.kind == "friction":
            return self.friction_element(f, pos, opts, ctx)
        if f.kind in ("contact", "limit"):
            return self.contact_element(f, pos, opts, ctx)
        # point force
        p = self.point(pos[0].value, pos[0].span or f.span, ctx)
        vec = pos[1].value
        if not isinstance(vec, Vec):
            self.error("E305", f"{ctx}: expected the force as a vector '(fx, fy)'",
                       pos[1].span or f.span, "not a vector")
            return None
        fx = self.time_function(vec.x, pos[1].span or f.span, ctx, unit="N")
        fy = self.time_function(vec.y, pos[1].span or f.span, ctx, unit="N")
        if p is None or fx is None or fy is None:
            return None
        if p.body == GROUND:
            self.error("E402", f"{ctx} acts on the ground", f.span, "no effect",
                       hint="apply the force to a moving body")
            return None
        return PointForce(f.name, p, fx, fy, f.span)

    def friction_element(self, f, pos, opts, ctx):
        """A Friction element from checked options; None after reporting."""
        joint = self.joint_argument(pos[0], f, ctx)
        if joint is None:
            return None
        span = getattr(pos[0].value, "span", None) or f.span
        kw = {a.keyword: a for a in f.args if a.keyword is not None}
        if joint.kind in ("fixed", "distance"):
            self.error("E305", f"{ctx}: friction acts in a revolute, prismatic or point_on_line "
                       f"joint; '{joint.name}' is a {joint.kind} joint", span,
                       f"no sliding surface in a {joint.kind} joint",
                       hint="friction(J, ...) takes a revolute, prismatic or point_on_line joint")
            return None
        radius = opts["radius"]
        if joint.kind == "revolute" and not self.turning(
                joint.bodies, ctx, f.span, "friction in a revolute joint brakes a relative rotation"):
            return None
        if joint.kind == "revolute":
            if np.isnan(radius):
                self.error("E304", f"{ctx}: friction in a revolute joint needs the pin's "
                           "'radius' (m)", f.kind_span or f.span, "'radius = ...' is required",
                           hint="the friction torque is mu r |reaction|")
                return None
        else:
            if not np.isnan(radius):
                self.error("E304", f"{ctx}: 'radius' is for revolute joints; '{joint.name}' is "
                           f"a {joint.kind} joint", kw["radius"].span or f.span,
                           "not a revolute joint",
                           hint="a sliding joint's friction force is mu |normal reaction|")
                return None
            radius = 1.0
            try:
                self.sliding_line(joint)
            except ExprError as err:
                self.expr_error(err, f.span, ctx)
                return None
        mu = opts["mu"]
        mu_s = mu if np.isnan(opts["mu_static"]) else opts["mu_static"]
        if mu_s != mu and opts["v_stribeck"] == 0.0:
            self.error("E304", f"{ctx}: 'mu_static' differs from 'mu' but no 'v_stribeck' "
                       "says at which speed", kw["mu_static"].span or f.span,
                       "needs v_stribeck",
                       hint="mu(z) = mu + (mu_static - mu) exp(-(z/v_stribeck)^2): "
                       "give v_stribeck = ... (m/s or rad/s)")
            return None
        return Friction(f.name, joint, mu, mu_s, opts["v_stribeck"], opts["viscous"],
                        opts["v_reg"], radius, f.span)

    def check_gravity(self):
        """Evaluate the gravity vector, or None when not declared."""
        if self.spec.gravity is None:
            return None
        return self.vector(self.spec.gravity, self.spec.gravity_span, "gravity", unit="m/s^2")

    #: What an output may read besides bodies, points and joints: result columns.
    OUTPUT_GROUPS = {"energy": ("kinetic", "potential", "total", "work", "dissipated", "balance"),
                     "constraint": ("position", "velocity")}

    def output_variable(self, ref: Dotted) -> OutputVariable:
        """The quantity of a reference in an ``output`` expression.

        Raises
        ------
        ExprError
            E201 for an unknown body, point, joint or driver; E304 for a
            field it does not have.
        """
        from ..model.elements import ACCELERATIONS

        def fail(msg, code="E304", hint=""):
            """The error of this reference."""
            return ExprError(f"'{ref.text}': {msg}", code, ref.span, hint=hint)
        if isinstance(ref.obj, Dotted):            # body.point.field, reaction.J.fx, driver.D.force
            head, mid, attr = ref.obj.obj, ref.obj.attr, ref.attr
            if head == "lambda":
                return self._multiplier_variable(ref, mid, attr, fail)
            sensors = self._sensor_elements()
            if isinstance(head, str) and head in sensors:       # stop.lower.gap
                return self._sensor_variable(ref, sensors[head], mid, attr, fail)
            kind = {"reaction": "joints", "driver": "drivers"}.get(head)
            if kind and mid in {x.name for x in self.items[kind]} \
                    and mid not in self.joints and mid not in {d.name for d in self.drivers}:
                # declared, but left out after an error reported at its declaration
                raise _BrokenReference(ref.text, "E201", ref.span)
            if head == "reaction":
                if mid not in self.joints or attr not in ("fx", "fy", "torque"):
                    raise fail("a reaction is reaction.<joint>.fx|fy|torque",
                               "E201" if mid not in self.joints else "E304",
                               _did_you_mean(mid, self.joints))
                return OutputVariable(ref.text, "column", column=ref.text)
            if head == "driver":
                drivers = {d.name: d for d in self.drivers}
                if mid not in drivers:
                    raise fail("no such driver", "E201", _did_you_mean(mid, drivers))
                d = drivers[mid]
                force = (d.kind == "coordinate" and d.coord < 2) or d.kind == "joint_distance"
                want = "force" if force else "torque"
                if attr != want:
                    raise fail(f"driver '{mid}' applies a {want}", hint=f"write driver.{mid}.{want}")
                return OutputVariable(ref.text, "column", column=ref.text)
            body = self.bodies.get(head) if isinstance(head, str) else None
            if body is None:
                raise fail(f"unknown body '{head}'", "E201",
                           _did_you_mean(str(head), list(self.bodies) + ["reaction", "driver"]))
            if mid not in body.points:
                raise fail(f"body '{head}' has no point '{mid}'", "E201",
                           _did_you_mean(mid, body.points))
            if isinstance(body, FlexibleBeam):
                fields = ("x", "y", "vx", "vy", "deflection")
                if attr not in fields:
                    raise fail("a beam point's field is x, y, vx, vy or deflection",
                               hint=_did_you_mean(attr, fields))
                self.output_units[ref.text] = "m/s" if attr[0] == "v" else "m"
                return OutputVariable(ref.text, "beam_point", field=attr,
                                      bodies=(body.index,), arc=float(body.points[mid]))
            if attr not in ("x", "y", "vx", "vy"):
                raise fail("a point's field is x, y, vx or vy",
                           hint=_did_you_mean(attr, ("x", "y", "vx", "vy")))
            return OutputVariable(ref.text, "point", point=point_ref(body, mid, ref.text),
                                  field=attr)
        obj, attr = ref.obj, ref.attr
        if obj in self.OUTPUT_GROUPS:
            if attr not in self.OUTPUT_GROUPS[obj]:
                raise fail(f"{obj} columns are {', '.join(self.OUTPUT_GROUPS[obj])}",
                           hint=_did_you_mean(attr, self.OUTPUT_GROUPS[obj]))
            return OutputVariable(ref.text, "column", column=ref.text)
        sensors = self._sensor_elements()
        if obj in sensors:
            return self._sensor_variable(ref, sensors[obj], None, attr, fail)
        if obj in self.bodies:
            fields = COORDINATES + VELOCITIES + ACCELERATIONS
            if getattr(self.bodies[obj], "particle", False):
                fields = ("x", "y", "vx", "vy", "ax", "ay")
            if isinstance(self.bodies[obj], FlexibleBeam):     # and its elastic coordinates
                names = self.bodies[obj].mesh.names
                elastic = tuple(names) + tuple(f"{x}_t" for x in names) + tuple(
                    f"{x}_tt" for x in names)
                if attr in elastic:
                    self.output_units[ref.text] = units.column_unit(ref.text)
                    return OutputVariable(ref.text, "column", column=ref.text)
                fields = fields + elastic
            if attr not in fields:
                raise fail(f"a body's fields are {', '.join(fields)}",
                           hint=_did_you_mean(attr, fields) or "or a point: body.point.x")
            return OutputVariable(ref.text, "column", column=ref.text)
        if obj in self.joints:
            j = self.joints[obj]
            if j.kind in ("prismatic", "point_on_line"):
                if attr not in SLIDING_STATE:
                    raise fail("an output reads a sliding joint's distance or speed",
                               hint=_did_you_mean(attr, SLIDING_STATE))
                try:
                    line = self.sliding_line(j, ref)
                except ExprError as err:
                    raise fail(str(err.args[0]))
                return OutputVariable(ref.text, "joint", field=attr, bodies=j.bodies, line=line)
            if j.kind != "revolute" or attr not in ("angle", "rate"):
                raise fail("an output reads a revolute joint's angle or rate, or a sliding "
                           "joint's distance or speed",
                           hint=f"'{obj}' is a {j.kind} joint" if j.kind != "revolute"
                           else _did_you_mean(attr, ("angle", "rate")))
            if any(self.is_particle(b) for b in j.bodies):
                raise fail("the joint holds a particle, which does not turn")
            return OutputVariable(ref.text, "joint", field=attr, bodies=j.bodies)
        if obj in self.element_spans or obj in self.broken_bodies:
            raise _BrokenReference(ref.text, "E201", ref.span)     # its own error is reported
        raise fail(f"unknown body or joint '{obj}'", "E201",
                   _did_you_mean(str(obj), list(self.bodies) + list(self.joints)
                                 + list(self.OUTPUT_GROUPS)))

    #: An angle limit's gap sensors, in its units (a gap between points: SENSOR_UNITS).
    ANGLE_GAP_UNITS = {"gap": "rad", "gap_rate": "rad/s", "normal": "N*m", "friction": "",
                       "power": "W", "energy": "J"}

    def _sensor_elements(self) -> dict:
        """Contacts, limits, friction elements and spring-dampers by name (what
        sensors read)."""
        from ..model.contact import Contact
        return {f.name: f for f in getattr(self, "forces", ())
                if isinstance(f, (Contact, Friction, SpringDamper, RotationalSpringDamper))}

    def _multiplier_variable(self, ref, mid, attr, fail) -> OutputVariable:
        """``lambda.<joint or driver>.<row>``: a Lagrange multiplier by name."""
        from ..model.elements import multiplier_unit
        elements = dict(self.joints)
        elements.update({d.name: d for d in self.drivers})
        if mid not in elements:
            raise fail("a multiplier is lambda.<joint or driver>.<row>", "E201",
                       _did_you_mean(str(mid), elements))
        rows = getattr(elements[mid], "rows", 1)
        if not (isinstance(attr, str) and attr.isdigit() and int(attr) < rows):
            raise fail(f"'{mid}' has multiplier rows 0 .. {rows - 1}")
        column = f"lambda.{mid}.{int(attr)}"
        self.output_units[ref.text] = multiplier_unit(elements[mid], int(attr))
        return OutputVariable(ref.text, "column", column=column)

    def _sensor_variable(self, ref, element, label, attr, fail) -> OutputVariable:
        """What a contact, limit (``floor.normal``, ``stop.upper.gap``),
        friction element (``f.friction``) or spring-damper (``spring.tension``)
        does at the stored rows."""
        from ..model.contact import Contact
        from ..model.elements import SENSOR_UNITS
        kind = {Friction: "friction", SpringDamper: "spring",
                RotationalSpringDamper: "rotational"}.get(type(element))
        if kind is not None:
            fields = SENSOR_UNITS[kind]
            if label is not None or attr not in fields:
                raise fail(f"a {kind} element's fields are {', '.join(fields)}",
                           hint=_did_you_mean(str(attr), fields))
            index = [f.name for f in self.forces if type(f) is type(element)].index(element.name)
            unit = fields[attr]
            if kind == "friction" and element.joint.kind == "revolute":
                unit = {"speed": "rad/s", "friction": "N*m", "power": "W"}[attr]
            self.output_units[ref.text] = unit
            return OutputVariable(ref.text, kind, field=attr, index=index)
        labels = [g[2] for g in element.gaps]
        if label is None and len(labels) > 1:
            raise fail(f"'{element.name}' has gaps {', '.join(labels)}: name one",
                       hint=f"write {element.name}.{labels[0]}.{attr}")
        if label is not None and label not in labels:
            raise fail(f"'{element.name}' has no gap '{label}'", "E201",
                       _did_you_mean(str(label), labels))
        if attr not in SENSOR_UNITS["gap"]:
            raise fail("a gap's fields are " + ", ".join(SENSOR_UNITS["gap"]),
                       hint=_did_you_mean(str(attr), SENSOR_UNITS["gap"]))
        k = labels.index(label) if label is not None else 0
        index = sum(len(f.gaps) for f in self.forces[:self.forces.index(element)]
                    if isinstance(f, Contact)) + k
        angle = element.gaps[k][0] == "angle"
        self.output_units[ref.text] = (self.ANGLE_GAP_UNITS if angle
                                       else SENSOR_UNITS["gap"])[attr]
        return OutputVariable(ref.text, "gap", field=attr, index=index)

    def check_outputs(self):
        """``output NAME = expr`` lines: names unique, references resolved."""
        self.outputs = []
        self.output_units = {}      # reference -> SI unit, where its element decides it
        seen = {}
        for o in self.spec.outputs:
            if o.name in seen:
                self.error("E202", f"output '{o.name}' is declared twice", o.span, "second one",
                           secondary=((seen[o.name], "first declared here"),) if seen[o.name]
                           else ())
                continue
            seen[o.name] = o.span
            found = {}

            def resolve(ref):
                """The variable's name; records it."""
                var = self.output_variable(ref)
                found.setdefault(var.name, var)
                return var.name
            value = self.instantiate(o.value, {}, o.span)      # crank[1].T.x -> "crank[1]"
            if value is None:
                continue
            try:
                e = substitute(value, self.params, resolve)
            except _BrokenReference:
                continue                # a reference to a broken element: reported already
            except ExprError as err:
                self.expr_error(err, o.span, f"output '{o.name}'")
                continue
            try:
                dim = units.dimension(value, self.param_dims, self._reference_dimension)
            except units.DimensionError as err:
                self.error("E307", f"output '{o.name}': {err}", err.span or o.span,
                           "dimensions differ")
                continue
            unit = units.unit_text(dim)
            named = self.output_units.get(getattr(value, "text", None))
            if named and isinstance(value, Dotted):      # a sensor alone: its own unit (J, not N*m)
                unit = named
            self.outputs.append(Output(o.name, e, tuple(found.values()), o.span, unit))

    def _reference_dimension(self, ref):
        """The dimension of an output's reference: by its element where that
        decides it (``output_units``), else by its last part."""
        unit = self.output_units.get(getattr(ref, "text", None))
        if unit is not None:
            return units.expected(unit) if unit else None
        return units.reference_dimension(ref)

    #: the SI unit of a body coordinate or velocity
    INITIAL_UNITS = {"x": "m", "y": "m", "phi": "rad", "vx": "m/s", "vy": "m/s", "omega": "rad/s"}

    def check_initials(self):
        """Resolve initial and guess lines; reject unknown fields and repeats."""
        self.initials = []
        seen = {}
        for ic in self.items["initials"]:
            tgt = ic.target
            kw = "guess" if ic.guess else "initial"
            body = self.bodies.get(tgt.obj)
            if body is None:
                if tgt.obj not in self.broken_bodies:
                    self.error("E201", f"{kw}: unknown body '{tgt.obj}'", tgt.span or ic.span,
                               "no body with this name",
                               hint=_did_you_mean(tgt.obj, self.bodies))
                continue
            if tgt.attr not in COORDINATES + VELOCITIES:
                self.error("E502", f"{kw}: '{tgt.attr}' is not a coordinate or velocity of a body",
                           tgt.span or ic.span, "unknown field",
                           hint=_did_you_mean(tgt.attr, COORDINATES + VELOCITIES)
                           or "use x, y, phi, vx, vy or omega")
                continue
            if getattr(body, "particle", False) and tgt.attr in ("phi", "omega"):
                self.error("E502", f"{kw}: particle '{tgt.obj}' does not turn: it has x, y, vx "
                           "and vy", tgt.span or ic.span, "a particle has no angle")
                continue
            key = (tgt.obj, tgt.attr)
            if key in seen:
                self.error("E502", f"{kw}: '{tgt.text}' is given twice", ic.span, "given again",
                           secondary=((seen[key], "first given here"),) if seen[key] else ())
                continue
            seen[key] = ic.span
            if tgt.attr == "phi":
                v = self.angle(ic.value, ic.span, f"{kw} {tgt.text}")
            else:
                v = self.number(ic.value, ic.span, f"{kw} {tgt.text}",
                                unit=self.INITIAL_UNITS[tgt.attr])
            if v is not None:
                self.initials.append(InitialCondition(body.index, tgt.attr, v, ic.guess, ic.span))

    def check_settings(self):
        """Check the simulate section (known method, positive h and t_end,
        method coefficients in range)."""
        self.settings = {}
        spans = {}
        for s in self.spec.settings:
            if s.name in self.settings:
                self.error("E202", f"simulate: '{s.name}' is given twice", s.span, "given again")
                continue
            if s.name == "method":
                if s.value not in KNOWN_METHODS:
                    self.error("E206", f"simulate: unknown method '{s.value}'", s.span,
                               "unknown method", hint=_did_you_mean(s.value, KNOWN_METHODS)
                               or f"methods are {', '.join(KNOWN_METHODS)}")
                    continue
                self.settings["method"] = s.value
                continue
            if s.name == "formulation":         # formulation lagrange | augmented
                v = s.value
                if isinstance(v, Name) and v.name in ("lagrange", "augmented"):
                    self.settings["formulation"] = v.name
                else:
                    self.error("E304", "simulate: 'formulation' is 'lagrange' or 'augmented'",
                               getattr(v, "span", None) or s.span, "unknown formulation",
                               hint="'augmented' runs through singular positions and "
                               "redundant joints (newmark, hht-i3, nstiff, genalpha)")
                continue
            if s.name not in SETTINGS:
                self.error("E304", f"simulate: unknown setting '{s.name}'", s.span, "unknown setting",
                           hint=_did_you_mean(s.name, list(SETTINGS) + ["method", "formulation"])
                           or f"settings are method, formulation, {', '.join(SETTINGS)}")
                continue
            v = self.number(s.value, s.span, f"simulate: {s.name}",
                            unit="s" if s.name in ("h", "t_end", "t_start", "output_dt")
                            else None if s.name == "atol" else "1")   # atol: m or rad
            if v is None:
                continue
            if SETTINGS[s.name] and v <= 0:
                self.error("E303", f"simulate: '{s.name}' must be positive, got {v:g}",
                           getattr(s.value, "span", None) or s.span, "not positive")
                continue
            self.settings[s.name] = v
            spans[s.name] = getattr(s.value, "span", None) or s.span
        self._check_coefficients(spans)

    def _check_coefficients(self, spans):
        """Method coefficients in their ranges, each against the methods that use
        it (alpha: the HHT family; beta, gamma: newmark; b: hht-add), so that a
        file never reaches the integrator with a value it would refuse."""
        st = self.settings
        groups, claimed = [], set()      # each coefficient against the first method taking it
        for method, coefs in METHOD_COEFFICIENTS.items():
            names = tuple(c for c in coefs if c not in claimed)
            claimed.update(names)
            if names:
                groups.append((method, names))
        for method, names in groups:
            given = {k: st[k] for k in names if k in st}
            if not given:
                continue
            gamma = st.get("gamma", METHOD_COEFFICIENTS["newmark"]["gamma"])
            try:
                for k, v in given.items():      # in the constructor's order: gamma, beta
                    check_coefficient(k, v, gamma=gamma)
            except ValueError as exc:
                name = next(iter(given))
                self.error("E303", f"simulate: {exc}", spans.get(name), "out of range")
                for k in given:
                    st.pop(k, None)

    def check_structure(self, model: Model):
        """Connectivity to the ground (the DOF are judged by the assembly)."""
        # more equations than coordinates is not decided here: the rows may be
        # redundant (E401) or inconsistent (E503), which the assembly tells apart
        # and names the joints (assembly/structure.py)
        from ..model.contact import Contact
        touching = {data[k] for f in model.forces if isinstance(f, Contact)
                    for _, data, _ in f.gaps for k in (0, 2)}
        for body_index in graph.bodies_not_connected_to_ground(model):
            if body_index in touching:          # held by a contact: free between impacts
                continue
            b = model.bodies[body_index]
            self.warning("W401", f"body '{b.name}' is not connected to the ground by joints",
                         b.span, "floats freely",
                         hint="that is fine for a free body; otherwise add a joint")
        # initial conditions against the DOF are judged by the assembly, by rank
        # (``initial.dof_diagnostic``): counting would blame an 'initial' line for
        # what a redundant joint does (E401)


def point_ref(body, name: str, text: str) -> PointRef:
    """The PointRef of point ``name`` of a rigid body or a flexible beam.

    A beam point at arc length x has u_bar0 = (x, 0) and depends on the
    elastic coordinates of its element (the non-zero columns of S(x)).
    """
    if not isinstance(body, FlexibleBeam):
        return PointRef(body.index, body.points[name], text)
    x = body.points[name]
    S = body.mesh.shape(x)[0]
    used = np.flatnonzero(np.any(S != 0.0, axis=0))
    return PointRef(body.index, np.array([x, 0.0]), text,
                    elastic_columns=body.elastic_offset + used, elastic_shape=S[:, used])


@paused
def check_spec(spec: ModelSpec, overrides: dict | None = None) -> Model:
    """Check a model specification and resolve it into a :class:`Model`.

    Parameters
    ----------
    spec : ModelSpec
        As parsed (``parse_text``) or built in Python.
    overrides : dict of str -> float or str, optional
        Parameter values replacing the declared ones (``--set``).

    Returns
    -------
    Model
        With any warnings in ``model.warnings``.

    Raises
    ------
    MbdModelError
        Carrying every diagnostic (errors and warnings) when there is at
        least one error.
    """
    c = _Checker(spec, overrides)
    c.check_parameters()
    c.expand_loops()
    c.check_ground()
    c.check_bodies()
    gravity = c.check_gravity()
    c.check_joints()
    c.check_drivers()
    c.check_forces()
    c.check_initials()
    c.check_outputs()
    c.check_settings()
    source = spec.source or ""
    model = Model(
        name=spec.name, bodies=tuple(c.bodies.values()), ground_points=c.ground_points,
        joints=tuple(c.joints.values()), drivers=tuple(c.drivers), forces=tuple(c.forces),
        gravity=gravity, initials=tuple(c.initials), settings=c.settings,
        parameters=dict(c.params), file=spec.file, source=spec.source,
        sha256=hashlib.sha256(source.encode()).hexdigest() if spec.source else "",
        static=bool(spec.static), static_span=spec.static_span, outputs=tuple(c.outputs))
    if not any(d.is_error for d in c.diags):
        c.check_structure(model)
    if any(d.is_error for d in c.diags):
        errors = [d for d in c.diags if d.is_error]
        raise MbdModelError(f"{len(errors)} error{'s' if len(errors) != 1 else ''} in "
                            f"{spec.file}", c.diags)
    return Model(**{**model.__dict__, "warnings": tuple(c.diags)})
