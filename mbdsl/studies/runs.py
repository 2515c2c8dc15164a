"""One run of a study: what to run (RunSpec), what it returns (RunData), and the
worker function that runs it (:func:`execute_run`).

A worker receives the model as its source text, never as a parsed object, so
the same call works in a local process pool and on a Dask cluster: specs and
results are small, picklable dataclasses of floats and numpy arrays. A worker
parses each distinct model once and keeps it (``_MODELS``), so a process that
executes many runs of one study pays the parse and assembly once.

Timings are taken in the worker: ``Solution.wall_time`` (the time loop only:
model parse, assembly, initial conditions, loading the compiled kernels and
output excluded), the median over ``repeat`` runs made after the run that
supplies the results, which warms what a first run pays for once (kernels
loaded, lazily imported modules, the processor's caches); a shared machine
is noisy and the median ignores the occasional descheduled run.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

__all__ = ["ModelSource", "RunSpec", "RunData", "execute_run", "time_run", "total_energy",
           "joint_velocity_violation"]


@dataclass(frozen=True)
class ModelSource:
    """A model as text, for workers that may not see the user's files.

    Attributes
    ----------
    text : str
        The ``.mbd`` source.
    file : str
        Its file name, for diagnostics.
    overrides : tuple of (str, str)
        Parameter overrides (``--set``), sorted.
    """

    text: str
    file: str
    overrides: tuple = ()

    @property
    def key(self) -> str:
        """SHA-256 of text, file and overrides: identifies the model in a worker's cache."""
        h = hashlib.sha256(self.text.encode())
        h.update(self.file.encode())
        h.update(repr(self.overrides).encode())
        return h.hexdigest()

    def load(self):
        """The checked Model (cached per process).

        Raises
        ------
        MbdError
            The model has errors.
        """
        key = self.key
        model = _MODELS.get(key)
        if model is None:
            from .. import load_text
            model = load_text(self.text, self.file, dict(self.overrides))
            _MODELS[key] = model
        return model


_MODELS: dict = {}


@dataclass(frozen=True)
class RunSpec:
    """One integration of a study.

    Attributes
    ----------
    method : str
        A key of :data:`mbdsl.METHODS`.
    h : float [s]
    t_end : float [s]
    coefficients : tuple of (str, float)
        Method coefficients given explicitly (e.g. ``(("alpha", -0.3),)``);
        the others come from the model's ``simulate`` section or the method's
        defaults, as in :func:`mbdsl.simulate`.
    repeat : int
        Timed runs after the one that supplies the results (a warm-up for
        them); 0 for a run whose time no table reports (its own time is kept).
    energy : bool
        Return the total energy at every step.
    drift_joint : str or None
        Return that joint's velocity constraint rows at every step.
    tol : float or None
        Error-controlled steps with rtol = atol = tol (``h`` the first
        step); None: fixed steps of h.
    samples : int
        Return q and v at this many equally spaced times after the start,
        the last at t_end (cubic Hermite on the steps; 0: none), for errors
        over the whole run.
    """

    method: str
    h: float
    t_end: float
    coefficients: tuple = ()
    repeat: int = 0
    energy: bool = False
    drift_joint: str | None = None
    tol: float | None = None
    samples: int = 0

    @property
    def key(self) -> tuple:
        """(method, h, coefficients[, tol]): runs with equal keys give equal results."""
        base = (self.method, self.h, self.coefficients)
        return base if self.tol is None else base + (self.tol,)

    def label(self) -> str:
        """``hht-i3 alpha=-0.3 h=2^-9``-style label for tables and messages."""
        coef = " ".join(f"{k}={v:g}" for k, v in self.coefficients)
        step = f"h={format_h(self.h)}" if self.tol is None else f"tol={self.tol:g}"
        return f"{self.method}{' ' + coef if coef else ''} {step}"


def format_h(h: float) -> str:
    """``2^-9`` for powers of two, else ``%g``."""
    k = np.log2(h)
    if abs(k - round(k)) < 1e-12:
        return f"2^{int(round(k))}"
    return f"{h:g}"


@dataclass
class RunData:
    """What a worker sends back.

    Attributes
    ----------
    spec : RunSpec
    status : str
        ``"completed"`` or ``"failed"``.
    message : str
        Why a run failed (the model's words), else empty.
    t_stop : float [s]
        Last time reached.
    q_end, v_end : ndarray, shape (n,)
    lam_end : ndarray, shape (m,)
        The output multipliers at the end (``Method.output_rows``).
        Generalized coordinates and velocities at ``t_stop``.
    coefficients : dict
        Every coefficient of the method as run.
    wall_times : list of float [s]
        Time-loop wall time of each timed repeat.
    engine : str
        The engine and linear solver that ran, e.g. ``compiled/dense``.
    stats : dict
        Totals of the first run: steps, rejected, iterations, residuals,
        jacobians, factorizations.
    t, energy : ndarray, shape (N,) or None
        Step times and total energy (``spec.energy``).
    drift : ndarray, shape (N, rows) or None
        ``Phi_q v + Phi_t`` of ``spec.drift_joint`` at every step.
    t_samples : ndarray, shape (k,) or None
        The times of ``spec.samples`` [s] (a completed run's).
    q_samples, v_samples : ndarray, shape (k, n) or None
        q and v there, by cubic Hermite interpolation of the steps.
    """

    spec: RunSpec
    status: str
    message: str
    t_stop: float
    q_end: np.ndarray
    v_end: np.ndarray
    coefficients: dict = field(default_factory=dict)
    wall_times: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)
    t: np.ndarray | None = None
    energy: np.ndarray | None = None
    drift: np.ndarray | None = None
    lam_end: np.ndarray | None = None
    engine: str = ""
    t_samples: np.ndarray | None = None
    q_samples: np.ndarray | None = None
    v_samples: np.ndarray | None = None

    @property
    def completed(self) -> bool:
        """True when the run reached t_end."""
        return self.status == "completed"

    @property
    def time(self) -> float:
        """Median wall time of the time loop [s]."""
        return float(np.median(self.wall_times)) if self.wall_times else float("nan")


def execute_run(source: ModelSource, spec: RunSpec) -> RunData:
    """Run one spec; never raises for a run that fails numerically.

    Parameters
    ----------
    source : ModelSource
    spec : RunSpec

    Returns
    -------
    RunData
        ``status == "failed"`` with the integrator's message when the run
        stopped early (its partial results up to ``t_stop`` are kept).

    Raises
    ------
    MbdError
        The model has errors or cannot be assembled (the parent reports it).
    """
    from .. import ConvergenceError, simulate
    model = source.load()
    try:
        sol = simulate(model, method=spec.method, h=spec.h, t_end=spec.t_end,
                       **_coefficients(spec))
        status, message = "completed", ""
    except ConvergenceError as err:
        sol, status, message = err.solution, "failed", str(err)
    times = [sol.wall_time]
    if status == "completed" and spec.repeat:      # the first run was the warm-up
        times = [time_run(source, spec) for _ in range(spec.repeat)]
    tot = sol.stats_total
    stats = {k: int(getattr(tot, k)) for k in
             ("steps", "rejected", "iterations", "residuals", "jacobians", "factorizations")}
    data = RunData(spec, status, message, float(sol.t[-1]), sol.q[-1].copy(), sol.v[-1].copy(),
                   dict(sol.method_parameters), times, stats,
                   engine=f"{sol.engine}/{sol.linear_solver}")
    data.lam_end = sol.lam[-1].copy()
    if spec.energy or spec.drift_joint:
        data.t = sol.t.copy()
    if spec.energy:
        data.energy = total_energy(sol.system, sol.q, sol.v)
    if spec.drift_joint:
        data.drift = joint_velocity_violation(sol, spec.drift_joint)
    if spec.samples and status == "completed":
        data.t_samples = sample_times(float(sol.t[0]), spec.t_end, spec.samples)
        data.q_samples, data.v_samples = hermite_state(sol)(data.t_samples)
    return data


def sample_times(t_start: float, t_end: float, k: int) -> np.ndarray:
    """k equally spaced times after t_start, the last at t_end [s], shape (k,)."""
    return np.linspace(t_start, t_end, k + 1)[1:]


def time_run(source: ModelSource, spec: RunSpec) -> float:
    """One more run of ``spec`` (one that completed before): the wall time of
    its time loop [s] (``Solution.wall_time``)."""
    from .. import simulate
    return simulate(source.load(), method=spec.method, h=spec.h, t_end=spec.t_end,
                    **_coefficients(spec)).wall_time


def _coefficients(spec: RunSpec) -> dict:
    """The keyword arguments of ``simulate`` for ``spec``'s method
    coefficients and, with ``spec.tol``, its error-controlled steps, else
    fixed steps of h (a model whose simulate section sets a tolerance too)."""
    coef = dict(spec.coefficients)
    if spec.tol is not None:
        coef.update(rtol=spec.tol, atol=spec.tol)
    else:                   # a sweep over h: steps of h, whatever the model's tolerance
        coef["fixed"] = True
    return coef


def total_energy(system, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Kinetic plus potential energy [J] of states q, v of shape (N, n); shape (N,)."""
    return np.array([system.kinetic_energy(qi, vi) + system.potential_energy(qi)
                     for qi, vi in zip(q, v)])


def joint_velocity_violation(sol, joint: str) -> np.ndarray:
    """``Phi_q v + Phi_t`` restricted to one joint's rows at every step.

    Parameters
    ----------
    sol : Solution
    joint : str
        A joint or driver name of the model.

    Returns
    -------
    ndarray, shape (N, rows of the joint)
        [m/s] for the translational rows, [rad/s] for the rotational one.

    Raises
    ------
    KeyError
        Unknown joint.
    """
    sys_ = sol.system
    rows = sys_.layout.element_rows[joint]
    out = np.empty((len(sol.t), len(rows)))
    for i, (t, q, v) in enumerate(zip(sol.t, sol.q, sol.v)):
        out[i] = (sys_.Phiq_times(q, t, v) + sys_.Phi_t(q, t))[rows]
    return out


def hermite_state(sol):
    """Continuous (q, v) of a Solution by cubic Hermite interpolation of its steps."""
    from scipy.interpolate import CubicHermiteSpline
    t = sol.t
    keep = np.concatenate([[True], np.diff(t) > 0])     # Hermite needs increasing t
    sq = CubicHermiteSpline(t[keep], sol.q[keep], sol.v[keep], axis=0)
    sv = CubicHermiteSpline(t[keep], sol.v[keep], sol.a[keep], axis=0)

    def state(tt):
        """(q, v) at times tt, each (N, n)."""
        tt = np.asarray(tt, dtype=float)
        return sq(tt), sv(tt)

    return state
