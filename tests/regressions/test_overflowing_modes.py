"""Models whose numbers overflow end in the run's own diagnosis, not in
numpy's LinAlgError: found by the mutation fuzzer. ``c = 1e308`` in the
slider crank's spring-damper broke the pre-run check of the step against
the model's modes (W606: the modes' amplification matrices); a rod of mass
``1e-308`` kg under error control broke the compiled loop's index-1
acceleration (its least-squares solve on a non-finite matrix)."""

from pathlib import Path

import pytest

import mbdsl

ROOT = Path(__file__).resolve().parents[2]


def test_a_damper_of_1e308_ends_in_a_coded_stop_not_a_traceback():
    text = (ROOT / "models" / "slider_crank.mbd").read_text().replace(
        "parameter c = 5", "parameter c = 1e308")
    model = mbdsl.load_text(text)
    sol = mbdsl.simulate(model, h=1e-3, t_end=3e-3, on_failure="return")
    assert sol.status == "failed"
    assert sol.diagnostics[0].code == "E601"
    assert "singular Newton matrix" in sol.message


@pytest.mark.parametrize("engine", ["compiled", "numpy", "uncompiled"])
def test_a_mass_of_1e_308_under_error_control_ends_in_a_coded_stop(engine):
    text = (ROOT / "models" / "pendulum_stop.mbd").read_text().replace(
        "parameter m = 1.0 ", "parameter m = 1e-308 ")
    model = mbdsl.load_text(text)
    assert model.settings["tol"] == 1e-6
    sol = mbdsl.simulate(model, h=1e-3, t_end=3e-3, on_failure="return", engine=engine)
    assert sol.status == "failed"
    assert sol.diagnostics[0].code.startswith("E6")
