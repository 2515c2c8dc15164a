"""Errors in the model's words: structure, assembly and runtime failures, no lost output."""

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.cli.main import main
from mbdsl.io.csvfile import read_csv_metadata

from ..conftest import MODELS, interrupted_run

INVALID = Path(__file__).resolve().parents[1] / "dsl" / "invalid"

LOCK_UP = """model lock_up   # a crank longer than its rod, driven until the rod stands vertical
body crank { mass 1; inertia 0.01; point O (-0.15, 0); point A (0.15, 0) }
body rod   { mass 1; inertia 0.01; point A (-0.1, 0); point B (0.1, 0) }
joint O: revolute(ground.origin, crank.O)
joint A: revolute(crank.A, rod.A)
joint B: point_on_line(rod.B, ground.origin, direction = (1, 0))
driver spin: crank.phi = 0.2 + t
guess rod.phi = -0.3
simulate { method hht-i3; h 1e-3; t_end 2 }
"""


def test_redundant_joint_of_a_four_bar_is_named_with_both_dof(capsys):
    path = INVALID / "e401_redundant_joint.mbd"
    assert main(["check", str(path)]) == 1
    out, err = capsys.readouterr()
    assert "DOF by count (Gruebler) = -1" in out
    assert "DOF by rank = 1 (rank of Phi_q 8" in out
    assert "error[E401]" in err and "rows 0, 1 of 'A2' repeat the equations of joint 'A'" in err
    assert f"{path}:10:7" in err


def test_redundancy_is_found_in_declaration_order():
    from mbdsl.assembly.structure import independent_rows
    A = np.array([[1.0, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 2], [0, 2, 0]])
    ind, dep = independent_rows(A)
    assert ind.tolist() == [0, 1, 3] and dep.tolist() == [2, 4]


def test_inconsistent_joint_is_named_with_its_miss_in_metres(capsys):
    path = INVALID / "e503_inconsistent_joints.mbd"      # rod 1 m: fixed at O, pinned at E to O
    assert main(["check", str(path)]) == 1
    err = capsys.readouterr().err
    assert f"{path}:4:7" in err
    assert "joint 'E' cannot close on the loop ground - rod - ground (joints O, E)" in err
    assert "misses by 1 m" in err


def test_two_pins_too_far_apart(tmp_path, capsys):
    path = tmp_path / "rod.mbd"
    path.write_text("model rod_two_pins\n"
                    "body rod { mass 1; inertia 1/12; point A (-0.5, 0); point B (0.5, 0) }\n"
                    "ground { point P (1.5, 0) }\n"
                    "joint A: revolute(ground.origin, rod.A)\n"
                    "joint B: revolute(ground.P, rod.B)\n")
    assert main(["simulate", str(path), "--h", "1e-3", "--t-end", "0.01", "-q",
                 "-o", str(tmp_path / "x.csv")]) == 4
    err = capsys.readouterr().err
    assert f"{path}:5:7" in err and "misses by 0.5 m" in err   # 1.5 m apart, rod 1 m long
    assert not (tmp_path / "x.csv").exists()


def test_an_initial_value_that_keeps_the_loop_open_is_named(tmp_path, capsys):
    path = tmp_path / "lock.mbd"
    # the rod (0.2 m) cannot reach the slide line from A = (0, 0.3): crank.phi = pi/2 is impossible
    path.write_text(LOCK_UP.replace("driver spin: crank.phi = 0.2 + t",
                                    "initial crank.phi = pi/2"))
    assert main(["check", str(path)]) == 1
    err = capsys.readouterr().err
    assert "error[E503]" in err and "'initial crank.phi' is not imposed" in err
    # where it closes instead: the largest crank angle the rod allows, asin(2/3)
    value = float(err.split("closes at crank.phi = ")[1].split(")")[0])
    assert abs(math.sin(value)) <= 2 / 3 + 1e-6


def test_a_mechanism_that_cannot_move_is_reported(tmp_path, capsys):
    path = tmp_path / "welded.mbd"
    path.write_text("model welded\nbody rod { mass 1; inertia 1/12; point O (-0.5, 0) }\n"
                    "joint W: fixed(ground.origin, rod.O)\n")
    assert main(["check", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "warning[W402]" in err and "DOF by rank = 0" in out


def test_lock_up_names_the_joints_time_step_and_method_and_keeps_the_steps(tmp_path, capsys):
    path, out = tmp_path / "lock.mbd", tmp_path / "lock.csv"
    path.write_text(LOCK_UP)
    assert main(["simulate", str(path), "-q", "-o", str(out)]) == 3
    err = capsys.readouterr().err
    t_lock = math.asin(0.2 / 0.3) - 0.2          # rod vertical: crank.phi = asin(L2 / L1)
    t_fail = float(err.split("the step from t = ")[1].split(" s")[0])
    assert abs(t_fail - t_lock) < 2e-3
    assert "hht-i3(alpha=-0.05" in err and "h = " in err
    assert "singular direction involves the rows of" in err and "'B'" in err
    assert "singular (dead-centre or locked) position" in err
    meta, names, values = read_csv_metadata(out)
    assert meta["status"] == "failed" and "could not converge" in meta["message"]
    t = values[:, names.index("t")]
    assert t[-1] == pytest.approx(t_fail, abs=1e-5) and len(t) > 500     # message has 6 digits


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_a_failed_run_recording_every_7th_step_keeps_its_last_accepted_state(engine):
    """The lock-up above recording every 7th step: the run ends at the step
    it cannot take, and its last row is the last accepted state (not the
    last recorded row before it), the same as the run recording every step."""
    from mbdsl.integrators import integrate, make_method
    system = mbdsl.assemble(mbdsl.load_text(LOCK_UP))
    init = mbdsl.consistent_initial_state(system)
    runs = [integrate(system, make_method("hht-i3"), 2.0, 1e-3, initial=init, engine=engine,
                      output_every=k, on_failure="return") for k in (1, 7)]
    every, seventh = runs
    assert every.status == seventh.status == "failed" and every.engine == engine
    t_fail = float(every.message.split("the step from t = ")[1].split(" s")[0])
    assert seventh.t[-1] == every.t[-1] == pytest.approx(t_fail, abs=1e-5)
    assert (len(every.t) - 1) % 7 != 0         # the last accepted step is not a 7th
    np.testing.assert_array_equal(seventh.q[-1], every.q[-1])
    assert len(seventh.t) == 1 + (len(every.t) - 1) // 7 + 1
    assert seventh.stats_total.steps == every.stats_total.steps == len(every.t) - 1


def test_stiff_spring_hint_names_the_spring():
    from mbdsl.integrators.diagnosis import _stiff_elements
    system = mbdsl.assemble(mbdsl.load(MODELS / "double_pendulum_stiff.mbd"))
    (name, period, what), = _stiff_elements(system, 1e-3)
    assert name == "elbow" and what == "period"
    assert period == pytest.approx(2 * math.pi * math.sqrt((1 / 12) / 1e7))
    assert _stiff_elements(system, 1e-5) == []


def test_nonfinite_forces_stop_before_any_step(tmp_path, capsys):
    path = tmp_path / "heavy.mbd"
    path.write_text("model heavy\ngravity (0, -1e10)\n"
                    "body rod { mass 1e300; inertia 1; point O (-0.5, 0) }\n"
                    "joint O: revolute(ground.origin, rod.O)\n")
    assert main(["simulate", str(path), "--h", "1e-3", "--t-end", "0.01", "-q",
                 "-o", str(tmp_path / "x.csv")]) == 4
    err = capsys.readouterr().err
    assert "error[E506]" in err and "rod.y" in err and f"{path}:3:6" in err


def _default_sigint():
    """In the child before exec: SIGINT back to its default (Python then raises
    KeyboardInterrupt on it)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_sigint_keeps_every_accepted_step(tmp_path):
    """A run interrupted on a signal from its own output: exit 130, status
    interrupted, every row. The run is far longer in steps (600 s at h =
    1e-3) than the test waits, so the interrupt always lands inside the
    time loop, however loaded the machine: it is sent once the file holds
    t >= 0.5 s, not after some seconds."""
    out = tmp_path / "run.csv"
    t_end, t_signal = 600.0, 0.5
    proc = subprocess.Popen([sys.executable, "-m", "mbdsl", "simulate",
                             str(MODELS / "slider_crank.mbd"), "--t-end", str(t_end), "-q",
                             "--engine", "numpy", "-o", str(out)],
                            stderr=subprocess.PIPE, text=True,
                            # a test run started in the background of a shell inherits
                            # SIGINT ignored (and so would this child): Ctrl-C is the user's
                            preexec_fn=_default_sigint)
    deadline = time.time() + 300          # only a hung run gets here
    last_t = 0.0
    while time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)
        try:
            lines = [ln for ln in out.read_text().splitlines() if ln and ln[0].isdigit()]
        except FileNotFoundError:
            continue
        if lines:
            last_t = float(lines[-1].split(",")[0])
            if last_t >= t_signal:
                break
    assert proc.poll() is None, f"the run ended (or never wrote t >= {t_signal} s): {last_t}"
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    meta, names, values = read_csv_metadata(out)
    assert meta["status"] == "interrupted"
    t = values[:, 0]
    assert t_signal <= t[-1] < t_end
    np.testing.assert_allclose(np.diff(t), 1e-3, rtol=1e-9)    # no step missing or doubled
    assert int(meta["stats_total"].split('"steps": ')[1].split(",")[0]) == len(t) - 1
    # the rows are the run's own: an uninterrupted run to the same time agrees
    # (to round-off: its last step lands on t_end = t[-1], which differs from h by ulps)
    ref = mbdsl.simulate(mbdsl.load(MODELS / "slider_crank.mbd"), t_end=t[-1], engine="numpy")
    assert len(ref.t) == len(t)
    np.testing.assert_array_equal(values[-2, 1:7], ref.q[-2])
    np.testing.assert_allclose(values[-1, 1:7], ref.q[-1], rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("alpha", [-0.3, -0.05])
def test_a_stiff_failure_s_hint_never_repeats_advice_already_followed(alpha):
    # two full-Newton iterations cannot take a 50 ms step of a pendulum with a 1e7 N m/rad
    # elbow: the hint names the spring; it suggests alpha = -0.3 only when alpha is not
    # already -0.3, and the message gives the Newton norms' trend, not every norm
    from mbdsl.integrators import NewtonOptions, integrate, make_method
    system = mbdsl.assemble(mbdsl.load(MODELS / "double_pendulum_stiff.mbd",
                                       overrides={"elbow0": 1e-3}))
    sol = integrate(system, make_method("hht-i3", alpha=alpha), 0.5, 0.05,
                    newton=NewtonOptions(max_iter=2, jacobian="full"), on_failure="return",
                    max_halvings=0)
    assert sol.status == "failed"
    d = sol.diagnostics[0]
    assert "'elbow' oscillates" in d.hint
    assert ("alpha = -0.3" in d.hint) == (alpha != -0.3)
    assert "Newton norms" in d.message and d.message.count("e+") <= 3


@pytest.mark.parametrize("engine, control", [("compiled", False), ("compiled", True),
                                             ("uncompiled", False)])
def test_an_interrupted_compiled_run_keeps_every_accepted_step(engine, control):
    """Ctrl-C reaches a compiled run between the kernels' chunks of steps
    (here raised by its progress callback once t >= 1 s, deterministic):
    status interrupted, its time in the message, and every recorded row is
    the uninterrupted run's, bit for bit."""
    from mbdsl.integrators.adaptive import StepControl
    system = mbdsl.assemble(mbdsl.load(MODELS / "slider_crank.mbd"))
    init = mbdsl.consistent_initial_state(system)
    full, cut = interrupted_run(system, 3.0, 1.0, initial=init, engine=engine,
                                control=StepControl(rtol=1e-6, atol=1e-8) if control else None)
    assert full.status == "completed" and cut.status == "interrupted"
    assert cut.engine == engine
    k = len(cut.t)
    assert 1.0 <= cut.t[-1] < 3.0 and k < len(full.t)
    assert f"at t = {cut.t[-1]:.6g} s" in cut.message
    assert np.array_equal(cut.t, full.t[:k]) and np.array_equal(cut.q, full.q[:k])
    assert np.array_equal(cut.lam, full.lam[:k])


def test_stiff_spring_hint_takes_the_modes_period_where_the_spectrum_is_available():
    """With the last accepted state, E601's stiff element comes from the
    linearization (``mbdsl.modes``): the elbow's mode of the stiff double
    pendulum, period 1/1863.8 Hz = 5.37e-4 s (both links move: the one-body
    estimate above says 5.74e-4 s), named by the spring holding its strain
    energy; shorter than 4 h at h = 1e-3 s, not at h = 1e-4 s."""
    from mbdsl.integrators.base import StepState
    from mbdsl.integrators.diagnosis import _stiff_elements
    from mbdsl.modes import modes
    system = mbdsl.assemble(mbdsl.load(MODELS / "double_pendulum_stiff.mbd"))
    init = mbdsl.consistent_initial_state(system)
    state = StepState(init.t, init.q, init.v, init.a, init.lam)
    (name, period, what), = _stiff_elements(system, 1e-3, init.v, state)
    assert name == "elbow" and what == "period"
    assert period == pytest.approx(2 * math.pi / modes(system).modes[-1].omega, rel=1e-12)
    assert period == pytest.approx(1 / 1863.83, rel=1e-5)
    assert _stiff_elements(system, 1e-4, init.v, state) == []
