"""Error-controlled step sizes: the local error estimate's norm and the step-size rule.

A run with a tolerance (``StepControl``) takes steps of varying size h so that
each step's estimated local error in the positions stays within

    || e / (atol + rtol max(|q_n|, |q_{n+1}|)) ||_RMS <= 1

(the weighted root-mean-square norm of Hairer, Norsett & Wanner, Solving
ODEs I, sec. II.4, which scipy's ``solve_ivp`` also uses), e of shape (n,)
in the units of q (m, rad). Each method estimates e from quantities it
already has (``Method.local_error``):

* the Newmark family (NEWMARK, HHT-I3, HHT-SI2, HHT-ADD) and generalized-alpha
  (on its auxiliary acceleration): e = (beta - 1/6) h^2 (a_{n+1} - a_n), the
  estimate of Zienkiewicz & Xie, "A simple error estimator and adaptive time
  stepping procedure for dynamic analysis", Earthquake Engng. Struct. Dyn.
  20 (1991) 871-887: the h^3 term of q's Taylor series the formula misses,
  with the acceleration's change standing for h q''';
* BDF2 (NSTIFF, NSTIFF-SI2): e = 2/9 h^2 (a_{n+1} - a_n), BDF2's error
  constant 2/9 (Hairer & Wanner, Solving ODEs II, sec. III.2) times the same
  stand-in for h^3 q'''; with variable steps BDF2's coefficients follow the
  step ratio (``common.bdf_coefficients``).

Rule: a step whose error norm E exceeds 1 is rejected and retried with
h * max(0.2, 0.9 E^(-1/3)); an accepted one sets the next step to
h * min(5, max(0.2, 0.9 E^(-1/3))), not growing right after a rejection (the
estimate is O(h^3), hence the exponent 1/3). Steps stay within
[h_min, h_max]; a step that fails to converge is halved as in fixed-step
runs. The fixed-step mode (no tolerance) is unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["StepControl"]


@dataclass(frozen=True)
class StepControl:
    """Tolerances and limits of error-controlled step sizes.

    Attributes
    ----------
    rtol : float
        Relative tolerance of the local position error (> 0).
    atol : float [m or rad]
        Absolute tolerance of the local position error (> 0).
    h_max : float [s]
        Largest step (default: unbounded; the run's end bounds it).
    h_min : float [s]
        Smallest step; below it the run stops with a message (default:
        1e-12 of the run's length, set by the driver when 0).
    safety, min_factor, max_factor : float
        The step-size rule's safety factor and its bounds on one change.

    Raises
    ------
    ValueError
        Non-positive or non-finite tolerances or limits.
    """

    rtol: float
    atol: float
    h_max: float = math.inf
    h_min: float = 0.0
    safety: float = 0.9
    min_factor: float = 0.2
    max_factor: float = 5.0

    def __post_init__(self):
        for name in ("rtol", "atol"):
            value = getattr(self, name)
            if not (value > 0 and math.isfinite(value)):
                raise ValueError(f"{name} must be positive and finite, got {value}")
        if not self.h_max > 0:
            raise ValueError(f"h_max must be positive, got {self.h_max}")

    def norm(self, error: np.ndarray, q_old: np.ndarray, q_new: np.ndarray) -> float:
        """The weighted RMS norm of a local error estimate (module notes); 0
        for a model without coordinates."""
        if not len(error):
            return 0.0
        scale = self.atol + self.rtol * np.maximum(np.abs(q_old), np.abs(q_new))
        return float(np.sqrt(np.mean((np.asarray(error) / scale) ** 2)))

    def factor(self, err: float, after_rejection: bool) -> float:
        """The next step's size over this one's, for error norm ``err``."""
        if err == 0.0:
            f = self.max_factor
        elif not math.isfinite(err):
            f = self.min_factor
        else:
            f = min(self.max_factor, max(self.min_factor, self.safety * err ** (-1.0 / 3.0)))
        return min(f, 1.0) if (after_rejection or err > 1.0) else f
