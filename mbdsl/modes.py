"""Linearization and modes: the mechanism's spectrum about a state.

The constrained equations of motion M(q) q'' + Phi_q^T lambda = Q(t, q, v),
Phi(q, t) = 0, perturbed about a state (q, v, a, lambda) that satisfies them:

    M dq'' + C dq' + K dq + Phi_q^T dlambda = 0,    Phi_q dq = 0,

    K = (M a)_q + (Phi_q^T lambda)_q - Q_q,    C = -Q_v,

K holding the stiffness of springs, beams, closed contacts and forces of the
state, the geometric stiffness of the constraint forces ((Phi_q^T lambda)_q,
what makes a hanging pendulum stiff) and the mass matrix's change with q
under the state's acceleration; C the damping of dampers and contacts and,
for flexible beams at a moving state, their gyroscopic terms (Geradin &
Cardona, Flexible Multibody Dynamics, sec. 12.3, on linearizing constrained
equations; Haug, Computer-Aided Kinematics and Dynamics of Mechanical
Systems, sec. 9.3). Drivers are constraints and hold their coordinates.
With dq = N z, N an orthonormal basis of the null space of Phi_q (its rank
counts the independent constraints: redundant joints are no trouble), the
reduced equations N^T M N z'' + N^T C N z' + N^T K N z = 0 have the
mechanism's degrees of freedom as unknowns. At a moving state the change of
N along the motion is neglected: the modes are those of the frozen
configuration.

Eigenvalues s of the reduced problem give each mode's natural frequency
omega = |s| [rad/s], damping ratio zeta = -Re(s)/|s| and shape (dq = N z,
in the model's coordinates). Without damping the symmetric problem
K z = omega^2 M z is solved as such (scipy.linalg.eigh); omega^2 < 0 is a
divergent (unstable) direction, reported with omega = sqrt(-omega^2) as its
growth rate. Models of more than ``DENSE_LIMIT`` coordinates use the sparse
constrained pencil instead,

    [[K, Phi_q^T], [Phi_q, 0]] x = omega^2 [[M, 0], [0, 0]] x,

with ARPACK in shift-invert mode about a small negative shift (scipy's
``eigsh``) for the lowest k frequencies, and ARPACK on P M^-1 K P (P the
M-orthogonal projector onto the null space of Phi_q) for the highest k;
damping left out (said so in the report).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .integrators.spectral import MethodSpectrum, spectrum

__all__ = ["DENSE_LIMIT", "FOLLOWED_PERIOD_ERROR", "STEP_CHECK_LIMIT", "Mode", "Modes",
           "describe_followed", "followed", "linearize", "mode_motion", "modes",
           "step_warning"]

#: above this many coordinates the sparse pencil and ARPACK (lowest k modes)
DENSE_LIMIT = 1500


def _sparse(pattern, vals, shape):
    import scipy.sparse
    rows, cols = pattern
    return scipy.sparse.csr_matrix((vals, (rows, cols)), shape=shape)


@dataclass
class Linearization:
    """The linearized equations about one state (sparse, scipy CSR).

    Attributes
    ----------
    M, C, K : scipy.sparse matrix, shape (n, n)
        Mass [kg, kg m, kg m^2], damping [N s/m ...] and stiffness [N/m ...]
        of M dq'' + C dq' + K dq + Phi_q^T dlambda = 0.
    Phi_q : scipy.sparse matrix, shape (m, n)
        The constraint Jacobian (dq must satisfy Phi_q dq = 0).
    damped : bool
        Whether C is not zero.
    """

    M: object
    C: object
    K: object
    Phi_q: object
    damped: bool


def linearize(system, t: float, q: np.ndarray, v: np.ndarray, a: np.ndarray,
              lam: np.ndarray) -> Linearization:
    """M, C, K and Phi_q of the constrained equations linearized about (t, q, v, a, lambda).

    Parameters
    ----------
    system : AssembledSystem
    t : float
        Time [s] (drivers and forces of time are frozen at t).
    q, v, a : ndarray, shape (n,)
        The state and its acceleration (zero at an equilibrium).
    lam : ndarray, shape (m,)
        The Lagrange multipliers at the state.

    Returns
    -------
    Linearization
        K = (M a)_q + (Phi_q^T lambda)_q - Q_q, C = -Q_v (module docstring).
    """
    n, m = system.n, system.m
    shape = (n, n)
    M = _sparse(system.pattern_mass, system.mass_values(q), shape)
    K = _sparse(system.pattern_hessian, system.PhiqT_lam_q_values(q, lam), shape) if m else \
        _sparse((np.zeros(0, int), np.zeros(0, int)), np.zeros(0), shape)
    Ma = system.Ma_q_values(q, a)
    if Ma is not None:
        K = K + _sparse(system.pattern_mass, Ma, shape)
    Qq, Qv = system.force_derivative_values(t, q, v, lam)
    if Qq is not None:
        K = K - _sparse(system.pattern_force, Qq, shape)
    C = _sparse(system.pattern_force, -Qv, shape) if Qv is not None else \
        _sparse((np.zeros(0, int), np.zeros(0, int)), np.zeros(0), shape)
    C.eliminate_zeros()
    G = _sparse(system.pattern_Phi_q, system.Phi_q_values(q, t), (m, n))
    damped = C.nnz > 0 and float(abs(C).max()) > 0.0
    return Linearization(M.tocsr(), C.tocsr(), K.tocsr(), G, damped)


@dataclass
class Mode:
    """One mode of the linearized mechanism.

    Attributes
    ----------
    omega : float
        Natural frequency |s| [rad/s] (for a divergent mode: its growth rate).
    damping_ratio : float
        zeta = -Re(s)/|s| (0 undamped; 1 and above: not oscillating; nan for
        a zero-frequency mode, a free motion).
    shape : ndarray, shape (n,)
        The mode shape in the model's coordinates, largest entry 1 [m, rad].
    stable : bool
        False for a divergent direction (omega^2 < 0: an unstable equilibrium).
    energy_share : ndarray, shape (n,)
        Each coordinate's share of the mode's kinetic energy (x_i (M x)_i /
        x^T M x): which bodies move.
    stiffened_by : list of (str, float)
        The springs (translational and rotational) that hold at least a tenth
        of the mode's strain energy x^T K x / 2, with their shares, largest
        first: what the mode is the vibration of (the elbow spring of a
        stiff double pendulum).
    """

    omega: float
    damping_ratio: float
    shape: np.ndarray
    stable: bool
    energy_share: np.ndarray
    stiffened_by: list = field(default_factory=list)

    @property
    def frequency(self) -> float:
        """omega / (2 pi) [Hz]."""
        return self.omega / (2.0 * np.pi)


def _moving(names, mode: Mode, share: float = 0.1) -> list[tuple[str, float]]:
    """(element, share of the kinetic energy) of the elements (the part of a
    coordinate name in ``names`` before its dot) carrying at least ``share``
    of the mode's kinetic energy, largest first."""
    out: dict[str, float] = {}
    for name, e in zip(names, mode.energy_share):
        # a body's coordinates by its name; a first-order state's by "state.<name>"
        key = ".".join(name.split(".")[:2]) if name.startswith("state.") else name.split(".")[0]
        out[key] = out.get(key, 0.0) + float(e)
    return sorted([(k, v) for k, v in out.items() if v >= share], key=lambda kv: -kv[1])


def _mode_of(names, mode: Mode) -> str:
    """``spring NAME: body, body`` or ``body, body`` (``Modes.mode_of``)."""
    bodies = ", ".join(k for k, _ in _moving(names, mode)[:2]) or "spread over the chain"
    return f"spring {mode.stiffened_by[0][0]}: {bodies}" if mode.stiffened_by else bodies


@dataclass
class Modes:
    """The modes of a model about one state, lowest frequency first.

    Attributes
    ----------
    model_name : str
    at : str
        Which state: ``"initial"``, ``"static"`` or ``"RESULT at t = ..."``.
    t : float
        Its time [s].
    q : ndarray, shape (n,)
    names : list of str
        The coordinates' names (``rod.x``, ``beam.u1`` ...).
    dof : int
        Degrees of freedom at the state (n - rank Phi_q).
    modes : list of Mode
    solver : str
        ``"dense"`` (every mode, damping included) or ``"sparse"`` (the
        lowest k by ARPACK, damping left out).
    notes : list of str
    """

    model_name: str
    at: str
    t: float
    q: np.ndarray
    names: list
    dof: int
    modes: list
    solver: str
    notes: list = field(default_factory=list)

    def moving_bodies(self, mode: Mode, share: float = 0.1) -> list[tuple[str, float]]:
        """(element, share of the kinetic energy) of the elements (bodies,
        beams, particles) that carry at least ``share`` of the mode's kinetic
        energy, largest first (:func:`_moving`)."""
        return _moving(self.names, mode, share)

    def mode_of(self, mode: Mode) -> str:
        """What a mode is, in a few words: ``spring elbow: link2, link1`` (the
        spring holding its strain energy, then the two bodies moving most)."""
        return _mode_of(self.names, mode)

    def method_spectra(self, method, h: float) -> list[MethodSpectrum | None]:
        """What ``method`` (an integrator) does to each mode at step h [s]
        (``integrators.spectral``); None for a zero-frequency or divergent mode."""
        return [spectrum(method.amplification(mo.omega * h), mo.omega * h)
                if mo.stable and mo.omega > 0.0 else None for mo in self.modes]

    def report(self, method=None, h: float | None = None) -> str:
        """The modes as a text table; with a method and h, what it does to each."""
        lines = [f"model {self.model_name}: {len(self.modes)} mode"
                 f"{'s' if len(self.modes) != 1 else ''} at the {self.at} state "
                 f"(t = {self.t:g} s), {self.dof} degree{'s' if self.dof != 1 else ''} of freedom, "
                 f"{self.solver} eigensolver"]
        lines += [f"  note: {n}" for n in self.notes]
        lines.append(f"  {'mode':>4}  {'f [Hz]':>12}  {'omega [rad/s]':>13}  {'damping':>8}  "
                     "moves most (share of kinetic energy); spring (of strain energy)")
        for i, mo in enumerate(self.modes, 1):
            who = ", ".join(f"{k} {100 * v:.0f} %" for k, v in self.moving_bodies(mo)[:3])
            if mo.stiffened_by:
                who += "; spring " + ", ".join(f"{k} {100 * v:.0f} %"
                                                for k, v in mo.stiffened_by[:2])
            zeta = ("   -" if np.isnan(mo.damping_ratio) else      # round-off shown as 0
                    f"{(0.0 if abs(mo.damping_ratio) < 1e-10 else mo.damping_ratio):8.4g}")
            freq = f"{mo.frequency:12.6g}" if mo.stable else f"{'unstable':>12}"
            lines.append(f"  {i:>4}  {freq}  {mo.omega:13.6g}  {zeta:>8}  {who}")
        if method is not None and h is not None:
            lines.append(f"  {method.describe()} at h = {h:g} s:")
            lines.append(f"  {'mode':>4}  {'omega h':>10}  {'rho':>8}  {'xi_bar':>9}  "
                         f"{'period err':>10}  {'steps to lose 99 %':>18}")
            for i, sp in enumerate(self.method_spectra(method, h), 1):
                if sp is None:
                    continue
                if sp.omega_h < 1e-4:         # the roots' angles are at round-off there
                    lines.append(f"  {i:>4}  {sp.omega_h:10.4g}  {sp.rho:8.6f}  "
                                 f"{'(a mode this slow is not touched by the step)':>41}")
                    continue
                xi = "-" if np.isnan(sp.damping_ratio) else f"{sp.damping_ratio:.3g}"
                per = "-" if not np.isfinite(sp.period_error) else f"{sp.period_error:+.3g}"
                steps = "never" if not np.isfinite(sp.steps_to_damp) else f"{sp.steps_to_damp:.3g}"
                lines.append(f"  {i:>4}  {sp.omega_h:10.4g}  {sp.rho:8.6f}  {xi:>9}  {per:>10}  "
                             f"{steps:>18}")
            lines.append("  " + describe_followed(self, method, h))
        return "\n".join(lines)


#: A mode is followed by a step when its period error under the method is at
#: most this (about 18 steps per period for the second-order methods); the
#: modes above it are not followed but damped (or, without numerical damping,
#: carried at the wrong frequency).
FOLLOWED_PERIOD_ERROR = 0.01


def followed(found: "Modes", method, h: float):
    """(the fastest mode ``method`` follows at step h, the modes it does not
    follow), each entry (index, Mode, MethodSpectrum); the first is None when
    it follows none. Zero-frequency and divergent modes are left out."""
    fast, above = None, []
    for i, (mo, sp) in enumerate(zip(found.modes, found.method_spectra(method, h)), 1):
        if sp is None:
            continue
        ok = sp.omega_h < 1e-4 or (np.isfinite(sp.period_error)       # (roots' angles at
                                    and abs(sp.period_error) <= FOLLOWED_PERIOD_ERROR)  # round-off)
        if ok and (fast is None or mo.omega > fast[1].omega):
            fast = (i, mo, sp)
        elif not ok:
            above.append((i, mo, sp))
    return fast, above


def describe_followed(found: "Modes", method, h: float) -> str:
    """One sentence: which modes the step h follows and what ``method`` does to
    the others (for ``study recommend`` and ``mbdsl modes``)."""
    fast, above = followed(found, method, h)

    def who(mo):
        """The mode in the sentence's words: 'the spring elbow: link2, link1'."""
        return ("the " if mo.stiffened_by else "") + found.mode_of(mo)
    parts = []
    if fast is not None:
        i, mo, sp = fast
        per = f", period error {sp.period_error:+.2g}" if sp.omega_h >= 1e-4 else ""
        parts.append(f"h = {h:.3g} s follows the modes up to {mo.frequency:.4g} Hz (mode {i}, "
                     f"{who(mo)}; omega h = {sp.omega_h:.3g}{per})")
    else:
        parts.append(f"h = {h:.3g} s follows none of the modes")
    if above:
        i, mo, sp = above[0]
        steps = sp.steps_to_damp
        damp = (f"{method.name} removes 99 % of its energy in {steps:.3g} steps "
                f"({steps * h:.3g} s)" if np.isfinite(steps) else
                f"{method.name} does not damp it (rho = {sp.rho:.6f})")
        parts.append(f"{len(above)} mode{'s' if len(above) > 1 else ''} above "
                     f"{'are' if len(above) > 1 else 'is'} not followed, the lowest of them "
                     f"mode {i} at {mo.frequency:.4g} Hz ({who(mo)}; omega h = {sp.omega_h:.3g}): "
                     + damp)
    return "; ".join(parts)


#: Models up to this many coordinates get the pre-run check of the step
#: against their modes (:func:`step_warning`; a dense eigenproblem, about a
#: millisecond at 10 coordinates and 20 ms at 100).
STEP_CHECK_LIMIT = 100


def step_warning(system, initial, method, h: float, t_span: float):
    """W606, or None: a mode the step h does not follow (omega h > 1) that
    ``method`` does not damp within the run either (99 % of its energy lasts
    more than the run's t_span / h steps) or amplifies (rho > 1): its error
    stays in the motion, at the wrong frequency, for the whole run. A mode
    that its own damping removes within the run, or an overdamped one (zeta
    >= 1: it does not oscillate), is not kept by any of the methods (they are
    A-stable) and is not reported. The modes
    are those about the initial state (``initial``: an InitialState); models
    of more than ``STEP_CHECK_LIMIT`` coordinates are not checked.
    """
    from .errors import Diagnostic
    if system.n > STEP_CHECK_LIMIT or h <= 0.0 or t_span <= 0.0:
        return None
    lin = linearize(system, initial.t, initial.q, initial.v, initial.a, initial.lam)
    try:
        _, found = _dense_modes(lin, None, False)
    except (np.linalg.LinAlgError, ValueError):
        return None
    steps = t_span / h
    worst = None
    for i, mo in enumerate(found, 1):
        if not mo.stable or mo.omega * h <= 1.0:
            continue
        # its own damping removes 99 % of its energy (exp(-2 zeta omega t)) within the
        # run, or it does not oscillate at all (zeta >= 1, a stiff damper's decay):
        # the methods, A-stable, decay it too and nothing is kept
        zeta = mo.damping_ratio if np.isfinite(mo.damping_ratio) else 0.0
        if zeta >= 1.0 or 2.0 * zeta * mo.omega * t_span >= np.log(100.0):
            continue
        try:            # a mode of an overflowing model (a damper of 1e308 N s/m) has none
            sp = spectrum(method.amplification(mo.omega * h), mo.omega * h)
        except (np.linalg.LinAlgError, ValueError, OverflowError):
            continue
        if sp.rho > 1.0 + 1e-9 or sp.steps_to_damp > steps:
            worst = (i, mo, sp)
    if worst is None:
        return None
    i, mo, sp = worst
    mo.stiffened_by = _springs_in(system, initial.q, lin, mo.shape)
    what = ("the " if mo.stiffened_by else "") + _mode_of(system.layout.coordinates, mo)
    if sp.rho > 1.0 + 1e-9:
        fate = f"amplifies it (rho = {sp.rho:.6f})"
    elif not np.isfinite(sp.steps_to_damp):
        fate = "keeps it undamped (rho = 1)"
    else:
        fate = (f"keeps it: 99 % of its energy takes {sp.steps_to_damp:.3g} steps, the run "
                f"has {steps:.3g} (rho = {sp.rho:.6f})")
    return Diagnostic(
        "warning", "W606",
        f"mode {i} at {mo.frequency:.4g} Hz ({what}) has omega h = {mo.omega * h:.3g} at "
        f"h = {h:g} s: {method.describe()} does not follow it and {fate}",
        None, "", hint=f"numerical damping that removes it (hht-i3 with alpha -0.3, genalpha "
                       f"with rho_inf 0.5, nstiff), or h below {0.3 / mo.omega:.2g} s to "
                       "follow it (mbdsl modes shows every mode)")


def mode_motion(system, found: "Modes", index: int, cycles: float = 2.0,
                frames_per_cycle: int = 40, amplitude: float | None = None):
    """The motion q(t) = q + A x sin(omega t) of mode ``index`` (1-based) as a
    Solution, for ``mbdsl.animate`` (one second of video per period at speed 1
    is not asked: the time axis is the mode's own, t [s]).

    A: the largest displacement of a coordinate x or y, 5 % of the model's
    size (the spread of its coordinates) unless given [m]; each frame is
    taken back onto the constraints (Gauss-Newton on Phi, up to 300
    coordinates), which the linear shape leaves at second order. The
    Solution carries no dynamics: its rows are the mode's shape, not a run.

    Raises
    ------
    ValueError
        No such mode, or a mode of zero frequency.
    """
    from .io.rows import RunStats
    from .io.solution import Solution
    if not 1 <= index <= len(found.modes):
        raise ValueError(f"no mode {index}; modes 1 .. {len(found.modes)}")
    mo = found.modes[index - 1]
    if not mo.omega > 0.0:
        raise ValueError(f"mode {index} has no frequency (a free motion): nothing to animate")
    q0, x = np.asarray(found.q, dtype=float), mo.shape
    if amplitude is None:
        xy = [j for j, name in enumerate(found.names) if name.endswith((".x", ".y"))]
        size = float(np.ptp(q0[xy])) if xy else 1.0
        amplitude = 0.05 * (size if size > 0 else 1.0)
    trans = [j for j, name in enumerate(found.names) if not name.endswith(".phi")]
    peak = float(np.max(np.abs(x[trans]))) if trans else float(np.max(np.abs(x)))
    A = amplitude / (peak if peak > 0 else 1.0)
    period = 2.0 * np.pi / mo.omega
    t = np.linspace(0.0, cycles * period, int(cycles * frames_per_cycle) + 1)
    s = np.sin(mo.omega * t)[:, None]
    c = np.cos(mo.omega * t)[:, None]
    q = q0 + A * s * x
    if system.m and system.n <= 300:      # the joints closed again (the shape is linear)
        for row in q:
            for _ in range(8):
                r = system.Phi(row, found.t)
                if np.max(np.abs(r)) < 1e-12:
                    break
                row -= np.linalg.lstsq(system.Phi_q(row, found.t), r, rcond=None)[0]
    v = A * mo.omega * c * x
    a = -A * mo.omega ** 2 * s * x
    N, m = len(t), system.m
    stats = {k: np.zeros(N) for k in Solution.STAT_NAMES}
    stats["h"][1:] = np.diff(t)
    return Solution.from_arrays(
        system, method_name=f"mode {index}", method_parameters={}, extra_names=(),
        h=float(t[1] - t[0]), t_end=float(t[-1]), t=t, q=q, v=v, a=a, lam=np.zeros((N, m)),
        extras={}, stats=stats, stats_total=RunStats(), status="completed",
        message=f"mode {index} at {mo.frequency:.4g} Hz, linearized shape", warnings=())


def _state_at(system, at, solution, t):
    """(description, t, q, v, a, lambda) of the state the modes are taken about."""
    from .assembly.initial import consistent_initial_state, static_positions
    from .errors import AssemblyError
    model = system.model
    t0 = float(model.settings.get("t_start", 0.0))
    if solution is not None:
        if list(solution.system.layout.coordinates) != list(system.layout.coordinates):
            raise ValueError("the result's coordinates are not the model's")
        i = int(np.argmin(np.abs(solution.t - t)))
        tt, q, v = float(solution.t[i]), solution.q[i].copy(), solution.v[i].copy()
        a, lam = system.index1_state(tt, q, v)[:2]
        return f"result's (row {i})", tt, q, v, a, lam
    init = consistent_initial_state(system, t0)
    if at == "initial":
        return "initial", t0, init.q, init.v, init.a, init.lam
    if at == "static":
        try:
            q = static_positions(system, t0, init.q, init.lam, hold_initials=False)
        except AssemblyError as exc:
            d = exc.diagnostics[0]
            hint = ("Newton starts from the model's initial configuration: give 'initial' "
                    "lines near the equilibrium (a link hanging, not horizontal, where gravity "
                    "has no stiffness), or take the modes at the initial state")
            raise AssemblyError(d.message, [dataclasses.replace(d, hint=hint)]) from None
        v = np.zeros(system.n)
        a, lam = system.index1_state(t0, q, v)[:2]
        return "static", t0, q, v, a, lam
    raise ValueError(f"unknown state '{at}': initial, static, or a result and a time")


def _energy_share(Mx, x):
    e = np.real(np.conj(x) * Mx)
    total = float(np.sum(e))
    return e / total if total != 0.0 else np.zeros_like(e)


def _dense_modes(lin, k, highest):
    import scipy.linalg
    M, C, K, G = (lin.M.toarray(), lin.C.toarray(), lin.K.toarray(), lin.Phi_q.toarray())
    N = scipy.linalg.null_space(G) if G.shape[0] else np.eye(M.shape[0])
    r = N.shape[1]
    if r == 0:
        return 0, []
    Mr, Cr, Kr = N.T @ M @ N, N.T @ C @ N, N.T @ K @ N
    out = []
    symmetric = np.allclose(Kr, Kr.T, rtol=1e-9, atol=1e-12 * max(1.0, np.abs(Kr).max()))
    if not lin.damped and symmetric:
        w2, Z = scipy.linalg.eigh(0.5 * (Kr + Kr.T), Mr)
        for j in range(r):
            x = N @ Z[:, j]
            stable = w2[j] >= -1e-9 * max(1.0, abs(w2).max())
            omega = float(np.sqrt(abs(w2[j])))
            zeta = float("nan") if omega < 1e-9 * max(1.0, np.sqrt(abs(w2).max())) else 0.0
            out.append((omega, zeta, x, stable))
    else:
        Mi = np.linalg.inv(Mr)
        A = np.block([[np.zeros((r, r)), np.eye(r)], [-Mi @ Kr, -Mi @ Cr]])
        s, V = np.linalg.eig(A)
        scale = max(1.0, float(np.abs(s).max()))
        for j in range(2 * r):
            if s[j].imag < -1e-12 * scale:
                continue                  # one of each complex pair
            x = N @ V[:r, j]
            omega = float(abs(s[j]))
            stable = s[j].real <= 1e-9 * scale
            zeta = float("nan") if omega < 1e-9 * scale else float(-s[j].real / omega)
            out.append((omega, zeta, x, stable))
    out.sort(key=lambda o: o[0])
    if k is not None:
        out = out[-k:] if highest else out[:k]
    return r, [_mode(M, *o) for o in out]


def _mode(M, omega, zeta, x, stable):
    x = np.asarray(x)
    i = int(np.argmax(np.abs(x)))
    if abs(x[i]) > 0:
        x = x / x[i]
    share = _energy_share(M @ x, x)
    return Mode(omega, zeta, np.real(x), bool(stable), share)


def _springs_in(system, q, lin, x, share=0.1):
    """(spring, share of the mode's strain energy x^T K x / 2) of the spring-dampers
    (k dL^2 / 2, dL the change of length along x by central differences) and
    rotational spring-dampers (k dtheta^2 / 2, dtheta the joint angle's change)
    holding at least ``share`` of it, largest first."""
    from .model.elements import RotationalSpringDamper, SpringDamper
    total = 0.5 * float(x @ (lin.K @ x))
    if not total > 0.0:
        return []
    out = []
    springs = [f for f in system.model.forces if isinstance(f, SpringDamper)]
    if springs:
        eps = 1e-7 / max(float(np.max(np.abs(x))), 1e-300)
        dp = np.hypot(*system.spring_separations(q + eps * x).T)
        dm = np.hypot(*system.spring_separations(q - eps * x).T)
        dL = (dp - dm) / (2 * eps)
        out += [(f.name, 0.5 * f.k * dL[i] ** 2) for i, f in enumerate(springs)]
    cmap, n = system.cmap, system.n
    for f in system.model.forces:
        if isinstance(f, RotationalSpringDamper):
            c1, c2 = cmap.column(f.joint.first.body, 2), cmap.column(f.joint.second.body, 2)
            dth = (x[c2] if c2 < n else 0.0) - (x[c1] if c1 < n else 0.0)
            out.append((f.name, 0.5 * f.k * dth ** 2))
    out = [(name, e / total) for name, e in out if e >= share * total]
    return sorted(out, key=lambda p: -p[1])


def _sparse_modes(lin, k):
    import scipy.sparse
    import scipy.sparse.linalg as sla
    n, m = lin.M.shape[0], lin.Phi_q.shape[0]
    K = 0.5 * (lin.K + lin.K.T)
    A = scipy.sparse.bmat([[K, lin.Phi_q.T], [lin.Phi_q, None]], format="csc")
    B = scipy.sparse.bmat([[lin.M, None], [None, scipy.sparse.csr_matrix((m, m))]],
                          format="csc")
    diag = lin.M.diagonal()
    sigma = -1e-6 * float(np.max(np.abs(K.diagonal()) / np.where(diag > 0, diag, 1.0)))
    w2, X = sla.eigsh(A, k=k, M=B, sigma=sigma or -1e-6, which="LM")
    order = np.argsort(w2)
    out = []
    scale = max(1.0, float(np.sqrt(np.abs(w2).max())))
    for j in order:
        omega = float(np.sqrt(abs(w2[j])))
        zeta = float("nan") if omega < 1e-9 * scale else 0.0
        out.append(_mode(lin.M, omega, zeta, X[:n, j], w2[j] >= -1e-9 * scale * scale))
    return out


def _projector(Mlu, G):
    """x -> P x, P = I - M^-1 G^T (G M^-1 G^T)^-1 G (M by its sparse LU
    ``Mlu``, G = Phi_q sparse; the identity without constraints)."""
    import scipy.sparse
    import scipy.sparse.linalg as sla
    if not G.shape[0]:
        return lambda x: x
    # M^-1 G^T: as sparse as G for the block-diagonal M of bodies and beams
    MiGT = scipy.sparse.csc_matrix(Mlu.solve(G.T.toarray()))
    Slu = sla.splu(scipy.sparse.csc_matrix(G @ MiGT))
    return lambda x: x - MiGT @ Slu.solve(G @ x)


def _sparse_highest(lin, k):
    """The k highest modes of a large model: ARPACK (scipy's ``eigs``, largest
    magnitude) on S = P M^-1 K P, P = I - M^-1 G^T (G M^-1 G^T)^-1 G the
    M-orthogonal projector onto the constraints' null space (G = Phi_q):
    on range(P) its eigenvalues are the constrained omega^2, on the rest 0.
    One sparse LU of M and of G M^-1 G^T, then products only."""
    import scipy.sparse.linalg as sla
    n = lin.M.shape[0]
    Mlu = sla.splu(lin.M.tocsc())
    G = lin.Phi_q.tocsr()
    K = 0.5 * (lin.K + lin.K.T)
    project = _projector(Mlu, G)
    op = sla.LinearOperator((n, n), dtype=float,
                            matvec=lambda x: project(Mlu.solve(K @ project(x))))
    w2, X = sla.eigs(op, k=k, which="LM", v0=np.cos(np.arange(n) + 0.5))
    order = np.argsort(w2.real)
    out = []
    scale = max(1.0, float(np.sqrt(np.abs(w2.real).max())))
    for j in order:
        omega = float(np.sqrt(abs(w2[j].real)))
        out.append(_mode(lin.M, omega, 0.0, np.real(X[:, j]), w2[j].real >= -1e-9 * scale ** 2))
    return out


def modes(system, at: str = "initial", k: int | None = None, highest: bool = False,
          solution=None, t: float = 0.0, sparse: bool | None = None) -> Modes:
    """The modes of a model linearized about a state (module docstring).

    Parameters
    ----------
    system : AssembledSystem or Model
    at : {"initial", "static"}
        The consistent initial state, or the static equilibrium (``mbdsl
        static``); ignored when ``solution`` is given.
    k : int, optional
        How many modes: the k lowest (or highest); default every mode
        (dense) or 10 (sparse).
    highest : bool
        The k highest instead (sparse: ARPACK on the projected M^-1 K).
    solution : Solution, optional
        A result of this model: the modes about its recorded row nearest t.
    t : float
        The time [s] of that row.
    sparse : bool, optional
        Force the sparse (True) or dense (False) eigensolver; default:
        sparse above ``DENSE_LIMIT`` coordinates.

    Returns
    -------
    Modes

    Raises
    ------
    ValueError
        An unknown state, or a result of another model.
    MbdError
        The state cannot be found (E503 assembly, E507 no static equilibrium).
    """
    from .assembly.system import AssembledSystem, assemble
    if not isinstance(system, AssembledSystem):
        system = assemble(system)
    desc, tt, q, v, a, lam = _state_at(system, at, solution, t)
    lin = linearize(system, tt, q, v, a, lam)
    use_sparse = system.n > DENSE_LIMIT if sparse is None else sparse
    notes = []
    if use_sparse:
        kk = k or 10
        found = _sparse_highest(lin, kk) if highest else _sparse_modes(lin, kk)
        dof = system.n - system.m          # independent constraints (E401 refuses others)
        if lin.damped:
            notes.append("damping left out (sparse solver): the frequencies are undamped")
        solver = "sparse"
    else:
        dof, found = _dense_modes(lin, k, highest)
        solver = "dense"
    top = max((mo.omega for mo in found), default=0.0)
    for mo in found:             # (a free motion's strain energy is round-off)
        if mo.stable and mo.omega > 1e-6 * top:
            mo.stiffened_by = _springs_in(system, q, lin, mo.shape)
    if np.any(np.abs(v) > 0) and solution is None and at == "initial":
        notes.append("a moving state: the modes of the frozen configuration")
    return Modes(system.model.name, desc, tt, q, list(system.layout.coordinates), dof, found,
                 solver, notes)
