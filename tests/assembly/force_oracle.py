"""An independent numpy evaluation of the applied loads: the oracle the load
kernels of ``mbdsl.kernels`` (``elements``: ``_forces``,
``_emit_force``, ``_emit_friction_lam``, ``_potential``, ``_power``, the
gaps, spring separations and friction speeds) are tested against. Not part
of the package: mbdsl evaluates its loads with the kernels only.

Each group's *local* arrays over the c coordinates it touches (columns
``cols`` (k, c) into q_ext = [q, 0, 0, 0]) are scattered into dense ones:
Q (k, c), Q_q and Q_v (k, c, c). The groups are the test's own reading of
the model (``load_groups``), and the equations their notes: spring-dampers, rotational spring-dampers,
torques, loads of the state, point forces, friction in joints (Andersson,
Soderberg & Bjorklund 2007, eq. (8)); contacts (``contact_oracle``) and
flexible beams (``ffr_oracle``) by their own oracles. A point's position and
derivatives are those of ``constraint_oracle`` (rotation matrices).
"""

from __future__ import annotations

import numpy as np

from ..contact.contact_oracle import ContactOracle
from ..flexible.ffr_oracle import BeamOracle
from .constraint_oracle import SystemOracle, _pair, _point_hess, _point_jac, line_distance
from .load_groups import (FrictionGroup, PointForceGroup, RotationalSpringGroup,
                          SpringDamperGroup, StateRateGroup, StateTorqueGroup, TorqueGroup,
                          load_groups)

__all__ = ["ForceOracle"]


# -- spring-dampers ---------------------------------------------------------------------------
def _spring(g, qx, vx):
    """(v local, d, D = dd/dq, DD, ddot, l, e) of a spring group."""
    q1, d, D, DD = _pair(g, qx)
    v = vx[g.cols]
    ddot = np.einsum("kaj,kj->ka", D, v)
    l = np.sqrt(np.einsum("ka,ka->k", d, d))
    e = np.divide(d, l[:, None], out=np.zeros_like(d), where=l[:, None] > 0.0)
    return v, d, D, DD, ddot, l, e


def spring_forces(g, qx, vx):
    v, d, D, DD, ddot, l, e = _spring(g, qx, vx)
    f = g.k * (l - g.l0) + g.c * np.einsum("ka,ka->k", e, ddot)
    return -np.einsum("kaj,ka->kj", D, f[:, None] * e)


def spring_derivatives(g, qx, vx):
    v, d, D, DD, ddot, l, e = _spring(g, qx, vx)
    Hv = np.einsum("kaij,kj->kai", DD, v)           # d(ddot)/dq
    inv_l = np.divide(1.0, l, out=np.zeros_like(l), where=l > 0.0)
    P = (np.eye(2)[None] - e[:, :, None] * e[:, None, :]) * inv_l[:, None, None]
    de = np.einsum("kab,kbj->kaj", P, D)            # de/dq
    ldot = np.einsum("ka,ka->k", e, ddot)
    dl = np.einsum("ka,kaj->kj", e, D)
    f = g.k * (l - g.l0) + g.c * ldot
    dldot = np.einsum("ka,kaj->kj", ddot, de) + np.einsum("ka,kaj->kj", e, Hv)
    df = g.k[:, None] * dl + g.c[:, None] * dldot
    dF = e[:, :, None] * df[:, None, :] + f[:, None, None] * de
    F = f[:, None] * e
    Qq = -np.einsum("kaj,kai->kji", D, dF) - np.einsum("ka,kaij->kij", F, DD)
    De = np.einsum("kaj,ka->kj", D, e)
    Qv = -g.c[:, None, None] * De[:, :, None] * De[:, None, :]
    return Qq, Qv


def spring_energy(g, qx):
    _, d, _, _, _, l, _ = _spring(g, qx, np.zeros_like(qx))
    return 0.5 * np.sum(g.k * (l - g.l0) ** 2)


def spring_dissipation(g, qx, vx):
    _, _, _, _, ddot, _, e = _spring(g, qx, vx)
    return np.sum(g.c * np.einsum("ka,ka->k", e, ddot) ** 2)


# -- rotational spring-dampers, torques ---------------------------------------------------------
def rotational_forces(g, qx, vx):
    q, v = qx[g.cols], vx[g.cols]
    tau = g.k * (q[:, 1] - q[:, 0] - g.angle) + g.c * (v[:, 1] - v[:, 0])
    return np.stack([tau, -tau], axis=1)


def rotational_derivatives(g):
    pattern = np.array([[-1.0, 1.0], [1.0, -1.0]])
    return g.k[:, None, None] * pattern, g.c[:, None, None] * pattern


# -- loads of the state ------------------------------------------------------------------------
def state_values(f, qx, vx, cmap):
    """The state variables' values of the state function f at (q, v) extended
    by the ground's zeros, shape (len(f.variables),): a coordinate or rate
    combination, or a sliding joint's distance or speed (``line_distance``)."""
    out = np.empty(len(f.variables))
    for k, var in enumerate(f.variables):
        if var.line is not None:
            s, grad, _ = line_distance(var.line, qx, cmap)
            out[k] = s if var.level == 0 else float(grad @ vx[var.columns(cmap)])
            continue
        src = qx if var.level == 0 else vx
        out[k] = var.offset + sum(c * src[cmap.column(b, j)] for b, j, c in var.terms)
    return out


def _tau(g, f, qx, vx, t):
    """tau and, for a state function, the variables' values."""
    if hasattr(f, "variables"):
        x = state_values(f, qx, vx, g.cmap)
        return f.f(t, x), x
    return f.f(t), None


def _direction(g, i, qx):
    """(local columns, w, dw/dq or None) of instance i."""
    if g.lines[i] is None:
        a, b = g.targets[i]
        return [a, b], np.array([1.0, -1.0]), None
    _, grad, H = line_distance(g.lines[i], qx, g.cmap)
    return g.line_cols[i], grad, H


def state_forces(g, qx, vx, t):
    out = np.zeros(g.cols.shape)
    for i, f in enumerate(g.functions):
        tau, _ = _tau(g, f, qx, vx, t)
        cols, w, _ = _direction(g, i, qx)
        np.add.at(out[i], cols, tau * w)
    return out


def state_derivatives(g, qx, vx, t):
    k, c = g.cols.shape
    Qq, Qv = np.zeros((k, c, c)), np.zeros((k, c, c))
    for i, f in enumerate(g.functions):
        tau, x = _tau(g, f, qx, vx, t)
        cols, w, dw = _direction(g, i, qx)
        if dw is not None:
            Qq[i][np.ix_(cols, cols)] += tau * dw
        if x is None:
            continue
        dq, dv = np.zeros(c), np.zeros(c)
        for grad, (var, local) in zip(f.grads, g.variables[i]):
            gk = grad(t, x)
            if var.line is None:
                target = dq if var.level == 0 else dv
                for a, (_, _, coef) in zip(local, var.terms):
                    target[a] += gk * coef
                continue
            _, gs, Hs = line_distance(var.line, qx, g.cmap)
            if var.level == 0:
                np.add.at(dq, local, gk * gs)
            else:
                np.add.at(dq, local, gk * (Hs @ vx[var.columns(g.cmap)]))
                np.add.at(dv, local, gk * gs)
        for a, wa in zip(cols, w):
            Qq[i, a] += wa * dq
            Qv[i, a] += wa * dv
    return Qq, Qv


# -- point forces -------------------------------------------------------------------------------
def _point_load(g, t, qx, vx):
    return np.array([[_tau(g, f, qx, vx, t)[0] for f in (fx, fy)]
                     for fx, fy in zip(g.fx, g.fy)]).reshape(-1, 2)


def point_forces(g, qx, vx, t):
    return np.einsum("kaj,ka->kj", _point_jac(g.points, qx[g.cols]), _point_load(g, t, qx, vx))


def point_derivatives(g, qx, vx, t):
    return np.einsum("ka,kaij->kij", _point_load(g, t, qx, vx),
                     _point_hess(g.points, qx[g.cols]))


def point_state_derivatives(g, qx, vx, t, nx):
    """J^T (dF/dx)(dx/dq), J^T (dF/dx)(dx/dv) of the forces of the state,
    dense (nx, nx): each partial derivative through its variable's terms (a
    linear combination of columns) or a sliding line's distance or speed."""
    Qq, Qv = np.zeros((nx, nx)), np.zeros((nx, nx))
    J = _point_jac(g.points, qx[g.cols])
    for i, comps in enumerate(zip(g.fx, g.fy)):
        for a, f in enumerate(comps):
            if not hasattr(f, "variables"):
                continue
            x = state_values(f, qx, vx, g.cmap)
            for grad, var in zip(f.grads, f.variables):
                gk = grad(t, x)
                dq, dv = np.zeros(nx), np.zeros(nx)
                cols = var.columns(g.cmap)
                if var.line is None:
                    for c, (_, _, coef) in zip(cols, var.terms):
                        (dq if var.level == 0 else dv)[c] += gk * coef
                else:
                    _, gs, Hs = line_distance(var.line, qx, g.cmap)
                    if var.level == 0:
                        np.add.at(dq, cols, gk * gs)
                    else:
                        np.add.at(dq, cols, gk * (Hs @ vx[cols]))
                        np.add.at(dv, cols, gk * gs)
                np.add.at(Qq, (g.cols[i][:, None], np.arange(nx)[None, :]),
                          np.outer(J[i, a], dq))
                np.add.at(Qv, (g.cols[i][:, None], np.arange(nx)[None, :]),
                          np.outer(J[i, a], dv))
    return Qq, Qv


# -- friction -----------------------------------------------------------------------------------
def _friction_kinematics(g, i, qx, vx):
    """(local columns, w, dw/dq or None, z, dz/dq local) of instance i."""
    if g.lines[i] is None:
        w = np.array([1.0, -1.0])
        return [0, 1], w, None, float(w @ vx[g.cols[i, :2]]), np.zeros(2)
    _, grad, H = line_distance(g.lines[i], qx, g.cmap)
    v = vx[g.cols[i, :6]]
    return list(range(6)), grad, H, float(grad @ v), H @ v


def friction_law(g, i, z, lam_J, slip=None):
    """(tau, dtau/dz, dtau/dlambda_J) of instance i; ``slip`` replaces
    tanh(z/v_reg) (and mu(z) by mu_s) where it is not None or NaN."""
    mu_k, mu_s, v_s, c, v_reg, r = g.params[i]
    e = np.exp(-(z / v_s) ** 2) if v_s > 0 else 0.0
    mu = mu_k + (mu_s - mu_k) * e
    dmu = (mu_s - mu_k) * e * (-2.0 * z / v_s ** 2) if v_s > 0 else 0.0
    th = np.tanh(z / v_reg)
    if slip is not None and not np.isnan(slip):
        th, mu, dmu = slip, mu_s, 0.0
    R = float(np.sqrt(lam_J @ lam_J))
    N = r * R
    dN = r * lam_J / R if R > 0.0 else np.zeros_like(lam_J)
    tau = -N * mu * th - c * z
    dz = -N * (dmu * th + mu * (1.0 - th * th) / v_reg) - c
    return tau, dz, -mu * th * dN


def friction_forces(g, qx, vx, lam, slip=None):
    out = np.zeros(g.cols.shape)
    for i in range(len(g.lines)):
        cols, w, _, z, _ = _friction_kinematics(g, i, qx, vx)
        tau, _, _ = friction_law(g, i, z, lam[g.rows[i]], None if slip is None else slip[i])
        out[i, cols] += tau * w
    return out


def friction_derivatives(g, qx, vx, lam):
    k, c = g.cols.shape
    Qq, Qv = np.zeros((k, c, c)), np.zeros((k, c, c))
    for i in range(k):
        cols, w, dw, z, dzq = _friction_kinematics(g, i, qx, vx)
        tau, dz, _ = friction_law(g, i, z, lam[g.rows[i]])
        ix = np.ix_(cols, cols)
        if dw is not None:
            Qq[i][ix] += tau * dw
        Qq[i][ix] += dz * np.outer(w, dzq)
        Qv[i][ix] += dz * np.outer(w, w)
    return Qq, Qv


def friction_speeds(g, qx, vx, ax=None):
    out = np.zeros(len(g.lines))
    for i in range(len(g.lines)):
        cols, w, dw, z, _ = _friction_kinematics(g, i, qx, vx)
        if ax is None:
            out[i] = z
            continue
        c = g.cols[i, cols]
        out[i] = w @ ax[c] + (0.0 if dw is None else vx[c] @ dw @ vx[c])
    return out


class ForceOracle(SystemOracle):
    """Q, its derivatives, the loads' energy and power of an
    ``AssembledSystem``'s force groups, dense."""

    @property
    def groups(self) -> list:
        """The model's loads as groups (``load_groups``), then the contacts'
        and the flexible beams' oracles."""
        if getattr(self, "_groups", None) is None:
            system = self.system
            contact = [ContactOracle(system)] if system.contact_state is not None else []
            self._groups = (load_groups(system) + contact
                            + [BeamOracle.of(system, s) for s in system.beam_sets])
        return self._groups

    def _local(self, g, qx, vx, t, lam, slip=None):
        """Local Q of group g."""
        if isinstance(g, SpringDamperGroup):
            return spring_forces(g, qx, vx)
        if isinstance(g, RotationalSpringGroup):
            return rotational_forces(g, qx, vx)
        if isinstance(g, TorqueGroup):
            return np.array([[f.f(t)] for f in g.functions])
        if isinstance(g, StateTorqueGroup):
            return state_forces(g, qx, vx, t)
        if isinstance(g, PointForceGroup):
            return point_forces(g, qx, vx, t)
        if isinstance(g, FrictionGroup):
            return friction_forces(g, qx, vx, lam, slip)
        assert isinstance(g, (ContactOracle, BeamOracle))
        return g.forces(qx, vx, t)

    def _local_derivatives(self, g, qx, vx, t, lam):
        """Local (Q_q, Q_v or None) of group g, or None (torques)."""
        if isinstance(g, SpringDamperGroup):
            return spring_derivatives(g, qx, vx)
        if isinstance(g, RotationalSpringGroup):
            return rotational_derivatives(g)
        if isinstance(g, TorqueGroup):
            return None
        if isinstance(g, StateTorqueGroup):
            return state_derivatives(g, qx, vx, t)
        if isinstance(g, PointForceGroup):
            return point_derivatives(g, qx, vx, t), None
        if isinstance(g, FrictionGroup):
            return friction_derivatives(g, qx, vx, lam)
        return g.derivatives(qx, vx, t)          # contacts and beams

    def Q(self, t, q, v, lam=None, slip=None):
        """Q (n,) [N, N m], gravity included."""
        qx, vx = self._ext(q), self._ext(v)
        out = np.zeros(self.nx)
        if self.system.gravity_force is not None:
            out[: self.n] += self.system.gravity_force
        for g in self.groups:
            np.add.at(out, g.cols, self._local(g, qx, vx, t, lam, slip))
        return out[: self.n]

    def derivatives(self, t, q, v, lam=None):
        """(Q_q, Q_v), each (n, n)."""
        qx, vx = self._ext(q), self._ext(v)
        Qq, Qv = np.zeros((self.nx, self.nx)), np.zeros((self.nx, self.nx))
        for g in self.groups:
            if isinstance(g, PointForceGroup):      # the forces of the state reach beyond
                dq, dv = point_state_derivatives(g, qx, vx, t, self.nx)
                Qq += dq
                Qv += dv
            blocks = self._local_derivatives(g, qx, vx, t, lam)
            if blocks is None:
                continue
            for i, cols in enumerate(g.cols):
                ix = np.ix_(cols, cols)
                np.add.at(Qq, ix, blocks[0][i])
                if blocks[1] is not None:
                    np.add.at(Qv, ix, blocks[1][i])
        return Qq[: self.n, : self.n], Qv[: self.n, : self.n]

    def Q_lam(self, t, q, v, lam):
        """dQ/dlambda (n, m) of friction."""
        qx, vx = self._ext(q), self._ext(v)
        out = np.zeros((self.nx, self.m))
        for g in [g for g in self.groups if isinstance(g, FrictionGroup)]:
            for i in range(len(g.lines)):
                cols, w, _, z, _ = _friction_kinematics(g, i, qx, vx)
                _, _, dl = friction_law(g, i, z, lam[g.rows[i]])
                out[np.ix_(g.cols[i, cols], g.rows[i])] += np.outer(w, dl)
        return out[: self.n]

    def potential(self, q):
        """Gravity, spring, rotational spring, contact and beam energy [J]."""
        qx = self._ext(q)
        e = 0.0 if self.system.gravity_force is None else -float(q @ self.system.gravity_force)
        for g in self.groups:
            if isinstance(g, SpringDamperGroup):
                e += spring_energy(g, qx)
            elif isinstance(g, RotationalSpringGroup):
                th = qx[g.cols[:, 1]] - qx[g.cols[:, 0]] - g.angle
                e += 0.5 * np.sum(g.k * th ** 2)
            elif isinstance(g, ContactOracle):
                e += g.energy(qx)
            elif isinstance(g, BeamOracle):
                e += float(g.energy(qx[None])[0])
        return e

    def power(self, t, q, v, lam, speeds=None):
        """(put in, dissipated) [W] by the loads (the drivers' power left
        out); ``speeds`` (k,) the contacts' impact speeds."""
        qx, vx = self._ext(q), self._ext(v)
        p_in = p_diss = 0.0
        for g in self.groups:
            if isinstance(g, StateRateGroup):
                continue                    # a state's rate does no work
            if isinstance(g, (TorqueGroup, StateTorqueGroup, PointForceGroup)):
                p_in += float(np.sum(self._local(g, qx, vx, t, lam) * vx[g.cols]))
            elif isinstance(g, SpringDamperGroup):
                p_diss += spring_dissipation(g, qx, vx)
            elif isinstance(g, RotationalSpringGroup):
                w = vx[g.cols[:, 1]] - vx[g.cols[:, 0]]
                p_diss += float(np.sum(g.c * w ** 2))
            elif isinstance(g, FrictionGroup):
                for i in range(len(g.lines)):
                    _, _, _, z, _ = _friction_kinematics(g, i, qx, vx)
                    p_diss -= friction_law(g, i, z, lam[g.rows[i]])[0] * z
            elif isinstance(g, ContactOracle):
                p_diss += g.dissipation(qx, vx, speeds)
        return p_in, p_diss

    def spring_separations(self, q):
        """d = p2 - p1 per spring-damper, shape (k, 2)."""
        for g in self.groups:
            if isinstance(g, SpringDamperGroup):
                return _pair(g, self._ext(q))[1]
        return np.zeros((0, 2))

    def friction_speeds(self, q, v, a=None):
        """z per friction joint, or its rate with accelerations a."""
        g = next(g for g in self.groups if isinstance(g, FrictionGroup))
        return friction_speeds(g, self._ext(q), self._ext(v), None if a is None else self._ext(a))

    def gaps(self, qx):
        """(g (k,), grad (k, 6)) of the contacts."""
        o = ContactOracle(self.system)
        parts = [o.gap(i, qx) for i in range(len(o.names))]
        return np.array([p[0] for p in parts]), np.array([p[1] for p in parts]).reshape(-1, 6)
