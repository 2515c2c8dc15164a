"""The entry points of the compiled engine: the kernels Python calls (the
facade :mod:`mbdsl.integrators.compiled` re-exports them), each a thin call of
the kernel that does the work, so that those can change signature-free."""

from __future__ import annotations

import numpy as np

from ...kernels.schema import _HEADER, _jit
from .index1 import _index1_multipliers, _index1_multipliers_band, _mobility
from .loop import _run
from .recipes import _force_term, _jacobian_triplets, _old_force, _residual


@_jit
def residual(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work):
    """Upsilon(w) of recipe ``rec`` into r; see ``_residual``. Returns False
    when r is not finite."""
    _residual(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work)
    for x in r:
        if not np.isfinite(x):
            return False
    return True


@_jit
def jacobian_triplets(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx, vx):
    """Newton-matrix triplets; see ``_jacobian_triplets``. Returns their count."""
    return _jacobian_triplets(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx, vx)


@_jit
def old_force(rec, I, Fl, t, q, v, lam, out, qx, vx, work):
    """F_n of the recipe into out (n,); see ``_old_force``."""
    _old_force(rec, I, Fl, t, q, v, lam, out, qx, vx, work)


@_jit
def force_term(I, Fl, t, q, v, lam, out, qx, vx, work):
    """Phi_q^T lambda - Q(q, v) into out (n,)."""
    _force_term(I, Fl, t, q, v, lam, out, qx, vx, work)


@_jit
def index1_multipliers(I, Fl, t, q, v, out, R, C, V, iterations):
    """Entry point of ``_index1_multipliers``."""
    _index1_multipliers(I, Fl, t, q, v, out, R, C, V, iterations)


@_jit
def index1_multipliers_band(I, Fl, t, q, v, out, R, C, V, iterations, order, kd, addr):
    """Entry point of ``_index1_multipliers_band``."""
    _index1_multipliers_band(I, Fl, t, q, v, out, R, C, V, iterations, order, kd, addr)


@_jit
def mobility(I, Fl, q, out, R, C, V, qx):
    """Multiplier mobility per constraint row into out (m,)."""
    _mobility(I, Fl, q, out, R, C, V, qx, np.empty(I[_HEADER - 1]))


@_jit
def run(mono, I, Fl, h, t0, t_end, step0, every, q, v, a, b, lam, mu, q_prev, v_prev,
        ctl, opts, solver, lin, lu_state, R, C, V, out_t, out_h, out_q, out_v, out_a,
        out_lam, out_mu, out_stats, counts, F0, state, trial):
    """The compiled time loop; see ``_run``."""
    return _run(mono, I, Fl, h, t0, t_end, step0, every, q, v, a, b, lam, mu, q_prev,
                v_prev, ctl, opts, solver, lin, lu_state, R, C, V, out_t, out_h, out_q,
                out_v, out_a, out_lam, out_mu, out_stats, counts, F0, state, trial)
