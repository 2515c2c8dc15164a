"""The index-1 accelerations of an index-3 method's error estimate on the band
Schur complement (``adaptive.index1_acceleration``, the compiled loop's
``compiled.index1._index1_acceleration``).

Checked against the projection written out here with dense numpy (the
pseudo-inverse of Phi_q M^-1 Phi_q^T by least squares, Haug 1989, sec. 6.3),
on a chain longer than the dense solve's limit and on a linkage whose
redundant joint makes the band Cholesky refuse the matrix.
"""

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators import integrate, make_method
from mbdsl.integrators.adaptive import (StepControl, _index1_acceleration_band,
                                        index1_acceleration)
from mbdsl.integrators.engine import _index1_band, index1_band_vector
from mbdsl.integrators.kernel_cache import uncompiled_kernels
from mbdsl.integrators.records import INDEX1_LIMIT

from ..conftest import MODELS


def _system(path, **params):
    model = mbdsl.load(path, overrides=params) if params else mbdsl.load(path)
    system = mbdsl.assemble(model)
    return system, mbdsl.consistent_initial_state(system, redundant="accept")


def _dense_projection(system, t, q, v, a):
    """a - M^-1 Phi_q^T (Phi_q M^-1 Phi_q^T)^+ (Phi_q a - gamma) with dense numpy."""
    P = system.Phi_q(q, t)
    P = P.toarray() if hasattr(P, "toarray") else np.asarray(P)
    W = P.T / system.mass_diag[:, None]
    z = np.linalg.lstsq(P @ W, P @ a - system.gamma(q, v, t), rcond=1e-13)[0]
    return a - W @ z


def _kernel_projection(system, t, q, v, a, band, dense=True):
    """The compiled loop's operation, run by the uncompiled kernels."""
    K = uncompiled_kernels()
    km = system.kernel_model()
    n, m = system.n, system.m
    qx, vx = np.zeros(n + 3), np.zeros(n + 3)
    qx[:n], vx[:n] = q, v
    R, C, V = np.empty(km.bound, np.int64), np.empty(km.bound, np.int64), np.empty(km.bound)
    scratch = K._index1_scratch(km.ints, km.floats, n, m, dense, band, R, C, V)
    out = np.empty(n)
    K._index1_acceleration(km.ints, km.floats, n, m, t, qx, vx, a, out, R, C, V, scratch)
    return out


def _state(system, init, seed):
    rng = np.random.default_rng(seed)
    q = init.q + 1e-3 * rng.standard_normal(system.n)
    v = rng.standard_normal(system.n)
    return q, v, rng.standard_normal(system.n)


def test_a_chain_above_the_dense_limit_is_projected_on_the_band():
    """150 links (300 constraint rows, above INDEX1_LIMIT): the band solve
    gives the dense projection to 1e-9 of |a| in both engines' copies, with
    Phi_q a1 = gamma; the plan is a band of half-width 3 (2 rows a pin)."""
    system, init = _system(MODELS / "pendulum_chain.mbd", N=150)
    assert system.m == 300 > INDEX1_LIMIT
    order, kd = _index1_band(system)
    assert kd <= 3
    t, (q, v, a) = 0.3, _state(system, init, 5)
    ref = _dense_projection(system, t, q, v, a)
    P = system.Phi_q(q, t)
    got = index1_acceleration(system, t, q, v, a, dense=False)
    scale = np.abs(a).max() + np.abs(ref).max()
    assert np.abs(got - ref).max() < 1e-9 * scale
    assert np.abs(P @ got - system.gamma(q, v, t)).max() < 1e-9 * scale
    kernel = _kernel_projection(system, t, q, v, a, index1_band_vector(system), dense=False)
    assert np.abs(kernel - ref).max() < 1e-9 * scale
    # without the plan and above the limit, the estimate reads a as it is
    empty = np.empty(0, np.int64)
    assert np.array_equal(_kernel_projection(system, t, q, v, a, empty, dense=False), a)


def test_a_redundant_joint_falls_back_to_the_pseudo_inverse():
    """The parallelogram with a redundant crank: Phi_q M^-1 Phi_q^T is
    singular, the band Cholesky refuses it (a pivot of round-off), and the
    dense least squares gives the pseudo-inverse's projection; without the
    dense solve (above the limit) a is kept."""
    system, init = _system(MODELS / "parallelogram_redundant.mbd")
    t, a = 0.0, _state(system, init, 7)[2]
    q, v = init.q, init.v                     # on the constraint manifold: the rank loss exact
    assert _index1_acceleration_band(system, _index1_band(system), t, q, v, a) is None
    ref = _dense_projection(system, t, q, v, a)
    scale = np.abs(a).max() + np.abs(ref).max()
    assert np.abs(index1_acceleration(system, t, q, v, a) - ref).max() < 1e-9 * scale
    band = index1_band_vector(system)
    assert np.abs(_kernel_projection(system, t, q, v, a, band) - ref).max() < 1e-9 * scale
    assert np.array_equal(index1_acceleration(system, t, q, v, a, dense=False), a)
    assert np.array_equal(_kernel_projection(system, t, q, v, a, band, dense=False), a)


@pytest.mark.parametrize("links", [100, 110])
def test_error_controlled_chain_steps_agree_between_engines(links):
    """hht-i3 with rtol 1e-3 on chains at and above the dense limit (200 and
    220 constraint rows): the compiled loop and the numpy engine, both on
    the band projection, take the same number of steps within 5 % and end
    within 1e-6 m of each other (measured: the same steps, 1e-10 m)."""
    system, init = _system(MODELS / "pendulum_chain.mbd", N=links)
    runs = {engine: integrate(system, make_method("hht-i3"), 0.2, 1e-3, initial=init,
                              engine=engine, control=StepControl(1e-3, 1e-3))
            for engine in ("numpy", "compiled")}
    for engine, sol in runs.items():
        assert sol.status == "completed" and sol.engine == engine, sol.message
    n = {e: r.stats_total.steps for e, r in runs.items()}
    assert n["compiled"] == pytest.approx(n["numpy"], rel=0.05), n
    assert np.abs(runs["compiled"].q[-1] - runs["numpy"].q[-1]).max() < 1e-6
