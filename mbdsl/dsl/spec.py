"""Model specification: the frozen objects the parser produces.

A :class:`ModelSpec` is the model as written, before any meaning is given to
it: names are not resolved and expressions are not evaluated. The same objects
can be built from Python (plain numbers and strings are accepted wherever an
expression is expected) and are checked by :func:`mbdsl.dsl.check.check_spec`
exactly as parsed files are.

Example
-------
>>> from mbdsl.dsl.spec import ModelSpec, BodySpec, JointSpec, InitialSpec
>>> spec = ModelSpec(
...     name="pendulum", gravity=(0, -9.81),
...     bodies=[BodySpec.rigid("rod", mass=1.0, inertia="1/12",
...                            points={"O": (-0.5, 0)})],
...     joints=[JointSpec("O", "revolute", ["ground.origin", "rod.O"])],
...     initials=[InitialSpec("rod.phi", "-pi/4")])
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..errors import Span
from .expressions import Dotted, Expr, Vec
from .grammar import as_expr

__all__ = [
    "ParameterSpec", "PointSpec", "PropertySpec", "BodySpec", "ShapeSpec", "GroundSpec",
    "ArgSpec",
    "JointSpec", "ForceSpec", "DriverSpec", "InitialSpec", "SettingSpec",
    "ForSpec", "OutputSpec", "ModelSpec", "StateSpec", "TableSpec",
    "ImportSpec", "ComponentSpec", "BlockSpec", "ComponentParameterSpec", "InstanceSpec",
]


def _vec(value) -> Vec:
    """(x, y) -> Vec, (x, y, z) -> Vec with z; a pair whose second item is a
    pair (a point and a direction, ``line = ("ground.origin", (1, 0))``) nests."""
    if isinstance(value, Vec):
        return value
    if len(value) == 3:
        return Vec(*(as_expr(c) for c in value[:2]), None, as_expr(value[2]))
    x, y = value
    return Vec(as_expr(x), _vec(y) if isinstance(y, (tuple, list, Vec)) else as_expr(y))


def _ref(value) -> Dotted:
    if isinstance(value, Dotted):
        return value
    e = as_expr(value)
    if not isinstance(e, Dotted):
        raise ValueError(f"expected a reference like 'body.phi', got {value!r}")
    return e


def _set(obj, name, value):
    object.__setattr__(obj, name, value)


@dataclass(frozen=True)
class ParameterSpec:
    """``parameter NAME = expr``."""

    name: str
    value: Any
    span: Span | None = None

    def __post_init__(self):
        _set(self, "value", as_expr(self.value))


@dataclass(frozen=True)
class TableSpec:
    """``table NAME(ARG) = [(x, y), ...]`` or ``= "file.csv"``, with options
    (``interpolation = pchip``, ``extrapolation = hold``, ``units = (s, N)``).

    Attributes
    ----------
    points : tuple of Vec or None
        The inline points (x, y), expressions of parameters with units.
    path : str or None
        The data file, relative to the model file's folder.
    args : tuple of ArgSpec
        The options.
    """

    name: str
    argument: str
    points: tuple | None = None
    path: str | None = None
    args: tuple = ()
    span: Span | None = None
    source_span: Span | None = None


@dataclass(frozen=True)
class StateSpec:
    """``state NAME { der = expr; initial expr }``: a first-order state z with
    dz/dt = der (an expression of t, parameters and the state, the other
    states and z itself by name) and z(t_start) = initial (default 0).

    Attributes
    ----------
    properties : tuple of PropertySpec
        ``der`` and ``initial`` as written (others are reported by the check).
    """

    name: str
    properties: tuple = ()
    span: Span | None = None

    def __post_init__(self):
        props = []
        for p in self.properties:
            props.append(p if isinstance(p, PropertySpec) else PropertySpec(*p))
        _set(self, "properties", tuple(props))

    @classmethod
    def of(cls, name: str, der, initial=0.0) -> "StateSpec":
        """The state from Python: ``StateSpec.of("i", "w_ref - crank.omega")``."""
        return cls(name, (PropertySpec("der", der), PropertySpec("initial", initial)))


@dataclass(frozen=True)
class PointSpec:
    """``point NAME (x, y)``: a body-fixed point [m], relative to the centre
    of mass in the body frame (or a ground point in the global frame); with
    ``axis`` True, ``axis NAME (x, y, z)``: a spatial body's direction for
    its joints, in its frame (the ground's in the global frame)."""

    name: str
    position: Any
    span: Span | None = None
    axis: bool = False

    def __post_init__(self):
        _set(self, "position", _vec(self.position))


@dataclass(frozen=True)
class PropertySpec:
    """``mass m1`` inside a body block: a named property, a scalar or, in a
    spatial model, a vector (``inertia (1, 2, 3)``)."""

    name: str
    value: Any
    span: Span | None = None

    def __post_init__(self):
        _set(self, "value", _vec(self.value) if isinstance(self.value, (tuple, list, Vec))
             else as_expr(self.value))


@dataclass(frozen=True)
class GroundSpec:
    """``ground { point ... }`` inside a ``for`` block (at the top level its
    points go straight to ``ModelSpec.ground_points``)."""

    points: tuple = ()
    span: Span | None = None

    def __post_init__(self):
        _set(self, "points", tuple(self.points))


@dataclass(frozen=True)
class ShapeSpec:
    """``shape KIND(args)`` in a body: how ``mbdsl animate`` draws it; kinds
    line (two points), circle (centre point, radius [m]) and polygon (three
    or more points). A point is a body point's name or body-frame
    coordinates ``(x, y)`` [m]."""

    kind: str
    args: tuple = ()
    span: Span | None = None
    kind_span: Span | None = None

    def __post_init__(self):
        _set(self, "args", _args(self.args, None))


@dataclass(frozen=True)
class BodySpec:
    """``body NAME { ... }``: a rigid body with properties, points and shapes;
    ``particle NAME { ... }`` (``particle=True``): a point mass, coordinates
    (x, y) only, with a mass and no inertia."""

    name: str
    properties: tuple = ()
    points: tuple = ()
    span: Span | None = None
    shapes: tuple = ()
    particle: bool = False

    def __post_init__(self):
        _set(self, "properties", tuple(self.properties))
        _set(self, "points", tuple(self.points))
        _set(self, "shapes", tuple(self.shapes))

    @classmethod
    def rigid(cls, name: str, mass, inertia, points: dict | None = None) -> "BodySpec":
        """Build a rigid body from Python values.

        Parameters
        ----------
        name : str
        mass : float or str
            [kg]
        inertia : float or str
            Centroidal moment of inertia [kg m^2].
        points : dict of name -> (x, y), optional
            Body-fixed points [m] relative to the centre of mass.
        """
        return cls(name, (PropertySpec("mass", mass), PropertySpec("inertia", inertia)),
                   tuple(PointSpec(k, v) for k, v in (points or {}).items()))


@dataclass(frozen=True)
class BeamPointSpec:
    """``point NAME at x`` in a flexible beam: a point by arc length [m] from
    the first node; ``start`` and ``end`` name the two ends."""

    name: str
    at: Any
    span: Span | None = None

    def __post_init__(self):
        _set(self, "at", as_expr(self.at))


@dataclass(frozen=True)
class BeamSpec:
    """``flexible_beam NAME { ... }``: a planar Euler-Bernoulli beam in the
    floating frame of reference (properties: mass or density, length, E,
    area, second_moment, elements; ``frame first_node|chord``; points)."""

    name: str
    properties: tuple = ()
    points: tuple = ()
    frame: str | None = None
    span: Span | None = None
    frame_span: Span | None = None

    def __post_init__(self):
        _set(self, "properties", tuple(self.properties))
        _set(self, "points", tuple(self.points))

    @classmethod
    def uniform(cls, name: str, *, length, E, area, second_moment, elements: int,
                mass=None, density=None, frame: str | None = None,
                points: dict | None = None) -> "BeamSpec":
        """Build a flexible beam from Python values.

        Parameters
        ----------
        name : str
        length : float or str
            [m]
        E : float or str
            Young's modulus [Pa].
        area, second_moment : float or str
            Cross-section area [m^2] and second moment of area [m^4].
        elements : int
            Number of finite elements.
        mass, density : float or str
            Exactly one: total mass [kg] or density [kg/m^3].
        frame : {"first_node", "chord"}, optional
        points : dict of name -> arc length [m] or "start"/"end"
        """
        props = [PropertySpec("length", length), PropertySpec("E", E),
                 PropertySpec("area", area), PropertySpec("second_moment", second_moment),
                 PropertySpec("elements", elements)]
        if mass is not None:
            props.append(PropertySpec("mass", mass))
        if density is not None:
            props.append(PropertySpec("density", density))
        return cls(name, tuple(props),
                   tuple(BeamPointSpec(k, v) for k, v in (points or {}).items()), frame)


@dataclass(frozen=True)
class ArgSpec:
    """One argument of a joint or force: positional or ``keyword = value``.

    ``value`` is an expression (a reference like ``crank.O`` is a
    :class:`~mbdsl.dsl.expressions.Dotted`) or a :class:`Vec`.
    """

    value: Any
    keyword: str | None = None
    span: Span | None = None

    def __post_init__(self):
        v = self.value
        if isinstance(v, (tuple, list)) and len(v) == 2:
            v = _vec(v)
        elif not isinstance(v, Vec):
            v = as_expr(v)
        _set(self, "value", v)


def _args(args, options) -> tuple:
    out = [a if isinstance(a, ArgSpec) else ArgSpec(a) for a in args]
    out += [ArgSpec(v, k) for k, v in (options or {}).items()]
    return tuple(out)


@dataclass(frozen=True)
class JointSpec:
    """``joint NAME: kind(args)``; kinds: revolute, prismatic, point_on_line, fixed,
    distance, and the couplers between joints gear, rack and coupler (their
    positional arguments joint names, or a coupler's relation)."""

    name: str
    kind: str
    args: tuple = ()
    options: dict | None = None
    span: Span | None = None
    kind_span: Span | None = None

    def __post_init__(self):
        _set(self, "args", _args(self.args, self.options))
        _set(self, "options", None)


@dataclass(frozen=True)
class ForceSpec:
    """``force NAME: kind(args)``; kinds: spring_damper,
    rotational_spring_damper, torque, joint_torque, joint_force, force,
    friction, contact, limit."""

    name: str
    kind: str
    args: tuple = ()
    options: dict | None = None
    span: Span | None = None
    kind_span: Span | None = None

    def __post_init__(self):
        _set(self, "args", _args(self.args, self.options))
        _set(self, "options", None)


@dataclass(frozen=True)
class DriverSpec:
    """``driver NAME: body.coord = f(t)`` or ``driver NAME: joint.angle = f(t)``."""

    name: str
    target: Any
    value: Any
    span: Span | None = None

    def __post_init__(self):
        _set(self, "target", _ref(self.target))
        _set(self, "value", as_expr(self.value))


@dataclass(frozen=True)
class InitialSpec:
    """``initial body.coord = value`` (kept) or ``guess body.coord = value``
    (a start value that assembly may change)."""

    target: Any
    value: Any
    guess: bool = False
    span: Span | None = None

    def __post_init__(self):
        _set(self, "target", _ref(self.target))
        _set(self, "value", _vec(self.value) if isinstance(self.value, (tuple, list, Vec))
             else as_expr(self.value))


@dataclass(frozen=True)
class OutputSpec:
    """``output NAME = expr``: a column ``output.NAME`` of the results, any
    expression of t, parameters and the state (``arm.T.y``, ``O.angle``,
    ``crank.omega``, ``reaction.O.fx``, ``energy.total``)."""

    name: str
    value: Any
    span: Span | None = None

    def __post_init__(self):
        _set(self, "value", as_expr(self.value))


@dataclass(frozen=True)
class SettingSpec:
    """A line of the ``simulate { }`` section; ``method`` holds a str."""

    name: str
    value: Any
    span: Span | None = None

    def __post_init__(self):
        if self.name != "method":
            _set(self, "value", as_expr(self.value))


@dataclass(frozen=True)
class ForSpec:
    """``for VAR in START..END { ... }``: declarations repeated for each integer
    VAR from START to END (both included). ``items`` are body, joint, force,
    driver, initial/guess specs and nested ForSpecs, whose names may be
    indexed (``link[i]``); the checker expands them.
    """

    var: str
    start: Any
    end: Any
    items: tuple = ()
    span: Span | None = None

    def __post_init__(self):
        _set(self, "start", as_expr(self.start))
        _set(self, "end", as_expr(self.end))
        _set(self, "items", tuple(self.items))


@dataclass(frozen=True)
class BlockSpec:
    """The declarations of one instance of a component, flattened
    (:func:`mbdsl.dsl.components.flatten`): they take the place of the
    instance's statement (``span``) in the model's order, as the items of a
    ``for`` block take the block's."""

    items: tuple = ()
    span: Span | None = None

    def __post_init__(self):
        _set(self, "items", tuple(self.items))


@dataclass(frozen=True)
class ImportSpec:
    """``import "parts.mbd"`` (a file, relative to the importing file's folder),
    ``import parts`` (``parts.mbd`` on the search path: ``MBDSL_PATH``, then
    mbdsl's own library) or either ``as NAME``: the file's components become
    ``NAME.Component`` (NAME defaults to the file's stem)."""

    target: str
    is_path: bool = False
    alias: str | None = None
    span: Span | None = None

    @property
    def namespace(self) -> str:
        """The name that qualifies the imported components."""
        if self.alias:
            return self.alias
        stem = self.target.replace("\\", "/").rsplit("/", 1)[-1]
        return stem[:-4] if stem.endswith(".mbd") else stem


@dataclass(frozen=True)
class ComponentParameterSpec:
    """A component's parameter ``NAME = default`` (``default`` None: the
    instance must give it)."""

    name: str
    default: Any = None
    span: Span | None = None

    def __post_init__(self):
        if self.default is not None:
            _set(self, "default", as_expr(self.default))


@dataclass(frozen=True)
class ComponentSpec:
    """``component NAME(P = default, ...) { declarations }``: a part defined
    once. ``items`` are its declarations in order: parameters derived from
    its own (``parameter I = m*L^2/12``), bodies, particles, beams, ground
    points, joints, forces, drivers, initial and guess lines, outputs, ``for``
    blocks and instances of other components. Inside, names are the
    component's own: its parameters, its elements, ``ground``, ``t`` and
    ``pi``; a point of a body is a connector the model joins to others.
    """

    name: str
    parameters: tuple = ()
    items: tuple = ()
    span: Span | None = None

    def __post_init__(self):
        given = self.parameters
        if isinstance(given, dict):                  # from Python: {"L": "1 m", "m": None}
            given = [ComponentParameterSpec(k, v) for k, v in given.items()]
        params = [p if isinstance(p, ComponentParameterSpec) else
                  ComponentParameterSpec(*p) if isinstance(p, tuple) else
                  ComponentParameterSpec(p) for p in given]
        _set(self, "parameters", tuple(params))
        _set(self, "items", tuple(self.items))

    def __call__(self, name, **parameters) -> "InstanceSpec":
        """An instance of this component: ``link("upper", L=0.4, m=2)``.

        Parameters
        ----------
        name : str
            The instance's name (its path's last part).
        **parameters : float or str
            Values of the component's parameters (numbers in SI, or
            expressions of the model's parameters as text: ``"2*L1"``).

        Returns
        -------
        InstanceSpec
            For ``ModelSpec(instances=[...])`` (with this component in
            ``components``).
        """
        return InstanceSpec(self.name, name, tuple(ArgSpec(v, k) for k, v in parameters.items()))


@dataclass(frozen=True)
class InstanceSpec:
    """``Link upper(L = 0.4, m = 2)``: an instance of a component, its
    parameters set by keyword (the others keep their defaults). ``component``
    is the component's name, qualified by an import's name where it comes
    from a library (``parts.Link``); ``name`` may be indexed in a ``for``
    block (``l[i]``)."""

    component: str
    name: Any
    args: tuple = ()
    span: Span | None = None
    component_span: Span | None = None

    def __post_init__(self):
        _set(self, "args", _args(self.args, None))

    @classmethod
    def of(cls, component: str, name, **parameters) -> "InstanceSpec":
        """An instance from Python: ``InstanceSpec.of("parts.Link", "upper", L=0.4)``."""
        return cls(component, name, tuple(ArgSpec(v, k) for k, v in parameters.items()))


@dataclass(frozen=True)
class ModelSpec:
    """A whole model as written.

    Parameters
    ----------
    name : str
    parameters, ground_points, bodies, joints, forces, drivers, initials,
    settings : sequences of the spec objects above
    loops : sequence of ForSpec
        Repeated declarations, expanded by the checker.
    gravity : (x, y) or Vec or None
        [m/s^2]; None means no gravity term at all.
    file : str
        Source file name, for diagnostics.
    source : str or None
        Source text, for diagnostics and the output's hash.
    static : bool
        ``initial static``: start at rest in static equilibrium.
    outputs : sequence of OutputSpec
        Output columns (sensors).
    tables : sequence of TableSpec
        Tables y(x), callable in expressions by name.
    states : sequence of StateSpec
        First-order states, read in expressions by name.
    imports : sequence of ImportSpec
        Libraries of components read by this file.
    components : sequence of ComponentSpec
        Components defined in this file.
    instances : sequence of InstanceSpec
        Instances of components at the top level (those in ``for`` blocks are
        among the blocks' items); the check flattens them
        (:func:`mbdsl.dsl.components.flatten`).
    library : bool
        A library file (``library NAME``): components and imports only.
    space : {2, 3}
        ``space 3d``: a spatial model (3); planar (2) by default.
    """

    name: str
    parameters: tuple = ()
    gravity: Any = None
    ground_points: tuple = ()
    bodies: tuple = ()
    joints: tuple = ()
    forces: tuple = ()
    drivers: tuple = ()
    initials: tuple = ()
    settings: tuple = ()
    loops: tuple = ()
    outputs: tuple = ()
    tables: tuple = ()
    states: tuple = ()
    file: str = "<python>"
    source: str | None = None
    span: Span | None = None
    gravity_span: Span | None = None
    static: bool = False
    static_span: Span | None = None
    imports: tuple = ()
    components: tuple = ()
    instances: tuple = ()
    library: bool = False
    space: int = 2
    space_span: Span | None = None

    def __post_init__(self):
        for f in ("parameters", "ground_points", "bodies", "joints", "forces",
                  "drivers", "initials", "settings", "loops", "outputs", "tables", "states",
                  "imports", "components", "instances"):
            _set(self, f, tuple(getattr(self, f)))
        if self.gravity is not None:
            _set(self, "gravity", _vec(self.gravity))
