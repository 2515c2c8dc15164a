"""The linear solvers of the compiled Newton iteration: an explicit dense
inverse (LAPACK through ``numpy.linalg.inv``) or LAPACK's band LU (dgbtrf,
called through the address scipy exports) with the band substitution of
LAPACK's dgbtrs written here (``_band_substitute`` says why).

``lin`` = (J, Jinv^T, AB, ipiv, rperm, cperm, lp, addr, b, Lr, Lc, Lv):
the dense Newton matrix and its inverse, stored transposed (size x size;
DENSE), and for BANDED: the band storage AB (size x ldab in C order, i.e. LAPACK's
column-major ldab x size, ldab = 2 kl + ku + 1), LAPACK's pivots, the
orderings (equation i is row rperm[i], unknown j is column cperm[j] of the
band matrix), the integer arguments lp = (s, s, kl, ku, ldab, info,
blocks, coupling count) with s = size / blocks, dgbtrf's address
(``lapack_band_addresses``), a right-hand side buffer, and the triplets of
the coupling block (below).

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

from llvmlite import ir
from numba.extending import intrinsic
import numba
import numpy as np

from mbdsl.integrators.outcomes import (CONVERGED, NONFINITE, SINGULAR)
from mbdsl.integrators.records import (LIN_AB, LIN_ADDR, LIN_B, LIN_CPERM, LIN_IPIV, LIN_J,
                                       LIN_JINV, LIN_LC, LIN_LP, LIN_LR, LIN_LV, LIN_RPERM,
                                       LP_BLOCKS, LP_INFO, LP_KL, LP_KU, LP_LDAB, LP_M, LP_N,
                                       LP_NC)

from ...kernels.schema import _hot, _jit

#: Linear solvers of the compiled loop: explicit inverse (LAPACK getrf/getri through
#: numpy.linalg.inv), or LAPACK's band LU (dgbtrf, then ``_band_substitute``) on a
#: bandwidth-reducing ordering.
DENSE, BANDED = 0, 1


@intrinsic
def _fortran_call(typingctx, address, args):
    """Call the Fortran-convention routine at ``address`` (an int64 known only
    at run time, so the calling function stays cacheable) with the data
    pointers of the arrays in the tuple ``args``: every argument of a LAPACK
    routine is passed by reference."""
    sig = numba.types.void(address, args)

    def codegen(context, builder, signature, llargs):
        """LLVM IR: the arrays' data pointers, cast to i8*, passed to the
        routine at ``addr`` as a void function of as many pointers."""
        addr, tup = llargs
        byte_ptr = ir.IntType(8).as_pointer()
        ptrs = []
        for i, ty in enumerate(signature.args[1]):
            arr = context.make_array(ty)(context, builder, builder.extract_value(tup, i))
            ptrs.append(builder.bitcast(arr.data, byte_ptr))
        fnty = ir.FunctionType(ir.VoidType(), [byte_ptr] * len(ptrs))
        builder.call(builder.inttoptr(addr, fnty.as_pointer()), ptrs)
        return context.get_dummy_value()

    return sig, codegen


def lapack_band_addresses(names=("dgbtrf",)):
    """int64 array: the addresses of LAPACK's routines ``names`` (default the
    band LU's factorization dgbtrf) in scipy.linalg.cython_lapack (the LAPACK scipy itself links), or None when
    that build uses 64-bit integers (the kernels pass 32-bit ones)."""
    import scipy
    from numba.extending import get_cython_function_address
    try:
        blas = scipy.show_config(mode="dicts")["Build Dependencies"]["blas"]
        if any("ilp64" in str(k) and v not in (False, "False", None) for k, v in blas.items()):
            return None
    except Exception:       # noqa: BLE001 - an older scipy without the dict: LP64 builds only
        pass
    return np.array([get_cython_function_address("scipy.linalg.cython_lapack", name)
                     for name in names], np.int64)


@_jit
def _invert(J, Jinv):
    """Jinv = (J^-1)^T, the inverse stored transposed (``_solve`` then reads
    it along memory); False when J is singular or too ill-conditioned to use
    (1-norm condition number above 1e15)."""
    if not np.all(np.isfinite(J)):    # whole-array: also the uncompiled copy's speed
        return False
    try:
        inv = np.linalg.inv(J)
    except Exception:      # noqa: BLE001 - numba raises LinAlgError for an exactly singular J
        return False
    na = np.max(np.sum(np.abs(J), axis=0))
    ni = np.max(np.sum(np.abs(inv), axis=0))
    if not np.isfinite(ni) or na * ni > 1e15:
        return False
    Jinv[:, :] = inv.T
    return True


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
def _band_cholesky(AB, s, kd):
    """A = U^T U in place for the symmetric positive definite band matrix A
    of half-width kd whose upper triangle AB holds in LAPACK's "U" band
    storage (A(i, j), i <= j, at AB[j, kd + i - j]; AB of shape (s, kd + 1)
    in C order): U(i, j) then at the same place. False when a pivot is not
    positive (A is not positive definite) or not finite.

    The column-by-column (left-looking) band Cholesky of Golub and Van Loan,
    Matrix Computations, 4th ed., alg. 4.3.5, with dpbtrf's storage. Written
    here, not called: dpbtrf asks ilaenv for its block size and its dpbtf2
    makes two BLAS calls per column, and on the small Schur complements of
    the output's index-1 multipliers (4 x 4 on the double pendulum) those
    calls were most of the time (``index1._index1_multipliers_band``)."""
    for j in range(s):
        i0 = max(0, j - kd)
        for i in range(i0, j + 1):
            acc = AB[j, kd + i - j]
            for k in range(max(i0, i - kd), i):
                acc -= AB[i, kd + k - i] * AB[j, kd + k - j]
            if i < j:
                AB[j, kd + i - j] = acc / AB[i, kd]
            elif not acc > 0.0 or not np.isfinite(acc):
                return False
            else:
                AB[j, kd] = np.sqrt(acc)
    return True


@_hot
def _band_cholesky_solve(AB, s, kd, b):
    """b = A^-1 b with the factor U of :func:`_band_cholesky` (A = U^T U):
    U^T y = b forward, then U x = y back (LAPACK's dpbtrs)."""
    for j in range(s):
        acc = b[j]
        for k in range(max(0, j - kd), j):
            acc -= AB[j, kd + k - j] * b[k]
        b[j] = acc / AB[j, kd]
    for j in range(s - 1, -1, -1):
        acc = b[j]
        for k in range(j + 1, min(s, j + kd + 1)):
            acc -= AB[k, kd + j - k] * b[k]
        b[j] = acc / AB[j, kd]


@_hot
def _band_substitute(AB, ipiv, b, off, s, kl, ku):
    """b[off:off + s] = A^-1 b[off:off + s] for the band matrix A whose LU
    factors dgbtrf left in AB[off:off + s] with pivots ipiv[off:off + s]
    (1-based, as LAPACK writes them): the row interchanges and unit lower
    factor column by column, then the banded upper triangle of kl + ku
    superdiagonals from the last column back; the operations of LAPACK's
    dgbtrs (TRANS = 'N'; its dger and dtbsv, Golub and Van Loan, Matrix
    Computations, 4th ed., sec. 4.3.5) in the same order.

    Written here, not called: dgbtrs makes two BLAS calls per column (dger,
    and dtbsv's daxpy) on kl or kl + ku numbers, and on a chain's band of 4
    their call and dispatch outweigh the arithmetic. On the 1 000-link chain
    (hht-i3) perf put 36 % of a step in those calls; with this loop the step
    fell from 1.6-1.7 to 1.2 ms, with results equal to the bit
    (``docs/performance.md``). The factorization stays LAPACK's: the same
    loop for dgbtf2 was measured no faster than the library."""
    diag = kl + ku
    if kl > 0:
        for j in range(s - 1):
            col = off + j
            lm = min(kl, s - 1 - j)
            piv = off + ipiv[col] - 1
            bj = b[piv]
            if piv != col:
                b[piv] = b[col]
                b[col] = bj
            if bj != 0.0:
                for i in range(1, lm + 1):
                    b[col + i] -= AB[col, diag + i] * bj
    for j in range(s - 1, -1, -1):
        col = off + j
        if b[col] != 0.0:
            bj = b[col] / AB[col, diag]
            b[col] = bj
            for i in range(1, min(diag, j) + 1):
                b[col - i] -= bj * AB[col, diag - i]


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
        _band_substitute(AB, ipiv, b, blk * s, s, lp[LP_KL], lp[LP_KU])
    for i in range(size):
        dw[i] = b[cperm[i]]
