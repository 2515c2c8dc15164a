"""NSTIFF-SI2: BDF2 on the stabilized index-2 (Gear-Gupta-Leimkuhler) DAE."""

from __future__ import annotations

import numpy as np

from .base import Block, Method, StepContext, StepState
from .common import (Terms, assemble, bdf_coefficients, bdf_error_coefficient,
                     force_term, roundoff_floor)
from .recipe import bdf_recipe
from .spectral import bdf2_step

__all__ = ["NStiffSI2"]


class NStiffSI2(Method):
    """BDF2 on the Gear-Gupta-Leimkuhler stabilized index-2 formulation.

    With D x = c0 (x_{n+1} - xi(x)) (BDF2: c0 = 3/(2h), xi = 4/3 x_n - 1/3 x_{n-1}):

        M(q) D v + Phi_q^T lambda - Q(t, q, v) = 0
        D q - v + Phi_q^T mu                 = 0
        c0 Phi(q, t)                         = 0
        c0 (Phi_q v + Phi_t)                 = 0

    mu would vanish without discretization error; both the position and
    the velocity constraints hold at every step.

    Unknowns: x = D v (acceleration-like), y = D q (velocity-like), lambda,
    mu, so that q = xi(q) + y / c0 and v = xi(v) + x / c0. In these
    unknowns the Newton matrix

        [[M - Q_v/c0,  ((M x)_q + (Phi_q^T lambda)_q - Q_q)/c0,  Phi_q^T, 0      ],
         [-I/c0,       I + (Phi_q^T mu)_q / c0,                  0,       Phi_q^T],
         [0,           Phi_q,                                    0,       0      ],
         [Phi_q,       (Phi_q v)_q + Phi_qt,                     0,       0      ]]

    tends, as h -> 0, to a matrix that is nonsingular for nonsingular M and
    independent constraints: the scaling c0 of the constraint rows keeps it
    well conditioned (choosing q, v themselves as unknowns would not).

    Start-up: the first step (and the first after an event) is BDF1 in the
    same unknowns (c0 = 1/h, xi(x) = x_n); its O(h^2) local error enters
    once, so the order is 2 from the first step. A change of h keeps BDF2,
    with the coefficients of the step ratio.

    Notes
    -----
    Order 2, index 2 with both constraint levels enforced: the velocity
    constraint violation stays at round-off. Unknowns 2n + 2m per step
    (HHT-I3: n + m), hence its higher cost per step.

    References
    ----------
    Gear, Gupta & Leimkuhler (1985), J. Comput. Appl. Math. 12-13, 77-90.
    Negrut, Jay & Khude; ``methods.md`` sec. 4.
    """

    name = "nstiff-si2"
    index = 2
    history_length = 2
    max_step_ratio = 2.0        # BDF2: below 1 + sqrt(2), with a margin
    extras = ("mu",)

    def order(self, system=None) -> int:
        """2."""
        return 2

    amplification = bdf2_step  # spectral.py: one step on x'' = -omega^2 x

    def parameters(self) -> dict:
        """None: BDF2 has no free coefficient."""
        return {}

    def blocks(self, system) -> list[Block]:
        """(Dv, Dq, lam, mu)."""
        n, m = system.n, system.m
        return [Block("Dv", n, "kinematic"), Block("Dq", n, "kinematic"),
                Block("lam", m, "multiplier"), Block("mu", m, "multiplier")]

    def scales(self, system, h, q) -> np.ndarray:
        """2h/3 for Dv, 1 for Dq (a velocity), 2h/3 times the mobility for lambda,
        1 for mu (Dq = v - Phi_q^T mu)."""
        n, m, s = system.n, system.m, 2.0 * h / 3.0
        return np.concatenate([np.full(n, s), np.ones(n), s * system.multiplier_mobility(q),
                               np.ones(m)])

    def roundoff_floor(self, system, h, q) -> np.ndarray:
        """Phi's round-off through the c0 rows (BDF1 start-up: 1/h)."""
        return roundoff_floor(system, q, 1.0 / h, 2 * system.n, 2 * system.m)

    def kernel_recipe(self, h, first):
        """BDF2 (BDF1 when ``first``) in the unknowns of this class."""
        return bdf_recipe(h, first, index2=True)

    def kernel_recipe_at(self, h, first, c0, w0, w1):
        """The recipe with the BDF coefficients c0, w0, w1 (variable steps)."""
        return bdf_recipe(h, first, index2=True, c0=c0, w0=w0, w1=w1)

    def error_coefficient(self, ctx):
        """BDF2's, BDF1's at start-up (``common.bdf_error_coefficient``)."""
        return bdf_error_coefficient(ctx)

    def first_step(self, history, h):
        """BDF1 when no two past states are h apart (``bdf_coefficients``)."""
        return bdf_coefficients(history, h)[2] == 1

    def start(self, system, initial) -> list[StepState]:
        """One state at t_0 (mu_0 = 0); the first step is BDF1."""
        s = StepState(initial.t, initial.q, initial.v, initial.a, initial.lam)
        s.extra["mu"] = np.zeros(system.m)
        return [s]

    def context(self, system, history, t, h) -> StepContext:
        """BDF coefficients and the xi terms."""
        c0, weights, order = bdf_coefficients(history, h)
        ctx = StepContext(system, tuple(history[-2:]), t, h)
        ctx.cache.update(c0=c0, bdf_order=order,
                         xi_q=sum(w * s.q for w, s in weights),
                         xi_v=sum(w * s.v for w, s in weights))
        return ctx

    def _split(self, w, ctx):
        n, m = ctx.system.n, ctx.system.m
        x, y, lam, mu = w[:n], w[n:2 * n], w[2 * n:2 * n + m], w[2 * n + m:]
        c0 = ctx.cache["c0"]
        return x, y, lam, mu, ctx.cache["xi_q"] + y / c0, ctx.cache["xi_v"] + x / c0

    def predict(self, ctx) -> np.ndarray:
        """w(0) = (a_n, v_n, lambda_n, 0)."""
        s = ctx.last
        return np.concatenate([s.a, s.v, s.lam, np.zeros(ctx.system.m)])

    def residual(self, w, ctx) -> np.ndarray:
        """Upsilon(w), shape (2n + 2m,)."""
        sys, t, c0 = ctx.system, ctx.t, ctx.cache["c0"]
        x, y, lam, mu, q, v = self._split(w, ctx)
        r1 = sys.mass_times(q, x) + force_term(sys, t, q, v, lam)
        r2 = y - v + sys.PhiqT_times(q, t, mu)
        r3 = c0 * sys.Phi(q, t)
        r4 = c0 * (sys.Phiq_times(q, t, v) + sys.Phi_t(q, t))
        return np.concatenate([r1, r2, r3, r4])

    def jacobian(self, w, ctx) -> np.ndarray:
        """Exact Newton matrix, shape (2n + 2m, 2n + 2m)."""
        sys, t, c0 = ctx.system, ctx.t, ctx.cache["c0"]
        n, m = sys.n, sys.m
        x, y, lam, mu, q, v = self._split(w, ctx)
        _, Qv = sys.force_derivative_values(t, q, v, lam)
        T = Terms(sys).mass(q).add(sys.pattern_force, Qv, coef=-1.0 / c0)
        T.stiffness(t, q, v, lam, row0=0, col0=n, c_q=1.0 / c0, a=x)   # ((M x)_q + K - Q_q)/c0
        T.Phi_q(q, t, 0, 2 * n, transpose=True).Q_lam(t, q, v, lam, 0, 2 * n, -1.0)
        T.identity(n, 0, -1.0 / c0).identity(n, n)
        T.add(sys.pattern_hessian, sys.PhiqT_lam_q_values(q, mu), n, n, 1.0 / c0)
        T.Phi_q(q, t, n, 2 * n + m, transpose=True)
        T.Phi_q(q, t, 2 * n, n).Phi_q(q, t, 2 * n + m, 0).G(q, v, t, 2 * n + m, n)
        return assemble(ctx, T, 2 * n + 2 * m)

    def accept(self, w, ctx) -> StepState:
        """State at t_{n+1}; a = D v."""
        x, y, lam, mu, q, v = self._split(w, ctx)
        s = StepState(ctx.t, q, v, x.copy(), lam.copy())
        s.extra["mu"] = mu.copy()
        return s
