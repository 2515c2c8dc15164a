"""Band matrices in the compiled engine: LAPACK's band LU (dgbtrf) called
through the address scipy exports (``_fortran_call``), its substitution
(dgbtrs's operations, written here: ``_band_substitute`` says why), and a
band Cholesky for symmetric positive definite Schur complements.
"""

from __future__ import annotations

from llvmlite import ir
from numba.extending import intrinsic
import numba
import numpy as np

from ...kernels.schema import _hot


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


@_hot
def _band_cholesky(AB, off, s, kd, dg):
    """A = U^T U in place for the symmetric positive definite band matrix A
    of s unknowns and half-width kd whose upper triangle AB holds column by
    column from row ``off`` (A(i, j), i <= j, at AB[off + j, dg + i - j]; U(i,
    j) then at the same place): LAPACK's "U" band storage (dg = kd, AB of
    shape (s, kd + 1) in C order) or the upper part of the band LU's storage
    (dg = kl + ku, as ``_band_substitute`` reads it). False when a pivot is
    not positive (A is not positive definite) or not finite.

    The column-by-column (left-looking) band Cholesky of Golub and Van Loan,
    Matrix Computations, 4th ed., alg. 4.3.5, with dpbtrf's storage. Written
    here, not called: dpbtrf asks ilaenv for its block size and its dpbtf2
    makes two BLAS calls per column, and on the small Schur complements of
    the output's index-1 multipliers (4 x 4 on the double pendulum) those
    calls were most of the time (``index1._index1_multipliers_band``)."""
    for j in range(s):
        i0 = max(0, j - kd)
        cj = off + j
        for i in range(i0, j + 1):
            ci = off + i
            acc = AB[cj, dg + i - j]
            for k in range(max(i0, i - kd), i):
                acc -= AB[ci, dg + k - i] * AB[cj, dg + k - j]
            if i < j:
                AB[cj, dg + i - j] = acc / AB[ci, dg]
            elif not acc > 0.0 or not np.isfinite(acc):
                return False
            else:
                AB[cj, dg] = np.sqrt(acc)
    return True


#: ``_band_cholesky_solve``'s ``rc`` where it divides by the diagonal.
NO_RECIPROCAL = np.int64(-1)


@_hot
def _band_cholesky_solve(AB, off, s, kd, dg, b, boff, rc):
    """b[boff:boff + s] = A^-1 b with the factor U of :func:`_band_cholesky`
    (A = U^T U, the same ``off`` and ``dg``): U^T y = b forward, then U x = y
    back (LAPACK's dpbtrs). ``rc``: the column of AB that holds 1 / U(j, j)
    in row off + j, or NO_RECIPROCAL to divide by U(j, j). Each unknown waits
    for the one before it through one multiply-add and this division or
    product, and a product's latency is a fraction of a division's (the
    condensed solver stores the reciprocals: ``condensed._unit_cholesky``).
    With kd = 3 and the reciprocals (the planar chains' S) the sweeps are
    :func:`_cholesky_solve_3`'s, the same operations in the same order."""
    recip = rc >= 0
    if kd == 3 and recip and s > 3:
        _cholesky_solve_3(AB, off, s, dg, b, boff, rc)
        return
    for j in range(s):
        acc = b[boff + j]
        for k in range(max(0, j - kd), j):
            acc -= AB[off + j, dg + k - j] * b[boff + k]
        b[boff + j] = acc * AB[off + j, rc] if recip else acc / AB[off + j, dg]
    for j in range(s - 1, -1, -1):
        acc = b[boff + j]
        for k in range(j + 1, min(s, j + kd + 1)):
            acc -= AB[off + k, dg + j - k] * b[boff + k]
        b[boff + j] = acc * AB[off + j, rc] if recip else acc / AB[off + j, dg]


@_hot
def _cholesky_solve_3(AB, off, s, dg, b, boff, rc):
    """:func:`_band_cholesky_solve` at kd = 3 with the reciprocals in column
    rc: each row's three products written out and the last three unknowns
    carried in registers, the sums in the loop's order (equal to the bit).
    The loop over a variable count kept each row waiting on its own bounds
    and on the store of the unknown before it: the two sweeps of the 2 000
    rows of the 1 000-link chain's S took 32 us, written out 24 us."""
    for j in range(3):
        acc = b[boff + j]
        for k in range(j):
            acc -= AB[off + j, dg + k - j] * b[boff + k]
        b[boff + j] = acc * AB[off + j, rc]
    y3, y2, y1 = b[boff], b[boff + 1], b[boff + 2]
    for j in range(3, s):
        o = off + j
        acc = b[boff + j] - AB[o, dg - 3] * y3
        acc -= AB[o, dg - 2] * y2
        acc -= AB[o, dg - 1] * y1
        y3, y2, y1 = y2, y1, acc * AB[o, rc]
        b[boff + j] = y1
    for j in range(s - 1, s - 4, -1):
        acc = b[boff + j]
        for k in range(j + 1, s):
            acc -= AB[off + k, dg + j - k] * b[boff + k]
        b[boff + j] = acc * AB[off + j, rc]
    x1, x2, x3 = b[boff + s - 3], b[boff + s - 2], b[boff + s - 1]
    for j in range(s - 4, -1, -1):
        o = off + j
        acc = b[boff + j] - AB[o + 1, dg - 1] * x1
        acc -= AB[o + 2, dg - 2] * x2
        acc -= AB[o + 3, dg - 3] * x3
        x3, x2, x1 = x2, x1, acc * AB[o, rc]
        b[boff + j] = x1


@_hot
def _band_substitute(AB, ipiv, b, off, s, kl, ku, boff):
    """b[boff:boff + s] = A^-1 b[boff:boff + s] for the band matrix A whose LU
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
    d = boff - off                 # b's place of the band's column col
    if kl > 0:
        for j in range(s - 1):
            col = off + j
            lm = min(kl, s - 1 - j)
            piv = off + ipiv[col] - 1
            bj = b[piv + d]
            if piv != col:
                b[piv + d] = b[col + d]
                b[col + d] = bj
            if bj != 0.0:
                for i in range(1, lm + 1):
                    b[col + d + i] -= AB[col, diag + i] * bj
    for j in range(s - 1, -1, -1):
        col = off + j
        if b[col + d] != 0.0:
            bj = b[col + d] / AB[col, diag]
            b[col + d] = bj
            for i in range(1, min(diag, j) + 1):
                b[col + d - i] -= bj * AB[col, diag - i]


@_hot
def _band_substitute_pair(AB, ipiv, b, off, s, kl, ku, boff, boff2):
    """:func:`_band_substitute` of two right-hand sides, b[boff:boff + s] and
    b[boff2:boff2 + s], in one pass over the factors: the same operations on
    each in the same order (bit-identical), each factor entry read once and
    the two independent chains of updates interleaved. The condensed
    solver's shared factorization solves HHT-SI2's two blocks so; on the
    spatial chain of 10 links (90 rows, kl = ku = 11) a pair took 4.1
    instead of 5.9 us."""
    diag = kl + ku
    d, e = boff - off, boff2 - off
    if kl > 0:
        for j in range(s - 1):
            col = off + j
            lm = min(kl, s - 1 - j)
            piv = off + ipiv[col] - 1
            bj, bk = b[piv + d], b[piv + e]
            if piv != col:
                b[piv + d] = b[col + d]
                b[col + d] = bj
                b[piv + e] = b[col + e]
                b[col + e] = bk
            for i in range(1, lm + 1):
                f = AB[col, diag + i]
                b[col + d + i] -= f * bj
                b[col + e + i] -= f * bk
    for j in range(s - 1, -1, -1):
        col = off + j
        u = AB[col, diag]
        bj, bk = b[col + d] / u, b[col + e] / u
        b[col + d], b[col + e] = bj, bk
        for i in range(1, min(diag, j) + 1):
            f = AB[col, diag - i]
            b[col + d - i] -= bj * f
            b[col + e - i] -= bk * f
