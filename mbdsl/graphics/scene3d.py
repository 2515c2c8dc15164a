"""What the drawing of a spatial model shows (``space 3d``), frame by frame,
and the camera that projects it: a perspective view (a pinhole camera) from
a fixed viewpoint above and beside the motion, computed once from the
positions of every frame so that nothing leaves the picture.

A body is drawn with its ``shape`` lines (lines, spheres, cylinders, boxes in
its frame) or, without them, as lines from its centre of mass to each of its
points and attachments; every body also has a dot at its centre of mass.
Joints are small circles at their first point, spring-dampers thin lines,
ground attachments grey crosses. The projection is ours (not matplotlib's
3D axes), so a test can hold a rendered pixel against
:meth:`Camera.project` of the body's position, and the painter's order
(farther items first) is set per frame by depth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.elements import GROUND
from .scene import COLORS, Drawing

__all__ = ["Camera", "SpatialScene", "Item3D", "circle"]


def _up_frame(up):
    """(u, e1, e2): ``up`` made a unit vector and two unit vectors across it,
    a right-handed frame (the floor's plane, the camera's azimuth)."""
    u = np.asarray(up, float) / np.linalg.norm(up)
    e1 = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    return u, e1, np.cross(u, e1)


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: a point ``eye`` [m] looking at ``target`` [m] with
    ``up`` the world direction drawn upward and ``focal`` the focal length
    (screen units per unit of depth).

    Source: the standard look-at perspective projection (Foley, van Dam et
    al., Computer Graphics, 2nd ed., sec. 6.5).
    """

    eye: np.ndarray
    target: np.ndarray
    up: np.ndarray
    focal: float = 1.0

    @property
    def axes(self) -> np.ndarray:
        """(3, 3): rows right, up (on the screen) and forward, unit vectors."""
        fwd = self.target - self.eye
        fwd = fwd / np.linalg.norm(fwd)
        right = np.cross(fwd, self.up)
        right = right / np.linalg.norm(right)
        return np.array([right, np.cross(right, fwd), fwd])

    def depth(self, p) -> np.ndarray:
        """Distance along the view direction [m] of points p (..., 3)."""
        return (np.asarray(p, float) - self.eye) @ self.axes[2]

    def project(self, p) -> np.ndarray:
        """Screen coordinates (..., 2) of world points p (..., 3): focal x
        (right, up) components over the depth."""
        c = (np.asarray(p, float) - self.eye) @ self.axes.T
        return self.focal * c[..., :2] / c[..., 2:3]

    @staticmethod
    def viewing(points, up=(0.0, 0.0, 1.0), azimuth=-55.0, elevation=25.0,
                distance=3.0) -> "Camera":
        """A camera looking at the centre of ``points`` (k, 3) [m] from
        ``azimuth`` and ``elevation`` [deg] about the ``up`` axis, at
        ``distance`` times their spread (at least 0.1 m)."""
        pts = np.asarray(points, float).reshape(-1, 3)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        centre, size = 0.5 * (lo + hi), max(float(np.max(hi - lo)), 0.1)
        u, e1, e2 = _up_frame(up)
        az, el = np.radians(azimuth), np.radians(elevation)
        d = np.cos(el) * (np.cos(az) * e1 + np.sin(az) * e2) + np.sin(el) * u
        return Camera(centre + distance * size * d, centre, u)


@dataclass(frozen=True)
class Item3D:
    """One drawn thing of a :class:`SpatialScene`.

    Attributes
    ----------
    kind : {"line", "sphere", "cylinder", "box", "cm", "spring", "joint"}
    body : str or None
        The body it belongs to (None: a spring or joint).
    color : str
        ``#rrggbb``.
    radius : float [m]
        Of a sphere or cylinder (0 otherwise).
    """

    kind: str
    body: str | None
    color: str
    radius: float = 0.0


#: a box's twelve edges (pairs of its corners, ``Shape.points`` order) and six faces
BOX_FACES = ((0, 1, 3, 2), (4, 5, 7, 6), (0, 1, 5, 4), (2, 3, 7, 6), (0, 2, 6, 4), (1, 3, 7, 5))
#: points of a wireframe's circle (``SpatialScene.wires``)
WIRE_CIRCLE = 25


def circle(centre, normal, radius, points: int = WIRE_CIRCLE) -> np.ndarray:
    """A closed circle (points, 3) [m] about ``centre`` (3,) in the plane
    normal to ``normal`` (3,), its first point repeated last."""
    _, e1, e2 = _up_frame(normal)
    a = np.linspace(0.0, 2.0 * np.pi, points)[:, None]
    return np.asarray(centre, float) + radius * (np.cos(a) * e1 + np.sin(a) * e2)


class SpatialScene(Drawing):
    """The drawing of a spatial model (module notes).

    Parameters
    ----------
    model : Model
        A spatial model (``model.space == 3``).

    Attributes
    ----------
    items : list of Item3D
        Bodies' shapes (or skeletons), their centres of mass, springs, joints.
    """

    def __init__(self, model):
        if getattr(model, "space", 2) != 3:
            raise ValueError("SpatialScene draws spatial models (space 3d)")
        self.model, self.cmap = model, model.coordinate_map
        self.springs = [f for f in model.forces if hasattr(f, "first") and hasattr(f, "second")]
        attach = {b.index: [np.asarray(p, float) for p in b.points.values()]
                  for b in model.bodies}
        for ref in [p for j in model.joints for p in (j.first, j.second)] + \
                [p for s in self.springs for p in (s.first, s.second)]:
            if ref.body != GROUND:
                attach[ref.body].append(np.asarray(ref.local, float))
        self.items, self._parts = [], []
        for b in model.bodies:
            color = COLORS[b.index % len(COLORS)]
            if b.shapes:
                for s in b.shapes:
                    self._add(Item3D(s.kind, b.name, color, float(s.radius)),
                              (b.index, np.asarray(s.points, float)))
            else:
                for p in attach[b.index]:
                    if np.linalg.norm(p) > 0.0:
                        self._add(Item3D("line", b.name, color),
                                  (b.index, np.array([np.zeros(3), p])))
            self._add(Item3D("cm", b.name, color), (b.index, np.zeros((1, 3))))
        for s in self.springs:
            self._add(Item3D("spring", None, "#000000"), (None, (s.first, s.second)))
        for j in model.joints:
            if getattr(j, "first", None) is not None:
                self._add(Item3D("joint", None, "#000000"), (None, (j.first,)))

    def frame(self, q, body):
        """(r (3,), A (3, 3)) of a spatial body at q (n,): its centre of mass
        and the rotation matrix whose columns are its axes (its directors); a
        particle's A the identity (it does not turn)."""
        col = self.cmap.spatial[body]
        if self.cmap.spatial_width[body] != 12:
            return q[col:col + 3], np.eye(3)
        return q[col:col + 3], q[col + 3:col + 12].reshape(3, 3).T

    def world(self, q, body, local) -> np.ndarray:
        """World positions (k, 3) [m] of body-frame points local (k, 3); the
        ground's points are world points already."""
        local = np.asarray(local, float).reshape(-1, 3)
        if body == GROUND:
            return local
        r, A = self.frame(q, body)
        return r + local @ A.T

    def coordinates(self, q) -> list:
        """World coordinates of every item at q (n,): per item (k, 3)."""
        out = []
        for body, what in self._parts:
            if body is not None:
                out.append(self.world(q, body, what))
            else:
                out.append(np.vstack([self.world(q, p.body, p.local) for p in what]))
        return out

    def wires(self, q) -> list:
        """Per item, the polylines (k, 3) [m] that draw it at q (n,) as a
        wireframe (``mbdsl view``): a line, spring or box edge as itself, a
        sphere as three great circles about its body's axes (so that its
        turning shows), a cylinder as its two end circles and four lines
        along it; a centre of mass or joint as its one point (1, 3)."""
        out = []
        for (body, _), item, w in zip(self._parts, self.items, self.coordinates(q)):
            if item.kind == "box":
                out.append([w[list(f) + [f[0]]] for f in BOX_FACES])
            elif item.kind == "sphere":
                A = self.frame(q, body)[1]
                out.append([circle(w[0], A[:, k], item.radius) for k in range(3)])
            elif item.kind == "cylinder":
                ends = [circle(c, w[1] - w[0], item.radius) for c in w[:2]]
                quarter = (WIRE_CIRCLE - 1) // 4
                out.append(ends + [np.array([ends[0][k], ends[1][k]])
                                   for k in range(0, 4 * quarter, quarter)])
            else:
                out.append([w])
        return out

    def ground_points(self) -> np.ndarray:
        """(k, 3): the ground's attachment points [m]."""
        pts = [np.asarray(p.local, float) for j in self.model.joints
               for p in (getattr(j, "first", None), getattr(j, "second", None))
               if p is not None and p.body == GROUND]
        pts += [np.asarray(p.local, float) for s in self.springs for p in (s.first, s.second)
                if p.body == GROUND]
        return np.array(pts).reshape(-1, 3)

    @staticmethod
    def floor(points, up, lines: int = 11) -> list:
        """A square grid (``lines`` lines each way) under ``points`` (k, 3),
        normal to ``up``, one spread wide: a list of (2, 3) segments [m]."""
        pts = np.asarray(points, float).reshape(-1, 3)
        u, e1, e2 = _up_frame(up)
        heights, a, b = pts @ u, pts @ e1, pts @ e2
        half = 0.6 * max(np.ptp(a), np.ptp(b), 0.1)
        o = heights.min() * u + 0.5 * (a.min() + a.max()) * e1 + 0.5 * (b.min() + b.max()) * e2
        ticks = np.linspace(-half, half, lines)
        return ([np.array([o + s * e1 - half * e2, o + s * e1 + half * e2]) for s in ticks]
                + [np.array([o + s * e2 - half * e1, o + s * e2 + half * e1]) for s in ticks])

    def camera(self, qs) -> Camera:
        """The camera for the frames qs (N, n): looking at everything drawn
        in any of them, world z up unless gravity says otherwise (up is
        against gravity)."""
        pts = [self.ground_points()]
        for q in qs[:: max(1, len(qs) // 50)]:
            pts += self.coordinates(q)
        g = self.model.gravity
        up = (0.0, 0.0, 1.0) if g is None or not np.any(g) else -np.asarray(g, float)
        return Camera.viewing(np.vstack(pts), up=up)
