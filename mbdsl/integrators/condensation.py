"""The plan of the compiled engine's condensed linear solver
(:mod:`mbdsl.integrators.compiled.condensed`, whose docstring gives the
method): from the Newton matrix's pattern, fixed at build, the coordinate
groups, the constraint rows each group touches, the Schur complement's
band ordering, and the flop counts that decide between this solver and the
band LU of the whole matrix.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
from scipy.sparse.csgraph import connected_components, reverse_cuthill_mckee

from .records import CONDENSED_FIELDS

__all__ = ["CondensedPlan", "condensed_plan", "coordinate_groups", "band_flops", "block_codes",
           "GROUP_LIMIT"]

#: The largest coordinate group the condensed solver eliminates by a dense LU:
#: four spatial bodies whose Hessians couple them, or a short flexible beam.
#: A larger group (a long beam) is the band LU's.
GROUP_LIMIT = 48

#: Floats of the shared factorization's record in ``cw``: whether block 1 is solved
#: with block 0's factors, and the scalars cA, cC, cB, cL (``compiled.condensed``).
SHARE_RECORD = 5


class CondensedPlan:
    """The condensed solver's plan for one model and method.

    Attributes
    ----------
    cp : ndarray of int64
        ``records.CONDENSED_FIELDS``' header and arrays, with room for the
        groups' pivots (the kernels write them).
    wsize : int
        Floats of the workspace ``cw``: the blocks' groups and the scratch.
    kl, ku : int
        The Schur complement's band (rows in ``sperm``'s order).
    m : int
        Its rows: the constraint rows of one block.
    blocks : int
        1, or 2 (HHT-SI2's split Newton matrix).
    groups : list of ndarray of int64
        Each group's coordinates.
    factor_flops, solve_flops : int
        A factorization's and a solve's floating-point operations, counted
        as :func:`band_flops` counts the band LU's.
    unit : bool
        Every group is one coordinate (the coordinate block is diagonal):
        the kernels take their one-coordinate loops (``compiled.condensed``).
    """

    def __init__(self, cp, wsize, kl, ku, m, blocks, groups, factor_flops, solve_flops,
                 unit=False):
        self.cp, self.wsize, self.kl, self.ku, self.m = cp, int(wsize), int(kl), int(ku), int(m)
        self.blocks, self.groups = int(blocks), groups
        self.factor_flops, self.solve_flops = int(factor_flops), int(solve_flops)
        self.unit = bool(unit)


def band_flops(size, kl, ku, blocks):
    """(factorization, solve) flops of the band LU of ``blocks`` blocks of
    size/blocks unknowns and kl, ku off-diagonals: 2 kl (kl + ku + 1) and
    2 (2 kl + ku + 1) per unknown (Golub and Van Loan, Matrix Computations,
    4th ed., sec. 4.3.5, with partial pivoting's fill)."""
    return 2 * size * kl * (kl + ku + 1), 2 * size * (2 * kl + ku + 1)


def block_codes(size, n, m, split):
    """(row codes, column codes): each Newton row's and column's block * (n +
    m) + place in its block (coordinate j, or n + constraint row i). One
    block: the Newton matrix's own order, coordinates then multipliers. Two
    (the split HHT-SI2 layout: unknowns a, abar, lambda, mu; rows of the
    dynamics, of abar, of Phi, of Phi_q v + Phi_t): block 0 = (a, lambda)
    with the dynamics and velocity rows, block 1 = (abar, mu) with the abar
    and position rows (``solver_plans.band_ordering`` reads them too)."""
    if not split:
        code = np.arange(size, dtype=np.int64)
        return code, code
    s, j, i = n + m, np.arange(n), np.arange(m)
    rows = np.concatenate([j, s + j, s + n + i, n + i])
    cols = np.concatenate([j, s + j, n + i, s + n + i])
    return rows.astype(np.int64), cols.astype(np.int64)


def _places(rb, cb, rl, cl, n, comp, pos, ks, rs, goff, wstride, pairs, tslot):
    """Each triplet's place (``records.CONDENSED_FIELDS``' ``dest``): its
    entry of A_g, C_g^T or B_g in ``cw``, -1 for the upper block (left out),
    -2 - k for the k-th entry of the lower block, in the triplets' order;
    ``pairs`` (constraint row, group), sorted, with their slots ``tslot``."""
    dest = np.full(len(rb), -1, np.int64)
    lower = np.flatnonzero(rb > cb)
    dest[lower] = -2 - np.arange(len(lower))
    t = np.flatnonzero(rb == cb)
    r_, c_ = rl[t], cl[t]
    coord = np.where(r_ < n, r_, c_)                  # the coordinate of the entry
    g = comp[coord]
    k, r, o = ks[g], rs[g], rb[t] * wstride + goff[g]
    row = np.where(r_ < n, c_ - n, r_ - n)            # the constraint row, where one is
    slot, _ = _slots(pairs, tslot, len(ks), row, g)
    in_a = (r_ < n) & (c_ < n)
    in_ct = (r_ < n) & (c_ >= n)
    dest[t] = np.where(in_a, o + pos[np.minimum(r_, n - 1)] * k + pos[np.minimum(c_, n - 1)],
                       np.where(in_ct, o + k * k + pos[np.minimum(r_, n - 1)] * r + slot,
                                o + k * k + k * r + slot * k + pos[np.minimum(c_, n - 1)]))
    return dest


def _slots(pairs, tslot, groups, row, g):
    """(slot, found): each constraint row's slot in group g (``tslot`` of the
    sorted (row, group) ``pairs``), and whether the pair is there (slot 0
    where not); a row below 0 is looked up as row 0."""
    G = max(groups, 1)
    keys = pairs[:, 0] * G + pairs[:, 1]              # sorted: rows, then groups
    want = np.maximum(row, 0) * G + g
    if len(keys) == 0:
        return np.zeros_like(g), np.zeros(len(g), bool)
    found = np.minimum(np.searchsorted(keys, want), len(keys) - 1)
    return tslot[found], keys[found] == want


def _lower_area_places(rb, cb, rl, cl, n, comp, pos, ks, rs, goff, pairs, tslot, lower):
    """Each lower-block triplet's place in the lower area of ``cw`` (``lplace``,
    in the order of ``dest``'s -2 - k): block 1's place of its entry, an A_g
    entry on a coordinate (abar) row, a B_g entry on a constraint row, where
    the sharing test of ``condensed._shareable`` reads it; -1 where it has
    none (a multiplier column, a coupling of two groups, a row the Schur
    complement lacks): such a nonzero entry keeps block 1's own
    factorization (``condensed._lower_places``, the same places found one
    by one for triplets other than the plan's)."""
    t = np.flatnonzero(rb > cb)
    r_, c_ = rl[t], cl[t]
    place = np.full(len(t), -1, np.int64)
    if n == 0 or len(t) == 0:
        return place
    ci, ri = np.minimum(c_, n - 1), np.minimum(r_, n - 1)
    g = comp[ci]
    k, r, o = ks[g], rs[g], lower + goff[g]
    slot, found = _slots(pairs, tslot, len(ks), r_ - n, g)
    in_a = (c_ < n) & (r_ < n) & (comp[ri] == g)
    in_b = (c_ < n) & (r_ >= n) & found
    place[in_a] = (o + pos[ri] * k + pos[ci])[in_a]
    place[in_b] = (o + k * k + k * r + slot * k + pos[ci])[in_b]
    return place


def _groups(rl, cl, same, n):
    """(groups, comp, touch pairs (constraint row, group) sorted): the
    coordinate groups of the coordinate block's pattern (its rows rl and
    columns cl where ``same``, the entries of one block), and which
    constraint rows touch which group (a C^T entry: coordinate row,
    multiplier column; a B entry: constraint row, coordinate column).

    Groups are the connected components of the pattern, over both blocks;
    components touched by the same rows are one group (a supernode): a
    spatial body's three director triples, coupled to each other by nothing
    but sharing its frame rows and joints, make one group of 9 whose
    contribution to S is scattered once (a third of the scattering, the
    most of S's assembly)."""
    inA = same & (rl < n) & (cl < n)
    A = scipy.sparse.coo_matrix((np.ones(int(inA.sum())), (rl[inA], cl[inA])), shape=(n, n))
    ncomp, comp = connected_components(A + A.T, directed=False)
    ct = same & (rl < n) & (cl >= n)
    bb = same & (rl >= n) & (cl < n)
    touch = np.concatenate([np.stack([cl[ct] - n, comp[rl[ct]]], axis=1),
                            np.stack([rl[bb] - n, comp[cl[bb]]], axis=1)]).reshape(-1, 2)
    rows_by_comp = [[] for _ in range(ncomp)]
    key = np.unique(touch[:, 0] * ncomp + touch[:, 1])     # (row, component), sorted by row
    for i, c in zip((key // ncomp).tolist(), (key % ncomp).tolist()):
        rows_by_comp[c].append(i)
    merged = {}
    of_comp = np.array([merged.setdefault(tuple(r) if r else ("free", c), len(merged))
                        for c, r in enumerate(rows_by_comp)], np.int64)
    comp = of_comp[comp]
    order = np.argsort(comp, kind="stable")             # each group's coordinates, ascending
    groups = np.split(order, np.cumsum(np.bincount(comp, minlength=len(merged)))[:-1])
    G = max(len(merged), 1)
    key = np.unique(touch[:, 0] * G + of_comp[touch[:, 1]])
    return groups, comp, np.stack([key // G, key % G], axis=1).reshape(-1, 2)


def _run_positions(lengths):
    """Each entry's position within its run, for runs of the given lengths
    laid end to end: [0, 1, .., l_0 - 1, 0, 1, .., l_1 - 1, ...]."""
    return np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths, lengths)


def _schur_band(grows, groff, m):
    """(sperm, kl, ku): the Schur complement's rows in the reverse
    Cuthill-McKee order of its pattern (every pair of rows that touch one
    group: group g's rows are grows[groff[g]:groff[g + 1]]), and its band.
    The pairs are made for all groups at once (a loop over the groups took
    most of a chain's plan: 3.8 of 7.4 ms a thousand links)."""
    rs = np.diff(groff)
    g = np.repeat(np.arange(len(rs)), rs)            # each slotted row's group
    cnt = rs[g]                                      # the pairs it makes: its group's rows
    si = np.concatenate([np.arange(m), np.repeat(grows, cnt)])
    sj = np.concatenate([np.arange(m), grows[np.repeat(groff[g], cnt) + _run_positions(cnt)]])
    S = scipy.sparse.csr_matrix((np.ones(len(si)), (si, sj)), shape=(m, m))
    perm = reverse_cuthill_mckee(S, symmetric_mode=True) if m else np.zeros(0, np.int64)
    sperm = np.empty(m, np.int64)
    sperm[perm] = np.arange(m)
    return (sperm, int(np.max(sperm[si] - sperm[sj], initial=0)),
            int(np.max(sperm[sj] - sperm[si], initial=0)))


def _unit_rows(ks, rs, goff, gcoord, grows, m, unit):
    """The plan's arrays ``brptr``, ``brsrc`` and ``brcoord`` (``records.CONDENSED_FIELDS``):
    each constraint row's entries of B, the place of each in a block of the
    workspace (group g's B_g after its 1 x 1 A_g and its r_g entries of X_g)
    and its coordinate, sorted by row; where a group has more than one
    coordinate (``unit`` False) the offsets are zero and the entries none."""
    if not unit:
        return {"brptr": np.zeros(m + 1, np.int64), "brsrc": np.zeros(0, np.int64),
                "brcoord": np.zeros(0, np.int64)}
    g = np.repeat(np.arange(len(ks)), rs)
    slot = _run_positions(rs)
    order = np.argsort(grows, kind="stable")
    return {"brptr": np.concatenate([[0], np.cumsum(np.bincount(grows, minlength=m))]),
            "brsrc": (goff[g] + 1 + rs[g] + slot)[order], "brcoord": gcoord[g][order]}


def _pack(header, arrays):
    """The plan's int64 array: the header's values and the arrays' offsets
    in ``CONDENSED_FIELDS``' order, then the arrays."""
    cp = np.zeros(len(CONDENSED_FIELDS), np.int64)
    parts, at = [], len(CONDENSED_FIELDS)
    for k, name in enumerate(CONDENSED_FIELDS):
        if name in arrays:
            cp[k] = at
            parts.append(np.asarray(arrays[name], np.int64))
            at += len(arrays[name])
        else:
            cp[k] = header[name]
    return np.concatenate([cp] + parts).astype(np.int64)


def coordinate_groups(R, C, n, m, split):
    """(comp (n,), count): each coordinate's group in the Newton matrix with
    triplet pattern (R, C) (the groups of :func:`_groups`, on which the
    shared factorization of HHT-SI2's split matrix is tested:
    ``compiled.condensed._shareable``, ``compiled.dense._split_shareable``)."""
    s = n + m
    rcode, ccode = block_codes((2 if split else 1) * s, n, m, split)
    rc, cc = rcode[R], ccode[C]
    groups, comp, _ = _groups(rc % s, cc % s, rc // s == cc // s, n)
    return comp.astype(np.int64), len(groups)


def condensed_plan(R, C, n, m, split=False):
    """The plan for the Newton matrix with triplet pattern (R, C) (p,) on n
    coordinates and m constraint rows per block, or None where the solver
    does not apply: an entry between two multipliers in a block (a
    regularized or additive form), a coordinate group above GROUP_LIMIT
    (:func:`_groups` finds them, :func:`_schur_band` orders S).
    """
    blocks = 2 if split else 1
    s = n + m
    rcode, ccode = block_codes(blocks * s, n, m, split)
    rc, cc = rcode[R], ccode[C]
    rb, cb, rl, cl = rc // s, cc // s, rc % s, cc % s
    same = rb == cb
    if np.any(same & (rl >= n) & (cl >= n)):
        return None
    groups, comp, pairs = _groups(rl, cl, same, n)
    if max((len(g) for g in groups), default=0) > GROUP_LIMIT:
        return None
    pos = np.empty(n, np.int64)
    for g in groups:
        pos[g] = np.arange(len(g))
    rows_of = [[] for _ in groups]
    tslot = []
    for i, g in pairs.tolist():              # sorted by row, then group
        tslot.append(len(rows_of[g]))
        rows_of[g].append(i)
    tstart = np.concatenate([[0], np.cumsum(np.bincount(pairs[:, 0], minlength=m))])
    # each group's place in a block of the workspace: A_g (k x k), X_g (k x r), B_g (r x k)
    ks = np.array([len(g) for g in groups], np.int64)
    rs = np.array([len(r) for r in rows_of], np.int64)
    sizes = ks * ks + 2 * ks * rs
    goff = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    wstride = int(sizes.sum())
    grows = np.concatenate([np.asarray(r, np.int64) for r in rows_of] + [np.zeros(0, np.int64)])
    groff = np.concatenate([[0], np.cumsum(rs)]).astype(np.int64)
    sperm, kl, ku = _schur_band(grows, groff, m)
    tg, tslot = pairs[:, 1].astype(np.int64), np.asarray(tslot, np.int64)
    arrays = {
        "rmap": rcode, "cmap": ccode, "comp": comp, "pos": pos, "tstart": tstart, "tg": tg,
        "tslot": tslot, "gkoff": np.concatenate([[0], np.cumsum(ks)]),
        "gcoord": np.concatenate(groups + [np.zeros(0, np.int64)]),
        "groff": groff, "grows": grows, "goff": goff,
        "sperm": sperm, "pivots": np.zeros(blocks * n, np.int64), "tr": R, "tc": C,
        "dest": _places(rb, cb, rl, cl, n, comp, pos, ks, rs, goff, wstride, pairs, tslot),
        "gband": sperm[grows]}
    # cw: the blocks' groups; with two, the lower block in block 1's places
    # (``lplace``); the shared factorization's record (5 floats);
    # scratch for up to two right-hand sides of S and of a group
    lower = blocks * wstride
    arrays["lplace"] = _lower_area_places(rb, cb, rl, cl, n, comp, pos, ks, rs, goff, pairs,
                                          tslot, lower)
    share = lower + (wstride if split else 0)
    scratch = share + SHARE_RECORD
    unit = bool(len(groups)) and int(ks.max()) == 1
    arrays.update(_unit_rows(ks, rs, goff, arrays["gcoord"], grows, m, unit))
    ident = np.arange(blocks * s)
    direct = blocks == 1 and np.array_equal(rcode, ident) and np.array_equal(ccode, ident)
    cp = _pack(dict(n=n, m=m, groups=len(groups), wstride=wstride, scratch=scratch,
                    triplets=len(R), lower=lower, share=share, unit=int(unit),
                    direct=int(direct)), arrays)
    wsize = scratch + 2 * (m + max(ks.max(initial=0), rs.max(initial=0), 1))
    kk, rr = ks.astype(float), rs.astype(float)
    per_factor = np.sum(2 / 3 * kk ** 3 + 2 * kk ** 2 * rr + 2 * rr * rr * kk)
    per_solve = np.sum(4 * kk * kk + 4 * kk * rr)
    sf, ss = band_flops(m, kl, ku, 1)
    return CondensedPlan(cp, wsize, kl, ku, m, blocks, groups, blocks * (per_factor + sf),
                         blocks * (per_solve + ss), unit)
