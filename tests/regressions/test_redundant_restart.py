"""A redundant joint and an event: the restart on the event's new branch
takes the least-norm multipliers.

``redundant_restart.mbd``: a distance joint C between two pinned points
repeats what their pins impose (W405, the augmented formulation), and a
torque table of time kinks at 0.05 s and 0.1 s. The restart at a kink solved
the index-1 system [[M, Phi_q^T], [Phi_q, 0]], singular there, by LU: the
multipliers came out near 1e20 N, the distance joint's Hessian term made
the next Newton matrix singular, and newmark, hht-i3 and genalpha stopped
at the first kink with a singular Newton matrix (found by the semantic
fuzzer: under a tolerance, 328 000 steps of 1.5e-7 s before that stop).
The redundant joint adds nothing to the motion: the arm moves as in the
same model without it.
"""

from pathlib import Path

import numpy as np
import pytest

import mbdsl

MODEL = Path(__file__).with_name("redundant_restart.mbd")


@pytest.fixture(scope="module")
def models():
    text = MODEL.read_text()
    without = text.replace("joint C: distance(w.cm, p.cm, length = 2.5)\n", "")
    assert without != text
    return mbdsl.load(MODEL), mbdsl.load_text(without)


@pytest.mark.parametrize("method", ["newmark", "hht-i3", "nstiff", "genalpha"])
@pytest.mark.parametrize("rtol", [None, 1e-6])
def test_a_redundant_joint_passes_the_events_as_the_model_without_it(models, method, rtol):
    redundant, plain = models
    runs = [mbdsl.simulate(m, method=method, rtol=rtol, on_failure="return")
            for m in (redundant, plain)]
    for sol in runs:
        assert sol.status == "completed", sol.message
        assert sum(e[2] == "switched" for e in sol.events) == 2
    a, b = (sol.column("arm.phi") for sol in runs)
    if rtol is None:                                   # the same fixed steps
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
    else:                                              # each its own steps
        assert abs(a[-1] - b[-1]) < 1e-4
    moved = abs(b[-1] - b[0])
    assert moved > 0.05                                # the arm swings: a sharp comparison
    lam = runs[0].lam
    assert np.all(np.isfinite(lam))
    if rtol is None:     # (under a tolerance the augmented iteration's multipliers wander in
        assert np.abs(lam).max() < 1e3     # the null space of Phi_q^T: only Phi_q^T lambda is unique)


def test_the_least_norm_solve_meets_the_index1_equations(models):
    """Where K is singular the solve returns accelerations that meet M a +
    Phi_q^T lambda = Q and Phi_q a = gamma, with the multipliers of least
    norm (none along the null space of Phi_q^T)."""
    system = mbdsl.assemble(models[0])
    init = mbdsl.consistent_initial_state(system, redundant="accept")
    t, q, v = 0.05, init.q, init.v
    K, _, least_norm = system.index1_matrix(t, q)
    assert least_norm is not None                      # C makes K singular
    a, lam = system.index1_state(t, q, v)
    P = system.Phi_q(q, t)
    P = P.toarray() if hasattr(P, "toarray") else np.asarray(P)
    np.testing.assert_allclose(system.mass_times(q, a) + P.T @ lam, system.Q(t, q, v, lam),
                               rtol=0, atol=1e-10)
    np.testing.assert_allclose(P @ a, system.gamma(q, v, t), rtol=0, atol=1e-10)
    null = np.linalg.svd(P.T)[2][-1]                    # the redundant combination of rows
    assert abs(null @ lam) < 1e-8 * np.abs(lam).max()
