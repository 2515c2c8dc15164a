"""What every integration method declares: the recipe interface.

A method is a recipe: the layout of its unknowns w, the integration
formulas q = I1(w), v = I2(w), the residual Upsilon(w) with its row
scaling, the Newton Jacobian, its start-up, its history length, its order
and index. The time loop (``loop.py``), the Python Newton loop
(``newton.py``) and the compiled loop (``integrators/compiled/loop.py``, on the method's
``kernel_recipe``) never ask which method they run.

Methods hold no mutable state: per-step values live in :class:`StepContext`
(built once per step) and :class:`StepState` (converged values at t_n).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Block", "StepState", "StepContext", "Method"]


@dataclass(frozen=True)
class Block:
    """A block of the unknown vector w.

    Attributes
    ----------
    name : str
        e.g. ``"a"``, ``"lam"``, ``"mu"``.
    size : int
    kind : {"kinematic", "multiplier"}
        Selects the Newton tolerance (accelerations and positions versus
        multipliers, which are in N and N m).
    """

    name: str
    size: int
    kind: str


@dataclass
class StepState:
    """Converged values at one time t_n.

    Attributes
    ----------
    t : float [s]
    q, v, a : ndarray, shape (n,)
        ``a`` is the method's acceleration-like variable (for HHT, the
        acceleration of the alpha-shifted equation, a_0 = q''(t_0)).
    lam : ndarray, shape (m,)
    extra : dict of str -> ndarray
        Method-specific values (``mu`` for the index-2 methods, cached
        force terms).
    """

    t: float
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    extra: dict = field(default_factory=dict)


@dataclass
class StepContext:
    """Everything one step needs, built once per step by the method.

    Attributes
    ----------
    system : AssembledSystem
    history : tuple of StepState
        Newest last; as long as the method's ``history_length`` allows.
    t : float [s]
        t_{n+1}.
    h : float [s]
        This step's size.
    cache : dict
        Per-step constants (predictors, mid-step mass matrix, old forces).
    assembler : JacobianAssembler or None
        The run's Newton-matrix assembler (dense or sparse, set by the
        driver); a dense one is made on first use when None.
    regularization : float [1/kg]
        The augmented formulation's epsilon (:meth:`Method.formulated`),
        set by the driver; 0 for the Lagrange formulation.
    """

    system: object
    history: tuple
    t: float
    h: float
    cache: dict = field(default_factory=dict)
    assembler: object = None
    #: epsilon of the augmented formulation's multiplier block (0: Lagrange)
    regularization: float = 0.0

    @property
    def last(self) -> StepState:
        """The state at t_n."""
        return self.history[-1]


class Method(ABC):
    """Abstract integration recipe; the paper's six methods and generalized-alpha are final subclasses.

    Attributes
    ----------
    name : str
        The paper's name, e.g. ``"hht-i3"``.
    index : int
        DAE index of the form it discretizes (3 or 2).
    history_length : int
        Number of past states the formulas use (2 for BDF2).
    extras : tuple of str
        Per-step multiplier arrays besides lambda, output as
        ``<name>.<joint>.<k>`` columns (``mu`` for the SI2 methods).
    """

    name: str = ""
    index: int = 3
    history_length: int = 1
    #: The largest ratio of successive step sizes the formulas stay stable for
    #: (error-controlled steps cap their growth at it): None for one-step
    #: methods; variable-step BDF2 is zero-stable for ratios below 1 + sqrt(2)
    #: (Grigorieff 1983; Hairer & Wanner, Solving ODEs II, sec. III.5).
    max_step_ratio: float | None = None
    #: Whether its formulas apply M^-1 (HHT-ADD's f and r): a run refuses a mass
    #: matrix with a zero on its diagonal (``driver._mass_inverse``)
    needs_mass_inverse: bool = False
    #: names of StepState.extra arrays of length m written to the output (e.g. "mu")
    extras: tuple = ()
    #: further (m,) columns that :meth:`output_rows` adds to the output
    output_extras: tuple = ()
    #: "lagrange" (the Newton matrix as derived) or "augmented" (see :meth:`formulated`)
    formulation: str = "lagrange"
    #: whether the method accepts the augmented formulation (index-3 methods
    #: whose Newton matrix is ``common.index3_newton_matrix``)
    accepts_augmented: bool = False
    #: epsilon of the augmented formulation [1/kg] (0: Lagrange)
    regularization: float = 0.0
    #: whether the carried acceleration ``a`` is the total one q'' (False for
    #: HHT-ADD, whose ``a`` is the applied forces' M^-1 Q without the
    #: constraint forces): where the motion's acceleration is read (the
    #: event locator's free flight to a closing), it is then the index-1 one
    acceleration_is_total: bool = True
    #: whether the rows of the residual's constraint equations are the rows of
    #: the multiplier unknowns (w = (x, [y,] lambda, [mu]), rows (dynamics, [..,]
    #: Phi, [Phi_q v + Phi_t])): every method but HHT-ADD, whose additive form
    #: orders them otherwise. Newton's round-off test on the residual
    #: (``newton.py``) reads the constraint rows by it.
    saddle_point_rows: bool = True

    @property
    def estimate_on_index1(self) -> bool:
        """Whether an error-controlled step's estimate reads the index-1
        projection of :meth:`estimate_acceleration` (``StepControl.index1``,
        ``adaptive.index1_acceleration``): the index-3 methods, whose own a
        meets only Phi = 0, its normal part the multipliers' round-off over
        beta h^2."""
        return self.index == 3

    def constraint_rows(self, system) -> np.ndarray | None:
        """The residual's rows that hold Phi and, at index 2, Phi_q v + Phi_t,
        shape (N,) of bool, where they are not the rows of the multiplier
        unknowns (Newton's round-off test, ``newton.py``); None: they are
        (``saddle_point_rows``)."""
        return None

    def estimate_acceleration(self, system, state: StepState) -> np.ndarray:
        """The acceleration (n,) [m/s^2, rad/s^2] whose change over a step the
        error estimate reads (``local_error``): the carried a."""
        return state.a

    #: epsilon = AUGMENTED_EPSILON / (largest body mass): small against the
    #: smallest non-zero singular value of Phi_q M^-1 Phi_q^T of a mechanism
    #: away from a singular position (so a full-rank step converges as with
    #: Lagrange), and it keeps the Newton matrix invertible at one
    AUGMENTED_EPSILON = 1e-10

    def formulated(self, formulation: str, system) -> "Method":
        """This method with the constraint formulation ``formulation``.

        ``"lagrange"``: the Newton matrix as derived (the default).
        ``"augmented"``: the index-3 augmented Lagrangian iteration. The
        multiplier block of the Newton matrix, 0 for Lagrange, is -epsilon I:
        eliminating the multiplier increment gives the Newton step of the
        augmented Lagrangian with penalty 1/epsilon,

            (A + Phi_q^T Phi_q / epsilon) da = -r_1 - Phi_q^T r_2 / epsilon,
            dlambda = (Phi_q da + r_2) / epsilon,

        A the kinematic block, and lambda is updated by it every iteration
        (lambda_{k+1} = lambda_k + dlambda: the augmented Lagrangian's
        multiplier update, Bayo & Ledesma 1996). The residual is unchanged,
        so a converged step solves the same equations as Lagrange; the matrix
        is invertible where Phi_q loses rank (singular positions, redundant
        joints), where Lagrange's is singular. There the multipliers are not
        unique (only Phi_q^T lambda is), so Newton judges convergence on the
        kinematic unknowns alone.

        Its Newton matrix is evaluated and factored at the first iterate of
        every step, never reused from an earlier step. Close to a singular
        position the step's solution is ill-determined along the directions
        where Phi_q loses rank, and a matrix taken at the configuration
        before it steers the iteration to a point within the kinematic
        tolerance but away from the solution. Measured on the N-four-bar
        (N = 40, 20 s, compiled, NSTIFF): with reuse, one step just past the
        first singular position ended 2.7e-6 m from the exact-Newton
        solution with a velocity-constraint residual 300 times its
        neighbours', and the top point's error at h = 1e-3, 7e-4, 5e-4 s was
        3.0e-2, 5.3e-2, 7.6e-3 m; with a matrix per step it is 6.4e-3,
        2.4e-3, 9.6e-4 m, the same as full Newton to the printed digits, for
        200 instead of 176 us per step (fewer iterations pay for most of the
        factorizations).

        Raises
        ------
        ValueError
            An unknown formulation, or ``"augmented"`` for a method that
            does not accept it (the index-2 and HHT-ADD methods).
        """
        if formulation not in ("lagrange", "augmented"):
            raise ValueError(f"unknown formulation '{formulation}'; "
                             "formulations are lagrange, augmented")
        if formulation == "lagrange":
            return self
        if not self.accepts_augmented:
            raise ValueError(f"{self.name} does not take the augmented formulation; "
                             "newmark, hht-i3, nstiff and genalpha do")
        import copy
        out = copy.copy(self)
        out.formulation = "augmented"
        masses = [b.mass for b in system.model.bodies] or [1.0]
        out.regularization = self.AUGMENTED_EPSILON / max(masses)
        return out

    @abstractmethod
    def order(self, system=None) -> int:
        """Global order of accuracy in q and v, on the model of ``system``
        (an AssembledSystem; None: a rigid model without friction, where
        every method has its nominal order). docs/methods.md gives the
        measured orders."""

    @abstractmethod
    def parameters(self) -> dict:
        """The method's coefficients, for output metadata."""

    @abstractmethod
    def blocks(self, system) -> list[Block]:
        """Layout of the unknown vector w."""

    @abstractmethod
    def start(self, system, initial) -> list[StepState]:
        """The history at t_0 from a consistent InitialState."""

    @abstractmethod
    def scales(self, system, h: float, q: np.ndarray) -> np.ndarray:
        """Velocity-equivalent scale of each unknown [m/s per unit], shape (N,).

        Used by the Newton convergence test (see ``newton.py``); q is the
        configuration at t_n (multipliers scale with the mobility there).
        """

    @abstractmethod
    def roundoff_floor(self, system, h: float, q: np.ndarray) -> np.ndarray:
        """Smallest velocity-equivalent change [m/s] Newton can resolve, per unknown.

        The round-off of Phi (eps |q|) through the method's constraint row
        scaling (see ``common.roundoff_floor``); the Newton tolerance is
        never set below it. Shape (N,).
        """

    @abstractmethod
    def context(self, system, history, t: float, h: float) -> StepContext:
        """Per-step constants for the step to t (= t_n + h)."""

    @abstractmethod
    def predict(self, ctx: StepContext) -> np.ndarray:
        """Newton start w(0)."""

    @abstractmethod
    def residual(self, w: np.ndarray, ctx: StepContext) -> np.ndarray:
        """Upsilon(w), row-scaled."""

    @abstractmethod
    def jacobian(self, w: np.ndarray, ctx: StepContext) -> np.ndarray:
        """d Upsilon / d w (or the method's approximation of it)."""

    @abstractmethod
    def accept(self, w: np.ndarray, ctx: StepContext) -> StepState:
        """The state at t_{n+1} from the converged w."""

    def kernel_recipe(self, h: float, first: bool):
        """The method as data for the compiled engine (:mod:`.recipe`), or None.

        Parameters
        ----------
        h : float [s]
            Step size.
        first : bool
            A start-up step (no history at this h; only BDF2 differs).

        Returns
        -------
        ndarray, shape (len(recipe.RECIPE_FIELDS),), or None
            None for a method the kernels do not express.
        """
        return None

    def kernel_recipe_at(self, h: float, first: bool, c0: float, w0: float,
                         w1: float) -> np.ndarray:
        """The recipe at step size h with a two-step method's coefficients
        c0, w0, w1 for unequal steps (``common.bdf_coefficients``); one-step
        methods have none and return ``kernel_recipe(h, first)``."""
        return self.kernel_recipe(h, first)

    def local_error(self, ctx: StepContext, new: StepState) -> np.ndarray:
        """Estimated local error of the positions over the step from
        ``ctx.last`` to ``new``, shape (n,) [m, rad] (``adaptive``: the
        estimate of each method and its source).

        The Newmark-type default: (beta - 1/6) h^2 (a_{n+1} - a_n)
        (Zienkiewicz & Xie 1991), with the method's ``beta``.
        """
        c, absolute = self.error_coefficient(ctx)
        return c * (new.a if absolute else new.a - ctx.last.a)

    def error_coefficient(self, ctx: StepContext) -> tuple[float, bool]:
        """(c [s^2], absolute): the local position error is c (a_{n+1} - a_n),
        or c a_{n+1} when ``absolute`` (``local_error``; the compiled
        recipe's ``err`` and ``eabs``). The Newmark-type default
        ((beta - 1/6) h^2, False)."""
        return (self.beta - 1.0 / 6.0) * ctx.h ** 2, False

    def first_step(self, history, h: float) -> bool:
        """Whether the step of size h after ``history`` is a start-up step
        (the recipe's ``first``); False for one-step methods."""
        return False

    def output_rows(self, system, t, q, v, a, lam, extras):
        """The multipliers and accelerations written to the output for
        recorded rows, and the extra columns (``output_extras``) added to them.

        Parameters
        ----------
        system : AssembledSystem
        t : ndarray, shape (N,) [s]
        q, v, a : ndarray, shape (N, n)
            The recorded state; ``a`` the method's acceleration-like unknown.
        lam : ndarray, shape (N, m)
            The method's multipliers as the steps computed them.
        extras : dict of str -> ndarray, shape (N, m)
            The stored extras (``extras``).

        Returns
        -------
        lam : ndarray, shape (N, m)
        a : ndarray, shape (N, n)
        extras : dict
            Entries for ``output_extras``. Here: ``lam`` and ``a`` unchanged,
            no extras (the methods whose lambda is the Lagrange multiplier of
            the equations of motion at t_{n+1} and whose a is the motion's q'').
        """
        return lam, a, {}

    @abstractmethod
    def amplification(self, omega_h: float) -> np.ndarray:
        """The matrix of one step on the linear oscillator x'' = -omega^2 x at
        Omega = omega h (``spectral.py``: its eigenvalues are the method's
        roots, from which the numerical damping and period error follow)."""

    def stability_check_every(self, system) -> int:
        """Accepted steps between two calls of :meth:`stability_check` on the
        model of ``system``; 0 (the default): never."""
        return 0

    def stability_check(self, system, state, h):
        """None, or ``(message, hint)`` when the method cannot take steps of
        h [s] stably from the accepted ``state`` (a StepState): the run then
        stops with E603 and keeps what it computed. The default: None."""
        return None

    def describe(self) -> str:
        """``name(alpha=-0.05, ...)`` for messages."""
        params = ", ".join(f"{k}={v:g}" for k, v in self.parameters().items())
        return f"{self.name}({params})"
