"""Compliant contacts and joint limits: their run state through events.

Each gap is a one-sided g(q) of :mod:`mbdsl.model.contact`
(a contact between a circle and a line or a hole, one side of a joint
limit), with the Hunt-Crossley law of that module:

    delta = -g,  ddelta/dt = -grad g . v,
    f = K delta^n (1 + chi ddelta/dt / v_impact) + f_c
                                                   (delta > 0, cut at f >= 0),
    f_c = c ddelta/dt limited to +-K delta^n (a rope's damping),
    Q = f grad g,

with, at a contact with a friction coefficient mu, the regularised Coulomb
force F_t = -mu f tanh(v_t / v_reg) along the contact's tangent (v_t the
slip speed of the two bodies' material points at the contact point, w(q) . v:
:func:`~mbdsl.model.contact.slip`), in generalized form F_t w; and the
exact derivatives for the Newton matrix:

    Q_q = grad g (df/dq)^T + f H_g,   Q_v = grad g (df/dv)^T,
    df/dq = -(K n delta^(n-1) (1 + chi ddelta/dt / v_impact)) grad g
            - (K delta^n chi / v_impact + c) H_g v,
    df/dv = -(K delta^n chi / v_impact + c) grad g

(where c ddelta/dt is beyond +-K delta^n, c leaves them and f_c's
+-K n delta^(n-1) joins the first term)

(zero where the gap is open or the force is cut; c is a rope's linear
damping, 0 for contacts and limits, limited as Modelica's ElastoGap limits
its damping: no jump in f where a rope goes taut at speed). v_impact is the state of
the contact, set by the time loop when the gap closes (``arm``, the event
that lands a step on the closing) and cleared when it opens (``release``).

The contacts' data are the model's (``Contact``), packed for the kernels
by ``kernels/loads/contact.py``, which evaluates the law (``_contact_law``,
``_contacts_add``, ``_emit_contacts``) and the gaps (``_gap``). What a run
changes, the impact speed of each closed gap and the log of the closings
and openings, is a :class:`ContactState`; it evaluates the gaps for the
event locator through the kernels (``AssembledSystem.contact_gaps``, given
by :meth:`ContactState.bind`). ``tests/contact/contact_oracle.py`` is an
independent numpy evaluation the kernels are tested against.
"""

from __future__ import annotations

import numpy as np

from ..model.contact import GAP_WIDTH, SPEED_FLOOR, gap_columns

__all__ = ["ContactState"]


class ContactState:
    """The run state of the contacts and joint limits
    (:class:`~mbdsl.model.contact.Contact`): per one-sided gap, the impact
    speed in force, and the log of the run's closings and openings; with
    where each gap sits, to evaluate it for the event locator. The contacts'
    parameters stay the model's (``contacts``).

    Parameters
    ----------
    cmap : CoordinateMap
        The model's body columns.
    contacts : sequence of Contact
        The model's contacts and limits, in its order (the kernels' gap order).

    Attributes
    ----------
    contacts : list of Contact
    owner : ndarray of intp, shape (k,)
        Per gap, its element in ``contacts``.
    cols : ndarray of intp, shape (k, GAP_WIDTH)
        Per gap, the columns of q_ext it reads (``model.contact.gap_columns``):
        x, y, phi of its first body, then of its second (a spatial gap: their
        twelve each), the rest the ground's n + 2.
    names : list of str
        Per gap, the element's name and the gap's label (``"stop.upper"``).
    impact_speed : ndarray, shape (k,) [m/s or rad/s]
        The approach speed of each closed gap when it closed; 0 while open.
    log : list of (float, int, float)
        (t, gap, speed; 0 for an opening) of every arm and release of the
        run under way.
    """

    def __init__(self, cmap, contacts):
        self.contacts = list(contacts)
        self.names, owner, cols = [], [], []
        for j, c in enumerate(self.contacts):
            for geometry, data, label in c.gaps:
                owner.append(j)
                self.names.append(c.name + ("." + label if label else ""))
                cols.append(gap_columns(geometry, data, cmap))
        self.owner = np.array(owner, dtype=np.intp)
        self.cols = np.array(cols, dtype=np.intp).reshape(-1, GAP_WIDTH)
        self.impact_speed = np.zeros(len(self.names))
        self.log = []
        self._gaps = None

    @property
    def elements(self) -> list:
        """Per gap, its element's name (list of str)."""
        return [self.contacts[j].name for j in self.owner]

    def bind(self, gaps) -> None:
        """Evaluate the gaps through ``gaps``: qx (nx,) -> (g (k,), dg/dq over
        each gap's columns (k, GAP_WIDTH)) (``AssembledSystem.contact_gaps``)."""
        self._gaps = gaps

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

    # -- evaluation (the kernels') --------------------------------------------------------
    def gaps(self, qx) -> np.ndarray:
        """g per gap, shape (k,) [m or rad], from q_ext (nx,)."""
        return self._gaps(qx)[0]

    def gaps_one(self, i, qx) -> float:
        """g of gap i [m or rad]."""
        return float(self._gaps(qx)[0][i])

    def gap_rates(self, qx, vx) -> np.ndarray:
        """dg/dt per gap, shape (k,)."""
        grad = self._gaps(qx)[1]
        return np.einsum("ka,ka->k", grad, vx[self.cols])

    def gap_rate_one(self, i, qx, vx) -> float:
        """dg/dt of gap i."""
        return float(self.gap_rates(qx, vx)[i])

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
        grad = self._gaps(qx)[1][i]
        inv = sum(gj * gj / mass_diag[c] for gj, c in zip(grad, self.cols[i])
                  if c < n_q and mass_diag[c] > 0.0)
        if not inv > 0.0:
            return np.inf
        v = max(float(speed), SPEED_FLOOR)
        contact = self.contacts[self.owner[i]]
        ex = float(contact.exponent)
        delta_max = ((ex + 1.0) * v * v / (2.0 * contact.k * inv)) ** (1.0 / (ex + 1.0))
        return 3.0 * delta_max / v

    def speeds_at(self, t, log):
        """Impact speeds in force at times t (N,), from a run's contact log
        [(t_event, gap index, speed; 0 for an opening)], shape (N, k)."""
        out = np.zeros((len(t), len(self.names)))
        for t_e, i, speed in sorted(log, key=lambda x: x[0]):
            out[np.asarray(t) >= t_e - 1e-15 * max(1.0, abs(t_e)), i] = speed
        return out
