"""Parse tree -> :class:`~mbdsl.dsl.spec.ModelSpec`.

Runs as its own pass (never passed into ``Lark(...)``, which would lose
``meta``). Methods follow the grammar's order; no name is resolved and no
physics happens here. The expressions' rules are
:class:`~.grammar.ToExpression`'s, which this transformer extends.
"""

from __future__ import annotations

from lark import Token, v_args

from . import spec as S
from .expressions import IndexedName
from .grammar import ToExpression, dotted_chain

__all__ = ["ToSpec"]


class ToSpec(ToExpression):
    """Build spec objects from a Lark tree of ``mbd.lark``.

    Parameters
    ----------
    file : str
        File name recorded in every :class:`~mbdsl.errors.Span`.
    source : str
        The text, stored on the resulting ModelSpec.
    """

    # -- 1. file and model header ------------------------------------------
    @v_args(meta=True)
    def start(self, meta, children):
        """The whole file -> ModelSpec, statements sorted into their kinds."""
        header, *items = children
        buckets = {k: [] for k in ("parameters", "ground_points", "bodies", "joints",
                                   "forces", "drivers", "initials", "settings", "loops",
                                   "outputs", "tables", "states", "imports", "components",
                                   "instances")}
        kinds = ((S.ImportSpec, "imports"), (S.ComponentSpec, "components"),
                 (S.InstanceSpec, "instances"))
        gravity, gspan, static, space = None, None, None, (2, None)
        for it in items:
            if isinstance(it, tuple) and it and it[0] == "static":
                static = it[1]
            elif isinstance(it, tuple) and it and it[0] == "space":
                space = it[1:]
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
            elif isinstance(it, S.TableSpec):
                buckets["tables"].append(it)
            elif isinstance(it, S.StateSpec):
                buckets["states"].append(it)
            elif isinstance(it, list):
                buckets["settings"].extend(it)
            else:
                buckets[next(k for cls, k in kinds if isinstance(it, cls))].append(it)
        return S.ModelSpec(name=header[0], gravity=gravity, gravity_span=gspan,
                           file=self.file, source=self.source, span=header[1],
                           static=static is not None, static_span=static,
                           library=header[2], space=space[0], space_span=space[1],
                           **buckets)

    @v_args(meta=True)
    def static_decl(self, meta, children):
        """``initial static`` -> ("static", span)."""
        return ("static", self._span(meta))

    @v_args(meta=True)
    def model_decl(self, meta, children):
        """``model NAME`` -> (name, span, False)."""
        return (str(children[0]), self._tspan(children[0]), False)

    @v_args(meta=True)
    def library_decl(self, meta, children):
        """``library NAME`` -> (name, span, True)."""
        return (str(children[0]), self._tspan(children[0]), True)

    # -- components and libraries -------------------------------------------
    @v_args(meta=True)
    def import_decl(self, meta, children):
        """``import "file.mbd"`` / ``import name`` [``as NAME``] -> ImportSpec."""
        target, *alias = children
        is_path = target.type == "STRING"
        return S.ImportSpec(str(target)[1:-1] if is_path else str(target), is_path,
                            str(alias[0]) if alias else None, self._span(meta))

    @v_args(meta=True)
    def component_decl(self, meta, children):
        """``component NAME(params) { ... }`` -> ComponentSpec."""
        name, *rest = children
        params = tuple(c for c in rest if isinstance(c, S.ComponentParameterSpec))
        items = tuple(c for c in rest if not isinstance(c, S.ComponentParameterSpec))
        return S.ComponentSpec(str(name), params, items, self._tspan(name))

    @v_args(meta=True)
    def comp_param(self, meta, children):
        """``L = 1 m`` (or ``L``) in a component's header -> ComponentParameterSpec."""
        return S.ComponentParameterSpec(str(children[0]), children[1] if len(children) > 1
                                        else None, self._tspan(children[0]))

    @v_args(meta=True)
    def instance_decl(self, meta, children):
        """``Link upper(L = 0.4)`` -> InstanceSpec."""
        (comp, cspan), name, *args = children
        return S.InstanceSpec(comp, self._name(name), tuple(args), self._nspan(name), cspan)

    @v_args(meta=True)
    def qualname(self, meta, children):
        """``Link`` or ``parts.Link`` -> (text, span)."""
        return ".".join(str(c) for c in children), self._span(meta)

    # -- 2. declarations -----------------------------------------------------
    @v_args(meta=True)
    def parameter_decl(self, meta, children):
        """``parameter NAME = expr`` -> ParameterSpec."""
        return S.ParameterSpec(str(children[0]), children[1], self._tspan(children[0]))

    @v_args(meta=True)
    def table_decl(self, meta, children):
        """``table NAME(ARG) = [points] | "file", options`` -> TableSpec."""
        name, arg, source, *options = children
        if isinstance(source, Token):           # the file's name, without its quotes
            return S.TableSpec(str(name), str(arg), None, str(source)[1:-1], tuple(options),
                               self._tspan(name), self._tspan(source))
        points, span = source
        return S.TableSpec(str(name), str(arg), points, None, tuple(options), self._tspan(name),
                           span)

    @v_args(meta=True)
    def state_decl(self, meta, children):
        """``state NAME { der = expr; initial expr }`` -> StateSpec."""
        name, *props = children
        return S.StateSpec(str(name), tuple(props), self._tspan(name))

    @v_args(meta=True)
    def state_initial(self, meta, children):
        """``initial expr`` inside a state block -> PropertySpec("initial")."""
        return S.PropertySpec("initial", children[0], self._span(meta))

    @v_args(meta=True)
    def table_points(self, meta, children):
        """``[(x, y), ...]`` -> (tuple of Vec, span)."""
        return tuple(children), self._span(meta)

    @v_args(meta=True)
    def space_decl(self, meta, children):
        """``space 3d`` -> ('space', 3, span)."""
        return ("space", int(str(children[0])[0]), self._span(meta))

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
    def axis_decl(self, meta, children):
        """``axis NAME (x, y, z)`` -> PointSpec(axis=True): a direction of a
        spatial body (or of the ground), for its joints."""
        return S.PointSpec(self._name(children[0]), children[1], self._nspan(children[0]),
                           axis=True)

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
        """``body.coord`` (``upper.b.phi``) -> Dotted (a chain of them)."""
        return dotted_chain(self._name(children[0]), [str(c) for c in children[1:]],
                            self._span(meta))

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

    @v_args(meta=True)
    def output_decl(self, meta, children):
        """``output NAME = expr`` -> OutputSpec."""
        return S.OutputSpec(str(children[0]), children[1], self._tspan(children[0]))
