"""Flexible beams in the floating frame of reference (FFR), all at once.

For a beam with reference coordinates (R, phi) (R = (x, y) the frame
origin) and elastic coordinates q_f, a material point at arc length x is at

    r = R + A(phi) u_bar,    u_bar = u_bar0(x) + S(x) q_f

(``model/beam.py``). With the inertia shape integrals of ``ShapeIntegrals``
(m, s0, I0, S_bar, M_ff, a_u, a_I, S_tilde; all computed once at build) and

    s_bar = s0 + S_bar q_f       (first moment of mass in the frame)
    a_U   = a_u + M_ff q_f       (int mu S^T u_bar)
    a_T   = a_I + S_tilde q_f    (int mu S^T I~ u_bar)

the mass matrix in local coordinates (x, y, phi, q_f) is

    M = [[m I2,         B s_bar,                                  A S_bar],
         [.,            I0 + 2 a_u.q_f + q_f^T M_ff q_f,          a_T^T  ],
         [sym,          a_T,                                      M_ff   ]]

and the quadratic velocity vector (M a = Q + Q_v, w = phi', qd = q_f'):

    Q_v,R   = w^2 A s_bar - 2 w B S_bar qd
    Q_v,phi = -2 w a_U . qd
    Q_v,f   = w^2 a_U - 2 w S_tilde qd

Applied: the elastic force -K q_f (minus, with geometric stiffening, the
gradient of the nonlinear part of the axial strain energy, below) and, with
gravity g, the generalized
gravity force (m g, (B s_bar) . g, S_bar^T A^T g). Potential energy
q_f^T K q_f / 2 - m g . R - g . A s_bar. Every q- and v-derivative the
Newton matrices need is below, analytic: Q_q, Q_v, and (M a)_q.

Geometric stiffening (on unless the beam says ``stiffening off``): the axial
strain of element e is eps_e = a_e + c_e / 2 (the foreshortening of a bent
beam) instead of a_e, with a_e = Bu_e q_f its u' and c_e = q_f^T G_e q_f the
element mean of v'^2 (``BeamMesh.strain_gradients``: averaged, so that a bent
beam is not locked). The strain energy gains, with k_e = EA l / 2,

    U_G = sum_e k_e (a_e c_e + c_e^2 / 4)
    dU_G/dq_f = sum_e k_e [c_e Bu_e + (2 a_e + c_e) G_e q_f]
    d^2U_G/dq_f^2 = sum_e k_e [2 Bu_e g_e^T + 2 g_e Bu_e^T + 2 g_e g_e^T
                               + (2 a_e + c_e) G_e],   g_e = G_e q_f

so an axial force EA a_e (centrifugal or applied) stiffens bending by
EA a_e l G_e, the geometric stiffness, which the linear floating frame
misses (a spinning cantilever softens and diverges above its first
frequency). Sharf, "Geometric stiffening in multibody dynamics
formulations", J. Guidance, Control, and Dynamics 18 (1995) 882-890, and
Sharf (1996), Multibody System Dynamics; Kane, Ryan & Banerjee (1987).

Source: Shabana, Dynamics of Multibody Systems, 4th ed., ch. 5 (the planar
FFR: eqs. for the mass matrix, the inertia shape integrals and the quadratic
velocity vector). A is the rotation matrix, B = dA/dphi, I~ = [[0,-1],[1,0]].

The beams' data (shape integrals, stiffness, strain data) are the model's
(``FlexibleBeam.shape_integrals``, ``stiffness``, ``strain_data``: computed
once per beam), packed for the kernels by ``kernels.beams.ffr.pack``. The
physics above is evaluated once, by the kernels of ``mbdsl/kernels``
(``_ffr_local``, ``_ffr_energy``): the compiled time loops call them
directly, and everything else (the numpy engine, the initial conditions,
the output's energies) through the functions below, on the packed model
the system gives them (``AssembledSystem.kernel_model``: the compiled
kernels when this process can call them without compiling, else their
uncompiled copy). A :class:`BeamSet` says where beams with the same number
of elastic coordinates sit: in q, and in the kernels' beam order. An
independent numpy evaluation of the same equations is the tests' oracle
(``tests/flexible/ffr_oracle.py``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .points import body_columns

__all__ = ["BeamSet", "beam_sets", "local_blocks", "mass_blocks", "Ma_q", "forces",
           "derivatives", "tangent_stiffness", "energy"]

#: ``kernels.beams.ffr._ffr_local``'s bits (M, Q, (Q_q, Q_v), (M x)_q), repeated here so
#: that building a model never imports numba.
FFR_M, FFR_Q, FFR_DQ, FFR_MXQ = 1, 2, 4, 8


class BeamSet(NamedTuple):
    """Where k flexible beams with the same number nf of elastic
    coordinates sit: an index, not a copy of their data.

    Attributes
    ----------
    first : int
        The kernels' beams ``first`` .. ``first + k - 1`` (``kernels.beams.ffr``).
    beams : tuple of FlexibleBeam
        The model's beams, in that order.
    cols : ndarray of intp, shape (k, 3 + nf)
        Their local coordinates (x, y, phi, q_f) as columns of q.
    """

    first: int
    beams: tuple
    cols: np.ndarray

    @property
    def c(self) -> int:
        """3 + nf, the local coordinates per beam."""
        return self.cols.shape[1]


def beam_sets(cmap, beams) -> list:
    """The model's flexible beams by their number of elastic coordinates, in
    the order of first appearance (the kernels' beam order).

    Parameters
    ----------
    cmap : CoordinateMap
        The model's body columns (``Model.coordinate_map``).
    beams : sequence of FlexibleBeam
        In the model's order.

    Returns
    -------
    list of BeamSet
    """
    by_size = {}
    for b in beams:
        by_size.setdefault(b.n_elastic, []).append(b)
    out, first = [], 0
    for same in by_size.values():
        cols = np.concatenate([body_columns(cmap, [b.index for b in same]),
                               np.array([b.elastic_columns() for b in same])], axis=1)
        out.append(BeamSet(first, tuple(same), cols))
        first += len(same)
    return out


def mass_pattern(s: BeamSet) -> tuple:
    """(rows, cols) of the set's dense mass blocks in q, each shape (k c c,),
    block by block, row-major."""
    c = s.c
    return np.repeat(s.cols, c, axis=1).ravel(), np.tile(s.cols, (1, c)).ravel()


def _extended(y, nx) -> np.ndarray:
    """y (..., n) or (..., n + 3) as contiguous extended vectors (..., nx = n + 3)."""
    y = np.asarray(y, dtype=float)
    out = np.zeros(y.shape[:-1] + (nx,))
    out[..., : y.shape[-1]] = y
    return out


def local_blocks(cm, s: BeamSet, qx, vx=None, x=None, what=FFR_M) -> tuple:
    """The kernels' local blocks of a set's beams (``kernels.beams.ffr.beam_blocks``).

    Parameters
    ----------
    cm : PackedModel
        The model packed for the kernels (``AssembledSystem.kernel_model()``).
    s : BeamSet
    qx, vx, x : ndarray, shape (n,) or (n + 3,)
        Configuration, velocities and the vector of (M x)_q; vx and x: qx
        when not given (not read unless ``what`` asks).
    what : int
        Bits of ``FFR_M``, ``FFR_Q``, ``FFR_DQ``, ``FFR_MXQ``.

    Returns
    -------
    M, Q, Q_q, Q_v, (M x)_q : ndarray
        Shapes (k, c, c), (k, c), (k, c, c) x 3 [SI units of M and Q];
        zeros where not asked for.
    """
    k, c, nx = len(s.beams), s.c, cm.n + 3
    M, Qq, Qv, Mxq = (np.zeros((k, c, c)) for _ in range(4))
    Q = np.zeros((k, c))
    qx, vx, x = (None if y is None else _extended(y, nx) for y in (qx, vx, x))
    cm.K.beam_blocks(cm.ints, cm.floats, s.first, qx, qx if vx is None else vx,
                     qx if x is None else x, what, M, Q, Qq, Qv, Mxq)
    return M, Q, Qq, Qv, Mxq


def mass_blocks(cm, s: BeamSet, qx) -> np.ndarray:
    """M(q) of every beam of the set, shape (k, c, c) [kg, kg m, kg m^2]."""
    return local_blocks(cm, s, qx)[0]


def Ma_q(cm, s: BeamSet, qx, ax) -> np.ndarray:
    """(M(q) a)_q of every beam of the set, shape (k, c, c), local rows and columns."""
    return local_blocks(cm, s, qx, None, ax, FFR_MXQ)[4]


def forces(cm, s: BeamSet, qx, vx) -> np.ndarray:
    """Local Q = Q_v - K q_f (- dU_G/dq_f) + Q_gravity, shape (k, c) [N, N m]."""
    return local_blocks(cm, s, qx, vx, None, FFR_Q)[1]


def derivatives(cm, s: BeamSet, qx, vx) -> tuple:
    """Local (Q_q, Q_v) of every beam of the set, each shape (k, c, c)."""
    blocks = local_blocks(cm, s, qx, vx, None, FFR_DQ)
    return blocks[2], blocks[3]


def tangent_stiffness(cm, s: BeamSet, qx) -> np.ndarray:
    """K (+ d^2U_G/dq_f^2 with geometric stiffening) of every beam of the set
    at q, shape (k, nf, nf) [N/m, N, N m]: -Q_q's elastic block at rest."""
    Qq = derivatives(cm, s, qx, np.zeros(np.shape(qx)[-1]))[0]
    return -Qq[:, 3:, 3:]


def energy(cm, qx, first: int, count: int, gravity: bool = True):
    """Strain energy (+ with ``gravity`` the gravity potential energy) of the
    kernels' beams ``first`` .. ``first + count - 1`` [J]
    (``kernels.beams.ffr.beam_energies``).

    Parameters
    ----------
    cm : PackedModel
    qx : ndarray, shape (n,) or (n + 3,), or rows (..., n or n + 3)
    first, count : int
        The beams (a :class:`BeamSet`'s ``first`` and size, or 0 and all).
    gravity : bool
        Whether to add the beams' gravity potential energy.

    Returns
    -------
    float, or ndarray of shape (...) for rows
    """
    nx = cm.n + 3
    rows = _extended(qx, nx).reshape(-1, nx)
    out = np.empty(len(rows))
    cm.K.beam_energies(cm.ints, cm.floats, first, first + count, rows, bool(gravity), out)
    return float(out[0]) if np.ndim(qx) == 1 else out.reshape(np.shape(qx)[:-1])
