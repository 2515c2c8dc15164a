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
    """The pendulum against its stops, 1 s (two impacts): HHT-I3 and NSTIFF
    at 1 .. 0.25 ms are within 1e-2 rad of the reference (it was 0.70 rad at
    every step: the smooth DOP853 reference went through the stop)."""
    options = StudyOptions(methods=["hht-i3", "nstiff"], hs=[1e-3, 5e-4, 2.5e-4], t_end=1.0,
                           jobs=1)
    result = run_study("convergence", ROOT / "models" / "pendulum_stop.mbd", options,
                       log=lambda text: None)
    assert result.reference.trusted and "landing on" in result.reference.description
    table, errors = _errors(result)
    assert np.all(errors < 1e-2)


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
