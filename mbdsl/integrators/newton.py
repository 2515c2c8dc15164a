"""THE Newton loop, shared by every integration method.

Sign convention (written once): solve J dw = Upsilon(w), then w <- w - dw.

Convergence is judged on a weighted max norm of dw in *velocity-equivalent*
units, with separate absolute tolerances for kinematic unknowns and for
multipliers (Chrono's abstolS/abstolL):

    ||dw||_W = max_i |s_i dw_i| / (atol_i + rtol |s_i w_i|)

(for multipliers, |s_i w_i| is replaced by the largest |s_j w_j| over all
multipliers: a joint's force is judged against the largest force in the
mechanism; in a chain of 1000 links the round-off of the small forces at the
free end is set by the large ones at the pin)

where s_i (declared by the method for each unknown and step size) converts
the unknown into the change of velocity it causes within the step: gamma h
for an HHT acceleration, gamma h times the mobility (largest acceleration
per unit multiplier, ``AssembledSystem.multiplier_mobility``) for its
multipliers, 1 for a velocity unknown. Why not a fixed tolerance on
accelerations: the constraint rows are scaled by 1/(beta h^2) to keep the
Newton matrix well conditioned, so the round-off of Phi (~1e-16 m) reaches
the accelerations amplified by 1/h^2 and a fixed tolerance cannot be met at
small h (the h-scaling RADAU5 applies to higher-index variables, Hairer &
Wanner, Solving ODEs II, sec. VII.8). Why velocity and not position units:
the velocity error a step leaves is carried into every later step; with a
position-level tolerance a modified Newton iteration leaves velocity errors
of tol/h per step that add up over the run (measured: 5e-6 rad/s on the
slider crank at h = 1e-4 with tol = 1e-11 m).

A step is converged when ``eta ||dw||_W <= 1`` and ``||dw||_W <= 1``, with
eta = max(theta / (1 - theta), 1e-2), theta the observed contraction rate
(Hairer & Wanner, sec. IV.8): eta ||dw||_W estimates the error of the
iterate the update dw led to, so that a slowly contracting modified Newton
iteration is not stopped early. From the second iteration on, an index-3
form on a planar model also stops where that estimate is within KAPPA =
0.1 of the tolerance, its last update not (Hairer and Wanner's kappa, which
they put at 0.01 to 0.1: a rate read off two updates can be several times
off on modified Newton, and a tenth keeps the iterate within the tolerance
through that). It saves the iteration that would only have confirmed a fast
contraction: on the slider crank over 2 s at h = 2^-9 s, 3.4 iterations a
step instead of 3.7, max |Phi| 5e-14 m instead of 2e-14, the end state the
same to 1e-9. Not in the forms with velocity-level rows (stabilized index 2,
HHT-ADD), where the last update within the tolerance is what keeps Phi_q v +
Phi_t at round-off (without it NSTIFF-SI2's velocity drift there rose from
1.6e-11 to 1.3e-10 m/s, above ``study drift``'s round-off line), nor with
spatial bodies, whose frames are held to FRAME_TOL (below).

One exception, counted and reported (``NewtonResult.multipliers_stalled``,
"steps at round-off" in the summary): when two successive updates, each
computed with a Jacobian evaluated at its own iterate (exact Newton, so a
stale Jacobian cannot pass for stagnation), fail to halve the best norm
reached so far (round-off fluctuates, so "the previous norm" would be
fooled by a lucky iterate) while it is within ROUNDOFF_BAND = 1000 times the tolerance (velocity-equivalent
1e-6 m/s by default), the iteration has reached the round-off floor of the
residual and the step is accepted. Long chains (N = 1000, |q| ~ 100 m, ill
conditioned) and small lever arms (Andrews' mechanism: 1 mm, mostly in the
multipliers) amplify that floor beyond any fixed tolerance; further
iterations only reshuffle round-off. Growth beyond the band is divergence.

Near a singular configuration the geometry amplifies the round-off of Phi
beyond any band: on a 1e-6 kg cart under a pendulum passing the vertical
(``models/light_cart_pole.mbd``) at h = 1e-12 s, Phi alternates between
+-1 ulp from iteration to iteration and each update moves the cart by
5.5e-14 m through multipliers of 1.4e8, a velocity-equivalent 3.9e3 times
the tolerance, the same at every iteration. So the stall is also read on
the residual (``at_roundoff``): when exact Newton stagnates, or an update
grows past the divergence test (the first update at the round-off floor
after one that was not: 9.6 then 7.7e3 on that cart), the iterate
meets its constraints to round-off (the caller's test: |Phi| and
|Phi_q v + Phi_t| within a few ulps of their terms), and the update that
the other rows alone ask for, J^-1 r with the constraint rows of r set to
zero, meets the tolerance, the step is converged at round-off as well
(counted in ``multipliers_stalled``). The constraint rows are the rows of
the multiplier unknowns (``kinds``), as in every saddle-point form here but
HHT-ADD's, which names its own (``Method.constraint_rows``).

A spatial body's frame is held to FRAME_TOL = 1e-12 whatever the
tolerances: its director coordinates are unit vectors whose orthonormality
rows a_k . a_l - delta_kl are read by every output that turns a vector
(the angles, the angular velocity, the points' positions), and a step that
met only the velocity-equivalent tolerance leaves them off by about h times
it (measured on the Euler-Poinsot body at h = 1e-2 to 1e-3 over 10 s:
1e-12 to 4e-12 for every method at the default tolerances, nstiff-si2
the worst). So where the update meets the tolerance but the iterate whose
residual was read has a frame row beyond FRAME_HOLD = FRAME_TOL / 2 (the
caller's test, ``frames_held``), the iteration goes on; the update it then
takes carries that residual down by the contraction rate. The margin is for
the last update, which the test does not see: taken with the factorization
of an earlier iterate it moves the frame rows too (HHT-ADD on the
Euler-Poinsot body at h = 4e-3 held its read iterates within FRAME_TOL and
returned 1.03e-12; with the margin 5.7e-13, at 2.0 instead of 1.4
iterations per step). Planar models have no frame rows and are not affected.

Jacobian policies (:class:`JacobianUpdate`):

* ``FULL``: a new Jacobian and factorization every iteration (Newton).
* ``MODIFIED``: keep the factorization across iterations and steps while
  the contraction rate stays below ``rate_refresh`` and h is unchanged;
  refresh it (and continue from the current iterate) when not, and
  whenever a correction is at least max(1/2, ``rate_refresh``) times the
  last (the stall rule: a matrix that costs many iterations is kept
  through a slower contraction).
"""

from __future__ import annotations

import enum
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy

from ..assembly.sparse import issparse

__all__ = ["JacobianUpdate", "NewtonStatus", "NewtonOptions", "NewtonResult", "Newton",
           "DenseLU", "SparseLU", "factorize"]


#: Stagnation within this many tolerances, under exact Newton, is round-off (see above).
ROUNDOFF_BAND = 1e3
#: A constraint is met to round-off within this many ulps of its terms (the
#: residual test above; ``python_stepper.constraints_at_roundoff``, ``integrators.compiled.newton._rest_at_roundoff``).
ROUNDOFF_ULPS = 8.0
#: A spatial body's frame rows |a_k . a_l - delta_kl| are held within this at
#: every accepted step (see above; ``kernels.schema.FRAME_TOL``).
FRAME_TOL = 1e-12
#: The frame rows' bound at the iterate the test reads (``kernels.schema.FRAME_HOLD``):
#: half of FRAME_TOL, the margin the last update needs (see above).
FRAME_HOLD = 0.5 * FRAME_TOL
#: An index-3 form on a planar model stops where the iterate's estimated error is
#: within this fraction of the tolerance, its last update not (see above;
#: ``integrators.compiled.newton.KAPPA``).
KAPPA = 0.1


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

    @property
    def code(self) -> int:
        """The status as the time loop's steppers return it, and the
        compiled Newton iteration its own (:mod:`.outcomes`)."""
        from . import outcomes
        return getattr(outcomes, self.name)


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
    rate_refresh : float or None
        MODIFIED only: a contraction rate above this, with a Newton matrix
        from an earlier step, triggers a refresh. None: 0.1 where a
        factorization costs about as much as an iteration (dense LAPACK in
        the numpy engine), 0.3 where it costs many iterations (SuperLU, and
        the compiled engine, whose iteration is a residual and a product
        with the stored inverse). Measured on the chain of N = 100 links,
        HHT-I3: 0.47 factorizations and 5.6 iterations per step at 0.1,
        0.18 and 7.6 at 0.3, 25% less time per step. 0.8 for HHT-ADD on
        flexible beams, whose Newton matrix costs some 10 iterations; above
        1/2 it is also the stall rule's ratio (module docstring).
    linear_solver : {"auto", "dense", "sparse", "banded", "condensed"}
        LU of the Newton matrix: LAPACK on a dense array, or SuperLU
        (scipy.sparse.linalg.splu) on a CSC matrix assembled on the
        pattern fixed at model build, or (compiled engine only) LAPACK's
        band LU on a reverse Cuthill-McKee ordering. "auto" takes dense up
        to ``mbdsl.assembly.sparse.DENSE_LIMIT`` unknowns; above it, sparse
        in the numpy engine, and banded, condensed or sparse in the compiled
        engine (``solver_plans.linear_solver_plan``: banded when the band is at most
        a few times SuperLU's fill; condensed, the coordinates eliminated
        body by body before a band LU of the constraint rows' Schur
        complement, where that costs at most a quarter of the flops:
        ``integrators.compiled.condensed``).
    start : {"extrapolated", "last"}
        Where the compiled time loop starts a step's iteration:
        "extrapolated" through the unknowns the two or three steps before
        converged to (``compiled.loop._extrapolated_start``; the last
        state's start again where Newton does not converge from there, and
        for the first steps of a call), or the last state's, as the Python
        Newton (numpy engine, the driver's loop) always does, and the
        compiled loop where a Newton matrix costs about ten iterations
        (HHT-ADD on flexible beams, ``engine.newton_matrix_cost``). The converged
        step is the same within the tolerances; from the extrapolated start
        it takes fewer iterations (about 3 instead of 5 a step on the slider
        crank and the double pendulum, docs/performance.md), and stops
        nearer the tolerance than far below it.
    """

    rtol: float = 1e-8
    atol_kinematic: float = 1e-9
    atol_multiplier: float = 1e-9
    max_iter: int = 12
    jacobian: JacobianUpdate = JacobianUpdate.MODIFIED
    rate_refresh: float | None = None
    linear_solver: str = "auto"
    start: str = "extrapolated"

    def refresh_rate(self, cost: int) -> float:
        """``rate_refresh``, or its default for a Newton matrix whose renewal
        is cheap (0 or False: 0.1), expensive (1 or True: 0.3), or costs
        about ten iterations (2: 0.8, the stall rule's ratio too;
        ``engine.newton_matrix_cost``)."""
        if self.rate_refresh is not None:
            return float(self.rate_refresh)
        return (0.1, 0.3, 0.8)[int(cost)]

    def __post_init__(self):
        if self.linear_solver not in ("auto", "dense", "sparse", "banded", "condensed"):
            raise ValueError("NewtonOptions.linear_solver must be 'auto', 'dense', 'sparse', "
                             f"'banded' or 'condensed', got {self.linear_solver!r}")
        if self.start not in ("extrapolated", "last"):
            raise ValueError("NewtonOptions.start must be 'extrapolated' or 'last', got "
                             f"{self.start!r}")
        for name in ("rtol", "atol_kinematic", "atol_multiplier", "rate_refresh"):
            if name == "rate_refresh" and self.rate_refresh is None:
                continue
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
    multipliers_stalled : bool
        Accepted at the round-off floor (stagnation under exact Newton
        within ROUNDOFF_BAND tolerances; see the module docstring).
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
    multipliers_stalled: bool = False

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


class SparseLU:
    """Sparse LU factorization (SuperLU via scipy.sparse.linalg.splu) of a Newton matrix.

    The Newton matrices are structurally symmetric saddle-point matrices
    ([[K, Phi_q^T], [Phi_q, 0]] and its index-2 extension), so the columns
    are ordered by minimum degree on the pattern of J^T + J, with threshold
    partial pivoting (a pivot within a factor 100 of the column's largest
    is kept on the diagonal), as SuperLU's documentation recommends for
    such matrices. Measured on the chain of N = 1000 links (5000 unknowns):
    solve 0.11 ms against 0.28 ms with the default COLAMD ordering, with the
    same fill; the solution's residual stays below 1e-9 of the right side.
    """

    def __init__(self, J):
        self.singular = False
        try:
            self.lu = scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(J),
                                               permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.01)
        except RuntimeError:          # "Factor is exactly singular"
            self.singular, self.lu = True, None
            return
        d = np.abs(self.lu.U.diagonal())
        self.singular = bool(d.min() < 1e-14 * d.max()) or not np.all(np.isfinite(d))

    def solve(self, r: np.ndarray) -> np.ndarray:
        """J^{-1} r."""
        return self.lu.solve(r)


def factorize(J):
    """DenseLU for an ndarray, SparseLU for a scipy.sparse matrix."""
    return SparseLU(J) if issparse(J) else DenseLU(J)


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
              key=None, floor=0.0, at_roundoff=None, constraint_rows=None,
              frames_held=None, velocity_rows=False) -> NewtonResult:
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
        floor : float or ndarray of shape (N,) [m/s]
            Round-off floor declared by the method; absolute tolerances are
            raised to it.
        key : hashable
            Identifies the Newton matrix's dependence on the step (h); a
            stored factorization is reused only under the same key.
        at_roundoff : callable w -> bool, optional
            Whether the iterate w meets its constraints to round-off (the
            residual test of the module docstring); its rows are those of
            ``kinds`` unless ``constraint_rows`` says otherwise. None: the
            stall is read on the update alone.
        constraint_rows : ndarray of bool, shape (N,), optional
            The residual's constraint rows, where they are not the rows of
            the multiplier unknowns (HHT-ADD: ``Method.constraint_rows``).
        frames_held : callable w -> bool, optional
            Whether the iterate w holds the spatial bodies' frames within
            FRAME_HOLD (the module docstring). None: no spatial bodies.
        velocity_rows : bool
            Whether the residual has velocity-level constraint rows
            (stabilized index 2, HHT-ADD). With them, or with
            ``frames_held``, the last update must itself be within the
            tolerance; without, an iterate whose estimated error is within
            KAPPA of it is taken (the module docstring).

        Returns
        -------
        NewtonResult
        """
        opt = self.options
        w = np.array(w0, dtype=float)
        mult = np.asarray(kinds, dtype=bool)
        weight = self._weights(w, mult, scales, floor)
        res = NewtonResult(w, NewtonStatus.MAX_ITER)
        reuse = opt.jacobian is JacobianUpdate.MODIFIED
        lu = self._lu if (reuse and self._key == key) else None
        age = np.inf          # iterations since the Jacobian in use was evaluated
        prev, best = None, np.inf      # best: the smallest norm reached under exact Newton
        stalls = grows = 0
        theta = self._rate
        hold_update = velocity_rows or frames_held is not None
        for k in range(opt.max_iter):
            if lu is None:
                lu = self._factorize(jacobian, w, res)
                if lu is None:
                    return self._fail(res, w)
                age = 0
            r = res.residual = residual(w)
            res.n_residual += 1
            if not np.all(np.isfinite(r)):
                res.status = NewtonStatus.NONFINITE
                return self._fail(res, w)
            dw = lu.solve(r)
            norm = float(np.max(np.abs(dw * weight))) if len(dw) else 0.0
            res.norms.append(norm)
            w = w - dw
            res.n_iter += 1
            current = age == 0            # this update used a Jacobian of this very iterate
            age += 1
            if not np.all(np.isfinite(w)):
                res.status = NewtonStatus.NONFINITE
                return self._fail(res, w)
            if prev is not None and prev > 0:
                theta = norm / prev
                res.rate = theta
            eta = max(theta / (1.0 - theta), 1e-2) if theta < 1.0 else np.inf
            rate = opt.refresh_rate(isinstance(lu, SparseLU))
            stuck = prev is not None and norm >= max(0.5, rate) * prev
            if current:      # exact Newton: no halving of the best norm means round-off
                stalls = stalls + 1 if norm >= 0.5 * best else 0
                best = min(best, norm)
            roundoff = stalls >= 2 and norm <= ROUNDOFF_BAND
            grows = grows + 1 if (prev is not None and theta >= 1.0 and current) else 0
            diverging = theta > 100.0 or (grows >= 2 and norm > ROUNDOFF_BAND)
            if ((stalls >= 2 or diverging) and not roundoff and norm > 1.0
                    and at_roundoff is not None and at_roundoff(w + dw)
                    and self._rest_converged(lu, r, mult if constraint_rows is None
                                             else constraint_rows, weight)):
                w = w + dw          # the iterate whose residual r was read
                roundoff = True
            within = norm <= 1.0 or (bool(prev) and not hold_update and eta * norm <= KAPPA)
            if norm == 0.0 or roundoff or (eta * norm <= 1.0 and within and (
                    frames_held is None or frames_held(w + dw))):
                res.w, res.status = w, NewtonStatus.CONVERGED
                res.multipliers_stalled = roundoff
                self._rate = min(max(theta, 1e-3), 0.9) if np.isfinite(theta) else 0.5
                if reuse:
                    self._lu, self._key = lu, key
                return res
            if diverging:
                res.status = NewtonStatus.DIVERGING
                return self._fail(res, w)
            # A new Jacobian for the next iterate: always for full Newton. Modified
            # Newton keeps one from an earlier step while it contracts faster than
            # rate_refresh, one of this solve while it contracts faster than 1/2
            # (or rate_refresh, when larger: a matrix that costs many iterations).
            # Within the round-off band a contraction slower than 1/4 also asks for
            # exact Newton, so that a plateau of round-off is recognised as one.
            from_earlier_step = res.n_jacobian == 0
            if (opt.jacobian is JacobianUpdate.FULL or stuck
                    or (from_earlier_step and prev is not None and theta > rate)
                    or (norm <= ROUNDOFF_BAND and prev is not None and theta > 0.25)):
                lu = None
            prev = norm
        res.status = NewtonStatus.MAX_ITER
        return self._fail(res, w)

    def _weights(self, w, mult, scales, floor) -> np.ndarray:
        """The weights of the update's norm, scales / (atol + rtol |scales w|),
        shape (N,): absolute tolerances raised to the method's round-off
        ``floor``; the relative part per entry for kinematic unknowns,
        norm-wise for multipliers (``mult``: a joint's force is judged against
        the largest force in the mechanism)."""
        opt = self.options
        atol = np.maximum(np.where(mult, opt.atol_multiplier, opt.atol_kinematic), floor)
        size = np.abs(scales * w)
        if mult.any():
            size[mult] = np.max(size[mult])
        return scales / (atol + opt.rtol * size)

    @staticmethod
    def _factorize(jacobian, w, res):
        """The Newton matrix at w, evaluated and factorized (counted in
        ``res``); None with ``res.status`` NONFINITE or SINGULAR."""
        J = jacobian(w)
        res.n_jacobian += 1
        values = J.data if issparse(J) else J
        if not np.all(np.isfinite(values)):
            res.status = NewtonStatus.NONFINITE
            return None
        lu = factorize(J)
        res.n_factor += 1
        if lu.singular:
            res.status = NewtonStatus.SINGULAR
            return None
        return lu

    @staticmethod
    def _rest_converged(lu, r, rows, weight) -> bool:
        """Whether the update the residual's rows other than ``rows`` (the
        constraint rows) ask for meets the tolerance: ||J^-1 r'||_W <= 1,
        r' = r with ``rows`` zeroed."""
        if not rows.any():
            return False
        rest = np.where(rows, 0.0, r)
        return float(np.max(np.abs(lu.solve(rest) * weight))) <= 1.0

    def _fail(self, res: NewtonResult, w) -> NewtonResult:
        res.w = w
        self.invalidate()
        return res
