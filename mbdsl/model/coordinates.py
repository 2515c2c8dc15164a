"""Where each body's coordinates are in q: :class:`CoordinateMap`, and the
names of a body's coordinates and their rates (``model.elements`` re-exports
them)."""

from __future__ import annotations

import numpy as np

#: Names of a body's position coordinates, and of their rates, by index.
COORDINATES = ("x", "y", "phi")


class CoordinateMap:
    """Where each body's (x, y, phi) are in q extended by the ground's three
    dummy coordinates, q_ext = [q, 0, 0, 0] (length n + 3).

    Bodies take three columns each in declaration order, a particle two (a
    spatial body twelve, a spatial particle three: ``model.spatial``); the
    ground (body ``GROUND``) is at n, n+1, n+2, and a particle's phi is the
    ground's n+2 (always 0: a particle never turns, so nothing reads a
    rotation of it, and what is written to that column is dropped with the
    ground's).

    Parameters
    ----------
    bodies : sequence of RigidBody or FlexibleBeam
    n : int
        The number of generalized coordinates.
    n_states : int
        The number of first-order states: their integrals are the last
        n_states columns of q, their values the same columns of v; state k
        is the pseudo body ``n_bodies + k`` with one coordinate (0).

    Attributes
    ----------
    n : int
    table : ndarray of int, shape (n_bodies, 3)
        Columns of x, y, phi of each body.
    n_bodies : int
    state_offset : int
        The column of the first state's integral (n - n_states).
    """

    def __init__(self, bodies, n: int, n_states: int = 0):
        self.n = int(n)
        self.state_offset = self.n - int(n_states)
        rows, offset = [], 0
        #: first column of each spatial body's twelve, or of a spatial particle's
        #: three (body index -> column)
        self.spatial = {}
        #: how many columns each of them has: 12 (x, y, z, then A's columns) or 3
        self.spatial_width = {}
        for i, b in enumerate(bodies):
            if getattr(b, "space", 2) == 3:
                self.spatial[i] = offset
                self.spatial_width[i] = len(b.coordinate_fields)
                rows.append((offset, offset + 1, offset + 2))
                offset += len(b.coordinate_fields)
            elif getattr(b, "particle", False):
                rows.append((offset, offset + 1, self.n + 2))
                offset += 2
            else:
                rows.append((offset, offset + 1, offset + 2))
                offset += 3
        self.n_reference = offset
        self.table = np.array(rows, dtype=np.intp).reshape(-1, 3)
        self.n_bodies = len(rows)
        #: first column of each flexible beam's elastic coordinates (body index -> column)
        self.elastic = {i: int(b.elastic_offset) for i, b in enumerate(bodies)
                        if hasattr(b, "n_elastic")}

    def __call__(self, bodies) -> np.ndarray:
        """Columns (x, y, phi) of body indices (ground -1 -> n..n+2), shape (k, 3)."""
        b = np.asarray(bodies, dtype=np.intp).reshape(-1)
        out = np.empty((len(b), 3), dtype=np.intp)
        ground = b < 0
        out[ground] = self.n + np.arange(3)
        out[~ground] = self.table[b[~ground]]
        return out

    def column(self, body: int, coord: int) -> int:
        """The column of coordinate ``coord`` of ``body``: 0, 1, 2 = x, y, phi,
        and on a flexible beam 3 + j its elastic coordinate j; of a first-order
        state's pseudo body (n_bodies + k) its integral's (coord 0)."""
        if body < 0:
            return self.n + coord
        if body >= self.n_bodies:
            return self.state_column(body - self.n_bodies)
        if body in self.spatial:                  # x, y, z, A11, ..., A33
            return self.spatial[body] + coord
        if coord >= 3:
            return self.elastic[body] + coord - 3
        return int(self.table[body, coord])

    def state_column(self, k: int) -> int:
        """The column of first-order state k: its integral in q, its value in v."""
        return self.state_offset + int(k)

    @property
    def states(self) -> range:
        """The columns of the first-order states."""
        return range(self.state_offset, self.n)


VELOCITIES = ("vx", "vy", "omega")
ACCELERATIONS = ("ax", "ay", "alpha")


def _fields(body, names):
    """The body's fields of ``names`` (x, y, phi or their rates): the first
    two for a particle; a spatial body's twelve, a spatial particle's three
    (``model.spatial``)."""
    if hasattr(body, "velocity_fields"):
        return {COORDINATES: body.coordinate_fields, VELOCITIES: body.velocity_fields}.get(
            names, getattr(body, "acceleration_fields", names))
    return names[:2] if getattr(body, "particle", False) else names
