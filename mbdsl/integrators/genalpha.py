"""Generalized-alpha on the index-3 DAE (GENALPHA) and on the stabilized index-2 DAE (GENALPHA-SI2).

Beyond the paper's six: Chung & Hulbert's generalized-alpha in the form
Arnold & Bruls (2007) gave it for constrained mechanical systems. HHT is
its member alpha_m = 0 with averaged forces instead of averaged
accelerations; at the same spectral radius at infinity rho_inf the
generalized-alpha choice of alpha_m has the smaller error constant on the
resolved motion (Chung & Hulbert 1993, sec. 4). GENALPHA-SI2 adds the
velocity constraints exactly as HHT-SI2 adds them to HHT-I3 (``docs/methods.md``).
"""

from __future__ import annotations

import numpy as np

from ..registry import check_coefficient
from .base import Block, Method, StepContext, StepState
from .common import (acceleration_scales, index3_newton_matrix, roundoff_floor,
                     si2_blocks, si2_newton_matrix, si2_residual, si2_scales)
from .recipe import genalpha_recipe
from .spectral import genalpha_step

__all__ = ["GenAlpha", "GenAlphaSI2", "genalpha_coefficients"]


def genalpha_coefficients(rho_inf: float) -> tuple[float, float, float, float, float]:
    """(rho_inf, alpha_m, alpha_f, beta, gamma) of Chung & Hulbert's optimal set.

        alpha_m = (2 rho_inf - 1)/(rho_inf + 1),  alpha_f = rho_inf/(rho_inf + 1),
        gamma = 1/2 + alpha_f - alpha_m,          beta = (gamma + 1/2)^2 / 4

    (Chung & Hulbert 1993, eqs. 25-27, with their alpha_f taken as the weight
    of the old value, as in Arnold & Bruls 2007.) rho_inf = 1 keeps every
    frequency (no numerical damping); rho_inf = 0 annihilates the unresolved
    ones in one step.

    Raises
    ------
    ValueError
        rho_inf outside [0, 1], with the reason.
    """
    rho = check_coefficient("rho_inf", rho_inf)
    alpha_m = (2.0 * rho - 1.0) / (rho + 1.0)
    alpha_f = rho / (rho + 1.0)
    gamma = 0.5 + alpha_f - alpha_m
    beta = 0.25 * (gamma + 0.5) ** 2
    return rho, alpha_m, alpha_f, beta, gamma


class _GenAlphaBase(Method):
    """What both generalized-alpha forms share: coefficients, the carried
    auxiliary acceleration and its update."""

    history_length = 1

    def __init__(self, rho_inf: float = 0.9):
        (self.rho_inf, self.alpha_m, self.alpha_f, self.beta,
         self.gamma) = genalpha_coefficients(rho_inf)
        d = 1.0 / (1.0 - self.alpha_m)
        #: dq_{n+1}/dqdd_{n+1} / h^2 and dv_{n+1}/dqdd_{n+1} / h
        self.beta_p = self.beta * (1.0 - self.alpha_f) * d
        self.gamma_p = self.gamma * (1.0 - self.alpha_f) * d

    def order(self, system=None) -> int:
        """2."""
        return 2

    amplification = genalpha_step  # spectral.py: one step on x'' = -omega^2 x

    def parameters(self) -> dict:
        """rho_inf, and the derived alpha_m, alpha_f, beta and gamma."""
        return {"rho_inf": self.rho_inf, "alpha_m": self.alpha_m, "alpha_f": self.alpha_f,
                "beta": self.beta, "gamma": self.gamma}

    def _state0(self, system, initial) -> StepState:
        """qdd_0 and lambda_0 from the index-1 system; aux_0 = qdd_0 at a start,
        the carried value when resuming (``InitialState.method_state``)."""
        s = StepState(initial.t, initial.q, initial.v, initial.a, initial.lam)
        aux = initial.method_state.get("aux")
        s.extra["aux"] = np.array(initial.a if aux is None else aux, dtype=float)
        return s

    def _predictor(self, s: StepState, h: float):
        """q_pred, v_pred: the parts of q_{n+1}, v_{n+1} known at t_n
        (``recipe.genalpha_recipe``)."""
        d = 1.0 / (1.0 - self.alpha_m)
        b, g, am, af = self.beta, self.gamma, self.alpha_m, self.alpha_f
        aux = s.extra["aux"]
        q_pred = s.q + h * s.v + h * h * (b * af * d * s.a + (0.5 - b - b * am * d) * aux)
        v_pred = s.v + h * (g * af * d * s.a + (1.0 - g - g * am * d) * aux)
        return q_pred, v_pred

    def _advance(self, s: StepState, qdd: np.ndarray) -> np.ndarray:
        """aux_{n+1} from (1 - alpha_m) aux_{n+1} + alpha_m aux_n
        = (1 - alpha_f) qdd_{n+1} + alpha_f qdd_n."""
        return ((1.0 - self.alpha_f) * qdd + self.alpha_f * s.a
                - self.alpha_m * s.extra["aux"]) / (1.0 - self.alpha_m)

    def local_error(self, ctx, new):
        """(beta - 1/6) h^2 (a_{n+1} - a_n) on the auxiliary acceleration a, the
        one the Newmark formulas of generalized-alpha integrate (Zienkiewicz &
        Xie 1991; ``adaptive``)."""
        return (self.beta - 1.0 / 6.0) * ctx.h ** 2 * (new.extra["aux"] - ctx.last.extra["aux"])


class GenAlpha(_GenAlphaBase):
    """Generalized-alpha for the index-3 equations of motion (Arnold & Bruls 2007).

    Unknowns w = (qdd_{n+1}, lambda_{n+1}), the true acceleration and the
    multipliers at t_{n+1}; the auxiliary acceleration a_n is carried:

        (1 - alpha_m) a_{n+1} + alpha_m a_n = (1 - alpha_f) qdd_{n+1} + alpha_f qdd_n
        q_{n+1} = q_n + h v_n + h^2 (1/2 - beta) a_n + h^2 beta a_{n+1}
        v_{n+1} = v_n + h (1 - gamma) a_n + h gamma a_{n+1}

    Residual (the equations of motion at t_{n+1}, unshifted; constraints
    scaled by 1/(beta' h^2) as HHT-I3 scales them by 1/(beta h^2)):

        M(q_{n+1}) qdd_{n+1} + Phi_q^T lambda_{n+1} - Q(t_{n+1}, q_{n+1}, v_{n+1}) = 0
        1/(beta' h^2) Phi(q_{n+1}, t_{n+1}) = 0

    with beta' = beta (1 - alpha_f)/(1 - alpha_m) = dq_{n+1}/dqdd_{n+1} / h^2
    and gamma' = gamma (1 - alpha_f)/(1 - alpha_m) = dv_{n+1}/dqdd_{n+1} / h.
    Newton matrix (exact):

        [[M + beta' h^2 ((M qdd)_q + (Phi_q^T lambda)_q - Q_q) - gamma' h Q_v,  Phi_q^T],
         [Phi_q,                                                          0      ]]

    Parameters
    ----------
    rho_inf : float, default 0.9
        Spectral radius at infinity in [0, 1] (:func:`genalpha_coefficients`).
        0.9 damps unresolved modes about as HHT's alpha = -0.05 does
        (rho_inf = (1 + alpha)/(1 - alpha) = 0.905).

    Notes
    -----
    Order 2 in q and v (Arnold & Bruls 2007, Theorem 2, with a_0 = qdd_0);
    index 3, so the velocity constraints hold to O(h^2). The multipliers
    are those of the equations of motion at t_{n+1} (no shift to undo, unlike
    HHT). One-step: the step size may change between steps (a_n is then
    carried as it is). Same cost per iteration as HHT-I3.

    References
    ----------
    Chung & Hulbert (1993), J. Appl. Mech. 60, 371-375.
    Arnold & Bruls (2007), Multibody Syst. Dyn. 18, 185-202.
    ``docs/methods.md``, "Generalized-alpha".
    """

    name = "genalpha"
    accepts_augmented = True
    index = 3

    def blocks(self, system) -> list[Block]:
        """(a, lam); a is qdd_{n+1}."""
        return [Block("a", system.n, "kinematic"), Block("lam", system.m, "multiplier")]

    def scales(self, system, h, q) -> np.ndarray:
        """gamma' h for qdd (dv = gamma' h dqdd), the same times the mobility for lambda."""
        return acceleration_scales(system, q, self.gamma_p * h)

    def roundoff_floor(self, system, h, q) -> np.ndarray:
        """Phi's round-off through the 1/(beta' h^2) rows, times gamma' h."""
        return roundoff_floor(system, q, self.gamma_p / (self.beta_p * h), system.n, system.m)

    def kernel_recipe(self, h, first):
        """The generalized-alpha formulas (``recipe.genalpha_recipe``); residual
        M qdd + F, Phi / (beta' h^2)."""
        return genalpha_recipe(h, self.alpha_m, self.alpha_f, self.beta, self.gamma, cM=1.0,
                               sP=1.0 / (self.beta_p * h * h),
                               floor=self.gamma_p / (self.beta_p * h))

    def start(self, system, initial) -> list[StepState]:
        """One state at t_0: qdd_0, lambda_0 from the index-1 system, a_0 = qdd_0."""
        return [self._state0(system, initial)]

    def context(self, system, history, t, h) -> StepContext:
        """The predictor parts of q and v."""
        ctx = StepContext(system, tuple(history[-1:]), t, h)
        ctx.cache["q_pred"], ctx.cache["v_pred"] = self._predictor(history[-1], h)
        return ctx

    def _qv(self, x, ctx):
        h = ctx.h
        return (ctx.cache["q_pred"] + self.beta_p * h * h * x,
                ctx.cache["v_pred"] + self.gamma_p * h * x)

    def predict(self, ctx) -> np.ndarray:
        """w(0) = (qdd_n, lambda_n)."""
        s = ctx.last
        return np.concatenate([s.a, s.lam])

    def residual(self, w, ctx) -> np.ndarray:
        """Upsilon(w), shape (n + m,)."""
        sys, n, t = ctx.system, ctx.system.n, ctx.t
        x, lam = w[:n], w[n:]
        q, v = self._qv(x, ctx)
        r1 = sys.mass_times(q, x) + sys.PhiqT_times(q, t, lam) - sys.Q(t, q, v, lam)
        r2 = sys.Phi(q, t) / (self.beta_p * ctx.h ** 2)
        return np.concatenate([r1, r2])

    def jacobian(self, w, ctx):
        """Exact Newton matrix, shape (n + m, n + m)."""
        n, h = ctx.system.n, ctx.h
        x, lam = w[:n], w[n:]
        q, v = self._qv(x, ctx)
        return index3_newton_matrix(ctx, q, v, x, lam, 1.0, self.beta_p * h * h,
                                    self.gamma_p * h)

    def accept(self, w, ctx) -> StepState:
        """State at t_{n+1} with the advanced auxiliary acceleration."""
        n = ctx.system.n
        x, lam = w[:n].copy(), w[n:].copy()
        q, v = self._qv(x, ctx)
        s = StepState(ctx.t, q, v, x, lam)
        s.extra["aux"] = self._advance(ctx.last, x)
        return s


class GenAlphaSI2(_GenAlphaBase):
    """Generalized-alpha on the stabilized index-2 formulation.

    Derived from GENALPHA as HHT-SI2 is from HHT-I3: a position correction
    h^2/2 abar, with its own multiplier mu, makes room for the velocity
    constraints at t_{n+1}; M is held at a predicted configuration for the step:

        q_{n+1} = q_n + h v_n + h^2 (1/2 - beta) a_n + h^2 beta a_{n+1} + h^2/2 abar
        v_{n+1} = v_n + h (1 - gamma) a_n + h gamma a_{n+1}

    (a_{n+1} from the generalized-alpha recursion, as in :class:`GenAlpha`);
    unknowns qdd_{n+1}, abar, lambda_{n+1}, mu (abar and mu live within one step):

        Mhat qdd_{n+1} + (Phi_q^T lambda - Q)_{n+1}         = 0
        Mhat abar + Phi_q^T(q_{n+1}) mu                    = 0
        1/h^2 Phi(q_{n+1}, t_{n+1})                        = 0
        1/h (Phi_q(q_{n+1}) v_{n+1} + Phi_t)               = 0

    Mhat := M(q_n + h v_n), the configuration predicted for t_{n+1} (where
    these equations of motion hold; HHT-SI2 takes t_n + (1 + alpha) h, where
    HHT's hold), evaluated once per step. Newton matrix (exact, dq/dqdd =
    beta' h^2, dq/dabar = h^2/2, dv/dqdd = gamma' h):

        [[Mhat + beta' h^2 K - gamma' h Q_v, h^2/2 K,                   Phi_q^T, 0      ],
         [beta' h^2 (Phi_q^T mu)_q,          Mhat + h^2/2 (Phi_q^T mu)_q, 0,       Phi_q^T],
         [beta' Phi_q,                       Phi_q / 2,                 0,       0      ],
         [gamma' Phi_q + beta' h G,          h/2 G,                     0,       0      ]]

    K = (Phi_q^T lambda)_q - Q_q, G = (Phi_q v)_q + Phi_qt; as h -> 0 it
    tends to HHT-SI2's limit with 1/(1 + alpha) -> 1, beta -> beta',
    gamma -> gamma' (nonsingular for a nonsingular M and independent constraints).

    Parameters
    ----------
    rho_inf : float, default 0.9
        As for :class:`GenAlpha`.

    Notes
    -----
    Order 2; index 2 with both constraint levels enforced (velocity
    constraint violation at round-off). mu = 0 without discretization error.

    References
    ----------
    Arnold & Bruls (2007); Negrut, Jay & Khude (HHT-SI2, the same construction);
    ``docs/methods.md``, "Generalized-alpha".
    """

    name = "genalpha-si2"
    index = 2
    extras = ("mu",)

    def blocks(self, system) -> list[Block]:
        """(a, abar, lam, mu) (``common.si2_blocks``)."""
        return si2_blocks(system)

    def scales(self, system, h, q) -> np.ndarray:
        """gamma' h for qdd, h/2 for abar, the same times the mobility for
        lambda, mu (``common.si2_scales``)."""
        return si2_scales(system, q, self.gamma_p * h, h)

    def roundoff_floor(self, system, h, q) -> np.ndarray:
        """Phi's round-off through the 1/h^2 rows, times h/2."""
        return roundoff_floor(system, q, 1.0 / h, 2 * system.n, 2 * system.m)

    def kernel_recipe(self, h, first):
        """The generalized-alpha formulas plus h^2/2 abar in q; residual as in the
        class docstring, Mhat = M(q_n + h v_n) (``mh``). Split for the band LU as HHT-SI2."""
        return genalpha_recipe(h, self.alpha_m, self.alpha_f, self.beta, self.gamma,
                               has_y=1.0, split=1.0, cqy=0.5 * h * h, cM=1.0, dM=1.0,
                               sP=1.0 / (h * h), sV=1.0 / h, sy=0.5 * h, mu_mob=1.0,
                               floor=1.0 / h, mh=h)

    def start(self, system, initial) -> list[StepState]:
        """One state at t_0: qdd_0, lambda_0, a_0 = qdd_0, mu_0 = 0."""
        s = self._state0(system, initial)
        s.extra["mu"] = np.zeros(system.m)
        return [s]

    def context(self, system, history, t, h) -> StepContext:
        """Predictors and Mhat = M(q_n + h v_n), once per step."""
        s = history[-1]
        ctx = StepContext(system, (s,), t, h)
        ctx.cache["q_pred"], ctx.cache["v_pred"] = self._predictor(s, h)
        ctx.cache["qhat"] = s.q + h * s.v
        return ctx

    def _split(self, w, ctx):
        n, m, h = ctx.system.n, ctx.system.m, ctx.h
        x, abar, lam, mu = w[:n], w[n:2 * n], w[2 * n:2 * n + m], w[2 * n + m:]
        q = ctx.cache["q_pred"] + self.beta_p * h * h * x + 0.5 * h * h * abar
        v = ctx.cache["v_pred"] + self.gamma_p * h * x
        return x, abar, lam, mu, q, v

    def predict(self, ctx) -> np.ndarray:
        """w(0) = (qdd_n, 0, lambda_n, 0)."""
        s, n, m = ctx.last, ctx.system.n, ctx.system.m
        return np.concatenate([s.a, np.zeros(n), s.lam, np.zeros(m)])

    def residual(self, w, ctx) -> np.ndarray:
        """Upsilon(w), shape (2n + 2m,) (``common.si2_residual``)."""
        x, abar, lam, mu, q, v = self._split(w, ctx)
        return si2_residual(ctx, q, v, x, abar, lam, mu, 1.0)

    def jacobian(self, w, ctx):
        """Exact Newton matrix, shape (2n + 2m, 2n + 2m) (``common.si2_newton_matrix``)."""
        x, abar, lam, mu, q, v = self._split(w, ctx)
        return si2_newton_matrix(ctx, q, v, lam, mu, 1.0, self.beta_p, self.gamma_p)

    def accept(self, w, ctx) -> StepState:
        """State at t_{n+1}, with mu and the advanced auxiliary acceleration."""
        x, abar, lam, mu, q, v = self._split(w, ctx)
        s = StepState(ctx.t, q, v, x.copy(), lam.copy())
        s.extra["mu"] = mu.copy()
        s.extra["aux"] = self._advance(ctx.last, x)
        return s
