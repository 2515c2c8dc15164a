"""The augmented formulation on the compiled engine: the same Newton matrix
as the numpy engine's (the multiplier block -epsilon I), and the same run
through singular positions."""

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators import NewtonOptions, integrate, make_method
from mbdsl.integrators.engine import SparseAdapter, unsupported

from ..conftest import MODELS

AUGMENTED = ["newmark", "hht-i3", "nstiff", "genalpha"]


def _system(N):
    model = mbdsl.load(MODELS / "n_fourbar.mbd", overrides={"N": N})
    system = mbdsl.assemble(model)
    return system, mbdsl.consistent_initial_state(system)


@pytest.mark.parametrize("method", AUGMENTED)
def test_kernel_newton_matrix_is_the_numpy_augmented_one(method):
    system, init = _system(2)
    m = make_method(method).formulated("augmented", system)
    assert unsupported(system, m) is None
    ad = SparseAdapter(system, m)
    hist = m.start(system, init)
    ctx = ad.context(system, hist, hist[-1].t + 1e-2, 1e-2)
    ctx.regularization = m.regularization
    rng = np.random.default_rng(5)
    w = m.predict(ctx) + 0.1 * rng.standard_normal(ad.size)
    J = ad.jacobian(w, ctx).toarray()
    ref = m.jacobian(w, ctx)
    ref = ref.toarray() if hasattr(ref, "toarray") else np.asarray(ref)
    n, k = system.n, system.m
    # the multiplier block: -epsilon I, where the Lagrange matrix has zeros
    assert m.regularization > 0
    assert np.array_equal(np.diag(J[n:, n:]), np.full(k, -m.regularization))
    assert np.abs(J - ref).max() < 1e-12 * np.abs(ref).max()


@pytest.mark.parametrize("method", AUGMENTED)
def test_compiled_run_through_singular_positions_matches_numpy(method):
    """N = 1 over 2.5 s at h = 1e-3: two singular positions; both engines
    take the same steps to the Newton tolerance."""
    system, init = _system(1)
    m = make_method(method).formulated("augmented", system)
    opt = NewtonOptions(rate_refresh=0.1)
    a = integrate(system, m, 2.5, 1e-3, initial=init, engine="numpy", newton=opt)
    b = integrate(system, m, 2.5, 1e-3, initial=init, engine="compiled", newton=opt)
    assert a.engine == "numpy" and b.engine == "compiled"
    assert a.status == b.status == "completed"
    assert np.abs(a.t - b.t).max() < 1e-12
    assert np.abs(a.q - b.q).max() < 2e-8        # measured 5e-10 to 4.9e-9
