"""The uncompiled engine: the compiled engine's kernels and loops run by the interpreter.

``engine="uncompiled"`` executes the sources of ``mbdsl/kernels`` and ``integrators/compiled`` a
second time with numba's JIT disabled (``kernel_cache.uncompiled_kernels``),
so that a kernel can be debugged with pdb or print. These tests check that
it is the same implementation and needs nothing compiled: its runs reach the
independent DOP853 reference of the slider crank with the method's order,
and agree with the compiled engine's to round-off on every method (where
Python's semantics and numba's differ, say integer wrap-around, a typed
container or a float32 temporary, they part by far more), with contacts,
error control and a flexible beam; a process that runs it never imports the
compiled module.
"""

import re
import subprocess
import sys

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators import NewtonOptions, integrate, make_method
from mbdsl.integrators.adaptive import StepControl
from mbdsl.integrators.kernel_cache import UNCOMPILED_MODULE, UNCOMPILED_ROOT, uncompiled_kernels

from ..conftest import MODELS

METHODS = ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
           "genalpha-si2"]


def _pair(path, method, T, h=1e-3, **kwargs):
    system = mbdsl.assemble(mbdsl.load(path))
    init = mbdsl.consistent_initial_state(system)
    return [integrate(system, make_method(method), T, h, initial=init, engine=engine, **kwargs)
            for engine in ("uncompiled", "compiled")]


def test_the_uncompiled_kernels_are_python_functions():
    K = uncompiled_kernels()
    assert K.__name__ == UNCOMPILED_MODULE and uncompiled_kernels() is K
    for name in ("forces", "phi", "_run", "run", "residual"):
        assert type(getattr(K, name)).__name__ == "function", name
    # the copy's modules call the copy: the Newton loop and an element kernel
    copy = sys.modules[UNCOMPILED_ROOT + ".integrators.compiled.newton"]
    assert type(copy._newton).__name__ == "function"
    system = sys.modules[UNCOMPILED_ROOT + ".kernels.system"]
    assert system._emit_force.__module__ == UNCOMPILED_ROOT + ".kernels.system"
    springs = sys.modules[UNCOMPILED_ROOT + ".kernels.loads.spring_damper"]
    assert system.spring_damper is springs and type(springs._spring).__name__ == "function"


def test_second_order_to_the_independent_reference(slider_crank_reference):
    """HHT-I3 uncompiled against the 1-DOF Lagrange reference (DOP853 1e-13)
    at t = 0.5 s: errors of h = 2 ms and 1 ms in the ratio of a second-order
    method, both small."""
    ref = next(r for r in slider_crank_reference["cases"]["damped_x0_zero"]["table"]
               if abs(r["t"] - 0.5) < 1e-12)
    model = mbdsl.load(MODELS / "slider_crank.mbd")
    errors = []
    for h in (2e-3, 1e-3):
        sol = mbdsl.simulate(model, method="hht-i3", h=h, t_end=0.5, engine="uncompiled")
        assert sol.engine == "uncompiled" and sol.status == "completed"
        errors.append(abs(sol.column("crank.phi")[-1] - ref["theta1"]))
    assert errors[1] < 1e-3
    assert 3.4 < errors[0] / errors[1] < 4.6, errors


@pytest.mark.parametrize("method", METHODS)
def test_every_method_runs_as_compiled(method):
    a, b = _pair(MODELS / "slider_crank.mbd", method, 0.1)
    assert a.engine == "uncompiled" and b.engine == "compiled"
    assert a.status == b.status == "completed"
    assert np.array_equal(a.t, b.t)
    # the dense solve of the uncompiled copy is numpy's matrix product, summed in
    # another order than the compiled loop's: round-off (measured 2e-15)
    assert np.abs(a.q - b.q).max() < 1e-11
    assert np.abs(a.lam - b.lam).max() < 1e-8 * np.abs(b.lam).max()


def test_events_and_error_control_as_compiled():
    """The bouncing ball: impacts located by the same EventLocator on the
    uncompiled kernels' steps, with error-controlled steps."""
    control = StepControl(rtol=1e-4, atol=1e-6)
    a, b = _pair(MODELS / "bouncing_ball.mbd", "hht-i3", 0.5, h=1e-3, control=control,
                 newton=NewtonOptions(rate_refresh=0.1))
    assert a.engine == "uncompiled" and a.status == b.status == "completed"
    assert [e[1:3] for e in a.events] == [e[1:3] for e in b.events] and len(a.events) >= 2
    assert np.allclose([e[0] for e in a.events], [e[0] for e in b.events], rtol=0, atol=1e-9)
    assert len(a.t) == len(b.t) and np.abs(a.q[-1] - b.q[-1]).max() < 1e-8


def test_a_flexible_beam_as_compiled():
    a, b = _pair(MODELS / "flexible_slider_crank.mbd", "hht-si2", 0.01, h=5e-4)
    assert a.engine == "uncompiled" and a.status == b.status == "completed"
    assert np.abs(a.q - b.q).max() < 1e-11


def test_band_solver_is_refused_with_a_reason():
    system = mbdsl.assemble(mbdsl.load(MODELS / "slider_crank.mbd"))
    with pytest.raises(ValueError, match="uncompiled engine takes 'dense' or 'sparse'"):
        integrate(system, make_method("hht-i3"), 0.01, 1e-3, engine="uncompiled",
                  newton=NewtonOptions(linear_solver="banded"))


def test_a_large_model_takes_superlu_uncompiled():
    """A pendulum chain above the dense limit: the condensed solver it takes
    compiled factors by LAPACK's band LU where S is not definite, out of the
    interpreter's reach; SuperLU instead."""
    model = mbdsl.load(MODELS / "pendulum_chain.mbd", overrides={"N": 100})
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=0.005, engine="uncompiled")
    ref = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=0.005, engine="compiled")
    assert sol.linear_solver == "sparse" and ref.linear_solver == "condensed"
    assert np.abs(sol.q - ref.q).max() < 1e-11


def test_an_uncompiled_run_imports_nothing_compiled(tmp_path):
    """The whole command on the uncompiled engine: the compiled module is never
    imported, so nothing is compiled or loaded."""
    code = (
        "import sys\n"
        "from mbdsl.cli.main import main\n"
        f"status = main(['simulate', {str(MODELS / 'slider_crank.mbd')!r}, '--t-end', '0.05',"
        f" '--engine', 'uncompiled', '-o', {str(tmp_path / 'out.csv')!r}, '--quiet'])\n"
        "assert status == 0, status\n"
        "assert 'mbdsl.integrators.compiled' not in sys.modules\n"
        "assert 'mbdsl.kernels.system' not in sys.modules\n"
        f"assert {UNCOMPILED_MODULE!r} in sys.modules\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    text = (tmp_path / "out.csv").read_text()
    assert "# engine: uncompiled" in text


# -- a first run: uncompiled while the kernels build, compiled once they are built -----------

def _upgrading_run(monkeypatch, path, method, T, h, looks_before_ready=1, overrides=None,
                   **kwargs):
    """A run as the command line makes it on a machine whose kernels are being
    built (``engine="auto"``, the background policy's choice of the uncompiled
    kernels), whose build is found done at the ``looks_before_ready``-th look:
    (the run, what it announced, the looks taken)."""
    from mbdsl.integrators import driver, engine as engine_module
    looks = []

    def ready():
        looks.append(True)
        return len(looks) >= looks_before_ready

    class Upgrade(driver.KernelUpgrade):
        def __init__(self, *args):
            super().__init__(*args, ready=ready, interval=0.0)

    monkeypatch.setattr(driver, "KernelUpgrade", Upgrade)
    # a Python stepper's call also ends after FLUSH_INTERVAL of wall time (to tell the
    # observers): on a loaded machine the first call of a 100-link chain ended at 9 steps
    # of 10; here calls end by their steps alone, so where the switch comes is the steps'
    from mbdsl.integrators import loop as loop_module
    monkeypatch.setattr(loop_module, "FLUSH_INTERVAL", float("inf"))
    select = engine_module.select_engine         # a warm-up of the kernels asks for "compiled"
    monkeypatch.setattr(engine_module, "select_engine", lambda engine, *a, **k:
                        "uncompiled" if engine == "auto" else select(engine, *a, **k))
    system = mbdsl.assemble(mbdsl.load(path, overrides=overrides))
    init = mbdsl.consistent_initial_state(system)
    said = []
    sol = integrate(system, make_method(method), T, h, initial=init, engine="auto",
                    announce=said.append, **kwargs)
    return sol, said, looks


@pytest.mark.parametrize("method", ["hht-i3", "nstiff", "hht-add", "hht-si2"])
def test_a_run_goes_on_compiled_once_the_kernels_are_built(monkeypatch, method):
    """The switch comes after the first uncompiled call (10 steps), the run
    records and says where, and its end agrees with a compiled run's to
    round-off (a wrong state handed over, say the step before's q_n of a
    two-step method or a stale multiplier, would part them by the step's
    error, 1e-6 and more)."""
    path = MODELS / "slider_crank.mbd"
    sol, said, looks = _upgrading_run(monkeypatch, path, method, 0.5, 1e-3)
    system = mbdsl.assemble(mbdsl.load(path))
    ref = integrate(system, make_method(method), 0.5, 1e-3,
                    initial=mbdsl.consistent_initial_state(system), engine="compiled")
    assert sol.status == "completed" and sol.engine == "compiled"
    assert sol.compiled_from[:2] == (pytest.approx(0.01), 10) and len(looks) == 1
    assert any("compiled kernels are built" in s for s in said)
    # each engine's time per step apart: the uncompiled steps' from their own time
    before = sol.compiled_from[2]
    assert 0.0 < before < sol.wall_time
    line = next(x for x in sol.summary().splitlines() if "uncompiled for the first" in x)
    uncompiled, compiled = (float(x) for x in re.findall(r"([0-9.]+) us/step", line))
    assert uncompiled == pytest.approx(1e6 * before / 10, rel=1e-3, abs=0.1)
    steps = sol.stats_total.steps
    assert compiled == pytest.approx(1e6 * (sol.wall_time - before) / (steps - 10),
                                     rel=1e-3, abs=0.1)
    assert uncompiled > compiled          # the interpreter's steps are the slower ones
    assert line.endswith("us/step compiled")
    assert len(sol.t) == len(ref.t)
    scale = np.abs(ref.q).max(axis=0) + 1.0
    assert np.max(np.abs(sol.q - ref.q) / scale) < 1e-9
    assert np.max(np.abs(sol.lam[1:] - ref.lam[1:])) < 1e-6 * np.abs(ref.lam).max()
    assert sol.timings["kernels"] >= 0 and sol.timings["integration"] > 0


def test_a_run_with_contacts_goes_on_compiled_with_its_contact_state(monkeypatch):
    """The bouncing ball's impacts set the contact state in the packed model
    (its impact speeds): the switch after a few bounces carries it over, and
    the heights equal a compiled run's."""
    path = MODELS / "bouncing_ball.mbd"
    sol, _, looks = _upgrading_run(monkeypatch, path, "hht-i3", 2.0, 1e-3, looks_before_ready=3)
    system = mbdsl.assemble(mbdsl.load(path))
    ref = integrate(system, make_method("hht-i3"), 2.0, 1e-3,
                    initial=mbdsl.consistent_initial_state(system), engine="compiled")
    assert sol.engine == "compiled" and sol.compiled_from is not None and len(looks) == 3
    assert 0.0 < sol.compiled_from[0] < 2.0
    assert len(sol.events) == len(ref.events) > 0
    assert abs(sol.q[-1] - ref.q[-1]).max() < 1e-8


def test_the_python_newton_on_the_kernels_goes_on_compiled_keeping_its_history(monkeypatch):
    """The Python stepper on the kernels (``python_loop``; SuperLU-sized
    models) keeps its stepper and history; only its kernels change."""
    path = MODELS / "slider_crank.mbd"
    sol, _, _ = _upgrading_run(monkeypatch, path, "nstiff", 0.2, 1e-3, python_loop=True)
    system = mbdsl.assemble(mbdsl.load(path))
    ref = integrate(system, make_method("nstiff"), 0.2, 1e-3, python_loop=True,
                    initial=mbdsl.consistent_initial_state(system), engine="compiled")
    assert sol.engine == "compiled" and sol.compiled_from[1] == 10
    assert np.max(np.abs(sol.q - ref.q)) < 1e-10


def test_a_chain_goes_on_from_the_python_newton_to_the_compiled_loop(monkeypatch):
    """The uncompiled kernels have no LAPACK band routines: a chain of 100
    links (500 unknowns) starts on the Python Newton with SuperLU and goes
    on in the compiled loop with the condensed solver, from the loop's
    state."""
    path = MODELS / "pendulum_chain.mbd"
    sol, _, _ = _upgrading_run(monkeypatch, path, "hht-i3", 0.05, 1e-3, overrides={"N": 100})
    system = mbdsl.assemble(mbdsl.load(path, overrides={"N": 100}))
    ref = integrate(system, make_method("hht-i3"), 0.05, 1e-3,
                    initial=mbdsl.consistent_initial_state(system), engine="compiled")
    assert ref.linear_solver == "condensed"
    assert sol.engine == "compiled" and sol.linear_solver == "condensed"
    assert sol.compiled_from[1] == 10
    assert np.max(np.abs(sol.q - ref.q)) < 1e-9
