"""Pure functions the method recipes share (never inheritance, never flags).

* Newmark predictors and updates (NEWMARK, HHT-I3, HHT-SI2, HHT-ADD).
* The index-3 Newton matrix in the unknowns (a, lambda).
* BDF coefficients with their start-up (NSTIFF, NSTIFF-SI2).
* The round-off floor of a constraint-row scaling.
"""

from __future__ import annotations

import numpy as np

from ..assembly.sparse import JacobianAssembler, Term

__all__ = ["newmark_predictor", "force_term", "index3_newton_matrix", "bdf_coefficients", "bdf_ratio_coefficients",
           "bdf_error_coefficient",
           "roundoff_floor", "EPS", "Terms", "assemble", "hht_coefficients",
           "acceleration_scales", "si2_blocks", "si2_scales", "si2_residual",
           "si2_newton_matrix"]

EPS = float(np.finfo(float).eps)


def hht_coefficients(alpha: float) -> tuple[float, float, float]:
    """(alpha, beta, gamma) of the HHT family: alpha validated in [-1/3, 0],
    beta = (1 - alpha)^2 / 4, gamma = (1 - 2 alpha) / 2 (Hilber, Hughes &
    Taylor 1977).

    Raises
    ------
    ValueError
        alpha out of range, with the reason.
    """
    from ..registry import check_coefficient
    alpha = check_coefficient("alpha", alpha)
    return alpha, (1.0 - alpha) ** 2 / 4.0, (1.0 - 2.0 * alpha) / 2.0


def acceleration_scales(system, q, dv_da: float) -> np.ndarray:
    """Velocity-equivalent scales of the unknowns (a, lambda): dv/da for the
    accelerations, dv/da times the multiplier mobility for lambda, shape (n + m,)."""
    return np.concatenate([np.full(system.n, dv_da), dv_da * system.multiplier_mobility(q)])


def newmark_predictor(state, h: float, beta: float, gamma: float):
    """Parts of the Newmark formulas known at t_n.

    q_{n+1} = q_pred + beta h^2 a_{n+1},  v_{n+1} = v_pred + gamma h a_{n+1} with
    q_pred = q_n + h v_n + h^2/2 (1 - 2 beta) a_n and v_pred = v_n + h (1 - gamma) a_n.

    Returns
    -------
    q_pred, v_pred : ndarray, shape (n,)
    """
    q_pred = state.q + h * state.v + 0.5 * h * h * (1.0 - 2.0 * beta) * state.a
    v_pred = state.v + h * (1.0 - gamma) * state.a
    return q_pred, v_pred


def force_term(system, t, q, v, lam) -> np.ndarray:
    """Phi_q^T lambda - Q(t, q, v, lambda), shape (n,): the HHT 'old force'
    term (Q reads lambda only with friction)."""
    return system.PhiqT_times(q, t, lam) - system.Q(t, q, v, lam)


def start_force_term(system, initial) -> np.ndarray:
    """force_term at t_0 with the forces the start was solved with
    (``InitialState.Q``: friction's Coulomb limit at rest), shape (n,)."""
    if getattr(initial, "Q", None) is None:
        return force_term(system, initial.t, initial.q, initial.v, initial.lam)
    return system.PhiqT_times(initial.q, initial.t, initial.lam) - initial.Q


class Terms:
    """Builder of a Newton matrix's term list from the system's fixed patterns.

    Each method names the blocks of its matrix; the patterns come from the
    system, the values are computed here, and :func:`assemble` sums them
    (dense or sparse, see ``assembly/sparse.py``).
    """

    def __init__(self, system):
        self.system, self.items = system, []
        self._values = {}      # one Newton matrix, one configuration: evaluate each term once

    def _once(self, key, fn):
        if key not in self._values:
            self._values[key] = fn()
        return self._values[key]

    def add(self, pattern, vals, row0=0, col0=0, coef=1.0, transpose=False):
        """Append coef * vals on pattern at block (row0, col0); None vals are skipped."""
        if vals is not None and coef != 0.0:
            self.items.append(Term(pattern[0], pattern[1], vals, row0, col0, coef, transpose))
        return self

    def dense(self, block, row0=0, col0=0, coef=1.0):
        """coef * a dense block (every entry on the pattern, so the pattern
        stays fixed for the run's assembler)."""
        r, c = block.shape
        rows = np.repeat(np.arange(r), c)
        cols = np.tile(np.arange(c), r)
        return self.add((rows, cols), np.asarray(block).ravel(), row0, col0, coef)

    def mass(self, q, row0=0, col0=0, coef=1.0):
        """coef M(q)."""
        s = self.system
        self.add(s.pattern_mass, s.mass_values(q), row0, col0, coef)
        return self

    def identity(self, row0=0, col0=0, coef=1.0):
        """coef I (n x n)."""
        s = self.system
        return self.add(s.pattern_diagonal, np.ones(s.n), row0, col0, coef)

    def stiffness(self, t, q, v, lam, row0=0, col0=0, c_q=1.0, c_v=0.0, a=None, c_mass=1.0):
        """c_q (c_mass (M a)_q + (Phi_q^T lam)_q - Q_q) - c_v Q_v.

        The (M a)_q term (``a`` the vector M multiplies in the residual) is
        only there with flexible beams; for rigid bodies M is constant and
        ``Ma_q_values`` is None.
        """
        s = self.system
        if a is not None and not s.mass_is_constant:
            self.add(s.pattern_mass, s.Ma_q_values(q, a), row0, col0, c_q * c_mass)
        self.add(s.pattern_hessian,
                 self._once(("hessian", id(lam)), lambda: s.PhiqT_lam_q_values(q, lam)),
                 row0, col0, c_q)
        Qq, Qv = self._once("force", lambda: s.force_derivative_values(t, q, v, lam))
        self.add(s.pattern_force, Qq, row0, col0, -c_q)
        if c_v:
            self.add(s.pattern_force, Qv, row0, col0, -c_v)
        return self

    def Q_lam(self, t, q, v, lam, row0=0, col0=0, coef=1.0, inv_mass=False):
        """coef dQ/dlambda (or M^{-1} dQ/dlambda), n x m: friction's normal
        loads are reactions, so wherever Phi_q^T lambda - Q stands the lambda
        columns hold Phi_q^T - Q_lambda. Nothing without friction."""
        s = self.system
        if s.pattern_force_lam is None:
            return self
        vals = s.Q_lam_values(t, q, v, lam)
        if inv_mass:
            vals = vals / s.mass_diag[s.pattern_force_lam[0]]
        return self.add(s.pattern_force_lam, vals, row0, col0, coef)

    def Phi_q(self, q, t, row0=0, col0=0, coef=1.0, transpose=False, inv_mass=False):
        """coef Phi_q (or its transpose, or M^{-1} Phi_q^T)."""
        s = self.system
        vals = self._once("Phi_q", lambda: s.Phi_q_values(q, t))
        if inv_mass:
            vals = vals / s.mass_diag[s.pattern_Phi_q[1]]
        return self.add(s.pattern_Phi_q, vals, row0, col0, coef, transpose)

    def G(self, q, v, t, row0=0, col0=0, coef=1.0):
        """coef ((Phi_q v)_q + Phi_qt); Phi_qt = 0 for every constraint mbdsl has."""
        s = self.system
        return self.add(s.pattern_Phiq_v_q, self._once("G", lambda: s.Phiq_v_q_values(q, v)),
                        row0, col0, coef)


def assemble(ctx, terms: Terms, size: int):
    """The Newton matrix from a term list, with the run's assembler (dense or sparse)."""
    assembler = ctx.assembler
    if assembler is None or assembler.size != size:
        assembler = ctx.assembler = JacobianAssembler(size, sparse=False)
    return assembler.assemble(terms.items)


def index3_newton_matrix(ctx, q, v, a, lam, c_mass: float, c_q: float, c_v: float):
    """Newton matrix of the index-3 methods in the unknowns (a, lambda).

        [[c_mass M + c_q (c_mass (M a)_q + (Phi_q^T lambda)_q - Q_q) - c_v Q_v,
          Phi_q^T - Q_lambda],
         [Phi_q,                                                              0      ]]

    with c_q = dq/da and c_v = dv/da of the method's integration formulas
    (constraint rows already divided by c_q). In the augmented formulation
    (``ctx.regularization`` = epsilon > 0) the multiplier block is
    -epsilon I (``Method.formulated``).

    Returns
    -------
    ndarray or scipy.sparse matrix, shape (n + m, n + m)
    """
    system, t, n = ctx.system, ctx.t, ctx.system.n
    T = Terms(system).mass(q, coef=c_mass)
    T.stiffness(t, q, v, lam, c_q=c_q, c_v=c_v, a=a, c_mass=c_mass)
    T.Phi_q(q, t, 0, n, transpose=True).Q_lam(t, q, v, lam, 0, n, -1.0).Phi_q(q, t, n, 0)
    if ctx.regularization:
        m = system.m
        T.add((np.arange(m), np.arange(m)), np.full(m, -ctx.regularization), n, n)
    return assemble(ctx, T, n + system.m)


def bdf_ratio_coefficients(h: float, spacing: float) -> tuple[float, float, float]:
    """(c0, w0, w1) of BDF2 with unequal steps: D x_{n+1} = c0 (x_{n+1} -
    w0 x_n - w1 x_{n-1}) for a step h after one of length ``spacing`` [s],
    w = h / spacing (Hairer & Wanner, Solving ODEs II, sec. III.5):
    c0 = (1 + 2w) / ((1 + w) h), w0 = (1 + w)^2 / (1 + 2w), w1 = -w^2 / (1 + 2w);
    the fixed-step 3/(2h), 4/3, -1/3 at w = 1."""
    w = h / spacing
    return (1.0 + 2.0 * w) / ((1.0 + w) * h), (1.0 + w) ** 2 / (1.0 + 2.0 * w), \
        -w * w / (1.0 + 2.0 * w)


def bdf_coefficients(history, h: float):
    """BDF derivative D x_{n+1} = c0 (x_{n+1} - xi(x)) for the given history.

    BDF2 when two past states are available: c0 = 3/(2h), xi = 4/3 x_n -
    1/3 x_{n-1} when they are h apart, else the coefficients of the step
    ratio (``bdf_ratio_coefficients``: error-controlled steps, a halved or
    regrown step, the last step shortened to land on t_end). Otherwise
    BDF1 (c0 = 1/h, xi = x_n), the start-up step (also after an event,
    where the driver drops the history): its local error O(h^2) enters the
    global error once, so the order stays 2. NSTIFF takes that step's q by
    the trapezoidal rule instead (``nstiff.py``): an index-3 step with q by
    BDF1 leaves its velocities O(h) off the constraints' tangent.

    Returns
    -------
    c0 : float [1/s]
    weights : tuple of (float, StepState)
        xi(x) = sum(w * x_state).
    order : int
        1 for the start-up step, 2 otherwise.
    """
    last = history[-1]
    if len(history) >= 2:
        spacing = last.t - history[-2].t
        if abs(spacing - h) <= 1e-9 * h:
            return 1.5 / h, ((4.0 / 3.0, last), (-1.0 / 3.0, history[-2])), 2
        if spacing > 0.0:
            c0, w0, w1 = bdf_ratio_coefficients(h, spacing)
            return c0, ((w0, last), (w1, history[-2])), 2
    return 1.0 / h, ((1.0, last),), 1


def bdf_error_coefficient(ctx) -> tuple[float, bool]:
    """(c [s^2], absolute) of a BDF step's local position error estimate
    (``Method.error_coefficient``, ``adaptive``): BDF2's error constant 2/9
    times h^2, with a_{n+1} - a_n standing for h times the third derivative
    of q (Hairer & Wanner II, sec. III.2); a BDF1 start-up step
    (``ctx.cache["bdf_order"]`` 1): h^2 / 2 times a_{n+1}, its own leading
    term (NSTIFF's start-up too, whose own error is smaller: ``nstiff.py``)."""
    if ctx.cache["bdf_order"] == 1:
        return 0.5 * ctx.h ** 2, True
    return (2.0 / 9.0) * ctx.h ** 2, False


def roundoff_floor(system, q: np.ndarray, velocity_per_metre: float, n_kinematic: int,
                   n_multiplier: int) -> np.ndarray:
    """Velocity-equivalent change [m/s] the round-off of Phi causes, per unknown.

    32 eps (1 + |q|_max) times the velocity change one metre of constraint
    residual causes through the method's row scaling (measured noise on the
    slider crank, HHT-I3, h = 1e-6: 1.5e-9 m/s; this floor: 8e-9 m/s). The
    floor only raises a tolerance that round-off would make unreachable;
    raising it further would leave a systematic error in every step (seen on
    Andrews' mechanism: an error floor of 4e-5 rad at h = 1.25e-6). The
    multipliers' own round-off floor, which geometry amplifies, is handled by
    the Newton engine's stall rule instead (``newton.py``).

    Returns
    -------
    ndarray, shape (n_kinematic + n_multiplier,)
    """
    qmax = float(np.max(np.abs(q), initial=0.0))
    f = 32.0 * EPS * (1.0 + qmax) * velocity_per_metre
    return np.full(n_kinematic + n_multiplier, f)


def si2_blocks(system):
    """The unknowns (a, abar, lambda, mu) of the stabilized index-2
    Newmark-type methods (HHT-SI2, GENALPHA-SI2)."""
    from .base import Block
    n, m = system.n, system.m
    return [Block("a", n, "kinematic"), Block("abar", n, "kinematic"),
            Block("lam", m, "multiplier"), Block("mu", m, "multiplier")]


def si2_scales(system, q, dv_da: float, h: float) -> np.ndarray:
    """Velocity-equivalent scales of (a, abar, lambda, mu): dv/da for a, h/2
    for abar (dq/h), the same times the multiplier mobility for lambda and
    mu; shape (2n + 2m,)."""
    n, hh = system.n, 0.5 * h
    mob = system.multiplier_mobility(q)
    return np.concatenate([np.full(n, dv_da), np.full(n, hh), dv_da * mob, hh * mob])


def si2_residual(ctx, q, v, x, abar, lam, mu, c_mass: float, old_force=None) -> np.ndarray:
    """Residual of the stabilized index-2 Newmark-type methods (HHT-SI2,
    GENALPHA-SI2), shape (2n + 2m,):

        c_mass Mhat x + (Phi_q^T lambda - Q)_{n+1} [- old_force]
        Mhat abar + Phi_q^T(q_{n+1}) mu
        1/h^2 Phi(q_{n+1}, t_{n+1})
        1/h (Phi_q v + Phi_t)_{n+1}

    Mhat = M(ctx.cache["qhat"]) held for the step; ``old_force`` the
    method's term at t_n (HHT: alpha/(1+alpha) F_n), or None.
    """
    sys, t, h = ctx.system, ctx.t, ctx.h
    qhat = ctx.cache["qhat"]
    r1 = c_mass * sys.mass_times(qhat, x) + force_term(sys, t, q, v, lam)
    if old_force is not None:
        r1 = r1 - old_force
    r2 = sys.mass_times(qhat, abar) + sys.PhiqT_times(q, t, mu)
    r3 = sys.Phi(q, t) / (h * h)
    r4 = (sys.Phiq_times(q, t, v) + sys.Phi_t(q, t)) / h
    return np.concatenate([r1, r2, r3, r4])


def si2_newton_matrix(ctx, q, v, lam, mu, c_mass: float, beta: float, gamma: float):
    """Exact Newton matrix of :func:`si2_residual` in (x, abar, lambda, mu), with
    q = q_pred + beta h^2 x + h^2/2 abar and v = v_pred + gamma h x (HHT-SI2:
    beta, gamma; GENALPHA-SI2: beta', gamma'):

        [[c Mhat + beta h^2 K - gamma h Q_v, h^2/2 K,                   Phi_q^T, 0      ],
         [beta h^2 (Phi_q^T mu)_q,           Mhat + h^2/2 (Phi_q^T mu)_q, 0,       Phi_q^T],
         [beta Phi_q,                        Phi_q / 2,                 0,       0      ],
         [gamma Phi_q + beta h G,            h/2 G,                     0,       0      ]]

    K = (Phi_q^T lambda)_q - Q_q, G = (Phi_q v)_q + Phi_qt; Mhat is held, so
    no (M a)_q term. Shape (2n + 2m, 2n + 2m).
    """
    sys, t, h = ctx.system, ctx.t, ctx.h
    n, m = sys.n, sys.m
    qhat = ctx.cache["qhat"]
    bh2, hh2, gh = beta * h * h, 0.5 * h * h, gamma * h
    Kmu = sys.PhiqT_lam_q_values(q, mu)
    T = Terms(sys).mass(qhat, coef=c_mass)
    T.stiffness(t, q, v, lam, row0=0, col0=0, c_q=bh2, c_v=gh)
    T.stiffness(t, q, v, lam, row0=0, col0=n, c_q=hh2)
    T.Phi_q(q, t, 0, 2 * n, transpose=True).Q_lam(t, q, v, lam, 0, 2 * n, -1.0)
    T.add(sys.pattern_hessian, Kmu, n, 0, bh2)
    T.mass(qhat, n, n).add(sys.pattern_hessian, Kmu, n, n, hh2)
    T.Phi_q(q, t, n, 2 * n + m, transpose=True)
    T.Phi_q(q, t, 2 * n, 0, beta).Phi_q(q, t, 2 * n, n, 0.5)
    T.Phi_q(q, t, 2 * n + m, 0, gamma).G(q, v, t, 2 * n + m, 0, beta * h)
    T.G(q, v, t, 2 * n + m, n, 0.5 * h)
    return assemble(ctx, T, 2 * n + 2 * m)
