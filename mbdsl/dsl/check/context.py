"""What every pass shares: the diagnostics, the elements resolved so far, and the
helpers that read numbers, points, vectors, time functions and joint references
with a diagnostic at the right place when they cannot.

The helpers' diagnostics: E201 (an unknown name, with did-you-mean), E202 (a
name declared twice), E205 (an unknown joint or force type), E301 (a value that
does not evaluate), E304/E305 (unknown keywords, wrong arguments), E307 (a
value of the wrong dimension), W301 (a plain angle above a full turn: degrees
written without a unit?).
"""

from __future__ import annotations

from collections import ChainMap

import difflib
import math

import numpy as np

from ...errors import Diagnostic, Span
from ...model.elements import GROUND, FlexibleBeam, Joint, PointRef, RigidBody, TimeFunction
from .. import units
from ..expressions import (compile_function, diff, Dotted, evaluate, ExprError, free_names,
                           IndexedName, Name, substitute, Vec)
from ..spec import ModelSpec


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


class BrokenReference(ExprError):
    """A reference to an element whose own error is reported (not reported again)."""


def plain_target(tgt):
    """An initial line's or a driver's target ``a.b.c`` (no instance of that
    path: ``components.flatten`` folds those) as ``Dotted("a.b", "c")``, so
    that it is reported as an unknown body or joint by its written name."""
    if isinstance(tgt.obj, Dotted):
        return Dotted(tgt.obj.text, tgt.attr, tgt.span)
    return tgt


def did_you_mean(name: str, candidates) -> str:
    """A hint: the closest of ``candidates`` to ``name`` as "did you mean ...?", or ""."""
    close = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.6)
    return f"did you mean '{close[0]}'?" if close else ""


class CheckContext:
    """The state of one check of a :class:`~mbdsl.dsl.spec.ModelSpec`.

    The passes (``check_spec``) read and extend it in order: ``params`` after
    the parameters' pass, ``items`` (the flattened declarations) after the
    loops', then ``bodies``, ``joints``, ``drivers``, ``forces``, ``initials``,
    ``outputs`` and ``settings``. Every diagnostic goes to ``diags``; a name
    whose own error is reported is in ``broken_names`` (bodies:
    ``broken_bodies``, points: ``broken_points``) so that its uses are not
    reported again.

    Parameters
    ----------
    spec : ModelSpec
        As parsed or built in Python.
    overrides : dict of str -> float or str, optional
        ``--set`` values; the parameters' pass removes those it applies.
    """

    def __init__(self, spec: ModelSpec, overrides: dict | None):
        self.spec = spec
        self.overrides = dict(overrides or {})
        self.diags: list[Diagnostic] = []
        self.params: dict[str, float] = {}
        self.tables: dict = {}                          # name -> model.table.Table
        self.states: dict[str, int] = {}                # first-order state name -> index
        self.first_order: list = []                     # FirstOrderState, in order
        self.param_dims: dict[str, units.Dimension | None] = {}
        self.bodies: dict[str, RigidBody] = {}
        #: 2 (planar) or 3 (``space 3d``): the components of every point and vector
        self.space = int(getattr(spec, "space", 2))
        self.ground_points: dict[str, np.ndarray] = {"origin": np.zeros(self.space)}
        #: a spatial model's ground axes (world frame): x, y, z and its ``axis`` lines
        self.ground_axes: dict[str, np.ndarray] = {k: v for k, v in zip("xyz", np.eye(3))}
        self.joints: dict[str, Joint] = {}
        self.element_spans: dict[str, Span | None] = {}
        # names whose own error is reported: their uses are not reported again
        self.broken_names: set[str] = set()
        self.broken_points: set[tuple[str, str]] = set()
        # per spec object (keyed by id, the object kept to check it is the same one):
        # what it holds (_scan), its fields a copy may change, its builders, its value
        self.scanned: dict = {}
        self.varying: dict = {}
        self.builders: dict = {}
        self._numbers: dict = {}
        # what the passes resolve, in their order (``check_spec``)
        self.items: dict[str, list] = {}               # the declarations, ``for`` flattened
        self.broken_bodies: set[str] = set()
        self.drivers: list = []
        self.couplers: list = []
        self.forces: list = []
        self.initials: list = []
        self.outputs: list = []
        self.output_units: dict[str, str] = {}         # reference -> SI unit, by its element
        self.settings: dict = {}

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
            hint = did_you_mean(err.name, list(self.params) + ["pi"])
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
        if self._vector_for_number(expr, span, context):
            return None
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

    def _vector_for_number(self, expr, span, context) -> bool:
        """True after reporting E305 when a vector stands where a number is
        expected (``inertia (1, 2, 3)`` in a planar model)."""
        if not isinstance(expr, Vec):
            return False
        self.error("E305", f"{context}: expected a number, got a vector",
                   expr.span or span, "a vector",
                   hint="a spatial model ('space 3d') takes a body's inertia as (J1, J2, J3); "
                   "here give one value" if self.space == 2 else "give one value")
        return True

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
        if self._vector_for_number(expr, span, context):
            return None
        if not self.dimension(expr, unit, span, context):
            return None
        try:
            e = substitute(expr, self.params, tables=self.tables)
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

    def known_kind(self, element, kinds, what: str, ctx: str) -> bool:
        """Whether a joint's or force's kind is one of ``kinds``; E205 with a
        did-you-mean hint if not."""
        if element.kind in kinds:
            return True
        self.error("E205", f"{ctx}: unknown {what} type '{element.kind}'",
                   element.kind_span or element.span, f"unknown {what} type",
                   hint=did_you_mean(element.kind, kinds)
                   or f"{what} types are {', '.join(kinds)}")
        return False

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
                       "unknown point", hint=did_you_mean(expr.attr, self.ground_points)
                       or "declare it in a 'ground { point NAME (x, y) }' block")
            return None
        body = self.bodies.get(expr.obj)
        if body is None:
            if expr.obj not in self.broken_bodies:
                self.error("E201", f"{context}: unknown body '{expr.obj}'", sp, "no body with this name",
                           hint=did_you_mean(expr.obj, list(self.bodies) + ["ground"]))
            return None
        if expr.attr not in body.points:
            if (body.name, expr.attr) in self.broken_points:
                return None           # its own error was reported where it is declared
            self.error("E201", f"{context}: body '{body.name}' has no point '{expr.attr}'", sp,
                       "unknown point", hint=did_you_mean(expr.attr, body.points)
                       or f"its points are {', '.join(sorted(body.points))}")
            return None
        return point_ref(body, expr.attr, expr.text)

    def vector(self, vec, span, context, unit="m"):
        """Evaluate a Vec to an ndarray of shape (2,), or (3,) in a spatial
        model (components in the SI ``unit``, checked as in :meth:`number`);
        None after reporting (E305: not a vector, or a vector of the other
        space's size)."""
        want = "(x, y, z)" if self.space == 3 else "(x, y)"
        if not isinstance(vec, Vec):
            self.error("E305", f"{context}: expected a vector '{want}'",
                       getattr(vec, "span", None) or span, "not a vector")
            return None
        if (vec.z is not None) != (self.space == 3):
            self.error("E305", f"{context}: expected a vector '{want}', got "
                       f"{3 if vec.z is not None else 2} components",
                       vec.span or span, f"a vector of {self.space}",
                       hint="a spatial model starts with 'space 3d'; its points and vectors "
                       "have three components" if self.space == 2 else
                       "this model is spatial ('space 3d'): write '(x, y, z)'")
            return None
        parts = [vec.x, vec.y] + ([vec.z] if self.space == 3 else [])
        values = [self.number(e, span, context, unit=unit) for e in parts]
        if any(v is None for v in values):
            return None
        return np.array(values)

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
                           "unknown option", hint=did_you_mean(a.keyword, allowed)
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
        base = name.base
        if isinstance(base, IndexedName):          # l[i].s[j]: an array in an indexed instance
            base = self.resolve_name(base, env, span)
            if base is None:
                return None
        index = name.index
        try:           # the parameters grow with a model's instances: not copied per name
            value = (env[index.name] if isinstance(index, Name) and index.name in env else
                     evaluate(index, ChainMap(env, self.params)))
        except ExprError as err:
            self.expr_error(err, name.span or span, f"index of '{base}[...]'")
            return None
        if value != int(value):
            self.error("E301", f"the index of '{base}[...]' must be an integer, got {value:g}",
                       name.span or span, "not an integer")
            return None
        return f"{base}[{int(value)}]{name.suffix}"

    def model_body(self, index):
        """The body with this index."""
        return next(b for b in self.bodies.values() if b.index == index)

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
        return joint.line

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
                       hint=did_you_mean(name, self.joints)
                       or (f"'{name}' is a body" if name in self.bodies else ""))
        return None
