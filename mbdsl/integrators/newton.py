"""THE Newton loop, shared by every integration method.

Sign convention (written once): solve J dw = Upsilon(w), then w <- w - dw.

Convergence is judged on a weighted max norm of dw in *velocity-equivalent*
units, with separate absolute tolerances for kinematic unknowns and for
multipliers (Chrono's abstolS/abstolL):

    ||dw||_W = max_i |s_i dw_i| / (atol_i + rtol |s_i w_i|)

where s_i (declared by the method for each unknown and step size) converts
the unknown into the change of velocity it causes within the step: gamma h
for an HHT acceleration, gamma h / m_mean for its multipliers, 1 for a
velocity unknown, 1/h for a position unknown. Why not a fixed tolerance on
accelerations: the constraint rows are scaled by 1/(beta h^2) to keep the
Newton matrix well conditioned, so the round-off of Phi (~1e-16 m) reaches
the accelerations amplified by 1/h^2 and a fixed tolerance cannot be met at
small h (the h-scaling RADAU5 applies to higher-index variables, Hairer &
Wanner, Solving ODEs II, sec. VII.8). Why velocity and not position units:
the velocity error a step leaves is carried into every later step; with a
position-level tolerance a modified Newton iteration leaves velocity errors
of tol/h per step that add up over the run (measured: 5e-6 rad/s on the
slider crank at h = 1e-4 with tol = 1e-11 m).

A step is converged when ``eta ||dw||_W <= 1`` with eta = max(theta / (1 -
theta), 1e-2), theta the observed contraction rate (Hairer & Wanner, sec.
IV.8), so that a slowly contracting modified Newton iteration is not stopped
early. A step is never reported converged otherwise.

Jacobian policies (:class:`JacobianUpdate`):

* ``FULL``: a new Jacobian and factorization every iteration (Newton).
* ``MODIFIED``: keep the factorization across iterations and steps while
  the contraction rate stays below ``rate_refresh`` and h is unchanged;
  refresh it (and continue from the current iterate) when not.
"""

from __future__ import annotations

import enum
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

__all__ = ["JacobianUpdate", "NewtonStatus", "NewtonOptions", "NewtonResult", "Newton",
           "DenseLU"]


class JacobianUpdate(enum.Enum):
    """When the Newton matrix is re-evaluated and factored."""

    FULL = "full"
    MODIFIED = "modified"


class NewtonStatus(enum.Enum):
    """Outcome of a Newton solve."""

    CONVERGED = "converged"
    MAX_ITER = "maximum number of iterations reached"
    DIVERGING = "diverging"
    SINGULAR = "singular Newton matrix"
    NONFINITE = "non-finite values"


@dataclass(frozen=True)
class NewtonOptions:
    """Tolerances and policy of the Newton iteration.

    Parameters
    ----------
    rtol : float
        Relative tolerance on every unknown.
    atol_kinematic : float [m/s]
        Absolute tolerance on kinematic unknowns, velocity-equivalent (see
        the module docstring). The default 1e-9 sits above the round-off
        floor down to h = 1e-6 s and far below the truncation error of any
        useful h.
    atol_multiplier : float [m/s]
        Absolute tolerance on Lagrange multipliers, velocity-equivalent.
    max_iter : int
        Iterations allowed per step.
    jacobian : JacobianUpdate
    rate_refresh : float
        MODIFIED only: a contraction rate above this triggers a refresh.
    """

    rtol: float = 1e-8
    atol_kinematic: float = 1e-9
    atol_multiplier: float = 1e-9
    max_iter: int = 12
    jacobian: JacobianUpdate = JacobianUpdate.MODIFIED
    rate_refresh: float = 0.1

    def __post_init__(self):
        for name in ("rtol", "atol_kinematic", "atol_multiplier", "rate_refresh"):
            if not getattr(self, name) > 0:
                raise ValueError(f"NewtonOptions.{name} must be positive, got {getattr(self, name)}")
        if self.max_iter < 1:
            raise ValueError(f"NewtonOptions.max_iter must be at least 1, got {self.max_iter}")
        object.__setattr__(self, "jacobian", JacobianUpdate(self.jacobian))


@dataclass
class NewtonResult:
    """What one Newton solve did.

    Attributes
    ----------
    w : ndarray
        Last iterate (the solution when ``status`` is CONVERGED).
    status : NewtonStatus
    n_iter, n_residual, n_jacobian, n_factor : int
        Iterations, residual evaluations, Jacobian evaluations, LU factorizations.
    rate : float
        Last observed contraction rate (nan if unknown).
    norms : list of float
        Weighted norm of each update.
    residual : ndarray or None
        Last residual evaluated.
    """

    w: np.ndarray
    status: NewtonStatus
    n_iter: int = 0
    n_residual: int = 0
    n_jacobian: int = 0
    n_factor: int = 0
    rate: float = float("nan")
    norms: list = field(default_factory=list)
    residual: np.ndarray | None = None

    @property
    def converged(self) -> bool:
        """True when the iteration met its tolerance."""
        return self.status is NewtonStatus.CONVERGED


class DenseLU:
    """Dense LU factorization (LAPACK getrf via scipy) of a Newton matrix."""

    def __init__(self, J: np.ndarray):
        with warnings.catch_warnings():   # singularity is reported as NewtonStatus.SINGULAR
            warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
            self.lu, self.piv = scipy.linalg.lu_factor(J, check_finite=False)
        d = np.abs(np.diag(self.lu))
        self.singular = bool(d.min() == 0.0 or d.min() < 1e-14 * d.max()) or not np.all(np.isfinite(d))
        self.pivot_ratio = float(d.min() / d.max()) if d.max() > 0 else 0.0

    def solve(self, r: np.ndarray) -> np.ndarray:
        """J^{-1} r."""
        return scipy.linalg.lu_solve((self.lu, self.piv), r, check_finite=False)


class Newton:
    """Newton solver with a reusable factorization (one per integration run).

    Parameters
    ----------
    options : NewtonOptions
    """

    def __init__(self, options: NewtonOptions | None = None):
        self.options = options or NewtonOptions()
        self._lu: DenseLU | None = None
        self._key = None
        self._rate = 0.5

    def invalidate(self) -> None:
        """Forget the stored factorization (e.g. after a failed step)."""
        self._lu, self._key = None, None

    def solve(self, residual, jacobian, w0: np.ndarray, kinds: np.ndarray, scales: np.ndarray,
              key=None, floor: float = 0.0) -> NewtonResult:
        """Solve residual(w) = 0 from w0.

        Parameters
        ----------
        residual : callable w -> ndarray, shape (N,)
        jacobian : callable w -> ndarray, shape (N, N)
        w0 : ndarray, shape (N,)
        kinds : ndarray of bool, shape (N,)
            True for multiplier entries (they get ``atol_multiplier``).
        scales : ndarray, shape (N,)
            Velocity-equivalent scale s_i of each unknown [m/s per unit].
        floor : float [m/s]
            Round-off floor declared by the method; absolute tolerances are
            raised to it.
        key : hashable
            Identifies the Newton matrix's dependence on the step (h); a
            stored factorization is reused only under the same key.

        Returns
        -------
        NewtonResult
        """
        opt = self.options
        w = np.array(w0, dtype=float)
        atol = np.maximum(np.where(kinds, opt.atol_multiplier, opt.atol_kinematic), floor)
        weight = scales / (atol + opt.rtol * np.abs(scales * w))
        res = NewtonResult(w, NewtonStatus.MAX_ITER)
        reuse = opt.jacobian is JacobianUpdate.MODIFIED
        lu = self._lu if (reuse and self._key == key) else None
        fresh = False
        prev = None
        theta = self._rate
        for k in range(opt.max_iter):
            if lu is None:
                J = jacobian(w)
                res.n_jacobian += 1
                if not np.all(np.isfinite(J)):
                    res.status = NewtonStatus.NONFINITE
                    return self._fail(res, w)
                lu = DenseLU(J)
                res.n_factor += 1
                fresh = True
                if lu.singular:
                    res.status = NewtonStatus.SINGULAR
                    return self._fail(res, w)
            r = residual(w)
            res.n_residual += 1
            res.residual = r
            if not np.all(np.isfinite(r)):
                res.status = NewtonStatus.NONFINITE
                return self._fail(res, w)
            dw = lu.solve(r)
            norm = float(np.max(np.abs(dw * weight))) if len(dw) else 0.0
            res.norms.append(norm)
            w = w - dw
            res.n_iter += 1
            if not np.all(np.isfinite(w)):
                res.status = NewtonStatus.NONFINITE
                return self._fail(res, w)
            if prev is not None and prev > 0:
                theta = norm / prev
                res.rate = theta
            eta = max(theta / (1.0 - theta), 1e-2) if theta < 1.0 else np.inf
            if norm == 0.0 or (eta * norm <= 1.0 and norm <= 1.0):
                res.w, res.status = w, NewtonStatus.CONVERGED
                self._rate = min(max(theta, 1e-3), 0.9) if np.isfinite(theta) else 0.5
                if reuse:
                    self._lu, self._key = lu, key
                return res
            if prev is not None and theta >= 1.0 and fresh:
                res.status = NewtonStatus.DIVERGING
                return self._fail(res, w)
            if opt.jacobian is JacobianUpdate.FULL:
                lu = None
            elif prev is not None and theta > opt.rate_refresh and not fresh:
                lu, prev, theta = None, None, self._rate  # refresh, keep the iterate
                continue
            prev = norm
        res.status = NewtonStatus.MAX_ITER
        return self._fail(res, w)

    def _fail(self, res: NewtonResult, w) -> NewtonResult:
        res.w = w
        self.invalidate()
        return res
