"""Parameter sweeps (``mbdsl sweep``): grids, random samples, failed runs
recorded, a stopped sweep continued, and a real Dask cluster.

Oracle: the same runs made one by one (``mbdsl.simulate`` with the same
overrides), which a sweep must reproduce exactly, whatever process or
machine made them.
"""

from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.cli.main import main
from mbdsl.io.hdf5 import read_sweep
from mbdsl.studies.sweep import (parse_distribution, parse_values, run_point, run_sweep,
                                 sweep_points)

from ..conftest import dask_processes

MODELS = Path(__file__).resolve().parents[2] / "models"
CRANK = MODELS / "slider_crank.mbd"
T = 0.1


def one_by_one(points):
    """The final crank angle of each point, run alone with mbdsl.simulate."""
    out = []
    for p in points:
        model = mbdsl.load(CRANK, overrides={k: repr(v) for k, v in p.items()})
        out.append(mbdsl.simulate(model, t_end=T).column("crank.phi")[-1])
    return np.array(out)


def by_point(table, names):
    """Row index by the parameter values."""
    return {tuple(float(table[n][i]) for n in names): i for i in range(len(table["status"]))}


def test_values_distributions_and_points():
    assert parse_values("100:1000:10") == pytest.approx(np.linspace(100, 1000, 10).tolist())
    assert parse_values("1,5,10") == [1.0, 5.0, 10.0]
    with pytest.raises(ValueError, match="a:b:n"):
        parse_values("1:2")
    assert parse_distribution("normal(5, 0.5)") == ("normal", 5.0, 0.5)
    with pytest.raises(ValueError, match="sigma < 0"):
        parse_distribution("normal(5,-1)")
    grid = sweep_points({"k": [1.0, 2.0, 3.0], "c": [4.0, 5.0]})
    assert len(grid) == 6 and {"k": 3.0, "c": 5.0} in grid
    a = sweep_points({"k": [1.0, 2.0]}, 50, {"c": ("normal", 5.0, 0.5)}, seed=3)
    b = sweep_points({"k": [1.0, 2.0]}, 50, {"c": ("normal", 5.0, 0.5)}, seed=3)
    assert a == b and len(a) == 100
    c = np.array([p["c"] for p in a])
    assert abs(c.mean() - 5.0) < 0.2 and 0.35 < c.std() < 0.65      # 50 draws of N(5, 0.5)
    with pytest.raises(ValueError, match="both on the grid"):
        sweep_points({"c": [1.0]}, 5, {"c": ("normal", 5.0, 0.5)})


def test_a_local_sweep_equals_the_runs_one_by_one(tmp_path):
    """Six points on two local processes: every run completed, each row's
    final crank angle equal (bit for bit) to the same run made alone."""
    points = sweep_points({"k": [50.0, 100.0, 150.0], "c": [1.0, 5.0]})
    out = tmp_path / "s.h5"
    result = run_sweep(CRANK, points, out, t_end=T, columns=["crank.phi"], jobs=2)
    assert (result.points, result.run, result.skipped, result.failed) == (6, 6, 0, 0)
    table = read_sweep(out)
    assert list(table["status"]) == ["completed"] * 6
    rows = by_point(table, ["k", "c"])
    got = np.array([table["crank.phi.final"][rows[(p["k"], p["c"])]] for p in points])
    assert np.array_equal(got, one_by_one(points))


def test_a_failed_run_is_a_row_with_its_code(tmp_path):
    """A point whose model is wrong (a crank of mass 0) and one whose run
    fails are rows with status failed and the error's code; the others run."""
    points = sweep_points({"m1": [3.0, 0.0]})
    out = tmp_path / "f.h5"
    result = run_sweep(CRANK, points, out, t_end=T, columns=["crank.phi"], jobs=1)
    table = read_sweep(out)
    assert result.failed == 1 and sorted(table["status"]) == ["completed", "failed"]
    bad = int(np.flatnonzero(table["m1"] == 0.0)[0])
    assert table["status"][bad] == "failed" and table["code"][bad].startswith("E")
    assert "mass" in table["message"][bad]
    assert np.isnan(table["crank.phi.final"][bad])
    from mbdsl.studies.sweep import SweepTask
    task = SweepTask(CRANK.read_text(), str(CRANK), None, None, T, None, ("crank.phi",))
    row = run_point(task, {"m1": 3.0})
    assert row["status"] == "completed"
    assert row["crank.phi.final"] == table["crank.phi.final"][1 - bad]


def test_a_stopped_sweep_continues_without_redoing_its_runs(tmp_path):
    """Stopped after 3 of 8 runs (Ctrl-C from the row callback), the table
    keeps those 3; the same sweep again runs the 5 others only, and the
    table then equals the runs one by one."""
    points = sweep_points({"k": [60.0, 80.0, 100.0, 120.0], "c": [2.0, 4.0]})
    out = tmp_path / "r.h5"
    seen = []

    def stop_after_three(row):
        seen.append(row)
        if len(seen) == 3:
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        run_sweep(CRANK, points, out, t_end=T, columns=["crank.phi"], jobs=1,
                  on_row=stop_after_three)
    assert len(read_sweep(out)["status"]) == 3
    again = []
    result = run_sweep(CRANK, points, out, t_end=T, columns=["crank.phi"], jobs=1,
                       on_row=again.append)
    assert (result.run, result.skipped) == (5, 3) and len(again) == 5
    done = {(r["k"], r["c"]) for r in seen}
    assert not done & {(r["k"], r["c"]) for r in again}
    table = read_sweep(out)
    rows = by_point(table, ["k", "c"])
    assert len(rows) == 8
    got = np.array([table["crank.phi.final"][rows[(p["k"], p["c"])]] for p in points])
    assert np.array_equal(got, one_by_one(points))
    with pytest.raises(ValueError, match="another sweep"):
        run_sweep(CRANK, points, out, t_end=T, columns=["crank.x"], jobs=1)


def test_the_command_line(tmp_path, capsys):
    out = tmp_path / "c.h5"
    assert main(["sweep", str(CRANK), "--set", "k=50:150:3", "--set", "c=1,5", "--t-end",
                 str(T), "--jobs", "1", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "6 points: 6 run now" in text and "crank.phi.final" in text
    assert main(["sweep", str(CRANK), "--set", "k=1:2", "-o", str(out)]) == 2
    assert "a:b:n" in capsys.readouterr().err
    assert main(["sweep", str(CRANK), "--set", "k=1,2", "--columns", "crank.bogus",
                 "-o", str(tmp_path / "d.h5")]) == 1
    assert "no column 'crank.bogus'" in capsys.readouterr().err


def test_200_runs_on_a_cluster_of_separate_processes(tmp_path):
    """`dask scheduler` and two `dask worker` processes on 127.0.0.1, the
    sweep through the command line with --scheduler: 200 rows (k x c, 20 x
    10), every run completed, equal to the runs one by one; the workers ran
    the tasks. The processes are stopped at the end."""
    distributed = pytest.importorskip("distributed")
    out = tmp_path / "cluster.h5"
    with dask_processes(tmp_path) as address:
        with distributed.Client(address, timeout=120) as client:
            client.wait_for_workers(2, timeout=120)
            with distributed.get_task_stream(client) as stream:
                assert main(["sweep", str(CRANK), "--set", "k=50:240:20", "--set",
                             "c=0.5:5:10", "--t-end", str(T), "--columns", "crank.phi",
                             "--scheduler", address, "-o", str(out), "-q"]) == 0
        assert len(stream.data) >= 200
    table = read_sweep(out)
    assert len(table["status"]) == 200 and set(table["status"]) == {"completed"}
    points = sweep_points({"k": parse_values("50:240:20"), "c": parse_values("0.5:5:10")})
    rows = by_point(table, ["k", "c"])
    got = np.array([table["crank.phi.final"][rows[(p["k"], p["c"])]] for p in points])
    assert np.array_equal(got, one_by_one(points))
