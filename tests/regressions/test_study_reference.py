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
    """The pendulum against its stops, 1 s (two impacts), fixed steps of 1 ..
    0.25 ms (the model's own tolerance does not apply to a sweep over h):
    HHT-I3's and NSTIFF's errors fall at order 2 +- 0.3 against the events
    reference, 0.06 .. 0.0045 rad (against the smooth DOP853 reference, which
    went through the stop, they were 0.70 rad at every step)."""
    options = StudyOptions(methods=["hht-i3", "nstiff"], hs=[1e-3, 5e-4, 2.5e-4], t_end=1.0,
                           jobs=1)
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
