"""The compiled engine's set-up: its copy of the model data
(:class:`CompiledModel`) and the linear solver of its Newton iteration
(:class:`LinearSolverPlan`): the dense inverse, the band LU on a reverse
Cuthill-McKee ordering, or the condensed solver (the coordinates eliminated
group by group, :mod:`.condensation`), chosen from the Newton matrix's
pattern fixed at build (:func:`linear_solver_plan`).
"""

from __future__ import annotations

import numpy as np
import scipy

from ..assembly.packing import PackedModel
from ..assembly.sparse import DENSE_LIMIT
from .condensation import (GROUP_LIMIT, band_flops, block_codes, condensed_plan,
                           coordinate_groups)
from .records import LAPACK_FIELDS, LIN_FIELDS, vector

__all__ = ["CompiledModel", "LinearSolverPlan", "linear_solver_plan", "band_plan",
           "band_ordering", "condensed_solver_plan", "newton_pattern", "newton_size",
           "BAND_LIMIT", "BAND_MIN_SIZE"]

#: The band LU is taken when the reordered Newton matrix has at most this many sub-
#: and super-diagonals and its band (2 kl + ku + 1 entries per unknown) is at most
#: half a dense row: a band solve then costs a few hundred flops per unknown with no
#: indexing or call overhead, inside the compiled loop. Measured on pendulum chains
#: (kl = ku = 4 for HHT-I3, 11 for HHT-SI2): N = 100, HHT-SI2, 0.37 ms per step
#: against 1.05 ms with SuperLU in the Python Newton loop; N = 1000, 4.5-5.5 ms
#: against 10.7 ms. Against the dense inverse (us per step, dense / band): chain of
#: 6 links, HHT-I3 (30 unknowns) 45 / 38, NSTIFF-SI2 (60) 94 / 72, HHT-ADD (78) 204
#: / 157; 10 links, NSTIFF-SI2 (100) 215 / 77; Andrews' mechanism, HHT-I3 (41
#: unknowns, kl = ku = 9: more than half a row) 27 / 34, so kept dense.
BAND_LIMIT = 32
#: Below this many unknowns the dense inverse is kept without looking for a band.
BAND_MIN_SIZE = 30


def _kernels(uncompiled: bool = False):
    """The kernels: the compiled module (imports numba, loads the cached
    kernels), or with ``uncompiled`` the same source run by the interpreter
    (:func:`.kernel_cache.uncompiled_kernels`)."""
    if uncompiled:
        from .kernel_cache import uncompiled_kernels
        return uncompiled_kernels()
    from . import compiled
    return compiled


def newton_size(system, method) -> int:
    """Unknowns of the Newton matrix: n + m (index 3), 2 (n + m) (stabilized index 2)."""
    return sum(b.size for b in method.blocks(system))


def _recipe_value(method, name, h=1e-3):
    from .recipe import RECIPE_FIELDS
    return float(method.kernel_recipe(h, False)[RECIPE_FIELDS.index(name)])


class CompiledModel(PackedModel):
    """:class:`~mbdsl.assembly.packing.PackedModel` on the compiled kernels by default.

    Parameters
    ----------
    system : AssembledSystem
        A model :func:`unsupported` accepts.
    kernels : module, optional
        The kernels the model data are for and the run calls (``K``):
        :mod:`.compiled` (the default) or its uncompiled copy
        (``_kernels(uncompiled=True)``).
    """

    def __init__(self, system, kernels=None):
        super().__init__(system, kernels if kernels is not None else _kernels())


class LinearSolverPlan:
    """How the compiled engine solves with the Newton matrix.

    Attributes
    ----------
    kind : {"dense", "banded", "condensed", "sparse"}
        Explicit inverse (of each block where split) in the compiled loop,
        LAPACK band LU in the compiled
        loop, the coordinates eliminated group by group and the Schur
        complement's band LU in the compiled loop
        (:mod:`.compiled.condensed`), or SuperLU in the Python Newton loop
        (:class:`SparseAdapter`).
    rperm, cperm : ndarray of int64, shape (size,) or None
        "banded": equation i is row rperm[i], unknown j column cperm[j] of
        the band matrix; "dense" with two blocks: their block codes
        (``condensation.block_codes``).
    kl, ku : int
        "banded": sub- and super-diagonals of each diagonal block;
        "condensed": of the Schur complement.
    blocks : int
        "banded", "condensed", "dense": 1, or 2 for HHT-SI2 split into its
        (a, lambda) and (abar, mu) blocks (see ``compiled.linalg``).
    addresses : ndarray of int64, shape (1,) or None
        "banded", "condensed": dgbtrf's (``integrators.compiled.band.lapack_band_addresses``).
    condensed : condensation.CondensedPlan or None
        "condensed": the groups, the Schur complement's ordering, the flops.
    why : str
        The reason for the choice, for reports.
    groups : ndarray of int64 or None
        "dense" with two blocks: (n, G, each coordinate's group), n the
        coordinates of a block (the rest of its s = size / 2 unknowns are
        multipliers), G the coordinate groups
        (``condensation.coordinate_groups``).
    """

    def __init__(self, kind, why, rperm=None, cperm=None, kl=0, ku=0, blocks=1, addresses=None,
                 condensed=None, groups=None):
        self.kind, self.why = kind, why
        self.rperm, self.cperm, self.kl, self.ku = rperm, cperm, int(kl), int(ku)
        self.blocks, self.addresses = int(blocks), addresses
        self.condensed, self.groups = condensed, groups

    def factorization_is_expensive(self, size) -> bool:
        """Whether a factorization costs more than about six Newton iterations
        (``NewtonOptions.refresh_rate``). Dense: an inverse costs about size/6
        iterations (measured: at 17 unknowns the cheap policy is fastest, at 50
        and 100 unknowns the expensive one). Band: dgbtrf's 2 kl (kl + ku + 1)
        flops per unknown against an iteration's band solve, 2 (2 kl + ku + 1),
        and a residual of about 20 (measured on chains: kl = ku = 11 is
        fastest with the cheap policy)."""
        if self.kind == "dense":               # per block where split
            return size // self.blocks >= 40
        if self.kind == "condensed":        # the same rule, on the counted flops
            c = self.condensed
            return c.factor_flops > 6 * (c.solve_flops + 20 * size)
        return self.kl * (self.kl + self.ku + 1) > 6 * (2 * self.kl + self.ku + 11)

    def workspace(self, size, bound):
        """The kernels' ``lin`` tuple (``records.LIN_FIELDS``, read by
        ``integrators.compiled.linalg._factor``) for this plan; ``bound``: the
        triplet bound of the model."""
        one, i8 = np.zeros((1, 1)), np.int64
        ldab = 2 * self.kl + self.ku + 1
        cp, cw = np.zeros(1, i8), np.zeros(1)
        if self.kind == "dense":
            J, Jinv, AB = np.empty((size, size)), np.empty((size, size)), one
            ipiv, rperm, cperm = np.zeros(1, np.int32), np.zeros(1, i8), np.zeros(1, i8)
            addresses, Lr, Lc, Lv = np.zeros(1, i8), np.zeros(1, i8), np.zeros(1, i8), np.zeros(1)
            if self.blocks == 2:                    # ``compiled.dense``: the blocks' places
                rperm, cperm = self.rperm, self.cperm
                cp = self.groups.copy()
                cw = np.zeros(5 + size + 8 * int(cp[1]))
        else:
            J = Jinv = one
            rows = size
            rperm, cperm = self.rperm, self.cperm
            if self.kind == "condensed":            # AB: the Schur complement's band
                c = self.condensed
                rows, rperm, cperm = c.blocks * c.m, np.zeros(1, i8), np.zeros(1, i8)
                cp, cw = c.cp.copy(), np.zeros(c.wsize)
            AB = np.zeros((max(rows, 1), ldab))
            ipiv, addresses = np.zeros(max(rows, 1), np.int32), self.addresses
            nL = bound if self.blocks == 2 else 1
            Lr, Lc, Lv = np.zeros(nL, i8), np.zeros(nL, i8), np.zeros(nL)
        s = size // max(self.blocks, 1)
        if self.kind == "condensed":
            s = self.condensed.m
        lp = vector(LAPACK_FIELDS, np.int32, m=s, n=s, kl=self.kl, ku=self.ku, ldab=ldab, info=0,
                    blocks=self.blocks, nc=0)
        lin = dict(J=J, Jinv=Jinv, AB=AB, ipiv=ipiv, rperm=rperm, cperm=cperm, lp=lp,
                   addr=addresses, b=np.empty(size), Lr=Lr, Lc=Lc, Lv=Lv, cp=cp, cw=cw)
        return tuple(lin[name] for name in LIN_FIELDS)


def newton_pattern(system, method, q, cm=None):
    """(rows, cols) of the Newton matrix's triplets, evaluated at configuration
    q (n,) [m, rad] at rest (h = 1e-3 s); the pattern is the model's, fixed
    at build, whatever the configuration."""
    cm = cm or CompiledModel(system)
    K = cm.K
    size = newton_size(system, method)
    n = system.n
    R, C, V = (np.empty(cm.bound, np.int64), np.empty(cm.bound, np.int64), np.empty(cm.bound))
    qx = np.zeros(n + 3)
    qx[:n] = q
    p = K.jacobian_triplets(method.kernel_recipe(1e-3, False), cm.ints, cm.floats, 0.0,
                            np.asarray(q, dtype=float), np.zeros(n), np.zeros(n), qx, np.zeros(size),
                            R, C, V, np.zeros(n + 3), np.zeros(n + 3))
    return R[:p], C[:p]


def _rcm(R, C, size):
    """iperm (size,): the reverse Cuthill-McKee ordering (scipy.sparse.csgraph)
    of the pattern (R, C) made symmetric, index i going to position iperm[i]."""
    from scipy.sparse.csgraph import reverse_cuthill_mckee
    A = scipy.sparse.csr_matrix((np.ones(len(R)), (R, C)), shape=(size, size))
    perm = reverse_cuthill_mckee((A + A.T).tocsr(), symmetric_mode=True)
    iperm = np.empty(size, np.int64)
    iperm[perm] = np.arange(size)
    return iperm


def band_ordering(system, method, q, split=False, cm=None, pattern=None):
    """(rperm, cperm, kl, ku, blocks): the band matrix of the Newton matrix.

    One block: the reverse Cuthill-McKee ordering of J + J^T for rows and
    columns alike. ``split`` (a recipe with ``split``, HHT-SI2): two blocks,
    equations (R1, R4) and unknowns (x, lambda) first, equations (R2, R3)
    and unknowns (y, mu) second, each ordered by reverse Cuthill-McKee of its own
    diagonal block. kl, ku: the largest sub- and super-diagonals of the
    diagonal blocks. ``pattern``: the (rows, cols) of :func:`newton_pattern`,
    when the caller has them.
    """
    size = newton_size(system, method)
    R, C = pattern if pattern is not None else newton_pattern(system, method, q, cm)
    if not split:
        # Equation i is paired with unknown pair[i] (the diagonal of the band matrix):
        # itself where the equations come in the unknowns' order; for HHT-ADD's
        # additive form, whose rows are (E1, E2, E3, E4, E5) and unknowns (dq, dv, a,
        # psi_I, psi_II), E5 (M a - ...) pairs with a, and the constraint rows E3, E4
        # with psi_I, psi_II. Without it, reverse Cuthill-McKee of a chain's matrix
        # found a bandwidth of 368 instead of a few tens.
        if _recipe_value(method, "form") == 1.0:
            n, m = system.n, system.m
            pair = np.concatenate([np.arange(2 * n), 3 * n + np.arange(2 * m),
                                   2 * n + np.arange(n)])
            iperm = _rcm(pair[R], C, size)
            rperm, cperm = iperm[pair], iperm
        else:
            iperm = _rcm(R, C, size)
            rperm = cperm = iperm
    else:
        if _recipe_value(method, "split") == 0.0:
            raise ValueError(f"the {method.name} Newton matrix is not split into blocks")
        n, m = system.n, system.m
        s = n + m
        # each equation's (row's) and unknown's (column's) block and place in it
        rcode, ccode = block_codes(size, n, m, True)
        row_block, row_local, col_block, col_local = rcode // s, rcode % s, ccode // s, ccode % s
        rperm, cperm = np.empty(size, np.int64), np.empty(size, np.int64)
        for blk in (0, 1):
            keep = (row_block[R] == blk) & (col_block[C] == blk)
            iperm = _rcm(row_local[R[keep]], col_local[C[keep]], s)
            rows, cols = row_block == blk, col_block == blk
            rperm[rows] = blk * s + iperm[row_local[rows]]
            cperm[cols] = blk * s + iperm[col_local[cols]]
        diagonal = (row_block[R] == col_block[C])
        R, C = R[diagonal], C[diagonal]
    kl = int(np.max(rperm[R] - cperm[C], initial=0))
    ku = int(np.max(cperm[C] - rperm[R], initial=0))
    return rperm, cperm, kl, ku, (2 if split else 1)


def band_plan(system, method, q, split, addresses, cm=None, pattern=None) -> LinearSolverPlan:
    """The "banded" plan of ``band_ordering`` (arguments as there; addresses
    from ``integrators.compiled.band.lapack_band_addresses``)."""
    rperm, cperm, kl, ku, blocks = band_ordering(system, method, q, split, cm, pattern)
    return LinearSolverPlan("banded", f"band LU, kl = {kl}, ku = {ku}, {blocks} block(s) "
                            f"({newton_size(system, method)} unknowns)", rperm, cperm, kl, ku,
                            blocks, addresses)


def linear_solver_plan(system, method, options, q, cm=None, split_si2=True) -> LinearSolverPlan:
    """The compiled engine's linear solver for this model and method, its
    pattern judged at configuration q (n,). The HHT-SI2 band matrix is split
    into its two blocks unless ``split_si2`` is False.

    ``options.linear_solver``: "dense" and "sparse" are taken as asked,
    "banded" and "condensed" whenever LAPACK's band routines are usable (and,
    for "condensed", the Newton matrix's coordinates fall into small groups:
    :func:`condensed_solver_plan`); "auto" takes the band LU when the
    reordered matrix is narrow (``BAND_LIMIT``, a band of at most half the
    unknowns, at least ``BAND_MIN_SIZE`` unknowns), and for HHT-SI2's split
    matrix in its place the two blocks' dense inverses where their counted
    flops are fewer (:func:`dense_split_cost`), else the dense inverse
    up to ``DENSE_LIMIT`` unknowns and SuperLU above; and in place of the
    band LU or the dense inverse the condensed solver, where it applies and
    its counted flops (a factorization and six solves) are at most a quarter
    of theirs (``CONDENSED_GAIN``).

    Raises
    ------
    ValueError
        "banded" or "condensed" asked for where the LAPACK routines cannot be
        called (an ILP64 LAPACK build), "condensed" where it does not apply.
    """
    choice = options.linear_solver
    size = newton_size(system, method)
    dense = LinearSolverPlan("dense", f"explicit inverse ({size} unknowns)")
    if choice == "dense" or (choice == "auto" and size < BAND_MIN_SIZE):
        return dense
    if choice == "sparse":
        return LinearSolverPlan("sparse", "SuperLU, as asked")
    uncompiled = cm is not None and cm.uncompiled
    addresses = None if uncompiled else _kernels().lapack_band_addresses()
    if addresses is None:
        if choice in ("banded", "condensed") and uncompiled:
            raise ValueError(f"linear_solver='{choice}' calls LAPACK from compiled kernels; "
                             "the uncompiled engine takes 'dense' or 'sparse'")
        if choice in ("banded", "condensed"):
            raise ValueError(f"linear_solver='{choice}' needs a LAPACK with 32-bit integers; "
                             "this scipy is built with ILP64")
        return dense if size <= DENSE_LIMIT else LinearSolverPlan(
            "sparse", "SuperLU (uncompiled kernels: no LAPACK band routines)" if uncompiled
            else "SuperLU (the LAPACK band routines use 64-bit integers here)")
    split = _recipe_value(method, "split") != 0.0 and split_si2
    pattern = newton_pattern(system, method, q, cm)          # once, for both plans
    condensed = (None if choice == "banded" else
                 condensed_solver_plan(system, method, q, split, addresses, cm, pattern))
    if choice == "condensed":
        if condensed is None:
            raise ValueError(f"linear_solver='condensed' does not apply to {method.name} on "
                             "this model: its Newton matrix's coordinates do not fall into "
                             f"groups of at most {GROUP_LIMIT}, or it couples two multipliers")
        return condensed
    plan = band_plan(system, method, q, split, addresses, cm, pattern)
    kl, ku = plan.kl, plan.ku
    if choice == "banded":
        return plan
    if max(kl, ku) <= BAND_LIMIT and 2 * (2 * kl + ku + 1) <= size:
        cost = sum(f * w for f, w in zip(band_flops(size, kl, ku, plan.blocks), (1, 6)))
        if split and dense_split_cost(size) < cost:
            plan = dense_split_plan(system, method, q, cm, pattern, condensed)
            cost = dense_split_cost(size)
    elif size <= DENSE_LIMIT:
        plan, cost = dense, (2 * size ** 3 + 6 * 2 * size ** 2) / DENSE_FLOP_RATE
    else:
        plan, cost = LinearSolverPlan("sparse", f"SuperLU (reordered bandwidth kl = {kl}, "
                                      f"ku = {ku})"), None
    gain = UNIT_GAIN if condensed is not None and condensed.condensed.unit else CONDENSED_GAIN
    if condensed is not None and (cost is None or condensed_cost(condensed) <= gain * cost):
        return condensed
    return plan


#: "auto" takes the condensed solver where its flops are at most this fraction of
#: the band LU's or the dense inverse's (weighed by ``DENSE_FLOP_RATE``): the band
#: solver's loops run over contiguous memory, the condensed solver's index through
#: its plan. Measured (``benchmarks/speed.py``, h = 1e-3 s): the spatial chains at
#: 0.20 of the band's flops take 0.6 to 0.7 of its time per step; the planar
#: N-four-bar at 0.31 the same time (hht-i3 28.9 against 27.7 us, hht-si2 44.8 and
#: 44.8), so it keeps the band LU (but see UNIT_GAIN).
CONDENSED_GAIN = 0.25
#: The same where every group is one coordinate (``CondensedPlan.unit``: a diagonal
#: coordinate block, as on the planar chains), whose kernels skip the small LU's loops,
#: read B row by row and factor a symmetric positive definite S by Cholesky
#: (``compiled.condensed._unit_groups``, ``_unit_block``).
#: Measured on the 1 000-link chain (hht-i3), at 0.57 of the band's flops: a
#: factorization in 0.45 of the band LU's time and a solve in 0.9 of its time.
UNIT_GAIN = 0.6
#: The dense inverse's flops (LAPACK's getrf and getri, then a product the compiler
#: vectorises) against the band and condensed loops' in the same time. Measured on
#: the spatial slider-crank (hht-i3, 71 unknowns): the dense inverse's 776 000
#: counted flops per factorization and six solves against the condensed solver's
#: 155 000, and 35 against 43 us per step: about 6; 8 keeps the dense inverse on
#: every model of up to a few bodies.
DENSE_FLOP_RATE = 8.0


def dense_split_plan(system, method, q, cm=None, pattern=None, condensed=None):
    """The "dense" plan of HHT-SI2's split Newton matrix: the explicit
    inverses of its two diagonal blocks of n + m unknowns, in the block
    codes of ``condensation.block_codes``, and the coordinate groups on
    which block 1 is tested against block 0 (``integrators.compiled.dense``);
    the pattern judged at q (n,) as in :func:`linear_solver_plan`, the
    groups those of the split's ``condensed`` plan where one was made."""
    size, n, m = newton_size(system, method), system.n, system.m
    rcode, ccode = block_codes(size, n, m, True)
    if condensed is not None:
        count, comp = len(condensed.condensed.groups), np.empty(n, np.int64)
        for g, coords in enumerate(condensed.condensed.groups):
            comp[coords] = g
    else:
        R, C = pattern if pattern is not None else newton_pattern(system, method, q, cm)
        comp, count = coordinate_groups(R, C, n, m, True)
    return LinearSolverPlan("dense", f"explicit inverses of 2 blocks of {n + m} unknowns "
                            f"({size} unknowns)", rcode, ccode, blocks=2,
                            groups=np.concatenate([[n, count], comp]).astype(np.int64))


def dense_split_cost(size) -> float:
    """A factorization's and six solves' flops of :func:`dense_split_plan`
    for ``size`` unknowns, weighed by ``DENSE_FLOP_RATE`` as the band LU's:
    two inverses of s = size / 2 unknowns (2 s^3 each), and per solve two
    products with them and one with L21 (2 s^2 each). On the IFToMM spatial
    slider-crank (s = 71, band kl = ku = 16) 201 000 against the band LU's
    233 000; on the planar chains the band LU stays far below."""
    s = size // 2
    return (4 * s ** 3 + 6 * 6 * s ** 2) / DENSE_FLOP_RATE


def condensed_cost(plan) -> int:
    """A factorization's and six solves' flops of a "condensed" plan."""
    c = plan.condensed
    return c.factor_flops + 6 * c.solve_flops


def condensed_solver_plan(system, method, q, split, addresses, cm=None, pattern=None):
    """The "condensed" plan (:mod:`.condensation`) of this model and method,
    its pattern judged at q (n,), or None where it does not apply: a Newton
    matrix not laid out as coordinates and multipliers (HHT-ADD's additive
    form; NSTIFF-SI2 and the other unsplit stabilized index-2 layouts), the
    augmented formulation (its multiplier block -epsilon I), or one
    :func:`.condensation.condensed_plan` refuses. ``pattern``: as
    :func:`band_ordering`'s."""
    n, m = system.n, system.m
    size = newton_size(system, method)
    if size != (2 if split else 1) * (n + m) or _recipe_value(method, "form") != 0.0:
        return None
    if getattr(method, "regularization", 0.0):
        return None
    if not split and _recipe_value(method, "has_y") != 0.0:
        return None
    R, C = pattern if pattern is not None else newton_pattern(system, method, q, cm)
    c = condensed_plan(R, C, n, m, split)
    if c is None:
        return None
    why = (f"condensed: {len(c.groups)} coordinate groups of at most "
           f"{max((len(g) for g in c.groups), default=0)}, Schur complement of {m} rows, "
           f"kl = {c.kl}, ku = {c.ku}, {c.blocks} block(s) ({size} unknowns)")
    return LinearSolverPlan("condensed", why, kl=c.kl, ku=c.ku, blocks=c.blocks,
                            addresses=addresses, condensed=c)
