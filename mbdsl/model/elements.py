"""Resolved model: bodies, joints, drivers and forces with numbers, not text.

This is the checked model the assembly compiles. Every element keeps the
:class:`~mbdsl.errors.Span` of its declaration so that numerical failures can
be reported at the line that declared the element.

Conventions (stated once for the whole package)
-----------------------------------------------
* Planar absolute coordinates: each rigid body has q_i = (x, y, phi), the
  position [m] of its centre of mass and its angle [rad], counter-clockwise
  positive from the global +x axis.
* Body-fixed vectors s are given in the body frame relative to the centre of
  mass; the global position of a point is r + A(phi) s.
* The ground is body index ``GROUND`` (-1); it has no coordinates.
* A particle (:class:`RigidBody` with ``particle=True``: a point mass) has
  two coordinates (x, y) and no rotation.
* A flexible beam (:class:`FlexibleBeam`) has the same three reference
  coordinates (x, y, phi) of its floating frame, and n_f elastic coordinates
  stored after those of all bodies, at q[elastic_offset : elastic_offset + n_f].
* Where a body's coordinates are in q is said by one table,
  :class:`CoordinateMap` (``Model.coordinate_map``): bodies in declaration
  order, three columns each (two for a particle). Everything that works on
  body frames (element groups, placement, drivers, initial conditions,
  outputs) reads it, so rigid bodies, particles and beams' frames are
  treated alike: a particle's phi is the ground's (always 0) dummy column,
  and its only point, ``cm``, never turns.
* A joint's relative angle is phi(second body) - phi(first body).
* A first-order state z (:class:`FirstOrderState`, ``state i { der = ...;
  initial ... }``) is integrated as the velocity of one more coordinate, its
  integral s = int z dt, stored after the elastic coordinates with unit mass
  and the generalized force f = dz/dt: each method's velocity update is then
  its own first-order counterpart (docs/methods.md, "First-order states").
  :class:`CoordinateMap` gives it the pseudo body index n_bodies + k (one
  coordinate, 0), so that the expressions read it as they read a body's.
"""

from __future__ import annotations

import functools
import operator
from dataclasses import dataclass, field

import numpy as np

from ..errors import Diagnostic, Span
from .functions import (StateFunction, StateSwitch, StateVariable,  # noqa: F401 (re-exported)
                        TimeFunction, line_columns, line_distance)

GROUND = -1

__all__ = [
    "GROUND", "RigidBody", "Shape", "FlexibleBeam", "PointRef", "Joint", "Driver", "SpringDamper",
    "RotationalSpringDamper", "Coupler", "Torque", "JointTorque", "JointForce", "Friction", "PointForce",
    "InitialCondition", "FirstOrderState", "line_distance", "line_columns", "CoordinateMap",
    "TimeFunction", "StateVariable", "StateFunction", "StateSwitch", "Output", "OutputVariable",
    "multiplier_unit", "SENSOR_UNITS", "Model", "COORDINATES", "VELOCITIES", "ACCELERATIONS",
]

from .spatial import SPATIAL_COORDINATES, SPATIAL_VELOCITIES
from .coordinates import (ACCELERATIONS, COORDINATES, VELOCITIES,  # noqa: F401 (re-exported)
                          BodyKinds, CoordinateMap, body_names)


@dataclass(frozen=True)
class OutputVariable:
    """A quantity an output expression reads.

    Attributes
    ----------
    name : str
        As written, e.g. ``"arm.T.y"``.
    kind : {"column", "point", "joint", "beam_point", "gap", "friction", "spring", "rotational"}
        "column": a result column by name (``column``); "point": ``field``
        (x, y, vx, vy) of a rigid body's point ``point``; "joint": a revolute
        joint's relative angle (``field`` "angle") or rate ("rate") of the
        bodies ``bodies`` (first, second), or with ``line`` (the geometry of
        :func:`line_distance`) a sliding joint's distance or speed;
        "beam_point": ``field`` (x, y, vx, vy, deflection) of the material
        point at ``arc`` [m] of the flexible beam ``bodies[0]``; "gap":
        ``field`` (gap, gap_rate, normal, friction, power) of contact gap
        ``index`` (``ContactState`` order); "friction", "spring",
        "rotational": ``field`` (:data:`SENSOR_UNITS`) of the element
        ``index`` among the model's forces of its kind.
    """

    name: str
    kind: str
    column: str = ""
    point: "PointRef | None" = None
    field: str = ""
    bodies: tuple = ()
    line: tuple | None = None
    arc: float = 0.0
    index: int = 0


#: What an ``output`` line reads of a force element (``OutputVariable.kind``
#: "gap", "friction", "spring", "rotational"): field -> SI unit, in the order of
#: ``AssembledSystem.sensor_values`` (a contact's gap; a friction element on a
#: sliding joint; a spring-damper; a rotational one). An angle limit's gap is
#: in rad, rad/s, N m.
SENSOR_UNITS = {
    "gap": {"gap": "m", "gap_rate": "m/s", "normal": "N", "friction": "N", "power": "W",
            "energy": "J"},
    "friction": {"speed": "m/s", "friction": "N", "power": "W"},
    "spring": {"length": "m", "rate": "m/s", "tension": "N", "energy": "J", "power": "W"},
    "rotational": {"angle": "rad", "rate": "rad/s", "torque": "N*m", "energy": "J",
                   "power": "W"},
}


def multiplier_unit(element, row: int) -> str:
    """The SI unit of row ``row``'s Lagrange multiplier of a joint or driver:
    the load that row carries, N for a row that holds a point (revolute,
    fixed, point_on_line, distance; a driven x, y (z) or joint distance),
    N*m for one that holds an angle (a fixed joint's third row, a prismatic
    joint's second; a driven phi or joint angle)."""
    if isinstance(element, Coupler):
        first = element.variables[0] if element.variables else None
        return "N" if first is not None and first.line is not None else "N*m"
    if isinstance(element, Driver):
        return "N" if element.load == "force" else "N*m"
    if element.kind == "frame":         # a spatial body's a_k . a_l = delta_kl: a couple
        return "N*m"
    if getattr(element, "space", 2) == 3:
        from .spatial import SPATIAL_ROW_UNITS
        return "N*m" if SPATIAL_ROW_UNITS[element.kind][row] == "T" else "N"
    return "N*m" if ANGLE_ROWS.get(element.kind) == row else "N"


#: The joint kinds that lock a relative angle, and the row of the joint that holds it
#: (a fixed joint's third, a prismatic joint's second); the others transmit no couple
#: about their first point.
ANGLE_ROWS = {"fixed": 2, "prismatic": 1}


@dataclass(frozen=True)
class Output:
    """``output NAME = expr``: the column ``output.NAME``.

    Attributes
    ----------
    name : str
    expr : Expr
        Substituted (parameters replaced), its variables as names.
    variables : tuple of OutputVariable
    unit : str
        The SI unit the expression determines (``"m"``, ``"N*m"``), or ``""``.
    """

    name: str
    expr: object
    variables: tuple
    span: Span | None = None
    unit: str = ""


# The elements a model holds by the thousand (bodies, joints, their points) keep
# their fields in slots, not in a dict each: the set-up's passes over them (the
# assembly's layout, the kernels' packing) read one object per element, not two,
# and a pendulum chain's model holds 1 965 bytes a link instead of 2 141.
@dataclass(frozen=True, slots=True)
class RigidBody:
    """A rigid body.

    Attributes
    ----------
    name : str
    index : int
        Position in the model's body list (its columns in q:
        ``Model.coordinate_map``).
    mass : float [kg]
    inertia : float [kg m^2]
        Centroidal moment of inertia (0 for a particle).
    points : dict of str -> ndarray, shape (2,) [m]
        Body-fixed points relative to the centre of mass; ``cm`` is (0, 0).
    shapes : tuple of Shape
        What ``mbdsl animate`` draws (empty: the outline of the points).
    particle : bool
        A point mass (``particle NAME { mass m }``): coordinates (x, y)
        only, no rotation, no inertia, one point ``cm``.
    """

    name: str
    index: int
    mass: float
    inertia: float
    points: dict
    span: Span | None = None
    shapes: tuple = ()
    particle: bool = False

    @property
    def coordinate_fields(self) -> tuple:
        """("x", "y", "phi"), or ("x", "y") for a particle."""
        return COORDINATES[:2] if self.particle else COORDINATES


@dataclass(frozen=True)
class Shape:
    """A drawn shape of a rigid body, in its frame.

    Attributes
    ----------
    kind : {"line", "circle", "polygon"}, or in a spatial body {"line", "sphere", "cylinder", "box"}
    points : ndarray, shape (k, 2), or (k, 3) in a spatial body [m]
        Line: its two ends; circle, sphere: its centre; polygon: its
        vertices; cylinder: its two ends' centres; box: its eight corners.
    radius : float [m]
        Circles, spheres and cylinders only (0 otherwise).
    """

    kind: str
    points: np.ndarray
    radius: float = 0.0


@functools.lru_cache(maxsize=64)
def _mesh(length, elements, frame, modes, mass_per_length, EA, EI, stiffening):
    """A beam's mesh, cached on its data (the modal one solves an eigenproblem);
    with geometric stiffening only the bending coordinates are reduced."""
    from .beam import BeamMesh, ModalMesh
    mesh = BeamMesh(length, elements, frame)
    return mesh if not modes else ModalMesh(mesh, modes, mass_per_length, EA, EI,
                                            keep_axial=stiffening)


@dataclass(frozen=True)
class FlexibleBeam:
    """A planar Euler-Bernoulli beam in the floating frame of reference.

    Attributes
    ----------
    name : str
    index : int
        Position in the model's body list; its reference coordinates (the
        floating frame: origin at the first node, see ``frame``) are where
        ``Model.coordinate_map`` says.
    mass : float [kg]
    length : float [m]
    E : float [Pa]
    area : float [m^2]
    second_moment : float [m^4]
    elements : int
    frame : {"first_node", "chord"}
        Reference conditions (``model/beam.py``).
    points : dict of str -> float [m]
        Named points by arc length from the first node.
    elastic_offset : int
        First column of its elastic coordinates in q.
    stiffening : bool
        Geometric stiffening (the nonlinear axial strain, ``assembly/ffr.py``);
        False: the linear floating-frame beam (``stiffening off``).
    modes : int
        K > 0: the elastic coordinates are the amplitudes of the K lowest
        modes of the mesh (``modes K``, :class:`~mbdsl.model.beam.ModalMesh`;
        with geometric stiffening the K lowest bending modes and the axial
        nodal coordinates); 0: the nodal coordinates.
    """

    name: str
    index: int
    mass: float
    length: float
    E: float
    area: float
    second_moment: float
    elements: int
    frame: str
    points: dict
    elastic_offset: int = 0
    span: Span | None = None
    stiffening: bool = True
    modes: int = 0

    #: Never a point mass (read with every body's: ``model.coordinates.BodyKinds``).
    particle = False

    @property
    def mesh(self):
        """The :class:`~mbdsl.model.beam.BeamMesh`, or with ``modes`` K its
        :class:`~mbdsl.model.beam.ModalMesh` (built once per beam data)."""
        return _mesh(self.length, self.elements, self.frame, self.modes,
                     self.mass / self.length, self.E * self.area, self.E * self.second_moment,
                     self.stiffening)

    @property
    def n_elastic(self) -> int:
        """n_f, the number of elastic coordinates (3 per element, less the
        frame's three; K with ``modes``)."""
        return self.mesh.nf

    @property
    def inertia(self) -> float:
        """Moment of inertia of the undeformed beam about its frame origin [kg m^2]."""
        return self.mass * self.length ** 2 / 3.0

    def elastic_columns(self) -> np.ndarray:
        """Columns of the elastic coordinates in q, shape (n_f,)."""
        return np.arange(self.elastic_offset, self.elastic_offset + self.n_elastic)

    # The beam's inertia, stiffness and strain data: computed once per beam, from its
    # mesh, and read by the kernels' packing (``kernels.beams.ffr.pack``), the mass
    # diagonal (``AssembledSystem.mass_diag``) and the tests' oracle; the one copy of
    # them between the model and the packed arrays.
    @functools.cached_property
    def shape_integrals(self):
        """The inertia shape integrals (:class:`~mbdsl.model.beam.ShapeIntegrals`:
        m, s0, I0, S_bar, M_ff, a_u, a_I, S_tilde) of the beam's elastic
        coordinates, for its uniform mass per length (Shabana, Dynamics of
        Multibody Systems, 4th ed., ch. 5)."""
        return self.mesh.shape_integrals(self.mass / self.length)

    @functools.cached_property
    def stiffness(self) -> np.ndarray:
        """K of the elastic coordinates, shape (n_f, n_f) [N/m, N, N m]."""
        return self.mesh.stiffness(self.E * self.area, self.E * self.second_moment)

    @functools.cached_property
    def strain_data(self):
        """Geometric stiffening's data (``assembly/ffr.py``): k_e = EA l / 2 per
        element (elements,) [N m], the axial strain gradients Bu (elements,
        n_f) and the mean squared slopes G (elements, n_f, n_f)
        (:meth:`~mbdsl.model.beam.BeamMesh.strain_gradients`); None with
        ``stiffening off``."""
        if not self.stiffening:
            return None
        Bu, G = self.mesh.strain_gradients()
        return np.full(self.elements, 0.5 * self.E * self.area * self.length / self.elements), Bu, G

    @property
    def mass_diagonal(self) -> np.ndarray:
        """The diagonal of M at q = 0 in the beam's local coordinates (x, y,
        phi, q_f): m, m, I0, diag M_ff, shape (3 + n_f,) [kg, kg m^2]; the
        scaling of the unknowns."""
        s = self.shape_integrals
        return np.concatenate([[s.mass, s.mass, s.I0], np.diagonal(s.M_ff)])


@dataclass(frozen=True, slots=True)
class PointRef:
    """A point of a body (or of the ground), resolved.

    Attributes
    ----------
    body : int
        Body index, or GROUND.
    local : ndarray, shape (2,) [m]
        In the body frame (global coordinates for the ground); for a point
        of a flexible beam, its undeformed position u_bar0 = (x, 0).
    text : str
        As written, e.g. ``"crank.O"``.
    elastic_columns : ndarray of int, shape (e,)
        For a point of a flexible beam: the columns of q its elastic
        displacement depends on (the nodes of its element); empty otherwise.
    elastic_shape : ndarray, shape (2, e)
        The matching columns of the shape matrix S(x): the point is at
        r + A(phi) (local + elastic_shape q[elastic_columns]).
    """

    body: int
    local: np.ndarray
    text: str
    elastic_columns: np.ndarray = field(default_factory=lambda: np.zeros(0, np.intp))
    elastic_shape: np.ndarray = field(default_factory=lambda: np.zeros((2, 0)))


@dataclass(frozen=True, slots=True)
class Joint:
    """A kinematic joint.

    Attributes
    ----------
    name : str
    kind : str
        Planar: "revolute", "prismatic", "point_on_line", "fixed", "distance";
        spatial (``dsl.check.spatial.SPATIAL_JOINT_KINDS``): "spherical", "revolute",
        "universal", "cylindrical", "point_on_line", "point_on_plane", "distance",
        "fixed", "prismatic".
    first, second : PointRef
        The two points as written. For ``point_on_line`` and ``prismatic``
        the first point moves on the line through the second point.
    direction : ndarray, shape (2,), or None
        Unit direction of the line, in the second body's frame.
    angle : float [rad]
        Locked relative angle (prismatic, fixed).
    rows : int
        Number of constraint equations.
    length : float [m]
        The distance a ``distance`` joint holds (0 for the others).
    axes : tuple of (int, ndarray (3,))
        A spatial joint's axes: (body, unit direction in its frame) each
        (``dsl.check.spatial.SPATIAL_JOINT_KINDS``); empty in a planar model.
    space : {2, 3}
        The model's: a spatial joint's rows are ``kernels.joints.spatial``'s.
    """

    name: str
    kind: str
    first: PointRef
    second: PointRef
    direction: np.ndarray | None = None
    angle: float = 0.0
    rows: int = 2
    span: Span | None = None
    length: float = 0.0
    axes: tuple = ()
    space: int = 2

    @property
    def bodies(self) -> tuple[int, int]:
        """(first body, second body) indices."""
        return self.first.body, self.second.body

    @property
    def locks_angle(self) -> bool:
        """Whether a row holds the bodies' relative angle (``ANGLE_ROWS``): a
        joint that locks none transmits no couple about its first point."""
        return self.kind in ANGLE_ROWS

    @property
    def line(self) -> tuple:
        """The sliding line of a prismatic or point_on_line joint: (body L,
        s_L, body P, s_P, u0), the line through the second point along
        ``direction`` and the first point sliding on it, as
        :func:`line_distance` reads it (hashable: shared by every load that
        uses it)."""
        return (self.second.body, tuple(float(x) for x in self.second.local), self.first.body,
                tuple(float(x) for x in self.first.local),
                tuple(float(x) for x in self.direction))


@dataclass(frozen=True)
class Driver:
    """A prescribed motion (rheonomic constraint), one row.

    ``kind == "coordinate"``: q[c] - f(t) = 0, c the body's column of
    ``coord`` (``Model.coordinate_map``).
    ``kind == "joint_angle"``: phi(second) - phi(first) - f(t) = 0.
    ``kind == "joint_distance"`` (prismatic, point_on_line): u . (p1 - p2) - f(t)
    = 0, u the line's unit direction turning with the second body, p1 the
    first (sliding) point, p2 the line's point.

    In a spatial model (``space == 3``) ``coord`` 0, 1, 2 is x, y, z of the
    centre of mass, a joint angle is a revolute's or cylindrical's turn
    about its first body's axis (``kernels.joints.spatial_angles``) and a
    distance is a prismatic's, cylindrical's or point_on_line's.
    """

    name: str
    kind: str
    function: TimeFunction
    body: int = GROUND
    coord: int = 2
    joint: Joint | None = None
    span: Span | None = None
    rows: int = 1
    space: int = 2

    @property
    def load(self) -> str:
        """What -lambda of its row is: "force" [N] for a driven x, y, z or
        distance, "torque" [N m] for a driven phi or joint angle."""
        if self.kind == "joint_distance" or (self.kind == "coordinate"
                                             and (self.coord < 2 or self.space == 3)):
            return "force"
        return "torque"


@dataclass(frozen=True)
class Coupler:
    """A linear relation between joint coordinates, one constraint row: a gear
    pair or a belt between two revolute joints' angles, a rack and pinion
    between a sliding joint's distance and a revolute's angle, or any linear
    combination of them.

    Phi(q) = sum_k a_k x_k(q) - c = 0, x_k a joint's relative angle
    (phi2 - phi1, linear in q) or a sliding joint's distance along its line
    (``line_distance``, not linear). A gear of ratio n between J1 and J2 is
    theta1 - n theta2 - c (theta1 - theta1_0 = n (theta2 - theta2_0)); a rack
    of pinion radius r is s - r theta - c (the rack moves r per radian of
    the pinion). Its multiplier lambda is the load conjugate to the first
    term: a torque [N m] when it is an angle, a force [N] when a distance;
    the coupler puts -a_k lambda on coordinate x_k (Haug, sec. 3.4, gears;
    Shabana, Computational Dynamics, sec. 3.6: a constraint's generalized
    force is -Phi_q^T lambda).

    Attributes
    ----------
    name : str
    kind : {"gear", "rack", "coupler"}
    variables : tuple of StateVariable
        The joint coordinates x_k (position level), in the order written.
    coefficients : tuple of float
        a_k, one per variable.
    value : float or None
        c; None: the value of sum a_k x_k in the configuration as placed
        (the model's initial and guess lines, the joints along the tree:
        ``assembly.placement.place_bodies``), so that teeth mesh as drawn.
    span : Span or None
    rows : int
        1.
    """

    name: str
    kind: str
    variables: tuple
    coefficients: tuple
    value: float | None = None
    span: Span | None = None
    rows: int = 1

    def placed_value(self, qx, cmap: "CoordinateMap") -> float:
        """sum_k a_k x_k at qx (q extended by the ground's three, shape
        (n+3,)): the value c taken as placed."""
        total = 0.0
        for a, v in zip(self.coefficients, self.variables):
            if v.line is not None:
                total += a * line_distance(v.line, qx, cmap)[0]
            else:
                total += a * sum(c * qx[cmap.column(b, j)] for b, j, c in v.terms)
        return float(total)


@dataclass(frozen=True)
class SpringDamper:
    """Translational spring-damper between two points.

    Tension f = k (l - length) + c dl/dt acts along the line of the points,
    pulling them together when positive.
    """

    name: str
    first: PointRef
    second: PointRef
    k: float
    c: float
    length: float
    span: Span | None = None

    #: The load kind (the kernel family that holds it: ``kernels.system.LOAD_FAMILIES``).
    kind = "spring"


@dataclass(frozen=True)
class RotationalSpringDamper:
    """Torsional spring-damper on a joint's relative angle theta.

    Torque on the second body -(k (theta - angle) + c dtheta/dt), the
    opposite on the first.
    """

    name: str
    joint: Joint
    k: float
    c: float
    angle: float
    span: Span | None = None

    #: The load kind (the kernel family that holds it: ``kernels.system.LOAD_FAMILIES``).
    kind = "rotational"


@dataclass(frozen=True)
class Torque:
    """A torque tau [N m] on one body (counter-clockwise positive): tau(t)
    (TimeFunction) or tau(t, state) (StateFunction)."""

    name: str
    body: int
    function: object
    span: Span | None = None

    @property
    def kind(self) -> str:
        """The load kind: "torque" for a function of time, "state_torque" for
        one that reads the motion (the kernel families differ:
        ``kernels.system.LOAD_FAMILIES``)."""
        return "torque" if isinstance(self.function, TimeFunction) else "state_torque"

    @property
    def functions(self) -> tuple:
        """Its function (of time, or of time and the state)."""
        return (self.function,)


@dataclass(frozen=True)
class JointForce:
    """A force F [N] acting in a prismatic or point_on_line joint along its
    line: +F u on the first (sliding) point, -F u on the line's point (an
    actuator between them); F(t) or F(t, state). Its generalized force is
    F grad s, s the joint's distance (:func:`line_distance`)."""

    name: str
    joint: "Joint"
    function: object
    span: Span | None = None

    #: The load kind (the kernel family that holds it: ``kernels.system.LOAD_FAMILIES``).
    kind = "joint_force"

    @property
    def functions(self) -> tuple:
        """Its function (of time, or of time and the state)."""
        return (self.function,)


@dataclass(frozen=True)
class Friction:
    """Coulomb friction in a joint, from the joint's own reaction.

    In a revolute joint a torque -r |R| mu(z) tanh(z/v_reg) - c z on the
    second body (the opposite on the first), z the relative rate [rad/s] and
    |R| the pin's reaction [N]; in a prismatic or point_on_line joint a force
    -|N| mu(z) tanh(z/v_reg) - c z along the line on its sliding point (the
    opposite on the line's body), z the sliding speed [m/s] and |N| the
    normal reaction [N]. mu(z) = mu + (mu_static - mu) exp(-(z/v_stribeck)^2)
    (Andersson, Soderberg & Bjorklund 2007; ``kernels.loads.friction``).

    Attributes
    ----------
    mu, mu_static : float
        Kinetic and static friction coefficients (equal: no Stribeck effect).
    v_stribeck : float
        Stribeck speed [m/s or rad/s]; 0 without a Stribeck effect.
    viscous : float
        Viscous coefficient c [N s/m or N m s/rad].
    v_reg : float
        Regularisation speed [m/s or rad/s]: a stuck joint creeps at
        v_reg atanh(load / (mu N)), below 2 v_reg while its load stays below
        0.96 mu N.
    radius : float
        Pin radius r [m] of a revolute joint (1 for a sliding joint).
    """

    name: str
    joint: "Joint"
    mu: float
    mu_static: float
    v_stribeck: float
    viscous: float
    v_reg: float
    radius: float = 1.0
    span: Span | None = None

    #: The load kind (the kernel family that holds it: ``kernels.system.LOAD_FAMILIES``).
    kind = "friction"


@dataclass(frozen=True)
class JointTorque:
    """A torque tau [N m] acting in a revolute joint: +tau on its second
    body, -tau on its first (an actuator between them); tau(t) or tau(t, state)."""

    name: str
    joint: "Joint"
    function: object
    span: Span | None = None

    #: The load kind (the kernel family that holds it: ``kernels.system.LOAD_FAMILIES``).
    kind = "joint_torque"

    @property
    def functions(self) -> tuple:
        """Its function (of time, or of time and the state)."""
        return (self.function,)


@dataclass(frozen=True)
class PointForce:
    """A force (fx, fy) [N] at a body point, in world axes: functions of time
    (:class:`TimeFunction`) or of time and the state (:class:`StateFunction`,
    with their exact partial derivatives: a follower force, a drag).

    A force declared in body axes (``frame = body``) holds here its world
    components, R(theta) (fx_body, fy_body), theta the body's angle (on a
    flexible beam the cross-section's at the point: the frame's phi plus the
    local slope of the deflection, ``BeamMesh.slope``), so that its
    derivatives with respect to theta are those of any state function.

    Attributes
    ----------
    frame : {"world", "body"}
        The axes the components were written in.
    """

    name: str
    point: PointRef
    fx: TimeFunction | StateFunction
    fy: TimeFunction | StateFunction
    span: Span | None = None
    frame: str = "world"

    #: The load kind (the kernel family that holds it: ``kernels.system.LOAD_FAMILIES``).
    kind = "point_force"

    @property
    def functions(self) -> tuple:
        """Its functions of time (fx, fy)."""
        return (self.fx, self.fy)


@dataclass(frozen=True)
class FirstOrderState:
    """A first-order state z of a controller, a filter or an electrical
    circuit: dz/dt = f(t, x), x the motion's state variables and the states
    (``state i { der = w_ref - crank.omega; initial 0 }``).

    mbdsl integrates z as the velocity of one more generalized coordinate,
    its integral s (s(t_start) = 0), of unit mass under the generalized force
    f: ds/dt = z, dz/dt = f. Each method's velocity update is then its own
    first-order formula at its order (the generalized-alpha family's for
    first-order systems, Jansen, Whiting & Hulbert 2000, for HHT and
    generalized-alpha; BDF2 for NSTIFF; Newmark's gamma rule for NEWMARK),
    and df/dx enters the Newton matrix as Q_q and Q_v do (docs/methods.md,
    "First-order states").

    Attributes
    ----------
    name : str
    index : int
        k: its pseudo body is n_bodies + k, its column
        ``CoordinateMap.state_column(k)``.
    function : TimeFunction or StateFunction
        f, its rate [unit of z / s].
    initial : float
        z(t_start).
    span : Span or None
    """

    name: str
    index: int
    function: object
    initial: float = 0.0
    span: Span | None = None

    #: The load kind of its rate, the generalized force on its integral's column
    #: (``kernels.loads.state_loads``).
    kind = "state_rate"

    @property
    def functions(self) -> tuple:
        """Its rate f (of time, or of time and the state)."""
        return (self.function,)

    def variable(self, n_bodies: int) -> StateVariable:
        """The state variable z (level 1: the velocity of its integral)."""
        return StateVariable(self.name, 1, ((n_bodies + self.index, 0, 1.0),))

    def conditions(self, n_bodies: int) -> tuple:
        """Its initial conditions, as kept ``initial`` lines: s = 0, z = z0."""
        body = n_bodies + self.index
        return (InitialCondition(body, "x", 0.0, span=self.span),
                InitialCondition(body, "vx", float(self.initial), span=self.span))


@dataclass(frozen=True)
class InitialCondition:
    """``initial body.coord = value`` or ``guess body.coord = value``.

    Attributes
    ----------
    body : int
    field : str
        One of x, y, phi (positions) or vx, vy, omega (velocities).
    value : float [m, rad, m/s or rad/s]
    guess : bool
        True: a start value the assembly may change; False: kept.
    counted : bool
        Whether it counts against the degrees of freedom (E501): of the
        nine directors a spatial body's orientation line gives (and of their
        rates), three do; the frame rows imply the other six.
    """

    body: int
    field: str
    value: float
    guess: bool = False
    span: Span | None = None
    counted: bool = True

    @property
    def is_velocity(self) -> bool:
        """True for vx, vy, omega (and a spatial body's rates, ``vz``, ``A11_t``)."""
        return self.field in VELOCITIES or self.field in SPATIAL_VELOCITIES

    def column(self, cmap: CoordinateMap) -> int:
        """Index of the coordinate in q (or v)."""
        if self.body in cmap.spatial:
            names = SPATIAL_VELOCITIES if self.is_velocity else SPATIAL_COORDINATES
        else:
            names = VELOCITIES if self.is_velocity else COORDINATES
        return cmap.column(self.body, names.index(self.field))


@dataclass(frozen=True)
class Model:
    """A checked planar multibody model, ready to assemble.

    Attributes
    ----------
    name : str
    bodies : tuple of RigidBody or FlexibleBeam
    ground_points : dict of str -> ndarray, shape (2,) [m]
    joints : tuple of Joint
    drivers : tuple of Driver
    forces : tuple of SpringDamper, RotationalSpringDamper, Torque, JointTorque, PointForce
    gravity : ndarray, shape (2,) [m/s^2], or None
    initials : tuple of InitialCondition
    settings : dict
        The ``simulate`` section: method (str), h, t_end, and method
        parameters, as given.
    parameters : dict of str -> float
    file, source, sha256 : str
        Where the model came from.
    warnings : tuple of Diagnostic
    static : bool
        Start at rest in static equilibrium (``initial static``): the
        positions the initial lines leave free are solved for equilibrium
        under the declared forces at t_start.
    outputs : tuple of Output
        ``output`` lines: columns ``output.<name>``.
    couplers : tuple of Coupler
        Gears, racks and linear couplers between joint coordinates (their
        rows after the drivers').
    tables : tuple of Table
        The model's tables y(x) (``model.table``), as its expressions call them.
    states : tuple of FirstOrderState
        First-order states (controllers, filters, circuits), in declaration
        order: their integrals are the last coordinates.
    imports : dict of str -> (str, str)
        The files of components the model imports: key (the path as the
        model's file reaches it, or ``library:NAME``) -> (text, SHA-256).
    instances : dict of str -> str
        The component instances the model was built from: path -> component.
    """

    name: str
    bodies: tuple
    ground_points: dict
    joints: tuple
    drivers: tuple
    forces: tuple
    gravity: np.ndarray | None
    initials: tuple
    settings: dict
    parameters: dict
    file: str = "<python>"
    source: str | None = None
    sha256: str = ""
    warnings: tuple = ()
    static: bool = False
    static_span: Span | None = None
    outputs: tuple = ()
    couplers: tuple = ()
    tables: tuple = ()
    states: tuple = ()
    imports: dict = field(default_factory=dict)
    instances: dict = field(default_factory=dict)
    space: int = 2

    # The model never changes once checked (a frozen dataclass): what is derived
    # from its bodies and joints below is derived once, each in one pass over them,
    # not again at each use (a 100 000-link chain's set-up reads them many times).
    @functools.cached_property
    def body_kinds(self) -> BodyKinds:
        """The bodies' kinds (:class:`~.coordinates.BodyKinds`): each one's
        width in q, names and space, read once per kind."""
        return BodyKinds(self.bodies)

    @functools.cached_property
    def frames(self) -> tuple:
        """The spatial bodies' orthonormality rows (``model.spatial.Frame``),
        constraint elements after the couplers."""
        from .spatial import Frame
        kinds = self.body_kinds
        return tuple(Frame(b.index, b.name, b.span) for b in
                     (self.bodies[i] for i in kinds.code_in(kinds.width == 12).tolist()))

    @functools.cached_property
    def n_coordinates(self) -> int:
        """n, the number of generalized coordinates (3 per body, 2 per
        particle, plus the elastic coordinates of the flexible beams, plus
        one per first-order state, its integral)."""
        kinds = self.body_kinds
        return (int(kinds.body_width.sum())
                + sum(b.n_elastic for b in self.flexible_bodies) + len(self.states))

    @functools.cached_property
    def coordinate_map(self) -> CoordinateMap:
        """Where each body's coordinates are in q (:class:`CoordinateMap`)."""
        return CoordinateMap(self.bodies, self.n_coordinates, len(self.states),
                             self.body_kinds)

    @property
    def loads(self) -> tuple:
        """What adds to Q: the forces, then the first-order states' rates
        (each the generalized force on its integral's column)."""
        return tuple(self.forces) + tuple(self.states)

    @property
    def state_conditions(self) -> tuple:
        """The first-order states' initial conditions (s = 0, z = z0), kept
        as ``initial`` lines are (``FirstOrderState.conditions``)."""
        nb = len(self.bodies)
        return tuple(ic for s in self.states for ic in s.conditions(nb))

    @functools.cached_property
    def flexible_bodies(self) -> tuple:
        """The :class:`FlexibleBeam` bodies, in body order."""
        kinds = self.body_kinds
        return tuple(self.bodies[i] for i in kinds.code_in(kinds.flexible).tolist())

    @functools.cached_property
    def constraint_rows(self) -> np.ndarray:
        """The number of constraint rows of each element of
        :attr:`constraint_elements`, in row order, shape (elements,)."""
        elements = self.constraint_elements
        return np.fromiter(map(_rows, elements), dtype=np.intp, count=len(elements))

    @property
    def n_constraints(self) -> int:
        """m, the number of constraint equations (joints, drivers, couplers and
        the spatial bodies' frames)."""
        return int(self.constraint_rows.sum())

    @property
    def dof(self) -> int:
        """Degrees of freedom of the mechanism by Gruebler's count, n - m
        (the first-order states' integrals not counted)."""
        return self.n_coordinates - len(self.states) - self.n_constraints

    def body(self, name: str) -> RigidBody:
        """The body called ``name``.

        Raises
        ------
        KeyError
        """
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    @functools.cached_property
    def body_names(self) -> list[str]:
        """The bodies' names, in order, length n_bodies."""
        return body_names(self.bodies)

    def _names(self, which: int, elastic: str, state: str) -> list[str]:
        """The names of q's (``which`` 0), v's (1) or a's (2) entries: the
        bodies' by their kinds, the beams' elastic coordinates with the suffix
        ``elastic``, the first-order states' as ``state.<name><state>``."""
        names = self.body_kinds.names(self.body_names, which)
        names += [f"{b.name}.{c}{elastic}" for b in self.flexible_bodies for c in b.mesh.names]
        names += [f"state.{s.name}{state}" for s in self.states]
        return names

    def coordinate_names(self) -> list[str]:
        """``["crank.x", "crank.y", "crank.phi", ...]``, shape (n,)."""
        return self._names(0, "", ".integral")

    def velocity_names(self) -> list[str]:
        """``["crank.vx", "crank.vy", "crank.omega", ...]``, shape (n,)."""
        return self._names(1, "_t", "")

    def acceleration_names(self) -> list[str]:
        """``["crank.ax", "crank.ay", "crank.alpha", ...]``, shape (n,)."""
        return self._names(2, "_tt", ".rate")

    @functools.cached_property
    def constraint_elements(self) -> tuple:
        """The elements with constraint rows, in row order: the joints, the
        drivers, the couplers, then the spatial bodies' frames."""
        return tuple(self.joints) + tuple(self.drivers) + tuple(self.couplers) + self.frames

    def constraint_names(self) -> list[tuple[str, int]]:
        """(element name, row within element) for each constraint row, shape (m,)."""
        return list(row_names([e.name for e in self.constraint_elements], self.constraint_rows))


_rows = operator.attrgetter("rows")


def row_names(names, counts):
    """(element name, row within it) of each constraint row, in row order,
    from the elements' names and their numbers of rows (an iterator)."""
    return ((name, k) for name, r in zip(names, np.asarray(counts).tolist()) for k in range(r))
