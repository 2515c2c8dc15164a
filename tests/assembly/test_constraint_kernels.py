"""The joints' and drivers' one implementation, the kernels (called from
Python through ``AssembledSystem.Phi``, ``Phi_q``, ``Phi_t``, ``Phi_tt``,
``gamma``, ``PhiqT_lam_q``, ``Phiq_v_q`` and the matrix-free products),
against an independent vectorised numpy evaluation of the same equations
(``constraint_oracle.ConstraintOracle``) at random states, on every shipped
model and every valid test model, on the compiled kernels and on their
uncompiled copy.

The finite-difference checks of each derivative against the function it
differentiates are in ``test_derivatives.py``; this test pins the values
themselves (a wrong offset, length or sign that every derivative shares).
"""

import dataclasses

import numpy as np
import pytest

from .constraint_oracle import ConstraintOracle
from .kernel_models import (FILES, ROOT, kernels, system_on,  # noqa: F401 (a fixture)
                            system_on_model)


def _close(got, want):
    scale = max(1.0, float(np.abs(want).max(initial=0.0)))
    assert np.shape(got) == np.shape(want)
    assert np.abs(np.asarray(got) - want).max(initial=0.0) <= 1e-13 * scale


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_constraint_kernels_match_the_numpy_oracle(path, kernels):
    system = system_on(path, kernels)
    o = ConstraintOracle(system)
    rng = np.random.default_rng(len(path.stem))
    for t in (0.0, 0.37, 1.9):
        q, v = rng.normal(size=(2, system.n))
        lam = rng.normal(size=system.m)
        _close(system.Phi(q, t), o.Phi(q, t))
        _close(system.Phi_q(q, t), o.Phi_q(q, t))
        _close(system.PhiqT_lam_q(q, lam), o.PhiqT_lam_q(q, lam))
        _close(system.Phiq_v_q(q, v), o.Phiq_v_q(q, v))
        _close(system.Phi_t(q, t), o.Phi_t(t))
        _close(system.Phi_tt(q, t), o.Phi_t(t, 2))
        _close(system.gamma(q, v, t), o.gamma(q, v, t))
        _close(system.Phiq_times(q, t, v), o.Phi_q(q, t) @ v)
        _close(system.PhiqT_times(q, t, lam), o.Phi_q(q, t).T @ lam)
    # rows of a stored solution at once, as the output evaluates them
    Q, T = rng.normal(size=(3, system.n)), np.array([0.0, 0.5, 1.5])
    _close(system.Phi(Q, T), np.stack([o.Phi(q, t) for q, t in zip(Q, T)]))
    _close(system.Phi_t(Q[0], T), np.stack([o.Phi_t(t) for t in T]))
    _close(system.Phiq_times(Q, T, 2.0 * Q), np.stack([o.Phi_q(q) @ (2.0 * q) for q in Q]))
    values = system.Phi_q_values(Q, T)
    for q, t, row in zip(Q, T, values):
        _close(system._dense(system.pattern_Phi_q, row, (system.m, system.n)), o.Phi_q(q, t))


def test_the_oracle_sees_a_wrong_length(kernels):
    # Sharp: a distance joint's length off by one part in 10^9 moves Phi far
    # above the tolerance of the comparison above.
    system = system_on(ROOT / "tests" / "dsl" / "valid" / "distance_elements.mbd", kernels)
    o = ConstraintOracle(system)
    q = np.random.default_rng(4).normal(size=system.n)
    want = o.Phi(q, 0.0)
    joints = [dataclasses.replace(j, length=j.length * (1.0 + 1e-9)) if j.kind == "distance"
              else j for j in system.model.joints]
    longer = dataclasses.replace(system.model, joints=joints)
    assert np.abs(ConstraintOracle(system, longer).Phi(q, 0.0) - want).max() > 1e2 * 1e-13 * max(
        1.0, np.abs(want).max())
    # and so does the system packed from it (the kernels read the model's lengths)
    assert np.abs(system_on_model(longer, kernels).Phi(q, 0.0) - want).max() > 1e2 * 1e-13 * max(
        1.0, np.abs(want).max())


def test_patterns_are_fixed_by_the_model(kernels):
    # The triplets' (row, column) pattern is the same at any state: the
    # numpy engine's Newton matrices and the reactions are built on it once.
    system = system_on(ROOT / "tests" / "dsl" / "valid" / "flexible_joints.mbd", kernels)
    K, cm = kernels, system.kernel_model()
    rng = np.random.default_rng(7)
    for what, width in ((K.C_PHIQ, 1), (K.C_PHIQT_Y_Q, system.m), (K.C_PHIQ_Y_Q, system.nx)):
        rows, cols = system._constraint_pattern(what)
        assert len(rows) > 0
        for _ in range(2):
            qx = np.zeros((1, system.nx))
            qx[0, :system.n] = rng.normal(size=system.n)
            R, C = np.empty(cm.bound, np.int64), np.empty(cm.bound, np.int64)
            p = K.elements(cm.ints, cm.floats, what, np.zeros(1), qx, qx,
                           rng.normal(size=(1, width)), np.zeros(0), np.zeros((0, 0)),
                           np.zeros((0, 0)), R, C, np.empty((1, cm.bound)))
            assert p == len(rows)
            assert np.array_equal(R[:p], rows) and np.array_equal(C[:p], cols)


def test_the_packages_copies_of_the_kernels_constants_agree(kernels):
    # system.py and ffr.py repeat the kernels' selectors so that building a
    # model never imports numba; they must be the kernels' own.
    from mbdsl.assembly import ffr, system
    assert (system._C_PHI, system._C_PHI_T, system._C_PHI_TT, system._C_PHIQ_Y,
            system._C_PHIQT_Y, system._C_PHIQ, system._C_PHIQT_Y_Q, system._C_PHIQ_Y_Q) == (
        kernels.C_PHI, kernels.C_PHI_T, kernels.C_PHI_TT, kernels.C_PHIQ_Y, kernels.C_PHIQT_Y,
        kernels.C_PHIQ, kernels.C_PHIQT_Y_Q, kernels.C_PHIQ_Y_Q)
    assert (ffr.FFR_M, ffr.FFR_Q, ffr.FFR_DQ, ffr.FFR_MXQ) == (
        kernels.FFR_M, kernels.FFR_Q, kernels.FFR_DQ, kernels.FFR_MXQ)
