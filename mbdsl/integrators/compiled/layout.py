"""A recipe's unknowns and their predictors: the layout of w, the state (q, v)
of an iterate, the predictor of a step and generalized-alpha's auxiliary
acceleration (``recipe.py`` states the recipes, ``docs/methods.md`` the methods).
"""

from __future__ import annotations

from mbdsl.integrators.recipe import RECIPE_FIELDS

from ...kernels.schema import _hot, _inline, _jit, _put

#: The recipe entries (``recipe.RECIPE_FIELDS``, checked below): literals here, so that
#: numba's cache of this file never holds indices of another file's version.
(FORM, HAS_Y, SPLIT, CQX, CQY, CVX, CVY, CM, CF, DM, DI, DV, SP, SV, SX, SY, MU_MOB, FLOOR,
 PQ0, PQ1, PV0, PV1, PA, VV0, VV1, VA, Y0V, KA1, KA2, KB, CQ, SM, PB, VB, BB, BA, BX,
 REG, ERR, EAUX, EABS, MH) = range(42)
_RECIPE = ("form", "has_y", "split", "cqx", "cqy", "cvx", "cvy", "cM", "cF", "dM", "dI", "dV",
           "sP", "sV", "sx", "sy", "mu_mob", "floor",
           "pq0", "pq1", "pv0", "pv1", "pa", "vv0", "vv1", "va", "y0v",
           "ka1", "ka2", "kb", "cQ", "sm", "pb", "vb", "bb", "ba", "bx", "reg", "err", "eaux",
           "eabs", "mh")
if _RECIPE != RECIPE_FIELDS:     # pragma: no cover (a developer's error, caught by any test)
    raise ImportError("layout.py's recipe indices differ from recipe.RECIPE_FIELDS")

#: The two forms of a recipe: the linear family, and HHT with additive corrections.
LINEAR, ADDITIVE = 0, 1


@_inline
def _copy(dst, start, src):
    """dst[start:start + len(src)] = src, as a loop: an array assigned to a
    slice needs numba's reference counting (a temporary where the two
    overlap), which the ``_hot`` kernels are compiled without."""
    for j in range(src.shape[0]):
        dst[start + j] = src[j]


@_jit
def _emit_identity(n, R, C, V, p, r0, c0, coef):
    """coef I (n x n) at (r0, c0)."""
    for j in range(n):
        p = _put(R, C, V, p, r0 + j, c0 + j, coef)
    return p


@_jit
def _layout(rec, n, m):
    """(size, column of lambda, column of the extra multipliers, column of a)
    of the unknowns: w = (x, [y,] lambda, [mu]) in the linear form, (dq,
    dv, a, psi_I, psi_II) in the additive form (lambda := psi_II, the extra
    multipliers psi_I)."""
    if rec[FORM] == ADDITIVE:
        return 3 * n + 2 * m, 3 * n + m, 3 * n, 2 * n
    if rec[HAS_Y] != 0.0:
        return 2 * (n + m), 2 * n, 2 * n + m, 0
    return n + m, n, n + m, 0


@_hot
def _state(rec, n, w, q_pred, v_pred, qx, vx):
    """q_{n+1}, v_{n+1} into the extended vectors from the unknowns w."""
    cqx, cvx = rec[CQX], rec[CVX]
    for j in range(n):
        qx[j] = q_pred[j] + cqx * w[j]
        vx[j] = v_pred[j] + cvx * w[j]
    if rec[HAS_Y] != 0.0:
        cqy, cvy = rec[CQY], rec[CVY]
        for j in range(n):
            qx[j] += cqy * w[n + j]
            vx[j] += cvy * w[n + j]


@_hot
def predict(rec, first, q, v, a, b, q_prev, v_prev, q_pred, v_pred):
    """The recipe's predictors into q_pred, v_pred (n,) from the state at t_n
    (q, v, a, the auxiliary acceleration b) and, unless ``first``, the one h
    before (q_prev, v_prev)."""
    n = q.shape[0]
    pq0, pq1, pv0, pv1, pa = rec[PQ0], rec[PQ1], rec[PV0], rec[PV1], rec[PA]
    vv0, vv1, va = rec[VV0], rec[VV1], rec[VA]
    for j in range(n):
        q_pred[j] = pq0 * q[j] + pv0 * v[j] + pa * a[j]
        v_pred[j] = vv0 * v[j] + va * a[j]
    pb, vb = rec[PB], rec[VB]
    if pb != 0.0 or vb != 0.0:
        for j in range(n):
            q_pred[j] += pb * b[j]
            v_pred[j] += vb * b[j]
    if not first and (pq1 != 0.0 or pv1 != 0.0 or vv1 != 0.0):
        for j in range(n):
            q_pred[j] += pq1 * q_prev[j] + pv1 * v_prev[j]
            v_pred[j] += vv1 * v_prev[j]


@_hot
def _advance(rec, b, a, x):
    """The auxiliary acceleration b (n,) in place from t_n to t_{n+1}:
    b_{n+1} = bb b_n + ba a_n + bx x, x = a_{n+1} (recipes without it: nothing)."""
    bb, ba, bx = rec[BB], rec[BA], rec[BX]
    if bb != 0.0 or ba != 0.0 or bx != 0.0:
        for j in range(b.shape[0]):
            b[j] = bb * b[j] + ba * a[j] + bx * x[j]


#: The state map, the layout of the unknowns and the auxiliary's update, for the Python
#: Newton loop (``engine.SparseAdapter``): the same compiled functions as the time loop's.
state, layout, advance = _state, _layout, _advance
