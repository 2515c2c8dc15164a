"""The index-1 quantities of the compiled engine: multipliers and accelerations
from M a + Phi_q^T lambda = Q, Phi_q a = gamma (Haug, sec. 6.3), the
multipliers' mobility, and the scales and weights of Newton's norm.
"""

from __future__ import annotations

import numpy as np

from .additive import _minus_correction
from .layout import ADDITIVE, FLOOR, FORM, HAS_Y, MU_MOB, REG, SM, SX, SY, _copy, _layout
from .band import NO_RECIPROCAL, _band_cholesky, _band_cholesky_solve
from mbdsl.integrators.records import (OPT_ATOL_KINEMATIC, OPT_ATOL_MULTIPLIER, OPT_RTOL)
from ...kernels.schema import (EPS, FRI, MASS, ROW_ELEMENT, _0, _HEADER, _NO, _YES, _f, _i, _hot, _jit,
                               _rows)
from ...kernels.system import _emit_G, _emit_mass, _emit_phiq, _phi_time_add, forces, phiq_times


@_jit
def _index1_gamma(I, Fl, t, qx, vx, gam, R, C, V):
    """-gamma = (Phi_q v)_q v + Phi_tt into gam (m,) at (t, qx, vx) (Haug, sec. 6.3)."""
    n = _rows(I, MASS)
    gam[:] = 0.0
    _phi_time_add(I, Fl, t, gam, 2)
    p = _emit_G(I, Fl, n, qx, vx, R, C, V, _0, _0, _0, 1.0)
    for i in range(p):
        gam[R[i]] += V[i] * vx[C[i]]


@_jit
def _column_groups(C, p, n):
    """(by_col, start) of the triplets C[:p] of a fixed pattern grouped by
    column: the entries of column j are by_col[start[j]:start[j + 1]]."""
    by_col = np.argsort(C[:p], kind="mergesort")
    start = np.zeros(n + 1, np.int64)
    for i in range(p):
        start[C[i] + 1] += 1
    for j in range(n):
        start[j + 1] += start[j]
    return by_col, start


@_hot
def _schur_band(R, V, by_col, start, place, minv, AB, kd):
    """A = Phi_q M^-1 Phi_q^T (m x m, M a constant diagonal of inverse minv
    (n,)) from Phi_q's triplets R, V grouped by column (``_column_groups``),
    row i of Phi_q at place[i], into AB (m, kd + 1) in LAPACK's "U" band
    storage (A(i, j), i <= j, at AB[j, kd + i - j]), factored in place by
    ``band._band_cholesky``. False when an entry falls outside the band,
    A is not positive definite, or a pivot U_kk^2 is below 1e-13 of the
    largest: dependent rows (redundant joints, a singular position) leave a
    pivot of round-off (3e-15 of the largest on a parallelogram with a
    redundant link), which a Cholesky accepts."""
    m = AB.shape[0]
    AB[:, :] = 0.0
    for col in range(start.shape[0] - 1):
        for x in range(start[col], start[col + 1]):
            ex = by_col[x]
            i = place[R[ex]]
            for y in range(start[col], start[col + 1]):
                ey = by_col[y]
                j = place[R[ey]]
                if i <= j:
                    if j - i > kd:
                        return False
                    AB[j, kd + i - j] += V[ex] * V[ey] * minv[col]
    if not _band_cholesky(AB, _0, m, kd, kd):
        return False
    dmin, dmax = np.inf, 0.0
    for k in range(m):
        d = AB[k, kd] * AB[k, kd]
        dmin, dmax = min(dmin, d), max(dmax, d)
    return dmin >= 1e-13 * dmax


@_jit
def _band_places(I, Fl, n, order):
    """(place, minv) of the band Schur complement: row order[k] of Phi_q at
    place[order[k]] = k (m,), and 1 / M_jj (n,) of the rigid bodies'
    constant diagonal mass [1/kg, 1/(kg m^2)]."""
    m = order.shape[0]
    place = np.empty(m, np.int64)
    for k in range(m):
        place[order[k]] = k
    minv = np.empty(n)
    for j in range(n):
        minv[j] = 1.0 / _f(I, Fl, MASS, j, 0)
    return place, minv


@_jit
def _index1_multipliers_band(I, Fl, t, q, v, out, R, C, V, iterations, order, kd, acc):
    """The index-1 multipliers of ``_index1_multipliers`` for rigid bodies
    (M a constant diagonal) from the Schur complement

        A lambda = Phi_q M^-1 Q - gamma,    A = Phi_q M^-1 Phi_q^T (m x m, SPD),

    the constraint rows reordered by ``order`` (position k holds row
    order[k]) so that A is a band of half-width kd, factored by the band
    Cholesky of ``band._band_cholesky`` (``_schur_band``). A chain of N
    links costs O(N) per row instead of the O((n + m)^3) of the dense
    index-1 matrix. Friction: the fixed point of ``_index1_multipliers`` on
    the same factorization. A matrix that is not positive definite, or whose
    Cholesky pivots (U_kk^2) fall below 1e-13 of the largest (redundant
    joints, a singular position), gives NaN for that row.

    With ``acc`` of N rows (else of none), also the accelerations these
    multipliers give, a = M^-1 (Q - Phi_q^T lambda), into it (N, n)
    (``AssembledSystem.accelerations``, from the Phi_q and Q at hand), NaN
    where the multipliers are."""
    n, m = q.shape[1], out.shape[1]
    with_acc = acc.shape[0] == q.shape[0]
    qx, vx, work = np.zeros(n + 3), np.zeros(n + 3), np.zeros(n + 3)
    AB, b, gam, lam = np.empty((m, kd + 1)), np.empty(m), np.empty(m), np.zeros(m)
    place, minv = _band_places(I, Fl, n, order)
    friction = _rows(I, FRI) > 0
    by_col = np.empty(0, np.int64)
    start = np.zeros(n + 1, np.int64)
    for row in range(q.shape[0]):
        for j in range(n):
            qx[j], vx[j] = q[row, j], v[row, j]
        _index1_gamma(I, Fl, t[row], qx, vx, gam, R, C, V)    # before R, C, V hold Phi_q
        p = _emit_phiq(I, Fl, n, qx, R, C, V, _0, _0, _0, 1.0, _NO)
        if row == 0:               # the pattern is fixed: entries grouped by column once
            by_col, start = _column_groups(C, p, n)
        ok = _schur_band(R, V, by_col, start, place, minv, AB, kd)
        lam[:] = 0.0
        settled = False
        for sweep in range(iterations if (friction and ok) else (1 if ok else 0)):
            forces(I, Fl, t[row], qx, vx, lam, work)
            for k in range(m):
                b[k] = gam[order[k]]            # Phi_q M^-1 Q - gamma, reordered
            for e in range(p):
                b[place[R[e]]] += V[e] * minv[C[e]] * work[C[e]]
            _band_cholesky_solve(AB, _0, m, kd, kd, b, _0, NO_RECIPROCAL)
            change, big = 0.0, 0.0
            for k in range(m):
                xk = b[place[k]]
                change = max(change, abs(xk - lam[k]))
                big = max(big, abs(xk))
                lam[k] = xk
            if not friction or change <= 1e-13 * (1.0 + big):
                settled = True
                break
        for k in range(m):
            out[row, k] = lam[k] if settled and np.isfinite(lam[k]) else np.nan
        if with_acc:
            if friction and settled:          # Q at the multipliers the sweeps settled on
                forces(I, Fl, t[row], qx, vx, lam, work)
            for j in range(n):
                acc[row, j] = work[j]
            for e in range(p):
                acc[row, C[e]] -= V[e] * lam[R[e]]
            for j in range(n):
                # divided, as AssembledSystem.accelerations does
                acc[row, j] = acc[row, j] / _f(I, Fl, MASS, j, 0) if settled else np.nan


@_jit
def _index1_multipliers(I, Fl, t, q, v, out, R, C, V, iterations):
    """The Lagrange multipliers of the index-1 system at each row into out
    (N, m): [[M(q), Phi_q^T], [Phi_q, 0]] [a; lambda] = [Q(t, q, v,
    lambda); gamma], gamma = -(Phi_q v)_q v - Phi_tt (Haug, sec. 6.3;
    ``AssembledSystem.index1_multipliers``). With friction Q reads lambda:
    up to ``iterations`` fixed-point sweeps from lambda = 0, to a change of
    1e-13 relative (``AssembledSystem.index1_solve``). A singular matrix, or
    friction that does not settle, gives NaN for that row. Rows: t (N,), q,
    v (N, n); R, C, V triplet scratch of ``triplet_bound`` entries."""
    n, m = q.shape[1], out.shape[1]
    size = n + m
    qx, vx, work = np.zeros(n + 3), np.zeros(n + 3), np.zeros(n + 3)
    K, rhs, gam, lam = np.empty((size, size)), np.empty(size), np.empty(m), np.zeros(m)
    friction = _rows(I, FRI) > 0
    for row in range(q.shape[0]):
        for j in range(n):
            qx[j], vx[j] = q[row, j], v[row, j]
        p = _emit_mass(I, Fl, n, qx, R, C, V, _0, _0, _0, 1.0)
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, _0, n, 1.0, _YES)
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, n, _0, 1.0, _NO)
        K[:, :] = 0.0
        for i in range(p):
            K[R[i], C[i]] += V[i]
        _index1_gamma(I, Fl, t[row], qx, vx, gam, R, C, V)
        lam[:] = 0.0
        ok = False
        for sweep in range(iterations if friction else 1):
            forces(I, Fl, t[row], qx, vx, lam, work)
            for j in range(n):
                rhs[j] = work[j]
            for i in range(m):
                rhs[n + i] = -gam[i]
            try:
                sol = np.linalg.solve(K, rhs)
            except Exception:       # a singular configuration
                break
            change, big = 0.0, 0.0
            for i in range(m):
                change = max(change, abs(sol[n + i] - lam[i]))
                big = max(big, abs(sol[n + i]))
                lam[i] = sol[n + i]
            if not friction or change <= 1e-13 * (1.0 + big):
                ok = True
                break
        for i in range(m):
            out[row, i] = lam[i] if ok else np.nan


@_hot
def _mobility(I, Fl, q, out, R, C, V, qx, per):
    """Multiplier mobility per constraint row into out (m,)
    (``AssembledSystem.multiplier_mobility``): max over the element's
    Phi_q entries of |Phi_q[k, j]| / M_jj; ``per``: scratch of n_elements."""
    n = _rows(I, MASS)
    _copy(qx, 0, q)
    p = _emit_phiq(I, Fl, n, qx, R, C, V, _0, _0, _0, 1.0, _NO)
    per[:] = 0.0
    for i in range(p):
        ratio = abs(V[i]) / _f(I, Fl, MASS, C[i], 0)
        e = _i(I, ROW_ELEMENT, R[i], 0)
        if ratio > per[e]:
            per[e] = ratio
    for i in range(out.shape[0]):
        out[i] = per[_i(I, ROW_ELEMENT, i, 0)]


@_hot
def _scales_weights(rec, I, Fl, q, w, opts, R, C, V, qx, weight, scratch):
    """Newton weights (``Newton.solve``): scales / (atol + rtol |s w|), with the
    multipliers' relative part taken norm-wise, and the round-off floor
    (``Method.scales``, ``Method.roundoff_floor``: the recipe's sx, sy,
    mu_mob and floor). ``scratch``: m + n_elements + 2 size floats, so that
    a step allocates nothing."""
    n, m, ne = _rows(I, MASS), _rows(I, ROW_ELEMENT), I[_HEADER - 1]
    size, l0, u0, a0 = _layout(rec, n, m)
    rtol, atol_k, atol_m = opts[OPT_RTOL], opts[OPT_ATOL_KINEMATIC], opts[OPT_ATOL_MULTIPLIER]
    mob = scratch[:m]
    _mobility(I, Fl, q, mob, R, C, V, qx, scratch[m:m + ne])
    qmax = 0.0
    for j in range(n):
        qmax = max(qmax, abs(q[j]))
    floor = 32.0 * EPS * (1.0 + qmax) * rec[FLOOR]
    scales = scratch[m + ne:m + ne + size]
    mult = scratch[m + ne + size:m + ne + 2 * size]
    mult[:] = 0.0
    sx, sy = rec[SX], rec[SY]
    scales[:n] = sx
    if rec[FORM] == ADDITIVE:          # dq, dv: sx; a: sy; psi_I, psi_II: sm times the mobility
        scales[n:2 * n] = sx
        scales[2 * n:3 * n] = sy
        for i in range(m):
            scales[u0 + i] = scales[l0 + i] = rec[SM] * mob[i]
            mult[u0 + i] = mult[l0 + i] = 1.0
    else:
        for i in range(m):
            scales[l0 + i] = sx * mob[i]
            mult[l0 + i] = 1.0
    if rec[FORM] != ADDITIVE and rec[HAS_Y] != 0.0:
        scales[n:2 * n] = sy
        for i in range(m):
            scales[u0 + i] = sy * mob[i] if rec[MU_MOB] != 0.0 else sy
            mult[u0 + i] = 1.0
    smax = 0.0
    for i in range(size):
        if mult[i] != 0.0:
            smax = max(smax, abs(scales[i] * w[i]))
    for i in range(size):
        is_mult = mult[i] != 0.0
        atol = max(atol_m if is_mult else atol_k, floor)
        sz = smax if is_mult else abs(scales[i] * w[i])
        weight[i] = scales[i] / (atol + rtol * sz)
    if rec[REG] != 0.0:        # augmented: only Phi_q^T lambda is unique; converge on x
        for i in range(m):
            weight[l0 + i] = 0.0


@_jit
def _index1_scratch(I, Fl, n, m, dense, plan, R, C, V):
    """The scratch of :func:`_index1_acceleration`, allocated once per call of
    the time loop: (S (k, k), col, g (k,), y (n + 3,)) of the dense solve,
    k = m when ``dense`` else 0, then (order, place, by_col, start, AB,
    minv, rhs) of the band solve when ``plan`` (int64, m + 1: the reverse
    Cuthill-McKee order of the constraint rows, then the half-bandwidth kd;
    ``engine._index1_band``) holds one, else empty arrays. R, C, V: triplet
    scratch (Phi_q's pattern is read once here)."""
    k = m if dense else 0
    S, col, g, y = np.empty((k, k)), np.empty(k), np.empty(k), np.empty(n + 3)
    band = plan.shape[0] == m + 1 and m > 0
    mb = m if band else 0
    order = plan[:mb].copy()
    kd = plan[m] if band else 0
    place, minv = _band_places(I, Fl, n if band else 0, order)
    by_col, start = np.empty(0, np.int64), np.zeros(1, np.int64)
    if band:
        qx = np.zeros(n + 3)
        p = _emit_phiq(I, Fl, n, qx, R, C, V, _0, _0, _0, 1.0, _NO)
        by_col, start = _column_groups(C, p, n)
    return (S, col, g, y, order, place, by_col, start, np.empty((mb, kd + 1)), minv,
            np.empty(2 * mb))


@_jit
def _index1_acceleration(I, Fl, n, m, t, qx, vx, a, out, R, C, V, scratch):
    """out[:n] = a - M^-1 Phi_q^T (Phi_q M^-1 Phi_q^T)^+ (Phi_q a - gamma) at
    (t, qx, vx): the acceleration a (n,) made to meet the acceleration
    constraints Phi_q a = gamma, gamma = -(Phi_q v)_q v - Phi_tt (Haug, sec.
    6.3), by a change along the directions M^-1 Phi_q^T lambda in which the
    multipliers act: the index-1 acceleration when a's tangential part is
    the true one (the pseudo-inverse keeps redundant rows). An index-3
    method's a meets only Phi = 0; its normal part is the multipliers'
    round-off over beta h^2. out may be a.

    Rigid bodies with a band plan: the band Cholesky of
    ``_index1_acceleration_band`` (O(m kd^2)); where it refuses the matrix,
    or without a plan, the dense least squares of
    ``_index1_acceleration_dense`` up to ``records.INDEX1_LIMIT`` rows, else a as it
    is. R, C, V: triplet scratch; ``scratch``: :func:`_index1_scratch`'s."""
    S, col, g, y, order, place, by_col, start, AB, minv, rhs = scratch
    if order.shape[0] == m and m > 0:
        if _index1_acceleration_band(I, Fl, n, m, t, qx, vx, a, out, R, C, V, order, place,
                                     by_col, start, AB, minv, rhs):
            return
    if S.shape[0] == m and m > 0:
        _index1_acceleration_dense(I, Fl, n, m, t, qx, vx, a, out, R, C, V, S, col, g, y)
        return
    for j in range(n):
        out[j] = a[j]


@_jit
def _index1_acceleration_band(I, Fl, n, m, t, qx, vx, a, out, R, C, V, order, place, by_col,
                              start, AB, minv, rhs):
    """:func:`_index1_acceleration` for rigid bodies (M a constant diagonal,
    1 / M_jj in minv) on the band Schur complement A = Phi_q M^-1 Phi_q^T
    of ``_schur_band``: A z = Phi_q a - gamma, out = a - M^-1 Phi_q^T z.
    False (out untouched) where ``_schur_band`` refuses A or z is not
    finite. rhs (2 m,): scratch."""
    kd = AB.shape[1] - 1
    gam = rhs[m:]
    _index1_gamma(I, Fl, t, qx, vx, gam, R, C, V)     # -gamma, before R, C, V hold Phi_q
    for k in range(m):                                # reordered
        rhs[k] = gam[order[k]]
    p = _emit_phiq(I, Fl, n, qx, R, C, V, _0, _0, _0, 1.0, _NO)
    for e in range(p):
        rhs[place[R[e]]] += V[e] * a[C[e]]
    if not _schur_band(R, V, by_col, start, place, minv, AB, kd):
        return False
    _band_cholesky_solve(AB, _0, m, kd, kd, rhs, _0, NO_RECIPROCAL)
    for k in range(m):
        if not np.isfinite(rhs[k]):
            return False
    for j in range(n):
        out[j] = a[j]
    for e in range(p):
        out[C[e]] -= minv[C[e]] * V[e] * rhs[place[R[e]]]
    return True


@_jit
def _index1_acceleration_dense(I, Fl, n, m, t, qx, vx, a, out, R, C, V, S, col, g, y):
    """:func:`_index1_acceleration` by the dense least-squares solve of the
    Schur complement (its pseudo-inverse; M^-1 Phi_q^T by ``_minus_correction``,
    flexible beams too): m Jacobian products and an m x m SVD. S (m, m),
    col, g (m,), y (n + 3,): scratch."""
    for i in range(m):
        col[:] = 0.0
        col[i] = 1.0
        _minus_correction(I, Fl, qx, col, y)        # M^-1 Phi_q^T e_i
        y[n:] = 0.0                                 # the ground's columns
        phiq_times(I, Fl, qx, y, g)
        S[:, i] = g
    y[:n] = a[:n]
    y[n:] = 0.0
    phiq_times(I, Fl, qx, y, g)
    _index1_gamma(I, Fl, t, qx, vx, col, R, C, V)   # -gamma
    for i in range(m):
        g[i] += col[i]
    # a model whose numbers overflow (a mass of 1e-308 kg) gives non-finite S or
    # g, which LAPACK refuses: the estimate then reads a as it is, and the
    # step's own tests stop the run with a code
    ok = np.all(np.isfinite(S)) and np.all(np.isfinite(g))
    if ok:
        try:
            z = np.linalg.lstsq(S, g, 1e-13)[0]
        except Exception:      # noqa: BLE001 - numba raises LinAlgError when the SVD fails
            ok = False
    if not ok:
        for j in range(n):
            out[j] = a[j]
        return
    _minus_correction(I, Fl, qx, z, y)
    for j in range(n):
        out[j] = a[j] - y[j]
