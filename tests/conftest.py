"""Shared fixtures: paths of the shipped models and the reference data."""

import contextlib
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
# The mbdsl processes the tests start (``python -c``, ``python -m mbdsl`` in the
# checkout) import the copy the tests import: pytest's importlib mode (pyproject)
# imports mbdsl as installed, and without this a child started in the checkout would
# put it first on sys.path, import its copy and compile that copy's kernels again.
os.environ["PYTHONSAFEPATH"] = "1"


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


@contextlib.contextmanager
def dask_processes(folder, workers: int = 2):
    """A Dask cluster of separate processes on 127.0.0.1 (`dask scheduler`
    and ``workers`` `dask worker`s, one thread each, as on machines of their
    own): yields the scheduler's address once it is up; stops them all."""
    import json
    import subprocess
    import sys
    import time
    sfile = Path(folder) / "scheduler.json"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    procs = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file", str(sfile)],
                              **quiet)]
    try:
        deadline = time.monotonic() + 120
        while not sfile.exists() and time.monotonic() < deadline:    # readiness, not a race
            time.sleep(0.2)
        address = json.loads(sfile.read_text())["address"]
        for _ in range(workers):
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "dask", "worker", "--scheduler-file", str(sfile),
                 "--nworkers", "1", "--nthreads", "1", "--no-dashboard"], **quiet))
        yield address
    finally:
        for p in procs[::-1]:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
