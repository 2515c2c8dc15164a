"""Coordinate and constraint-row layout: indices <-> bodies and joints.

Used to name output columns and to report numerical failures in the model's
words (which joint's rows have the largest residual, which body's columns a
singular matrix involves).

The constraint rows are held as arrays (each row's element, each element's
first row), not as one Python object per row: a 100 000-link chain has
200 000 rows, and every question asked of them (whose row is this, which rows
are this joint's, which element's residual is largest) is an index into those
arrays.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Mapping, Sequence

import numpy as np

from ..model.elements import Model, row_names

__all__ = ["Layout"]

_name = operator.attrgetter("name")


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
    element_names : list of str, length n_elements
        The joints, drivers, couplers and spatial bodies' frames, in row order
        (``Model.constraint_elements``).
    element_start : ndarray of int, shape (n_elements + 1,)
        Each element's first row of lambda; the last entry is m.
    row_element : ndarray of int, shape (m,)
        Number of the element each row belongs to.
    rows : sequence of (str, int), length m
        (element name, row within it) of each constraint row.
    element_rows : mapping of str -> list of int
        An element's rows of lambda, by its name, in row order.
    frame_rows : ndarray of int, shape (6 b,)
        The spatial bodies' orthonormality rows a_k . a_l - delta_kl
        (``model.spatial.Frame``), which Newton holds to ``newton.FRAME_TOL``.
    """

    def __init__(self, model: Model):
        self.coordinates = model.coordinate_names()
        self.velocities = model.velocity_names()
        self.accelerations = model.acceleration_names()
        self._elements = elements = model.constraint_elements
        counts = model.constraint_rows
        self.element_names = list(map(_name, elements))
        self.n_elements = len(elements)
        self.element_start = np.zeros(self.n_elements + 1, dtype=np.intp)
        np.cumsum(counts, out=self.element_start[1:])
        #: element number of each constraint row, shape (m,), for vectorised reductions
        self.row_element = np.repeat(np.arange(self.n_elements, dtype=np.intp), counts)
        self.rows = _Rows(self)
        self.element_rows = _ElementRows(self)
        # the frames are the last elements (``Model.constraint_elements``)
        self.frame_rows = np.arange(self.element_start[self.n_elements - len(model.frames)],
                                    self.element_start[-1], dtype=np.intp)

    @functools.cached_property
    def _number(self) -> dict:
        """Element name -> its number; made when an element is first asked for
        by name (a failure's report, a friction joint's or a driver's rows)."""
        return dict(zip(self.element_names, range(self.n_elements)))

    def first_rows(self, count: int) -> Mapping:
        """The first row of lambda of each of the first ``count`` elements,
        by name (the joints': ``AssembledSystem.joint_rows``)."""
        return _FirstRows(self, count)

    def element_of_row(self, i: int) -> str:
        """The name of the joint, driver, coupler or frame of constraint row i."""
        return self.element_names[self.row_element[i]]

    def element_mask(self, names) -> np.ndarray:
        """Whether each constraint row belongs to an element named in ``names``
        (a set of str), shape (m,) of bool."""
        mine = np.array([name in names for name in self.element_names], dtype=bool)
        return mine[self.row_element]

    def multiplier_names(self) -> list[str]:
        """``lambda.<joint>.<k>`` column names, length m."""
        return [f"lambda.{name}.{k}" for name, k in self.rows]

    def worst_element(self, residual: np.ndarray) -> tuple[str, float]:
        """(joint or driver name, max abs residual of its rows) of the largest,
        the first of equals; an element with a non-finite residual is passed
        over, and ("", -1.0) returned when every one has.

        Parameters
        ----------
        residual : ndarray, shape (m,)
        """
        per = np.full(self.n_elements, -np.inf)
        with np.errstate(invalid="ignore"):
            np.maximum.at(per, self.row_element, np.abs(residual))
        per[np.isnan(per)] = -np.inf
        if not self.n_elements or per.max() == -np.inf:
            return "", -1.0
        k = int(np.argmax(per))
        return self.element_names[k], float(per[k])

    def span_of(self, name: str):
        """Declaration span of a joint, driver, coupler or frame, or None."""
        k = self._number.get(name)
        return None if k is None else getattr(self._elements[k], "span", None)

    def body_of_column(self, i: int) -> str:
        """Name of the coordinate in column i, e.g. ``"rod.phi"``."""
        return self.coordinates[i]


class _Rows(Sequence):
    """(element name, row within it) of each constraint row, read off the
    layout's arrays (:attr:`Layout.rows`)."""

    def __init__(self, layout: Layout):
        self._layout = layout

    def __len__(self) -> int:
        return len(self._layout.row_element)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        lay = self._layout
        e = int(lay.row_element[i])
        return lay.element_names[e], int(i) % len(self) - int(lay.element_start[e])

    def __iter__(self):
        lay = self._layout
        return row_names(lay.element_names, np.diff(lay.element_start))


class _ElementRows(Mapping):
    """An element's rows of lambda by its name (:attr:`Layout.element_rows`)."""

    def __init__(self, layout: Layout):
        self._layout = layout

    def __getitem__(self, name: str) -> list[int]:
        lay = self._layout
        k = lay._number[name]
        return list(range(int(lay.element_start[k]), int(lay.element_start[k + 1])))

    def __iter__(self):
        return iter(self._layout.element_names)

    def __len__(self) -> int:
        return self._layout.n_elements


class _FirstRows(Mapping):
    """The first row of lambda of the layout's first ``count`` elements, by
    name (:meth:`Layout.first_rows`)."""

    def __init__(self, layout: Layout, count: int):
        self._layout, self._count = layout, count

    def __getitem__(self, name: str) -> int:
        k = self._layout._number[name]
        if k >= self._count:
            raise KeyError(name)
        return int(self._layout.element_start[k])

    def __iter__(self):
        return iter(self._layout.element_names[:self._count])

    def __len__(self) -> int:
        return self._count
