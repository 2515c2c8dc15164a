"""The entry points of the compiled engine: the kernels Python calls (the
facade :mod:`mbdsl.integrators.compiled` re-exports them).

Most are the kernels that do the work, under the name Python knows them
by. numba compiles every function with all its callees linked in and
optimizes and emits machine code for that whole tree again, so a wrapper
that only calls a kernel costs a second compilation of the kernel's tree
(measured: 21 s of the 170 s build for six wrappers, docs/performance.md).
A wrapper stays where it adds work: ``residual`` tests r for finite
values, ``mobility`` allocates its scratch."""

from __future__ import annotations

import numpy as np

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
def mobility(I, Fl, q, out, R, C, V, qx):
    """Multiplier mobility per constraint row into out (m,)."""
    _mobility(I, Fl, q, out, R, C, V, qx, np.empty(I[_HEADER - 1]))


#: Newton-matrix triplets (``_jacobian_triplets``; returns their count)
jacobian_triplets = _jacobian_triplets
#: F_n of the recipe into out (n,) (``_old_force``)
old_force = _old_force
#: Phi_q^T lambda - Q(q, v) into out (n,) (``_force_term``)
force_term = _force_term
#: The index-1 multipliers, dense (``_index1_multipliers``) and banded
#: (``_index1_multipliers_band``)
index1_multipliers = _index1_multipliers
index1_multipliers_band = _index1_multipliers_band
#: The compiled time loop (``loop._run``), which borrows its arrays itself
run = _run
#: The time loop's scratch for one run (``loop._workspace``), lent to every call of ``run``
workspace = _workspace
