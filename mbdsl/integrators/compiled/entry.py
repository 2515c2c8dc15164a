"""The entry points of the compiled engine: the kernels Python calls (the
facade :mod:`mbdsl.integrators.compiled` re-exports them), each a thin call of
the kernel that does the work, so that those can change signature-free."""

from __future__ import annotations

import numpy as np

from ...kernels.jit import borrowed as _b
from ...kernels.schema import _HEADER, _jit
from .index1 import _index1_multipliers, _index1_multipliers_band, _mobility
from .loop import _run, _workspace
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
        out_lam, out_mu, out_stats, counts, F0, state, trial, ws):
    """The compiled time loop; see ``_run``. Every array goes in as a
    borrowed view (``kernels.jit.borrowed``): the caller holds them all
    for the call, and the loop's kernels count no references to them."""
    return _run(_b(mono), _b(I), _b(Fl), h, t0, t_end, step0, every, _b(q), _b(v), _b(a), _b(b),
                _b(lam), _b(mu), _b(q_prev), _b(v_prev), _b(ctl), _b(opts), solver, _b(lin),
                _b(lu_state), _b(R), _b(C), _b(V), _b(out_t), _b(out_h), _b(out_q), _b(out_v),
                _b(out_a), _b(out_lam), _b(out_mu), _b(out_stats), _b(counts), _b(F0),
                _b(state), _b(trial), _b(ws))


@_jit
def workspace(n, m, size, I):
    """The time loop's scratch for a model of n coordinates and m
    constraint rows and a Newton iteration of ``size`` unknowns, for every
    call of ``run`` in one run; see ``_workspace``."""
    return _workspace(n, m, size, I)
