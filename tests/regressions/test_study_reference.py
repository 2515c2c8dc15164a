"""Studies on models with contacts and limits: a reference that lands on the
same events, and a study that says when its reference cannot be trusted."""

from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.studies import StudyOptions, run_study
from mbdsl.studies import reference as reference_module

ROOT = Path(__file__).resolve().parents[2]


def _errors(result):
    table = next(t for s in result.sections for t in s.tables if t.name == "convergence")
    return table, np.array([[row[2], row[3]] for row in table.rows], dtype=float)


def test_the_pendulum_stop_reference_follows_the_impacts(tmp_path):
    """The pendulum against its stops, 1 s (two impacts), fixed steps of 0.25
    .. 0.0625 ms (the model's own tolerance does not apply to a sweep over h):
    HHT-I3's and NSTIFF's errors fall at order 2 +- 0.3 against the events
    reference, 4.5e-3 .. 2.4e-4 rad (against the smooth DOP853 reference,
    which went through the stop, they were 0.70 rad at every step). The
    stop's contact lasts about 5.7 ms; at h = 1 .. 0.5 ms, a few steps in
    contact, NSTIFF's error is not yet in its asymptotic range (2.5e-4 rad at
    1 ms, 1.1e-2 at 0.5 ms)."""
    options = StudyOptions(methods=["hht-i3", "nstiff"], hs=[2.5e-4, 1.25e-4, 6.25e-5],
                           t_end=1.0, jobs=1)
    result = run_study("convergence", ROOT / "models" / "pendulum_stop.mbd", options,
                       log=lambda text: None)
    assert result.reference.trusted and "landing on" in result.reference.description
    table, errors = _errors(result)
    assert np.all(errors < 0.2)
    for k in (0, 3):                                   # each method's three step sizes
        assert np.all(np.diff(errors[k:k + 3, 0]) < 0)
    orders = next(t for s in result.sections for t in s.tables if t.name == "convergence_orders")
    for row in orders.rows:
        assert row[2] == pytest.approx(2.0, abs=0.3) and row[-1] == 3


def test_a_sweep_over_h_runs_fixed_steps_whatever_the_models_tolerance():
    """pendulum_stop's simulate section sets tol 1e-6; a study's runs at h
    are steps of h (their step sizes all equal h)."""
    options = StudyOptions(methods=["hht-i3"], hs=[1e-3], t_end=0.2, jobs=1)
    result = run_study("convergence", ROOT / "models" / "pendulum_stop.mbd", options,
                       log=lambda text: None)
    run = next(iter(result.runs.values()))
    assert run.completed and run.stats.get("steps") >= 0.2 / 1e-3 - 1


def test_dop853_is_refused_for_a_model_with_events():
    with pytest.raises(ValueError, match="does not follow"):
        reference_module.build_reference("dop853", mbdsl.load(ROOT / "models" /
                                                              "pendulum_stop.mbd"), 1.0, 1e-3)


def test_a_reference_that_fails_its_cross_check_fits_no_order(monkeypatch):
    """With the cross-check's margin at 0 the two reference methods never
    agree: the study says the reference cannot be trusted, shows the errors
    and fits no order."""
    monkeypatch.setattr(reference_module, "CROSS_CHECK_MARGIN", 0.0)
    options = StudyOptions(methods=["hht-i3"], hs=[1e-3, 5e-4], t_end=0.3, jobs=1)
    logged = []
    result = run_study("convergence", ROOT / "models" / "pendulum_stop.mbd", options,
                       log=logged.append)
    assert not result.reference.trusted
    assert any("cannot be trusted" in line for line in logged)
    table, errors = _errors(result)
    assert "cannot be trusted" in table.notes[0]
    orders = next(t for s in result.sections for t in s.tables if t.name == "convergence_orders")
    assert all(row[-1] == 0 for row in orders.rows)          # no point fitted


def test_fixed_steps_and_a_tolerance_exclude_each_other():
    model = mbdsl.load(ROOT / "models" / "pendulum_stop.mbd")
    with pytest.raises(ValueError, match="exclude each other"):
        mbdsl.simulate(model, t_end=0.01, fixed=True, rtol=1e-6)
    sol = mbdsl.simulate(model, h=1e-3, t_end=0.01, fixed=True)
    assert sol.control is None and np.allclose(sol.stats["h"][1:], 1e-3)


def _pendulum_stop_by_scipy(T=1.0, m=1.0, L=1.0, g=9.81, k=1e5, e=0.5):
    """phi(T) of models/pendulum_stop.mbd computed here, independently of
    mbdsl: the rod's one equation I_O phi'' = -m g L/2 cos(phi) + tau_stop,
    the stop's law of docs/contact.md (k delta (1 + chi ddelta/v_impact),
    cut at zero; chi from chi (1 + e) = ln((1 + chi)/(1 - chi e))), DOP853 at
    rtol = atol = 1e-12 from event to event (scipy's own root finding)."""
    import scipy.integrate as si
    import scipy.optimize as so
    inertia = m * L * L / 3
    lo, up = -np.pi / 2 - np.pi / 4, -np.pi / 2 + np.pi / 4
    chi = so.brentq(lambda c: c * (1 + e) - np.log((1 + c) / (1 - c * e)), 0.5, 1 / e - 1e-6)

    def rhs(t, y, side, v_impact):
        phi, w = y
        tau = -m * g * L / 2 * np.cos(phi)
        if side:                                      # +1 upper stop, -1 lower
            d, dd = side * (phi - (up if side > 0 else lo)), side * w
            tau -= side * max(0.0, k * d * (1 + chi * dd / v_impact))
        return [w, tau / inertia]

    def crossing(bound, direction):
        def event(t, y, *args):
            return y[0] - bound
        event.terminal, event.direction = True, direction
        return event

    t, y, side, v_impact = 0.0, np.array([-np.pi / 2, 5.0]), 0, 1.0
    while t < T:
        events = ([crossing(up, 1), crossing(lo, -1)] if side == 0
                  else [crossing(up if side > 0 else lo, -side)])
        r = si.solve_ivp(rhs, (t, T), y, method="DOP853", rtol=1e-12, atol=1e-12,
                         events=events, args=(side, v_impact))
        t, y = r.t[-1], r.y[:, -1]
        if r.status == 1:
            if side == 0:
                side, v_impact = (1 if len(r.t_events[0]) else -1), max(abs(y[1]), 1e-3)
            else:
                side = 0
    return y[0]


def test_the_pendulum_stop_errors_are_those_against_an_independent_reference():
    """The study's errors (0.062, 0.018, 0.0045 rad for HHT-I3 at 1, 0.5,
    0.25 ms) are the model's: against phi(1 s) = -1.66074 rad computed by
    scipy from the equation of the rod and the stop's law, HHT-I3 at fixed
    steps is off by the same amounts. The stop (k = 1e5 N m/rad on I_O = 1/3
    kg m^2) is in contact for pi sqrt(I_O/k) = 5.7 ms, six steps of 1 ms:
    an error below 1e-2 rad needs h <= 0.4 ms with a second-order method."""
    ref = _pendulum_stop_by_scipy()
    assert ref == pytest.approx(-1.6607, abs=1e-4)
    model = mbdsl.load(ROOT / "models" / "pendulum_stop.mbd")
    errors = []
    for h in (1e-3, 5e-4, 2.5e-4):
        sol = mbdsl.simulate(model, "hht-i3", h, 1.0, fixed=True)
        errors.append(abs(sol.column("rod.phi")[-1] - ref))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.3), orders       # 1.79, 1.99 measured
    assert errors[2] < 5e-3 and errors[0] > 1e-2


SPRING_DROP = """model spring_drop
gravity (0, -9.81)
particle ball { mass 1 }
ground { point anchor (0, 0.6) }
force sp: spring_damper(ground.anchor, ball.cm, k = 20, c = 0, length = 0.3)
initial ball.x = X0
initial ball.y = 1
"""


@pytest.mark.parametrize("x0, events", [(0.0, True), (0.5, False)])
def test_a_spring_that_never_passes_its_points_keeps_the_dop853_reference(x0, events):
    """A spring-damper with a free length flips its force where its points
    pass each other: the ball dropped straight through the anchor (x0 = 0)
    passes it, and the reference lands on that event; dropped 0.5 m beside it
    the spring's length stays above 0.5 m, its motion is smooth, and the
    reference is DOP853: on Andrews' mechanism, whose spring never comes near
    zero length, 2.8 s against more than 3 minutes and 5 GB for the events
    reference (measured). Where both apply they agree at T (to 1e-7, the
    events reference's tolerance)."""
    model = mbdsl.load_text(SPRING_DROP.replace("X0", str(x0)))
    said = []
    ref = reference_module.build_reference("auto", model, 0.6, 1e-3, said.append)
    assert ref.trusted
    assert ("landing on" in ref.description) == events
    assert ("DOP853" in ref.description) == (not events)
    if not events:
        check = reference_module._events_reference(model, 0.6)
        assert np.max(np.abs(check.q_end - ref.q_end)) < 1e-7
    else:
        assert any("non-smooth events" in s for s in said)
