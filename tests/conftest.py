"""Shared fixtures: paths of the shipped models and the reference data."""

import json
import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"
REFERENCE = Path(__file__).resolve().parent / "reference"

# The command line builds missing compiled kernels in a detached background
# process and runs that model on the numpy engine. Tests (and the mbdsl
# processes they start, which inherit this) compile in the process instead,
# so that which engine runs never depends on how far a background build got.
os.environ["MBDSL_BACKGROUND_COMPILE"] = "0"


@pytest.fixture(scope="session")
def slider_crank_reference():
    """Independent reference solutions of the rigid slider crank (provenance in the file)."""
    return json.loads((REFERENCE / "slider_crank.json").read_text())


@pytest.fixture
def handed_over(monkeypatch):
    """The times [s] at which the time loop handed a step the compiled loop
    could not take to its fallback, the Python stepper
    (``loop.TimeLoop._fall_back``), in a list that fills as runs go."""
    from mbdsl.integrators.loop import TimeLoop
    times = []
    fall_back = TimeLoop._fall_back

    def counted(self):
        took = fall_back(self)
        if took:
            times.append(self.t)
        return took
    monkeypatch.setattr(TimeLoop, "_fall_back", counted)
    return times


def interrupted_run(system, t_end, at, **options):
    """(the uninterrupted run, the run interrupted): HHT-I3 at h = 1e-3 s from
    0 to t_end [s] with ``options`` (``integrate``'s), and the same run whose
    progress callback raises KeyboardInterrupt (Ctrl-C) once t >= at [s]."""
    from mbdsl.integrators import integrate, make_method
    full = integrate(system, make_method("hht-i3"), t_end, 1e-3, **options)

    def progress(t, h, iterations):
        if t >= at:
            raise KeyboardInterrupt

    cut = integrate(system, make_method("hht-i3"), t_end, 1e-3, progress=progress,
                    on_failure="return", **options)
    return full, cut
