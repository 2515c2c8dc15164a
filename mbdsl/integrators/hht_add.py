"""HHT-ADD: HHT with additive constraint corrections (Jay & Negrut)."""

from __future__ import annotations

import numpy as np

from ..registry import check_coefficient
from .base import Block, Method, StepContext, StepState
from .common import Terms, assemble, hht_coefficients, newmark_predictor, roundoff_floor
from .recipe import additive_recipe
from .spectral import hht_step

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
    acceleration_is_total = False       # a = M^-1 Q; the constraint forces' part is in psi
    saddle_point_rows = False           # rows (E1..E5) not in the unknowns' order
    extras = ("psi1",)
    output_extras = ("psi2",)

    needs_mass_inverse = True

    def __init__(self, alpha: float = -0.05, b: float = 0.0):
        self.alpha, self.beta, self.gamma = hht_coefficients(alpha)
        self.b = check_coefficient("b", b)

    def order(self, system=None) -> int:
        """2; 1 on a model with friction in joints, whose normal load is then
        psi_II, an O(h) approximation of the reaction (docs/methods.md,
        "Friction")."""
        from ..model.elements import Friction
        if system is not None and any(isinstance(f, Friction) for f in system.model.forces):
            return 1
        return 2

    amplification = hht_step  # spectral.py: one step on x'' = -omega^2 x

    def parameters(self) -> dict:
        """alpha, b, and the derived beta and gamma."""
        return {"alpha": self.alpha, "b": self.b, "beta": self.beta, "gamma": self.gamma}

    def blocks(self, system) -> list[Block]:
        """(dq, dv, a, psi_I, psi_II)."""
        n, m = system.n, system.m
        return [Block("dq", n, "kinematic"), Block("dv", n, "kinematic"),
                Block("a", n, "kinematic"), Block("psi1", m, "multiplier"),
                Block("psi2", m, "multiplier")]

    def scales(self, system, h, q) -> np.ndarray:
        """h for dq and dv, gamma h for a, h/2 times the mobility for psi."""
        n = system.n
        ps = 0.5 * h * system.multiplier_mobility(q)
        return np.concatenate([np.full(2 * n, h), np.full(n, self.gamma * h), ps, ps])

    def roundoff_floor(self, system, h, q) -> np.ndarray:
        """Phi's round-off through the 1/h^2 rows, times h."""
        return roundoff_floor(system, q, 1.0 / h, 3 * system.n, 2 * system.m)

    def _f(self, system, t, q, v, lam):
        """f = M^{-1} Q(t, q, v, lambda); lambda := psi_II, read only by
        friction (whose normal load is then psi_II: an O(h) approximation of
        the reaction, see ``output_rows``)."""
        return system.mass_solve(q, system.Q(t, q, v, lam))

    def output_rows(self, system, t, q, v, a, lam, extras):
        """lambda from the index-1 system at each step's (t, q, v), the
        accelerations they give, and psi_II (the step's own unknown) as the
        extra column ``psi2``.

        psi_I and psi_II are the corrections' multipliers, not the Lagrange
        multipliers of the equations of motion: psi_II converges at order 1
        to lambda (a driving torque on a driven slider crank off by 0.31,
        0.16, 0.078 N m at h = 1e-4, 5e-5, 2.5e-5 where HHT-I3's lambda is
        off by 1.5e-4, 3.7e-5, 9.0e-6), while q and v are of order 2. The
        index-1 multipliers at (q, v) inherit the order of q and v.

        The step's own a is M^-1 Q alone (``acceleration_is_total`` False:
        the constraint forces' share is in psi), not the motion's
        acceleration; written as the acceleration columns it showed a
        pendulum's angular acceleration as 0. The columns are q'' = M^-1 (Q -
        Phi_q^T lambda) with the output's lambda.

        Both from one call of the compiled kernels after a compiled run
        (``engine.index1_multipliers``: a few us per row on small models,
        against about 0.3 ms per row by the system's dense index-1 matrix;
        rigid bodies by a band Cholesky of Phi_q M^-1 Phi_q^T, linear in a
        chain's length, whose kernel forms the accelerations from the Phi_q
        and Q it holds).
        """
        from .engine import index1_multipliers
        out, acc = index1_multipliers(system, t, q, v, accelerations=True)
        return out, acc, {"psi2": lam}

    #: accepted steps between two looks at :meth:`stability_check` on a
    #: model whose mass matrix depends on q (flexible beams)
    STABILITY_CHECK_EVERY = 100
    #: h^2/2 rho(dR/dq) above which a step is refused (see stability_check)
    STABILITY_LIMIT = 1.0
    #: up to this many coordinates rho(dR/dq) comes from dense eigenvalues
    DENSE_EIGENVALUES = 300

    def stability_check_every(self, system) -> int:
        """100 on a model whose mass matrix depends on q, else 0 (never)."""
        return 0 if system.mass_is_constant or not system.m else self.STABILITY_CHECK_EVERY

    def explicit_stiffness(self, system, state, h) -> float:
        """kappa = h^2/2 rho(dR/dq) at an accepted state, dimensionless.

        R_I = r(q_n, psi_I) = -M(q_n)^{-1} Phi_q(q_n)^T psi_I enters the
        step at the configuration of its start: a change dq_n of q_n moves
        q_{n+1} by h^2 (1 - b)/2 and v_{n+1} by h/2 times S dq_n, with

            S = dr/dq = -M^{-1} ((Phi_q^T psi)_q - (M y)_q),  y = M^{-1} Phi_q^T psi,

        an explicit term in an otherwise implicit step. Where M is constant
        (rigid bodies) S is the constraints' geometric stiffness over the
        mass, of the order of the motion's own frequencies squared. Where M
        depends on q (a floating-frame beam) the split into f = M^{-1} Q
        and r = -M^{-1} Phi_q^T psi is lopsided: a beam clamped in its frame
        has nodal slopes of a few grams m^2, so f and r are each 1e4..1e6
        times the true acceleration and cancel, and (M y)_q makes S grow
        with the reaction: on an 8-element 10 m cantilever under gravity
        rho(S) = 3.3e5 1/s^2 (|f| = 3e6 m/s^2 where the beam's acceleration
        is 10 m/s^2). Explicit terms are stable for kappa up to about one.

        rho(S) by numpy's eigenvalues of S up to ``DENSE_EIGENVALUES``
        coordinates, else by ARPACK (scipy) on products with S; off the hot
        path: every ``STABILITY_CHECK_EVERY`` steps (on the cantilever, 27
        coordinates, 0.2 ms a look against 0.56 ms a step). psi is the
        state's psi_I. (Power iteration was tried: its 30 iterations
        stopped 13 % short of rho, whose nearest eigenvalues are close.)
        """
        q = state.q
        psi = state.extra.get("psi1", state.lam)
        y = system.mass_solve(q, system.PhiqT_times(q, state.t, psi))
        K = system.PhiqT_lam_q(q, psi)
        Mq = system.Ma_q(q, y)
        if Mq is not None:
            K = K - Mq
        K = K.toarray() if hasattr(K, "toarray") else np.asarray(K)
        if system.n <= self.DENSE_EIGENVALUES:
            rho = float(np.max(np.abs(np.linalg.eigvals(system.mass_solve(q, K)))))
        else:
            import scipy.sparse.linalg as sla
            op = sla.LinearOperator((system.n, system.n), dtype=float,
                                    matvec=lambda x: system.mass_solve(q, K @ x))
            try:
                vals = sla.eigs(op, k=1, which="LM", tol=1e-3, maxiter=50 * system.n,
                                v0=np.cos(np.arange(system.n) + 0.5),
                                return_eigenvectors=False)
            except sla.ArpackNoConvergence as exc:
                vals = exc.eigenvalues
            rho = float(np.max(np.abs(vals))) if len(vals) else 0.0
        return 0.5 * h * h * rho

    def stability_check(self, system, state, h):
        """None, or the message of a step that HHT-ADD cannot take stably
        (E603): kappa = h^2/2 rho(dR/dq) above one (:meth:`explicit_stiffness`).

        Measured, against HHT-I3 at a tenth of the step (largest error over
        the run / largest deflection): the 8-element cantilever under
        gravity, kappa 17.9, 1.6, 0.18, 0.016 at h = 1e-2, 3e-3, 1e-3, 3e-4
        s: 62 %, 7.9 %, 0.42 %, 0.038 % (HHT-I3 at the same steps: 0.16 %,
        0.03 %, 6.6e-3 %, 1.2e-3 %); models/spinup_beam.mbd over 10 s,
        kappa 4.8, 1.2, 0.19 at h = 1e-2, 5e-3, 2e-3 s: 54 %, 60 %, 6.4 %.
        Below one what remains is inaccuracy, which the energy balance
        guard (W602) reports.
        """
        kappa = self.explicit_stiffness(system, state, h)
        if kappa <= self.STABILITY_LIMIT:
            return None
        h_ok = h * np.sqrt(self.STABILITY_LIMIT / kappa)
        return (f"hht-add is unstable on this model at h = {h:.3g} s (t = {state.t:.6g} s): "
                f"its start-of-step constraint correction -M(q_n)^-1 Phi_q(q_n)^T psi_I acts "
                f"as an explicit stiffness h^2/2 |dR/dq| = {kappa:.3g} (stable below 1), "
                f"because the flexible beams' mass matrix splits the constraint forces into "
                f"unconstrained and corrective accelerations far larger than the motion's",
                f"hht-i3, hht-si2 or genalpha (implicit in the constraint forces, same order), "
                f"or h below {h_ok:.2g} s at this load (the limit falls as the reactions grow)")

    def kernel_recipe(self, h, first):
        """The additive form (``recipe.py``): these equations with rows 1, 2
        and 5 multiplied by M, for rigid bodies."""
        return additive_recipe(h, self.alpha, self.beta, self.gamma, self.b)

    def start(self, system, initial) -> list[StepState]:
        """a_0 = f(t_0, q_0, v_0); psi_I of the first step starts at lambda_0."""
        f0 = (self._f(system, initial.t, initial.q, initial.v, initial.lam)
              if getattr(initial, "Q", None) is None else system.mass_solve(initial.q, initial.Q))
        s = StepState(initial.t, initial.q, initial.v, f0, initial.lam)
        s.extra["psi1"] = initial.lam.copy()
        s.extra["f"] = s.a.copy()
        s.extra["acc"] = np.asarray(initial.a, dtype=float).copy()
        return [s]

    #: The estimate reads the index-1 projection of a + R_II
    #: (:meth:`estimate_acceleration`): R_II carries R_I's round-off, which
    #: enters q over h^2 / 2 (Phi(q_n)'s residual over h^2, in the direction
    #: M^-1 Phi_q^T the projection replaces). Measured on the car axis at
    #: rtol 1e-10 without it: a + R_II jumped by 1e9 m/s^2 between steps of
    #: 3e-12 s, 73 times the tolerance at the smallest step.
    estimate_on_index1 = True

    def constraint_rows(self, system):
        """E3 (Phi / h^2) and E4 ((Phi_q v + Phi_t) / h): rows 2n to 2n + 2m
        of the 3n + 2m."""
        n, m = system.n, system.m
        rows = np.zeros(3 * n + 2 * m, dtype=bool)
        rows[2 * n:2 * n + 2 * m] = True
        return rows

    def estimate_acceleration(self, system, state):
        """The total acceleration a + R_II = a - M^-1 Phi_q^T psi_II (n,)
        [m/s^2, rad/s^2]: a alone is the acceleration of the applied forces,
        which misses what the constraint forces do (on a pendulum under
        gravity a does not change at all)."""
        acc = state.extra.get("acc")    # (a state the kernels' accept built has none)
        return acc if acc is not None else state.a + self._r(system, state.q, state.lam)

    def local_error(self, ctx, new):
        """(beta - 1/6) h^2 times the change of the total acceleration a + R_II
        over the step (Zienkiewicz & Xie 1991; ``adaptive``;
        :meth:`estimate_acceleration`)."""
        prev = self.estimate_acceleration(ctx.system, ctx.last)
        acc = self.estimate_acceleration(ctx.system, new)
        return (self.beta - 1.0 / 6.0) * ctx.h ** 2 * (acc - prev)

    @staticmethod
    def _r(system, q, psi):
        """r(q, psi) = -M(q)^{-1} Phi_q(q)^T psi [m/s^2]."""
        if not system.m:
            return np.zeros(system.n)
        return -system.mass_solve(q, system.PhiqT_times(q, 0.0, psi))

    def context(self, system, history, t, h) -> StepContext:
        """Predictors, f_n and B_n = M(q_n)^{-1} Phi_q(q_n)^T (fixed within the step)."""
        s = history[-1]
        ctx = StepContext(system, (s,), t, h)
        ctx.cache["q_pred"], ctx.cache["v_pred"] = newmark_predictor(s, h, self.beta, self.gamma)
        ctx.cache["Phi_q_n"] = system.Phi_q_values(s.q, s.t)   # B_n = M^-1 Phi_q(q_n)^T
        return ctx

    def _split(self, w, ctx):
        n, m, h = ctx.system.n, ctx.system.m, ctx.h
        dq, dv, a = w[:n], w[n:2 * n], w[2 * n:3 * n]
        p1, p2 = w[3 * n:3 * n + m], w[3 * n + m:]
        return dq, dv, a, p1, p2, ctx.cache["q_pred"] + h * h * dq, ctx.cache["v_pred"] + h * dv

    def predict(self, ctx) -> np.ndarray:
        """w(0): a = a_n, psi_I = psi_II = lambda_n, and q, v at the Newmark
        predictor with a_n and the corrections of the step before, R_n =
        r(q_n, lambda_n), in place of R_I and R_II: dq = beta a_n + R_n / 2,
        dv = gamma a_n + R_n.

        a is only the applied forces' part of the acceleration; a + R is the
        acceleration. Leaving R_n out (dq = beta a_n) starts q and v off by
        the constraint forces' share of a step: on the slider crank 6.4
        Newton iterations a step instead of 5.3, and on the flexible slider
        crank, whose beam's elastic a and R are large and of opposite
        signs, a new Newton matrix at every step instead of at 3 of 4.
        """
        s = ctx.last
        R = self._r(ctx.system, s.q, s.lam)
        dq, dv = self.beta * s.a + 0.5 * R, self.gamma * s.a + R
        return np.concatenate([dq, dv, s.a, s.lam, s.lam])

    def residual(self, w, ctx) -> np.ndarray:
        """Upsilon(w), shape (3n + 2m,)."""
        sys, t, h = ctx.system, ctx.t, ctx.h
        dq, dv, a, p1, p2, q, v = self._split(w, ctx)
        s = ctx.last
        R1 = -sys.mass_solve(s.q, sys.PhiqT_times(s.q, s.t, p1))
        R2 = -sys.mass_solve(q, sys.PhiqT_times(q, t, p2))
        e1 = dq - self.beta * a - 0.5 * ((1.0 - self.b) * R1 + self.b * R2)
        e2 = dv - self.gamma * a - 0.5 * (R1 + R2)
        e3 = sys.Phi(q, t) / (h * h)
        e4 = (sys.Phiq_times(q, t, v) + sys.Phi_t(q, t)) / h
        e5 = a - (1.0 + self.alpha) * self._f(sys, t, q, v, p2) + self.alpha * ctx.last.extra["f"]
        return np.concatenate([e1, e2, e3, e4, e5])

    def jacobian(self, w, ctx) -> np.ndarray:
        """Newton matrix derived in the class docstring, shape (3n + 2m, 3n + 2m)."""
        sys, t, h = ctx.system, ctx.t, ctx.h
        n, m = sys.n, sys.m
        dq, dv, a, p1, p2, q, v = self._split(w, ctx)
        h2, c4, c5, r5 = h * h, 3 * n, 3 * n + m, 2 * n + 2 * m
        if not sys.mass_is_constant:
            return self._jacobian_flexible(ctx, q, v, p2)
        # dR_II/dq = -M^{-1} (Phi_q^T psi_II)_q (rigid bodies: M constant);
        # df/dq = M^{-1} Q_q, df/dv = M^{-1} Q_v: the products with M^{-1}
        # are the cost the paper reports for this method.
        inv = 1.0 / sys.mass_diag
        K2 = sys.PhiqT_lam_q_values(q, p2) * inv[sys.pattern_hessian[0]]
        Bn = ctx.cache["Phi_q_n"] * inv[sys.pattern_Phi_q[1]]
        T = Terms(sys)
        T.identity(0, 0).add(sys.pattern_hessian, K2, 0, 0, 0.5 * self.b * h2)
        T.identity(0, 2 * n, -self.beta)
        T.add(sys.pattern_Phi_q, Bn, 0, c4, 0.5 * (1.0 - self.b), transpose=True)
        T.Phi_q(q, t, 0, c5, 0.5 * self.b, transpose=True, inv_mass=True)
        T.add(sys.pattern_hessian, K2, n, 0, 0.5 * h2)
        T.identity(n, n).identity(n, 2 * n, -self.gamma)
        T.add(sys.pattern_Phi_q, Bn, n, c4, 0.5, transpose=True)
        T.Phi_q(q, t, n, c5, 0.5, transpose=True, inv_mass=True)
        T.Phi_q(q, t, 2 * n, 0)
        T.G(q, v, t, 2 * n + m, 0, h).Phi_q(q, t, 2 * n + m, n)
        Qq, Qv = sys.force_derivative_values(t, q, v, p2)
        rows = sys.pattern_force[0]
        T.Q_lam(t, q, v, p2, r5, c5, -(1.0 + self.alpha), inv_mass=True)
        T.add(sys.pattern_force, None if Qq is None else Qq * inv[rows], r5, 0,
              -(1.0 + self.alpha) * h2)
        T.add(sys.pattern_force, None if Qv is None else Qv * inv[rows], r5, n,
              -(1.0 + self.alpha) * h)
        T.identity(r5, 2 * n)
        return assemble(ctx, T, 3 * n + 2 * m)

    def _jacobian_flexible(self, ctx, q, v, p2):
        """The same Newton matrix when M depends on q (flexible beams).

        The products with M(q)^{-1} are dense n x n and n x m blocks here
        (one block solve per beam): the cost the paper attributes to this
        method on flexible models. (M y)_q and (M f)_q enter as in the class
        docstring.
        """
        sys, t, h = ctx.system, ctx.t, ctx.h
        n, m = sys.n, sys.m
        h2, c4, c5, r5 = h * h, 3 * n, 3 * n + m, 2 * n + 2 * m
        s = ctx.last
        if "B_n" not in ctx.cache:
            ctx.cache["B_n"] = sys.mass_solve(s.q, sys.Phi_q(s.q, s.t).T)
        Bn = ctx.cache["B_n"]
        B = sys.mass_solve(q, sys.Phi_q(q, t).T)
        y = B @ p2
        dR2 = sys.mass_solve(q, sys.PhiqT_lam_q(q, p2) - sys.Ma_q(q, y))    # = -dR_II/dq
        Qq, Qv = sys.force_derivatives(t, q, v, p2)
        f = sys.mass_solve(q, sys.Q(t, q, v, p2))
        Ql = sys.Q_lam(t, q, v, p2)            # friction: d f / d psi_II
        dfq = sys.mass_solve(q, (0.0 if Qq is None else Qq) - sys.Ma_q(q, f))
        T = Terms(sys)
        T.identity(0, 0).dense(dR2, 0, 0, 0.5 * self.b * h2)
        T.identity(0, 2 * n, -self.beta)
        T.dense(Bn, 0, c4, 0.5 * (1.0 - self.b)).dense(B, 0, c5, 0.5 * self.b)
        T.dense(dR2, n, 0, 0.5 * h2)
        T.identity(n, n).identity(n, 2 * n, -self.gamma)
        T.dense(Bn, n, c4, 0.5).dense(B, n, c5, 0.5)
        T.Phi_q(q, t, 2 * n, 0)
        T.G(q, v, t, 2 * n + m, 0, h).Phi_q(q, t, 2 * n + m, n)
        T.dense(dfq, r5, 0, -(1.0 + self.alpha) * h2)
        if Qv is not None:
            T.dense(sys.mass_solve(q, Qv), r5, n, -(1.0 + self.alpha) * h)
        if Ql is not None:
            T.dense(sys.mass_solve(q, Ql), r5, c5, -(1.0 + self.alpha))
        T.identity(r5, 2 * n)
        return assemble(ctx, T, 3 * n + 2 * m)

    def accept(self, w, ctx) -> StepState:
        """State at t_{n+1}: lambda := psi_II, psi_I kept as ``psi1``, f cached."""
        dq, dv, a, p1, p2, q, v = self._split(w, ctx)
        s = StepState(ctx.t, q, v, a.copy(), p2.copy())
        s.extra["psi1"] = p1.copy()
        s.extra["f"] = self._f(ctx.system, ctx.t, q, v, p2)
        s.extra["acc"] = a + self._r(ctx.system, q, p2)
        return s
