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

A :class:`FlexibleBeamGroup` holds the data of the beams with the same
number of elastic coordinates, stacked (struct of arrays, shape (k, ...)):
columns, shape integrals, stiffness and strain data, which
``packing.PackedModel`` packs for the kernels. The physics
above is evaluated once, by the kernels of ``mbdsl/kernels``
(``_ffr_local``, ``_ffr_energy``): the compiled time loops call them
directly, and everything else (the numpy engine, the initial conditions,
the output's energies) through this group's methods, on the compiled
kernels when this process can call them without compiling, else on their
uncompiled copy (``AssembledSystem.kernel_model``). An independent numpy
evaluation of the same equations is the tests' oracle
(``tests/flexible/ffr_oracle.py``).
"""

from __future__ import annotations

import numpy as np

from .points import body_columns

__all__ = ["FlexibleBeamGroup"]

#: ``kernels.beams.ffr._ffr_local``'s bits (M, Q, (Q_q, Q_v), (M x)_q), repeated here so
#: that building a model never imports numba.
FFR_M, FFR_Q, FFR_DQ, FFR_MXQ = 1, 2, 4, 8


class FlexibleBeamGroup:
    """k flexible beams with the same number nf of elastic coordinates.

    Local coordinates per beam: (x, y, phi, q_f), c = 3 + nf, columns
    ``cols`` (k, c) into q.

    Parameters
    ----------
    cmap : CoordinateMap
        The model's body columns (``Model.coordinate_map``).
    beams : sequence of FlexibleBeam
    gravity : ndarray, shape (2,), or None
        [m/s^2]; None: no gravity term.

    Notes
    -----
    The evaluations (``mass_blocks``, ``forces``, ...) call the kernels
    through the model data :meth:`bind` gives the group; the group's beams
    are the kernels' beams ``first`` .. ``first + k - 1``.
    """

    def __init__(self, cmap, beams, gravity=None):
        beams = list(beams)
        self.beams = beams
        self.nf = beams[0].n_elastic
        self.c = 3 + self.nf
        self.cols = np.concatenate([body_columns(cmap, [b.index for b in beams]),
                                    np.array([b.elastic_columns() for b in beams])], axis=1)
        ints, stiff = [], []
        for b in beams:        # build time only: one mesh per beam
            mesh = b.mesh
            ints.append(mesh.shape_integrals(b.mass / b.length))
            stiff.append(mesh.stiffness(b.E * b.area, b.E * b.second_moment))

        def stack(name):
            """One shape integral of every beam, stacked on axis 0."""
            return np.array([getattr(i, name) for i in ints])

        self.m = stack("mass")
        self.s0, self.I0, self.S_bar = stack("s0"), stack("I0"), stack("S_bar")
        self.M_ff, self.a_u, self.a_I = stack("M_ff"), stack("a_u"), stack("a_I")
        self.S_tilde = stack("S_tilde")
        self.K = np.array(stiff)
        # geometric stiffening: quadrature data of the beams that have it
        self.stiffening = np.array([getattr(b, "stiffening", True) for b in beams])
        if self.stiffening.any():
            grads = [b.mesh.strain_gradients() for b in beams]
            self.Bu = np.array([g[0] for g in grads])                 # (k, N_e, nf)
            self.G = np.array([g[1] for g in grads])                  # (k, N_e, nf, nf)
            self.kEA = np.array([np.full(b.elements, 0.5 * b.E * b.area * b.length / b.elements
                                         * (1.0 if s else 0.0))
                                 for b, s in zip(beams, self.stiffening)])
        self.gravity = None if gravity is None else np.asarray(gravity, float)
        k, c = len(beams), self.c
        #: mass-matrix pattern in q: (rows, cols), each shape (k * c * c,)
        self.pattern = (np.repeat(self.cols, c, axis=1).ravel(),
                        np.tile(self.cols, (1, c)).ravel())
        #: the diagonal of M at q = 0 (the mass of the frame's translation, I0,
        #: diag M_ff), shape (k, c): the scaling of the unknowns
        self.mass_diagonal = np.concatenate([self.m[:, None], self.m[:, None], self.I0[:, None],
                                             np.diagonal(self.M_ff, axis1=1, axis2=2)], axis=1)
        self._kernel_model, self.first = None, 0
        self._nx = cmap.n + 3           # the kernels read extended vectors (ground: 3 zeros)

    def bind(self, kernel_model, first: int) -> None:
        """Evaluate through ``kernel_model()`` (a callable returning the
        model's ``PackedModel``), this group's beams being the kernels'
        ``first`` .. ``first + k - 1``."""
        self._kernel_model, self.first = kernel_model, first

    def _blocks(self, qx, vx, x, what):
        """The kernels' local blocks of the group's beams (``kernels.beams.ffr.beam_blocks``):
        M, Q, Q_q, Q_v, (M x)_q, shapes (k, c, c), (k, c), (k, c, c) x 3."""
        cm = self._kernel_model()
        k, c = len(self.beams), self.c
        M, Qq, Qv, Mxq = (np.zeros((k, c, c)) for _ in range(4))
        Q = np.zeros((k, c))
        qx, vx, x = (None if y is None else self._extended(y) for y in (qx, vx, x))
        cm.K.beam_blocks(cm.ints, cm.floats, self.first, qx, qx if vx is None else vx,
                         qx if x is None else x, what, M, Q, Qq, Qv, Mxq)
        return M, Q, Qq, Qv, Mxq

    def _extended(self, y) -> np.ndarray:
        """y (..., n) or (..., n + 3) as contiguous extended vectors (..., n + 3)."""
        y = np.asarray(y, dtype=float)
        out = np.zeros(y.shape[:-1] + (self._nx,))
        out[..., : y.shape[-1]] = y
        return out

    # -- mass --------------------------------------------------------------------------------
    def mass_blocks(self, qx) -> np.ndarray:
        """M(q) of every beam, shape (k, c, c) [kg, kg m, kg m^2]; qx (n,) or (n + 3,)."""
        return self._blocks(qx, None, None, FFR_M)[0]

    def Ma_q(self, qx, ax) -> np.ndarray:
        """(M(q) a)_q of every beam, shape (k, c, c), local rows and columns."""
        return self._blocks(qx, None, ax, FFR_MXQ)[4]

    # -- forces ------------------------------------------------------------------------------
    def forces(self, qx, vx, t):
        """Local Q = Q_v - K q_f (- dU_G/dq_f) + Q_gravity, shape (k, c) [N, N m]."""
        return self._blocks(qx, vx, None, FFR_Q)[1]

    def derivatives(self, qx, vx, t):
        """Local (Q_q, Q_v), each shape (k, c, c)."""
        M, Q, Qq, Qv, Mxq = self._blocks(qx, vx, None, FFR_DQ)
        return Qq, Qv

    def tangent_stiffness(self, qx) -> np.ndarray:
        """K (+ d^2U_G/dq_f^2 with geometric stiffening) of every beam at q,
        shape (k, nf, nf) [N/m, N, N m]: -Q_q's elastic block at rest."""
        Qq = self.derivatives(qx, np.zeros(len(qx)), 0.0)[0]
        return -Qq[:, 3:, 3:]

    # -- energy ------------------------------------------------------------------------------
    def energy(self, qx, gravity: bool = True):
        """Strain energy (+ with ``gravity`` the gravity potential energy) of
        all beams [J]: a float, or shape (...) for rows qx of shape (..., n
        or n + 3) (``kernels.beams.ffr.beam_energies``)."""
        cm = self._kernel_model()
        rows = self._extended(qx).reshape(-1, self._nx)
        out = np.empty(len(rows))
        cm.K.beam_energies(cm.ints, cm.floats, self.first, self.first + len(self.beams), rows,
                           bool(gravity), out)
        return float(out[0]) if np.ndim(qx) == 1 else out.reshape(np.shape(qx)[:-1])
