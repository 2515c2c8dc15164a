"""An independent, vectorised evaluation of the flexible beams' physics in
the floating frame of reference: the oracle the kernels of
``mbdsl.kernels.beams.ffr`` (``_ffr_local``, ``_ffr_energy``) are tested
against. Not part of the package: mbdsl evaluates its beams with the kernels
only.

The equations are those of ``mbdsl.assembly.ffr``'s module notes (Shabana,
Dynamics of Multibody Systems, 4th ed., ch. 5; Sharf 1995 for the geometric
stiffening), written here with einsums over stacked beams with the same
number of elastic coordinates, from the shape integrals, stiffness and strain
data of their meshes (``mbdsl.model.beam``).
"""

from __future__ import annotations

import numpy as np


__all__ = ["BeamOracle"]


def _AB(phi):
    """A(phi) and B(phi) = dA/dphi, each shape (k, 2, 2)."""
    c, s = np.cos(phi), np.sin(phi)
    A = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    B = np.stack([np.stack([-s, -c], -1), np.stack([c, -s], -1)], -2)
    return A, B


class BeamOracle:
    """The physics of k beams with nf elastic coordinates each (local
    coordinates (x, y, phi, q_f), c = 3 + nf, columns ``cols`` (k, c) into
    q), evaluated with numpy: the shape integrals and stiffness of the
    beams' meshes (computed here, not read from the package's packing), an
    independent implementation of what the kernels compute from them.

    Parameters
    ----------
    beams : sequence of FlexibleBeam
        With the same number of elastic coordinates.
    cols : ndarray of int, shape (k, c)
    gravity : ndarray, shape (2,), or None
    """

    def __init__(self, beams, cols, gravity):
        self.beams, self.cols, self.gravity = list(beams), np.asarray(cols), gravity
        self.nf = self.beams[0].n_elastic
        self.c = 3 + self.nf
        ints = [b.mesh.shape_integrals(b.mass / b.length) for b in self.beams]
        for name in ("S_bar", "M_ff", "a_u", "a_I", "S_tilde", "s0", "I0"):
            setattr(self, name, np.array([getattr(i, name) for i in ints]))
        self.m = np.array([i.mass for i in ints])
        self.K = np.array([b.mesh.stiffness(b.E * b.area, b.E * b.second_moment)
                           for b in self.beams])
        self.stiffening = np.array([b.stiffening for b in self.beams])
        if self.stiffening.any():
            grads = [b.mesh.strain_gradients() for b in self.beams]
            self.Bu = np.array([g[0] for g in grads])
            self.G = np.array([g[1] for g in grads])
            self.kEA = np.array([np.full(b.elements, 0.5 * b.E * b.area * b.length / b.elements
                                         * (1.0 if b.stiffening else 0.0)) for b in self.beams])
        k, c = len(self.beams), self.c
        self._M = np.zeros((k, c, c))
        self._M[:, 0, 0] = self._M[:, 1, 1] = self.m
        self._M[:, 3:, 3:] = self.M_ff

    @classmethod
    def of(cls, system, beam_set):
        """The oracle of one of a system's ``beam_sets`` (``mbdsl.assembly.ffr.BeamSet``)."""
        return cls(beam_set.beams, beam_set.cols, system.beam_gravity)

    # -- kinematic parts ------------------------------------------------------------------
    def _parts(self, q):
        """Local q (k, c) -> phi, q_f, A, B, s_bar, a_U, a_T."""
        phi, qf = q[:, 2], q[:, 3:]
        A, B = _AB(phi)
        s_bar = self.s0 + np.einsum("kaj,kj->ka", self.S_bar, qf)
        a_U = self.a_u + np.einsum("kij,kj->ki", self.M_ff, qf)
        a_T = self.a_I + np.einsum("kij,kj->ki", self.S_tilde, qf)
        return phi, qf, A, B, s_bar, a_U, a_T

    # -- mass --------------------------------------------------------------------------------
    def mass_blocks(self, qx) -> np.ndarray:
        """M(q) of every beam, shape (k, c, c) [kg, kg m, kg m^2]."""
        q = qx[self.cols]
        phi, qf, A, B, s_bar, a_U, a_T = self._parts(q)
        M = self._M.copy()
        Bs = np.einsum("kab,kb->ka", B, s_bar)
        M[:, 0:2, 2] = M[:, 2, 0:2] = Bs
        ASb = np.einsum("kab,kbj->kaj", A, self.S_bar)
        M[:, 0:2, 3:] = ASb
        M[:, 3:, 0:2] = ASb.transpose(0, 2, 1)
        M[:, 2, 2] = (self.I0 + 2.0 * np.einsum("ki,ki->k", self.a_u, qf)
                      + np.einsum("ki,kij,kj->k", qf, self.M_ff, qf))
        M[:, 2, 3:] = M[:, 3:, 2] = a_T
        return M

    def Ma_q(self, qx, ax) -> np.ndarray:
        """(M(q) a)_q of every beam, shape (k, c, c), local rows and columns."""
        q, a = qx[self.cols], ax[self.cols]
        phi, qf, A, B, s_bar, a_U, a_T = self._parts(q)
        aR, aphi, af = a[:, 0:2], a[:, 2], a[:, 3:]
        BSb = np.einsum("kab,kbj->kaj", B, self.S_bar)            # (k, 2, nf)
        out = np.zeros((len(q), self.c, self.c))
        # rows R: d/dphi (B s_bar aphi + A S_bar af) and d/dq_f (B S_bar aphi)
        out[:, 0:2, 2] = (-np.einsum("kab,kb->ka", A, s_bar) * aphi[:, None]
                          + np.einsum("kaj,kj->ka", BSb, af))
        out[:, 0:2, 3:] = BSb * aphi[:, None, None]
        # row phi: (B s_bar) . aR + m_phiphi aphi + a_T . af
        out[:, 2, 2] = -np.einsum("kab,kb,ka->k", A, s_bar, aR)
        out[:, 2, 3:] = (np.einsum("kaj,ka->kj", BSb, aR) + 2.0 * a_U * aphi[:, None]
                         - np.einsum("kij,kj->ki", self.S_tilde, af))
        # rows f: S_bar^T A^T aR + a_T aphi + M_ff af
        out[:, 3:, 2] = np.einsum("kaj,ka->kj", BSb, aR)
        out[:, 3:, 3:] = self.S_tilde * aphi[:, None, None]
        return out

    # -- geometric stiffening ---------------------------------------------------------------
    def _strains(self, qf):
        """a_e, g_e = G_e q_f and c_e per element: shapes (..., k, N_e),
        (..., k, N_e, nf), (..., k, N_e)."""
        a = np.einsum("kej,...kj->...ke", self.Bu, qf)
        g = np.einsum("keij,...kj->...kei", self.G, qf)
        return a, g, np.einsum("...kei,...ki->...ke", g, qf)

    def _stiffening_force(self, qf):
        """dU_G/dq_f, shape (k, nf) (module docstring)."""
        a, g, c = self._strains(qf)
        return (np.einsum("ke,kej->kj", self.kEA * c, self.Bu)
                + np.einsum("ke,kej->kj", self.kEA * (2.0 * a + c), g))

    def _stiffening_matrix(self, qf):
        """d^2U_G/dq_f^2, shape (k, nf, nf)."""
        a, g, c = self._strains(qf)
        cross = np.einsum("ke,kei,kej->kij", self.kEA, self.Bu, g)
        return (2.0 * (cross + cross.transpose(0, 2, 1))
                + 2.0 * np.einsum("ke,kei,kej->kij", self.kEA, g, g)
                + np.einsum("ke,keij->kij", self.kEA * (2.0 * a + c), self.G))

    def tangent_stiffness(self, qx) -> np.ndarray:
        """K (+ d^2U_G/dq_f^2 with geometric stiffening) of every beam at q,
        shape (k, nf, nf) [N/m, N, N m]."""
        if not self.stiffening.any():
            return self.K
        return self.K + self._stiffening_matrix(qx[self.cols][:, 3:])

    def _stiffening_energy(self, qf):
        """U_G of every beam, shape (..., k)."""
        a, _, c = self._strains(qf)
        return np.einsum("ke,...ke->...k", self.kEA, a * c + 0.25 * c * c)

    # -- forces ------------------------------------------------------------------------------
    def forces(self, qx, vx, t):
        """Local Q = Q_v - K q_f + Q_gravity, shape (k, c) [N, N m]."""
        q, v = qx[self.cols], vx[self.cols]
        phi, qf, A, B, s_bar, a_U, a_T = self._parts(q)
        w, qd = v[:, 2], v[:, 3:]
        w2 = (w * w)[:, None]
        out = np.empty((len(q), self.c))
        out[:, 0:2] = (w2 * np.einsum("kab,kb->ka", A, s_bar)
                       - 2.0 * w[:, None] * np.einsum("kab,kbj,kj->ka", B, self.S_bar, qd))
        out[:, 2] = -2.0 * w * np.einsum("ki,ki->k", a_U, qd)
        out[:, 3:] = (w2 * a_U - 2.0 * w[:, None] * np.einsum("kij,kj->ki", self.S_tilde, qd)
                      - np.einsum("kij,kj->ki", self.K, qf))
        if self.stiffening.any():
            out[:, 3:] -= self._stiffening_force(qf)
        if self.gravity is not None:
            g = self.gravity
            out[:, 0:2] += self.m[:, None] * g
            out[:, 2] += np.einsum("kab,kb,a->k", B, s_bar, g)
            out[:, 3:] += np.einsum("kaj,kba,b->kj", self.S_bar, A, g)   # S_bar^T A^T g
        return out

    def derivatives(self, qx, vx, t):
        """Local (Q_q, Q_v), each shape (k, c, c)."""
        q, v = qx[self.cols], vx[self.cols]
        phi, qf, A, B, s_bar, a_U, a_T = self._parts(q)
        w, qd = v[:, 2], v[:, 3:]
        kk, c = len(q), self.c
        w1, w2 = w[:, None], (w * w)[:, None]
        As = np.einsum("kab,kb->ka", A, s_bar)
        Bs = np.einsum("kab,kb->ka", B, s_bar)
        ASb = np.einsum("kab,kbj->kaj", A, self.S_bar)
        BSb = np.einsum("kab,kbj->kaj", B, self.S_bar)
        Sq = np.einsum("kij,kj->ki", self.S_tilde, qd)
        Qq, Qv = np.zeros((kk, c, c)), np.zeros((kk, c, c))
        # Q_R = w^2 A s_bar - 2 w B S_bar qd
        Qq[:, 0:2, 2] = w2 * Bs + 2.0 * w1 * np.einsum("kaj,kj->ka", ASb, qd)
        Qq[:, 0:2, 3:] = w2[:, :, None] * ASb
        Qv[:, 0:2, 2] = 2.0 * w1 * As - 2.0 * np.einsum("kaj,kj->ka", BSb, qd)
        Qv[:, 0:2, 3:] = -2.0 * w1[:, :, None] * BSb
        # Q_phi = -2 w a_U . qd
        Qq[:, 2, 3:] = -2.0 * w1 * np.einsum("kij,kj->ki", self.M_ff, qd)
        Qv[:, 2, 2] = -2.0 * np.einsum("ki,ki->k", a_U, qd)
        Qv[:, 2, 3:] = -2.0 * w1 * a_U
        # Q_f = w^2 a_U - 2 w S_tilde qd - K q_f
        Qq[:, 3:, 3:] = w2[:, :, None] * self.M_ff - self.K
        if self.stiffening.any():
            Qq[:, 3:, 3:] -= self._stiffening_matrix(qf)
        Qv[:, 3:, 2] = 2.0 * w1 * a_U - 2.0 * Sq
        Qv[:, 3:, 3:] = -2.0 * w1[:, :, None] * self.S_tilde
        if self.gravity is not None:
            g = self.gravity
            Qq[:, 2, 2] += -np.einsum("ka,a->k", As, g)
            Qq[:, 2, 3:] += np.einsum("kaj,a->kj", BSb, g)
            Qq[:, 3:, 2] += np.einsum("kaj,a->kj", BSb, g)
        return Qq, Qv

    # -- energy and momentum -------------------------------------------------------------------
    def energy(self, qx):
        """Strain energy plus gravity potential energy of all beams [J]: a
        float, or shape (...) for rows qx of shape (..., nx)."""
        q = qx[..., self.cols]
        qf = q[..., 3:]
        e = 0.5 * np.einsum("...ki,kij,...kj->...", qf, self.K, qf)
        if self.stiffening.any():
            e = e + np.sum(self._stiffening_energy(qf), axis=-1)
        if self.gravity is not None:
            A, _ = _AB(q[..., 2])
            s_bar = self.s0 + np.einsum("kaj,...kj->...ka", self.S_bar, qf)
            e = e - np.sum(self.m * (q[..., 0:2] @ self.gravity), axis=-1)
            e = e - np.einsum("a,...kab,...kb->...", self.gravity, A, s_bar)
        return e

    def strain_energy(self, qx) -> np.ndarray:
        """q_f^T K q_f / 2 (+ U_G with geometric stiffening) of each beam, shape (k,) [J]."""
        qf = qx[self.cols][:, 3:]
        e = 0.5 * np.einsum("ki,kij,kj->k", qf, self.K, qf)
        return e + self._stiffening_energy(qf) if self.stiffening.any() else e
