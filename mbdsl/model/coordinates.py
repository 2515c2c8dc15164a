"""Where each body's coordinates are in q: :class:`CoordinateMap`, the
bodies' kinds (:class:`BodyKinds`), and the names of a body's coordinates and
their rates (``model.elements`` re-exports them)."""

from __future__ import annotations

import operator

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
    kinds : BodyKinds, optional
        The bodies' kinds, when the caller has them (``Model.body_kinds``);
        found from ``bodies`` otherwise.

    Attributes
    ----------
    n : int
    table : ndarray of int, shape (n_bodies, 3)
        Columns of x, y, phi of each body.
    n_bodies : int
    state_offset : int
        The column of the first state's integral (n - n_states).
    """

    def __init__(self, bodies, n: int, n_states: int = 0, kinds: BodyKinds | None = None):
        self.n = int(n)
        self.state_offset = self.n - int(n_states)
        kinds = BodyKinds(bodies) if kinds is None else kinds
        # each body's first column: the widths' running sum (arrays, not a pass over
        # the bodies: a 100 000-link chain's map is made in milliseconds)
        width = kinds.body_width
        first = np.zeros(len(width), dtype=np.intp)
        np.cumsum(width[:-1], out=first[1:])
        self.n_reference = int(first[-1] + width[-1]) if len(width) else 0
        self.table = first[:, None] + np.arange(3, dtype=np.intp)
        # a planar particle's phi is the ground's dummy n + 2
        self.table[kinds.code_in(kinds.planar_particle), 2] = self.n + 2
        self.n_bodies = len(width)
        spatial = kinds.code_in(kinds.space == 3).tolist()
        #: first column of each spatial body's twelve, or of a spatial particle's
        #: three (body index -> column)
        self.spatial = dict(zip(spatial, first[spatial].tolist()))
        #: how many columns each of them has: 12 (x, y, z, then A's columns) or 3
        self.spatial_width = dict(zip(spatial, width[spatial].tolist()))
        #: first column of each flexible beam's elastic coordinates (body index -> column)
        self.elastic = {i: int(bodies[i].elastic_offset)
                        for i in kinds.code_in(kinds.flexible).tolist()}

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


class BodyKinds:
    """The kinds of a model's bodies: each distinct (class, particle) pair
    once, and each body's kind as a number, found by passes over the bodies
    that make no object per body.

    What the model's layout needs of a body (its width in q, its names, its
    space) depends on its kind alone, so it is read once per kind, not once
    per body (``Model.body_kinds``; a 100 000-link chain has one kind).

    Parameters
    ----------
    bodies : sequence of RigidBody, FlexibleBeam, SpatialBody or SpatialParticle

    Attributes
    ----------
    code : ndarray of int, shape (n_bodies,)
        Each body's kind, an index into the per-kind attributes.
    fields : list of (tuple of str, tuple of str, tuple of str)
        Per kind: the names of its coordinates, velocities and accelerations
        (``x, y, phi``, ``vx, vy, omega``, ``ax, ay, alpha``; two of each for
        a particle; twelve for a spatial body, three for a spatial particle).
    width : ndarray of int, shape (kinds,)
        Per kind: its reference coordinates in q (3, 2, 12 or 3).
    body_width : ndarray of int, shape (n_bodies,)
        Each body's: ``width[code]``.
    space : ndarray of int, shape (kinds,)
        Per kind: 2 (planar) or 3 (spatial).
    flexible : ndarray of bool, shape (kinds,)
        Per kind: a flexible beam (elastic coordinates after all bodies').
    planar_particle : ndarray of bool, shape (kinds,)
        Per kind: a planar particle (its phi is the ground's dummy column).
    """

    def __init__(self, bodies):
        # C-level passes (map) that make no object per body; the kinds' numbers only
        # when there are several. Every body class has ``particle`` (a field, or a
        # class attribute of a kind that never is one).
        types = set(map(type, bodies))
        if len(types) == 1 and not any(map(_particle, bodies)):
            number = {(types.pop(), False): 0}
        else:
            number = {k: i for i, k in enumerate(dict.fromkeys(map(_kind, bodies)))}
        if len(number) > 1:
            self.code = np.fromiter(map(number.__getitem__, map(_kind, bodies)),
                                    dtype=np.intp, count=len(bodies))
        else:
            self.code = np.zeros(len(bodies), dtype=np.intp)
        reps = [bodies[int(np.argmax(self.code == k))] for k in range(len(number))]
        self.fields = [tuple(_fields(b, names) for names in (COORDINATES, VELOCITIES,
                                                             ACCELERATIONS)) for b in reps]
        self.width = np.array([len(f[0]) for f in self.fields], dtype=np.intp)
        self.body_width = self.width[self.code]
        self.space = np.array([getattr(b, "space", 2) for b in reps], dtype=np.intp)
        self.flexible = np.array([hasattr(b, "n_elastic") for b in reps], dtype=bool)
        self.planar_particle = np.array([k[1] for k in number], dtype=bool) & (self.space == 2)

    def code_in(self, kinds: np.ndarray) -> np.ndarray:
        """The bodies whose kind is among ``kinds`` (a bool per kind), shape (k,)."""
        return np.flatnonzero(np.asarray(kinds, dtype=bool)[self.code])

    def names(self, names: list, which: int) -> list:
        """Each body's names of its coordinates (``which`` 0), velocities (1)
        or accelerations (2), ``"<body>.<field>"``, in q's order.

        Parameters
        ----------
        names : list of str, length n_bodies
            The bodies' names.
        """
        suffix = [tuple("." + c for c in f[which]) for f in self.fields]
        if len(suffix) == 1:                       # one kind: no per-body lookup
            one = suffix[0]
            return [b + c for b in names for c in one]
        return [b + c for b, k in zip(names, self.code.tolist()) for c in suffix[k]]


_name, _particle = operator.attrgetter("name"), operator.attrgetter("particle")
_kind = operator.attrgetter("__class__", "particle")


def body_names(bodies) -> list:
    """The bodies' names, in order."""
    return list(map(_name, bodies))


def _fields(body, names):
    """The body's fields of ``names`` (x, y, phi or their rates): the first
    two for a particle; a spatial body's twelve, a spatial particle's three
    (``model.spatial``)."""
    if hasattr(body, "velocity_fields"):
        return {COORDINATES: body.coordinate_fields, VELOCITIES: body.velocity_fields}.get(
            names, getattr(body, "acceleration_fields", names))
    return names[:2] if getattr(body, "particle", False) else names
