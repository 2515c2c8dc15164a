"""Compliant contacts and joint limits as a force group with events.

Each instance is one one-sided gap g(q) of :mod:`mbdsl.model.contact`
(a contact between a circle and a line or a hole, one side of a joint
limit), with the Hunt-Crossley law of that module:

    delta = -g,  ddelta/dt = -grad g . v,
    f = K delta^n (1 + chi ddelta/dt / v_impact)   (delta > 0, cut at f >= 0),
    Q = f grad g,

with, at a contact with a friction coefficient mu, the regularised Coulomb
force F_t = -mu f tanh(v_t / v_reg) along the contact's tangent (v_t the
slip speed of the two bodies' material points at the contact point, w(q) . v:
:func:`~mbdsl.model.contact.slip`), in generalized form F_t w; and the
exact derivatives for the Newton matrix:

    Q_q = grad g (df/dq)^T + f H_g,   Q_v = grad g (df/dv)^T,
    df/dq = -(K n delta^(n-1) (1 + chi ddelta/dt / v_impact)) grad g
            - (K delta^n chi / v_impact) H_g v,
    df/dv = -(K delta^n chi / v_impact) grad g

(zero where the gap is open or the force is cut). v_impact is the state of
the contact, set by the time loop when the gap closes (``arm``, the event
that lands a step on the closing) and cleared when it opens (``release``).
"""

from __future__ import annotations

import numpy as np

from ..model.contact import SPEED_FLOOR, gap, gap_columns, slip

__all__ = ["ContactGroup"]


class ContactGroup:
    """Contacts and joint limits (:class:`~mbdsl.model.contact.Contact`), one
    instance per one-sided gap.

    Attributes
    ----------
    cols : ndarray of intp, shape (k, 6)
        Local columns per gap: x, y, phi of its first body, then of its second.
    names : list of str
        Per gap, the element's name and the gap's label (``"stop.upper"``).
    k_, n_, chi : ndarray, shape (k,)
        Stiffness, exponent and damping factor.
    impact_speed : ndarray, shape (k,) [m/s or rad/s]
        The approach speed of each closed gap when it closed; 0 while open.
    """

    damped = True

    def __init__(self, cmap, contacts):
        self.cmap = cmap
        self.geometry, self.names, self.elements = [], [], []
        cols, K, n, chi, mu, v_reg = [], [], [], [], [], []
        for c in contacts:
            for geometry, data, label in c.gaps:
                mu.append(c.mu)
                v_reg.append(c.v_reg)
                self.geometry.append((geometry, data))
                self.names.append(c.name + ("." + label if label else ""))
                self.elements.append(c.name)
                cols.append(gap_columns(geometry, data, cmap))
                K.append(c.k)
                n.append(c.exponent)
                chi.append(c.damping)
        self.cols = np.array(cols, dtype=np.intp).reshape(-1, 6)
        self.k_, self.n_, self.chi = (np.array(x, float) for x in (K, n, chi))
        self.mu, self.v_reg = np.array(mu, float), np.array(v_reg, float)
        self.damped = bool(np.any(self.chi > 0.0) or np.any(self.mu > 0.0))
        self.impact_speed = np.zeros(len(self.names))
        #: (t, gap, speed) of every arm and release of the run under way
        self.log = []
        #: The kernels' evaluation of :meth:`energy` and :meth:`dissipation`
        #: over rows, (qx (N, nx), vx (N, nx), speeds (N, k)) -> (energy,
        #: dissipation), each (N,), installed by a run that loaded them
        #: (``engine.prepare_compiled``); None: the loops below.
        self.row_kernel = None

    # -- the contact state (set by the time loop) ------------------------------------------
    def reset(self):
        """Every gap open, no impact speed remembered, an empty log: the start
        of a run. Gaps closed at the start are armed by the time loop."""
        self.impact_speed[:] = 0.0
        self.log = []

    def arm(self, i, speed, t):
        """Gap i closed at time t [s] with approach speed ``speed`` (floored:
        ``SPEED_FLOOR``); logged."""
        self.impact_speed[i] = max(float(speed), SPEED_FLOOR)
        self.log.append((float(t), int(i), float(self.impact_speed[i])))

    def release(self, i, t):
        """Gap i opened at time t [s]; logged."""
        self.impact_speed[i] = 0.0
        self.log.append((float(t), int(i), 0.0))

    # -- evaluation ----------------------------------------------------------------------
    def gaps(self, qx) -> np.ndarray:
        """g per gap, shape (k,) [m or rad], from q_ext (nx,)."""
        return np.array([gap(geo, data, qx, self.cmap)[0] for geo, data in self.geometry])

    def duration(self, i, qx, speed, mass_diag) -> float:
        """Estimated duration [s] of an impact of gap i at approach speed
        ``speed``: 3 delta_max / v with delta_max = ((n + 1) m v^2 / (2 K))^(1
        / (n + 1)) the undamped law's largest penetration (pi sqrt(m / K) for
        n = 1; Hertz's 2.94 delta_max / v for n = 1.5: Johnson, Contact
        Mechanics, sec. 11.4), m the gap's effective mass 1 / (grad g^T
        M^-1 grad g) over its two bodies' diagonal masses (the joints that
        add to it are left out: the estimate errs short).

        Parameters
        ----------
        mass_diag : ndarray, shape (n,)
            The rigid bodies' diagonal mass matrix [kg, kg m^2].
        """
        n_q = len(mass_diag)
        _, grad, _ = gap(*self.geometry[i], qx, self.cmap)
        inv = sum(gj * gj / mass_diag[c] for gj, c in zip(grad, self.cols[i])
                  if c < n_q and mass_diag[c] > 0.0)
        if not inv > 0.0:
            return np.inf
        v = max(float(speed), SPEED_FLOOR)
        ex = self.n_[i]
        delta_max = ((ex + 1.0) * v * v / (2.0 * self.k_[i] * inv)) ** (1.0 / (ex + 1.0))
        return 3.0 * delta_max / v

    def gaps_one(self, i, qx) -> float:
        """g of gap i [m or rad]."""
        return gap(*self.geometry[i], qx, self.cmap)[0]

    def gap_rate_one(self, i, qx, vx) -> float:
        """dg/dt of gap i."""
        return float(gap(*self.geometry[i], qx, self.cmap)[1] @ vx[self.cols[i]])

    def gap_rates(self, qx, vx) -> np.ndarray:
        """dg/dt per gap, shape (k,)."""
        return np.array([gap(geo, data, qx, self.cmap)[1] @ vx[c]
                         for (geo, data), c in zip(self.geometry, self.cols)])

    def _law(self, i, qx, vx, speed):
        """(g, grad, H, delta, ddelta, f, elastic part K delta^n) of gap i."""
        geo, data = self.geometry[i]
        g, grad, H = gap(geo, data, qx, self.cmap)
        if g >= 0.0:
            return g, grad, H, 0.0, 0.0, 0.0, 0.0
        delta = -g
        ddelta = -(grad @ vx[self.cols[i]])
        elastic = self.k_[i] * delta ** self.n_[i]
        # not armed yet (a trial step into a contact the event has not closed):
        # the approach speed now stands for the impact speed
        v_imp = speed if speed > 0.0 else max(ddelta, SPEED_FLOOR)
        f = elastic * (1.0 + self.chi[i] * ddelta / v_imp)
        return g, grad, H, delta, ddelta, max(f, 0.0), elastic

    def _friction(self, i, qx, vx, f):
        """(F_t, w, dw, v_t, T) of gap i under normal force f: F_t = -mu f
        tanh(v_t / v_reg) along the contact's tangent, v_t = w . v
        (:func:`~mbdsl.model.contact.slip`), T = tanh(v_t / v_reg)."""
        w, dw = slip(*self.geometry[i], qx, self.cmap)
        vt = w @ vx[self.cols[i]]
        T = np.tanh(vt / self.v_reg[i])
        return -self.mu[i] * f * T, w, dw, vt, T

    def forces(self, qx, vx, t):
        """Local Q, shape (k, 6) [N, N m]: the normal force f grad g and, with
        friction, F_t w (the tangential force's generalized form)."""
        out = np.zeros(self.cols.shape)
        for i in range(len(self.names)):
            _, grad, _, _, _, f, _ = self._law(i, qx, vx, self.impact_speed[i])
            if f > 0.0:
                out[i] = f * grad
                if self.mu[i] > 0.0:
                    Ft, w, _, _, _ = self._friction(i, qx, vx, f)
                    out[i] += Ft * w
        return out

    def derivatives(self, qx, vx, t):
        """Local (Q_q, Q_v), each shape (k, 6, 6) (module notes)."""
        k = len(self.names)
        Qq, Qv = np.zeros((k, 6, 6)), np.zeros((k, 6, 6))
        for i in range(k):
            g, grad, H, delta, ddelta, f, elastic = self._law(i, qx, vx, self.impact_speed[i])
            if f <= 0.0:
                continue
            n, chi = self.n_[i], self.chi[i]
            armed = self.impact_speed[i] > 0.0 or ddelta <= SPEED_FLOOR
            speed = self.impact_speed[i] if self.impact_speed[i] > 0.0 else max(ddelta,
                                                                                 SPEED_FLOOR)
            # df/d(ddelta): K delta^n chi / v_impact; unarmed, f = K delta^n (1 + chi)
            # does not depend on ddelta
            damp = elastic * chi / speed if armed else 0.0
            df_ddelta = n * self.k_[i] * delta ** (n - 1.0) * (1.0 + chi * ddelta / speed)
            v = vx[self.cols[i]]
            dfdq = -df_ddelta * grad - damp * (H @ v)
            dfdv = -damp * grad
            Qq[i] = np.outer(grad, dfdq) + f * H
            Qv[i] = np.outer(grad, dfdv)
            if self.mu[i] > 0.0:
                # Q = F_t w, F_t = -mu f T(v_t): Q_q = w dF_t/dq^T + F_t dw/dq,
                # Q_v = w dF_t/dv^T, dv_t/dq = (dw/dq)^T v, dv_t/dv = w
                Ft, w, dw, vt, T = self._friction(i, qx, vx, f)
                dT = (1.0 - T * T) / self.v_reg[i]
                dvt_dq = dw.T @ v
                dFt_dq = -self.mu[i] * (T * dfdq + f * dT * dvt_dq)
                dFt_dv = -self.mu[i] * (T * dfdv + f * dT * w)
                Qq[i] += np.outer(w, dFt_dq) + Ft * dw
                Qv[i] += np.outer(w, dFt_dv)
        return Qq, Qv

    def energy(self, qx):
        """Elastic energy of the contacts, K delta^(n+1) / (n+1) [J]: a float,
        or shape (N,) for rows qx (N, nx)."""
        rows = np.atleast_2d(qx)
        if self.row_kernel is not None:
            zero = np.zeros((len(rows), len(self.names)))
            out = self.row_kernel(rows, np.zeros_like(rows), zero)[0]
            return float(out[0]) if np.ndim(qx) == 1 else out
        out = np.zeros(len(rows))
        for r, row in enumerate(rows):
            for i, (geo, data) in enumerate(self.geometry):
                g = gap(geo, data, row, self.cmap)[0]
                if g < 0.0:
                    out[r] += self.k_[i] * (-g) ** (self.n_[i] + 1.0) / (self.n_[i] + 1.0)
        return float(out[0]) if np.ndim(qx) == 1 else out

    def dissipation(self, qx, vx, speeds):
        """Power the contacts dissipate [W], shape (N,), for rows qx, vx
        (N, nx) and the impact speeds in force at each row (N, k)
        (:meth:`speeds_at`): (f - K delta^n) ddelta/dt, the damping's power
        and, where the force is cut at zero, the elastic power it leaves out."""
        if self.row_kernel is not None:
            return self.row_kernel(qx, vx, speeds)[1]
        out = np.zeros(len(qx))
        for r in range(len(qx)):
            for i in range(len(self.names)):
                _, _, _, delta, ddelta, f, elastic = self._law(i, qx[r], vx[r], speeds[r, i])
                if delta > 0.0:
                    out[r] += (f - elastic) * ddelta
                    if self.mu[i] > 0.0 and f > 0.0:       # friction: -F_t v_t >= 0
                        Ft, _, _, vt, _ = self._friction(i, qx[r], vx[r], f)
                        out[r] -= Ft * vt
        return out

    def speeds_at(self, t, log):
        """Impact speeds in force at times t (N,), from a run's contact log
        [(t_event, gap index, speed; 0 for an opening)], shape (N, k)."""
        out = np.zeros((len(t), len(self.names)))
        for t_e, i, speed in sorted(log, key=lambda x: x[0]):
            out[np.asarray(t) >= t_e - 1e-15 * max(1.0, abs(t_e)), i] = speed
        return out
