"""Coordinate and constraint-row layout: indices <-> bodies and joints.

Used to name output columns and to report numerical failures in the model's
words (which joint's rows have the largest residual, which body's columns a
singular matrix involves).
"""

from __future__ import annotations

import numpy as np

from ..model.elements import COORDINATES, VELOCITIES, Model

__all__ = ["Layout"]


class Layout:
    """Names of the coordinates (n) and constraint rows (m) of a model.

    Attributes
    ----------
    coordinates : list of str, length n
        ``"crank.x"``, ``"crank.y"``, ``"crank.phi"``, ...
    velocities : list of str, length n
        ``"crank.vx"``, ...
    accelerations : list of str, length n
        ``"crank.ax"``, ``"crank.ay"``, ``"crank.alpha"``, ...
    rows : list of (str, int), length m
        (joint or driver name, row within it).
    row_element : ndarray of int, shape (m,)
        Number of the joint or driver each row belongs to.
    frame_rows : ndarray of int, shape (6 b,)
        The spatial bodies' orthonormality rows a_k . a_l - delta_kl
        (``model.spatial.Frame``), which Newton holds to ``newton.FRAME_TOL``.
    """

    def __init__(self, model: Model):
        self.coordinates = model.coordinate_names()
        self.velocities = model.velocity_names()
        self.accelerations = model.acceleration_names()
        self.rows = model.constraint_names()
        self._spans = {j.name: j.span for j in model.joints}
        self._spans.update({d.name: d.span for d in model.drivers + model.couplers})
        self.element_rows: dict[str, list[int]] = {}
        for i, (name, _) in enumerate(self.rows):
            self.element_rows.setdefault(name, []).append(i)
        #: element number of each constraint row, shape (m,), for vectorised reductions
        numbers = {name: k for k, name in enumerate(self.element_rows)}
        self.row_element = np.array([numbers[name] for name, _ in self.rows], dtype=np.intp)
        self.n_elements = len(numbers)
        self.frame_rows = np.array([r for f in model.frames for r in self.element_rows[f.name]],
                                   dtype=np.intp)

    def multiplier_names(self) -> list[str]:
        """``lambda.<joint>.<k>`` column names, length m."""
        return [f"lambda.{name}.{k}" for name, k in self.rows]

    def worst_element(self, residual: np.ndarray) -> tuple[str, float]:
        """(joint or driver name, max abs residual of its rows) of the largest."""
        best, value = "", -1.0
        for name, rows in self.element_rows.items():
            r = float(np.max(np.abs(residual[rows])))
            if r > value:
                best, value = name, r
        return best, value

    def span_of(self, name: str):
        """Declaration span of a joint or driver, or None."""
        return self._spans.get(name)

    def body_of_column(self, i: int) -> str:
        """Name of the coordinate in column i, e.g. ``"rod.phi"``."""
        return self.coordinates[i]
