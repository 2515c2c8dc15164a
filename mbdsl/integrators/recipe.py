"""Kernel recipes: the methods as data.

Seven of the eight methods (NEWMARK, HHT-I3, NSTIFF, NSTIFF-SI2, HHT-SI2,
GENALPHA, GENALPHA-SI2) are
one nonlinear system in one of two shapes of unknowns (the linear form,
``form`` 0), with coefficients that depend on the method, the step size h
and (for BDF2) whether the step is a start-up step; HHT-ADD is a second form
(``form`` 1, below). A recipe is that coefficient vector, in the spirit of
the Butcher tableaux of scipy's Runge-Kutta solvers: the compiled engine
(:mod:`.compiled`) reads it, and holds no method name.

Unknowns w = (x, [y,] lambda, [mu]), x and y of size n, lambda and mu of size
m; y and mu exist when ``has_y`` is 1 (the stabilized index-2 methods). The
state at t_{n+1} is linear in them::

    q = q_pred + cqx x + cqy y,        v = v_pred + cvx x + cvy y
    q_pred = pq0 q_n + pq1 q_{n-1} + pv0 v_n + pv1 v_{n-1} + pa a_n + pb b_n
    v_pred = vv0 v_n + vv1 v_{n-1} + va a_n + vb b_n

where a_n is the converged x of the step before and b_n an auxiliary
acceleration carried from step to step (generalized-alpha's a_n, see
``genalpha.py``; unused, 0, by the paper's six), advanced after each step by

    b_{n+1} = bb b_n + ba a_n + bx a_{n+1}

and the residual has up to four blocks (F := Phi_q^T lambda - Q)::

    R1 = cM M x + F(q, v, lambda) - cF F_n                      (n rows)
    R2 = dM M y + dI y + dV v + Phi_q^T mu                      (n rows, has_y)
    R3 = sP Phi(q, t)                                           (m rows)
    R4 = sV (Phi_q v + Phi_t)                                   (m rows, has_y)

M is M(q) at the step's end (with flexible beams its (M x)_q and (M y)_q
enter the Newton matrix), or, when ``mh`` is not 0, Mhat = M(q_n + mh v_n)
held for the step (HHT-SI2: mh = (1 + alpha) h; GENALPHA-SI2: mh = h). For
rigid bodies M is a constant diagonal and ``mh`` changes nothing.

Their Newton matrix follows by the chain rule (``integrators.compiled.recipes._jacobian_triplets``):
d/dx of a term in q is its q-derivative times cqx, and so on. After
convergence a_{n+1} = x. Newton starts from x = a_n, y = y0v v_n, lambda_n,
mu = 0, with velocity-equivalent scales sx for x, sy for y, sx times the
multiplier mobility for lambda, sy (times the mobility when ``mu_mob`` is
1) for mu, and a round-off floor of 32 eps (1 + |q|_max) ``floor``
(``common.roundoff_floor``). ``split`` is 1 where the band LU may factor the
(x, lambda) and (y, mu) diagonal blocks apart (``compiled``, "Linear
solvers"): the coupling it leaves out must be O(h) against the blocks.

The augmented formulation (``base.Method.formulated``) sets ``reg`` =
epsilon: the Newton matrix's multiplier block is -epsilon I instead of 0,
the residual is unchanged, and Newton judges convergence on x alone (the
multipliers are not unique where Phi_q loses rank). The engine writes it
(``engine.recipe``); the methods' own recipes leave it 0.

``err`` is the coefficient of the local error estimate of error-controlled
steps (``adaptive``): e = err (x_{n+1} - x_n), err = (beta - 1/6) h^2 for
the Newmark formulas (Zienkiewicz & Xie 1991), on the auxiliary
acceleration b instead of x when ``eaux`` is 1 (generalized-alpha), and
e = err x when ``eabs`` is 1 (a BDF1 start-up step: err = h^2 / 2).

Each method's ``kernel_recipe(h, first)`` (``base.Method``) fills one with
:func:`make_recipe`; its equations are the ones its numpy ``residual``
evaluates, and ``tests/integrators/test_engine.py`` checks the two against
each other and the Newton matrix against differences of the residual.

The additive form (HHT-ADD, ``hht_add.py``): unknowns (dq, dv, a, psi_I,
psi_II), q = q_pred + cqx dq, v = v_pred + cvy dv (Newmark predictor), and
the residual of HHT-ADD with its rows 1, 2 and 5 multiplied by M(q) (for
rigid bodies a constant diagonal: Newton's iterates are unchanged and no
M^-1 is formed)::

    M dq - ka1 M a + (1 - kb)/2 M M_n^-1 Phi_q(q_n)^T psi_I + kb/2 Phi_q(q)^T psi_II
    M dv - ka2 M a + 1/2 M M_n^-1 Phi_q(q_n)^T psi_I + 1/2 Phi_q(q)^T psi_II
    sP Phi(q, t),   sV (Phi_q v + Phi_t)
    M a - cQ Q(t, q, v) + cF M f_n

with M = M(q), M_n = M(q_n) and f_n = M_n^-1 Q_n (for rigid bodies M M_n^-1 = I;
with flexible beams a block solve per beam).

Scales: sx for dq and dv, sy for a, sm times the mobility for psi_I and
psi_II. lambda := psi_II; psi_I is the method's extra multiplier. Newton
starts from a = a_n, psi_I = psi_II = lambda_n, dq = ka1 a_n + R_n/2 and
dv = ka2 a_n + R_n, R_n = -M(q_n)^-1 Phi_q(q_n)^T lambda_n.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RECIPE_FIELDS", "LINEAR", "ADDITIVE", "make_recipe", "newmark_recipe",
           "bdf_recipe", "additive_recipe", "genalpha_recipe", "uses_auxiliary"]

#: The two forms (``form``).
LINEAR, ADDITIVE = 0, 1

#: The recipe's entries, in order (``compiled`` checks its copy against this one).
RECIPE_FIELDS = ("form", "has_y", "split", "cqx", "cqy", "cvx", "cvy", "cM", "cF", "dM", "dI",
                 "dV", "sP", "sV", "sx", "sy", "mu_mob", "floor",
                 "pq0", "pq1", "pv0", "pv1", "pa", "vv0", "vv1", "va", "y0v",
                 "ka1", "ka2", "kb", "cQ", "sm", "pb", "vb", "bb", "ba", "bx", "reg",
                 "err", "eaux", "eabs", "mh")


def make_recipe(**values: float) -> np.ndarray:
    """A recipe vector, shape (len(RECIPE_FIELDS),): the named entries, 0 elsewhere.

    Raises
    ------
    ValueError
        A name that is not in :data:`RECIPE_FIELDS`.
    """
    unknown = set(values) - set(RECIPE_FIELDS)
    if unknown:
        raise ValueError(f"not recipe entries: {', '.join(sorted(unknown))}")
    return np.array([float(values.get(k, 0.0)) for k in RECIPE_FIELDS])


def newmark_recipe(h: float, beta: float, gamma: float, **values: float) -> np.ndarray:
    """A recipe with the Newmark predictor and x = a_{n+1} (NEWMARK, HHT-I3, HHT-SI2).

    q = q_n + h v_n + h^2/2 ((1 - 2 beta) a_n + 2 beta a_{n+1}) [+ cqy y],
    v = v_n + h ((1 - gamma) a_n + gamma a_{n+1}); ``values`` as in
    :func:`make_recipe` (the residual's coefficients).
    """
    return make_recipe(cqx=beta * h * h, cvx=gamma * h, sx=gamma * h,
                       pq0=1.0, pv0=h, pa=0.5 * h * h * (1.0 - 2.0 * beta),
                       vv0=1.0, va=h * (1.0 - gamma), err=(beta - 1.0 / 6.0) * h * h, **values)


def bdf_recipe(h: float, first: bool, index2: bool, c0: float | None = None,
               w0: float | None = None, w1: float | None = None) -> np.ndarray:
    """The recipe of BDF2 on the index-3 (NSTIFF) or stabilized index-2
    (NSTIFF-SI2) DAE; ``first``: the start-up step, BDF1 (``common.bdf_coefficients``).

    With D x = c0 (x_{n+1} - xi(x)), xi(x) = 4/3 x_n - 1/3 x_{n-1} (BDF1: x_n):
    NSTIFF has x = D v, q = xi(q) + xi(v)/c0 + x/c0^2; NSTIFF-SI2 has x = D v,
    y = D q, q = xi(q) + y/c0, v = xi(v) + x/c0 (``nstiff.py``, ``nstiff_si2.py``).
    c0, w0, w1 given: xi(x) = w0 x_n + w1 x_{n-1} with that c0 (the
    variable-step coefficients). Error estimate: 2/9 h^2 (x - x_n); a
    start-up step h^2 / 2 x (``common.bdf_error_coefficient``).

    NSTIFF's start-up step is BDF1 in v and the trapezoidal rule in q,
    q = q_n + h (v_n + v_{n+1}) / 2 = q_n + h v_n + x / (2 c0^2), its
    constraint rows scaled by 2 c0^2. BDF1 in both (x / c0^2) would put half
    of the normal acceleration on a curved constraint into Phi(q) = 0 and
    leave v off its tangent by O(h), an offset the index-3 BDF2 steps after
    it keep (``nstiff.py``). NSTIFF-SI2's start-up is BDF1 in both (its v
    obeys the velocity constraints).
    """
    if c0 is None:
        c0, w0, w1 = (1.0 / h, 1.0, 0.0) if first else (1.5 / h, 4.0 / 3.0, -1.0 / 3.0)
    common = dict(cvx=1.0 / c0, cM=1.0, sx=2.0 * h / 3.0, floor=1.0 / h,
                  pq0=w0, pq1=w1, vv0=w0, vv1=w1,
                  err=(0.5 if first else 2.0 / 9.0) * h * h, eabs=1.0 if first else 0.0)
    if not index2:
        k = 0.5 if first else 1.0         # dq/dx = k / c0^2; the rows scaled by its inverse
        return make_recipe(cqx=k / c0 ** 2, sP=c0 * c0 / k, pv0=w0 / c0, pv1=w1 / c0,
                           **common)
    return make_recipe(has_y=1.0, cqy=1.0 / c0, dI=1.0, dV=-1.0, sP=c0, sV=c0, sy=1.0,
                       y0v=1.0, **common)


def additive_recipe(h: float, alpha: float, beta: float, gamma: float, b: float) -> np.ndarray:
    """The recipe of HHT-ADD (``hht_add.py``): the additive form with the
    Newmark predictor; row scalings 1/h^2 and 1/h of its constraint rows."""
    return make_recipe(form=ADDITIVE, has_y=1.0, cqx=h * h, cvy=h, cQ=1.0 + alpha, cF=alpha,
                       ka1=beta, ka2=gamma, kb=b, sP=1.0 / (h * h), sV=1.0 / h,
                       sx=h, sy=gamma * h, sm=0.5 * h, floor=1.0 / h,
                       pq0=1.0, pv0=h, pa=0.5 * h * h * (1.0 - 2.0 * beta),
                       vv0=1.0, va=h * (1.0 - gamma), err=(beta - 1.0 / 6.0) * h * h)


def genalpha_recipe(h: float, alpha_m: float, alpha_f: float, beta: float, gamma: float,
                    **values: float) -> np.ndarray:
    """A recipe of the generalized-alpha formulas with x = qdd_{n+1}, the true
    acceleration (``genalpha.py``), and b the auxiliary acceleration a_n of
    Arnold & Bruls (2007):

        (1 - alpha_m) b_{n+1} + alpha_m b_n = (1 - alpha_f) qdd_{n+1} + alpha_f qdd_n
        q = q_n + h v_n + h^2 (1/2 - beta) b_n + h^2 beta b_{n+1}
        v = v_n + h (1 - gamma) b_n + h gamma b_{n+1}

    with b_{n+1} eliminated: q = q_pred + beta' h^2 x, v = v_pred + gamma' h x,
    beta' = beta (1 - alpha_f)/(1 - alpha_m), gamma' = gamma (1 - alpha_f)/(1 - alpha_m).
    ``values`` as in :func:`make_recipe` (the residual's coefficients).
    """
    d = 1.0 / (1.0 - alpha_m)
    return make_recipe(cqx=beta * (1.0 - alpha_f) * d * h * h, cvx=gamma * (1.0 - alpha_f) * d * h,
                       sx=gamma * (1.0 - alpha_f) * d * h,
                       pq0=1.0, pv0=h, pa=beta * alpha_f * d * h * h,
                       pb=(0.5 - beta - beta * alpha_m * d) * h * h,
                       vv0=1.0, va=gamma * alpha_f * d * h, vb=(1.0 - gamma - gamma * alpha_m * d) * h,
                       bb=-alpha_m * d, ba=alpha_f * d, bx=(1.0 - alpha_f) * d,
                       err=(beta - 1.0 / 6.0) * h * h, eaux=1.0, **values)


def uses_auxiliary(rec) -> bool:
    """Whether the recipe carries the auxiliary acceleration b."""
    i = RECIPE_FIELDS.index
    return any(rec[i(k)] != 0.0 for k in ("pb", "vb", "bb", "ba", "bx"))
