"""The residual Upsilon(w) and Newton matrix of a recipe, for the linear family
(Newmark, HHT, NSTIFF, generalized-alpha, at index 3 or stabilized index 2);
HHT-ADD's additive form is :mod:`.additive`.
"""

from __future__ import annotations

from .additive import _jacobian_additive, _mass_solve, _residual_additive
from .layout import (ADDITIVE, CF, CM, CQX, CQY, CVX, CVY, DI, DM, DV, FORM, HAS_Y, MH, REG, SP, SV,
                     _copy, _emit_identity, _layout, _state)
from ...kernels.beams.ffr import FFR_MXQ, _beam_mass_add, _emit_beams
from ...kernels.loads.friction import _emit_friction_lam
from ...kernels.schema import BEAM, FRI, MASS, MRIG, ROW_ELEMENT, _0, _NO, _YES, _f, _hot, _jit, _rows
from ...kernels.system import (_emit_G, _emit_force, _emit_hess, _emit_mass, _emit_phiq,
                               _phi_time_add, forces, phi, phi_phiqT_add, phiq_products,
                               phiqT_add, phiq_times)


@_hot
def _residual(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work):
    """Upsilon(w) of the recipe ``rec``, size n + m (index 3), 2 (n + m)
    (stabilized index 2) or 3 n + 2 m (additive form).

    ``qx``, ``vx`` are scratch vectors of size n + 3 (ground entries zero),
    ``work`` of n + 3 or 2 (n + 3): with the second half, the stabilized
    index-2 residual's products Phi_q^T lambda, Phi_q^T mu and Phi_q v are
    made in one pass over the rows (``system.phiq_products``; the same
    numbers); ``qx_old`` the extended q_n + mh v_n (the additive form's q_n
    of Phi_q(q_n), or where a held Mhat is evaluated). The same equations as
    each method's numpy ``residual`` (the additive form's rows 1, 2 and 5
    multiplied by M).
    """
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    wk = work[:n + 3]
    if rec[FORM] == ADDITIVE:
        _residual_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, wk)
        return
    size, l0, u0, a0 = _layout(rec, n, m)
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    cM, cF = rec[CM], rec[CF]
    qM = qx_old if rec[MH] != 0.0 else qx      # M held at q_n + mh v_n, or M(q)
    forces(I, Fl, t, qx, vx, w[l0:l0 + m], wk)
    for j in range(n):
        wk[j] = -wk[j]
    fused = rec[HAS_Y] != 0.0 and work.shape[0] >= 2 * (n + 3)
    mw = work[n + 3:2 * (n + 3)] if fused else wk     # Phi_q^T mu
    if fused:
        for j in range(n + 3):
            mw[j] = 0.0
        phiq_products(I, Fl, qx, vx, w[l0:l0 + m], w[u0:], wk, mw, r[u0:])
        phi(I, Fl, t, qx, r[l0:l0 + m])
    else:                               # Phi and Phi_q^T lambda in one pass
        phi_phiqT_add(I, Fl, t, qx, w[l0:l0 + m], r[l0:l0 + m], wk)
    for j in range(n):
        r[j] = cM * _f(I, Fl, MRIG, j, 0) * w[j] + wk[j] - cF * F_old[j]
    if _rows(I, BEAM) > 0:
        _beam_mass_add(I, Fl, qM, w, cM, r)
    sP = rec[SP]
    for i in range(m):
        r[l0 + i] *= sP
    if rec[HAS_Y] != 0.0:
        dM, dI, dV = rec[DM], rec[DI], rec[DV]
        if not fused:
            mw[:] = 0.0
            phiqT_add(I, Fl, qx, w[u0:], 1.0, mw)
        for j in range(n):
            r[n + j] = (dM * _f(I, Fl, MRIG, j, 0) + dI) * w[n + j] + dV * vx[j] + mw[j]
        if dM != 0.0 and _rows(I, BEAM) > 0:
            _beam_mass_add(I, Fl, qM, w[n:2 * n], dM, r[n:2 * n])
        if not fused:
            phiq_times(I, Fl, qx, vx, r[u0:])
        _phi_time_add(I, Fl, t, r[u0:], 1)
        sV = rec[SV]
        for i in range(m):
            r[u0 + i] *= sV


@_hot
def _jacobian_triplets(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx, vx):
    """Newton matrix entries (R, C, V) of the recipe ``rec``, in an order and
    pattern fixed by the model and the method; returns their count.
    Duplicates are summed by the caller.

    The chain rule on ``_residual``: with K(u) = (Phi_q^T u)_q and
    G = (Phi_q v)_q,
    d R1/dx = cM M + cqx (K(lambda) - Q_q) - cvx Q_v, d R1/dy likewise with
    cqy, cvy; d R2/dx = cqx K(mu) + dV cvx I, d R2/dy = dM M + (dI + dV cvy) I
    + cqy K(mu); d R3/d(x, y) = sP (cqx, cqy) Phi_q; d R4/d(x, y) = sV (cvx
    Phi_q + cqx G, cvy Phi_q + cqy G); Phi_q^T in the multiplier columns.
    With flexible beams and M(q) not held (mh = 0) d R1/dx gains cM cqx (M
    x)_q, d R1/dy cM cqy (M x)_q, and d R2/d(x, y) dM (cqx, cqy) (M y)_q.
    Zero coefficients are structural (the same for every h of a method) and
    emit nothing.
    """
    if rec[FORM] == ADDITIVE:
        return _jacobian_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx,
                                  vx)
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, u0, a0 = _layout(rec, n, m)
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    cqx, cvx, sP = rec[CQX], rec[CVX], rec[SP]
    lam = w[l0:l0 + m]
    held = rec[MH] != 0.0                  # M held at q_n + mh v_n: no (M x)_q
    beams = _rows(I, BEAM) > 0 and not held
    p = 0
    p = _emit_mass(I, Fl, n, qx_old if held else qx, R, C, V, p, _0, _0, rec[CM])
    if beams and cqx != 0.0:               # (M(q) x)_q
        p = _emit_beams(I, Fl, qx, vx, w, FFR_MXQ, R, C, V, p, _0, _0, rec[CM] * cqx, 0.0)
    if cqx != 0.0:
        p = _emit_hess(I, Fl, n, qx, lam, R, C, V, p, _0, _0, cqx)
    p = _emit_force(I, Fl, t, n, qx, vx, lam, R, C, V, p, _0, _0, cqx, cvx)
    p = _emit_phiq(I, Fl, n, qx, R, C, V, p, _0, l0, 1.0, _YES)
    if _rows(I, FRI) > 0:                  # Phi_q^T - Q_lambda: friction reads lambda
        p = _emit_friction_lam(I, Fl, n, qx, vx, lam, R, C, V, p, _0, l0, 1.0)
    if cqx != 0.0:
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, l0, _0, sP * cqx, _NO)
    if rec[REG] != 0.0:                    # the augmented formulation: -epsilon I
        p = _emit_identity(m, R, C, V, p, l0, l0, -rec[REG])
    if rec[HAS_Y] != 0.0:
        cqy, cvy, sV, dM, dI, dV = rec[CQY], rec[CVY], rec[SV], rec[DM], rec[DI], rec[DV]
        mu = w[u0:]
        y = w[n:2 * n]
        if beams and cqy != 0.0:
            p = _emit_beams(I, Fl, qx, vx, w, FFR_MXQ, R, C, V, p, _0, n, rec[CM] * cqy, 0.0)
        if beams and dM != 0.0:
            if cqx != 0.0:
                p = _emit_beams(I, Fl, qx, vx, y, FFR_MXQ, R, C, V, p, n, _0, dM * cqx, 0.0)
            if cqy != 0.0:
                p = _emit_beams(I, Fl, qx, vx, y, FFR_MXQ, R, C, V, p, n, n, dM * cqy, 0.0)
        if cqy != 0.0:
            p = _emit_hess(I, Fl, n, qx, lam, R, C, V, p, _0, n, cqy)
        if cqy != 0.0 or cvy != 0.0:
            p = _emit_force(I, Fl, t, n, qx, vx, lam, R, C, V, p, _0, n, cqy, cvy)
        if cqx != 0.0:
            p = _emit_hess(I, Fl, n, qx, mu, R, C, V, p, n, _0, cqx)
        if dV * cvx != 0.0:
            p = _emit_identity(n, R, C, V, p, n, _0, dV * cvx)
        if dM != 0.0:
            p = _emit_mass(I, Fl, n, qx_old if held else qx, R, C, V, p, n, n, dM)
        if dI + dV * cvy != 0.0:
            p = _emit_identity(n, R, C, V, p, n, n, dI + dV * cvy)
        if cqy != 0.0:
            p = _emit_hess(I, Fl, n, qx, mu, R, C, V, p, n, n, cqy)
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, n, u0, 1.0, _YES)
        if cqy != 0.0:
            p = _emit_phiq(I, Fl, n, qx, R, C, V, p, l0, n, sP * cqy, _NO)
        if cvx != 0.0:
            p = _emit_phiq(I, Fl, n, qx, R, C, V, p, u0, _0, sV * cvx, _NO)
        if cqx != 0.0:
            p = _emit_G(I, Fl, n, qx, vx, R, C, V, p, u0, _0, sV * cqx)
        if cvy != 0.0:
            p = _emit_phiq(I, Fl, n, qx, R, C, V, p, u0, n, sV * cvy, _NO)
        if cqy != 0.0:
            p = _emit_G(I, Fl, n, qx, vx, R, C, V, p, u0, n, sV * cqy)
    return p


@_hot
def _old_force(rec, I, Fl, t, q, v, lam, out, qx, vx, work):
    """F_n of the recipe into out (n,): Phi_q^T lambda - Q (linear form),
    -M(q)^-1 Q (additive form: minus HHT-ADD's f_n)."""
    if rec[FORM] == ADDITIVE:
        n = q.shape[0]
        _copy(qx, 0, q)
        _copy(vx, 0, v)
        forces(I, Fl, t, qx, vx, lam, work)
        for j in range(n):
            work[j] = -work[j]
        _mass_solve(I, Fl, qx, work, out)
    else:
        _force_term(I, Fl, t, q, v, lam, out, qx, vx, work)


@_jit
def accumulate(V, count, position, data):
    """data[position[i]] += V[i] for the first ``count`` triplets (data zeroed
    first): the values of a sparse matrix on its fixed pattern."""
    data[:] = 0.0
    for i in range(count):
        data[position[i]] += V[i]


@_hot
def _force_term(I, Fl, t, q, v, lam, out, qx, vx, work):
    """Phi_q^T lambda - Q(q, v) into out (n,) (``common.force_term``)."""
    n = q.shape[0]
    _copy(qx, 0, q)
    _copy(vx, 0, v)
    forces(I, Fl, t, qx, vx, lam, work)
    for j in range(n + 3):
        work[j] = -work[j]
    phiqT_add(I, Fl, qx, lam, 1.0, work)
    _copy(out, 0, work[:n])
