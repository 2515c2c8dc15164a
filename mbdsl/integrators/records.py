"""The named places of the vectors the time loop, Newton and the banded solver
share between Python and the compiled kernels.

The run's state, the error control's settings, Newton's options and
factorization state, the linear solver's workspace and LAPACK's arguments
cross every call of the compiled time loop as small arrays (and one tuple of
arrays). Each place has a name here, and every reader and writer, Python or
compiled, uses the name: ``state[ST_H]``, never ``state[1]``.

Why named indices, not a numba record or named tuple: numba reads a
module's integer globals as compile-time constants, so ``state[ST_H]``
compiles to the load ``state[1]`` did, and the arrays keep their types; a
structured array or a named tuple would give every entry point a new
signature and the loop's per-step code new loads. The field names are listed
beside the constants and checked against them at import, as
``kernels.schema`` does for the model data.
"""

from __future__ import annotations

import numpy as np

__all__ = ["STATE_FIELDS", "CONTROL_FIELDS", "OPTION_FIELDS", "LU_FIELDS", "LIN_FIELDS",
           "LAPACK_FIELDS", "COUNT_FIELDS", "CONDENSED_FIELDS"]

#: The run's state (float64, ``loop.Loop.state``): t at the last accepted step [s], the
#: next step's size [s], the error control's rejections, the last step's size (0: none,
#: the BDF start), the stepper's mode (``outcomes``: RUN, ATTEMPT, LAND), the Kahan
#: compensation of the sum t, whether the last attempt was rejected, how many accepted
#: steps a call may take (0: no limit), the step-size filter's last error per unit step
#: and step ratio.
STATE_FIELDS = ("t", "h", "rejected", "h_last", "mode", "carry", "after_rejection", "limit",
                "err", "ratio")
(ST_T, ST_H, ST_REJECTED, ST_H_LAST, ST_MODE, ST_CARRY, ST_AFTER_REJECTION, ST_LIMIT, ST_ERR,
 ST_RATIO) = range(10)

#: The step control (float64, ``loop.Loop.ctl``): rtol, atol, the safety factor, the
#: smallest and largest step ratio, h_min and h_max [s], fixed steps (1) or not, the
#: error estimated on the index-1 accelerations (1) or not.
CONTROL_FIELDS = ("rtol", "atol", "safety", "min_factor", "max_factor", "h_min", "h_max",
                  "fixed", "index1")
(CTL_RTOL, CTL_ATOL, CTL_SAFETY, CTL_MIN_FACTOR, CTL_MAX_FACTOR, CTL_H_MIN, CTL_H_MAX, CTL_FIXED,
 CTL_INDEX1) = range(9)

#: Newton's options (float64, ``engine.CompiledStepper.opts``): rtol, atol of the
#: kinematic unknowns and of the multipliers, the most iterations, the contraction rate
#: above which the Newton matrix is refreshed, a full Newton matrix every iteration (1),
#: the start extrapolated from the steps before (1) or the last state's (0).
OPTION_FIELDS = ("rtol", "atol_kinematic", "atol_multiplier", "max_iter", "refresh", "full",
                 "extrapolate")
(OPT_RTOL, OPT_ATOL_KINEMATIC, OPT_ATOL_MULTIPLIER, OPT_MAX_ITER, OPT_REFRESH, OPT_FULL,
 OPT_EXTRAPOLATE) = range(7)

#: The factorization's state (float64, ``lu_state``): valid (1) or not, the last
#: contraction rate, the step and c0 it was made for.
LU_FIELDS = ("valid", "rate", "step", "c0")
LU_VALID, LU_RATE, LU_STEP, LU_C0 = range(4)

#: The linear solver's workspace (a tuple, ``engine.SolverPlan.workspace``): the dense
#: Newton matrix and its inverse, the band storage, pivots, the band ordering's row and
#: column permutations, LAPACK's arguments (``LAPACK_FIELDS``), the address of LAPACK's
#: band LU (dgbtrf), the right-hand side, the triplets of the split form's lower
#: block, and the condensed solver's plan (int64, ``CONDENSED_FIELDS``) and float
#: workspace (``compiled.condensed``).
LIN_FIELDS = ("J", "Jinv", "AB", "ipiv", "rperm", "cperm", "lp", "addr", "b", "Lr", "Lc", "Lv",
              "cp", "cw")
(LIN_J, LIN_JINV, LIN_AB, LIN_IPIV, LIN_RPERM, LIN_CPERM, LIN_LP, LIN_ADDR, LIN_B,
 LIN_LR, LIN_LC, LIN_LV, LIN_CP, LIN_CW) = range(14)

#: The condensed solver's plan (int64, ``lin[LIN_CP]``, ``solver_plans.condensed_solver_plan``): its
#: header, then arrays at the offsets the header names. n coordinates and m constraint
#: rows per block; the coordinate groups (``groups``) the Newton matrix's coordinate
#: block falls into; floats per block in ``cw`` (``wstride``); the offsets of: each
#: Newton row's and column's code (block * (n + m) + place in the block: coordinate j,
#: or n + constraint row i), each coordinate's group and place in it, each constraint
#: row's groups and slots (``tstart``, ``tg``, ``tslot``), each group's coordinates
#: (``gkoff``, ``gcoord``) and slotted rows (``groff``, ``grows``), its blocks' offset in
#: ``cw`` (``goff``), the rows' order in the Schur complement's band (``sperm``), the
#: groups' LU pivots (``pivots``, n per block); the offset in ``cw`` of its scratch;
#: and the triplets of the pattern it was made on (their count, rows ``tr`` and
#: columns ``tc``) with each one's place (``dest``: in ``cw``, or -1 left out, or
#: -2 - k the lower block's k-th entry); each group's slotted rows' places in the
#: Schur complement's band (``gband``, as ``grows``); the offsets in ``cw`` of the lower
#: block's area (``lower``: L21 in block 1's places, one block's floats where there are
#: two blocks) and of the shared factorization's record (``share``: whether block 1 is
#: solved with block 0's factors, and the scalars cA, cC, cB, cL of ``condensed``); each
#: lower-block triplet's place in the lower area (``lplace``, -1: none); whether every
#: group is one coordinate (``unit``: a diagonal coordinate block), and then each
#: constraint row's entries of B (``brptr``, m + 1 offsets into ``brsrc``, each entry's
#: place in a block of ``cw``, and ``brcoord``, its coordinate), which the solve reads
#: row by row (``compiled.condensed._unit_block``); whether the Newton rows' and
#: columns' codes are their own indices, one block (``direct``: the solve works in the
#: update's own array, ``compiled.condensed._condensed_solve``).
CONDENSED_FIELDS = ("n", "m", "groups", "wstride", "rmap", "cmap", "comp", "pos", "tstart",
                    "tg", "tslot", "gkoff", "gcoord", "groff", "grows", "goff", "sperm",
                    "pivots", "scratch", "triplets", "tr", "tc", "dest", "gband", "lower",
                    "share", "lplace", "unit", "brptr", "brsrc", "brcoord", "direct")
(CP_N, CP_M, CP_GROUPS, CP_WSTRIDE, CP_RMAP, CP_CMAP, CP_COMP, CP_POS, CP_TSTART, CP_TG,
 CP_TSLOT, CP_GKOFF, CP_GCOORD, CP_GROFF, CP_GROWS, CP_GOFF, CP_SPERM, CP_PIVOTS,
 CP_SCRATCH, CP_TRIPLETS, CP_TR, CP_TC, CP_DEST, CP_GBAND, CP_LOWER, CP_SHARE,
 CP_LPLACE, CP_UNIT, CP_BRPTR, CP_BRSRC, CP_BRCOORD, CP_DIRECT) = range(32)

#: LAPACK's integer arguments (int32, ``lin[LIN_LP]``), passed by reference as one-entry
#: slices: dgbtrf's M and N, KL, KU, LDAB, INFO; then the blocks of the matrix (1, or 2
#: for the additive form) and the lower block's triplets.
LAPACK_FIELDS = ("m", "n", "kl", "ku", "ldab", "info", "blocks", "nc")
(LP_M, LP_N, LP_KL, LP_KU, LP_LDAB, LP_INFO, LP_BLOCKS, LP_NC) = range(8)

#: The Newton counts since the last recorded row (int64, ``loop.RowBuffers.counts``):
#: iterations, residuals, Newton matrices, factorizations, steps whose multipliers
#: stalled at round-off, accepted steps.
COUNT_FIELDS = ("iterations", "residuals", "jacobians", "factorizations", "stalled", "steps")
(CNT_ITERATIONS, CNT_RESIDUALS, CNT_JACOBIANS, CNT_FACTORIZATIONS, CNT_STALLED,
 CNT_STEPS) = range(6)


def _check():
    """The literals above against their field lists (an edit of one without the
    other is an import error, not a wrong index)."""
    g = globals()
    for prefix, fields in (("ST_", STATE_FIELDS), ("CTL_", CONTROL_FIELDS),
                           ("OPT_", OPTION_FIELDS), ("LU_", LU_FIELDS), ("LIN_", LIN_FIELDS),
                           ("LP_", LAPACK_FIELDS), ("CNT_", COUNT_FIELDS),
                           ("CP_", CONDENSED_FIELDS)):
        for k, name in enumerate(fields):
            if g.get(prefix + name.upper()) != k:
                raise ImportError(f"records.py: {prefix}{name.upper()} is not {k}")


_check()


def vector(fields, dtype=float, **values):
    """A record's array with every field set by name.

    Parameters
    ----------
    fields : tuple of str
        One of the ``*_FIELDS`` lists above.
    dtype : numpy dtype
    **values
        A value for each field.

    Raises
    ------
    ValueError
        A field missing or unknown.
    """
    if set(values) != set(fields):
        raise ValueError(f"record fields {sorted(set(fields) ^ set(values))} missing or unknown")
    return np.array([values[name] for name in fields], dtype=dtype)


#: Constraint rows up to which an index-3 method's error estimate is taken on
#: its index-1 accelerations by the dense least-squares solve
#: (``compiled.index1._index1_acceleration_dense``: m Jacobian products and an
#: m x m SVD per step). Rigid bodies take the band Cholesky of
#: ``compiled.index1._index1_acceleration_band`` at any size, and the dense
#: solve only where that refuses the matrix (redundant joints, a singular
#: position); above this size such a step's estimate reads a as it is. Both
#: engines read it (``compiled.loop._run_flags``, ``PythonStepper``).
INDEX1_LIMIT = 200
