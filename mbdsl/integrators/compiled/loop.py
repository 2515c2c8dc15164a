"""The compiled time loop: fixed and error-controlled steps, events, output
rows, with the contract of :mod:`mbdsl.integrators.loop` (``outcomes.py``).
"""

from __future__ import annotations

import math

import numpy as np

from mbdsl.integrators.outcomes import (CONVERGED, EVENT, LAND, REJECTED, RUN, TOLERANCE)
from mbdsl.integrators.records import (CNT_STEPS, CTL_ATOL, CTL_FIXED, CTL_H_MAX, CTL_H_MIN,
                                       CTL_INDEX1, CTL_MAX_FACTOR, CTL_MIN_FACTOR, CTL_RTOL,
                                       CTL_SAFETY, INDEX1_LIMIT, LU_C0, LU_STEP, LU_VALID,
                                       OPT_EXTRAPOLATE,
                                       ST_AFTER_REJECTION, ST_CARRY, ST_ERR, ST_H, ST_H_LAST,
                                       ST_LIMIT, ST_MODE, ST_RATIO, ST_REJECTED, ST_T)

from .additive import _minus_correction
from .index1 import _index1_acceleration, _index1_scratch, _scales_weights
from .layout import (ADDITIVE, CF, EABS, EAUX, ERR, FORM, KA1, KA2, MH, REG, Y0V, _advance,
                     _copy, _layout, _state, predict)
from .newton import _newton
from .recipes import _old_force
from ...kernels.geometry import MEMO
from ...kernels.jit import borrowed as _b
from ...kernels.loads.contact import WIDTH, _gap
from ...kernels.loads.spring_damper import _spring_passed
from ...kernels.programs import switch_branches
from ...kernels.schema import (EPS, FRI, KGI, MASS, ROW_ELEMENT, SCOL1, SPAR, SWP, _HEADER, _f,
                               _hot, _jit, _rows)


@_jit
def _workspace(n, m, size, I, plan):
    """The time loop's scratch arrays: (r, dw, w, weight, qx, vx, work,
    q_pred, v_pred, qx_old, F, scratch, plan), allocated by the caller once
    per run (``entry.workspace``) and lent to every call of ``_run``;
    ``plan`` (int64) is the caller's band plan of the index-1 accelerations
    (``index1._index1_scratch``: m + 1 entries, or none); ``work`` has 2 (n
    + 3) entries, the residual's two halves (``recipes._residual``), its
    first half the other kernels' force-sized scratch. The
    iterate's qx and the step start's qx_old carry the rotations' memo
    after their n + 3 entries (``kernels.geometry._cos_sin``; no angle
    remembered yet: NaN)."""
    qx, qx_old = np.zeros((MEMO + 1) * (n + 3)), np.zeros((MEMO + 1) * (n + 3))
    qx[n + 3:] = np.nan
    qx_old[n + 3:] = np.nan
    return (np.empty(size), np.empty(size), np.empty(size), np.empty(size), qx,
            np.zeros(n + 3), np.zeros(2 * (n + 3)), np.empty(n), np.empty(n), qx_old,
            np.zeros(n), np.empty(m + I[_HEADER - 1] + 2 * size), plan)


@_jit
def _start_force(rc, I, Fl, t0, q, v, lam, F0, F, qx, vx, work):
    """F_n at t0 into F (recipes with cF != 0): F0 when given (not NaN),
    else the law's at (q, v, lambda)."""
    if rc[CF] != 0.0:
        if F0.shape[0] == F.shape[0] and not math.isnan(F0[0]):
            F[:] = F0
        else:
            _old_force(rc, I, Fl, t0, q, v, lam, F, qx, vx, work)


@_hot
def _start_w(rc, I, Fl, q, a, v, lam, w, qx, y):
    """Newton's start: x = a_n, lambda_n; y = y0v v_n. The additive form:
    a = a_n, psi_I = psi_II = lambda_n, and dq, dv with the corrections of
    the step before, R_n = -M(q_n)^-1 Phi_q(q_n)^T lambda_n, in place of R_I
    and R_II (``HHTADD.predict``): dq = ka1 a_n + R_n / 2, dv = ka2 a_n +
    R_n. ``qx``, ``y``: scratch of size n + 3."""
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rc, n, m)
    w[:] = 0.0
    _copy(w, a0, a)
    _copy(w, l0, lam)
    if rc[FORM] == ADDITIVE:
        _copy(qx, 0, q)
        _minus_correction(I, Fl, qx, lam, y)          # y = -R_n
        for j in range(n):
            w[j] = rc[KA1] * a[j] - 0.5 * y[j]
            w[n + j] = rc[KA2] * a[j] - y[j]
        _copy(w, e0, lam)
    elif e0 < size:
        for j in range(n):
            w[n + j] = rc[Y0V] * v[j]


#: The largest ratio of two successive steps across which Newton's start is
#: extrapolated (``_extrapolated_start``); beyond it the last state's is taken.
START_RATIO = 2.0


@_hot
def _extrapolated_start(w, hx, hh, s, multipliers, l0, e0, m):
    """Newton's start of a step of size s (``_start_w``'s in w) with its
    kinematic unknowns moved to their extrapolation to t_n + s through the
    values the steps before it in this call converged to: hx (3, size) at
    t_n, t_n - h1 and t_n - h1 - h2 (newest first), hh = (how many, h1,
    h2); the quadratic through three, the line through two, by Lagrange's
    formula on the step sizes (each ratio of two neighbouring steps at most
    ``START_RATIO``). Returns False, w untouched, with fewer than two or
    steps too unequal.

    The converged step is the same (Newton's root, within its tolerance);
    the start only comes closer to it. Where the motion is smooth the
    accelerations (and the stabilized index-2 and additive forms' other
    kinematic unknowns) change by O(h) a step: the last state's start is
    O(h) away from the root and this one O(h^3), and the modified Newton
    iteration, contracting by a fixed rate, takes fewer iterations to reach
    its tolerance (docs/performance.md). The multipliers (rows l0 and, with
    a second block, e0, m each) move with them, unless ``multipliers`` is
    False (the augmented formulation): where Phi_q loses rank, only Phi_q^T
    lambda is unique there, the multipliers' part in the null space of
    Phi_q^T is set by the start alone, and extrapolated it grew by itself
    from step to step (to 1e5 N on a redundant joint,
    tests/regressions/test_redundant_restart.py)."""
    k, h1, h2 = int(hh[0]), hh[1], hh[2]
    if k < 2 or s > START_RATIO * h1 or h1 > START_RATIO * s:
        return False
    d1 = -h1                                    # the nodes relative to t_n: 0, d1, d2
    if k >= 3 and h2 <= START_RATIO * h1 and h1 <= START_RATIO * h2:
        d2 = d1 - h2
        c0 = (s - d1) * (s - d2) / (d1 * d2)
        c1 = s * (s - d2) / (d1 * (d1 - d2))
        c2 = s * (s - d1) / (d2 * (d2 - d1))
    else:
        c0, c1, c2 = (s - d1) / -d1, s / d1, 0.0
    for i in range(w.shape[0]):
        if not multipliers and (l0 <= i < l0 + m or e0 <= i < e0 + m):
            continue                                # the last state's multiplier
        w[i] = c0 * hx[0, i] + c1 * hx[1, i] + c2 * hx[2, i]
    return True


@_hot
def _push_start(w, hx, hh, s, on):
    """The unknowns w a step of size s converged to, newest, into the
    history of ``_extrapolated_start`` (nothing when ``on`` is False: a
    run on the last state's start)."""
    if not on:
        return
    for i in range(w.shape[0]):
        hx[2, i], hx[1, i], hx[0, i] = hx[1, i], hx[0, i], w[i]
    hh[0], hh[1], hh[2] = min(hh[0] + 1.0, 3.0), s, hh[1]


@_hot
def _step_newton(rc, I, Fl, t_new, q, v, a, lam, q_pred, v_pred, F, qx_old, w, weight, opts,
                 solver, lin, lu_state, R, C, V, r, dw, qx, vx, work, counts, scratch, hx, hh,
                 step, l0, e0):
    """Newton's iteration of a step of size ``step`` to t_new (``_newton``),
    with its weights (from the last state's start, ``_start_w``), from the
    extrapolated start (``_extrapolated_start``, unless ``opts`` says the
    last state's: ``NewtonOptions.start``) and, when it does not
    converge from there, once more from the last state's: a start that
    extrapolation moved across a change the steps did not resolve (a
    stick-slip transition, say) never fails a step the old start would
    take. l0, e0: where the multipliers start in w (``_layout``); ``work``:
    2 (n + 3), the residual's (``recipes._residual``). Returns Newton's
    status."""
    size = w.shape[0]
    status = CONVERGED
    for attempt in range(2):
        _start_w(rc, I, Fl, q, a, v, lam, w, qx, work[:work.shape[0] // 2])
        if attempt == 0:
            _scales_weights(rc, I, Fl, q, w, opts, R, C, V, qx, weight, scratch)
        moved = (attempt == 0 and opts[OPT_EXTRAPOLATE] != 0.0
                 and _extrapolated_start(w, hx, hh, step, rc[REG] == 0.0, l0, e0,
                                         lam.shape[0]))
        status = _newton(rc, I, Fl, t_new, q_pred, v_pred, F, qx_old, w, weight, opts, solver,
                         lin, lu_state, R, C, V, r, dw, qx, vx, work, counts,
                         scratch[scratch.shape[0] - 2 * size:])
        if status == CONVERGED or not moved:
            break
    return status


@_hot
def _record(rec, t, q, v, a, lam, mu, counts, out_t, out_q, out_v, out_a, out_lam, out_mu,
            out_stats):
    """Row ``rec`` of the out_* arrays: the state, and the Newton counts
    since the last record (then zeroed); returns rec + 1."""
    out_t[rec] = t
    _copy(out_q[rec], 0, q)
    _copy(out_v[rec], 0, v)
    _copy(out_a[rec], 0, a)
    _copy(out_lam[rec], 0, lam)
    _copy(out_mu[rec], 0, mu)
    for i in range(6):
        out_stats[rec, i] = counts[i]
    counts[:] = 0
    return rec + 1


@_jit
def _total_acceleration(I, Fl, n, qx, a, psi, R, C, V, out):
    """a - M(q)^{-1} Phi_q(q)^T psi into out (n,) [m/s^2 or rad/s^2] at qx:
    the additive form's total acceleration a + R (``HHTADD.local_error``);
    R, C, V: triplet scratch (unused)."""
    y = np.empty(n + 3)
    _minus_correction(I, Fl, qx, psi, y)
    for j in range(n):
        out[j] = a[j] - y[j]


@_jit
def _estimate_acceleration(I, Fl, n, m, t, qx, vx, a, psi, additive, index1, out, R, C, V,
                           est):
    """The acceleration at (t, qx, vx) whose change the step's error estimate
    reads, into out (n,) [m/s^2, rad/s^2]: the additive form's a + R_II
    (psi = psi_II), which sees the constraint forces, and with ``index1``
    the index-1 projection of it or of a (``_index1_acceleration``, in
    place; ``_run_flags`` says when; ``est``: its scratch); else nothing (the
    estimate reads a)."""
    if additive:
        _total_acceleration(I, Fl, n, qx, a, psi, R, C, V, out)
        if index1:
            _index1_acceleration(I, Fl, n, m, t, qx, vx, out, out, R, C, V, est)
    elif index1:
        _index1_acceleration(I, Fl, n, m, t, qx, vx, a, out, R, C, V, est)


@_jit
def _recipe_at(mono, h, c0, w0, w1, rec):
    """The recipe at step size h and BDF coefficients c0, w0, w1 from its
    monomials (``engine.recipe_monomials``, mono (5, F)): rec[i] =
    c h^a c0^b w0^c w1^d."""
    for i in range(rec.shape[0]):
        c = mono[0, i]
        rec[i] = (c * h ** mono[1, i] * c0 ** mono[2, i] * w0 ** mono[3, i] * w1 ** mono[4, i]
                  if c != 0.0 else 0.0)


@_jit
def _bdf_ratio(two_step, h, h_last):
    """(c0 [1/s], w0, w1) of a two-step recipe's step of size h [s] after one
    of h_last [s] (BDF2 of the ratio w = h / h_last: c0 = (1 + 2w)/((1 + w) h),
    w0 = (1 + w)^2/(1 + 2w), w1 = -w^2/(1 + 2w); BDF1, (1/h, 1, 0), when
    h_last is 0); (1, 1, 1) for a one-step recipe, which reads none of them."""
    if not two_step:
        return 1.0, 1.0, 1.0
    if h_last == 0.0:
        return 1.0 / h, 1.0, 0.0
    wr = h / h_last
    return ((1.0 + 2.0 * wr) / ((1.0 + wr) * h), (1.0 + wr) ** 2 / (1.0 + 2.0 * wr),
            -wr * wr / (1.0 + 2.0 * wr))


@_jit
def _event_scratch(n, I):
    """``_crossed``'s scratch: (qs, vs (n + 3,), grad6 (WIDTH,), H6 (WIDTH, WIDTH):
    a gap's, ``contact.WIDTH``, b0, b1 (rows of SWP,) int64)."""
    return (np.zeros(n + 3), np.zeros(n + 3), np.empty(WIDTH), np.empty((WIDTH, WIDTH)),
            np.empty(_rows(I, SWP), np.int64), np.empty(_rows(I, SWP), np.int64))


@_jit
def _crossed(I, Fl, n, t, t_new, q, v, qx, vx, gaps, springs, switches, ev):
    """Whether the step from (t, q, v) (n,) to (t_new, qx, vx) (n + 3,)
    changes the sign of a gap of the contacts and joint limits (``gaps``),
    takes the points of a spring-damper with a free length past each other
    (``springs``) or takes the argument of a table of the state past one of
    its kinks (``switches``: ``programs.switch_branches``): an event. ``ev``:
    scratch (``_event_scratch``)."""
    qs, vs, grad6, H6, b0, b1 = ev
    qs[:n] = q
    if springs and _spring_passed(I, Fl, qs, qx):
        return True
    for i in range(_rows(I, KGI) if gaps else 0):        # a gap opens or closes
        if (_gap(I, Fl, qs, i, grad6, H6) > 0.0) != (_gap(I, Fl, qx, i, grad6, H6) > 0.0):
            return True
    if switches:
        vs[:n] = v
        switch_branches(I, Fl, t, qs, vs, grad6, H6, b0)
        switch_branches(I, Fl, t_new, qx, vx, grad6, H6, b1)
        for s in range(b0.shape[0]):
            if b0[s] >= 0 and b1[s] >= 0 and b0[s] != b1[s]:
                return True
    return False


#: The step-size controller (``adaptive``): the order k of the error per unit
#: step in h, and the gains of Soderlind's H211b digital filter with b = 4
#: (G. Soderlind, "Digital filters in adaptive time-stepping", ACM TOMS 29
#: (2003) 1-26, sec. 6): beta1 = beta2 = 1/(b k), alpha2 = 1/b.
ERROR_ORDER = 2.0
H211B_BETA = 1.0 / (4.0 * ERROR_ORDER)
H211B_ALPHA = 0.25


@_jit
def step_ratio(err, err_last, ratio_last, safety, fmin, fmax):
    """The next step's size over this one's from the error per unit step
    ``err`` of this step (``_error_norm``) and, when both are positive, the
    last accepted step's ``err_last`` and the ratio ``ratio_last`` chosen
    after it: Soderlind's H211b filter

        r = (theta / err)^beta1 (theta / err_last)^beta2 ratio_last^(-alpha2),

    theta = safety^k (the filter's fixed point is err = theta), else the
    elementary controller (theta / err)^(1/k) (the first step, and after a
    rejection or an event); within [fmin, fmax]. An error of 0 gives fmax, a
    non-finite one fmin. Both steppers' rule (``_run``,
    ``python_stepper.PythonStepper``)."""
    if err == 0.0:
        return fmax
    if not math.isfinite(err):
        return fmin
    theta = safety ** ERROR_ORDER
    if err_last > 0.0 and ratio_last > 0.0:
        r = ((theta / err) ** H211B_BETA * (theta / err_last) ** H211B_BETA
             * ratio_last ** (-H211B_ALPHA))
    else:
        r = (theta / err) ** (1.0 / ERROR_ORDER)
    return min(fmax, max(fmin, r))


@_jit
def _error_norm(rc, n, q, qx, a_new, a, b, b_new, additive, acc_old, acc_new, rtol, atol, h,
                index1, d):
    """The error per unit step of a step of size h [s]: the weighted RMS norm
    of its local error estimate e = err d (``adaptive``: Hairer, Norsett &
    Wanner I, sec. II.4) over h / (1 s): d the change of the
    auxiliary acceleration b -> b_new when the recipe's ``eaux``, of HHT-ADD's
    a + R_II or of an index-3 recipe's index-1 acceleration when
    ``index1`` (acc_old -> acc_new), acc_new itself when ``eabs`` and
    ``index1``, a_new when ``eabs``, else a -> a_new; each entry over
    atol + rtol max(|q|, |q_new|), an entry's tolerance for the step never
    below the estimate's round-off, err / h^2 ulps of max(|q|, |q_new|)
    (``StepControl.norm``). d (n,): scratch."""
    if n == 0:
        return 0.0
    for j in range(n):
        if index1:
            d[j] = acc_new[j] if rc[EABS] != 0.0 else acc_new[j] - acc_old[j]
        elif rc[EAUX] != 0.0:
            d[j] = b_new[j] - b[j]
        elif additive:
            d[j] = acc_new[j] - acc_old[j]
        elif rc[EABS] != 0.0:
            d[j] = a_new[j]
        else:
            d[j] = a_new[j] - a[j]
    acc = 0.0
    noise = abs(rc[ERR]) / (h * h) * EPS       # the estimate's round-off per unit of |q|
    for j in range(n):
        size = max(abs(q[j]), abs(qx[j]))
        e = rc[ERR] * d[j] / max((atol + rtol * size) * h, noise * size)
        acc += e * e
    return math.sqrt(acc / n)


@_jit
def step_end(h, t, t_end, carry):
    """The next step of the time loop from t [s] towards t_end [s], of size h
    [s] at most: (step [s], its end time t_new [s], the new carry). The
    last step lands on t_end exactly and never leaves a sliver (under 1e-6
    of a step) before it; t_new is a compensated (Kahan) sum with
    ``carry``, the rounding error of the sum so far, so that t stays exact
    to round-off over 1e6 steps. Both steppers' rule (``_run``,
    ``python_stepper.PythonStepper``)."""
    step = min(h, t_end - t)
    if t_end - (t + step) < 1e-6 * step:
        step = t_end - t
    if step == t_end - t:
        return step, t_end, 0.0
    y = step - carry
    t_new = t + y
    return step, t_new, (t_new - t) - y


@_jit
def _run_flags(mono, I, Fl, rc, ctl, has_extra, mode, plan):
    """What a run of ``_run`` does besides its steps: (a two-step recipe,
    reading c0, w0, w1; the error estimated on the index-1 accelerations;
    events of gaps; events of spring-dampers with a free length; events of
    kinks of tables of the state).

    An index-3 recipe (no velocity constraints, not additive) takes its error
    estimate on its index-1 accelerations: the normal part of its own is the
    multipliers' round-off over beta h^2, which a tolerance per unit step
    would chase. So does the additive form, on its total acceleration a +
    R_II, whose normal part carries R_I's round-off, Phi(q_n)'s residual over
    h^2 / 2 (``HHTADD.estimate_on_index1``). Not where friction reads the
    multipliers (their oscillation then moves q: the estimate sees it).
    Rigid bodies with a band plan (``plan``, m + 1 entries) at any size, else up to
    ``INDEX1_LIMIT`` constraint rows (``index1._index1_acceleration``)."""
    two_step = False                    # a recipe reading c0, w0, w1
    for i in range(mono.shape[2]):
        two_step = two_step or mono[1, 2, i] != 0.0 or mono[1, 3, i] != 0.0 \
            or mono[1, 4, i] != 0.0
    fixed = ctl[CTL_FIXED] != 0.0
    m = _rows(I, ROW_ELEMENT)
    band = plan.shape[0] == m + 1
    index1 = (not fixed and ctl[CTL_INDEX1] != 0.0 and (rc[FORM] == ADDITIVE or not has_extra)
              and 0 < m and (band or m <= INDEX1_LIMIT) and _rows(I, FRI) == 0)
    gaps = _rows(I, KGI) > 0 and mode != LAND
    springs = False                     # spring-dampers with a free length
    for i in range(_rows(I, SCOL1)):
        springs = springs or (_f(I, Fl, SPAR, i, 2) > 0.0 and mode != LAND)
    switches = _rows(I, SWP) > 0 and mode != LAND
    return two_step, index1, gaps, springs, switches


@_jit
def _start_estimate(I, Fl, n, m, t0, q, v, a, lam, additive, fixed, index1, qx_old, vx, R, C,
                    V, plan):
    """The acceleration the first step's error estimate compares with, at the
    last accepted state (the additive form's a + R_II, or the index-1
    acceleration), its successor's array and the index-1 acceleration's
    scratch (``index1._index1_scratch``, on the band ``plan`` when it holds
    one): (acc_old, acc_new, est)."""
    acc_old, acc_new = np.empty(n), np.empty(n)     # at the last accepted state, then carried
    est = _index1_scratch(I, Fl, n, m, index1 and m <= INDEX1_LIMIT,
                          plan if index1 else plan[:0], R, C, V)
    if not fixed:
        qx_old[:n] = q
        if index1:
            vx[:n] = v
        _estimate_acceleration(I, Fl, n, m, t0, qx_old, vx, a, lam, additive, index1, acc_old,
                               R, C, V, est)
    return acc_old, acc_new, est


@_jit
def _run(mono, I, Fl, h, t0, t_end, step0, every, q, v, a, b, lam, mu, q_prev, v_prev,
         ctl, opts, solver, lin, lu_state, R, C, V, out_t, out_h, out_q, out_v, out_a,
         out_lam, out_mu, out_stats, counts, F0, state, trial, ws):
    """The compiled time loop: steps of every method, fixed or error-controlled,
    from (t0, q, v, a, b, lam, mu) towards t_end, until t_end, a step that
    fails, an event, or the out_* arrays are full.

    ``mu`` (m,) holds the method's extra multipliers (mu, or HHT-ADD's
    psi_I), ``b`` (n,) the auxiliary acceleration of the recipes that carry
    one (generalized-alpha). The state arrays are updated in place after
    every accepted step, so that they hold the last accepted state when
    the loop returns.

    ``mono`` (2, 5, len(RECIPE_FIELDS)): the recipe's monomials for a
    start-up step and the steps after it (``engine.recipe_monomials``); a
    recipe that reads c0, w0, w1 (BDF2) takes them from the ratio
    w = h / h_prev of this step to the last one, c0 = (1 + 2w)/((1 + w) h),
    w0 = (1 + w)^2/(1 + 2w), w1 = -w^2/(1 + 2w), and its start-up
    coefficients (BDF1: 1/h, 1, 0) while there is no last step;
    ``q_prev``, ``v_prev`` the state before (q, v). The recipe is evaluated
    again only when h or these coefficients change. ``lu_state`` (4,) =
    (factorization valid, contraction rate (``_newton``), the step h and c0
    it was made for): a step of another h or c0 takes a new Newton matrix.

    ``ctl`` = (rtol, atol, safety, min_factor, max_factor, h_min, h_max,
    fixed). Error control (fixed = 0): after each converged step the local
    error estimate e = err (x - x_n) (on b when ``eaux``; err x when
    ``eabs``; HHT-ADD's the change of a + R_II) is measured per unit step,
    E = ||e||_RMS,w / (h / 1 s) (``_error_norm``); E > 1 rejects the step
    (retried with h max(min_factor, safety E^(-1/2))), else it is accepted
    and the next h follows the H211b filter (``step_ratio``; not growing
    right after a rejection); a step Newton cannot converge is not halved
    here. Fixed steps (fixed = 1): steps of h, the last one
    shortened to land on t_end; no error estimate. Either way a step Newton
    cannot converge ends the call at once (its Newton status, with the
    step's size in state[ST_H]): halving, the augmented formulation's jump and
    any hand-over are the time loop's (``loop.TimeLoop``, ``loop.StepSizes``;
    this loop is its ``engine.KernelStepper``).

    Every ``every``-th accepted step (global number step0 + k) and the last
    one are recorded in the out_* arrays with their step size in out_h and
    the Newton counts summed since the previous record (out_stats columns:
    iterations, residuals, jacobians, factorizations, stalled steps,
    steps); ``counts`` (6,) carries those sums between records and calls.
    R, C, V are triplet buffers of ``triplet_bound(md)`` entries. ``F0``
    (n,): F_n at t0 when F0[0] is not NaN (a start whose forces are not the
    law's at (q, v, lambda): friction's Coulomb limit, ``InitialState.Q``).

    ``state`` (10,) in/out: (t, h of the next step, rejected steps, h of the
    last step or 0, mode, the compensation of the sum t, 1 when the last
    attempt was rejected (the next accepted step does not grow h), the
    number of accepted steps this call may take or 0 for no limit, the last
    accepted step's error per unit step E or 0 (none: the step-size filter
    restarts), the step ratio chosen after it).
    Returns (status, steps, records): CONVERGED, a Newton status (a step
    that does not converge), TOLERANCE (the error above 1 at h_min), EVENT
    or REJECTED below.

    Events: a converged step that changes the sign of a gap of the contacts
    and joint limits (KGI), or across which the points of a spring-damper
    with a free length pass each other or the argument of a table of the
    state passes one of its kinks (SWP), is not taken; the loop returns EVENT
    with its end (q, v) in ``trial`` (2, n) and its size in state[ST_H], for
    the time loop to land a step on the event (``events.EventLocator``).
    ``ws``: the Newton iteration's scratch (``_workspace``), the caller's.
    Mode (state[ST_MODE]) RUN goes on until t_end, an event, a failure or a full
    output; ATTEMPT and LAND make one attempt at a step of h (with error
    control halved while Newton fails) and return: EVENT (ATTEMPT only),
    REJECTED (its error estimate: the next h in state[ST_H]) or CONVERGED with
    the step taken; LAND takes a step across an event.

    Python calls this loop (``entry.run``), which works on its arrays as
    borrowed views (``kernels.jit.borrowed``): the caller holds them for the
    call, and the kernels below count no references to them."""
    (mono, I, Fl, q, v, a, b, lam, mu, q_prev, v_prev, ctl, opts, lu_state, R, C, V, out_t,
     out_h, out_q, out_v, out_a, out_lam, out_mu, out_stats, counts, F0, state, trial) = _b((
        mono, I, Fl, q, v, a, b, lam, mu, q_prev, v_prev, ctl, opts, lu_state, R, C, V, out_t,
        out_h, out_q, out_v, out_a, out_lam, out_mu, out_stats, counts, F0, state, trial))
    lin, ws = _b(lin), _b(ws)
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    rc = np.empty(mono.shape[2])
    _recipe_at(mono[1], 1.0, 1.0, 1.0, 1.0, rc)
    size, l0, e0, a0 = _layout(rc, n, m)
    has_extra = e0 < size
    rtol, atol, safety = ctl[CTL_RTOL], ctl[CTL_ATOL], ctl[CTL_SAFETY]
    fmin, fmax = ctl[CTL_MIN_FACTOR], ctl[CTL_MAX_FACTOR]
    h_min, h_max = ctl[CTL_H_MIN], ctl[CTL_H_MAX]
    fixed = ctl[CTL_FIXED] != 0.0
    r, dw, w, weight, qx, vx, wide, q_pred, v_pred, qx_old, F, scratch, plan = ws
    b_new, d_err = np.empty(n), np.empty(n)
    hx, hh = np.zeros((3, size)), np.zeros(3)     # the steps' w Newton's start extrapolates
    mode = int(state[ST_MODE])
    two_step, index1, gaps, springs, kinks = _run_flags(mono, I, Fl, rc, ctl, has_extra, mode, plan)
    ev = _event_scratch(n, I)
    additive = rc[FORM] == ADDITIVE
    acc_old, acc_new, est = _start_estimate(I, Fl, n, m, t0, q, v, a, lam, additive, fixed,
                                            index1, qx_old, vx, R, C, V, plan)
    _start_force(rc, I, Fl, t0, q, v, lam, F0, F, qx, vx, wide[:n + 3])   # half of it
    t = t0
    # the step, start-up flag and c0, w0, w1 of the recipe in rc
    h_rc, first_rc, c0_rc, w0_rc, w1_rc = -1.0, False, -1.0, -1.0, -1.0
    # the last attempt, before this call, was rejected
    after_rejection = state[ST_AFTER_REJECTION] != 0.0
    limit = int(state[ST_LIMIT])                 # accepted steps this call may take (0: no limit)
    rec, k = 0, 0                                # records written, steps accepted
    while t < t_end - 1e-12 * (t_end - t0) and rec < out_t.shape[0]:
        step, t_new, carry = step_end(h, t, t_end, state[ST_CARRY])
        first = two_step and state[ST_H_LAST] == 0.0
        c0, w0, w1 = _bdf_ratio(two_step, step, state[ST_H_LAST])
        if step != h_rc or first != first_rc or c0 != c0_rc or w0 != w0_rc or w1 != w1_rc:
            _recipe_at(mono[0] if first else mono[1], step, c0, w0, w1, rc)
            h_rc, first_rc, c0_rc, w0_rc, w1_rc = step, first, c0, w0, w1
        if step != lu_state[LU_STEP] or c0 != lu_state[LU_C0]:  # the Newton matrix depends on them
            lu_state[LU_VALID] = 0.0
            lu_state[LU_STEP], lu_state[LU_C0] = step, c0
        predict(rc, first, q, v, a, b, q_prev, v_prev, q_pred, v_pred)
        for j in range(n):                 # q_n (the additive form), or Mhat's q_n + mh v_n
            qx_old[j] = q[j] + rc[MH] * v[j]
        status = _step_newton(rc, I, Fl, t_new, q, v, a, lam, q_pred, v_pred, F, qx_old, w,
                              weight, opts, solver, lin, lu_state, R, C, V, r, dw, qx, vx, wide,
                              counts, scratch, hx, hh, step, l0, e0)
        if status != CONVERGED:       # the driver decides: halve, jump, or hand over
            state[ST_T], state[ST_H] = t, step
            state[ST_AFTER_REJECTION] = 1.0 if after_rejection else 0.0
            return status, k, rec
        _state(rc, n, w, q_pred, v_pred, qx, vx)
        # an event within the step: the caller lands a step on it
        if (gaps or springs or kinks) and _crossed(I, Fl, n, t, t_new, q, v, qx, vx, gaps,
                                                   springs, kinks, ev):
                trial[0, :] = qx[:n]
                trial[1, :] = vx[:n]
                state[ST_T], state[ST_H] = t, step
                return EVENT, k, rec
        # the local error estimate and its weighted RMS norm
        if rc[EAUX] != 0.0:
            b_new[:] = b
            _advance(rc, b_new, a, w[a0:a0 + n])
        err, factor = 0.0, fmax
        if not fixed:
            _estimate_acceleration(I, Fl, n, m, t_new, qx, vx, w[a0:a0 + n], w[l0:l0 + m],
                                   additive, index1, acc_new, R, C, V, est)
            err = _error_norm(rc, n, q, qx, w[a0:a0 + n], a, b, b_new, additive, acc_old,
                              acc_new, rtol, atol, step, index1, d_err)
            if err > 1.0 or after_rejection:        # the filter restarts after a rejection
                state[ST_ERR] = 0.0
            factor = step_ratio(err, state[ST_ERR], state[ST_RATIO], safety, fmin, fmax)
        if err > 1.0:
            if step <= h_min * (1.0 + 1e-9):
                state[ST_T], state[ST_H] = t, step
                return TOLERANCE, k, rec
            state[ST_REJECTED] += 1.0
            h = max(step * min(factor, 1.0), h_min)
            after_rejection = True
            if mode != RUN:
                state[ST_T], state[ST_H], state[ST_AFTER_REJECTION] = t, h, 1.0
                return REJECTED, k, rec
            continue
        if after_rejection:
            factor = min(factor, 1.0)
        after_rejection = False
        if not fixed:
            state[ST_ERR], state[ST_RATIO] = err, factor
        q_prev[:] = q
        v_prev[:] = v
        _push_start(w, hx, hh, step, opts[OPT_EXTRAPOLATE] != 0.0)
        state[ST_H_LAST] = step
        q[:] = qx[:n]
        v[:] = vx[:n]
        if rc[EAUX] != 0.0:
            b[:] = b_new
        else:
            _advance(rc, b, a, w[a0:a0 + n])
        if additive or index1:
            acc_old[:] = acc_new
        a[:] = w[a0:a0 + n]
        lam[:] = w[l0:l0 + m]
        if has_extra:
            mu[:] = w[e0:e0 + m]
        t = t_new
        state[ST_CARRY] = carry
        if rc[CF] != 0.0:                  # F_n enters the next residual only through cF
            _old_force(rc, I, Fl, t, q, v, lam, F, qx, vx, wide[:n + 3])
        counts[CNT_STEPS] += 1
        k += 1
        if not fixed:
            # a step shortened to land on t_end (a segment's end: a switch of a function
            # of time) leaves the size planned before it for the next stretch
            h = max(min(step * factor, h_max), h if t >= t_end - 1e-12 * (t_end - t0) else 0.0)
        if (step0 + k) % every == 0 or t >= t_end - 1e-12 * (t_end - t0):
            out_h[rec] = step
            rec = _record(rec, t, q, v, a, lam, mu, counts, out_t, out_q, out_v, out_a, out_lam,
                          out_mu, out_stats)
        if mode != RUN or k == limit:
            break
    state[ST_T], state[ST_H], state[ST_AFTER_REJECTION] = t, h, 1.0 if after_rejection else 0.0
    return CONVERGED, k, rec
