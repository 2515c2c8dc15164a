"""Pure functions the method recipes share (never inheritance, never flags).

* Newmark predictors and updates (NEWMARK, HHT-I3, HHT-SI2, HHT-ADD).
* The index-3 Newton matrix in the unknowns (a, lambda).
* BDF coefficients with their start-up (NSTIFF, NSTIFF-SI2).
* The round-off floor of a constraint-row scaling.
"""

from __future__ import annotations

import numpy as np

__all__ = ["newmark_predictor", "force_term", "force_jacobians", "index3_newton_matrix",
           "bdf_coefficients", "roundoff_floor", "EPS"]

EPS = float(np.finfo(float).eps)


def newmark_predictor(state, h: float, beta: float, gamma: float):
    """Parts of the Newmark formulas known at t_n.

    q_{n+1} = q_pred + beta h^2 a_{n+1},  v_{n+1} = v_pred + gamma h a_{n+1} with
    q_pred = q_n + h v_n + h^2/2 (1 - 2 beta) a_n and v_pred = v_n + h (1 - gamma) a_n.

    Returns
    -------
    q_pred, v_pred : ndarray, shape (n,)
    """
    q_pred = state.q + h * state.v + 0.5 * h * h * (1.0 - 2.0 * beta) * state.a
    v_pred = state.v + h * (1.0 - gamma) * state.a
    return q_pred, v_pred


def force_term(system, t, q, v, lam) -> np.ndarray:
    """Phi_q^T lambda - Q(t, q, v), shape (n,): the HHT 'old force' term."""
    return system.Phi_q(q, t).T @ lam - system.Q(t, q, v)


def force_jacobians(system, t, q, v):
    """(Q_q, Q_v) as (n, n) arrays or None where the model declares no such term."""
    return system.force_derivatives(t, q, v)


def index3_newton_matrix(system, t, q, v, a, lam, c_mass: float, c_q: float,
                         c_v: float) -> np.ndarray:
    """Newton matrix of the index-3 methods in the unknowns (a, lambda).

        [[c_mass M + c_q (c_mass (M a)_q + (Phi_q^T lambda)_q - Q_q) - c_v Q_v,  Phi_q^T],
         [Phi_q,                                                              0      ]]

    with c_q = dq/da and c_v = dv/da of the method's integration formulas
    (constraint rows already divided by c_q).

    Returns
    -------
    ndarray, shape (n + m, n + m)
    """
    n, m = system.n, system.m
    K = c_mass * system.mass_matrix(q) + c_q * system.PhiqT_lam_q(q, lam)
    Ma_q = system.Ma_q(q, a)
    if Ma_q is not None:
        K += c_q * c_mass * Ma_q
    Q_q, Q_v = force_jacobians(system, t, q, v)
    if Q_q is not None:
        K -= c_q * Q_q
    if Q_v is not None:
        K -= c_v * Q_v
    Phi_q = system.Phi_q(q, t)
    J = np.zeros((n + m, n + m))
    J[:n, :n] = K
    J[:n, n:] = Phi_q.T
    J[n:, :n] = Phi_q
    return J


def bdf_coefficients(history, h: float):
    """BDF derivative D x_{n+1} = c0 (x_{n+1} - xi(x)) for the given history.

    BDF2 (c0 = 3/(2h), xi = 4/3 x_n - 1/3 x_{n-1}) when two past states
    with spacing h are available; otherwise BDF1 (c0 = 1/h, xi = x_n), the
    start-up step, also taken after every change of the step size (BDF2's
    fixed-step coefficients would be wrong then). One BDF1 step has a local
    error O(h^2), which enters the global error once, so the order stays 2.

    Returns
    -------
    c0 : float [1/s]
    weights : tuple of (float, StepState)
        xi(x) = sum(w * x_state).
    order : int
        1 for the start-up step, 2 otherwise.
    """
    last = history[-1]
    if len(history) >= 2 and abs((last.t - history[-2].t) - h) <= 1e-9 * h:
        return 1.5 / h, ((4.0 / 3.0, last), (-1.0 / 3.0, history[-2])), 2
    return 1.0 / h, ((1.0, last),), 1


def roundoff_floor(q: np.ndarray, velocity_per_metre: float) -> float:
    """32 eps (1 + |q|_max) times the velocity change one metre of constraint
    residual causes through the method's row scaling [m/s].

    The factor 32 covers the conditioning of Phi_q (measured noise on the
    slider crank: about 7 eps (1 + |q|) / h for HHT-I3).
    """
    return 32.0 * EPS * (1.0 + float(np.max(np.abs(q), initial=0.0))) * velocity_per_metre
