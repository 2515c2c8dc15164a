"""What a method does to one mode: its amplification matrix on the linear
oscillator x'' = -omega^2 x and the numerical damping and period error that
follow from it.

Every method is linear on x'' = -omega^2 x; one step maps the state it
carries from step to step (positions, h times velocities, h^2 times the
accelerations it keeps, and for BDF2 the step before) to the next one by a
matrix A(Omega) that depends only on Omega = omega h and the method's
coefficients. Its eigenvalues are the method's roots: the two principal ones
approximate exp(+-i Omega) and carry the mode, the others are spurious. From
the principal pair lambda = exp(Omegabar (-xibar +- i)) (Hilber, Hughes &
Taylor 1977; Hughes, The Finite Element Method, sec. 9.3; Chung & Hulbert
1993):

* spectral radius rho = max |eig A|,
* algorithmic damping ratio xibar = -ln |lambda| / Omegabar,
* relative period error Omega / Omegabar - 1,
* the steps in which the mode loses 99 % of its energy, ln(0.01) / (2 ln |lambda|).

On a constrained model the same holds for each mode of the linearization
(``mbdsl.modes``): the index-3 and index-2 forms differ only in how the
constraints are enforced, not in what the step does to an unconstrained
oscillation, so HHT-SI2 and HHT-ADD share HHT-I3's matrix, NSTIFF-SI2 NSTIFF's
and GENALPHA-SI2 GENALPHA's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MethodSpectrum", "bdf2_amplification", "bdf2_step", "genalpha_amplification",
           "genalpha_step", "hht_step", "newmark_amplification", "spectrum"]


def newmark_amplification(Omega: float, beta: float, gamma: float, alpha: float = 0.0) -> np.ndarray:
    """One step of Newmark (alpha = 0) or HHT-alpha on x'' = -omega^2 x, shape (3, 3).

    State (x, h v, h^2 a), a the carried acceleration; HHT's a_{n+1}
    satisfies a_{n+1} = -(1 + alpha) omega^2 x_{n+1} + alpha omega^2 x_n (the
    residual of ``hht_i3.py`` with M = 1, K = omega^2):

        x1 = x + hv + (1/2 - beta) A + beta A1
        hv1 = hv + (1 - gamma) A + gamma A1
        A1 = -(1 + alpha) Omega^2 x1 + alpha Omega^2 x

    Parameters
    ----------
    Omega : float
        omega h, dimensionless.
    beta, gamma, alpha : float
        The method's coefficients (alpha in [-1/3, 0]; 0 for Newmark).
    """
    W = Omega * Omega
    # unknowns (x1, hv1, A1): L s1 = R s
    L = np.array([[1.0, 0.0, -beta],
                  [0.0, 1.0, -gamma],
                  [(1.0 + alpha) * W, 0.0, 1.0]])
    R = np.array([[1.0, 1.0, 0.5 - beta],
                  [0.0, 1.0, 1.0 - gamma],
                  [alpha * W, 0.0, 0.0]])
    return np.linalg.solve(L, R)


def genalpha_amplification(Omega: float, alpha_m: float, alpha_f: float, beta: float,
                           gamma: float) -> np.ndarray:
    """One step of generalized-alpha (Arnold & Bruls 2007's form, ``genalpha.py``)
    on x'' = -omega^2 x, shape (4, 4).

    State (x, h v, h^2 a, h^2 b), a the true acceleration, b the auxiliary one:

        x1 = x + hv + (1/2 - beta) B + beta B1
        hv1 = hv + (1 - gamma) B + gamma B1
        (1 - alpha_m) B1 + alpha_m B = (1 - alpha_f) A1 + alpha_f A
        A1 = -Omega^2 x1
    """
    W = Omega * Omega
    # unknowns (x1, hv1, A1, B1)
    L = np.array([[1.0, 0.0, 0.0, -beta],
                  [0.0, 1.0, 0.0, -gamma],
                  [0.0, 0.0, -(1.0 - alpha_f), 1.0 - alpha_m],
                  [W, 0.0, 1.0, 0.0]])
    R = np.array([[1.0, 1.0, 0.0, 0.5 - beta],
                  [0.0, 1.0, 0.0, 1.0 - gamma],
                  [0.0, 0.0, alpha_f, -alpha_m],
                  [0.0, 0.0, 0.0, 0.0]])
    return np.linalg.solve(L, R)


def bdf2_amplification(Omega: float) -> np.ndarray:
    """One step of BDF2 (NSTIFF, ``nstiff.py``) on x' = v, v' = -omega^2 x at a
    constant step, shape (4, 4).

    State (x, h v, x_prev, h v_prev):

        x1 - 4/3 x + 1/3 x_prev = 2/3 hv1
        hv1 - 4/3 hv + 1/3 hv_prev = -2/3 Omega^2 x1
    """
    W = Omega * Omega
    L = np.array([[1.0, -2.0 / 3.0], [2.0 / 3.0 * W, 1.0]])
    R = np.array([[4.0 / 3.0, 0.0, -1.0 / 3.0, 0.0],
                  [0.0, 4.0 / 3.0, 0.0, -1.0 / 3.0]])
    top = np.linalg.solve(L, R)
    return np.vstack([top, np.hstack([np.eye(2), np.zeros((2, 2))])])


def hht_step(method, omega_h: float) -> np.ndarray:
    """``Method.amplification`` of the Newmark and HHT methods (NEWMARK,
    HHT-I3, HHT-SI2, HHT-ADD: alpha 0 for Newmark), shape (3, 3)."""
    return newmark_amplification(omega_h, method.beta, method.gamma,
                                 getattr(method, "alpha", 0.0))


def genalpha_step(method, omega_h: float) -> np.ndarray:
    """``Method.amplification`` of GENALPHA and GENALPHA-SI2, shape (4, 4)."""
    return genalpha_amplification(omega_h, method.alpha_m, method.alpha_f, method.beta,
                                  method.gamma)


def bdf2_step(method, omega_h: float) -> np.ndarray:
    """``Method.amplification`` of NSTIFF and NSTIFF-SI2, shape (4, 4)."""
    return bdf2_amplification(omega_h)


@dataclass(frozen=True)
class MethodSpectrum:
    """What one step of a method does to a mode of frequency omega at step h.

    Attributes
    ----------
    omega_h : float
        Omega = omega h.
    rho : float
        Spectral radius of the amplification matrix (1: no numerical
        damping; above 1: unstable).
    damping_ratio : float
        Algorithmic damping ratio xibar of the principal roots (nan when
        they are real and positive: the mode is not carried as an
        oscillation).
    period_error : float
        Relative period error Omega/Omegabar - 1 (positive: the numerical
        period is longer).
    steps_to_damp : float
        Steps in which the mode loses 99 % of its energy (inf without
        numerical damping).
    """

    omega_h: float
    rho: float
    damping_ratio: float
    period_error: float
    steps_to_damp: float


def spectrum(A: np.ndarray, Omega: float) -> MethodSpectrum:
    """The properties of amplification matrix ``A`` at Omega = omega h.

    The principal roots are those with the largest modulus among the
    eigenvalues off the positive real axis (for Omega -> 0 they tend to 1;
    the spurious roots of the HHT and generalized-alpha families and of
    BDF2 stay inside). Without such a pair, the largest eigenvalue is taken.
    """
    lam = np.linalg.eigvals(A)
    rho = float(np.max(np.abs(lam)))
    osc = lam[np.abs(np.angle(lam)) > 1e-12]
    principal = osc[np.argmax(np.abs(osc))] if len(osc) else lam[np.argmax(np.abs(lam))]
    mod, arg = abs(principal), abs(np.angle(principal))
    if arg > 0.0:
        xi = -np.log(mod) / arg
        period = Omega / arg - 1.0
    else:
        xi, period = float("nan"), float("inf")
    steps = np.log(0.01) / (2.0 * np.log(mod)) if mod < 1.0 else float("inf")
    return MethodSpectrum(float(Omega), rho, float(xi), float(period), float(steps))
