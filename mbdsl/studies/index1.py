"""Reference solutions independent of the integrators.

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

from ..assembly.initial import consistent_initial_state

__all__ = ["ReferenceSolution", "EvaluationBudgetExceeded", "index1_reference"]


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
    interpolant : callable or None
        With ``dense_output=True``: ``interpolant(t)`` -> y = (q, v) of shape
        (2n,) or (2n, len(t)), DOP853's order-7 continuous extension.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    drift: float
    nfev: int
    interpolant: object = None


class EvaluationBudgetExceeded(RuntimeError):
    """The index-1 integration needed more right-hand side evaluations than allowed."""


def index1_reference(system, t_eval, rtol: float = 1e-12, atol: float = 1e-12,
                     initial=None, dense_output: bool = False,
                     max_evaluations: int | None = None) -> ReferenceSolution:
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
    dense_output : bool
        Keep DOP853's continuous extension (``ReferenceSolution.interpolant``).
    max_evaluations : int, optional
        Give up after this many right-hand side evaluations (a stiff model
        makes an explicit method crawl; callers then fall back to another
        reference).

    Returns
    -------
    ReferenceSolution

    Raises
    ------
    RuntimeError
        If DOP853 fails (scipy's message is included).
    EvaluationBudgetExceeded
        After ``max_evaluations`` right-hand side evaluations.
    """
    initial = initial or consistent_initial_state(system)
    n, m = system.n, system.m
    t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))

    count = [0]

    def _rhs(t, y):
        """y' = (v, a) with a from the index-1 KKT system at (t, y)."""
        count[0] += 1
        if max_evaluations is not None and count[0] > max_evaluations:
            raise EvaluationBudgetExceeded(
                f"the index-1 reference needed more than {max_evaluations} evaluations "
                f"(stopped at t = {t:.6g} s); the model is likely stiff")
        q, v = y[:n], y[n:]
        Phi_q = system.Phi_q(q, t)
        K = np.zeros((n + m, n + m))
        K[:n, :n] = system.mass_matrix(q)
        K[:n, n:] = Phi_q.T
        K[n:, :n] = Phi_q
        a = system.index1_solve(K, t, q, v, solve=lambda rhs_: scipy.linalg.solve(
            K, rhs_, check_finite=False))[:n]
        return np.concatenate([v, a])

    y0 = np.concatenate([initial.q, initial.v])
    res = scipy.integrate.solve_ivp(_rhs, (initial.t, float(t_eval[-1])), y0, method="DOP853",
                                    t_eval=t_eval, rtol=rtol, atol=atol,
                                    dense_output=dense_output)
    if not res.success:
        raise RuntimeError(f"index-1 reference failed: {res.message}")
    q, v = res.y[:n].T, res.y[n:].T
    t_last = res.t[-1]
    drift = max(float(np.max(np.abs(system.Phi(q[-1], t_last)), initial=0.0)),
                float(np.max(np.abs(system.Phi_q(q[-1], t_last) @ v[-1]
                                    + system.Phi_t(q[-1], t_last)), initial=0.0)))
    return ReferenceSolution(res.t, q, v, drift, res.nfev, res.sol if dense_output else None)
