"""HHT with additive corrections (HHT-ADD): its residual and Newton matrix,
the mass solves and the flexible beams' rows it scales.
"""

from __future__ import annotations

import numpy as np

from .layout import CF, CQ, CQX, CVY, KA1, KA2, KB, SP, SV, _layout, _state
from ...kernels.beams.ffr import FFR_M, FFR_MXQ, _emit_beams, _ffr_local, _ffr_scratch
from ...kernels.loads.friction import _emit_friction_lam
from ...kernels.schema import (BCOL, BEAM, FRI, MASS, MRIG, ROW_ELEMENT, _0, _NO, _YES, _f, _hot,
                               _i, _jit, _put, _rows)
from ...kernels.system import (_emit_G, _emit_force, _emit_hess, _emit_mass, _emit_phiq,
                               _phi_time_add, forces, phi, phiq_times, phiq_triplets,
                               phiqT_add)


@_jit
def _mass_solve(I, Fl, qM, x, out):
    """out[:n] = M(qM)^-1 x[:n]: a division on the rigid diagonal, a dense
    solve per flexible beam block (``AssembledSystem.mass_solve``)."""
    for j in range(_rows(I, MRIG)):
        if _f(I, Fl, MRIG, j, 0) != 0.0:
            out[j] = x[j] / _f(I, Fl, MRIG, j, 0)
    if _rows(I, BEAM) > 0:
        M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
        for b in range(_rows(I, BEAM)):
            _ffr_local(I, Fl, b, qM, qM, qM, FFR_M, M, Q, Qq, Qv, Mxq)
            k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
            rhs = np.empty(c)
            for a in range(c):
                rhs[a] = x[_i(I, BCOL, k0 + a, 0)]
            y = np.linalg.solve(M[:c, :c], rhs)
            for a in range(c):
                out[_i(I, BCOL, k0 + a, 0)] = y[a]


@_hot
def _minus_correction(I, Fl, qx, psi, y):
    """y[:n] = M(q)^-1 Phi_q(q)^T psi at qx: minus the additive form's
    correction r(q, psi) (``HHTADD._r``); y of size n + 3, overwritten."""
    y[:] = 0.0
    phiqT_add(I, Fl, qx, psi, 1.0, y)
    _mass_solve(I, Fl, qx, y, y)


@_hot
def _rigid_mass_times(I, Fl, x):
    """x[:n] = M x[:n] on the rigid bodies' rows (the constant diagonal), 0
    on the beams' rows."""
    for j in range(_rows(I, MRIG)):
        if _f(I, Fl, MRIG, j, 0) != 0.0:
            x[j] *= _f(I, Fl, MRIG, j, 0)
    for b in range(_rows(I, BEAM)):
        k0 = _i(I, BEAM, b, 0)
        for a in range(3 + _i(I, BEAM, b, 1)):
            x[_i(I, BCOL, k0 + a, 0)] = 0.0


@_hot
def _additive_parts(rec, I, Fl, t, F_old, qx_old, w, qx, vx, z1, z2, z5, y):
    """The vectors M(q) multiplies in HHT-ADD's scaled rows 1, 2 and 5 (the
    state (qx, vx) already set): z1 = dq - ka1 a + (1 - kb)/2 y, z2 = dv -
    ka2 a + y/2, z5 = a - cF F_n, y = M(q_n)^-1 Phi_q(q_n)^T psi_I (y:
    scratch of size n + 3)."""
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rec, n, m)
    ka1, ka2, kb, cF = rec[KA1], rec[KA2], rec[KB], rec[CF]
    _minus_correction(I, Fl, qx_old, w[e0:e0 + m], y)
    for j in range(n):
        a = w[a0 + j]
        z1[j] = w[j] - ka1 * a + 0.5 * (1.0 - kb) * y[j]
        z2[j] = w[n + j] - ka2 * a + 0.5 * y[j]
        z5[j] = a - cF * F_old[j]


@_jit
def _residual_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work):
    """Upsilon(w) of HHT-ADD (``hht_add.py``) with its rows 1, 2 and 5
    multiplied by M(q) (for rigid bodies a constant diagonal: Newton's
    iterates are those of the unscaled system, and the rows are the M dq -
    ka1 M a + (1 - kb)/2 Phi_q(q_n)^T psi_I ... of ``recipe.py``)::

        M(q) z1 + kb/2 Phi_q^T psi_II,   M(q) z2 + 1/2 Phi_q^T psi_II
        sP Phi,   sV (Phi_q v + Phi_t)
        M(q) z5 - cQ Q(q, v)

    z1, z2, z5 of ``_additive_parts``, F_n = -M(q_n)^-1 Q_n (``_old_force``),
    q = q_pred + cqx dq, v = v_pred + cvy dv. With flexible beams M(q_n)
    and M(q) differ and y = M(q_n)^-1 Phi_q(q_n)^T psi_I is a block solve;
    a beam's rows are then left unscaled (M_b(q)^-1 times the above, the
    rows of ``hht_add.py`` themselves, formed as z_i + M_b^-1 times the
    other terms, one block solve per beam): scaled by M(q), whose q moves with
    the iterate, Newton converged poorly from the predictor (measured on
    tests/dsl/valid/flexible_joints.mbd: 5 to 12 iterations a step and
    steps 3e-5 m off the converged solution, against 5 to 8 unscaled).
    """
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rec, n, m)
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    r5 = 2 * n + 2 * m
    _additive_parts(rec, I, Fl, t, F_old, qx_old, w, qx, vx, r[:n], r[n:2 * n], r[r5:], work)
    beams = _rows(I, BEAM) > 0
    if beams:                     # a beam's rows: z_i + M_b^-1 (the other terms), below
        z = np.empty((3, n))
        z[0], z[1], z[2] = r[:n], r[n:2 * n], r[r5:]
    for off in (0, n, r5):        # the z_i in place of M z_i (rigid; 0 on the beams' rows)
        _rigid_mass_times(I, Fl, r[off:off + n])
    kb = rec[KB]
    work[:] = 0.0
    phiqT_add(I, Fl, qx, w[l0:l0 + m], 1.0, work)                # Phi_q(q)^T psi_II
    for j in range(n):
        r[j] += 0.5 * kb * work[j]
        r[n + j] += 0.5 * work[j]
    phi(I, Fl, t, qx, r[2 * n:2 * n + m])
    phiq_times(I, Fl, qx, vx, r[2 * n + m:2 * n + 2 * m])
    _phi_time_add(I, Fl, t, r[2 * n + m:2 * n + 2 * m], 1)
    sP, sV = rec[SP], rec[SV]
    for i in range(m):
        r[2 * n + i] *= sP
        r[2 * n + m + i] *= sV
    forces(I, Fl, t, qx, vx, w[l0:l0 + m], work)              # friction reads psi_II
    cQ = rec[CQ]
    for j in range(n):
        r[r5 + j] -= cQ * work[j]
    if beams:                      # a beam's rows unscaled: z_i + M_b(q)^-1 (the other terms)
        _beam_rows_solve(I, Fl, qx, r, n, r5)
        for b in range(_rows(I, BEAM)):
            k0 = _i(I, BEAM, b, 0)
            for a in range(3 + _i(I, BEAM, b, 1)):
                col = _i(I, BCOL, k0 + a, 0)
                r[col] += z[0, col]
                r[n + col] += z[1, col]
                r[r5 + col] += z[2, col]


@_jit
def _beam_inverses(I, Fl, qx):
    """M_b(q)^-1 of every beam, shape (beams, c_max, c_max)."""
    nb, cmax = _rows(I, BEAM), 3
    for b in range(nb):
        cmax = max(cmax, 3 + _i(I, BEAM, b, 1))
    out = np.zeros((nb, cmax, cmax))
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(nb):
        c = 3 + _i(I, BEAM, b, 1)
        _ffr_local(I, Fl, b, qx, qx, qx, FFR_M, M, Q, Qq, Qv, Mxq)
        out[b, :c, :c] = np.linalg.inv(M[:c, :c].copy())
    return out


@_jit
def _beam_rows_solve(I, Fl, qx, r, n, r5):
    """r's rows 1, 2 and 5 of the additive form (offsets 0, n, r5) on each
    beam's columns replaced by M_b(q)^-1 times them: one solve with three
    right-hand sides per beam."""
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(_rows(I, BEAM)):
        k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
        _ffr_local(I, Fl, b, qx, qx, qx, FFR_M, M, Q, Qq, Qv, Mxq)
        rhs = np.empty((c, 3))
        for a in range(c):
            col = _i(I, BCOL, k0 + a, 0)
            rhs[a, 0], rhs[a, 1], rhs[a, 2] = r[col], r[n + col], r[r5 + col]
        y = np.linalg.solve(M[:c, :c].copy(), rhs)
        for a in range(c):
            col = _i(I, BCOL, k0 + a, 0)
            r[col], r[n + col], r[r5 + col] = y[a, 0], y[a, 1], y[a, 2]


@_jit
def _beam_map(I, n):
    """(beam, local index) of each of the n columns: the beam whose
    coordinates it is (-1 for a rigid body's), and its place among them."""
    beam_of, local = np.full(n, -1, np.int64), np.zeros(n, np.int64)
    for b in range(_rows(I, BEAM)):
        k0 = _i(I, BEAM, b, 0)
        for a in range(3 + _i(I, BEAM, b, 1)):
            beam_of[_i(I, BCOL, k0 + a, 0)] = b
            local[_i(I, BCOL, k0 + a, 0)] = a
    return beam_of, local


@_jit
def _emit_mass_ratio_phiqT(I, Fl, n, qx, qx_old, R, C, V, p, c0, coef0, coef1):
    """coef0 M(q) M(q_n)^-1 Phi_q(q_n)^T at rows 0 and coef1 times it at rows
    n (a block left out where its coefficient is 0), columns from c0:
    Phi_q(q_n)^T on the rigid columns; on a beam's columns its block T =
    M_b(q) M_b(q_n)^-1 times the beam's rows of Phi_q(q_n)^T, formed once
    for both blocks."""
    if _rows(I, BEAM) == 0:
        if coef0 != 0.0:
            p = _emit_phiq(I, Fl, n, qx_old, R, C, V, p, _0, c0, coef0, _YES)
        if coef1 != 0.0:
            p = _emit_phiq(I, Fl, n, qx_old, R, C, V, p, n, c0, coef1, _YES)
        return p
    nb, cmax = _rows(I, BEAM), 3
    for b in range(nb):
        cmax = max(cmax, 3 + _i(I, BEAM, b, 1))
    beam_of, local = _beam_map(I, n)
    T = np.zeros((nb, cmax, cmax))
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(nb):
        c = 3 + _i(I, BEAM, b, 1)
        _ffr_local(I, Fl, b, qx_old, qx_old, qx_old, FFR_M, M, Q, Qq, Qv, Mxq)
        Mn = M[:c, :c].copy()
        _ffr_local(I, Fl, b, qx, qx, qx, FFR_M, M, Q, Qq, Qv, Mxq)
        X = np.linalg.solve(Mn, M[:c, :c].copy())        # M_n^-1 M(q); T = X^T (M symmetric)
        for a in range(c):
            for d in range(c):
                T[b, a, d] = X[d, a]
    k = phiq_triplets(I)
    Rs, Cs, Vs = np.empty(k, np.int64), np.empty(k, np.int64), np.empty(k)
    ks = _emit_phiq(I, Fl, n, qx_old, Rs, Cs, Vs, _0, _0, _0, 1.0, _YES)
    for r0, coef in ((0, coef0), (n, coef1)):
        if coef == 0.0:
            continue
        for i in range(ks):
            j, row, g = Rs[i], Cs[i], coef * Vs[i]
            b = beam_of[j]
            if b < 0:
                p = _put(R, C, V, p, r0 + j, c0 + row, g)
                continue
            k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
            for a in range(c):
                p = _put(R, C, V, p, r0 + _i(I, BCOL, k0 + a, 0), c0 + row, T[b, a, local[j]] * g)
    return p


@_jit
def _jacobian_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx, vx):
    """Newton matrix of ``_residual_additive``, K(u) = (Phi_q^T u)_q, G =
    (Phi_q v)_q, B = M(q) M(q_n)^-1 Phi_q(q_n)^T, and with flexible beams
    Z_i = (M z_i)_q (zero for rigid bodies)::

        [[M + cqx (Z1 + kb/2 K(psi_II)), 0,  -ka1 M, (1-kb)/2 B, kb/2 Phi_q^T],
         [cqx (Z2 + 1/2 K(psi_II)),      M,  -ka2 M, 1/2 B,      1/2 Phi_q^T ],
         [sP cqx Phi_q,                  0,  0,      0,          0           ],
         [sV cqx G,             sV cvy Phi_q, 0,     0,          0           ],
         [cqx (Z5 - cQ Q_q),    -cQ cvy Q_v,  M,     0,          0           ]]
    """
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rec, n, m)
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    ka1, ka2, kb, cqx, cvy = rec[KA1], rec[KA2], rec[KB], rec[CQX], rec[CVY]
    psi2 = w[l0:l0 + m]
    r5 = 2 * n + 2 * m
    p = 0
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, _0, _0, 1.0)
    if kb != 0.0:
        p = _emit_hess(I, Fl, n, qx, psi2, R, C, V, p, _0, _0, 0.5 * kb * cqx)
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, _0, l0, 0.5 * kb, _YES)
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, _0, a0, -ka1)
    p = _emit_mass_ratio_phiqT(I, Fl, n, qx, qx_old, R, C, V, p, e0, 0.5 * (1.0 - kb), 0.5)
    p = _emit_hess(I, Fl, n, qx, psi2, R, C, V, p, n, _0, 0.5 * cqx)
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, n, n, 1.0)
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, n, a0, -ka2)
    p = _emit_phiq(I, Fl, n, qx, R, C, V, p, n, l0, 0.5, _YES)
    p = _emit_phiq(I, Fl, n, qx, R, C, V, p, 2 * n, _0, rec[SP] * cqx, _NO)
    p = _emit_G(I, Fl, n, qx, vx, R, C, V, p, 2 * n + m, _0, rec[SV] * cqx)
    p = _emit_phiq(I, Fl, n, qx, R, C, V, p, 2 * n + m, n, rec[SV] * cvy, _NO)
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, r5, a0, 1.0)
    p = _emit_force(I, Fl, t, n, qx, vx, psi2, R, C, V, p, r5, _0, rec[CQ] * cqx, 0.0)
    p = _emit_force(I, Fl, t, n, qx, vx, psi2, R, C, V, p, r5, n, 0.0, rec[CQ] * cvy)
    if _rows(I, FRI) > 0:
        p = _emit_friction_lam(I, Fl, n, qx, vx, psi2, R, C, V, p, r5, l0, rec[CQ])
    if _rows(I, BEAM) > 0:
        p = _unscale_beam_rows(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, p,
                               qx, vx)
    return p


@_jit
def _unscale_beam_rows(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, p, qx, vx):
    """The Newton matrix of the beams' unscaled rows from the scaled one's
    triplets R, C, V[:p] (M(q) held in them): the scaled rows are r = M(q) z
    + (terms without M), so with r = M_b(q) u on a beam's rows, du/dw =
    M_b^-1 (dr/dw|_M + cqx (M_b (z - u))_q). Adds the last term (z of
    ``_additive_parts``, u the unscaled residual), gathers the triplets
    on a beam's rows into dense rows (the originals kept at zero, so that
    the pattern is fixed) and emits M_b^-1 times them on their structural
    columns; returns the new count."""
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rec, n, m)
    r5 = 2 * n + 2 * m
    u = np.empty(size)
    _residual_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, u, qx, vx, np.zeros(n + 3))
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    z = np.empty((3, n))
    _additive_parts(rec, I, Fl, t, F_old, qx_old, w, qx, vx, z[0], z[1], z[2], np.empty(n + 3))
    cqx = rec[CQX]
    for k in range(3):
        off = (0, n, r5)[k]
        for j in range(n):
            z[k, j] -= u[off + j]
        p = _emit_beams(I, Fl, qx, vx, z[k], FFR_MXQ, R, C, V, p, off, _0, cqx, 0.0)
    Minv = _beam_inverses(I, Fl, qx)
    beam_of, local = _beam_map(I, n)
    nb, cmax = Minv.shape[0], Minv.shape[1]
    rows_of = np.zeros((3, nb, cmax, size))        # the beams' rows, by block, dense
    used = np.zeros((3, nb, size), np.bool_)       # their structural columns
    for i in range(p):
        row = R[i]
        k = 0 if row < n else (1 if row < 2 * n else (2 if row >= r5 else -1))
        if k < 0:
            continue
        j = row - (0, n, r5)[k]
        b = beam_of[j]
        if b < 0:
            continue
        rows_of[k, b, local[j], C[i]] += V[i]
        used[k, b, C[i]] = True
        V[i] = 0.0
    for k in range(3):
        off = (0, n, r5)[k]
        for b in range(nb):
            k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
            for col in range(size):
                if not used[k, b, col]:
                    continue
                for d in range(c):
                    acc = 0.0
                    for a in range(c):
                        acc += Minv[b, d, a] * rows_of[k, b, a, col]
                    p = _put(R, C, V, p, off + _i(I, BCOL, k0 + d, 0), col, acc)
    return p
