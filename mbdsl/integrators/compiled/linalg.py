"""The linear solvers of the compiled Newton iteration: an explicit dense
inverse (LAPACK through ``numpy.linalg.inv``), LAPACK's band LU (dgbtrf,
called through the address scipy exports) with the band substitution of
LAPACK's dgbtrs written here (``band``), or the coordinates eliminated
group by group before a band LU of the constraint rows' Schur complement
(``condensed``, whose docstring says when and why), or the explicit inverses
of HHT-SI2's two diagonal blocks (``dense``).

``lin`` = (J, Jinv^T, AB, ipiv, rperm, cperm, lp, addr, b, Lr, Lc, Lv, cp, cw):
the dense Newton matrix and its inverse, stored transposed (size x size;
DENSE), and for BANDED: the band storage AB (size x ldab in C order, i.e. LAPACK's
column-major ldab x size, ldab = 2 kl + ku + 1), LAPACK's pivots, the
orderings (equation i is row rperm[i], unknown j is column cperm[j] of the
band matrix), the integer arguments lp = (s, s, kl, ku, ldab, info,
blocks, coupling count) with s = size / blocks, dgbtrf's address
(``lapack_band_addresses``), a right-hand side buffer, and the triplets of
the coupling block (below); for CONDENSED the plan and workspace of
``condensed`` (AB, ipiv and lp then hold the Schur complement's band).

Blocks: with one block the band matrix is the Newton matrix reordered.
With two (HHT-SI2: block 0 = the (a, lambda) unknowns with the dynamics
and velocity-constraint rows, block 1 = (abar, mu) with the abar and
position-constraint rows) it is the block lower-triangular part of the
Newton matrix: the diagonal blocks are factored apart (two band LUs of n +
m unknowns and a third of the bandwidth, instead of one of 2 (n + m)), the
lower block L21 enters the solve by a product, and the upper block, the
dependence of the dynamics and velocity-constraint rows on abar (h^2/2 K,
h/2 d(Phi_q v)/dq: O(h^2) and O(h) against the mass and Phi_q they sit
beside), is left out. That changes the Newton matrix, never the residual:
modified Newton converges to the same solution, at a contraction rate of
the order of those terms. Arrays a solver does not use are one-element
placeholders, so that every solver shares one compiled signature.
"""

from __future__ import annotations

import numpy as np

from mbdsl.integrators.outcomes import (CONVERGED, NONFINITE, SINGULAR)
from mbdsl.integrators.records import (LIN_AB, LIN_ADDR, LIN_B, LIN_CPERM, LIN_IPIV, LIN_J,
                                       LIN_JINV, LIN_LC, LIN_LP, LIN_LR, LIN_LV, LIN_RPERM,
                                       LP_BLOCKS, LP_INFO, LP_KL, LP_KU, LP_LDAB, LP_M, LP_N,
                                       LP_NC)

from .band import _band_substitute, _fortran_call, lapack_band_addresses  # noqa: F401
from .condensed import _condensed_factor, _condensed_solve
from .dense import _invert, _split_factor, _split_solve
from ...kernels.schema import _hot, _jit

#: Linear solvers of the compiled loop: explicit inverse (LAPACK getrf/getri through
#: numpy.linalg.inv), LAPACK's band LU (dgbtrf, then ``_band_substitute``) on a
#: bandwidth-reducing ordering, the coordinates eliminated group by group and the
#: Schur complement's band LU (``condensed``), or the explicit inverses of HHT-SI2's
#: two diagonal blocks (``dense``).
DENSE, BANDED, CONDENSED, DENSE_SPLIT = 0, 1, 2, 3


@_jit
def _factor(solver, lin, R, C, V, p):
    """Factor the Newton matrix given by p triplets; the Newton status code
    (CONVERGED for success, SINGULAR or NONFINITE)."""
    J, Jinv, AB, ipiv = lin[LIN_J], lin[LIN_JINV], lin[LIN_AB], lin[LIN_IPIV]
    rperm, cperm, lp, addr = lin[LIN_RPERM], lin[LIN_CPERM], lin[LIN_LP], lin[LIN_ADDR]
    Lr, Lc, Lv = lin[LIN_LR], lin[LIN_LC], lin[LIN_LV]
    for i in range(p):
        if not np.isfinite(V[i]):
            return NONFINITE
    if solver == CONDENSED:
        return _condensed_factor(lin, R, C, V, p)
    if solver == DENSE_SPLIT:
        return _split_factor(lin, R, C, V, p)
    if solver == DENSE:
        J[:, :] = 0.0
        for i in range(p):
            J[R[i], C[i]] += V[i]
        return CONVERGED if _invert(J, Jinv) else SINGULAR
    s, kl, ku, blocks = lp[LP_M], lp[LP_KL], lp[LP_KU], lp[LP_BLOCKS]
    diag = kl + ku
    AB[:, :] = 0.0
    nc = 0
    if blocks == 1:
        # one block: every triplet is in the band. Apart from the loop below,
        # whose two integer divisions a triplet (about 40 cycles each on this
        # machine) made this gather 10 % of the 1 000-link chain's step
        for i in range(p):
            row, col = rperm[R[i]], cperm[C[i]]
            if row - col > kl or col - row > ku:
                return SINGULAR
            AB[col, diag + row - col] += V[i]
    for i in range(p if blocks > 1 else 0):
        row, col = rperm[R[i]], cperm[C[i]]
        rb, cb = int(row >= s), int(col >= s)           # blocks = 2
        if rb == cb:
            row -= rb * s
            col -= cb * s
            if row - col > kl or col - row > ku:     # outside the band found at build
                return SINGULAR
            AB[cb * s + col, diag + row - col] += V[i]
        elif rb > cb:                                  # the coupling block L21
            Lr[nc], Lc[nc], Lv[nc] = row - s, col, V[i]
            nc += 1
    lp[LP_NC] = nc
    for blk in range(blocks):
        lp[LP_INFO] = 0
        # dgbtrf(M, N, KL, KU, AB, LDAB, IPIV, INFO), the integers by reference
        _fortran_call(addr[0], (lp[LP_M:LP_M + 1], lp[LP_N:LP_N + 1], lp[LP_KL:LP_KL + 1],
                                lp[LP_KU:LP_KU + 1], AB[blk * s:(blk + 1) * s],
                                lp[LP_LDAB:LP_LDAB + 1], ipiv[blk * s:(blk + 1) * s],
                                lp[LP_INFO:LP_INFO + 1]))
        if lp[LP_INFO] != 0:                         # info > 0: an exactly zero pivot
            return SINGULAR
    # as SparseLU: a pivot below 1e-14 of the largest is numerically singular
    dmin, dmax = np.inf, 0.0
    for j in range(AB.shape[0]):
        d = abs(AB[j, diag])
        dmin, dmax = min(dmin, d), max(dmax, d)
    if not (dmin >= 1e-14 * dmax) or not np.isfinite(dmax):
        return SINGULAR
    return CONVERGED


@_hot
def _solve(solver, lin, r, dw):
    """dw = J^-1 r with the factorization of ``_factor``."""
    size = r.shape[0]
    if solver == DENSE:
        # dw = sum_k r_k (J^-1)[:, k], column by column of J^-1 (a row of the
        # stored transpose): the inner loop runs along memory and over
        # independent sums, which the compiler vectorises; each dw_i adds the
        # same products in the same order as a row-times-vector loop would
        # (bit-identical), 3x faster at 28 unknowns
        JinvT = lin[LIN_JINV]
        dw[:size] = 0.0
        for k in range(size):
            rk = r[k]
            for i in range(size):
                dw[i] += JinvT[k, i] * rk
        return
    if solver == CONDENSED:
        _condensed_solve(lin, r, dw)
        return
    if solver == DENSE_SPLIT:
        _split_solve(lin, r, dw)
        return
    AB, ipiv, rperm, cperm = lin[LIN_AB], lin[LIN_IPIV], lin[LIN_RPERM], lin[LIN_CPERM]
    lp, b = lin[LIN_LP], lin[LIN_B]
    Lr, Lc, Lv = lin[LIN_LR], lin[LIN_LC], lin[LIN_LV]
    s, blocks = lp[LP_M], lp[LP_BLOCKS]
    for i in range(size):
        b[rperm[i]] = r[i]
    for blk in range(blocks):
        if blk == 1:                                   # block 1's rows: r2 - L21 x1
            for k in range(lp[LP_NC]):
                b[s + Lr[k]] -= Lv[k] * b[Lc[k]]
        _band_substitute(AB, ipiv, b, blk * s, s, lp[LP_KL], lp[LP_KU], blk * s)
    for i in range(size):
        dw[i] = b[cperm[i]]
