"""The first guess of the positions: bodies placed along the spanning tree of
the joint graph (``model.graph``), each taking its angle from an
``initial``/``guess`` line or a driver's value at t0 (else its parent's angle
for fixed and prismatic joints, else 0) and translated so that its tree
joint holds. The initial conditions start from it
(``assembly.initial``), and a coupler whose constant is not given takes its
relation's value there (``model.elements.Coupler``).

Source: Haug, Computer-Aided Kinematics and Dynamics of Mechanical Systems,
sec. 3.6 (assembly).
"""

from __future__ import annotations

import math

import numpy as np

from ..model import graph
from ..model.elements import GROUND

__all__ = ["place_bodies"]


def place_bodies(system, t0: float = 0.0, notes: list | None = None, kernels=None) -> np.ndarray:
    """Initial guess of q from the spanning tree of the joint graph, shape (n,).

    Each body is placed so that its tree joint holds: a revolute, fixed or
    sliding joint's two points coincide; a joint whose family says where its
    far point starts (``start_point``, ``kernels.system.joint_hook``: a
    distance joint's at its length along gravity, along -y without gravity,
    or on its circle at a given x or y) puts it there, and what was chosen is
    appended to ``notes`` (strings for the "solved for" line) when given.

    Parameters
    ----------
    system : AssembledSystem
    t0 : float [s]
        The time at which drivers give their values.
    notes : list of str, optional
    kernels : module, optional
        The kernels whose joint families place a joint's far point
        (``K.joint_hook``); the system's own by default (the packing passes
        the kernels it packs for, before the system has them).

    Returns
    -------
    ndarray, shape (n,)
    """
    model = system.model
    if system.cmap.spatial:
        return _place_spatial(system, t0)
    g = np.asarray(model.gravity, float) if model.gravity is not None else np.zeros(2)
    down, along = ((g / np.linalg.norm(g), "gravity") if np.linalg.norm(g) > 0.0
                   else (np.array([0.0, -1.0]), "-y"))
    K = kernels if kernels is not None else system.kernel_model().K
    cmap = system.cmap
    q = np.zeros(system.n + 3)          # extended: ground (and particles' phi) at n..n+2 stay 0
    given = {}
    for ic in model.initials:
        if not ic.is_velocity:
            given[(ic.body, ic.field)] = ic.value
    coordinate_drivers = {(d.body, ("x", "y", "phi")[d.coord]): d.function.f(t0)
                          for d in model.drivers if d.kind == "coordinate"}
    angle_drivers = {d.joint.name: d.function.f(t0) for d in model.drivers
                     if d.kind == "joint_angle"}
    given.update(coordinate_drivers)
    placed = {GROUND}

    # body by body along the tree, in scalars (numpy's per-call overhead on (2,)
    # arrays was most of the set-up of a 100 000-link chain)
    def _angle(b):
        return 0.0 if b == GROUND else float(q[cmap.column(b, 2)])

    def _turned(phi, local):
        c, s = math.cos(phi), math.sin(phi)
        return np.array([c * local[0] - s * local[1], s * local[0] + c * local[1]])

    def _point(ref):
        if ref.body == GROUND:
            return ref.local
        cx, cy = cmap.column(ref.body, 0), cmap.column(ref.body, 1)
        return np.array([q[cx], q[cy]]) + _turned(_angle(ref.body), ref.local)

    for parent, child, joint in graph.spanning_tree_edges(model):
        phi = given.get((child, "phi"))
        if phi is None and joint is not None:
            sign = 1.0 if joint.second.body == child else -1.0
            if joint.name in angle_drivers:
                phi = _angle(parent) + sign * angle_drivers[joint.name]
            elif joint.kind in ("fixed", "prismatic"):
                phi = _angle(parent) + sign * joint.angle
        cx, cy, cp = (cmap.column(child, k) for k in range(3))
        if cp < system.n:                   # a particle does not turn
            q[cp] = phi if phi is not None else 0.0
        if joint is not None:
            mine, theirs = ((joint.second, joint.first) if joint.second.body == child
                            else (joint.first, joint.second))
            target = _point(theirs)
            offset = _turned(float(q[cp]), mine.local)
            start = K.joint_hook(joint.kind, "start_point")
            if start is not None:
                target, how = start(joint, target, offset, down, along,
                                    given.get((child, "x")), given.get((child, "y")))
                if how and notes is not None:
                    notes.append(f"'{joint.name}' placed {how}")
            q[[cx, cy]] = target - offset
        for k, name in enumerate(("x", "y")):
            if (child, name) in given:
                q[(cx, cy)[k]] = given[(child, name)]
        placed.add(child)
    return q[:system.n]


def _place_spatial(system, t0) -> np.ndarray:
    """The first guess of a spatial model (``model.spatial``): each body's
    directors as its ``initial`` or ``guess`` lines give them (else the
    world axes), then, along the spanning tree, its centre of mass where
    its joint's point meets the placed body's, r = p - A s (else its given
    or driven x, y, z at t0, or the origin)."""
    model, cmap = system.model, system.cmap
    q = np.zeros(system.n)
    given = {(ic.body, ic.field): ic.value for ic in model.initials if not ic.is_velocity}
    given.update({(d.body, "xyz"[d.coord]): d.function.f(t0) for d in model.drivers
                  if d.kind == "coordinate"})
    for b, col in cmap.spatial.items():
        fields = model.bodies[b].coordinate_fields
        if cmap.spatial_width[b] == 12:
            q[col + 3:col + 12] = np.eye(3).T.ravel()
        for k, name in enumerate(fields):
            if (b, name) in given:
                q[col + k] = given[(b, name)]

    def _frame(b):
        """(r, A) of body b; a particle's A the identity (its point is cm)."""
        col = cmap.spatial[b]
        if cmap.spatial_width[b] == 3:
            return q[col:col + 3], np.eye(3)
        return q[col:col + 3], q[col + 3:col + 12].reshape(3, 3).T

    for parent, child, joint in graph.spanning_tree_edges(model):
        col = cmap.spatial[child]
        if joint is not None:
            mine, theirs = ((joint.second, joint.first) if joint.second.body == child
                            else (joint.first, joint.second))
            if theirs.body == GROUND:
                target = np.asarray(theirs.local, float)
            else:
                r, A = _frame(theirs.body)
                target = r + A @ theirs.local
            q[col:col + 3] = target - _frame(child)[1] @ mine.local
        for k in range(3):
            if (child, "xyz"[k]) in given:
                q[col + k] = given[(child, "xyz"[k])]
    return q
