"""The flexible beams' one implementation, the kernels (``kernels.beams.ffr._ffr_local``,
``_ffr_energy``, called from Python through ``assembly.ffr``), against
an independent vectorised numpy evaluation of the same equations
(``ffr_oracle.BeamOracle``) at random states, on the compiled kernels and on
their uncompiled copy.

The oracle shares only the beams' meshes with the kernels (the model
data; it computes their shape integrals and stiffness itself); a sign or a missing term in either shows as a
difference far above round-off. The finite-difference checks of Q_q, Q_v
and (M a)_q against Q and M a are in ``tests/assembly/test_derivatives.py``,
the mass matrix and Q against point-by-point kinetic energy in
``test_beam.py``.
"""

from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.assembly import ffr
from mbdsl.integrators.engine import CompiledModel, _kernels

from .ffr_oracle import BeamOracle

ROOT = Path(__file__).resolve().parents[2]
MODELS = [ROOT / "models" / "flexible_slider_crank.mbd",     # gravity, stiffening
          ROOT / "models" / "spinup_beam.mbd",               # no gravity, stiffening
          Path(__file__).with_name("spinup_beam.mbd"),       # stiffening off
          ROOT / "tests" / "dsl" / "valid" / "flexible_elements.mbd",   # two sizes of beam
          ROOT / "tests" / "dsl" / "valid" / "flexible_joints.mbd"]


def _states(system, seed):
    """Random (q, v, x) with deformations of a few centimetres."""
    rng = np.random.default_rng(seed)
    for _ in range(3):
        q, v, x = rng.normal(size=(3, system.n))
        for b in system.model.flexible_bodies:
            q[b.elastic_columns()] *= 0.03
        yield q, v, x


@pytest.fixture(scope="module", params=["compiled", "uncompiled"])
def kernels(request):
    return _kernels(uncompiled=request.param == "uncompiled")


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_beam_kernels_match_the_numpy_oracle(path, kernels):
    system = mbdsl.assemble(mbdsl.load(path))
    cm = CompiledModel(system, kernels)
    for s in system.beam_sets:
        o = BeamOracle.of(system, s)
        for q, v, x in _states(system, seed=len(s.beams)):
            pairs = [(ffr.mass_blocks(cm, s, q), o.mass_blocks(q)),
                     (ffr.forces(cm, s, q, v), o.forces(q, v, 0.0)),
                     (ffr.Ma_q(cm, s, q, x), o.Ma_q(q, x)),
                     (ffr.tangent_stiffness(cm, s, q), o.tangent_stiffness(q))]
            pairs += list(zip(ffr.derivatives(cm, s, q, v), o.derivatives(q, v, 0.0)))
            for got, want in pairs:
                assert got.shape == want.shape
                np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())
            rows = np.stack([q, 0.5 * q, -q])
            want = o.energy(rows)
            k = len(s.beams)
            np.testing.assert_allclose(ffr.energy(cm, rows, s.first, k), want, rtol=1e-12,
                                       atol=1e-12 * np.abs(want).max())
            assert ffr.energy(cm, q, s.first, k) == pytest.approx(float(want[0]), rel=1e-12)
            strain = o.strain_energy(q).sum()
            assert ffr.energy(cm, q, s.first, k, gravity=False) == pytest.approx(strain, rel=1e-12)
            assert strain > 0.0


def test_the_oracle_sees_a_wrong_term(kernels):
    # The comparison above is sharp: the elastic force of a beam with its
    # stiffness off by one part in 10^6 differs from the oracle's far above the
    # tolerance used there.
    system = mbdsl.assemble(mbdsl.load(MODELS[0]))
    cm = CompiledModel(system, kernels)
    s = system.beam_sets[0]
    o = BeamOracle.of(system, s)
    o.K = o.K * (1.0 + 1e-6)
    q, v, _ = next(_states(system, seed=3))
    want = o.forces(q, v, 0.0)
    assert np.abs(ffr.forces(cm, s, q, v) - want).max() > 1e3 * 1e-12 * np.abs(want).max()


def test_a_system_evaluates_its_beams_on_the_kernels_it_can_call():
    # A process that has not loaded the compiled kernels and whose machine has
    # not built them evaluates its beams uncompiled; either way through the
    # same packed model data as a run.
    from mbdsl.integrators import kernel_cache
    system = mbdsl.assemble(mbdsl.load(MODELS[0]))
    cm = system.kernel_model()
    assert cm.uncompiled == (not (kernel_cache.loaded() or kernel_cache.kernels_ready()))
    assert system.kernel_model() is cm
    q = np.zeros(system.n)
    M = system.mass_matrix(q)
    np.testing.assert_allclose(np.diag(M), system.mass_diag, rtol=1e-14)


def test_a_pickled_system_evaluates_as_the_original():
    # The kernel models hold a module and are not pickled; a copy builds its own
    # (process pools ship systems and solutions).
    import pickle
    system = mbdsl.assemble(mbdsl.load(MODELS[0]))
    q = np.full(system.n, 0.01)
    before = (system.mass_matrix(q), system.Phi_q(q), system.Q(0.0, q, q))
    copy = pickle.loads(pickle.dumps(system))
    assert copy._kernel_models == {}
    for a, b in zip(before, (copy.mass_matrix(q), copy.Phi_q(q), copy.Q(0.0, q, q))):
        np.testing.assert_array_equal(a, b)
