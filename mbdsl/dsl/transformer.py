"""Parse tree -> :class:`~mbdsl.dsl.spec.ModelSpec`.

Runs as its own pass (never passed into ``Lark(...)``, which would lose
``meta``). Methods follow the grammar's order; no name is resolved and no
physics happens here.
"""

from __future__ import annotations

import re

from lark import Token, Transformer, v_args

from ..errors import Diagnostic, MbdSyntaxError, Span
from . import spec as S
from . import units
from .expressions import Binary, Call, Cond, Dotted, IndexedName, Name, Num, Unary, Vec

__all__ = ["ToSpec"]

#: a QUANTITY token split into the number and the unit as written
_QUANTITY = re.compile(r"((?:\d+(?:\.\d+)?|\.\d+)(?:[eE][+-]?\d+)?)[ \t]*(\S+)")


class ToSpec(Transformer):
    """Build spec objects from a Lark tree of ``mbd.lark``.

    Parameters
    ----------
    file : str
        File name recorded in every :class:`~mbdsl.errors.Span`.
    source : str
        The text, stored on the resulting ModelSpec.
    """

    def __init__(self, file: str, source: str):
        super().__init__()
        self.file, self.source = file, source

    def _span(self, meta) -> Span | None:
        if getattr(meta, "empty", True):
            return None
        return Span(self.file, meta.line, meta.column, meta.end_line, meta.end_column)

    def _tspan(self, tok: Token) -> Span:
        return Span(self.file, tok.line, tok.column, tok.end_line, tok.end_column)

    # -- 1. file and model header ------------------------------------------
    @v_args(meta=True)
    def start(self, meta, children):
        """The whole file -> ModelSpec, statements sorted into their kinds."""
        header, *items = children
        buckets = {k: [] for k in ("parameters", "ground_points", "bodies", "joints",
                                   "forces", "drivers", "initials", "settings", "loops",
                                   "outputs")}
        gravity, gspan, static = None, None, None
        for it in items:
            if isinstance(it, tuple) and it and it[0] == "static":
                static = it[1]
            elif isinstance(it, S.ParameterSpec):
                buckets["parameters"].append(it)
            elif isinstance(it, tuple) and it and it[0] == "gravity":
                gravity, gspan = it[1], it[2]
            elif isinstance(it, S.GroundSpec):
                buckets["ground_points"].extend(it.points)
            elif isinstance(it, (S.BodySpec, S.BeamSpec)):
                buckets["bodies"].append(it)
            elif isinstance(it, S.JointSpec):
                buckets["joints"].append(it)
            elif isinstance(it, S.ForceSpec):
                buckets["forces"].append(it)
            elif isinstance(it, S.DriverSpec):
                buckets["drivers"].append(it)
            elif isinstance(it, S.InitialSpec):
                buckets["initials"].append(it)
            elif isinstance(it, S.ForSpec):
                buckets["loops"].append(it)
            elif isinstance(it, S.OutputSpec):
                buckets["outputs"].append(it)
            elif isinstance(it, list):
                buckets["settings"].extend(it)
        return S.ModelSpec(name=header[0], gravity=gravity, gravity_span=gspan,
                           file=self.file, source=self.source, span=header[1],
                           static=static is not None, static_span=static, **buckets)

    @v_args(meta=True)
    def static_decl(self, meta, children):
        """``initial static`` -> ("static", span)."""
        return ("static", self._span(meta))

    @v_args(meta=True)
    def model_decl(self, meta, children):
        """``model NAME`` -> (name, span)."""
        return (str(children[0]), self._tspan(children[0]))

    # -- 2. declarations -----------------------------------------------------
    @v_args(meta=True)
    def parameter_decl(self, meta, children):
        """``parameter NAME = expr`` -> ParameterSpec."""
        return S.ParameterSpec(str(children[0]), children[1], self._tspan(children[0]))

    @v_args(meta=True)
    def gravity_decl(self, meta, children):
        """``gravity (gx, gy)`` -> ('gravity', Vec, span)."""
        return ("gravity", children[0], self._span(meta))

    @v_args(meta=True)
    def ground_decl(self, meta, children):
        """``ground { point ... }`` -> GroundSpec."""
        return S.GroundSpec(tuple(children), self._span(meta))

    @v_args(meta=True)
    def for_block(self, meta, children):
        """``for VAR in a..b { ... }`` -> ForSpec."""
        var, start, end, *items = children
        return S.ForSpec(str(var), start, end, tuple(items), self._span(meta))

    @v_args(meta=True)
    def indexed_name(self, meta, children):
        """``link[i]`` as a declared name -> IndexedName."""
        return IndexedName(str(children[0]), children[1], self._span(meta))

    def _name(self, x):
        return x if isinstance(x, IndexedName) else str(x)

    def _nspan(self, x):
        return x.span if isinstance(x, IndexedName) else self._tspan(x)

    def _body(self, children, particle):
        name, *items = children
        props = tuple(i for i in items if isinstance(i, S.PropertySpec))
        points = tuple(i for i in items if isinstance(i, S.PointSpec))
        shapes = tuple(i for i in items if isinstance(i, S.ShapeSpec))
        return S.BodySpec(self._name(name), props, points, self._nspan(name), shapes,
                          particle=particle)

    @v_args(meta=True)
    def body_decl(self, meta, children):
        """``body NAME { ... }`` -> BodySpec."""
        return self._body(children, False)

    @v_args(meta=True)
    def particle_decl(self, meta, children):
        """``particle NAME { ... }`` -> BodySpec(particle=True)."""
        return self._body(children, True)

    @v_args(meta=True)
    def shape_decl(self, meta, children):
        """``shape kind(args)`` -> ShapeSpec."""
        kind, *args = children
        return S.ShapeSpec(str(kind), tuple(args), self._span(meta), self._tspan(kind))

    @v_args(meta=True)
    def beam_decl(self, meta, children):
        """``flexible_beam NAME { ... }`` -> BeamSpec."""
        name, *items = children
        props = tuple(i for i in items if isinstance(i, S.PropertySpec))
        points = tuple(i for i in items if isinstance(i, S.BeamPointSpec))
        frames = [i for i in items if isinstance(i, tuple)]
        frame, fspan = frames[-1] if frames else (None, None)
        return S.BeamSpec(self._name(name), props, points, frame, self._nspan(name), fspan)

    @v_args(meta=True)
    def beam_point(self, meta, children):
        """``point NAME at x`` -> BeamPointSpec."""
        return S.BeamPointSpec(str(children[0]), children[1], self._tspan(children[0]))

    @v_args(meta=True)
    def beam_frame(self, meta, children):
        """``frame NAME`` -> (name, span)."""
        return (str(children[0]), self._tspan(children[0]))

    @v_args(meta=True)
    def point_decl(self, meta, children):
        """``point NAME (x, y)`` (or ``point P[i] (x, y)``) -> PointSpec."""
        return S.PointSpec(self._name(children[0]), children[1], self._nspan(children[0]))

    @v_args(meta=True)
    def property(self, meta, children):
        """``mass m1`` -> PropertySpec."""
        return S.PropertySpec(str(children[0]), children[1], self._tspan(children[0]))

    @v_args(meta=True)
    def joint_decl(self, meta, children):
        """``joint NAME: kind(args)`` -> JointSpec."""
        name, kind, *args = children
        return S.JointSpec(self._name(name), str(kind), tuple(args), span=self._nspan(name),
                           kind_span=self._tspan(kind))

    @v_args(meta=True)
    def force_decl(self, meta, children):
        """``force NAME: kind(args)`` -> ForceSpec."""
        name, kind, *args = children
        return S.ForceSpec(self._name(name), str(kind), tuple(args), span=self._nspan(name),
                           kind_span=self._tspan(kind))

    @v_args(meta=True)
    def keyword_arg(self, meta, children):
        """``k = 100`` -> ArgSpec with a keyword."""
        return S.ArgSpec(children[1], str(children[0]), self._span(meta))

    @v_args(meta=True)
    def positional_arg(self, meta, children):
        """``crank.O`` or ``(1, 0)`` -> positional ArgSpec."""
        return S.ArgSpec(children[0], None, self._span(meta))

    @v_args(meta=True)
    def driver_decl(self, meta, children):
        """``driver NAME: target = f(t)`` -> DriverSpec."""
        return S.DriverSpec(self._name(children[0]), children[1], children[2],
                            self._nspan(children[0]))

    @v_args(meta=True)
    def initial_decl(self, meta, children):
        """``initial body.coord = value`` -> InitialSpec."""
        return S.InitialSpec(children[0], children[1], False, self._span(meta))

    @v_args(meta=True)
    def guess_decl(self, meta, children):
        """``guess body.coord = value`` -> InitialSpec(guess=True)."""
        return S.InitialSpec(children[0], children[1], True, self._span(meta))

    @v_args(meta=True)
    def ref(self, meta, children):
        """``body.coord`` -> Dotted."""
        return Dotted(self._name(children[0]), str(children[1]), self._span(meta))

    @v_args(meta=True)
    def simulate_decl(self, meta, children):
        """``simulate { ... }`` -> [SettingSpec]."""
        return list(children)

    @v_args(meta=True)
    def method_setting(self, meta, children):
        """``method hht-i3`` -> SettingSpec."""
        return S.SettingSpec("method", str(children[0]), self._tspan(children[0]))

    @v_args(meta=True)
    def value_setting(self, meta, children):
        """``h 1e-3`` -> SettingSpec."""
        return S.SettingSpec(str(children[0]), children[1], self._tspan(children[0]))

    # -- 3. expressions --------------------------------------------------------
    def expression(self, children):
        """A lone expression (parse_expression's entry point)."""
        return children[0]

    @v_args(meta=True)
    def vec(self, meta, children):
        """``(x, y)`` -> Vec."""
        return Vec(children[0], children[1], self._span(meta))

    def _bin(op):
        @v_args(meta=True)
        def method(self, meta, children):
            """``a op b`` -> Binary."""
            return Binary(op, children[0], children[1], self._span(meta))
        return method

    add, sub, mul, div, pow = _bin("+"), _bin("-"), _bin("*"), _bin("/"), _bin("^")
    del _bin

    @v_args(meta=True)
    def compare(self, meta, children):
        """``a < b`` (``>``, ``<=``, ``>=``) -> Binary worth 1 or 0."""
        left, op, right = children
        return Binary(str(op), left, right, self._span(meta))

    @v_args(meta=True)
    def neg(self, meta, children):
        """``-x`` -> Unary."""
        return Unary("-", children[0], self._span(meta))

    @v_args(meta=True)
    def pos(self, meta, children):
        """``+x`` -> x."""
        return children[0]

    @v_args(meta=True)
    def number(self, meta, children):
        """NUMBER -> Num."""
        return Num(float(children[0]), self._tspan(children[0]))

    @v_args(meta=True)
    def quantity(self, meta, children):
        """QUANTITY (``15 cm``) -> Num in SI, keeping the number and unit as written."""
        tok = children[0]
        number, unit = _QUANTITY.match(str(tok)).groups()
        try:
            value = units.to_si(number, unit)
        except units.UnitError as err:
            diag = Diagnostic("error", "E307", str(err), self._tspan(tok), "unknown unit",
                              hint="units are SI symbols and their multiples, joined by * and /")
            raise MbdSyntaxError(diag.message, [diag]) from None
        return Num(value, self._tspan(tok), unit=unit, written=number)

    @v_args(meta=True)
    def name(self, meta, children):
        """NAME -> Name."""
        return Name(str(children[0]), self._tspan(children[0]))

    @v_args(meta=True)
    def dotted(self, meta, children):
        """``a.b`` or ``a[i].b`` -> Dotted."""
        return Dotted(self._name(children[0]), str(children[1]), self._span(meta))

    @v_args(meta=True)
    def dotted_indexed(self, meta, children):
        """``ground.P[i]``: an indexed point -> Dotted with an IndexedName attr."""
        attr = IndexedName(str(children[1]), children[2], self._tspan(children[1]))
        return Dotted(self._name(children[0]), attr, self._span(meta))

    @v_args(meta=True)
    def dotted2(self, meta, children):
        """``arm.T.x`` (a point's field, or ``reaction.O.fx``; ``lambda.O.0``, a
        multiplier row) -> Dotted of a Dotted."""
        inner = Dotted(self._name(children[0]), str(children[1]), self._span(meta))
        return Dotted(inner, str(children[2]), self._span(meta))

    @v_args(meta=True)
    def output_decl(self, meta, children):
        """``output NAME = expr`` -> OutputSpec."""
        return S.OutputSpec(str(children[0]), children[1], self._tspan(children[0]))

    @v_args(meta=True)
    def indexed(self, meta, children):
        """``link[i]`` in an expression (a reference) -> IndexedName."""
        return IndexedName(str(children[0]), children[1], self._span(meta))

    @v_args(meta=True)
    def call(self, meta, children):
        """``f(x)`` -> Call; ``min(a, b)``, ``max(a, b)`` -> Binary;
        ``clip(x, lo, hi)`` -> max(lo, min(x, hi)). A wrong number of
        arguments is kept as a Call that the checks report (E203)."""
        name, args = str(children[0]), children[1:]
        span = self._tspan(children[0])
        if name in ("min", "max") and len(args) == 2:
            return Binary(name, args[0], args[1], span)
        if name == "clip" and len(args) == 3:
            return Binary("max", args[1], Binary("min", args[0], args[2], span), span)
        if name == "if" and len(args) == 3:
            return Cond(args[0], args[1], args[2], span)
        if len(args) != 1:
            return Call(f"{name}/{len(args)}", args[0], span)
        return Call(name, args[0], span)
