"""What a run reports about itself: derived columns of all rows at once, where
the wall time went, which engine ran, and how the compiled kernels are built."""

import json
import os
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import mbdsl
from mbdsl.cli.main import main
from mbdsl.integrators import HHTI3, integrate, kernel_cache
from mbdsl.kernels import cache as kernel_cache_state
from mbdsl.io.csvfile import read_csv_metadata
from mbdsl.io.derived import derived_columns

from ..conftest import MODELS, ROOT

SHIPPED = sorted(MODELS.glob("*.mbd")) + [ROOT / "tests" / "dsl" / "valid" / "all_elements.mbd",
                                          ROOT / "tests" / "dsl" / "valid" / "flexible_elements.mbd"]


def _row_by_row(system, t, q, v, lam):
    """The derived columns from the one-row API, one row at a time (the oracle)."""
    out = {"energy.kinetic": [], "energy.potential": [], "constraint.position": [],
           "constraint.velocity": [], "reactions": []}
    reactions = None
    if system.model.joints and not system.cmap.spatial:   # planar reactions (spatial: -lambda)
        from mbdsl.io.derived import _Reactions
        reactions = _Reactions(system)
    for i in range(len(t)):
        out["energy.kinetic"].append(system.kinetic_energy(q[i], v[i]))
        out["energy.potential"].append(system.potential_energy(q[i]))
        out["constraint.position"].append(np.max(np.abs(system.Phi(q[i], t[i])), initial=0.0))
        vel = system.Phiq_times(q[i], t[i], v[i]) + system.Phi_t(q[i], t[i])
        out["constraint.velocity"].append(np.max(np.abs(vel), initial=0.0))
        if reactions is not None:
            out["reactions"].append(reactions(q[i], t[i], lam[i]))
    return out


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_derived_columns_of_all_rows_at_once_equal_row_by_row(path):
    """The element groups evaluated over a leading axis of rows give what they
    give one row at a time, on every shipped model (rigid, flexible, drivers
    that depend on time, every joint and force kind)."""
    model = mbdsl.load(path)
    sol = mbdsl.simulate(model, t_end=0.02, h=1e-3, engine="numpy")
    d = derived_columns(sol.system, sol.t, sol.q, sol.v, sol.lam)
    ref = _row_by_row(sol.system, sol.t, sol.q, sol.v, sol.lam)
    for k in ("energy.kinetic", "energy.potential", "constraint.position", "constraint.velocity"):
        np.testing.assert_allclose(d[k], ref[k], rtol=1e-12, atol=1e-14, err_msg=k)
    np.testing.assert_allclose(d["energy.total"], d["energy.kinetic"] + d["energy.potential"])
    for j, joint in enumerate(model.joints if ref["reactions"] else ()):
        for c, comp in enumerate(("fx", "fy", "torque")):
            np.testing.assert_allclose(d[f"reaction.{joint.name}.{comp}"],
                                       np.array(ref["reactions"])[:, j, c],
                                       rtol=1e-12, atol=1e-9, err_msg=f"{joint.name}.{comp}")


def test_pendulum_pivot_reaction_is_m_times_a_minus_g():
    """Independent check of the reactions over rows: for a single pendulum the
    pivot's force on the body is m (a_cm - g) (Newton's second law). NEWMARK
    enforces M a + Phi_q^T lambda = Q at every step (HHT weights two steps)."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "pendulum.mbd"), method="newmark", t_end=0.2,
                         engine="numpy")
    body = sol.model.bodies[0]
    joint = sol.model.joints[0]
    fx, fy = sol.column(f"reaction.{joint.name}.fx"), sol.column(f"reaction.{joint.name}.fy")
    g = sol.model.gravity
    sign = 1.0 if joint.second.body == 0 else -1.0   # reaction on the joint's second body
    np.testing.assert_allclose(sign * fx, body.mass * (sol.a[:, 0] - g[0]), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(sign * fy, body.mass * (sol.a[:, 1] - g[1]), rtol=1e-9, atol=1e-9)


def test_summary_and_files_say_where_the_time_went_and_which_engine_ran(tmp_path, capsys):
    out = tmp_path / "run.csv"
    assert main(["simulate", str(MODELS / "slider_crank.mbd"), "--t-end", "0.2",
                 "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "on the compiled engine (dense linear solver)" in text
    line = next(ln for ln in text.splitlines() if "wall time:" in ln)
    for phase in ("setup", "kernels", "integration", "output"):
        assert phase in line
    meta, _, _ = read_csv_metadata(out)
    assert meta["engine"] == "compiled" and meta["linear_solver"] == "dense"
    timings = json.loads(meta["timings"])
    assert set(timings) == {"setup", "kernels", "integration", "output"}
    assert timings["output"] > 0 and timings["integration"] > 0
    sol = mbdsl.load_solution(out)
    assert sol.engine == "compiled" and sol.timings == timings
    # the per-step time is the time loop's alone
    assert sol.wall_time == timings["integration"]

    h5 = tmp_path / "run.h5"
    assert main(["simulate", str(MODELS / "slider_crank.mbd"), "--t-end", "0.2", "-q",
                 "--engine", "numpy", "-o", str(h5)]) == 0
    with h5py.File(h5) as f:
        assert f.attrs["engine"] == "numpy"
        assert json.loads(f.attrs["timings"])["output"] > 0   # stored after it was known
    assert mbdsl.load_solution(h5).engine == "numpy"


def test_the_csv_stream_hands_its_derived_columns_to_the_solution(tmp_path):
    """Derived columns are computed once: the summary reuses those written."""
    from mbdsl.io.csvfile import CsvStream
    writer = CsvStream(tmp_path / "run.csv", interval=0.0)
    sol = mbdsl.simulate(mbdsl.load(MODELS / "slider_crank.mbd"), t_end=0.1, observers=[writer])
    assert sol._derived is not None
    fresh = derived_columns(sol.system, sol.t, sol.q, sol.v, sol.lam)
    for k, v in fresh.items():
        np.testing.assert_array_equal(sol._derived[k], v)


# -- building the kernels ---------------------------------------------------------------------

@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    """The marker and the lock in a folder of the test's own. A build for a new
    key empties numba's cache first (``purge_kernel_caches``); here the
    process has its kernels compiled in memory and writes nothing back, so
    an emptied cache would leave the machine's real marker saying "built"
    over an empty cache, and every later process of the suite would compile
    silently (measured: two later tests of this file took 140 s and 65 s
    instead of 3.5 s). The purge is left out."""
    monkeypatch.setattr(kernel_cache, "purge_kernel_caches", lambda: 0)
    monkeypatch.setattr(kernel_cache, "_cache_dir", lambda: tmp_path)
    monkeypatch.setattr(kernel_cache_state, "_cache_dir", lambda: tmp_path)
    monkeypatch.setattr(kernel_cache_state, "_loaded", set())     # as in a new process
    monkeypatch.setattr(kernel_cache, "_loaded", kernel_cache_state._loaded)
    return tmp_path


def test_background_policy_runs_uncompiled_and_starts_one_build(cache_dir, monkeypatch):
    started = []

    class FakePopen:
        def __init__(self, cmd, **kw):
            started.append(cmd)
            assert kw.get("start_new_session")
            # the child, run as ``-m`` from its working directory, imports this very
            # package (not a source checkout's copy in the user's directory, whose
            # numba cache the installed command would never read)
            assert (Path(kw["cwd"]) / "mbdsl" / "__init__.py").resolve() == \
                Path(mbdsl.__file__).resolve()

    monkeypatch.setattr("subprocess.Popen", FakePopen)
    system = mbdsl.assemble(mbdsl.load(MODELS / "slider_crank.mbd"))
    said = []
    sol = integrate(system, HHTI3(), 0.01, 1e-3, compile_policy="background",
                    announce=said.append)
    assert sol.engine == "uncompiled" and len(started) == 1
    assert started[0][1:] == ["-m", "mbdsl.integrators.build_kernels"]
    assert "background" in said[0] and "uncompiled kernels" in said[0]
    # while the build holds its lock, no second build starts
    sol = integrate(system, HHTI3(), 0.01, 1e-3, compile_policy="background")
    assert sol.engine == "uncompiled" and len(started) == 1
    # a lock left by a dead build is taken over
    old = time.time() - 2 * kernel_cache._STALE_LOCK
    os.utime(cache_dir / "mbdsl-kernels.lock", (old, old))
    assert kernel_cache.start_background_build() and len(started) == 2
    # the default policy waits for the kernels, announced, and records them as built
    sol = integrate(system, HHTI3(), 0.01, 1e-3, announce=said.append)
    assert sol.engine == "compiled"
    assert any(s.startswith("compiling the kernels") for s in said)
    assert kernel_cache.kernels_ready()
    # once built, the background policy runs compiled and starts nothing
    kernel_cache._loaded.clear()
    sol = integrate(system, HHTI3(), 0.01, 1e-3, compile_policy="background")
    assert sol.engine == "compiled" and len(started) == 2


def test_a_marker_from_another_source_is_not_trusted(cache_dir):
    (cache_dir / "mbdsl-kernels.json").write_text(json.dumps(dict(kernel_cache._key(),
                                                                  source="0" * 64)))
    assert not kernel_cache.kernels_ready()
    (cache_dir / "mbdsl-kernels.json").write_text(json.dumps(kernel_cache._key()))
    assert kernel_cache.kernels_ready()


def test_compile_policy_is_checked():
    system = mbdsl.assemble(mbdsl.load(MODELS / "pendulum.mbd"))
    with pytest.raises(ValueError, match="compile_policy"):
        integrate(system, HHTI3(), 0.01, 1e-3, compile_policy="later")


def test_the_head_of_a_streamed_csv_is_true_after_the_run(tmp_path):
    # `head out.csv` shows the final status and wall time, not "running" and 0.0:
    # the fields are written padded while the run goes and rewritten in place
    out = tmp_path / "out.csv"
    assert main(["simulate", str(MODELS / "slider_crank.mbd"), "--t-end", "0.2", "-q",
                 "-o", str(out)]) == 0
    head = {}
    with open(out, encoding="utf-8") as f:
        for line in f:
            if not line.startswith("#"):
                break                                   # the column names: the head ends
            key, _, value = line[1:].strip().partition(": ")
            head.setdefault(key, value)
    assert head["status"] == "completed"
    assert float(head["wall_time"]) > 0.0
    meta, names, values = read_csv_metadata(out)
    assert meta["status"] == "completed" and values.shape[0] == 201 and names[0] == "t"
    keys = [line[1:].partition(":")[0].strip() for line in out.read_text().splitlines()
            if line.startswith("#")]
    assert len(keys) == len(set(keys))               # each key once: head or trailer
    assert meta["timings"] and json.loads(meta["timings"])["setup"] > 0.0


def test_the_solved_for_line_is_short_and_prints_round_off_as_zero():
    from mbdsl.assembly.initial import InitialState
    solved = {"crank.x": -2.75e-17, "crank.y": -0.15, "crank.phi": 3e-13}
    solved.update({f"link{i}.y": -0.1 * i for i in range(1, 12)})
    st = InitialState(0.0, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(0), 1e-16, 0.0, 0.0,
                      solved, 1)
    text = st.report()
    assert "(1 Newton iteration)" in text
    assert "crank.x = 0," in text and "crank.phi = 0," in text and "crank.y = -0.15" in text
    assert text.count(" = ") == 3 + 10 and text.endswith("and 4 more")
    # a model's own output: the slider crank's crank.x is zero to round-off
    system = mbdsl.assemble(mbdsl.load(MODELS / "slider_crank.mbd"))
    assert "crank.x = 0," in mbdsl.consistent_initial_state(system).report()


@pytest.mark.parametrize("out", ["x.csv", "x.h5"])
def test_the_console_script_leaves_its_output_whole(out, tmp_path):
    """``python -m mbdsl`` (as the ``mbdsl`` script) ends the process without the
    interpreter's teardown (``cli.main.run``): the summary on stdout, the
    file's every row and the exit status must all be there, on a pipe. (The
    numpy engine: with a cold kernel cache the compiled one would start a
    background build beside the test suite.)"""
    import subprocess
    import sys
    proc = subprocess.run([sys.executable, "-m", "mbdsl", "simulate", str(MODELS / "pendulum.mbd"),
                           "--t-end", "0.3", "--engine", "numpy", "-o", str(tmp_path / out)],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    rows = int(proc.stdout.split("wrote ")[1].split("(")[1].split(" rows")[0])
    sol = mbdsl.load_solution(tmp_path / out)
    assert len(sol.t) == rows and sol.t[-1] == pytest.approx(0.3)
    assert proc.stdout.rstrip().splitlines()[-1].startswith(f"wrote {tmp_path / out} ({rows} rows")


def test_a_killed_runs_hdf5_keeps_every_chunk_written(tmp_path, capsys):
    """mbdsl simulate -o run.h5 streams chunks (SWMR): killed outright with
    SIGKILL once the file holds rows, the file still reads, with at least
    every row read before the kill, status running; plot says it ended
    early. No timing is assumed: the test waits for rows to appear."""
    import signal
    import subprocess
    import sys
    out = tmp_path / "run.h5"
    env = dict(os.environ, MBDSL_BACKGROUND_COMPILE="0")
    proc = subprocess.Popen([sys.executable, "-m", "mbdsl", "simulate",
                             str(MODELS / "double_pendulum.mbd"), "--h", "1e-4", "--t-end", "1e4",
                             "-q", "-o", str(out)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    seen, deadline = 0, time.monotonic() + 600
    try:
        while seen < 2 and time.monotonic() < deadline:      # 2000 rows flushed
            time.sleep(0.2)
            try:
                seen = len(mbdsl.load_solution(out).t) // 1000
            except (OSError, ValueError):
                pass                   # not created yet
        rows = len(mbdsl.load_solution(out).t)
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert seen >= 2, "the run wrote no rows in 600 s"
    sol = mbdsl.load_solution(out)
    assert sol.status == "running" and len(sol.t) >= rows
    assert np.all(np.diff(sol.t) > 0) and "did not finish" in sol.message
    assert np.all(np.isfinite(sol.column("energy.total")))
    assert main(["plot", str(out), "-o", str(tmp_path / "run.png")]) == 0
    assert "ended early" in capsys.readouterr().err


def test_an_observers_time_before_the_loop_is_not_taken_from_the_loops():
    """An observer that spends 0.3 s opening its file (``on_start``, before
    the first step): that time is output's, and the integration's time stays
    the loop's own, positive (it was once the loop's time less the 0.3 s,
    negative for a short run)."""
    import time as clock
    from mbdsl.io.observers import RunObserver

    class SlowHead(RunObserver):
        def on_start(self, sol):
            t0 = clock.perf_counter()
            clock.sleep(0.3)
            self.elapsed += clock.perf_counter() - t0

    model = mbdsl.load(MODELS / "slider_crank.mbd")
    sol = mbdsl.simulate(model, h=1e-3, t_end=0.05, observers=(SlowHead(),))
    assert sol.completed
    assert sol.timings["integration"] > 0.0
    assert sol.timings["output"] >= 0.3
    assert sol.timings["setup"] >= 0.0
