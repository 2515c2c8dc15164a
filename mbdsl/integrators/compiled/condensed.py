"""The condensed linear solver of the compiled Newton iteration: the Newton
matrix of a block

    [[A,  C^T],     A: coordinate rows x coordinates (n x n),
     [B,  0  ]]     C^T: their multiplier columns, B: the constraint rows

solved by eliminating the coordinates where A falls into small independent
groups (``condensation.condensed_plan`` finds them in the pattern fixed at build:
a spatial body's 12 coordinates, coupled by its mass, its frame rows'
Hessian and the forces on it alone). Each group's A_g is factored by a
dense LU with partial pivoting, X_g = A_g^-1 C_g^T is formed, and the Schur
complement

    S = B A^-1 C^T = sum_g B_g X_g          (m x m)

is assembled as a band (rows ordered by reverse Cuthill-McKee at build)
and factored by LAPACK's band LU. A solve is then

    z = A^-1 r_c,   S y = B z - r_k,   x = z - X y.

This is the range-space (Schur complement) method of saddle-point systems
(Benzi, Golub and Liesen, Numerical solution of saddle point problems, Acta
Numerica 14, 2005, sec. 5), the elimination of each body's accelerations
that recursive and "body-by-body" multibody solvers make (Featherstone,
Rigid Body Dynamics Algorithms, 2008, ch. 6-7; Baraff, Linear-time dynamics
using Lagrange multipliers, SIGGRAPH 1996). It solves the same Newton
matrix as the band LU of the whole block, in other arithmetic: the
iterates agree to round-off, the converged step within Newton's tolerance.

Why: a spatial body carries 12 coordinates and 6 frame rows, and the band
of the whole matrix of a chain of them is 29 wide each way (reverse
Cuthill-McKee): its LU costs about 2 s kl (kl + ku) flops for s unknowns.
Eliminating the coordinates leaves S on the m constraint rows, about 10
wide, and 12 x 12 dense blocks: on the spatial chain of 10 links the
factorization took 22 us instead of 109, an iteration's solve 9 us instead
of 17 (``docs/performance.md``).

With two blocks (HHT-SI2's split, ``linalg``) each block is condensed on
its own and the lower block L21 enters the second block's right-hand side,
as in the band solver; the triplets of the upper block are left out. Where
block 1 and L21 are, group by group, within SHARE_TOL of multiples of block
0's parts (:func:`_shareable`: HHT-SI2 without a stiff spring or damper),
block 1 is not factored: both blocks' right-hand sides are formed before
either is solved and go through block 0's factors together
(:func:`_shared_pair`). On the spatial chain of 10 links this took HHT-SI2's
factorization from 89 to 65 us and its solve from 25 to 18 us; the Newton
iteration converges to the same solution (5.25 instead of 5.15 iterations a
step over 1 s).

``cp`` is the plan (``records.CONDENSED_FIELDS``: a header of offsets into
``cp`` itself), ``cw`` the float workspace: per block and group, A_g (k x k,
row-major, then its LU), X_g (k x r, C_g^T before the factorization) and
B_g (r x k), for a group of k coordinates touched by r constraint rows;
after the blocks, scratch for a right-hand side of S and a group's z or a
row of B_g X_g.
"""

from __future__ import annotations

import numpy as np

from mbdsl.integrators.outcomes import CONVERGED, SINGULAR
from mbdsl.integrators.records import (CP_BRCOORD, CP_BRPTR, CP_BRSRC, CP_CMAP, CP_COMP, CP_DEST,
                                       CP_DIRECT, CP_GBAND, CP_GCOORD, CP_GKOFF, CP_GOFF, CP_GROFF,
                                       CP_GROUPS, CP_GROWS, CP_LOWER, CP_LPLACE, CP_M, CP_N,
                                       CP_PIVOTS, CP_POS, CP_RMAP, CP_SCRATCH, CP_SHARE, CP_SPERM,
                                       CP_TC, CP_TG, CP_TR, CP_TRIPLETS, CP_TSLOT, CP_TSTART,
                                       CP_UNIT, CP_WSTRIDE, LIN_AB, LIN_ADDR, LIN_B, LIN_CP,
                                       LIN_CW, LIN_IPIV, LIN_LC, LIN_LP, LIN_LR, LIN_LV, LP_BLOCKS,
                                       LP_INFO, LP_KL, LP_KU, LP_LDAB, LP_M, LP_N, LP_NC)

from .band import (_band_cholesky, _band_cholesky_solve, _band_substitute,
                   _band_substitute_pair, _fortran_call)
from ...kernels.schema import _0, _hot, _inline

#: A group's LU pivot below this fraction of its largest entry is singular
#: (SparseLU's and the band solver's threshold).
PIVOT_FLOOR = 1e-14

#: Block 1 of HHT-SI2's split Newton matrix is solved with block 0's factors
#: where, group by group, each of its parts is within this relative (Frobenius)
#: distance of a multiple of block 0's (:func:`_shareable`).
SHARE_TOL = 0.05


@_hot
def _lu_small(a, o, k, piv, po, r):
    """The k x k row-major matrix at a[o:o + k k] = P L U in place (unit
    lower L below the diagonal, U on and above), with row interchanges in
    piv[po:po + k] (the row swapped with row j at step j), and the k x r
    row-major matrix after it, at a[o + k k:], times A^-1 in place; Golub and
    Van Loan, Matrix Computations, 4th ed., alg. 3.4.1 and 3.1.1-2. False
    where a pivot is below PIVOT_FLOOR of the largest entry or an entry is
    not finite.

    One function for the whole group: numba passes each array to a call as
    its seven fields, and calling a solve per column of X took 40 us of the
    50 us a block's groups took on the spatial chain of 10 links."""
    amax = 0.0
    for i in range(k * k):
        amax = max(amax, abs(a[o + i]))
    if not np.isfinite(amax):
        return False
    x = o + k * k
    for j in range(k):
        p, best = j, abs(a[o + j * k + j])
        for i in range(j + 1, k):
            v = abs(a[o + i * k + j])
            if v > best:
                p, best = i, v
        piv[po + j] = p
        if not best > PIVOT_FLOOR * amax:
            return False
        if p != j:
            for c in range(k):
                t = a[o + j * k + c]
                a[o + j * k + c] = a[o + p * k + c]
                a[o + p * k + c] = t
            for c in range(r):
                t = a[x + j * r + c]
                a[x + j * r + c] = a[x + p * r + c]
                a[x + p * r + c] = t
        d = a[o + j * k + j]
        for i in range(j + 1, k):
            f = a[o + i * k + j] / d
            a[o + i * k + j] = f
            if f != 0.0:
                for c in range(j + 1, k):
                    a[o + i * k + c] -= f * a[o + j * k + c]
                for c in range(r):
                    a[x + i * r + c] -= f * a[x + j * r + c]
    for i in range(k - 1, -1, -1):             # U X = L^-1 P C^T, row by row from the last
        for c in range(r):
            acc = a[x + i * r + c]
            for j in range(i + 1, k):
                acc -= a[o + i * k + j] * a[x + j * r + c]
            a[x + i * r + c] = acc / a[o + i * k + i]
    return True


@_inline
def _lu_small_solve(a, o, k, piv, po, x, xo):
    """x[xo:xo + k] = A^-1 x with the factors of :func:`_lu_small`."""
    for j in range(k):
        p = piv[po + j]
        if p != j:
            x[xo + j], x[xo + p] = x[xo + p], x[xo + j]
    for i in range(k):
        acc = x[xo + i]
        for c in range(i):
            acc -= a[o + i * k + c] * x[xo + c]
        x[xo + i] = acc
    for i in range(k - 1, -1, -1):
        acc = x[xo + i]
        for c in range(i + 1, k):
            acc -= a[o + i * k + c] * x[xo + c]
        x[xo + i] = acc / a[o + i * k + i]


@_inline
def _lu_small_solve_pair(a, o, k, piv, po, x, xo, yo):
    """:func:`_lu_small_solve` of x[xo:xo + k] and x[yo:yo + k] together,
    the same operations on each in the same order."""
    for j in range(k):
        p = piv[po + j]
        if p != j:
            x[xo + j], x[xo + p] = x[xo + p], x[xo + j]
            x[yo + j], x[yo + p] = x[yo + p], x[yo + j]
    for i in range(k):
        acc0, acc1 = x[xo + i], x[yo + i]
        for c in range(i):
            f = a[o + i * k + c]
            acc0 -= f * x[xo + c]
            acc1 -= f * x[yo + c]
        x[xo + i], x[yo + i] = acc0, acc1
    for i in range(k - 1, -1, -1):
        acc0, acc1 = x[xo + i], x[yo + i]
        for c in range(i + 1, k):
            f = a[o + i * k + c]
            acc0 -= f * x[xo + c]
            acc1 -= f * x[yo + c]
        d = a[o + i * k + i]
        x[xo + i], x[yo + i] = acc0 / d, acc1 / d


@_inline
def _slot(cp, i, g):
    """Constraint row i's slot in group g (-1: it does not touch g)."""
    t0 = cp[CP_TSTART]
    for t in range(cp[t0 + i], cp[t0 + i + 1]):
        if cp[cp[CP_TG] + t] == g:
            return cp[cp[CP_TSLOT] + t]
    return -1


@_inline
def _group(cp, g):
    """(k, r, o, c): group g's coordinates and constraint rows, the offset
    of its blocks in a block of cw, and where its coordinates start in
    ``gcoord`` (and its pivots in a block's)."""
    gk, gr = cp[CP_GKOFF], cp[CP_GROFF]
    return (cp[gk + g + 1] - cp[gk + g], cp[gr + g + 1] - cp[gr + g], cp[cp[CP_GOFF] + g],
            cp[gk + g])


@_hot
def _scatter(cp, cw, R, C, V, p, s, Lr, Lc, Lv):
    """The triplets into each block's groups (A_g, C_g^T, B_g) and the lower
    block L21 (its count returned; -2: an entry outside the plan's
    pattern, between two multipliers or outside its groups and slots)."""
    n, ws = cp[CP_N], cp[CP_WSTRIDE]
    rmap, cmap, comp, pos = cp[CP_RMAP], cp[CP_CMAP], cp[CP_COMP], cp[CP_POS]
    nc = 0
    for t in range(p):
        v = V[t]
        rc, cc = cp[rmap + R[t]], cp[cmap + C[t]]
        rb, cb = int(rc >= s), int(cc >= s)
        if rb != cb:
            if rb > cb:                        # the lower block L21, in block-local places
                Lr[nc], Lc[nc], Lv[nc] = rc - s, cc, v
                nc += 1
            continue                           # the upper block: left out (``linalg``)
        rl, cl = rc - rb * s, cc - cb * s
        if rl < n:
            g = cp[comp + rl]
            k, r, o, _ = _group(cp, g)
            o += rb * ws
            if cl < n:                         # A_g
                if cp[comp + cl] != g:         # a coupling the plan's groups lack
                    return -2
                cw[o + cp[pos + rl] * k + cp[pos + cl]] += v
            else:                              # C_g^T
                slot = _slot(cp, cl - n, g)
                if slot < 0:                   # a row the plan's Schur complement lacks
                    return -2
                cw[o + k * k + cp[pos + rl] * r + slot] += v
        elif cl < n:                           # B_g
            g = cp[comp + cl]
            k, r, o, _ = _group(cp, g)
            slot = _slot(cp, rl - n, g)
            if slot < 0:
                return -2
            cw[rb * ws + o + k * k + k * r + slot * k + cp[pos + cl]] += v
        elif v != 0.0:
            return -2
    return nc


@_hot
def _scatter_planned(cp, cw, R, C, V, p, s, Lr, Lc, Lv):
    """:func:`_scatter` by the places the plan found for its triplets
    (``dest``), when R and C are those triplets (the pattern and order are
    the model's and method's, fixed at build): one indexed add each, where
    the search of the constraint rows' slots took 8 ns a triplet (55 us of
    HHT-SI2's factorization on the spatial chain of 10 links). The lower
    block's triplets go to the L21 list and, by the places the plan found
    (``lplace``), to the lower area, as :func:`_lower_places` places them
    one by one (4 us of a 67 us factorization there). (nc, placed): the
    lower block's count (-1 when the triplets differ from the plan's), and
    whether each of its nonzero entries had a place in the lower area."""
    if p != cp[CP_TRIPLETS]:
        return -1, False
    tr, tc, dest = cp[CP_TR], cp[CP_TC], cp[CP_DEST]
    differ = 0                                 # without a branch a triplet: vectorized
    for t in range(p):
        differ |= (R[t] ^ cp[tr + t]) | (C[t] ^ cp[tc + t])
    if differ != 0:
        return -1, False
    rmap, cmap, lplace = cp[CP_RMAP], cp[CP_CMAP], cp[CP_LPLACE]
    nc, placed = 0, True
    for t in range(p):
        d = cp[dest + t]
        if d >= 0:
            cw[d] += V[t]
        elif d <= -2:                          # the lower block L21, in block-local places
            k = -2 - d
            v = V[t]
            Lr[k], Lc[k], Lv[k] = cp[rmap + R[t]] - s, cp[cmap + C[t]], v
            nc = max(nc, k + 1)
            at = cp[lplace + k]
            if at >= 0:
                cw[at] += v
            elif v != 0.0:
                placed = False
    return nc, placed


@_hot
def _lower_places(cp, cw, Lr, Lc, Lv, nc):
    """The lower block L21's nc triplets (block 1's rows, block 0's columns)
    summed into the lower area of ``cw`` in block 1's places: an entry on a
    coordinate (abar) row where A_g's would be, on a constraint row where
    B_g's would be. False where one has no such place (a multiplier column,
    a coupling of two groups, a row the plan's Schur complement lacks), so
    that block 1 keeps a factorization of its own."""
    n, lo = cp[CP_N], cp[CP_LOWER]
    comp, pos = cp[CP_COMP], cp[CP_POS]
    for t in range(nc):
        rl, cl, v = Lr[t], Lc[t], Lv[t]
        if v == 0.0:
            continue
        if cl >= n:
            return False
        g = cp[comp + cl]
        k, r, o, _ = _group(cp, g)
        o += lo
        if rl < n:
            if cp[comp + rl] != g:
                return False
            cw[o + cp[pos + rl] * k + cp[pos + cl]] += v
        else:
            slot = _slot(cp, rl - n, g)
            if slot < 0:
                return False
            cw[o + k * k + k * r + slot * k + cp[pos + cl]] += v
    return True


@_inline
def _fit(cw, x, y, e):
    """(sum x_i y_i, sum y_i y_i) over cw[x:x + e] and cw[y:y + e]."""
    xy, yy = 0.0, 0.0
    for i in range(e):
        xy += cw[x + i] * cw[y + i]
        yy += cw[y + i] * cw[y + i]
    return xy, yy


@_inline
def _off(cw, x, y, c, e):
    """(|x - c y|^2, |x|^2) over cw[x:x + e] and cw[y:y + e]."""
    d, xx = 0.0, 0.0
    for i in range(e):
        f = cw[x + i] - c * cw[y + i]
        d += f * f
        xx += cw[x + i] * cw[x + i]
    return d, xx


@_hot
def _shareable(cp, cw):
    """Whether block 1 of the split Newton matrix, with the lower block L21
    in the lower area (:func:`_lower_places`), is within SHARE_TOL of

        J1 ~ [[cA A0, cC C0^T], [cB B0, 0]],    L21 ~ [[0, 0], [cL B0, 0]]

    group by group (relative Frobenius distances of A_g, C_g^T, B_g and
    L21's parts), the scalars fitted by least squares over all groups and
    written to the share record. Block 1 is then solved with block 0's
    factors (:func:`_condensed_solve`).

    On HHT-SI2 (``hht_si2``): A1 = Mhat + h^2/2 (Phi_q^T mu)_q against A0 =
    Mhat/(1+alpha) + beta h^2 K - gamma h Q_v, B1 = Phi_q/2 against B0 =
    gamma Phi_q + beta h (Phi_q v)_q, L21 = (beta h^2 (Phi_q^T mu)_q, beta
    Phi_q): the differences are O(h^2 K), O(h Q_v), O(h (Phi_q v)_q) and mu,
    the order of the upper block the split already leaves out (``linalg``),
    so modified Newton converges to the same solution at about the same
    rate. A stiff damper or spring (h Q_v or h^2 K not small against the
    mass) fails the test, and block 1 is factored on its own as before."""
    G, ws, lo = cp[CP_GROUPS], cp[CP_WSTRIDE], cp[CP_LOWER]
    sa, sa0, sc, sc0, sb, sb0, sl = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for g in range(G):
        k, r, o, _ = _group(cp, g)
        xy, yy = _fit(cw, ws + o, o, k * k)
        sa, sa0 = sa + xy, sa0 + yy
        xy, yy = _fit(cw, ws + o + k * k, o + k * k, k * r)
        sc, sc0 = sc + xy, sc0 + yy
        xy, yy = _fit(cw, ws + o + k * k + k * r, o + k * k + k * r, k * r)
        sb, sb0 = sb + xy, sb0 + yy
        sl += _fit(cw, lo + o + k * k + k * r, o + k * k + k * r, k * r)[0]
    if not (sa0 > 0.0 and sc0 > 0.0 and sb0 > 0.0):
        return False
    cA, cC, cB, cL = sa / sa0, sc / sc0, sb / sb0, sl / sb0
    if not (cA != 0.0 and cC != 0.0 and cB != 0.0 and np.isfinite(cA + cC + cB + cL)):
        return False
    tol2 = SHARE_TOL * SHARE_TOL
    for g in range(G):
        k, r, o, _ = _group(cp, g)
        d, xx = _off(cw, ws + o, o, cA, k * k)
        d += _off(cw, lo + o, o, 0.0, k * k)[1]          # L21's abar rows: left out
        if d > tol2 * xx:
            return False
        o += k * k
        d, xx = _off(cw, ws + o, o, cC, k * r)
        if d > tol2 * xx:
            return False
        o += k * r
        d, xx = _off(cw, ws + o, o, cB, k * r)
        if d > tol2 * xx:
            return False
        d, xx = _off(cw, lo + o, o, cL, k * r)
        if d > tol2 * xx:
            return False
    sh = cp[CP_SHARE]
    cw[sh + 1], cw[sh + 2], cw[sh + 3], cw[sh + 4] = cA, cC, cB, cL
    return True


@_hot
def _kxk_schur(cp, cw, AB, blk, diag):
    """:func:`_condensed_factor`'s groups of k coordinates: each A_g = P L U by
    :func:`_lu_small` with X_g = A_g^-1 C_g^T, and S += B_g X_g into the
    block's rows of the band AB. False where a group's LU is singular."""
    n, m, G, ws = cp[CP_N], cp[CP_M], cp[CP_GROUPS], cp[CP_WSTRIDE]
    groff, gband = cp[CP_GROFF], cp[CP_GBAND]
    y0 = cp[CP_SCRATCH] + m                    # a row of B_g X_g
    for g in range(G):
        k, r, o, c0 = _group(cp, g)
        o += blk * ws
        po = cp[CP_PIVOTS] + blk * n + c0
        if not _lu_small(cw, o, k, cp, po, r):
            return False
        xo, bo = o + k * k, o + k * k + k * r
        band = gband + cp[groff + g]           # the slots' places in S's band
        for a in range(r):                     # S += B_g X_g (in the band: the plan's pattern)
            for b in range(r):                 # row a of B_g X_g, along X_g's rows
                cw[y0 + b] = 0.0
            for j in range(k):
                baj = cw[bo + a * k + j]
                if baj != 0.0:
                    for b in range(r):
                        cw[y0 + b] += baj * cw[xo + j * r + b]
            row = diag + cp[band + a]
            for b in range(r):
                col = cp[band + b]
                AB[blk * m + col, row - col] += cw[y0 + b]
    return True


@_hot
def _condensed_factor(lin, R, C, V, p):
    """Factor the Newton matrix given by p triplets (module docstring); the
    Newton status code (CONVERGED, or SINGULAR)."""
    cp, cw, AB, ipiv, lp, addr = (lin[LIN_CP], lin[LIN_CW], lin[LIN_AB], lin[LIN_IPIV],
                                  lin[LIN_LP], lin[LIN_ADDR])
    n, m, ws = cp[CP_N], cp[CP_M], cp[CP_WSTRIDE]
    s, blocks = n + m, lp[LP_BLOCKS]
    kl, ku = lp[LP_KL], lp[LP_KU]
    diag = kl + ku
    sh = cp[CP_SHARE]
    cw[:sh + 1] = 0.0                          # the blocks, the lower block, not shared
    AB[:, :] = 0.0
    nc, placed = _scatter_planned(cp, cw, R, C, V, p, s, lin[LIN_LR], lin[LIN_LC],
                                  lin[LIN_LV])
    if nc == -1:                               # triplets other than the plan's: one by one
        cw[:blocks * ws] = 0.0
        nc = _scatter(cp, cw, R, C, V, p, s, lin[LIN_LR], lin[LIN_LC], lin[LIN_LV])
        placed = blocks == 2 and nc >= 0 and _lower_places(cp, cw, lin[LIN_LR], lin[LIN_LC],
                                                           lin[LIN_LV], nc)
    if nc < 0:
        return SINGULAR
    lp[LP_NC] = nc
    if blocks == 2 and placed and _shareable(cp, cw):
        cw[sh] = 1.0                           # block 1 by block 0's factors
        blocks = 1
    for blk in range(blocks):
        chol = False
        if cp[CP_UNIT] != 0:
            ok, spd = _unit_groups(cp, cw, blk)
            if not ok:
                return SINGULAR
            _unit_schur(cp, cw, AB, blk, diag)
            chol = spd and _unit_cholesky(cp, cw, AB, blk, kl, ku)
        elif not _kxk_schur(cp, cw, AB, blk, diag):
            return SINGULAR
        if m == 0:
            continue
        if chol:                               # LAPACK's pivots are 1-based: 0 marks U^T U
            ipiv[blk * m] = 0
        else:
            lp[LP_INFO] = 0
            _fortran_call(addr[0], (lp[LP_M:LP_M + 1], lp[LP_N:LP_N + 1], lp[LP_KL:LP_KL + 1],
                                    lp[LP_KU:LP_KU + 1], AB[blk * m:(blk + 1) * m],
                                    lp[LP_LDAB:LP_LDAB + 1], ipiv[blk * m:(blk + 1) * m],
                                    lp[LP_INFO:LP_INFO + 1]))
            if lp[LP_INFO] != 0:
                return SINGULAR
        dmin, dmax = np.inf, 0.0
        for j in range(blk * m, (blk + 1) * m):
            d = abs(AB[j, diag])
            if chol:                           # the pivots of its LDL^T, as the LU's
                d *= d
            dmin, dmax = min(dmin, d), max(dmax, d)
        if not (dmin >= PIVOT_FLOOR * dmax) or not np.isfinite(dmax):
            return SINGULAR
    return CONVERGED


@_hot
def _unit_groups(cp, cw, blk):
    """:func:`_condensed_factor`'s groups where each is one coordinate (a
    diagonal coordinate block, ``CP_UNIT``: the planar chains): X_g = C_g^T /
    a_g, the k x k code's operations at k = 1 without its loops over k and
    its pivot search. (ok, spd): ok False where an a_g is zero or not finite
    (the k x k code's pivot test at k = 1); spd where every a_g is positive
    and B_g = C_g (the Newton matrix symmetric in its constraint rows, as
    HHT-I3's, NSTIFF's and generalized-alpha's are): S = B A^-1 B^T is then
    symmetric positive semidefinite, and definite where B has full rank."""
    G, ws, n = cp[CP_GROUPS], cp[CP_WSTRIDE], cp[CP_N]
    goff, groff, piv = cp[CP_GOFF], cp[CP_GROFF], cp[CP_PIVOTS] + blk * n
    spd = True
    for g in range(G):
        o = cp[goff + g] + blk * ws
        r = cp[groff + g + 1] - cp[groff + g]
        a = cw[o]
        if not np.isfinite(a) or a == 0.0:
            return False, False
        spd = spd and a > 0.0
        cp[piv + g] = 0
        xo = o + 1
        for j in range(r):
            spd = spd and cw[xo + r + j] == cw[xo + j]
            cw[xo + j] = cw[xo + j] / a
    return True, spd


@_hot
def _unit_schur(cp, cw, AB, blk, diag):
    """S += B_g X_g over the one-coordinate groups (:func:`_unit_groups`), into
    the block's rows of the band AB: the k x k code's sums at k = 1."""
    G, ws, m = cp[CP_GROUPS], cp[CP_WSTRIDE], cp[CP_M]
    goff, groff, gband = cp[CP_GOFF], cp[CP_GROFF], cp[CP_GBAND]
    for g in range(G):
        xo = cp[goff + g] + blk * ws + 1
        r0 = cp[groff + g]
        r = cp[groff + g + 1] - r0
        bo, band = xo + r, gband + r0
        for i in range(r):
            bi = cw[bo + i]
            row = diag + cp[band + i]
            for j in range(r):
                col = cp[band + j]
                AB[blk * m + col, row - col] += bi * cw[xo + j]


@_hot
def _unit_cholesky(cp, cw, AB, blk, kl, ku):
    """S = U^T U in place in the block's rows of the band AB (S symmetric
    positive semidefinite by :func:`_unit_groups`), with 1 / U(j, j) in the
    column after the diagonal, which the band LU's storage has free (kl > 0)
    and the solve multiplies by (``band._band_cholesky_solve``). Where the
    Cholesky refuses S (not numerically definite), S is assembled again for
    the band LU, and False."""
    m, diag = cp[CP_M], kl + ku
    if kl != ku or kl == 0 or m == 0:
        return False
    if not _band_cholesky(AB, blk * m, m, ku, diag):
        AB[blk * m:(blk + 1) * m, :] = 0.0
        _unit_schur(cp, cw, AB, blk, diag)
        return False
    for j in range(blk * m, (blk + 1) * m):
        AB[j, diag + 1] = 1.0 / AB[j, diag]
    return True


@_hot
def _schur_solve(AB, ipiv, lp, cw, off, m, t):
    """cw[t:t + m] = S^-1 of itself for the block of S whose factor
    :func:`_condensed_factor` left in AB's rows off:off + m: its Cholesky
    factor where the block's first pivot is 0 (LAPACK's are 1-based; the
    diagonal's reciprocals in the column after it, ``_unit_cholesky``), else
    dgbtrf's LU."""
    if m == 0:
        return
    kl, ku = lp[LP_KL], lp[LP_KU]
    if ipiv[off] == 0:
        _band_cholesky_solve(AB, off, m, ku, kl + ku, cw, t, kl + ku + 1)
    else:
        _band_substitute(AB, ipiv, cw, off, m, kl, ku, t)


@_hot
def _unit_block(cp, cw, AB, ipiv, lp, b, blk):
    """:func:`_condensed_block` where each group is one coordinate: z = r_c /
    a, S's right-hand side B z - r_k gathered row by row (``brptr``: each
    sum in registers, where the group-by-group scatter of the k x k code
    chains its additions through memory from one body to the next), S y =
    that by S's Cholesky factor or its band LU (``_condensed_factor``), x = z -
    X y. The same sums as the k x k code, in another order: equal to
    round-off. Measured against the band LU of the whole Newton matrix in
    ``docs/performance.md`` (the pendulum chain)."""
    n, m, G, ws = cp[CP_N], cp[CP_M], cp[CP_GROUPS], cp[CP_WSTRIDE]
    goff, groff, gcoord, grows = cp[CP_GOFF], cp[CP_GROFF], cp[CP_GCOORD], cp[CP_GROWS]
    brptr, brsrc, brcoord, sperm = cp[CP_BRPTR], cp[CP_BRSRC], cp[CP_BRCOORD], cp[CP_SPERM]
    off, wo = blk * (n + m), blk * ws
    t0 = cp[CP_SCRATCH]                        # S's right-hand side, then y, in band order
    for g in range(G):
        c = off + cp[gcoord + g]
        b[c] = b[c] / cw[cp[goff + g] + wo]
    for i in range(m):
        acc = -b[off + n + i]
        for k in range(cp[brptr + i], cp[brptr + i + 1]):
            acc += cw[cp[brsrc + k] + wo] * b[off + cp[brcoord + k]]
        cw[t0 + cp[sperm + i]] = acc
    _schur_solve(AB, ipiv, lp, cw, blk * m, m, t0)
    for i in range(m):
        b[off + n + i] = cw[t0 + cp[sperm + i]]
    for g in range(G):
        xo = cp[goff + g] + wo + 1
        r0 = cp[groff + g]
        c = off + cp[gcoord + g]
        acc = b[c]
        for j in range(cp[groff + g + 1] - r0):
            acc -= cw[xo + j] * b[off + n + cp[grows + r0 + j]]
        b[c] = acc


@_hot
def _condensed_block(lin, b, blk):
    """b[blk (n + m):(blk + 1) (n + m)] = J_blk^-1 of itself, in the block's
    places (coordinates, then constraint rows): z = A^-1 r_c, S y = B z -
    r_k, x = z - X y."""
    cp, cw, AB, ipiv, lp = lin[LIN_CP], lin[LIN_CW], lin[LIN_AB], lin[LIN_IPIV], lin[LIN_LP]
    if cp[CP_UNIT] != 0:
        _unit_block(cp, cw, AB, ipiv, lp, b, blk)
        return
    n, m, G, ws = cp[CP_N], cp[CP_M], cp[CP_GROUPS], cp[CP_WSTRIDE]
    grows, groff, sperm, gcoord = cp[CP_GROWS], cp[CP_GROFF], cp[CP_SPERM], cp[CP_GCOORD]
    gband = cp[CP_GBAND]
    off = blk * (n + m)
    t0 = cp[CP_SCRATCH]                        # S's right-hand side, then y, in band order
    z = t0 + 2 * m                             # a group's z
    for i in range(m):
        cw[t0 + cp[sperm + i]] = -b[off + n + i]
    for g in range(G):
        k, r, o, c0 = _group(cp, g)
        o += blk * ws
        po = cp[CP_PIVOTS] + blk * n + c0
        c0 += gcoord
        bo = o + k * k + k * r
        band = gband + cp[groff + g]
        for a in range(k):
            cw[z + a] = b[off + cp[c0 + a]]
        _lu_small_solve(cw, o, k, cp, po, cw, z)
        for a in range(k):
            b[off + cp[c0 + a]] = cw[z + a]
        for a in range(r):
            acc = 0.0
            for i in range(k):
                acc += cw[bo + a * k + i] * cw[z + i]
            cw[t0 + cp[band + a]] += acc
    _schur_solve(AB, ipiv, lp, cw, blk * m, m, t0)
    for i in range(m):
        b[off + n + i] = cw[t0 + cp[sperm + i]]
    for g in range(G):
        k, r, o, c0 = _group(cp, g)
        xo = o + blk * ws + k * k
        c0 += gcoord
        r0 = grows + cp[groff + g]
        for a in range(k):
            acc = b[off + cp[c0 + a]]
            for c in range(r):
                acc -= cw[xo + a * r + c] * b[off + n + cp[r0 + c]]
            b[off + cp[c0 + a]] = acc


@_hot
def _condensed_pair(lin, b):
    """Both blocks' places of b = J_0^-1 of themselves (the shared
    factorization, :func:`_shareable`): :func:`_condensed_block`'s
    operations on each right-hand side in the same order, so the same
    results to the bit, but interleaved, two independent sums in each inner
    loop: the dot products of length 3 to 12 wait on their additions'
    latency, and a second sum fills the wait (14.3 against 11.5 us on the
    spatial chain of 10 links, where the pair went through the block
    twice over)."""
    cp, cw, AB, ipiv, lp = lin[LIN_CP], lin[LIN_CW], lin[LIN_AB], lin[LIN_IPIV], lin[LIN_LP]
    n, m, G = cp[CP_N], cp[CP_M], cp[CP_GROUPS]
    s = n + m
    grows, groff, sperm, gcoord = cp[CP_GROWS], cp[CP_GROFF], cp[CP_SPERM], cp[CP_GCOORD]
    gband = cp[CP_GBAND]
    t0 = cp[CP_SCRATCH]                        # S's two right-hand sides, then y, in band order
    t1 = t0 + m
    z0 = t0 + 2 * m                            # a group's two z
    z1 = z0 + (cw.shape[0] - z0) // 2          # (room for two: ``condensation``)
    for i in range(m):
        cw[t0 + cp[sperm + i]] = -b[n + i]
        cw[t1 + cp[sperm + i]] = -b[s + n + i]
    for g in range(G):
        k, r, o, c0 = _group(cp, g)
        po = cp[CP_PIVOTS] + c0
        c0 += gcoord
        bo = o + k * k + k * r
        band = gband + cp[groff + g]
        for a in range(k):
            c = cp[c0 + a]
            cw[z0 + a], cw[z1 + a] = b[c], b[s + c]
        _lu_small_solve_pair(cw, o, k, cp, po, cw, z0, z1)
        for a in range(k):
            c = cp[c0 + a]
            b[c], b[s + c] = cw[z0 + a], cw[z1 + a]
        for a in range(r):
            acc0, acc1 = 0.0, 0.0
            for i in range(k):
                f = cw[bo + a * k + i]
                acc0 += f * cw[z0 + i]
                acc1 += f * cw[z1 + i]
            slot = cp[band + a]
            cw[t0 + slot] += acc0
            cw[t1 + slot] += acc1
    if m > 0 and ipiv[0] == 0:                 # S = U^T U: one sweep each
        _schur_solve(AB, ipiv, lp, cw, _0, m, t0)
        _schur_solve(AB, ipiv, lp, cw, _0, m, t1)
    elif m > 0:
        _band_substitute_pair(AB, ipiv, cw, _0, m, lp[LP_KL], lp[LP_KU], t0, t1)
    for i in range(m):
        slot = cp[sperm + i]
        b[n + i], b[s + n + i] = cw[t0 + slot], cw[t1 + slot]
    for g in range(G):
        k, r, o, c0 = _group(cp, g)
        xo = o + k * k
        c0 += gcoord
        r0 = grows + cp[groff + g]
        for a in range(k):
            c = cp[c0 + a]
            acc0, acc1 = b[c], b[s + c]
            for j in range(r):
                f, row = cw[xo + a * r + j], n + cp[r0 + j]
                acc0 -= f * b[row]
                acc1 -= f * b[s + row]
            b[c], b[s + c] = acc0, acc1


@_hot
def _condensed_solve(lin, r, dw):
    """dw = J^-1 r with the factorization of :func:`_condensed_factor`. Where
    the Newton rows and columns are in the block's own order (``CP_DIRECT``:
    one block, the index-3 forms), the block is solved in dw itself, without
    the two passes through the row and column codes."""
    cp, cw, b, lp = lin[LIN_CP], lin[LIN_CW], lin[LIN_B], lin[LIN_LP]
    Lr, Lc, Lv = lin[LIN_LR], lin[LIN_LC], lin[LIN_LV]
    size = r.shape[0]
    if cp[CP_DIRECT] != 0:
        for i in range(size):
            dw[i] = r[i]
        _condensed_block(lin, dw, _0)
        return
    s = cp[CP_N] + cp[CP_M]
    rmap, cmap = cp[CP_RMAP], cp[CP_CMAP]
    for i in range(size):
        b[cp[rmap + i]] = r[i]
    sh = cp[CP_SHARE]
    if lp[LP_BLOCKS] == 2 and cw[sh] != 0.0:
        _shared_pair(cp, cw, b, sh)
        _condensed_pair(lin, b)
        n = cp[CP_N]
        for j in range(n):
            b[s + j] /= cw[sh + 1]
        for i in range(s - n):
            b[s + n + i] /= cw[sh + 2]
    else:
        for blk in range(lp[LP_BLOCKS]):
            if blk == 1:                       # block 1's rows: r2 - L21 x1
                for k in range(lp[LP_NC]):
                    b[s + Lr[k]] -= Lv[k] * b[Lc[k]]
            _condensed_block(lin, b, blk)
    for j in range(size):
        dw[j] = b[cp[cmap + j]]


@_inline
def _shared_pair(cp, cw, b, sh):
    """Block 1's right-hand side for block 0's factors (:func:`_shareable`):
    with J1 = [[cA A0, cC C0^T], [cB B0, 0]] and L21 = [[0, 0], [cL B0, 0]],
    L21 x1 = (0, cL r1_k) (block 0's solve makes B0 x1 = r1_k), so block 1's
    (x2, y2) solve J0 (cA x2, cC y2) = (r2_c, cA (r2_k - cL r1_k) / cB): both
    blocks' right-hand sides are known before either is solved."""
    n, m = cp[CP_N], cp[CP_M]
    s = n + m
    f, cL = cw[sh + 1] / cw[sh + 3], cw[sh + 4]
    for i in range(m):
        b[s + n + i] = f * (b[s + n + i] - cL * b[n + i])
