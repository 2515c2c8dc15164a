"""Shared definitions of the method suite (the paper's six and generalized-alpha) (test_methods*.py).

Oracles: the independent slider-crank reference (tests/reference), the
index-1 DOP853 reference (for T = 0.05 s), energy conservation of the
undamped model, and the constraint equations themselves.
"""

import numpy as np
import pytest

import mbdsl

from ..conftest import MODELS

METHODS = list(mbdsl.METHODS)
ORDER = {"newmark": 1, "hht-i3": 2, "nstiff": 2, "nstiff-si2": 2, "hht-add": 2, "hht-si2": 2,
         "genalpha": 2, "genalpha-si2": 2}
INDEX2 = ("nstiff-si2", "hht-add", "hht-si2", "genalpha-si2")
HS = [2.0**-k for k in range(8, 13)]


def fitted_slope(hs, errors):
    """Slope of log |error| against log h (least squares)."""
    return float(np.polyfit(np.log(hs), np.log(np.abs(errors)), 1)[0])


def eps_energy(sol):
    """eps(T) = (1/T) int_0^T |E(t) - E(0)| dt (trapezoidal rule on the steps)."""
    e = sol.column("energy.total")
    return float(np.trapezoid(np.abs(e - e[0]), sol.t) / (sol.t[-1] - sol.t[0]))


@pytest.fixture(scope="module")
def slider_crank():
    """The paper's damped slider crank."""
    return mbdsl.load(MODELS / "slider_crank.mbd")
