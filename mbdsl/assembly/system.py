"""The assembled equations of motion of a planar multibody model.

    M(q) a + Phi_q(q,t)^T lambda = Q(t, q, v)      (n equations)
    Phi(q, t) = 0                                 (m equations)

with every derivative an implicit integrator needs, all analytic:
Phi_q, Phi_t, Phi_tt, Phi_qt, gamma = -(Phi_q v)_q v - 2 Phi_qt v - Phi_tt,
Q_q, Q_v, (Phi_q^T lambda)_q, (Phi_q v)_q and (M a)_q.

Notation for the whole package: n generalized coordinates (3 per rigid body:
x, y, phi of the centre of mass), m constraint equations (joint rows in
declaration order, then driver rows). Sign convention:
``M a + Phi_q^T lambda = Q``, so lambda is the negative of the constraint
force in the joint's row direction. SI units.

Only what the model declares is built and evaluated: a model without gravity
has no gravity vector, a model without springs no spring group, and the
force derivatives are ``None`` when no declared force depends on q or v.

The :class:`AssembledSystem` never changes once built (model/data split):
per-step values live in the integrators' state.
"""

from __future__ import annotations

import numpy as np

from ..model.elements import (GROUND, Model, PointForce, RotationalSpringDamper,
                              SpringDamper, Torque)
from .groups import (CoincidenceGroup, LinearConstraintGroup, PointForceGroup,
                     PointOnLineGroup, RotationalSpringGroup, SpringDamperGroup, TorqueGroup,
                     body_columns)
from .layout import Layout

__all__ = ["AssembledSystem", "assemble"]


def _normal(direction):
    return np.array([-direction[1], direction[0]])


class AssembledSystem:
    """Equations of motion, constraints and their derivatives for a Model.

    Parameters
    ----------
    model : Model

    Attributes
    ----------
    n, m : int
        Numbers of coordinates and of constraint equations.
    layout : Layout
        Maps coordinates and constraint rows back to bodies and joints.
    mass_is_constant : bool
        True for rigid bodies: (M a)_q = 0 and M is factored once.
    """

    def __init__(self, model: Model):
        self.model = model
        self.layout = Layout(model)
        n = self.n = model.n_coordinates
        self.m = model.n_constraints
        self.nx = n + 3                      # extended: ground coordinates at n..n+2
        mass = np.repeat([b.mass for b in model.bodies], 3)
        mass[2::3] = [b.inertia for b in model.bodies]
        self.mass_diag = mass
        self.mass_scale = float(np.mean(mass))   # [kg]: converts multipliers to accelerations
        self._M = np.diag(mass)
        self._M.setflags(write=False)
        self.mass_is_constant = True
        self._build_constraints(model)
        self._build_forces(model)

    # -- build ------------------------------------------------------------------
    def _build_constraints(self, model):
        n = self.n
        coinc, pol, lin = [], [], []

        def phi_col(body):
            return body_columns(n, [body])[0, 2]

        def angle_row(row, body1, body2, offset, fn):   # phi2 - phi1 - offset - f(t)
            lin.append((row, (phi_col(body1), phi_col(body2)), (-1.0, 1.0), offset, fn))

        row = 0
        for j in model.joints:
            a, b = j.first, j.second
            if j.kind in ("revolute", "fixed"):
                coinc.append((row, row + 1, a.body, a.local, b.body, b.local))
                if j.kind == "fixed":
                    angle_row(row + 2, a.body, b.body, j.angle, None)
            elif j.kind == "point_on_line":
                pol.append((row, a.body, a.local, b.body, b.local, _normal(j.direction)))
            elif j.kind == "prismatic":
                pol.append((row, a.body, a.local, b.body, b.local, _normal(j.direction)))
                angle_row(row + 1, a.body, b.body, j.angle, None)   # rotation locked
            row += j.rows
        for d in model.drivers:
            if d.kind == "coordinate":        # q_c - f(t); first column: ground dummy, coef 0
                lin.append((row, (n, 3 * d.body + d.coord), (0.0, 1.0), 0.0, d.function))
            else:
                angle_row(row, d.joint.first.body, d.joint.second.body, 0.0, d.function)
            row += 1
        assert row == self.m
        self.constraint_groups = []
        if coinc:
            r0, r1, b1, s1, b2, s2 = zip(*coinc)
            self.constraint_groups.append(CoincidenceGroup(
                n, np.stack([r0, r1], axis=1), b1, np.array(s1), b2, np.array(s2)))
        if pol:
            r, bp, sp, bl, sl, nrm = zip(*pol)
            self.constraint_groups.append(PointOnLineGroup(n, r, bp, np.array(sp), bl,
                                                           np.array(sl), np.array(nrm)))
        if lin:
            r, cols, coefs, off, fns = zip(*lin)
            self.constraint_groups.append(LinearConstraintGroup(n, r, cols, coefs, off, fns))
        self.nonlinear_groups = [g for g in self.constraint_groups if g.hess is not None]
        self.timed_groups = [g for g in self.constraint_groups if g.time_dependent]
        # Fixed scatter patterns (row, col) for Phi_q-shaped blocks, and flat
        # (col, col) indices for the n x n Hessian contractions.
        nx = self.nx
        self._pattern = []
        for g in self.constraint_groups:
            rr = np.broadcast_to(g.rows[:, :, None], (len(g.rows), g.r, g.cols.shape[1]))
            cc = np.broadcast_to(g.cols[:, None, :], rr.shape)
            self._pattern.append((rr, cc))
        self._hess_flat = [(g.cols[:, :, None] * nx + g.cols[:, None, :]) for g in self.nonlinear_groups]

    def _build_forces(self, model):
        n = self.n
        self.gravity_force = None
        if model.gravity is not None and np.any(model.gravity != 0.0):
            Qg = np.zeros(n)
            for b in model.bodies:
                Qg[3 * b.index: 3 * b.index + 2] = b.mass * model.gravity
            self.gravity_force = Qg
        springs = [f for f in model.forces if isinstance(f, SpringDamper)]
        rsprings = [f for f in model.forces if isinstance(f, RotationalSpringDamper)]
        torques = [f for f in model.forces if isinstance(f, Torque)]
        pforces = [f for f in model.forces if isinstance(f, PointForce)]
        self.force_groups = []
        if springs:
            self.force_groups.append(SpringDamperGroup(
                n, [s.first.body for s in springs], [s.first.local for s in springs],
                [s.second.body for s in springs], [s.second.local for s in springs],
                [s.k for s in springs], [s.c for s in springs], [s.length for s in springs]))
        if rsprings:
            self.force_groups.append(RotationalSpringGroup(
                n, [s.joint.first.body for s in rsprings], [s.joint.second.body for s in rsprings],
                [s.k for s in rsprings], [s.c for s in rsprings], [s.angle for s in rsprings]))
        if torques:
            self.force_groups.append(TorqueGroup(n, [f.body for f in torques],
                                                 [f.function for f in torques]))
        if pforces:
            self.force_groups.append(PointForceGroup(
                n, [f.point.body for f in pforces], [f.point.local for f in pforces],
                [f.fx for f in pforces], [f.fy for f in pforces]))
        self.potential_groups = [g for g in self.force_groups if hasattr(g, "energy")]
        self.derivative_groups = [g for g in self.force_groups if g.derivatives is not None]
        self.has_Q_v = any(getattr(g, "damped", False) for g in self.derivative_groups)
        self.has_Q_q = bool(self.derivative_groups)
        nx = self.nx
        self._force_flat = [(g.cols[:, :, None] * nx + g.cols[:, None, :]) for g in self.derivative_groups]

    # -- helpers ------------------------------------------------------------------
    def _ext(self, x):
        out = np.zeros(self.nx)
        out[: self.n] = x
        return out

    def _accumulate(self, flat_list, values_list):
        nx = self.nx
        total = np.zeros(nx * nx)
        for flat, vals in zip(flat_list, values_list):
            total += np.bincount(flat.ravel(), weights=vals.ravel(), minlength=nx * nx)
        return total.reshape(nx, nx)[: self.n, : self.n]

    # -- mass -----------------------------------------------------------------------
    def mass_matrix(self, q=None) -> np.ndarray:
        """M(q), shape (n, n) [kg, kg m^2]; constant (read-only) for rigid bodies."""
        return self._M

    def mass_solve(self, q, X) -> np.ndarray:
        """M(q)^{-1} X for X of shape (n,) or (n, k); a division for rigid bodies."""
        X = np.asarray(X, dtype=float)
        return X / (self.mass_diag if X.ndim == 1 else self.mass_diag[:, None])

    def Ma_q(self, q, a):
        """(M(q) a)_q, shape (n, n), or None when M is constant (rigid bodies)."""
        return None

    # -- forces -------------------------------------------------------------------------
    def Q(self, t, q, v) -> np.ndarray:
        """Generalized applied forces Q(t, q, v), shape (n,) [N, N m]."""
        out = np.zeros(self.nx)
        if self.gravity_force is not None:
            out[: self.n] += self.gravity_force
        if self.force_groups:
            qx, vx = self._ext(q), self._ext(v)
            for g in self.force_groups:
                np.add.at(out, g.cols, g.forces(qx, vx, t))
        return out[: self.n]

    def force_derivatives(self, t, q, v):
        """(Q_q, Q_v), each shape (n, n), or None where no declared force
        depends on q (resp. v)."""
        if not self.has_Q_q:
            return None, None
        qx, vx = self._ext(q), self._ext(v)
        Qq, Qv = [], []
        for g in self.derivative_groups:
            a, b = g.derivatives(qx, vx, t)
            Qq.append(a)
            Qv.append(b if b is not None else np.zeros_like(a))
        Q_q = self._accumulate(self._force_flat, Qq)
        Q_v = self._accumulate(self._force_flat, Qv) if self.has_Q_v else None
        return Q_q, Q_v

    # -- constraints ------------------------------------------------------------------
    def Phi(self, q, t) -> np.ndarray:
        """Constraint values Phi(q, t), shape (m,) [m or rad]."""
        qx = self._ext(q)
        out = np.empty(self.m)
        for g in self.constraint_groups:
            out[g.rows] = g.phi(qx, t)
        return out

    def Phi_q(self, q, t=0.0) -> np.ndarray:
        """Constraint Jacobian, shape (m, n)."""
        qx = self._ext(q)
        out = np.zeros((self.m, self.nx))
        for g, (rr, cc) in zip(self.constraint_groups, self._pattern):
            out[rr, cc] = g.jac(qx)
        return out[:, : self.n]

    def Phi_t(self, q, t) -> np.ndarray:
        """Partial time derivative of Phi, shape (m,)."""
        out = np.zeros(self.m)
        for g in self.timed_groups:
            out[g.rows] = g.phi_t(t)
        return out

    def Phi_tt(self, q, t) -> np.ndarray:
        """Second partial time derivative of Phi, shape (m,)."""
        out = np.zeros(self.m)
        for g in self.timed_groups:
            out[g.rows] = g.phi_tt(t)
        return out

    def Phi_qt(self, q, t) -> np.ndarray:
        """Mixed derivative Phi_qt, shape (m, n).

        Zero for every constraint mbdsl provides: drivers prescribe a
        coordinate or a relative angle, linear in q with a time-only term.
        Kept so that gamma and the index-2 velocity constraints are written
        in full.
        """
        return np.zeros((self.m, self.n))

    def Phiq_v_q(self, q, v) -> np.ndarray:
        """(Phi_q v)_q, shape (m, n)."""
        qx, vx = self._ext(q), self._ext(v)
        out = np.zeros((self.m, self.nx))
        for g, (rr, cc) in zip(self.constraint_groups, self._pattern):
            if g.hess is not None:
                out[rr, cc] = np.einsum("krij,kj->kri", g.hess(qx), vx[g.cols])
        return out[:, : self.n]

    def PhiqT_lam_q(self, q, lam) -> np.ndarray:
        """(Phi_q^T lambda)_q, shape (n, n), symmetric."""
        qx = self._ext(q)
        vals = [np.einsum("krij,kr->kij", g.hess(qx), lam[g.rows]) for g in self.nonlinear_groups]
        return self._accumulate(self._hess_flat, vals)

    def gamma(self, q, v, t) -> np.ndarray:
        """Acceleration right side gamma = -(Phi_q v)_q v - 2 Phi_qt v - Phi_tt, shape (m,)."""
        qx, vx = self._ext(q), self._ext(v)
        out = np.zeros(self.m)
        for g in self.nonlinear_groups:
            vl = vx[g.cols]
            out[g.rows] = -np.einsum("kj,krij,ki->kr", vl, g.hess(qx), vl)
        for g in self.timed_groups:
            out[g.rows] -= g.phi_tt(t)
        return out

    # -- energy ---------------------------------------------------------------------------
    def kinetic_energy(self, q, v) -> float:
        """T = v^T M v / 2 [J]."""
        return float(0.5 * np.dot(v, self.mass_diag * v))

    def potential_energy(self, q) -> float:
        """Gravity and spring potential energy [J] (zero at y = 0, unstretched springs)."""
        e = 0.0
        if self.gravity_force is not None:
            e -= float(np.dot(self.gravity_force, q))
        if self.potential_groups:
            qx = self._ext(q)
            e += sum(g.energy(qx) for g in self.potential_groups)
        return e


def assemble(model: Model) -> AssembledSystem:
    """Build the :class:`AssembledSystem` of a checked model."""
    return AssembledSystem(model)
