"""HHT-SI2: HHT on the stabilized index-2 DAE (new in Negrut, Jay & Khude)."""

from __future__ import annotations

import numpy as np

from .base import Block, Method, StepContext, StepState
from .common import (force_term, hht_coefficients, newmark_predictor, roundoff_floor,
                     si2_blocks, si2_newton_matrix, si2_residual, si2_scales,
                     start_force_term)
from .recipe import newmark_recipe
from .spectral import hht_step

__all__ = ["HHTSI2"]


class HHTSI2(Method):
    """Hilber-Hughes-Taylor on the stabilized index-2 formulation.

        q_{n+1} = q_n + h v_n + h^2/2 [(1 - 2 beta) a_n + 2 beta a_{n+1}] + h^2/2 abar
        v_{n+1} = v_n + h [(1 - gamma) a_n + gamma a_{n+1}]

    Unknowns a_{n+1}, abar, lambda_{n+1}, mu (abar and mu live within one step):

        1/(1+alpha) Mhat a + (Phi_q^T lambda - Q)_{n+1} - alpha/(1+alpha) (Phi_q^T lambda - Q)_n = 0
        Mhat abar + Phi_q^T(q_{n+1}) mu                                = 0
        1/h^2 Phi(q_{n+1}, t_{n+1})                                    = 0
        1/h (Phi_q(q_{n+1}) v_{n+1} + Phi_t)                           = 0

    Mhat := M(q_n + h (1 + alpha) v_n) is evaluated once per step at the
    predicted mid-step configuration and held constant (what makes HHT-SI2
    cheaper than NSTIFF-SI2 for large or flexible models).

    Newton matrix (exact, with dq/da = beta h^2, dq/dabar = h^2/2, dv/da = gamma h):

        [[Mhat/(1+alpha) + beta h^2 K - gamma h Q_v, h^2/2 K,                  Phi_q^T, 0      ],
         [beta h^2 (Phi_q^T mu)_q,             Mhat + h^2/2 (Phi_q^T mu)_q, 0,       Phi_q^T],
         [beta Phi_q,                          Phi_q / 2,                   0,       0      ],
         [gamma Phi_q + beta h G,              h/2 G,                       0,       0      ]]

    with K = (Phi_q^T lambda)_q - Q_q and G = (Phi_q v)_q + Phi_qt; as h -> 0
    it tends to the nonsingular matrix of ``methods.md`` sec. 6.

    Parameters
    ----------
    alpha : float, default -0.05
        In [-1/3, 0]; beta = (1 - alpha)^2/4, gamma = (1 - 2 alpha)/2.

    Notes
    -----
    Order 2; index 2 with both constraint levels enforced (velocity
    constraint violation at round-off). One-step; a_0 = q''(t_0), mu_0 = 0.

    References
    ----------
    Negrut, Jay & Khude; ``methods.md`` sec. 6.
    """

    name = "hht-si2"
    index = 2
    history_length = 1
    extras = ("mu",)

    def __init__(self, alpha: float = -0.05):
        self.alpha, self.beta, self.gamma = hht_coefficients(alpha)

    def order(self, system=None) -> int:
        """2."""
        return 2

    amplification = hht_step  # spectral.py: one step on x'' = -omega^2 x

    def parameters(self) -> dict:
        """alpha, and the derived beta and gamma."""
        return {"alpha": self.alpha, "beta": self.beta, "gamma": self.gamma}

    def blocks(self, system) -> list[Block]:
        """(a, abar, lam, mu) (``common.si2_blocks``)."""
        return si2_blocks(system)

    def scales(self, system, h, q) -> np.ndarray:
        """gamma h for a, h/2 for abar, the same times the mobility for
        lambda, mu (``common.si2_scales``)."""
        return si2_scales(system, q, self.gamma * h, h)

    def roundoff_floor(self, system, h, q) -> np.ndarray:
        """Phi's round-off through the 1/h^2 rows, times h/2."""
        return roundoff_floor(system, q, 1.0 / h, 2 * system.n, 2 * system.m)

    def kernel_recipe(self, h, first):
        """The Newmark formulas plus h^2/2 abar in q; residual as in the class
        docstring, Mhat = M(q_n + (1 + alpha) h v_n) (``mh``). The band LU may
        split it: the coupling it leaves out is h^2/2 K and h/2 d(Phi_q v)/dq."""
        c = 1.0 / (1.0 + self.alpha)
        return newmark_recipe(h, self.beta, self.gamma, has_y=1.0, split=1.0, cqy=0.5 * h * h,
                              cM=c, cF=self.alpha * c, dM=1.0, sP=1.0 / (h * h), sV=1.0 / h,
                              sy=0.5 * h, mu_mob=1.0, floor=1.0 / h,
                              mh=(1.0 + self.alpha) * h)

    def start(self, system, initial) -> list[StepState]:
        """One state at t_0: a_0 = q''(t_0), mu_0 = 0, the old force term cached."""
        s = StepState(initial.t, initial.q, initial.v, initial.a, initial.lam)
        s.extra["mu"] = np.zeros(system.m)
        s.extra["F"] = start_force_term(system, initial)
        return [s]

    def context(self, system, history, t, h) -> StepContext:
        """Predictors and Mhat = M(q_n + h (1 + alpha) v_n), once per step."""
        s = history[-1]
        ctx = StepContext(system, (s,), t, h)
        ctx.cache["q_pred"], ctx.cache["v_pred"] = newmark_predictor(s, h, self.beta, self.gamma)
        ctx.cache["qhat"] = s.q + h * (1.0 + self.alpha) * s.v    # Mhat = M(qhat)
        return ctx

    def _split(self, w, ctx):
        n, m, h = ctx.system.n, ctx.system.m, ctx.h
        a, abar, lam, mu = w[:n], w[n:2 * n], w[2 * n:2 * n + m], w[2 * n + m:]
        q = ctx.cache["q_pred"] + self.beta * h * h * a + 0.5 * h * h * abar
        v = ctx.cache["v_pred"] + self.gamma * h * a
        return a, abar, lam, mu, q, v

    def predict(self, ctx) -> np.ndarray:
        """w(0) = (a_n, 0, lambda_n, 0)."""
        s, n, m = ctx.last, ctx.system.n, ctx.system.m
        return np.concatenate([s.a, np.zeros(n), s.lam, np.zeros(m)])

    def residual(self, w, ctx) -> np.ndarray:
        """Upsilon(w), shape (2n + 2m,) (``common.si2_residual``)."""
        a, abar, lam, mu, q, v = self._split(w, ctx)
        c = 1.0 / (1.0 + self.alpha)
        return si2_residual(ctx, q, v, a, abar, lam, mu, c, self.alpha * c * ctx.last.extra["F"])

    def jacobian(self, w, ctx) -> np.ndarray:
        """Exact Newton matrix, shape (2n + 2m, 2n + 2m) (``common.si2_newton_matrix``)."""
        a, abar, lam, mu, q, v = self._split(w, ctx)
        return si2_newton_matrix(ctx, q, v, lam, mu, 1.0 / (1.0 + self.alpha), self.beta,
                                 self.gamma)

    def accept(self, w, ctx) -> StepState:
        """State at t_{n+1}, with mu and the force term for the next step."""
        a, abar, lam, mu, q, v = self._split(w, ctx)
        s = StepState(ctx.t, q, v, a.copy(), lam.copy())
        s.extra["mu"] = mu.copy()
        s.extra["F"] = force_term(ctx.system, s.t, q, v, s.lam)
        return s
