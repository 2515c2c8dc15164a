"""NEWMARK: Newmark's method on the index-3 DAE."""

from __future__ import annotations

import numpy as np

from ..registry import check_coefficient
from .base import Block, Method, StepContext, StepState
from .common import (acceleration_scales, force_term, index3_newton_matrix,
                     newmark_predictor, roundoff_floor)
from .recipe import newmark_recipe
from .spectral import hht_step

__all__ = ["Newmark"]


class Newmark(Method):
    """Newmark's method for the index-3 equations of motion.

    Unknowns w = (a_{n+1}, lambda_{n+1}); formulas

        q_{n+1} = q_n + h v_n + h^2/2 [(1 - 2 beta) a_n + 2 beta a_{n+1}]
        v_{n+1} = v_n + h [(1 - gamma) a_n + gamma a_{n+1}]

    Residual: M a + Phi_q^T lambda - Q = 0 at t_{n+1}, and
    1/(beta h^2) Phi(q_{n+1}, t_{n+1}) = 0. Newton matrix as HHT-I3 with
    alpha = 0: [[M + beta h^2 ((M a)_q + (Phi_q^T lambda)_q - Q_q) - gamma h Q_v,
    Phi_q^T], [Phi_q, 0]].

    Parameters
    ----------
    gamma : float, default 0.6
        >= 1/2; numerical damping grows with gamma - 1/2.
    beta : float, default 0.3025
        >= (gamma + 1/2)^2 / 4 (unconditional stability of the linear
        test problem). The defaults are the paper's: gamma = 0.6,
        beta = (0.6 + 0.5)^2 / 4 = 0.3025.

    Notes
    -----
    Order 1 unless gamma = 1/2 (then 2: with beta = 1/4 the trapezoidal
    rule, which is known to be unstable on the index-3 DAE: without
    numerical damping the multipliers oscillate and grow). Index 3;
    one-step, started from a0 = q''(t_0).

    References
    ----------
    Newmark (1959), J. Eng. Mech. Div. ASCE 85, 67-94.
    Negrut, Jay & Khude; ``methods.md`` sec. 2.
    """

    name = "newmark"
    accepts_augmented = True
    index = 3
    history_length = 1

    def __init__(self, gamma: float = 0.6, beta: float = 0.3025):
        self.gamma = check_coefficient("gamma", gamma)
        self.beta = check_coefficient("beta", beta, gamma=self.gamma)

    def order(self, system=None) -> int:
        """2 when gamma = 1/2, otherwise 1."""
        return 2 if abs(self.gamma - 0.5) < 1e-14 else 1

    amplification = hht_step  # spectral.py: one step on x'' = -omega^2 x

    def parameters(self) -> dict:
        """gamma and beta."""
        return {"gamma": self.gamma, "beta": self.beta}

    def blocks(self, system) -> list[Block]:
        """(a, lam)."""
        return [Block("a", system.n, "kinematic"), Block("lam", system.m, "multiplier")]

    def scales(self, system, h, q) -> np.ndarray:
        """gamma h for a, gamma h times the mobility for lambda."""
        return acceleration_scales(system, q, self.gamma * h)

    def roundoff_floor(self, system, h, q) -> np.ndarray:
        """Phi's round-off through the 1/(beta h^2) rows, times gamma h."""
        return roundoff_floor(system, q, self.gamma / (self.beta * h), system.n, system.m)

    def kernel_recipe(self, h, first):
        """The Newmark formulas; residual M a + F, Phi / (beta h^2)."""
        return newmark_recipe(h, self.beta, self.gamma, cM=1.0, sP=1.0 / (self.beta * h * h),
                              floor=self.gamma / (self.beta * h))

    def start(self, system, initial) -> list[StepState]:
        """One state at t_0 with a_0 = q''(t_0)."""
        return [StepState(initial.t, initial.q, initial.v, initial.a, initial.lam)]

    def context(self, system, history, t, h) -> StepContext:
        """Predictor parts of q and v."""
        ctx = StepContext(system, tuple(history[-1:]), t, h)
        ctx.cache["q_pred"], ctx.cache["v_pred"] = newmark_predictor(history[-1], h, self.beta,
                                                                     self.gamma)
        return ctx

    def _qv(self, a, ctx):
        h = ctx.h
        return ctx.cache["q_pred"] + self.beta * h * h * a, ctx.cache["v_pred"] + self.gamma * h * a

    def predict(self, ctx) -> np.ndarray:
        """w(0) = (a_n, lambda_n)."""
        return np.concatenate([ctx.last.a, ctx.last.lam])

    def residual(self, w, ctx) -> np.ndarray:
        """Upsilon(w), shape (n + m,)."""
        sys, n = ctx.system, ctx.system.n
        a, lam = w[:n], w[n:]
        q, v = self._qv(a, ctx)
        r1 = sys.mass_times(q, a) + force_term(sys, ctx.t, q, v, lam)
        return np.concatenate([r1, sys.Phi(q, ctx.t) / (self.beta * ctx.h ** 2)])

    def jacobian(self, w, ctx) -> np.ndarray:
        """Exact Newton matrix, shape (n + m, n + m)."""
        n, h = ctx.system.n, ctx.h
        a, lam = w[:n], w[n:]
        q, v = self._qv(a, ctx)
        return index3_newton_matrix(ctx, q, v, a, lam, 1.0,
                                    self.beta * h * h, self.gamma * h)

    def accept(self, w, ctx) -> StepState:
        """State at t_{n+1}."""
        n = ctx.system.n
        a, lam = w[:n].copy(), w[n:].copy()
        q, v = self._qv(a, ctx)
        return StepState(ctx.t, q, v, a, lam)
