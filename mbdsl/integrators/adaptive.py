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

Error per unit step: the norm above is divided by h / (1 s), so that a step
is accepted when its local error is at most the tolerance per second of
simulated time (Shampine's "error per unit step"; Hairer, Norsett & Wanner I,
sec. II.4). A second-order method's estimate is O(h^3); per unit step it is
O(h^2), the steps follow tol^(1/2), and the global error after a stretch of
T seconds is about T tol |q| times the model's error growth: proportional to
the tolerance. (Per step, as scipy's codes test it, the steps of a
second-order method would follow tol^(1/3) and its global error tol^(2/3):
ten times less tolerance would buy only 4.6 times less error.)

The per-unit-step tolerance tol h of an entry never falls below the
estimate's own round-off: c (a_{n+1} - a_n) with c = err h^2 reads the
accelerations, whose round-off is that of q over h^2 (the constraint rows
are scaled by 1/h^2), so it carries err ulps of |q| (0.11 for HHT, 2/9 for
BDF2): the floor is err ulps of max(|q_n|, |q_{n+1}|). Below it no step
could meet the tolerance. That happens where the light cart-pole's pole
passes the vertical (``models/light_cart_pole.mbd``: the 1e-6 kg cart
crosses at 4.4 km/s for a microsecond; steps of 1e-11 s at rtol 1e-7, where
tol h is 1e-18 m against an estimate that stalls at 1e-18 m), and on smooth
models only below rtol 1e-10 (the car axis at 1e-10: steps of 1.5e-6 s,
tol h |q| = 1.5e-16 m against a floor of 2.4e-17 m).

Rule (``integrators.compiled.loop.step_ratio``, the same in both engines): a step whose error
E per unit step exceeds 1 is rejected and retried with
h max(min_factor, safety E^(-1/2)); after an accepted step the next size
follows Soderlind's H211b digital filter with b = 4 ("Digital filters in
adaptive time-stepping", ACM TOMS 29 (2003) 1-26),

    h_{n+1} / h_n = (theta/E_n)^(1/8) (theta/E_{n-1})^(1/8) (h_n/h_{n-1})^(-1/4),

theta = safety^2, which smooths the step sequence where the elementary
controller (theta/E_n)^(1/2) rings; the elementary one takes the first step,
and the steps after a rejection or an event (the filter restarts). Each
change is within [min_factor, max_factor], and no step grows right after a
rejection. Steps stay within [h_min, h_max]; a step that fails to converge
is halved as in fixed-step runs. The fixed-step mode (no tolerance) is
unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .common import EPS

__all__ = ["StepControl", "index1_acceleration"]


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
    index1 : bool
        An index-3 method's estimate, and HHT-ADD's on a + R_II, on their
        index-1 projections (:func:`index1_acceleration`,
        ``Method.estimate_on_index1``; docs/methods.md); False: on the
        accelerations themselves.

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
    index1: bool = True

    def __post_init__(self):
        for name in ("rtol", "atol"):
            value = getattr(self, name)
            if not (value > 0 and math.isfinite(value)):
                raise ValueError(f"{name} must be positive and finite, got {value}")
        if not self.h_max > 0:
            raise ValueError(f"h_max must be positive, got {self.h_max}")

    def norm(self, error: np.ndarray, q_old: np.ndarray, q_new: np.ndarray, h: float,
             noise: float = 1.0) -> float:
        """The error per unit step of a local error estimate (module notes): its
        weighted RMS norm with each entry's tolerance (atol + rtol max(|q_n|,
        |q_{n+1}|)) h, never below ``noise`` ulps of max(|q_n|, |q_{n+1}|); 0
        for a model without coordinates (``integrators.compiled.loop._error_norm`` in the
        compiled loop).

        Parameters
        ----------
        error : ndarray, shape (n,) [m, rad]
        q_old, q_new : ndarray, shape (n,) [m, rad]
            The positions at the step's start and end (the weights).
        h : float [s]
            The step's size.
        noise : float
            The estimate's round-off in ulps of q: its coefficient over h^2
            (``Method.error_coefficient``; module notes).
        """
        if not len(error):
            return 0.0
        size = np.maximum(np.abs(q_old), np.abs(q_new))
        scale = np.maximum((self.atol + self.rtol * size) * h, noise * EPS * size)
        return float(np.sqrt(np.mean((np.asarray(error) / scale) ** 2)))


def index1_acceleration(system, t: float, q: np.ndarray, v: np.ndarray,
                        a: np.ndarray, dense: bool = True) -> np.ndarray:
    """The acceleration a made to meet the acceleration constraints
    Phi_q a = gamma by a change along the directions M^-1 Phi_q^T lambda in
    which the multipliers act:

        a - M^-1 Phi_q^T (Phi_q M^-1 Phi_q^T)^+ (Phi_q a - gamma(q, v, t)),

    the index-1 acceleration at (t, q, v) when a's tangential part is the true
    one (Haug, Computer-Aided Kinematics and Dynamics of Mechanical Systems,
    sec. 6.3; the pseudo-inverse keeps redundant rows). An index-3 method's error
    estimate reads it (module notes): its own a meets only Phi = 0, and the
    normal part carries the multipliers' round-off over beta h^2.

    Rigid bodies (M a constant diagonal) solve the Schur complement
    Phi_q M^-1 Phi_q^T by a band Cholesky in the reverse Cuthill-McKee order
    of its rows (``engine._index1_band``), linear in the size of a chain.
    Where that refuses the matrix (a pivot below 1e-13 of the largest:
    redundant rows, a singular position), and for flexible beams, the dense
    least squares does when ``dense``, else a is returned as it is. The
    compiled loop's ``integrators.compiled.index1._index1_acceleration`` is
    the same operation with the same rule.

    Parameters
    ----------
    system : AssembledSystem
    t : float [s]
    q, v, a : ndarray, shape (n,) [m, rad; m/s, rad/s; m/s^2, rad/s^2]
    dense : bool
        Whether the dense least squares may be used (up to ``records.INDEX1_LIMIT``
        constraint rows, the compiled loop's rule).

    Returns
    -------
    ndarray, shape (n,) [m/s^2, rad/s^2]
    """
    from .engine import _index1_band
    plan = _index1_band(system)
    if plan is not None:
        out = _index1_acceleration_band(system, plan, t, q, v, a)
        if out is not None:
            return out
    if not dense:
        return np.array(a, dtype=float)
    Phi_q = system.Phi_q(q, t)
    Phi_q = Phi_q.toarray() if hasattr(Phi_q, "toarray") else np.asarray(Phi_q)
    W = system.mass_solve(q, Phi_q.T)                  # M^-1 Phi_q^T, (n, m)
    z = np.linalg.lstsq(Phi_q @ W, Phi_q @ a - system.gamma(q, v, t), rcond=1e-13)[0]
    return a - W @ z


def _index1_acceleration_band(system, plan, t, q, v, a):
    """:func:`index1_acceleration` for rigid bodies on the band Cholesky of
    A = Phi_q M^-1 Phi_q^T, rows in the plan's order (``engine._index1_band``:
    (order, kd)), or None where A is not positive definite or a pivot U_kk^2
    is below 1e-13 of the largest (``compiled.index1._schur_band``'s test)."""
    import scipy.linalg
    import scipy.sparse
    order, kd = plan
    m = len(order)
    P = scipy.sparse.csr_matrix(system.Phi_q(q, t))[order]
    minv = 1.0 / system.mass_diag
    A = (P @ scipy.sparse.diags(minv) @ P.T).tocoo()
    upper = A.row <= A.col
    if np.any(A.col[upper] - A.row[upper] > kd):
        return None
    ab = np.zeros((kd + 1, m))             # A(i, j), i <= j, at ab[kd + i - j, j] (LAPACK "U")
    np.add.at(ab, (kd + A.row[upper] - A.col[upper], A.col[upper]), A.data[upper])
    try:
        U = scipy.linalg.cholesky_banded(ab, lower=False, check_finite=False)
    except np.linalg.LinAlgError:
        return None
    pivots = U[kd] ** 2
    if not np.all(np.isfinite(pivots)) or pivots.min() < 1e-13 * pivots.max():
        return None
    z = scipy.linalg.cho_solve_banded((U, False), P @ a - system.gamma(q, v, t)[order],
                                      check_finite=False)
    if not np.all(np.isfinite(z)):
        return None
    return a - minv * (P.T @ z)
