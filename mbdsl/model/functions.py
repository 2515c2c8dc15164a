"""Functions of time and of the state as the model holds them.

A driver's or a load's magnitude is a :class:`TimeFunction` (f(t) with its
first two derivatives) or, when it reads the motion, a :class:`StateFunction`
of the :class:`StateVariable` s it reads (a body's coordinate or velocity, a
joint's angle or rate, a sliding joint's distance or speed along its line
(:func:`line_distance`), a first-order state), with its exact partial
derivatives. Conventions: :mod:`mbdsl.model.elements`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["TimeFunction", "StateVariable", "StateFunction", "StateSwitch", "line_columns",
           "line_distance"]

@dataclass(frozen=True)
class TimeFunction:
    """f(t) with its first two derivatives, compiled from an expression.

    Attributes
    ----------
    f, df, ddf : callable float -> float
        f(t), f'(t), f''(t), exact (symbolic differentiation).
    text : str
        The expression as written, for messages.
    constant : bool
        True when f does not depend on t.
    expr : Expr or None
        The substituted expression of f (parameters replaced by their
        values), from which the compiled engine builds its programs for f
        and f' (``dsl.expressions.postfix``).
    """

    f: Callable[[float], float]
    df: Callable[[float], float]
    ddf: Callable[[float], float]
    text: str = ""
    constant: bool = False
    expr: object = None


@dataclass(frozen=True)
class StateVariable:
    """A quantity of the motion a force expression may use: a linear
    combination of generalized coordinates (``level`` 0) or velocities
    (``level`` 1) of bodies: their frames' x, y, phi and a flexible beam's
    elastic coordinates.

    Attributes
    ----------
    name : str
        As written, e.g. ``"crank.omega"``, ``"O.angle"``.
    level : int
        0: x = sum c_j q[j] (+ offset); 1: x = sum c_j v[j].
    terms : tuple of (int, int, float)
        (body index, coordinate 0..2 = x, y, phi or 3 + j = a beam's elastic
        coordinate j, coefficient c_j); its columns are those of
        :class:`~mbdsl.model.elements.CoordinateMap`.
    offset : float
        Added to a position-level variable (0 for every variable mbdsl has).
    line : tuple or None
        A sliding joint's ``distance`` (level 0) or ``speed`` (level 1), not
        linear: (body L, s_L, body P, s_P, u0) (:func:`line_distance`); terms
        is empty then.
    """

    name: str
    level: int
    terms: tuple
    offset: float = 0.0
    line: tuple | None = None

    def columns(self, cmap) -> list[int]:
        """The coordinates it reads, as columns of q extended by the ground's
        three (n..n+2)."""
        if self.line is None:
            return [cmap.column(b, j) for b, j, _ in self.terms]
        return line_columns(self.line, cmap)

    def value(self, qx, vx, cmap) -> float:
        """Its value at (q, v) extended by the ground's three zeros, shape
        (n+3,) each (the kernels' ``programs._state_values``, in numpy)."""
        if self.line is not None:
            s, grad = line_distance(self.line, qx, cmap)
            return float(s) if self.level == 0 else float(grad @ vx[self.columns(cmap)])
        src = qx if self.level == 0 else vx
        return self.offset + sum(c * float(src[cmap.column(b, j)]) for b, j, c in self.terms)


def line_columns(line, cmap) -> list[int]:
    """Columns (x, y, phi of the line's body, then of the point's body) of a
    sliding joint's geometry ``line`` = (body L, s_L, body P, s_P, u0) in q
    extended by the ground's three (n..n+2)."""
    bL, _, bP, _, _ = line
    return [int(c) for c in cmap([bL, bP]).ravel()]


def line_distance(line, qx, cmap):
    """Distance along a sliding joint and its gradient: s = u . (p_P - p_L),
    u = A(phi_L) u0, p = r + A(phi) s_body, for the rigid bodies (or ground)
    of ``line`` = (body L, s_L, body P, s_P, u0), at one state (the output
    columns of a sliding joint's distance and speed; the kernels evaluate it
    for the loads that read it, ``kernels.geometry._line``).

    Returns
    -------
    s : float [m]
    grad : ndarray, shape (6,)
        ds/d(x_L, y_L, phi_L, x_P, y_P, phi_P).
    """
    q = qx[line_columns(line, cmap)]
    _, sL, _, sP, u0 = line

    def rot(phi, v):
        """A(phi) v, shape (2,)."""
        c, sn = np.cos(phi), np.sin(phi)
        return np.array([c * v[0] - sn * v[1], sn * v[0] + c * v[1]])
    u, Bu = rot(q[2], u0), rot(q[2], (-u0[1], u0[0]))
    aL, aP = rot(q[2], sL), rot(q[5], sP)
    BaL, BaP = np.array([-aL[1], aL[0]]), np.array([-aP[1], aP[0]])
    d = q[3:5] + aP - q[0:2] - aL
    s = float(u @ d)
    return s, np.array([-u[0], -u[1], Bu @ d - u @ BaL, u[0], u[1], u @ BaP])


@dataclass(frozen=True)
class StateFunction:
    """f(t, x) of time and state variables, with its exact partial derivatives.

    Attributes
    ----------
    f : callable (t, x) -> float
        x: the values of ``variables``, in order.
    grads : tuple of callable (t, x) -> float
        df/dx_k for each variable (symbolic differentiation), in order.
    variables : tuple of StateVariable
    expr : Expr
        The substituted expression (state variables as names), for the
        compiled engine; ``grad_exprs`` its partial derivatives.
    grad_exprs : tuple of Expr
    text : str
    switches : tuple of StateSwitch
        The kinks of the tables of the state it reads, located as events.
    """

    f: Callable
    grads: tuple
    variables: tuple
    expr: object = None
    grad_exprs: tuple = ()
    text: str = ""
    constant: bool = False
    switches: tuple = ()


@dataclass(frozen=True)
class StateSwitch:
    """Where a function of the state changes its law: the argument u(t, x)
    of a table whose slope jumps at its ``kinks`` (every point of a linear
    table; the ends of one that holds its end values:
    ``model.table.Table.switches``). The time loop locates the steps across
    which u passes a kink as events and ends a step on each
    (``integrators.events.EventLocator``).

    Attributes
    ----------
    text : str
        The table's call, e.g. ``"motor(crank.omega)"``: the event's name.
    f : callable (t, x) -> float
        u, x the values of ``variables`` in order.
    expr : Expr
        u's expression (the state variables as names), for the kernels.
    variables : tuple of StateVariable
        Those of the function the table is called in.
    table : Table
        A table whose sign changes at each kink (``Table.switches``); its
        points ``table.x`` are the kinks, ascending.
    """

    text: str
    f: Callable
    expr: object
    variables: tuple
    table: object

    @property
    def kinks(self) -> np.ndarray:
        """The kinks of u [the argument's unit], ascending, shape (k,)."""
        return self.table.x

    def value(self, t, qx, vx, cmap) -> float:
        """u at time t [s] and (q, v) extended by the ground's three zeros,
        shape (n+3,) each."""
        return float(self.f(t, [v.value(qx, vx, cmap) for v in self.variables]))

    def interval(self, u) -> int:
        """How many kinks lie at or below u: the branch u is on (the
        kernels' ``programs.switch_branches``)."""
        return int(np.searchsorted(self.kinks, u, side="right"))
