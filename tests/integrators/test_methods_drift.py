"""The six integrators: constraint drift over a 10 s run (split from test_methods for parallel CI).

Oracles: the independent slider-crank reference (tests/reference), the
index-1 DOP853 reference (for T = 0.05 s), energy conservation of the
undamped model, and the constraint equations themselves.
"""

import numpy as np
import pytest

import mbdsl
from mbdsl.assembly.initial import consistent_initial_state
from mbdsl.integrators import make_method
from mbdsl.reference import index1_reference

from ..conftest import MODELS

METHODS = list(mbdsl.METHODS)
ORDER = {"newmark": 1, "hht-i3": 2, "nstiff": 2, "nstiff-si2": 2, "hht-add": 2, "hht-si2": 2}
INDEX2 = ("nstiff-si2", "hht-add", "hht-si2")
HS = [2.0**-k for k in range(8, 13)]


def fitted_slope(hs, errors):
    return float(np.polyfit(np.log(hs), np.log(np.abs(errors)), 1)[0])


def eps_energy(sol):
    """eps(T) = (1/T) int_0^T |E(t) - E(0)| dt (trapezoidal rule on the steps)."""
    e = sol.column("energy.total")
    return float(np.trapezoid(np.abs(e - e[0]), sol.t) / (sol.t[-1] - sol.t[0]))


@pytest.fixture(scope="module")
def slider_crank():
    return mbdsl.load(MODELS / "slider_crank.mbd")


@pytest.fixture(scope="module")
def drift_runs(slider_crank):
    runs = {}
    for method in METHODS:
        runs[method, 10] = mbdsl.simulate(slider_crank, method=method, h=2.0**-10, t_end=10.0)
        if method not in INDEX2:
            runs[method, 9] = mbdsl.simulate(slider_crank, method=method, h=2.0**-9, t_end=10.0)
    return runs


@pytest.mark.parametrize("method", METHODS)
def test_constraint_drift(method, drift_runs):
    sol = drift_runs[method, 10]
    assert sol.t[-1] == 10.0
    assert np.max(sol.column("constraint.position")) <= 1e-10
    vel = np.max(sol.column("constraint.velocity"))
    if method in INDEX2:
        assert vel <= 1e-9
    else:
        # index 3: the velocity constraint is not imposed; its violation is
        # reported, non-zero, and shrinks with h at least at the method's order
        # (measured: 4.0 times per halving for all three, NEWMARK included).
        coarse = np.max(drift_runs[method, 9].column("constraint.velocity"))
        assert vel > 1e-8
        assert np.log2(coarse / vel) >= ORDER[method] - 0.2, (coarse, vel)


