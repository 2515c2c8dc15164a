"""The IFToMM spatial slider-crank (``models/spatial_slider_crank.mbd``):
against an independent index-1 Newton-Euler solution of the same mechanism
(``newton_euler.mechanism_reference``, DOP853), self-convergence, energy,
and the degrees of freedom by count and by rank."""

from __future__ import annotations

import numpy as np
import pytest

import mbdsl
from tests.conftest import MODELS

from .newton_euler import mechanism_reference
from .test_spatial_joints import _frames

BODIES = ("crank", "rod", "slider")
L_AB, L_BC = 0.08, 0.3
EX, EY, EZ = np.eye(3)
# the joints as elementary conditions (ground: None, world axes)
CONDITIONS = [
    ("point", 0, (0, 0, 0), None, (0, 0.1, 0.12)),       # A: the crank's bearing ...
    ("perp", 0, EY, None, EX), ("perp", 0, EZ, None, EX),  # ... about the world x axis
    ("point", 0, (0, 0, L_AB), 1, (-L_BC / 2, 0, 0)),    # B: spherical
    ("point", 2, (0, 0, 0), 1, (L_BC / 2, 0, 0)),        # C: universal, the cross ...
    ("perp", 2, EX, 1, EY),                              # ... slider x across rod y
    ("plane", 2, (0, 0, 0), EY, (0, 0, 0)),              # D: the slider on the x axis ...
    ("plane", 2, (0, 0, 0), EZ, (0, 0, 0)),
    ("lock", 2),                                         # ... not turning
]
MASS = [0.12, 0.5, 2.0]
INERTIA = [(1e-4, 1e-5, 1e-4), (4e-4, 4e-3, 4e-3), (1e-4, 1e-4, 1e-4)]


@pytest.fixture(scope="module")
def crank_reference():
    """The Newton-Euler solution over 1 s from mbdsl's assembled start."""
    model = mbdsl.load(MODELS / "spatial_slider_crank.mbd")
    start = mbdsl.simulate(model, h=1e-3, t_end=1e-3)
    frames = [_frames(start, b) for b in BODIES]
    times = np.linspace(0.0, 1.0, 21)
    ref = mechanism_reference(MASS, INERTIA, CONDITIONS, (0, 0, -9.81),
                              r0=[f[0][0] for f in frames], R0=[f[1][0] for f in frames],
                              v0=[f[2][0] for f in frames], w0=[f[3][0] for f in frames],
                              times=times)
    return model, times, ref


def _error(sol, times, ref):
    """Largest difference of the bodies' centres of mass [m] and axes at ``times``."""
    r_ref, R_ref, _ = ref
    t = sol.column("t")
    keep = np.isin(np.round(t, 9), np.round(times, 9))
    err = 0.0
    for k, body in enumerate(BODIES):
        r, A, _, _ = _frames(sol, body)
        err = max(err, np.max(np.abs(r[keep] - r_ref[:, k])),
                  np.max(np.abs(A[keep] - R_ref[:, k])))
    return err


def test_the_reference_holds_its_joints(crank_reference):
    """The oracle itself: the rod's length and the slider's line held over
    1 s, and the crank turning (its speed changes under gravity)."""
    _, _, (r, R, w) = crank_reference
    B = r[:, 0] + R[:, 0] @ np.array([0, 0, L_AB])
    C = r[:, 2]
    assert np.max(np.abs(np.linalg.norm(C - B, axis=1) - L_BC)) < 1e-9
    assert np.max(np.abs(C[:, 1:])) < 1e-9
    assert np.max(np.abs(R @ R.transpose(0, 1, 3, 2) - np.eye(3))) < 1e-9
    assert w[0, 0, 0] == pytest.approx(6.0, abs=1e-9) and np.ptp(w[:, 0, 0]) > 1.0


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "genalpha", "nstiff-si2", "nstiff",
                                    "hht-add"])
def test_the_spatial_slider_crank_converges_to_the_newton_euler_solution(crank_reference,
                                                                         method):
    """Every body's centre of mass and axes at t = 0.05 .. 1 s: order 2 from
    h = 2e-4 to 1e-4 and within 1e-4 at h = 1e-4 (measured: 5.5e-6 hht-add to 5.1e-5
    nstiff; the crank speeds up from 6 to 15 rad/s in that second)."""
    model, times, ref = crank_reference
    errors = [_error(mbdsl.simulate(model, method=method, h=h, t_end=1.0,
                                    output_times=list(times[1:])), times, ref)
              for h in (2e-4, 1e-4)]
    assert errors[1] < 1e-4, errors
    assert abs(np.log2(errors[0] / errors[1]) - 2.0) < 0.2, errors


def test_newmark_converges_at_first_order(crank_reference):
    """NEWMARK (gamma = 0.6): order 1."""
    model, times, ref = crank_reference
    errors = [_error(mbdsl.simulate(model, method="newmark", h=h, t_end=1.0,
                                    output_times=list(times[1:])), times, ref)
              for h in (2e-4, 1e-4)]
    assert abs(np.log2(errors[0] / errors[1]) - 1.0) < 0.15, errors


def test_one_degree_of_freedom_by_count_and_by_rank():
    """Gruebler-Kutzbach: 3 bodies x 6 - (5 + 3 + 4 + 5) = 1; the rank of
    Phi_q at the assembled start says the same."""
    model = mbdsl.load(MODELS / "spatial_slider_crank.mbd")
    assert model.dof == 1
    from mbdsl.assembly.structure import analyse_structure
    q = mbdsl.simulate(model, h=1e-3, t_end=1e-3).q[0]
    report = analyse_structure(mbdsl.assemble(model), q, 0.0)
    assert report.dof_rank == 1 and not report.redundant


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2"])
def test_the_energy_change_falls_at_second_order(method):
    """No damping, gravity only: the total energy's largest change over 2 s
    falls by 4 (+-20 %) when h halves (2e-4 -> 1e-4)."""
    model = mbdsl.load(MODELS / "spatial_slider_crank.mbd")
    drift = []
    for h in (2e-4, 1e-4):
        E = mbdsl.simulate(model, method=method, h=h, t_end=2.0).column("energy.total")
        drift.append(np.max(np.abs(E - E[0])))
    assert 3.2 < drift[0] / drift[1] < 4.8, drift
