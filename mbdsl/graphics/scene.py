"""What a drawing of the mechanism shows, frame by frame: the geometry the
animation (``plotting.animate_solution``, matplotlib) and the browser viewer
(``viewer.write_html``, plotly) both draw, computed once here.

Rigid bodies are their ``shape`` lines (lines, circles, polygons in the body
frame) or, without them, the outline through their points
(:func:`body_outline`); flexible beams their deformed centre
line (the floating frame of reference: r + A(phi) ((x, 0) + s S(x) q_f), s the
deformation scale); joints are circles at their first point, spring-dampers
zig-zags, distance joints (massless rods) lines; ground attachments and the
guides of sliders on the ground are drawn once (:meth:`Scene.ground`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.elements import GROUND, FlexibleBeam

__all__ = ["Drawing", "Scene", "Item", "COLORS"]

#: Body colours, by body index (matplotlib's tab10).
COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
          "#7f7f7f", "#bcbd22", "#17becf")


@dataclass(frozen=True)
class Item:
    """One drawn thing of a :class:`Scene`.

    Attributes
    ----------
    kind : {"polygon", "line", "circle", "point", "beam", "spring", "rod", "joint"}
        How it is drawn: a filled closed polygon, a thick line, a filled
        circle (centre and ``radius``), a dot, a beam's centre line, a
        zig-zag, a thin line, a joint's circle.
    body : str or None
        The body it belongs to (None: a spring, rod or joint).
    color : str
        ``#rrggbb``.
    radius : float [m]
        Of a circle shape (0 otherwise).
    """

    kind: str
    body: str | None
    color: str
    radius: float = 0.0


class Drawing:
    """What a drawing of a model holds in common, planar or spatial: its items
    in drawing order, each with how to place it, and the bodies' colours."""

    def _add(self, item, part):
        self.items.append(item)
        self._parts.append(part)

    @property
    def colors(self) -> dict:
        """Body name -> colour (``#rrggbb``)."""
        return {b.name: COLORS[b.index % len(COLORS)] for b in self.model.bodies}


class Scene(Drawing):
    """The drawing of a model's mechanism (module notes).

    Parameters
    ----------
    model : Model
    deform_scale : float
        Magnification of the beams' elastic displacements (1: true size).

    Attributes
    ----------
    items : list of Item
        In drawing order (bodies, springs, rods, joints on top);
        :meth:`coordinates` gives their world coordinates at a state.

    Raises
    ------
    ValueError
        A negative or non-finite deformation scale, or a spatial model
        (``space 3d``: :class:`mbdsl.graphics.scene3d.SpatialScene` draws it).
    """

    def __init__(self, model, deform_scale: float = 1.0):
        if getattr(model, "space", 2) == 3:
            raise ValueError("Scene draws planar models; scene3d.SpatialScene draws a "
                             "spatial one (space 3d)")
        if not (deform_scale >= 0 and np.isfinite(deform_scale)):
            raise ValueError(f"the deformation scale must be zero or positive, got {deform_scale}")
        self.model, self.deform_scale = model, float(deform_scale)
        self.cmap = model.coordinate_map
        self.beams = {b.index: b for b in model.bodies if isinstance(b, FlexibleBeam)}
        self.arcs = {i: np.linspace(0.0, b.length, 8 * b.elements + 1)
                     for i, b in self.beams.items()}
        # body geometry in body frames: declared points plus every attachment
        attach = {b.index: [np.array([p, 0.0]) if np.ndim(p) == 0 else np.asarray(p, float)
                            for p in b.points.values()] for b in model.bodies}
        self.springs = [f for f in model.forces if type(f).__name__ == "SpringDamper"]
        # a joint that holds its points apart (a distance joint's massless rod)
        self.rods = [j for j in model.joints if j.length > 0.0]
        self.joint_points = [j.first for j in model.joints]
        for ref in [p for j in model.joints for p in (j.first, j.second)] + \
                [p for s in self.springs for p in (s.first, s.second)]:
            if ref.body != GROUND:
                attach[ref.body].append(np.asarray(ref.local, float))
        self.outlines = {b.index: body_outline(np.array(attach[b.index]).reshape(-1, 2))
                         for b in model.bodies}
        self.items = []
        self._parts = []             # per item: how to place it (body index, what)
        for b in model.bodies:
            color = COLORS[b.index % len(COLORS)]
            if b.index in self.beams:
                self._add(Item("beam", b.name, color), (b.index, "beam", None))
            elif getattr(b, "shapes", ()):
                for s in b.shapes:
                    kind = {"circle": "circle", "polygon": "polygon"}.get(s.kind, "line")
                    self._add(Item(kind, b.name, color, float(getattr(s, "radius", 0.0) or 0.0)),
                              (b.index, "shape", s))
            else:
                kind, verts = self.outlines[b.index]
                kind = {"polygon": "polygon", "segment": "line"}.get(kind, "point")
                self._add(Item(kind, b.name, color), (b.index, "outline", verts))
        for s in self.springs:
            self._add(Item("spring", None, "#000000"), (None, "spring", s))
        for j in self.rods:
            self._add(Item("rod", None, "#333333"), (None, "rod", j))
        for p in self.joint_points:
            self._add(Item("joint", None, "#000000"), (None, "joint", p))
        self.scale = 1.0             # the scene's size [m] (``frame_extent``)

    def located(self, q, body, local) -> np.ndarray:
        """World position (1, 2) [m] of a body-frame point (on a beam: the
        deformed material point at the arc ``local[0]``) at q (n,)."""
        if body in self.beams:
            return beam_world(q, self.beams[body], [float(np.asarray(local).reshape(-1)[0])],
                              self.deform_scale, cmap=self.cmap)
        return _world(q, body, local, self.cmap)

    def coordinates(self, q) -> list:
        """World coordinates of every item at q (n,): per item an array (k,
        2) [m] (a circle: its centre, (1, 2); a joint: its point)."""
        out = []
        for body, what, data in self._parts:
            if what == "beam":
                out.append(beam_world(q, self.beams[body], self.arcs[body], self.deform_scale,
                                      cmap=self.cmap))
            elif what == "shape":
                out.append(_world(q, body, data.points, self.cmap))
            elif what == "outline":
                out.append(_world(q, body, data, self.cmap))
            elif what == "spring":
                out.append(_zigzag(self.located(q, data.first.body, data.first.local)[0],
                                   self.located(q, data.second.body, data.second.local)[0],
                                   0.02 * self.scale))
            elif what == "rod":
                out.append(np.vstack([self.located(q, data.first.body, data.first.local),
                                      self.located(q, data.second.body, data.second.local)]))
            else:
                out.append(self.located(q, data.body, data.local))
        return out

    def frame_extent(self, qs) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) [m] of a drawing that holds every frame q of qs (F, n)
        with a 12 % margin (at most 200 frames sampled); sets :attr:`scale`."""

        def shape_verts(shape):
            """Body-frame vertices bounding a shape (a circle: its bounding square)."""
            if shape.kind == "circle":
                c, r = shape.points[0], shape.radius
                return c + r * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
            return shape.points
        model = self.model
        every = [np.array([p.local for j in model.joints for p in (j.first, j.second)
                           if p.body == GROUND]).reshape(-1, 2)]
        sample = list(qs[:: max(1, len(qs) // 200)]) + [qs[-1]]
        for b in model.bodies:
            if b.index in self.beams:
                every += [beam_world(q, b, self.arcs[b.index], self.deform_scale,
                                     cmap=self.cmap) for q in sample]
                continue
            shapes = getattr(b, "shapes", ())
            verts = (np.vstack([shape_verts(s) for s in shapes]) if shapes
                     else self.outlines[b.index][1])
            every += [_world(q, b.index, verts, self.cmap) for q in sample]
        every = np.vstack(every)
        lo, hi = every.min(axis=0), every.max(axis=0)
        self.scale = scale = float(max(np.max(hi - lo), 1e-3))
        return lo - 0.12 * scale, hi + 0.12 * scale

    def ground(self) -> tuple[list, list]:
        """(the ground attachment points (k, 2), the guides of sliders on the
        ground as ((2, 2) end points)) [m], from :attr:`scale`."""
        marks, guides = [], []
        for j in self.model.joints:
            for p in (j.first, j.second):
                if p.body == GROUND:
                    marks.append(np.asarray(p.local, float))
            if j.direction is not None and j.second.body == GROUND:
                g, d = np.asarray(j.second.local, float), np.asarray(j.direction, float)
                d = d / np.hypot(*d)
                guides.append(np.array([g - 2 * self.scale * d, g + 2 * self.scale * d]))
        return marks, guides


# -- drawing geometry -------------------------------------------------------------------------

def body_outline(points: np.ndarray) -> tuple[str, np.ndarray]:
    """How to draw a rigid body through its points (body frame).

    Parameters
    ----------
    points : ndarray, shape (k, 2) [m]

    Returns
    -------
    kind : {"polygon", "segment", "dot"}
    vertices : ndarray, shape (v, 2)
        The convex outline for three or more non-collinear points (ordered
        by angle about their centroid), the two extreme points of collinear
        ones, the segment from the centre of mass to a single point, or the
        centre of mass alone.
    """
    pts = np.unique(np.round(np.asarray(points, float).reshape(-1, 2), 12), axis=0)
    if len(pts) == 0 or (len(pts) == 1 and not np.any(pts)):
        return "dot", np.zeros((1, 2))
    if len(pts) == 1:
        return "segment", np.vstack([np.zeros(2), pts[0]])
    c = pts.mean(axis=0)
    d = pts - c
    _, sv, vt = np.linalg.svd(d, full_matrices=False)
    if len(pts) == 2 or sv[1] <= 1e-9 * sv[0]:
        s = d @ vt[0]
        return "segment", np.vstack([pts[np.argmin(s)], pts[np.argmax(s)]])
    from scipy.spatial import ConvexHull
    hull = ConvexHull(pts)
    return "polygon", pts[hull.vertices]        # counter-clockwise


def _world(q, body, local, cmap):
    """Positions of body-frame points: local shape (k, 2) -> (k, 2); ground:
    local as is. ``cmap``: the model's CoordinateMap (a particle's phi is 0)."""
    if body == GROUND:
        return np.asarray(local, float).reshape(-1, 2)
    cx, cy, cp = cmap(body)[0]
    x, y, phi = q[cx], q[cy], (q[cp] if cp < len(q) else 0.0)
    c, s = np.cos(phi), np.sin(phi)
    loc = np.asarray(local, float).reshape(-1, 2)
    return np.column_stack([x + c * loc[:, 0] - s * loc[:, 1], y + s * loc[:, 0] + c * loc[:, 1]])


def beam_world(q, beam, arcs, scale: float = 1.0, *, cmap) -> np.ndarray:
    """World positions of a flexible beam's material points, deformed.

    r + A(phi) ((x, 0) + scale S(x) q_f) at arc lengths x (the floating frame
    of reference; ``scale`` magnifies the elastic displacement for drawing).

    Parameters
    ----------
    q : ndarray, shape (n,)
    beam : FlexibleBeam
    arcs : ndarray, shape (k,) [m]
        In [0, beam.length].
    scale : float
        Deformation scale (1: true size).
    cmap : CoordinateMap
        The model's body columns (``Model.coordinate_map``).

    Returns
    -------
    ndarray, shape (k, 2) [m]
    """
    arcs = np.asarray(arcs, float).reshape(-1)
    S = beam.mesh.shape(arcs)                               # (k, 2, nf)
    local = np.column_stack([arcs, np.zeros(len(arcs))])
    local = local + scale * np.einsum("kif,f->ki", S, q[beam.elastic_columns()])
    return _world(q, beam.index, local, cmap)


def _zigzag(p1, p2, width, coils=6):
    """Polyline of a spring between two points: straight ends, zig-zag middle."""
    d = p2 - p1
    length = float(np.hypot(*d))
    if length < 1e-12:
        return np.vstack([p1, p2])
    u = d / length
    nrm = np.array([-u[1], u[0]])
    s = np.concatenate([[0.0, 0.15], 0.15 + 0.7 * (np.arange(1, 2 * coils) / (2 * coils)),
                        [0.85, 1.0]])
    off = np.zeros_like(s)
    off[2:-2] = width * np.where(np.arange(2 * coils - 1) % 2 == 0, 1.0, -1.0)
    return p1 + np.outer(s * length, u) + np.outer(off, nrm)
