"""The compiled Newton iteration: the one of :mod:`mbdsl.integrators.newton`
(weighted velocity-equivalent norm, contraction-based stopping, modified
Newton with refresh on poor contraction, the round-off stall rule).
"""

from __future__ import annotations

import numpy as np

from mbdsl.integrators.outcomes import (CONVERGED, DIVERGING, MAX_ITER, NONFINITE)
from mbdsl.integrators.records import (CNT_FACTORIZATIONS, CNT_ITERATIONS, CNT_JACOBIANS,
                                       CNT_RESIDUALS, CNT_STALLED, LU_RATE, LU_VALID, OPT_FULL,
                                       OPT_MAX_ITER, OPT_REFRESH)

from .layout import ADDITIVE, FORM, HAS_Y, REG, SP, SV, _layout
from .linalg import _factor, _solve
from .recipes import _jacobian_triplets, _residual
from ...kernels.schema import (EPS, FRAME_HOLD, FROW, MASS, ROUNDOFF_BAND, ROW_ELEMENT, _hot, _i,
                               _rows)


@_hot
def _newton(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, weight, opts, solver, lin, lu_state,
            R, C, V, r, dw, qx, vx, work, counts, spare):
    """One step's Newton iteration on w (in place), with the stored
    factorization (``_factor``, ``_solve``) reused across iterations and
    steps (modified Newton). ``spare``: scratch of 2 size floats for the
    residual's round-off test (``_rest_at_roundoff``, newton.py's).

    ``opts`` = (rtol, atol_k, atol_m, max_iter, rate_refresh, full);
    ``lu_state`` = (valid, rate); ``counts`` += (iterations, residuals,
    jacobians, factorizations, stalled steps). Returns the status code.
    """
    max_iter, rate_refresh, full = int(opts[OPT_MAX_ITER]), opts[OPT_REFRESH], opts[OPT_FULL] != 0.0
    size = w.shape[0]
    # the augmented formulation factors a Newton matrix of its own every step
    # (``Method.formulated``: near a singular position one from an earlier step
    # ends the iteration away from the step's solution)
    valid = lu_state[LU_VALID] != 0.0 and not full and rec[REG] == 0.0
    age = 1 << 30
    prev = -1.0
    best = np.inf
    stalls = 0
    grows = 0
    theta = lu_state[LU_RATE]
    n_jac = 0
    # the last update itself within the tolerance, as well as the iterate's
    # estimated error, with velocity-level rows or spatial frames; without,
    # an estimated error within KAPPA of it will do (newton.py)
    hold_update = (_constraint_rows(rec, _rows(I, MASS), _rows(I, ROW_ELEMENT))[2]
                   or (_rows(I, FROW) > 0 and rec[REG] == 0.0))
    for _ in range(max_iter):
        if not valid:
            p = _jacobian_triplets(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx,
                                   vx)
            counts[CNT_JACOBIANS] += 1
            n_jac += 1
            status = _factor(solver, lin, R, C, V, p)
            if status != CONVERGED:
                lu_state[LU_VALID] = 0.0
                return status
            counts[CNT_FACTORIZATIONS] += 1
            valid = True
            age = 0
        _residual(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work)
        counts[CNT_RESIDUALS] += 1
        for i in range(size):
            if not np.isfinite(r[i]):
                lu_state[LU_VALID] = 0.0
                return NONFINITE
        _solve(solver, lin, r, dw)
        norm, finite = _update(w, dw, weight, size)
        counts[CNT_ITERATIONS] += 1
        current = age == 0
        age += 1
        if not finite:
            lu_state[LU_VALID] = 0.0
            return NONFINITE
        if prev > 0.0:
            theta = norm / prev
        eta = max(theta / (1.0 - theta), 1e-2) if theta < 1.0 else np.inf
        stuck = prev >= 0.0 and norm >= max(0.5, rate_refresh) * prev   # newton.py's rule
        if current:
            stalls = stalls + 1 if norm >= 0.5 * best else 0
            best = min(best, norm)
        roundoff = stalls >= 2 and norm <= ROUNDOFF_BAND
        grows = grows + 1 if (prev >= 0.0 and theta >= 1.0 and current) else 0
        diverging = theta > 100.0 or (grows >= 2 and norm > ROUNDOFF_BAND)
        if ((stalls >= 2 or diverging) and not roundoff and norm > 1.0 and rec[REG] == 0.0
                and _rest_at_roundoff(rec, I, solver, lin, r, qx, vx, weight, spare)):
            for i in range(size):         # the iterate whose residual r was read
                w[i] += dw[i]
            roundoff = True
        within = norm <= 1.0 or (prev > 0.0 and not hold_update and eta * norm <= KAPPA)
        if norm == 0.0 or roundoff or (eta * norm <= 1.0 and within       # and newton.py's
                                       and _frames_held(rec, I, r)):        # frame test
            if roundoff:
                counts[CNT_STALLED] += 1
            lu_state[LU_RATE] = min(max(theta, 1e-3), 0.9) if np.isfinite(theta) else 0.5
            lu_state[LU_VALID] = 0.0 if full else 1.0
            return CONVERGED
        if diverging:
            lu_state[LU_VALID] = 0.0
            return DIVERGING
        from_earlier_step = n_jac == 0
        if (full or stuck or (from_earlier_step and prev >= 0.0 and theta > rate_refresh)
                or (norm <= ROUNDOFF_BAND and prev >= 0.0 and theta > 0.25)):
            valid = False
        prev = norm
    lu_state[LU_VALID] = 0.0
    return MAX_ITER


ROUNDOFF_ULPS = 8.0        # as in newton.py
KAPPA = 0.1                # as in newton.py


@_hot
def _update(w, dw, weight, size):
    """w -= dw, in one pass with the update's norm max_i |dw_i weight_i| and
    whether every new w_i is finite: (norm, finite). The maximum runs in four
    lanes, each a chain of its own (a single chain waits on each comparison:
    numba compiles without fast-math, so LLVM does not split it), and the
    finiteness is or-ed without a branch. The same norm as one lane: a
    maximum does not round."""
    n0, n1, n2, n3 = 0.0, 0.0, 0.0, 0.0
    bad = False
    i = 0
    while i + 4 <= size:
        n0 = max(n0, abs(dw[i] * weight[i]))
        n1 = max(n1, abs(dw[i + 1] * weight[i + 1]))
        n2 = max(n2, abs(dw[i + 2] * weight[i + 2]))
        n3 = max(n3, abs(dw[i + 3] * weight[i + 3]))
        for j in range(i, i + 4):
            w[j] -= dw[j]
            bad = bad | (not np.isfinite(w[j]))
        i += 4
    for j in range(i, size):
        n0 = max(n0, abs(dw[j] * weight[j]))
        w[j] -= dw[j]
        bad = bad | (not np.isfinite(w[j]))
    return max(max(n0, n1), max(n2, n3)), not bad


@_hot
def _constraint_rows(rec, n, m):
    """(first row of Phi, first row of Phi_q v + Phi_t, whether the latter
    are rows) in the residual of the recipe ``rec``: after the unknowns' rows,
    and the additive form's E3 and E4 after its 2n rows of dq and dv."""
    _, l0, u0, _ = _layout(rec, n, m)
    if rec[FORM] == ADDITIVE:
        return 2 * n, 2 * n + m, True
    return l0, u0, rec[HAS_Y] != 0.0


@_hot
def _frames_held(rec, I, r):
    """newton.py's test of the spatial bodies' frames at the iterate whose
    residual is r: every frame row |a_k . a_l - delta_kl| within FRAME_HOLD
    (its row of r is Phi scaled by sP), so that the update after it leaves
    them within FRAME_TOL. True without spatial bodies, and in the augmented
    formulation (its rows hold a regularized Phi)."""
    k = _rows(I, FROW)
    if k == 0 or rec[REG] != 0.0:
        return True
    l0, _, _ = _constraint_rows(rec, _rows(I, MASS), _rows(I, ROW_ELEMENT))
    tol = abs(rec[SP]) * FRAME_HOLD
    for i in range(k):
        if abs(r[l0 + _i(I, FROW, i, 0)]) > tol:
            return False
    return True


@_hot
def _rest_at_roundoff(rec, I, solver, lin, r, qx, vx, weight, spare):
    """newton.py's residual test of a stagnating exact-Newton iteration at
    the iterate whose residual is r (state in qx, vx): its constraint rows
    (Phi scaled by sP, at index 2 Phi_q v + Phi_t scaled by sV) within
    ROUNDOFF_ULPS ulps of their terms, and the update the other rows alone
    ask for, J^-1 r' (r' = r with those rows zeroed, in spare[:size]; the
    update in spare[size:]), within the tolerance. The additive form's
    constraint rows are its E3 and E4 (Phi scaled by sP and Phi_q v + Phi_t
    by sV, after the 2n rows of dq and dv: ``additive._residual_additive``)."""
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    if m == 0:
        return False
    size = _layout(rec, n, m)[0]
    l0, u0, velocity = _constraint_rows(rec, n, m)
    qmax, vmax = 0.0, 0.0
    for j in range(n):
        qmax = max(qmax, abs(qx[j]))
        vmax = max(vmax, abs(vx[j]))
    scale = ROUNDOFF_ULPS * EPS * (1.0 + qmax)
    for i in range(m):
        if abs(r[l0 + i]) > abs(rec[SP]) * scale:
            return False
    if velocity:
        for i in range(m):
            if abs(r[u0 + i]) > abs(rec[SV]) * scale * (1.0 + vmax):
                return False
    rest, dw = spare[:size], spare[size:2 * size]
    for i in range(size):
        rest[i] = r[i]
    for i in range(m):
        rest[l0 + i] = 0.0
    if velocity:
        for i in range(m):
            rest[u0 + i] = 0.0
    _solve(solver, lin, rest, dw)
    for i in range(size):
        if abs(dw[i] * weight[i]) > 1.0:
            return False
    return True
