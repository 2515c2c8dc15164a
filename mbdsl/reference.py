"""Reference solutions independent of the six integrators.

:func:`index1_reference` integrates the index-1 form of the equations of
motion, y = (q, v), y' = (v, a(q, v, t)) with (a, lambda) from

    [[M, Phi_q^T], [Phi_q, 0]] [a; lambda] = [Q; gamma],

by scipy's DOP853 (an explicit Runge-Kutta method of order 8) at tight
tolerances. It shares only the assembly (M, Q, Phi_q, gamma) with the
methods under test, not their formulas, start-up or Newton iteration, so it
is the oracle for convergence studies on models without a published
reference. Over short horizons the drift of the index-1 form off the
position and velocity constraints stays at the integration tolerance; the
returned ``drift`` says how far it went.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.integrate
import scipy.linalg

from .assembly.initial import consistent_initial_state

__all__ = ["ReferenceSolution", "index1_reference"]


@dataclass
class ReferenceSolution:
    """q, v at the requested times, and the constraint drift at the end.

    Attributes
    ----------
    t : ndarray, shape (N,) [s]
    q, v : ndarray, shape (N, n)
    drift : float
        max(|Phi|, |Phi_q v + Phi_t|) at the last time.
    nfev : int
        Right-hand side evaluations.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    drift: float
    nfev: int


def index1_reference(system, t_eval, rtol: float = 1e-12, atol: float = 1e-12,
                     initial=None) -> ReferenceSolution:
    """Integrate the index-1 equations of motion with DOP853.

    Parameters
    ----------
    system : AssembledSystem
    t_eval : array_like of float [s]
        Output times, increasing; the integration runs from the initial
        time to the last of them.
    rtol, atol : float
        DOP853 tolerances.
    initial : InitialState, optional

    Returns
    -------
    ReferenceSolution

    Raises
    ------
    RuntimeError
        If DOP853 fails (scipy's message is included).
    """
    initial = initial or consistent_initial_state(system)
    n, m = system.n, system.m
    t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))

    def _rhs(t, y):
        q, v = y[:n], y[n:]
        Phi_q = system.Phi_q(q, t)
        K = np.zeros((n + m, n + m))
        K[:n, :n] = system.mass_matrix(q)
        K[:n, n:] = Phi_q.T
        K[n:, :n] = Phi_q
        rhs_ = np.concatenate([system.Q(t, q, v), system.gamma(q, v, t)])
        a = scipy.linalg.solve(K, rhs_, check_finite=False)[:n]
        return np.concatenate([v, a])

    y0 = np.concatenate([initial.q, initial.v])
    res = scipy.integrate.solve_ivp(_rhs, (initial.t, float(t_eval[-1])), y0, method="DOP853",
                                    t_eval=t_eval, rtol=rtol, atol=atol)
    if not res.success:
        raise RuntimeError(f"index-1 reference failed: {res.message}")
    q, v = res.y[:n].T, res.y[n:].T
    t_last = res.t[-1]
    drift = max(float(np.max(np.abs(system.Phi(q[-1], t_last)), initial=0.0)),
                float(np.max(np.abs(system.Phi_q(q[-1], t_last) @ v[-1]
                                    + system.Phi_t(q[-1], t_last)), initial=0.0)))
    return ReferenceSolution(res.t, q, v, drift, res.nfev)
