"""NSTIFF: BDF2 on the index-3 DAE."""

from __future__ import annotations

import numpy as np

from .base import Block, Method, StepContext, StepState
from .common import (acceleration_scales, bdf_coefficients, bdf_error_coefficient,
                     force_term, index3_newton_matrix, roundoff_floor)
from .recipe import bdf_recipe
from .spectral import bdf2_step

__all__ = ["NStiff"]


class NStiff(Method):
    """Second-order backward differentiation (BDF2) on the index-3 DAE.

    With the BDF derivative D x = c0 (x_{n+1} - xi(x)), c0 = 3/(2h),
    xi(x) = 4/3 x_n - 1/3 x_{n-1}, applied to q' = v and v' = a:

        v_{n+1} = xi(v) + a_{n+1} / c0 = 4/3 v_n - 1/3 v_{n-1} + 2/3 h a_{n+1}
        q_{n+1} = xi(q) + v_{n+1} / c0
                = 4/3 q_n - 1/3 q_{n-1} + h (8/9 v_n - 2/9 v_{n-1}) + 4/9 h^2 a_{n+1}

    Unknowns (a_{n+1}, lambda_{n+1}); residual M a + Phi_q^T lambda - Q = 0 and
    9/(4 h^2) Phi = 0; Newton matrix [[M + P, Phi_q^T], [Phi_q, 0]] with
    P = 4/9 h^2 ((M a)_q + (Phi_q^T lambda)_q - Q_q) - 2/3 h Q_v.

    Start-up: two-step, so the first step (and the first after an event) is
    one backward-Euler (BDF1) step in v and a trapezoidal one in q, in the
    same unknowns (c0 = 1/h, see :func:`~mbdsl.integrators.common.bdf_coefficients`):

        v_{n+1} = v_n + h a_{n+1},   q_{n+1} = q_n + h (v_n + v_{n+1}) / 2

    and the constraint rows scaled by 2/h^2. Its local error, O(h^3) in q and
    O(h^2) in v, enters the global error once, so the method is of order 2
    from the first step. BDF1 in q as well, q_{n+1} = q_n + h v_{n+1} =
    q_n + h v_n + h^2 a_{n+1}, would be too: but on a curved constraint
    Phi(q_{n+1}) = 0 then takes only half of the normal acceleration, v_{n+1}
    leaves the constraint's tangent by O(h), and the index-3 BDF2 steps after
    it carry that offset (an Euler-Poinsot body's angular momentum drifted
    at order 1 with it, at order 2 without). A change of h keeps BDF2, with
    the coefficients of the step ratio.

    Notes
    -----
    Order 2, index 3, strongly damping (L-stable): good on stiff problems,
    dissipative on resolved oscillations. No coefficients.

    References
    ----------
    Gear (1971), Numerical Initial Value Problems in ODEs.
    Negrut, Jay & Khude; ``methods.md`` sec. 1.
    """

    name = "nstiff"
    accepts_augmented = True
    index = 3
    history_length = 2
    max_step_ratio = 2.0        # BDF2: below 1 + sqrt(2), with a margin

    def order(self, system=None) -> int:
        """2."""
        return 2

    amplification = bdf2_step  # spectral.py: one step on x'' = -omega^2 x

    def parameters(self) -> dict:
        """None: BDF2 has no free coefficient."""
        return {}

    def blocks(self, system) -> list[Block]:
        """(a, lam)."""
        return [Block("a", system.n, "kinematic"), Block("lam", system.m, "multiplier")]

    def scales(self, system, h, q) -> np.ndarray:
        """2h/3 for a (dv = da / c0), 2h/3 times the mobility for lambda."""
        return acceleration_scales(system, q, 2.0 * h / 3.0)

    def roundoff_floor(self, system, h, q) -> np.ndarray:
        """Phi's round-off through the c0^2 rows, times 1/c0 (BDF1 start-up: worst case)."""
        return roundoff_floor(system, q, 1.0 / h, system.n, system.m)

    def kernel_recipe(self, h, first):
        """BDF2 (BDF1 when ``first``) in the unknowns of this class."""
        return bdf_recipe(h, first, index2=False)

    def kernel_recipe_at(self, h, first, c0, w0, w1):
        """The recipe with the BDF coefficients c0, w0, w1 (variable steps)."""
        return bdf_recipe(h, first, index2=False, c0=c0, w0=w0, w1=w1)

    def error_coefficient(self, ctx):
        """BDF2's, BDF1's h^2 |a_{n+1}| / 2 at start-up (``common.bdf_error_coefficient``).

        The start-up step's own leading error is h^2 q'(3) / 2 in v (against
        h^3 q'(3) / 3 in q), which h^2 (a_{n+1} - a_n) / 2 would estimate. BDF1's
        estimate is kept: larger, it starts a run, and each restart after an
        event, with small steps that grow by the step ratio's limit. On the
        pendulum against elastic stops (``models/pendulum_stop.mbd``, e = 1,
        tol 1e-6) the energy after ten impacts was off by 2.0e-7 with it and
        by 1.3e-5 with the other, whose first steps into a contact are longer.
        """
        return bdf_error_coefficient(ctx)

    def first_step(self, history, h):
        """BDF1 when no two past states are h apart (``bdf_coefficients``)."""
        return bdf_coefficients(history, h)[2] == 1

    def start(self, system, initial) -> list[StepState]:
        """One state at t_0; the first step is the start-up step."""
        return [StepState(initial.t, initial.q, initial.v, initial.a, initial.lam)]

    def context(self, system, history, t, h) -> StepContext:
        """BDF coefficients (BDF2, or BDF1 at start-up) and the xi terms."""
        c0, weights, order = bdf_coefficients(history, h)
        ctx = StepContext(system, tuple(history[-2:]), t, h)
        xi_q = sum(w * s.q for w, s in weights)
        xi_v = sum(w * s.v for w, s in weights)
        if order == 1:          # q = q_n + h v_n / 2 + h v_{n+1} / 2
            ctx.cache.update(xi_q=xi_q + 0.5 * h * xi_v, dq_dv=0.5 * h)
        else:                   # q = xi(q) + v_{n+1} / c0
            ctx.cache.update(xi_q=xi_q, dq_dv=1.0 / c0)
        ctx.cache.update(c0=c0, xi_v=xi_v, bdf_order=order)
        return ctx

    def _qv(self, a, ctx):
        v = ctx.cache["xi_v"] + a / ctx.cache["c0"]
        return ctx.cache["xi_q"] + ctx.cache["dq_dv"] * v, v

    def predict(self, ctx) -> np.ndarray:
        """w(0) = (a_n, lambda_n)."""
        return np.concatenate([ctx.last.a, ctx.last.lam])

    def residual(self, w, ctx) -> np.ndarray:
        """Upsilon(w), shape (n + m,)."""
        sys, n, c0 = ctx.system, ctx.system.n, ctx.cache["c0"]
        a, lam = w[:n], w[n:]
        q, v = self._qv(a, ctx)
        r1 = sys.mass_times(q, a) + force_term(sys, ctx.t, q, v, lam)
        return np.concatenate([r1, c0 / ctx.cache["dq_dv"] * sys.Phi(q, ctx.t)])

    def jacobian(self, w, ctx) -> np.ndarray:
        """Exact Newton matrix, shape (n + m, n + m)."""
        n, c0 = ctx.system.n, ctx.cache["c0"]
        a, lam = w[:n], w[n:]
        q, v = self._qv(a, ctx)
        return index3_newton_matrix(ctx, q, v, a, lam, 1.0, ctx.cache["dq_dv"] / c0, 1.0 / c0)

    def accept(self, w, ctx) -> StepState:
        """State at t_{n+1}."""
        n = ctx.system.n
        a, lam = w[:n].copy(), w[n:].copy()
        q, v = self._qv(a, ctx)
        return StepState(ctx.t, q, v, a, lam)
