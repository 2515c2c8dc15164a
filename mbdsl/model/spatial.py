"""Spatial rigid bodies in director (natural) coordinates.

A spatial body's configuration is its centre of mass r and the three body
axes in world components, the columns of its rotation matrix
A = [a1 a2 a3] (the *directors*): twelve coordinates,

    q_i = (x, y, z, A11, A21, A31, A12, A22, A32, A13, A23, A33),

held orthonormal by six constraint rows per body (:class:`Frame`),
a_k . a_l - delta_kl = 0 (k <= l). A body point is at r + A s = r + sum_k
s_k a_k, linear in q. With the body axes principal, the kinetic energy is

    T = 1/2 m |r'|^2 + 1/2 sum_k Jbar_k |a_k'|^2,   Jbar_k = int rho s_k^2 dV
                                                          = (J_l + J_m - J_k) / 2,

so the mass matrix is constant and diagonal, diag(m I3, Jbar_1 I3,
Jbar_2 I3, Jbar_3 I3), and the equations of motion keep the paper's form
M q'' + Phi_q^T lambda = Q, Phi(q, t) = 0 with no quadratic velocity term:
the gyroscopic couples are carried by the frame rows' multipliers. Every
joint of Haug's library is a polynomial of degree at most 2 in q (a point is
linear, a dot product of two body vectors bilinear), so Phi's Hessians are
constant. Sources: J. Garcia de Jalon and E. Bayo, Kinematic and Dynamic
Simulation of Multibody Systems (1994), ch. 3 (natural coordinates); P.
Betsch and P. Steinmann, Constrained integration of rigid body dynamics,
CMAME 191 (2001) 467-488 (the director formulation and its mass matrix);
docs/methods.md, "Spatial bodies", says why mbdsl uses it instead of Euler
parameters.

Rotation helpers: :func:`zyx`, :func:`axis_angle`, :func:`euler_parameters`
(Shepperd's method) and :func:`body_angular_velocity`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import Span

__all__ = ["SpatialBody", "SpatialParticle", "Frame", "SpatialSpring", "SpatialRotationalSpring", "SpatialLoad",
           "SpatialStateLoad", "DIRECTORS", "SPATIAL_COORDINATES", "SPATIAL_VELOCITIES",
           "SPATIAL_ACCELERATIONS", "zyx", "zyx_angles", "axis_angle", "euler_parameters",
           "body_angular_velocity", "director_inertia", "reference_vectors"]

#: The directors' coordinate names: A_ij, row i (world axis), column j (body axis).
DIRECTORS = tuple(f"A{i}{j}" for j in (1, 2, 3) for i in (1, 2, 3))
SPATIAL_COORDINATES = ("x", "y", "z") + DIRECTORS
SPATIAL_VELOCITIES = ("vx", "vy", "vz") + tuple(f"{d}_t" for d in DIRECTORS)
SPATIAL_ACCELERATIONS = ("ax", "ay", "az") + tuple(f"{d}_tt" for d in DIRECTORS)


#: Per spatial joint kind, what each row holds, in row order: F, a point (its multiplier a
#: force [N]), or T, a direction (a dot product of two body axes: a couple [N m]);
#: ``kernels.joints.spatial._rows_of`` writes the rows in this order.
SPATIAL_ROW_UNITS = {"spherical": "FFF", "revolute": "FFFTT", "universal": "FFFT",
                     "cylindrical": "TTFF", "point_on_line": "FF", "point_on_plane": "F",
                     "distance": "F", "fixed": "FFFTTT", "prismatic": "TTTFF"}


def director_inertia(inertia) -> np.ndarray:
    """Jbar (3,) [kg m^2], the second moments int rho s_k^2 dV of a body
    with principal moments of inertia J (3,): Jbar_k = (J_l + J_m - J_k) / 2
    (Betsch and Steinmann 2001, eq. 2.5). Non-negative exactly when J
    satisfies the triangle inequalities."""
    J = np.asarray(inertia, float)
    return 0.5 * (J.sum() - 2.0 * J)


@dataclass(frozen=True)
class SpatialBody:
    """A spatial rigid body (``space 3d``), in director coordinates.

    Attributes
    ----------
    name : str
    index : int
        Position in the model's body list.
    mass : float [kg]
    inertia : ndarray, shape (3,) [kg m^2]
        Principal moments of inertia about the centre of mass, along the
        body axes.
    points : dict of str -> ndarray, shape (3,) [m]
        Body-fixed points relative to the centre of mass, in body axes;
        ``cm`` is (0, 0, 0).
    shapes : tuple
        What is drawn (none yet for spatial bodies).
    axes : dict of str -> ndarray, shape (3,)
        Unit directions for its joints, in body axes: x, y, z and its
        ``axis`` lines.
    """

    name: str
    index: int
    mass: float
    inertia: np.ndarray
    points: dict
    span: Span | None = None
    shapes: tuple = ()
    particle: bool = False
    axes: dict = field(default_factory=dict)

    #: Its coordinates, velocities and accelerations, in order (12 each).
    coordinate_fields = SPATIAL_COORDINATES
    velocity_fields = SPATIAL_VELOCITIES
    acceleration_fields = SPATIAL_ACCELERATIONS
    #: The space it moves in (``model.coordinates.CoordinateMap``).
    space = 3

    @property
    def mass_diagonal(self) -> np.ndarray:
        """The diagonal of its block of M, shape (12,): m three times, then
        Jbar_k three times for each director (:func:`director_inertia`)."""
        return np.repeat(np.concatenate([[self.mass], director_inertia(self.inertia)]), 3)


@dataclass(frozen=True)
class SpatialParticle:
    """A point mass of a spatial model (``particle NAME { mass m }``): three
    coordinates, its position r, and no directors: it does not turn, so
    joints and loads attach at its one point ``cm`` and none reads an axis
    of it. Its block of M is m I (3 x 3).

    Attributes
    ----------
    name : str
    index : int
        Position in the model's body list.
    mass : float [kg]
    points : dict of str -> ndarray, shape (3,) [m]
        ``cm`` only, (0, 0, 0).
    shapes : tuple
        What is drawn at its position (spheres).
    """

    name: str
    index: int
    mass: float
    points: dict
    span: Span | None = None
    shapes: tuple = ()
    particle: bool = True
    axes: dict = field(default_factory=dict)

    #: Its coordinates, velocities and accelerations, in order (3 each).
    coordinate_fields = SPATIAL_COORDINATES[:3]
    velocity_fields = SPATIAL_VELOCITIES[:3]
    acceleration_fields = SPATIAL_ACCELERATIONS[:3]
    #: The space it moves in (``model.coordinates.CoordinateMap``).
    space = 3

    @property
    def mass_diagonal(self) -> np.ndarray:
        """The diagonal of its block of M, shape (3,): m three times."""
        return np.full(3, self.mass)


@dataclass(frozen=True)
class Frame:
    """The six orthonormality rows of a spatial body's directors,
    a_k . a_l - delta_kl = 0 for k <= l (in the order (1, 1), (2, 2), (3, 3),
    (1, 2), (2, 3), (1, 3): ``kernels.joints.spatial``): a constraint
    element of its own, after the joints, drivers and couplers. Their
    multipliers are the internal stresses that keep the body rigid [N m].

    Attributes
    ----------
    body : int
        The body's index.
    name : str
        The body's name (the rows' element name: ``lambda.<body>.k``).
    """

    body: int
    name: str
    span: Span | None = None
    kind: str = "frame"
    rows: int = 6


@dataclass(frozen=True)
class SpatialSpring:
    """A spring-damper-actuator between two points of a spatial model (TSDA,
    ``kernels.loads.spatial_springs``): tension f = k (l - length) + c dl/dt
    along the line of the points, pulling them together when positive.

    Attributes
    ----------
    name : str
    first, second : PointRef
        Local points (3,) [m] of spatial bodies (or the ground's, world).
    k : float [N/m]
    c : float [N s/m]
    length : float [m]
        The free length.
    """

    name: str
    first: object
    second: object
    k: float
    c: float
    length: float
    span: Span | None = None

    #: The load kind (its kernel family: ``kernels.system.LOAD_FAMILIES``).
    kind = "tsda"


@dataclass(frozen=True)
class SpatialRotationalSpring:
    """A rotational spring-damper-actuator about a spatial revolute's or
    cylindrical's axis (RSDA, ``kernels.loads.spatial_rotational``): torque
    -(k (theta - angle) + c dtheta/dt) about the first body's joint axis on
    the second body, the opposite on the first; theta the joint's angle
    (``kernels.joints.spatial_angles``), theta - angle taken within half a
    turn.

    Attributes
    ----------
    name : str
    joint : Joint
        A spatial revolute or cylindrical joint.
    k : float [N m/rad]
    c : float [N m s/rad]
    angle : float [rad]
        The spring's rest angle.
    """

    name: str
    joint: object
    k: float
    c: float
    angle: float
    span: Span | None = None

    #: The load kind (its kernel family: ``kernels.system.LOAD_FAMILIES``).
    kind = "rsda"


@dataclass(frozen=True)
class SpatialLoad:
    """A force on a point or a torque on a spatial body, of time, in world
    or body axes (``kernels.loads.spatial_loads``). Its generalized force
    (Haug 1989, sec. 11.3; the director form of ``model.spatial``): a force F
    at s gives F on r and s_k F on the director a_k; a torque T gives
    T x a_k / 2 on a_k (sum_k a_k x (T x a_k) / 2 = T for orthonormal a_k,
    so its virtual work on a rotation d theta is T . d theta).

    Attributes
    ----------
    name : str
    kind : {"spatial_force", "spatial_torque"}
    body : int
    local : ndarray, shape (3,) [m]
        The force's point in body axes (zeros for a torque).
    components : tuple of 3 TimeFunction
        [N] or [N m], along the world axes, or the body's with ``frame``
        "body" (then turning with it: a follower load).
    frame : {"world", "body"}
    """

    name: str
    kind: str
    body: int
    local: np.ndarray
    components: tuple
    frame: str = "world"
    span: Span | None = None


@dataclass(frozen=True)
class SpatialStateLoad:
    """A load of a spatial model that reads the motion, or acts along a
    joint's turning axis or line: ``force(B.p, (fx, fy, fz))`` and
    ``torque(B, ...)`` with components of the state, ``joint_torque(J, tau)``
    and ``joint_force(J, F)``. It is held as its generalized force entry by
    entry: each a function of t and of state variables linear in q or v
    (the bodies' r, directors a_k and their rates), so that the Newton
    matrix has its exact derivatives by symbolic differentiation
    (``kernels.loads.state_loads``: Q = sum over the entries of Q_j(t, x) on
    its column). The entries are :class:`SpatialLoad`'s generalized force: F
    on r and s_k F on a_k for a force F at s, T x a_k / 2 on a_k for a
    torque T, with F (T) in body axes turned to the world's by the
    directors, F = sum_l f_l a_l; a joint's torque tau u on its second body
    and -tau u on its first, a joint's force F u and -F u on its points.

    Attributes
    ----------
    name : str
    entries : tuple of (int, int, StateFunction)
        (body, its coordinate 0..11 as ``SPATIAL_COORDINATES``, the
        generalized force [N] on r, [N m] on a director).
    torque : bool
        A torque (else a force), for messages.
    """

    name: str
    entries: tuple
    torque: bool = False
    span: Span | None = None

    #: The load kind (its kernel family: ``kernels.system.LOAD_FAMILIES``).
    kind = "spatial_state_load"

    @property
    def functions(self) -> tuple:
        """Its entries' functions of time and the state, in order."""
        return tuple(fn for _, _, fn in self.entries)


def reference_vectors(first_axis, second_axis) -> np.ndarray:
    """(f_1, g_1, f_2) (9,) of a joint whose axes are ``first_axis`` (body 1)
    and ``second_axis`` (body 2), unit (3,) in body axes, across which its
    angle is measured (``kernels.joints.spatial_angles``' notes): f_1
    across a_1 (across the body axis least aligned with it), g_1 = a_1 x f_1,
    f_2 = R_m f_1 with R_m the least rotation taking a_1 to a_2 (Rodrigues;
    for opposite axes a half turn about f_1)."""
    a1 = np.asarray(first_axis, float) / np.linalg.norm(first_axis)
    a2 = np.asarray(second_axis, float) / np.linalg.norm(second_axis)
    f1 = np.cross(np.eye(3)[int(np.argmin(np.abs(a1)))], a1)
    f1 /= np.linalg.norm(f1)
    g1 = np.cross(a1, f1)
    k, cos = np.cross(a1, a2), float(a1 @ a2)
    if np.linalg.norm(k) < 1e-12:
        f2 = f1.copy()                          # the same axis, or a half turn about f_1
    else:
        K = np.cross(k, np.eye(3))              # rows k x e_i: x @ K = k x x
        f2 = f1 + f1 @ K + (f1 @ K) @ K / (1.0 + cos)
    return np.r_[f1, g1, f2]


def zyx(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """The rotation matrix (3, 3) of z-y'-x'' angles [rad] (yaw about z,
    then pitch about the new y, then roll about the newest x): A = Rz Ry Rx,
    its columns the body axes in world components."""
    cz, sz, cy, sy, cx, sx = (np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch),
                              np.cos(roll), np.sin(roll))
    Rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    Ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    return Rz @ Ry @ Rx


def zyx_angles(A) -> np.ndarray:
    """The z-y'-x'' angles (..., 3) = (yaw, pitch, roll) [rad] of rotation
    matrices A (..., 3, 3), the inverse of :func:`zyx`: yaw and roll in
    (-pi, pi], pitch in [-pi/2, pi/2] (at pitch = +-pi/2, gimbal lock, the
    split between yaw and roll is arbitrary: roll is taken 0). Source:
    Diebel, "Representing attitude", 2006, sec. 5.6 (the 3-2-1 sequence)."""
    A = np.asarray(A, float)
    pitch = np.arcsin(np.clip(-A[..., 2, 0], -1.0, 1.0))
    locked = np.hypot(A[..., 0, 0], A[..., 1, 0]) < 1e-12
    yaw = np.where(locked, np.arctan2(-A[..., 0, 1], A[..., 1, 1]),
                   np.arctan2(A[..., 1, 0], A[..., 0, 0]))
    roll = np.where(locked, 0.0, np.arctan2(A[..., 2, 1], A[..., 2, 2]))
    return np.stack([yaw, pitch, roll], axis=-1)


def axis_angle(axis, angle: float) -> np.ndarray:
    """The rotation matrix (3, 3) of ``angle`` [rad] about ``axis`` (3,)
    (normalized here; Rodrigues' formula).

    Raises
    ------
    ValueError
        A zero axis.
    """
    u = np.asarray(axis, float)
    norm = np.linalg.norm(u)
    if not norm > 0.0:
        raise ValueError("the rotation axis is zero")
    u = u / norm
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


def euler_parameters(A: np.ndarray) -> np.ndarray:
    """Euler parameters (..., 4) = (e0, e1, e2, e3), e0 >= 0, of rotation
    matrices A (..., 3, 3), by Shepperd's method (Shepperd, J. Guidance
    Control 1 (1978) 223; Haug 1989, sec. 9.3.3): the largest of the four
    squares is taken first, so that no division is by a small number."""
    A = np.asarray(A, float)
    tr = np.trace(A, axis1=-2, axis2=-1)
    d = np.stack([tr, A[..., 0, 0], A[..., 1, 1], A[..., 2, 2]], axis=-1)
    k = np.argmax(d, axis=-1)
    e = np.empty(A.shape[:-2] + (4,))
    a = lambda i, j: A[..., i, j]                                   # noqa: E731
    with np.errstate(divide="ignore", invalid="ignore"):   # each case on every row; kept where chosen
        _shepperd(A, a, tr, k, e)
    return np.where(e[..., :1] < 0.0, -e, e)


def _shepperd(A, a, tr, k, e):
    """The four cases of :func:`euler_parameters` into e, each where k chose it."""
    for case in range(4):
        sel = k == case
        if not np.any(sel):
            continue
        if case == 0:
            w = np.sqrt(np.maximum(1.0 + tr, 0.0)) / 2.0
            v = np.stack([w, (a(2, 1) - a(1, 2)) / (4 * w), (a(0, 2) - a(2, 0)) / (4 * w),
                          (a(1, 0) - a(0, 1)) / (4 * w)], axis=-1)
        else:
            i = case - 1
            j, m = (i + 1) % 3, (i + 2) % 3
            w = np.sqrt(np.maximum(1.0 + 2.0 * a(i, i) - tr, 0.0)) / 2.0
            v = np.empty(A.shape[:-2] + (4,))
            v[..., 0] = (a(m, j) - a(j, m)) / (4 * w)
            v[..., 1 + i] = w
            v[..., 1 + j] = (a(j, i) + a(i, j)) / (4 * w)
            v[..., 1 + m] = (a(m, i) + a(i, m)) / (4 * w)
        e[sel] = v[sel]


def body_angular_velocity(A: np.ndarray, A_t: np.ndarray) -> np.ndarray:
    """Angular velocity in body axes (..., 3) [rad/s] from the directors and
    their rates (..., 3, 3): the skew matrix A^T A' = [omega]x (Haug 1989,
    eq. 9.2.30), read from its antisymmetric part."""
    W = np.swapaxes(A, -1, -2) @ A_t
    return 0.5 * np.stack([W[..., 2, 1] - W[..., 1, 2], W[..., 0, 2] - W[..., 2, 0],
                           W[..., 1, 0] - W[..., 0, 1]], axis=-1)
