"""HHT-ADD: HHT with additive constraint corrections (Jay & Negrut)."""

from __future__ import annotations

import numpy as np

from .base import Block, Method, StepContext, StepState, check_range
from .common import force_jacobians, newmark_predictor, roundoff_floor

__all__ = ["HHTADD"]


class HHTADD(Method):
    """HHT applied to q' = v, v' = f(t, q, v) + r(q, psi) with additive corrections.

    f := M(q)^{-1} Q(t, q, v), r(q, psi) := -M(q)^{-1} Phi_q(q)^T psi;
    R_I := r(q_n, psi_I), R_II := r(q_{n+1}, psi_II):

        q_{n+1} = q_n + h v_n + h^2/2 ((1-2 beta) a_n + 2 beta a_{n+1}) + h^2/2 ((1-b) R_I + b R_II)
        v_{n+1} = v_n + h ((1-gamma) a_n + gamma a_{n+1}) + h/2 (R_I + R_II)
        0 = Phi(q_{n+1}, t_{n+1}),  0 = Phi_q(q_{n+1}) v_{n+1} + Phi_t
        a_{n+1} = (1 + alpha) f(t_{n+1}, q_{n+1}, v_{n+1}) - alpha f(t_n, q_n, v_n)

    The velocity correction's coefficient is illegible in the paper's
    extracted text; h/2 is what the dimensions require (R is an
    acceleration) and the order test confirms it.

    Unknowns, scaled for conditioning: dq = (q_{n+1} - q_pred)/h^2,
    dv = (v_{n+1} - v_pred)/h (q_pred, v_pred the Newmark predictors), a,
    psi_I, psi_II. Residual rows:

        E1 = dq - beta a - ((1-b) R_I + b R_II)/2
        E2 = dv - gamma a - (R_I + R_II)/2
        E3 = Phi(q, t) / h^2
        E4 = (Phi_q v + Phi_t) / h
        E5 = a - (1 + alpha) f(t, q, v) + alpha f_n

    Jacobian (the paper gives none; derived here). With B(q) = M^{-1} Phi_q^T,
    d(M^{-1} x)/dq = M^{-1} (x_q - (M y)_q) for y = M^{-1} x:

        dR_II/dq = -M^{-1} ((Phi_q^T psi_II)_q - (M y)_q),  y = M^{-1} Phi_q^T psi_II
        df/dq    =  M^{-1} (Q_q - (M f)_q),    df/dv = M^{-1} Q_v

        [[I - b h^2/2 dR_II/dq, 0, -beta I,  (1-b)/2 B_n, b/2 B],
         [-h^2/2 dR_II/dq,      I, -gamma I, B_n/2,       B/2 ],
         [Phi_q,                0, 0,        0,           0   ],
         [h G,               Phi_q, 0,       0,           0   ],
         [-(1+alpha) h^2 df/dq, -(1+alpha) h df/dv, I, 0, 0   ]]

    with G = (Phi_q v)_q + Phi_qt. As h -> 0 it is nonsingular exactly when
    b != 1/2: the two corrections must not enter q with equal weights.
    Its cost is the products with M^{-1}: n + m solves with M per Jacobian,
    cheap for rigid bodies (M diagonal), expensive when M depends on q.

    Parameters
    ----------
    alpha : float, default -0.05
        In [-1/3, 0]; beta = (1 - alpha)^2/4, gamma = (1 - 2 alpha)/2.
    b : float, default 0.0
        Weight of R_II in the position update; any b != 1/2. b = 0 puts the
        position correction at the start of the step only.

    Notes
    -----
    Order 2; index 2 with both constraint levels enforced. a_0 = f(t_0, q_0,
    v_0) (a is the unconstrained part of the acceleration); psi_II
    approximates lambda_{n+1} and is reported as lambda; psi_I, an
    approximation of lambda_n solved within the step, is kept as
    ``psi1``.

    References
    ----------
    Jay & Negrut (2007), "Extensions of the HHT-alpha method to differential-
    algebraic equations in mechanics", ETNA 26, 190-208.
    Negrut, Jay & Khude; ``methods.md`` sec. 5.
    """

    name = "hht-add"
    index = 2
    history_length = 1
    extras = ("psi1",)

    def __init__(self, alpha: float = -0.05, b: float = 0.0):
        self.alpha = check_range("alpha", alpha, -1.0 / 3.0 - 1e-12 <= alpha <= 0.0,
                                 "[-1/3, 0]", "HHT is unconditionally stable and second "
                                 "order only in this range")
        self.b = check_range("b", b, abs(b - 0.5) > 1e-12, "b != 1/2",
                             "with b = 1/2 the Newton matrix is singular as h -> 0")
        self.gamma = (1.0 - 2.0 * self.alpha) / 2.0
        self.beta = (1.0 - self.alpha) ** 2 / 4.0

    def order(self) -> int:
        """2."""
        return 2

    def parameters(self) -> dict:
        """alpha, b, and the derived beta and gamma."""
        return {"alpha": self.alpha, "b": self.b, "beta": self.beta, "gamma": self.gamma}

    def blocks(self, system) -> list[Block]:
        """(dq, dv, a, psi_I, psi_II)."""
        n, m = system.n, system.m
        return [Block("dq", n, "kinematic"), Block("dv", n, "kinematic"),
                Block("a", n, "kinematic"), Block("psi1", m, "multiplier"),
                Block("psi2", m, "multiplier")]

    def scales(self, system, h) -> np.ndarray:
        """h for dq and dv, gamma h for a, h/2/mean(M_ii) for psi."""
        n, m = system.n, system.m
        ps = 0.5 * h / system.mass_scale
        return np.concatenate([np.full(2 * n, h), np.full(n, self.gamma * h), np.full(2 * m, ps)])

    def roundoff_floor(self, system, h, q) -> float:
        """Phi's round-off through the 1/h^2 rows, times h."""
        return roundoff_floor(q, 1.0 / h)

    def _f(self, system, t, q, v):
        return system.mass_solve(q, system.Q(t, q, v))

    def start(self, system, initial) -> list[StepState]:
        """a_0 = f(t_0, q_0, v_0); psi_I of the first step starts at lambda_0."""
        s = StepState(initial.t, initial.q, initial.v,
                      self._f(system, initial.t, initial.q, initial.v), initial.lam)
        s.extra["psi1"] = initial.lam.copy()
        s.extra["f"] = s.a.copy()
        return [s]

    def context(self, system, history, t, h) -> StepContext:
        """Predictors, f_n and B_n = M(q_n)^{-1} Phi_q(q_n)^T (fixed within the step)."""
        s = history[-1]
        ctx = StepContext(system, (s,), t, h)
        ctx.cache["q_pred"], ctx.cache["v_pred"] = newmark_predictor(s, h, self.beta, self.gamma)
        ctx.cache["B_n"] = system.mass_solve(s.q, system.Phi_q(s.q, s.t).T)
        return ctx

    def _split(self, w, ctx):
        n, m, h = ctx.system.n, ctx.system.m, ctx.h
        dq, dv, a = w[:n], w[n:2 * n], w[2 * n:3 * n]
        p1, p2 = w[3 * n:3 * n + m], w[3 * n + m:]
        return dq, dv, a, p1, p2, ctx.cache["q_pred"] + h * h * dq, ctx.cache["v_pred"] + h * dv

    def predict(self, ctx) -> np.ndarray:
        """w(0): q, v at the Newmark predictor with a = a_n, psi at lambda_n."""
        s, h = ctx.last, ctx.h
        dq, dv = self.beta * s.a, self.gamma * s.a
        return np.concatenate([dq, dv, s.a, s.lam, s.lam])

    def residual(self, w, ctx) -> np.ndarray:
        """Upsilon(w), shape (3n + 2m,)."""
        sys, t, h = ctx.system, ctx.t, ctx.h
        dq, dv, a, p1, p2, q, v = self._split(w, ctx)
        Phi_q = sys.Phi_q(q, t)
        R1 = -ctx.cache["B_n"] @ p1
        R2 = -sys.mass_solve(q, Phi_q.T @ p2)
        e1 = dq - self.beta * a - 0.5 * ((1.0 - self.b) * R1 + self.b * R2)
        e2 = dv - self.gamma * a - 0.5 * (R1 + R2)
        e3 = sys.Phi(q, t) / (h * h)
        e4 = (Phi_q @ v + sys.Phi_t(q, t)) / h
        e5 = a - (1.0 + self.alpha) * self._f(sys, t, q, v) + self.alpha * ctx.last.extra["f"]
        return np.concatenate([e1, e2, e3, e4, e5])

    def jacobian(self, w, ctx) -> np.ndarray:
        """Newton matrix derived in the class docstring, shape (3n + 2m, 3n + 2m)."""
        sys, t, h = ctx.system, ctx.t, ctx.h
        n, m = sys.n, sys.m
        dq, dv, a, p1, p2, q, v = self._split(w, ctx)
        Phi_q = sys.Phi_q(q, t)
        B = sys.mass_solve(q, Phi_q.T)                       # M^{-1} Phi_q^T, the M^{-1} cost
        x = Phi_q.T @ p2
        dx = sys.PhiqT_lam_q(q, p2)
        Ma_q = sys.Ma_q(q, sys.mass_solve(q, x))
        dR2 = -sys.mass_solve(q, dx if Ma_q is None else dx - Ma_q)
        f = self._f(sys, t, q, v)
        Q_q, Q_v = force_jacobians(sys, t, q, v)
        df_q = np.zeros((n, n)) if Q_q is None else Q_q.copy()
        Mf_q = sys.Ma_q(q, f)
        if Mf_q is not None:
            df_q -= Mf_q
        df_q = sys.mass_solve(q, df_q)
        df_v = np.zeros((n, n)) if Q_v is None else sys.mass_solve(q, Q_v)
        I = np.eye(n)
        h2 = h * h
        J = np.zeros((3 * n + 2 * m, 3 * n + 2 * m))
        c1, c2, ca, c4, c5 = 0, n, 2 * n, 3 * n, 3 * n + m
        J[:n, c1:c2] = I - 0.5 * self.b * h2 * dR2
        J[:n, ca:c4] = -self.beta * I
        J[:n, c4:c5] = 0.5 * (1.0 - self.b) * ctx.cache["B_n"]
        J[:n, c5:] = 0.5 * self.b * B
        J[n:2 * n, c1:c2] = -0.5 * h2 * dR2
        J[n:2 * n, c2:ca] = I
        J[n:2 * n, ca:c4] = -self.gamma * I
        J[n:2 * n, c4:c5] = 0.5 * ctx.cache["B_n"]
        J[n:2 * n, c5:] = 0.5 * B
        J[2 * n:2 * n + m, c1:c2] = Phi_q
        J[2 * n + m:2 * n + 2 * m, c1:c2] = h * (sys.Phiq_v_q(q, v) + sys.Phi_qt(q, t))
        J[2 * n + m:2 * n + 2 * m, c2:ca] = Phi_q
        r5 = 2 * n + 2 * m
        J[r5:, c1:c2] = -(1.0 + self.alpha) * h2 * df_q
        J[r5:, c2:ca] = -(1.0 + self.alpha) * h * df_v
        J[r5:, ca:c4] = I
        return J

    def accept(self, w, ctx) -> StepState:
        """State at t_{n+1}: lambda := psi_II, psi_I kept as ``psi1``, f cached."""
        dq, dv, a, p1, p2, q, v = self._split(w, ctx)
        s = StepState(ctx.t, q, v, a.copy(), p2.copy())
        s.extra["psi1"] = p1.copy()
        s.extra["f"] = self._f(ctx.system, ctx.t, q, v)
        return s
