"""HHT-I3: the Hilber-Hughes-Taylor method on the index-3 DAE."""

from __future__ import annotations

import numpy as np

from .base import Block, Method, StepContext, StepState
from .common import (acceleration_scales, force_term, hht_coefficients,
                     index3_newton_matrix, newmark_predictor, roundoff_floor, start_force_term)
from .recipe import newmark_recipe
from .spectral import hht_step

__all__ = ["HHTI3"]


class HHTI3(Method):
    """Hilber-Hughes-Taylor method for the index-3 equations of motion.

    Unknowns w = (a_{n+1}, lambda_{n+1}); Newmark formulas

        q_{n+1} = q_n + h v_n + h^2/2 [(1 - 2 beta) a_n + 2 beta a_{n+1}]
        v_{n+1} = v_n + h [(1 - gamma) a_n + gamma a_{n+1}]

    Residual (equations of motion divided by 1 + alpha, constraints scaled
    by 1/(beta h^2) so that the Newton matrix stays well conditioned as
    h -> 0):

        1/(1+alpha) (M a)_{n+1} + (Phi_q^T lambda - Q)_{n+1}
                    - alpha/(1+alpha) (Phi_q^T lambda - Q)_n = 0
        1/(beta h^2) Phi(q_{n+1}, t_{n+1}) = 0

    Newton matrix (exact, from dq/da = beta h^2, dv/da = gamma h):

        [[M/(1+alpha) + beta h^2 ((M a)_q/(1+alpha) + (Phi_q^T lambda)_q - Q_q)
          - gamma h Q_v,  Phi_q^T],
         [Phi_q,          0      ]]

    Parameters
    ----------
    alpha : float, default -0.05
        In [-1/3, 0]. 0 is the trapezoidal rule (no numerical damping);
        -1/3 damps high frequencies most. The default is the paper's
        small-damping setting: close to energy-conserving on resolved
        motion, while still damping unresolved stiff modes.

    Notes
    -----
    Derived coefficients: gamma = (1 - 2 alpha)/2, beta = (1 - alpha)^2/4.
    Order 2 in q and v for every alpha in range; index 3 (velocity
    constraints hold only to O(h^2)); one-step, so a0 = q''(t_0) from the
    index-1 system starts it and the step size may change between steps.
    The multipliers start with a transient of size O(h) that the numerical
    damping removes (faster for more negative alpha). Cost per iteration:
    one residual, and one factorization of an (n + m) matrix when the
    Jacobian is refreshed.

    References
    ----------
    Hilber, Hughes & Taylor (1977), Earthquake Eng. Struct. Dyn. 5, 283-292.
    Negrut, Rampalli, Ottarsson & Sajdak (2007), J. Comput. Nonlinear Dyn. 2, 73-85.
    Negrut, Jay & Khude, "A Discussion of Low Order Numerical Integration
    Formulas for Rigid and Flexible Multibody Dynamics"; ``methods.md`` sec. 3.
    """

    name = "hht-i3"
    accepts_augmented = True
    index = 3
    history_length = 1

    def __init__(self, alpha: float = -0.05):
        self.alpha, self.beta, self.gamma = hht_coefficients(alpha)

    def order(self, system=None) -> int:
        """2. On flexible beams with alpha != 0 the residual's M(q_{n+1})
        a_{n+1}, with a_{n+1} standing for the acceleration at
        t_n + (1 + alpha) h, is O(alpha h) off and the order falls to 1 as
        h -> 0; at the step sizes of the paper's flexible slider crank the
        fitted order is 2.01 (docs/methods.md, "Order on flexible models"),
        so a study expects 2."""
        return 2

    amplification = hht_step  # spectral.py: one step on x'' = -omega^2 x

    def parameters(self) -> dict:
        """alpha, and the derived beta and gamma."""
        return {"alpha": self.alpha, "beta": self.beta, "gamma": self.gamma}

    def blocks(self, system) -> list[Block]:
        """(a, lam)."""
        return [Block("a", system.n, "kinematic"), Block("lam", system.m, "multiplier")]

    def scales(self, system, h, q) -> np.ndarray:
        """gamma h for a (dv = gamma h da), gamma h times the mobility for lambda."""
        return acceleration_scales(system, q, self.gamma * h)

    def roundoff_floor(self, system, h, q) -> np.ndarray:
        """Phi's round-off through the 1/(beta h^2) rows, times gamma h."""
        return roundoff_floor(system, q, self.gamma / (self.beta * h), system.n, system.m)

    def kernel_recipe(self, h, first):
        """The Newmark formulas; residual M a/(1+alpha) + F - alpha/(1+alpha) F_n,
        Phi / (beta h^2)."""
        c = 1.0 / (1.0 + self.alpha)
        return newmark_recipe(h, self.beta, self.gamma, cM=c, cF=self.alpha * c,
                              sP=1.0 / (self.beta * h * h), floor=self.gamma / (self.beta * h))

    def start(self, system, initial) -> list[StepState]:
        """One state at t_0 with a_0 = q''(t_0) and lambda_0 from the index-1 system."""
        s = StepState(initial.t, initial.q, initial.v, initial.a, initial.lam)
        s.extra["F"] = start_force_term(system, initial)
        return [s]

    def context(self, system, history, t, h) -> StepContext:
        """Predictor parts of q and v, and the old force term."""
        ctx = StepContext(system, tuple(history[-1:]), t, h)
        ctx.cache["q_pred"], ctx.cache["v_pred"] = newmark_predictor(history[-1], h, self.beta,
                                                                     self.gamma)
        return ctx

    def _qv(self, a, ctx):
        h = ctx.h
        return ctx.cache["q_pred"] + self.beta * h * h * a, ctx.cache["v_pred"] + self.gamma * h * a

    def predict(self, ctx) -> np.ndarray:
        """w(0) = (a_n, lambda_n)."""
        s = ctx.last
        return np.concatenate([s.a, s.lam])

    def residual(self, w, ctx) -> np.ndarray:
        """Upsilon(w), shape (n + m,)."""
        sys, n = ctx.system, ctx.system.n
        a, lam = w[:n], w[n:]
        q, v = self._qv(a, ctx)
        c = 1.0 / (1.0 + self.alpha)
        r1 = (c * (sys.mass_times(q, a)) + force_term(sys, ctx.t, q, v, lam)
              - self.alpha * c * ctx.last.extra["F"])
        r2 = sys.Phi(q, ctx.t) / (self.beta * ctx.h ** 2)
        return np.concatenate([r1, r2])

    def jacobian(self, w, ctx) -> np.ndarray:
        """Exact Newton matrix, shape (n + m, n + m)."""
        n, h = ctx.system.n, ctx.h
        a, lam = w[:n], w[n:]
        q, v = self._qv(a, ctx)
        return index3_newton_matrix(ctx, q, v, a, lam, 1.0 / (1.0 + self.alpha),
                                    self.beta * h * h, self.gamma * h)

    def accept(self, w, ctx) -> StepState:
        """State at t_{n+1}, with its force term cached for the next step."""
        n = ctx.system.n
        a, lam = w[:n].copy(), w[n:].copy()
        q, v = self._qv(a, ctx)
        s = StepState(ctx.t, q, v, a, lam)
        s.extra["F"] = force_term(ctx.system, s.t, q, v, lam)
        return s
