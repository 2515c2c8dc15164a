"""Reference solutions for studies, with an estimate of their own error.

Three kinds, chosen by ``--reference``:

events (what ``auto`` takes for a model with contacts, limits or springs
    that pass through zero length, whose motion is not smooth)
    HHT-SI2 with error control at rtol = atol = 1e-10, landing on every event
    and restarting past it, its error estimated against the same run at
    1e-9, and cross-checked by NSTIFF-SI2 at 1e-10; where the cross-check
    fails the reference is marked not trusted and a study fits no order
    from it. ``dop853`` is refused for such models: it does not follow events.
``dop853`` (what ``auto`` tries first for a smooth model)
    The index-1 form integrated by scipy's DOP853 (order 8) at rtol = atol =
    1e-12 (:func:`mbdsl.studies.index1.index1_reference`). It shares only the
    assembly (M, Q, Phi_q, gamma) with the methods, none of their
    formulas. Its error is estimated by a second integration at rtol = atol =
    1e-11: the difference is about the error of the looser run, so it bounds
    the tighter one's from above (by roughly a factor 10).
``METHOD`` (``auto`` falls back to ``hht-si2`` when DOP853 exceeds its
    evaluation budget, i.e. on stiff models)
    The named method at a step 16 times smaller than the smallest step of the
    study, and again at 8 times smaller; Richardson's estimate
    ``|x(h/16) - x(h/8)| / (2^p - 1)`` (p the method's order) is its error.
``FILE``
    A result of ``mbdsl simulate`` (CSV or HDF5). The model is rebuilt from the
    source stored in the file and run again with the same method at twice the
    file's step, for the same Richardson estimate.

Every reference gives the state at T (errors at T) and a continuous state on
[t0, T] (energies along a run): DOP853's order-7 continuous extension, or
cubic Hermite interpolation of (q, v) and (v, a) over the reference's steps
(scipy's CubicHermiteSpline), exact at the reference's own step times.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .runs import hermite_state, total_energy

__all__ = ["StudyReference", "build_reference", "method_order"]

#: rhs evaluations DOP853 may spend before ``auto`` gives up on it
#: (a 2 s slider-crank run at rtol 1e-12 needs about 2300)
DOP853_BUDGET = 200_000


def method_order(method: str, coefficients: dict, system=None) -> int:
    """Global order of a method with these coefficients on the model of
    ``system`` (``Method.order``: 1 for NEWMARK with gamma != 1/2 and for
    HHT-ADD with friction, else 2;
    None: a rigid model without friction). Derived coefficients stored with
    a result (HHT's beta and gamma) are ignored."""
    from ..integrators import make_method, method_parameters
    accepted = method_parameters(method)
    return make_method(method, **{k: v for k, v in coefficients.items()
                                  if k in accepted}).order(system)


@dataclass
class StudyReference:
    """A reference solution on [t0, T].

    Attributes
    ----------
    description : str
        How it was computed (for tables and the index page).
    t_end : float [s]
    q_end, v_end : ndarray, shape (n,)
        Generalized coordinates and velocities at T.
    error_q, error_v : ndarray, shape (n,)
        Estimated absolute error of q_end, v_end (same units).
    state : callable
        ``state(t)`` with t of shape (N,) -> (q, v), each of shape (N, n).
    lam_names : tuple of str
        The multiplier columns (``lambda.<joint>.<k>``), once
        :meth:`add_multipliers` has run.
    lam_end, error_lam : ndarray, shape (m,), or None
        The multipliers at T and their estimated error.
    """

    description: str
    t_end: float
    q_end: np.ndarray
    v_end: np.ndarray
    error_q: np.ndarray
    error_v: np.ndarray
    state: object
    lam_names: tuple = ()
    lam_end: np.ndarray | None = None
    error_lam: np.ndarray | None = None
    #: False when the reference's own cross-check failed: a study then shows
    #: the errors but fits no order from them, and says why (``warning``)
    trusted: bool = True
    warning: str = ""

    def add_multipliers(self, system) -> None:
        """lambda at T from the index-1 system at (q_end, v_end) (the
        Lagrange multipliers of the reference's state), with an error
        estimate: the change of those multipliers when q and v move by their
        estimated errors."""
        lay = system.layout
        self.lam_names = tuple(f"lambda.{name}.{k}" for name, k in lay.rows)
        lam = system.index1_multipliers([self.t_end], self.q_end, self.v_end)[0]
        moved = system.index1_multipliers([self.t_end], self.q_end + self.error_q,
                                          self.v_end + self.error_v)[0]
        self.lam_end, self.error_lam = lam, np.abs(moved - lam)

    def energy(self, system, t: np.ndarray) -> np.ndarray:
        """Total energy T + V [J] of the reference at times t, shape (N,)."""
        return total_energy(system, *self.state(np.asarray(t, dtype=float)))


def build_reference(kind: str, model, t_end: float, h_min: float,
                    log=lambda text: None) -> StudyReference:
    """Compute the reference a study compares against.

    Parameters
    ----------
    kind : str
        ``"auto"``, ``"dop853"``, a method name, or a result file path.
    model : Model
    t_end : float [s]
    h_min : float [s]
        Smallest step of the study (method references use h_min/16).
    log : callable
        Receives one-line progress messages.

    Returns
    -------
    StudyReference

    Raises
    ------
    ValueError
        A file reference of another model, or one that does not reach T.
    RuntimeError
        DOP853 failed (``kind="dop853"``).
    ConvergenceError
        A method reference could not complete.
    """
    from .. import METHODS, assemble
    system = assemble(model)
    if kind in ("auto", "dop853") and _has_events(system) and system.contact_state is None:
        # springs with a free length only: their event is their points passing
        # each other, which most runs never come near
        from .index1 import EvaluationBudgetExceeded
        try:
            ref = _dop853(model, t_end, DOP853_BUDGET if kind == "auto" else None)
        except (EvaluationBudgetExceeded, RuntimeError):
            ref = None
        if ref is not None and _springs_stay_apart(system, ref, t_end):
            log("reference: the springs' points stay apart (no event): DOP853")
            return ref
    if kind in ("auto", "dop853") and _has_events(system):
        if kind == "dop853":
            raise ValueError("the DOP853 reference integrates the smooth index-1 equations and "
                             "does not follow the model's contacts, limits or springs through "
                             "zero length; use --reference auto (error-controlled runs that "
                             "land on every event, cross-checked) or a method")
        log("reference: the model has non-smooth events: error-controlled runs that land on "
            "them, cross-checked by a second method")
        return _events_reference(model, t_end)
    if kind in ("auto", "dop853"):
        from .index1 import EvaluationBudgetExceeded
        try:
            return _dop853(model, t_end, DOP853_BUDGET if kind == "auto" else None)
        except (EvaluationBudgetExceeded, RuntimeError) as exc:
            if kind == "dop853":
                raise
            log(f"reference: DOP853 gave up ({exc}); using hht-si2 at h/16")
            return _method(model, "hht-si2", {}, t_end, h_min / 16)
    if kind in METHODS:
        return _method(model, kind, {}, t_end, h_min / 16)
    return _file(kind, model, t_end)


def _dop853(model, t_end, budget):
    """DOP853 at 1e-12, error estimated against 1e-11."""
    from .. import assemble
    from ..assembly.initial import consistent_initial_state
    from .index1 import index1_reference
    system = assemble(model)
    init = consistent_initial_state(system, float(model.settings.get("t_start", 0.0)))
    fine = index1_reference(system, [t_end], 1e-12, 1e-12, init, dense_output=True,
                            max_evaluations=budget)
    coarse = index1_reference(system, [t_end], 1e-11, 1e-11, init, max_evaluations=budget)
    n = system.n

    def state(t):
        """(q, v) from DOP853's continuous extension, each (N, n)."""
        y = np.asarray(fine.interpolant(np.asarray(t, dtype=float)))
        return y[:n].T, y[n:].T

    return StudyReference(
        f"index-1 DOP853 (scipy), rtol = atol = 1e-12, {fine.nfev} evaluations; error "
        f"estimated against rtol = 1e-11; constraint drift at T {fine.drift:.1e}",
        t_end, fine.q[-1], fine.v[-1], np.abs(fine.q[-1] - coarse.q[-1]),
        np.abs(fine.v[-1] - coarse.v[-1]), state)


#: The tolerance of the event models' reference runs, and the looser one of
#: its error estimate.
EVENTS_RTOL, EVENTS_RTOL_COARSE = 1e-10, 1e-9
#: The cross-check passes when the two methods agree within this multiple of
#: the estimated error (plus round-off).
CROSS_CHECK_MARGIN = 10.0


def _has_events(system) -> bool:
    """Whether the model's motion has non-smooth events (contacts, limits,
    springs whose points pass each other), which a smooth integrator without
    event location does not follow."""
    return (getattr(system, "contact_state", None) is not None
            or getattr(system, "flipping_springs", None) is not None)


#: Samples of the DOP853 trajectory over which the springs' lengths are read,
#: and the least length, as a fraction of its free length, a spring may come
#: down to for the motion to count as free of its event (points passing).
SPRING_SAMPLES, SPRING_MARGIN = 20001, 0.05


def _springs_stay_apart(system, ref, t_end) -> bool:
    """Whether every spring-damper with a free length keeps its points at
    least SPRING_MARGIN of that length apart over the reference's trajectory
    (sampled at SPRING_SAMPLES times): no spring passes through zero length,
    the only event of a model without contacts and limits."""
    springs = system.flipping_springs
    lengths = {f.name: getattr(f, "length", 0.0) for f in system.model.forces}
    free = np.array([lengths[name] for _, name in springs])
    index = [i for i, _ in springs]
    t_start = float(system.model.settings.get("t_start", 0.0))
    q, _ = ref.state(np.linspace(t_start, t_end, SPRING_SAMPLES))
    for row in q:
        d = system.spring_separations(row)[index]
        if np.any(np.hypot(d[:, 0], d[:, 1]) < SPRING_MARGIN * free):
            return False
    return True


def _events_reference(model, t_end):
    """The reference of a model with contacts, limits or flipping springs:
    HHT-SI2 with error control at rtol = atol = EVENTS_RTOL, landing on every
    event (``integrators.events``) and restarting past it; its error
    estimated against the same run at EVENTS_RTOL_COARSE (the difference
    bounds the looser run's error); cross-checked by NSTIFF-SI2 at
    EVENTS_RTOL, a method with other formulas and other step sizes. Where the
    two differ by more than CROSS_CHECK_MARGIN times the estimate, or either
    run fails, the reference is not trusted (``StudyReference.trusted``):
    events the steps land on differently (a grazing contact, a rattling
    clearance) make the motion itself sensitive."""
    from .. import simulate
    h0 = 1e-3 * max(t_end, 1e-9)
    runs, why = {}, []
    for name, method, rtol in (("fine", "hht-si2", EVENTS_RTOL),
                               ("coarse", "hht-si2", EVENTS_RTOL_COARSE),
                               ("check", "nstiff-si2", EVENTS_RTOL)):
        runs[name] = simulate(model, method=method, h=h0, t_end=t_end, rtol=rtol, atol=rtol,
                              on_failure="return")
        if not runs[name].completed:
            why.append(f"{method} at rtol {rtol:g} stopped at t = {runs[name].t[-1]:.6g} s")
    fine, coarse, check = runs["fine"], runs["coarse"], runs["check"]
    error_q = np.abs(fine.q[-1] - coarse.q[-1])
    error_v = np.abs(fine.v[-1] - coarse.v[-1])
    tiny = 1e-12 * (1.0 + np.abs(fine.q[-1])), 1e-12 * (1.0 + np.abs(fine.v[-1]))
    dq, dv = np.abs(fine.q[-1] - check.q[-1]), np.abs(fine.v[-1] - check.v[-1])
    if not why and (np.any(dq > CROSS_CHECK_MARGIN * error_q + tiny[0])
                    or np.any(dv > CROSS_CHECK_MARGIN * error_v + tiny[1])):
        why.append(f"hht-si2 and nstiff-si2 at rtol {EVENTS_RTOL:g} differ by "
                   f"{float(np.max(dq)):.3g} in positions and {float(np.max(dv)):.3g} in "
                   f"velocities at T, more than {CROSS_CHECK_MARGIN:g} times the estimated "
                   f"error {float(np.max(error_q)):.3g} / {float(np.max(error_v)):.3g}")
    events = len(fine.events)
    description = (f"hht-si2 with error control, rtol = atol = {EVENTS_RTOL:g}, landing on "
                   f"{events} event{'s' if events != 1 else ''}; error estimated against rtol = "
                   f"{EVENTS_RTOL_COARSE:g}; cross-checked by nstiff-si2 at {EVENTS_RTOL:g}"
                   + (" (failed: not trusted)" if why else " (agrees)"))
    return StudyReference(description, t_end, fine.q[-1], fine.v[-1], error_q, error_v,
                          hermite_state(fine), trusted=not why,
                          warning="; ".join(why))


def _method(model, method, coefficients, t_end, h):
    """A method at h, error by Richardson against 2h."""
    from .. import simulate
    fine = simulate(model, method=method, h=h, t_end=t_end, fixed=True, **coefficients)
    coarse = simulate(model, method=method, h=2 * h, t_end=t_end, fixed=True, **coefficients)
    p = method_order(method, fine.method_parameters, fine.system)
    return StudyReference(
        f"{method} at h = {h:.4g} s (16 times below the smallest step), error by Richardson "
        f"against h = {2 * h:.4g} s (order {p})", t_end, fine.q[-1], fine.v[-1],
        np.abs(fine.q[-1] - coarse.q[-1]) / (2**p - 1),
        np.abs(fine.v[-1] - coarse.v[-1]) / (2**p - 1), hermite_state(fine))


def _file(path, model, t_end):
    """A stored result, its error by a rerun at twice its step."""
    from .. import simulate
    from ..io import load_solution
    sol = load_solution(path)
    if sol.system.layout.coordinates != model.coordinate_names():
        raise ValueError(f"reference {path} is a result of model '{sol.model.name}' with "
                         f"coordinates {', '.join(sol.system.layout.coordinates)}; the study's "
                         f"model has {', '.join(model.coordinate_names())}")
    hit = np.flatnonzero(np.abs(sol.t - t_end) <= 1e-9 * max(1.0, abs(t_end)))
    if hit.size == 0:
        raise ValueError(f"reference {path} has no step at T = {t_end:g} s "
                         f"(it covers {sol.t[0]:g} .. {sol.t[-1]:g} s)")
    i = int(hit[0])
    from ..integrators import method_parameters
    accepted = method_parameters(sol.method_name)     # HHT stores its derived beta, gamma too
    coarse = simulate(sol.model, method=sol.method_name, h=2 * sol.h, t_end=t_end,
                      **{k: v for k, v in sol.method_parameters.items() if k in accepted})
    p = method_order(sol.method_name, sol.method_parameters, sol.system)
    return StudyReference(
        f"file {path}: {sol.method_name} at h = {sol.h:.4g} s, error by Richardson against "
        f"h = {2 * sol.h:.4g} s (order {p})", t_end, sol.q[i], sol.v[i],
        np.abs(sol.q[i] - coarse.q[-1]) / (2**p - 1),
        np.abs(sol.v[i] - coarse.v[-1]) / (2**p - 1), hermite_state(sol))
