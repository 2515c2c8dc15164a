"""The dense solvers of the compiled Newton iteration: the explicit inverse
of the whole Newton matrix (LAPACK's getrf and getri through
``numpy.linalg.inv``), and of HHT-SI2's split Newton matrix block by block.

The split (``linalg``'s docstring): block 0 = the (a, lambda) unknowns with
the dynamics and velocity-constraint rows, block 1 = (abar, mu) with the
abar and position-constraint rows, each of s = n + m unknowns in its local
order (coordinates, then constraint rows: ``condensation.block_codes``, in
``rperm`` and ``cperm``); the lower block L21 enters block 1's right-hand
side by a product; the upper block is left out. Two inverses of s unknowns
cost a quarter of one of 2 s, and a solve two or three products of s^2
instead of one of 4 s^2.

Where block 1 and L21 are, coordinate group by group, within ``condensed.SHARE_TOL`` of
multiples of block 0's parts (:func:`_split_shareable`: HHT-SI2 without a
stiff spring or damper, the test the condensed solver makes group by
group), only block 0 is inverted and both right-hand sides, known before
either solve (:func:`_shared_rhs`), go through its inverse together. On the
IFToMM spatial slider-crank (71 unknowns a block) an iteration's solve took
2.2 us against the split band LU's 6.5, a factorization 150 us against 30
(``docs/performance.md``, ``benchmarks/split_solvers.py``).

``lin`` for the split: J and Jinv (2 s x 2 s, C order) hold, in their first
s^2, 2 s^2 and 3 s^2 floats, block 0, block 1 and L21 (row-major, s x s)
and the blocks' inverses stored transposed; ``cp`` = (n, G, each of the n
coordinates' group); ``cw`` = the share record (shared?, cA, cC, cB, cL),
the solution in block order (2 s), and 8 G floats for the test.
"""

from __future__ import annotations

import numpy as np

from mbdsl.integrators.outcomes import CONVERGED, SINGULAR
from mbdsl.integrators.records import (LIN_B, LIN_CP, LIN_CPERM, LIN_CW, LIN_J, LIN_JINV, LIN_LP,
                                       LIN_RPERM, LP_M)

from .condensed import SHARE_TOL, _fit, _off
from ...kernels.schema import _hot, _jit

#: Floats of the split dense solver's share record at the start of ``cw``.
SHARE = 5
#: The s x s matrices of J's and Jinv's storage (:func:`_square`): block 0, block 1,
#: L21 (numpy integers, as ``kernels.schema._0``: a literal argument would compile a
#: kernel once per value)
_B0, _B1, _L21 = np.int64(0), np.int64(1), np.int64(2)


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
def _square(a, k, s):
    """The k-th s x s matrix in the flat C-order storage of the 2D array a."""
    return a.reshape(a.size)[k * s * s:(k + 1) * s * s].reshape((s, s))


@_hot
def _split_shareable(f, s, cp, cw):
    """Whether block 1 and L21 in f (flat: block 0, block 1, L21, each s x s)
    are, coordinate group by group (cp = (n, G, each coordinate's group)),
    within SHARE_TOL of

        J1 ~ [[cA A0, cC C0^T], [cB B0, 0]],    L21 ~ [[0, 0], [cL B0, 0]]

    (relative Frobenius distances of each group's A, C^T, B and L21 parts:
    its coordinates' rows, and columns for B and L21), the scalars fitted by
    least squares over the whole blocks and written to cw[1:5]; the
    multiplier blocks and L21's multiplier columns must be zero.
    ``condensed._shareable`` makes the same test on the same groups and says
    why HHT-SI2 passes it without stiff elements. Tested row by row instead,
    the last factorization of runs of the spatial slider-crank to 0.3 and
    1.5 s was not shared (a row of a director against its small inertia);
    tested by groups, it was in every run sampled from 0.05 to 2 s."""
    n, G = cp[0], cp[1]
    ss = s * s
    for i in range(s):
        for j in range(n, s):
            if f[2 * ss + i * s + j] != 0.0 or (i >= n and (f[i * s + j] != 0.0
                                                             or f[ss + i * s + j] != 0.0)):
                return False
    sa, sa0, sc, sc0, sb, sb0, sl = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for i in range(s):
        o = i * s
        if i < n:
            xy, yy = _fit(f, ss + o, o, n)
            sa, sa0 = sa + xy, sa0 + yy
            xy, yy = _fit(f, ss + o + n, o + n, s - n)
            sc, sc0 = sc + xy, sc0 + yy
        else:
            xy, yy = _fit(f, ss + o, o, n)
            sb, sb0 = sb + xy, sb0 + yy
            sl += _fit(f, 2 * ss + o, o, n)[0]
    if not (sa0 > 0.0 and sc0 > 0.0 and sb0 > 0.0):
        return False
    cA, cC, cB, cL = sa / sa0, sc / sc0, sb / sb0, sl / sb0
    if not (cA != 0.0 and cC != 0.0 and cB != 0.0 and np.isfinite(cA + cC + cB + cL)):
        return False
    acc = cw[SHARE + 2 * s:SHARE + 2 * s + 8 * G]      # per group: (distance^2, norm^2) x 4
    acc[:] = 0.0
    for i in range(s):
        o = i * s
        if i < n:
            a = 8 * cp[2 + i]
            d, xx = _off(f, ss + o, o, cA, n)
            acc[a] += d + _off(f, 2 * ss + o, o, 0.0, n)[1]   # L21's abar rows: left out
            acc[a + 1] += xx
            d, xx = _off(f, ss + o + n, o + n, cC, s - n)
            acc[a + 2] += d
            acc[a + 3] += xx
        else:
            for j in range(n):
                a = 8 * cp[2 + j]
                b0, b1, lo = f[o + j], f[ss + o + j], f[2 * ss + o + j]
                acc[a + 4] += (b1 - cB * b0) ** 2
                acc[a + 5] += b1 * b1
                acc[a + 6] += (lo - cL * b0) ** 2
                acc[a + 7] += lo * lo
    tol2 = SHARE_TOL * SHARE_TOL
    for k in range(0, 8 * G, 2):
        if acc[k] > tol2 * acc[k + 1]:
            return False
    cw[1], cw[2], cw[3], cw[4] = cA, cC, cB, cL
    return True


@_jit
def _split_factor(lin, R, C, V, p):
    """Invert the split Newton matrix's diagonal blocks (block 1 only where
    :func:`_split_shareable` fails), given by p finite triplets; the Newton
    status code (CONVERGED, or SINGULAR)."""
    J, Jinv, rperm, cperm = lin[LIN_J], lin[LIN_JINV], lin[LIN_RPERM], lin[LIN_CPERM]
    s, cw = lin[LIN_LP][LP_M], lin[LIN_CW]
    ss = s * s
    f = J.reshape(J.size)
    f[:3 * ss] = 0.0
    for t in range(p):
        row, col = rperm[R[t]], cperm[C[t]]
        if row >= s and col >= s:                      # block 1
            f[ss + (row - s) * s + col - s] += V[t]
        elif row >= s:                                 # L21
            f[2 * ss + (row - s) * s + col] += V[t]
        elif col < s:                                  # block 0; the upper block left out
            f[row * s + col] += V[t]
    shared = _split_shareable(f, s, lin[LIN_CP], cw)
    cw[0] = 1.0 if shared else 0.0
    if not _invert(_square(J, _B0, s), _square(Jinv, _B0, s)):
        return SINGULAR
    if not shared and not _invert(_square(J, _B1, s), _square(Jinv, _B1, s)):
        return SINGULAR
    return CONVERGED


@_hot
def _shared_rhs(b, s, n, share):
    """Block 1's right-hand side for block 0's inverse: with J1 = [[cA A0, cC
    C0^T], [cB B0, 0]] and L21 = [[0, 0], [cL B0, 0]], L21 x1 = (0, cL r1_k)
    (block 0's solve makes B0 x1 = r1_k), so (cA x2, cC y2) = J0^-1 (r2_c,
    cA (r2_k - cL r1_k) / cB) (``condensed._shared_pair``, the same algebra)."""
    f, cL = share[1] / share[3], share[4]
    for i in range(n, s):
        b[s + i] = f * (b[s + i] - cL * b[i])


@_hot
def _split_solve(lin, r, dw):
    """dw = J^-1 r with the inverses of :func:`_split_factor`: x1 = J0^-1 r1,
    x2 = J1^-1 (r2 - L21 x1), or both through J0^-1 where shared. The
    products run column by column of the inverse (a row of its stored
    transpose), along memory."""
    J, Jinv, rperm, cperm = lin[LIN_J], lin[LIN_JINV], lin[LIN_RPERM], lin[LIN_CPERM]
    s, n, cw, b = lin[LIN_LP][LP_M], lin[LIN_CP][0], lin[LIN_CW], lin[LIN_B]
    size = r.shape[0]
    x = cw[SHARE:SHARE + 2 * s]
    for i in range(size):
        b[rperm[i]] = r[i]
    T0 = _square(Jinv, _B0, s)
    x[:] = 0.0
    if cw[0] != 0.0:
        _shared_rhs(b, s, n, cw)
        for k in range(s):
            b0, b1 = b[k], b[s + k]
            for i in range(s):
                x[i] += T0[k, i] * b0
                x[s + i] += T0[k, i] * b1
        cA, cC = cw[1], cw[2]
        for j in range(n):
            x[s + j] /= cA
        for i in range(n, s):
            x[s + i] /= cC
    else:
        for k in range(s):
            b0 = b[k]
            for i in range(s):
                x[i] += T0[k, i] * b0
        L = _square(J, _L21, s)
        for i in range(s):                             # block 1's rows: r2 - L21 x1
            acc = 0.0
            for j in range(s):
                acc += L[i, j] * x[j]
            b[s + i] -= acc
        T1 = _square(Jinv, _B1, s)
        for k in range(s):
            b1 = b[s + k]
            for i in range(s):
                x[s + i] += T1[k, i] * b1
    for j in range(size):
        dw[j] = x[cperm[j]]
