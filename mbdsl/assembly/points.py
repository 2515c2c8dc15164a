"""Points on bodies in numpy, for rows of a stored solution: positions of
body-fixed and beam points, A(phi) s and B(phi) s over many rows at once.

The run's physics is the kernels' (``mbdsl/kernels``); these serve the
derived output columns (``io.derived``), which evaluate points over every
row of a solution. Columns ``cols`` (k, c) index the extended coordinate
vector q_ext = [q, 0, 0, 0], where the three trailing zeros are the ground.
All formulas are in absolute planar coordinates (Haug, Computer-Aided
Kinematics and Dynamics of Mechanical Systems, ch. 3; Nikravesh,
Computer-Aided Analysis of Mechanical Systems, ch. 4): A(phi) is the
rotation matrix, B(phi) = dA/dphi, and d^2(A s)/dphi^2 = -A s.

Shapes: k instances, c local coordinates.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rot", "drot", "body_columns", "PointSet"]


def rot(phi: np.ndarray, s: np.ndarray) -> np.ndarray:
    """A(phi) s for arrays: phi shape (..., k), s shape (k, 2) or (..., k, 2)
    -> (..., k, 2). Leading axes are rows of a stored solution (evaluated
    all at once for its derived columns); the integrators pass one row."""
    c, si = np.cos(phi), np.sin(phi)
    out = np.empty(np.shape(phi) + (2,))
    out[..., 0] = c * s[..., 0] - si * s[..., 1]
    out[..., 1] = si * s[..., 0] + c * s[..., 1]
    return out


def drot(phi: np.ndarray, s: np.ndarray) -> np.ndarray:
    """B(phi) s = dA/dphi s, shapes as for :func:`rot`."""
    c, si = np.cos(phi), np.sin(phi)
    out = np.empty(np.shape(phi) + (2,))
    out[..., 0] = -si * s[..., 0] - c * s[..., 1]
    out[..., 1] = c * s[..., 0] - si * s[..., 1]
    return out


def body_columns(cmap, bodies) -> np.ndarray:
    """Columns (x, y, phi) in q_ext of body indices (ground = -1 -> n..n+2; a
    particle's phi -> n+2), shape (k, 3), from the model's
    :class:`~mbdsl.model.elements.CoordinateMap`."""
    return cmap(bodies)


class PointSet:
    """k points, one per instance, on rigid bodies, flexible beams or the ground.

    A point is at r + A(phi) u with u = s + S q_e: s its body-fixed (or
    undeformed) position, S the columns of a flexible beam's shape matrix
    for the e elastic coordinates q_e it depends on (none on a rigid body).
    Local coordinates per instance: (x, y, phi, q_e), with e padded to the
    largest count in the set by the ground's dummy column (q_ext = 0 there)
    and zero shape entries. Rigid-only sets have e = 0 and cost what the
    rigid formulas cost.

    * position: r + A u                                   (k, 2)
    * jacobian: [I, B u, A S]                             (k, 2, 3 + e)
    * Hessian:  d2/dphi2 = -A u, d2/dphi dq_e = B S       (k, 2, 3 + e, 3 + e)

    (the jacobian and Hessian are the kernels', ``kernels.geometry._Au`` and the
    elastic terms of the joints and loads; ``tests/assembly`` builds them in
    numpy for its oracles)

    (Shabana, Dynamics of Multibody Systems, sec. 5.3: the position of an
    arbitrary point of a deformable body in the floating frame.)
    """

    def __init__(self, cmap, points):
        n = cmap.n
        points = list(points)
        #: the points (``model.elements.PointRef``), for the kernels' packing
        self.refs = points
        k = len(points)
        self.e = max((len(p.elastic_columns) for p in points), default=0)
        self.c = 3 + self.e
        ecols = np.full((k, self.e), n, dtype=np.intp)
        self.S = np.zeros((k, 2, self.e))
        for i, p in enumerate(points):      # build time only
            ne = len(p.elastic_columns)
            ecols[i, :ne] = p.elastic_columns
            self.S[i, :, :ne] = p.elastic_shape
        self.cols = np.concatenate([body_columns(cmap, [p.body for p in points]), ecols], axis=1)
        self.s = np.array([p.local for p in points], dtype=float).reshape(-1, 2)
        self.flexible = self.e > 0

    def local(self, q) -> np.ndarray:
        """u = s + S q_e in the body frame, shape (k, 2), from local coordinates q (k, c)."""
        if not self.flexible:
            return self.s
        return self.s + np.einsum("kaj,...kj->...ka", self.S, q[..., 3:])

    def position(self, q) -> np.ndarray:
        """Global positions, shape (..., k, 2) for q of shape (..., k, c)."""
        return q[..., 0:2] + rot(q[..., 2], self.local(q))
