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


def dop853_error_ratios(system, init, methods, T, steps=(1e-3, 5e-4)):
    """{method name: (errors, ratios)} of compiled runs against the DOP853
    solution of the index-1 equations at T (``mbdsl.studies.index1``, rtol = atol
    = 1e-12, numpy assembly): errors max |q(T) - q_ref| at each h of steps,
    ratios of consecutive errors (2^p for a method of order p). ``methods``:
    Method instances."""
    from mbdsl.integrators import integrate
    from mbdsl.studies.index1 import index1_reference
    q_ref = index1_reference(system, [T], initial=init).q[-1]
    out = {}
    for method in methods:
        errors = []
        for h in steps:
            sol = integrate(system, method, T, h, initial=init, engine="compiled")
            assert sol.engine == "compiled" and sol.status == "completed"
            errors.append(np.abs(sol.q[-1] - q_ref).max())
        errors = np.array(errors)
        out[method.name] = (errors, errors[:-1] / errors[1:])
    return out
