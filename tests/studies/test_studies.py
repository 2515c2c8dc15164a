"""mbdsl study: convergence, energy, drift, cost and work-precision on small models.

Oracles: the methods' known orders (1 for NEWMARK with gamma = 0.6, 2 for the
others), energy conservation of the undamped pendulum (the study's eps(T)
against E_ref must equal the eps(T) against E(0) computed here from a plain
simulate), the velocity constraint (round-off for the index-2 methods), and
determinism (--jobs 1 and --jobs 2 give identical numbers).
"""

import csv
import re

import numpy as np
import pytest
from PIL import Image

import mbdsl
from mbdsl.cli.main import main
from mbdsl.studies import StudyOptions, parse_h_range, run_study

from ..conftest import MODELS

PENDULUM = MODELS / "pendulum.mbd"
HS = [2.0**-k for k in range(7, 11)]          # 2^-7 .. 2^-10
T = 1.0
ORDER = {"newmark": 1, "hht-i3": 2, "nstiff": 2, "nstiff-si2": 2, "hht-add": 2, "hht-si2": 2}


def _series_in_svg(path):
    """Number of distinct plotted series per panel in a figure written by write_figure."""
    ids = re.findall(r'id="series-(\d+)-(\d+)', path.read_text())
    panels = {}
    for k, j in set(ids):
        panels.setdefault(int(k), set()).add(int(j))
    return {k: len(v) for k, v in panels.items()}


def _assert_image(path, width=200):
    """A readable PNG of a plausible size."""
    with Image.open(path) as im:
        im.verify()
    with Image.open(path) as im:
        assert im.format == "PNG" and im.size[0] >= width


@pytest.fixture(scope="module")
def pendulum_all(tmp_path_factory):
    """Every study on the pendulum, two worker processes; written to a folder."""
    out = tmp_path_factory.mktemp("pendulum_all")
    opts = StudyOptions(methods=list(mbdsl.METHODS), hs=HS, t_end=T, repeat=2, jobs=2)
    result = run_study("all", PENDULUM, opts, log=lambda s: None)
    files = result.write(out)
    return result, out, files


def test_convergence_orders_on_the_pendulum(pendulum_all):
    result, _, _ = pendulum_all
    orders = {row[0]: row for row in result.section("convergence").tables[1].rows}
    for method, expected in ORDER.items():
        _, exp, pos, vel, points = orders[method]
        assert exp == expected
        assert points == len(HS)
        assert abs(pos - expected) <= 0.15, (method, pos)
        assert abs(vel - expected) <= 0.15, (method, vel)


def test_errors_are_measured_against_an_accurate_reference(pendulum_all):
    result, _, _ = pendulum_all
    ref = result.reference
    assert "DOP853" in ref.description
    assert np.max(ref.error_q) < 1e-9 and np.max(ref.error_v) < 1e-9
    # the reference at T agrees with a fine hht-si2 run to that run's accuracy
    sol = mbdsl.simulate(mbdsl.load(PENDULUM), method="hht-si2", h=2.0**-13, t_end=T)
    assert np.max(np.abs(sol.q[-1] - ref.q_end)) < 1e-6
    err = result.section("convergence").tables[0]
    run = result.runs[("hht-i3", HS[-1], ())]
    row = [r for r in err.rows if r[0] == "hht-i3" and r[1] == HS[-1]][0]
    assert row[2] == pytest.approx(np.max(np.abs(run.q_end - ref.q_end)), rel=1e-12)


def test_energy_error_matches_an_independent_computation(pendulum_all):
    """On a conservative model eps(T) against E_ref is eps(T) against E(0)."""
    result, _, _ = pendulum_all
    rows = {(r[0], r[1]): r[2] for r in result.section("energy").tables[0].rows}
    model = mbdsl.load(PENDULUM)
    for method in ("newmark", "hht-i3"):
        sol = mbdsl.simulate(model, method=method, h=HS[1], t_end=T)
        e = sol.column("energy.total")
        eps = np.trapezoid(np.abs(e - e[0]), sol.t) / T
        assert rows[method, HS[1]] == pytest.approx(eps, rel=1e-4)
    orders = {r[0]: r[2] for r in result.section("energy").tables[1].rows}
    assert abs(orders["newmark"] - 1) <= 0.3
    for method in ("hht-i3", "hht-si2", "nstiff"):
        assert abs(orders[method] - 2) <= 0.3, (method, orders[method])


def test_energy_dissipation_table_compares_two_alphas(pendulum_all):
    result, _, _ = pendulum_all
    table = result.section("energy").tables[2]
    methods = {r[0] for r in table.rows}
    assert methods == {"hht-i3", "hht-si2", "hht-add"}
    for m, h, e03, e005, ratio in table.rows:
        assert ratio == pytest.approx(e03 / e005)
        assert e03 > 0 and e005 > 0
    # the alpha = -0.3 runs are real runs at that alpha
    run = result.runs[("hht-i3", HS[0], (("alpha", -0.3),))]
    assert run.coefficients["alpha"] == -0.3


def test_drift_is_roundoff_for_the_index2_methods(pendulum_all):
    result, _, _ = pendulum_all
    rows = {r[0]: r for r in result.section("drift").tables[0].rows}
    # the index-2 methods meet the velocity constraints to Newton's tolerance (below
    # 1e-10 times the speeds: the study's "round-off"), the index-3 methods miss them by
    # the truncation error, more than 100 times that
    index2 = max(max(rows[m][1], rows[m][2]) for m in ("nstiff-si2", "hht-add", "hht-si2"))
    for m in ("nstiff-si2", "hht-add", "hht-si2"):
        assert rows[m][3] == "round-off"
    for m in ("newmark", "hht-i3", "nstiff"):
        assert rows[m][3] == "O(h^p)" and max(rows[m][1], rows[m][2]) > max(1e-8, 100 * index2)
    # the table's maximum is the joint's Phi_q v + Phi_t recomputed from the run
    sol = mbdsl.simulate(mbdsl.load(PENDULUM), method="hht-i3", h=result.options.h_single,
                         t_end=T)
    sysm = sol.system
    viol = [np.abs(sysm.Phiq_times(q, t, v) + sysm.Phi_t(q, t)) for t, q, v in
            zip(sol.t, sol.q, sol.v)]
    assert rows["hht-i3"][1] == pytest.approx(max(v[0] for v in viol), rel=1e-9)


def test_cost_has_one_row_per_method_with_positive_times(pendulum_all):
    result, _, _ = pendulum_all
    rows = result.section("cost").tables[0].rows
    assert [r[0] for r in rows] == list(mbdsl.METHODS)
    for m, engine, steps, time, us, rel, its, jac, fac, res, status in rows:
        assert steps == round(T / result.options.h_single)
        assert time > 0 and us > 0 and rel > 0 and its >= 1 and status == "completed"
        assert engine in ("compiled/dense", "numpy/dense"), engine
    assert [r[5] for r in rows if r[0] == "hht-i3"] == [1.0]
    assert [r[1] for r in rows if r[0] == "hht-i3"] == ["compiled/dense"]
    # two timed runs after the warm-up run that supplied the results
    assert len(result.runs[("hht-i3", result.options.h_single, ())].wall_times) == 2


def test_files_figures_and_index(pendulum_all):
    result, out, files = pendulum_all
    names = {p.name for p in files}
    for stem in ("convergence", "convergence_orders", "energy", "energy_orders",
                 "energy_dissipation", "drift", "cost", "work_precision"):
        assert f"{stem}.csv" in names and f"{stem}.md" in names
    k = len(mbdsl.METHODS)
    expected = {            # figure -> series per panel
        "convergence": {0: k, 1: k},
        "energy_eps": {0: k},
        "energy_curves": {0: len(HS), 1: len(HS)},
        "drift": {i: 1 for i in range(k)},
        "cost": {0: 1},
        "work_precision": {0: k},
    }
    for stem, series in expected.items():
        _assert_image(out / f"{stem}.png")
        assert _series_in_svg(out / f"{stem}.svg") == series, stem
    # every figure names what it shows: the bars of the cost chart carry the method
    # names as tick labels, the line plots a legend of the methods (matplotlib's SVG
    # writes each text it draws as a comment before its glyphs)
    for stem in ("cost", "convergence", "energy_eps", "work_precision"):
        texts = set(re.findall(r"<!-- (.*?) -->", (out / f"{stem}.svg").read_text()))
        assert set(mbdsl.METHODS) <= texts, (stem, set(mbdsl.METHODS) - texts)
    index = (out / "index.md").read_text()
    for stem in expected:
        assert f"({stem}.png)" in index
    assert "| hht-si2 |" in index and "DOP853" in index
    csv = (out / "convergence.csv").read_text().splitlines()
    assert csv[0].startswith("method,h [s],error positions,error velocities")
    assert len(csv) == 1 + k * len(HS)


def test_jobs_2_gives_the_same_errors_as_jobs_1(pendulum_all):
    result2, _, _ = pendulum_all
    opts = StudyOptions(methods=["newmark", "hht-si2"], hs=HS[:2], t_end=T, jobs=1)
    result1 = run_study("convergence", PENDULUM, opts, log=lambda s: None)
    for key, run in result1.runs.items():
        other = result2.runs[key]
        assert np.array_equal(run.q_end, other.q_end) and np.array_equal(run.v_end, other.v_end)
        assert run.stats == other.stats


def test_a_file_reference_flags_errors_at_its_own_accuracy(tmp_path):
    """The run at the reference's own step has error 0: flagged and not fitted."""
    ref_file = tmp_path / "ref.csv"
    assert main(["simulate", str(PENDULUM), "--method", "hht-i3", "--h", str(HS[-1]),
                 "--t-end", "1", "-o", str(ref_file), "-q"]) == 0
    opts = StudyOptions(methods=["hht-i3"], hs=HS, t_end=T, reference=str(ref_file), jobs=1)
    result = run_study("convergence", PENDULUM, opts, log=lambda s: None)
    assert "Richardson" in result.reference.description
    errors, orders = result.section("convergence").tables
    last = [r for r in errors.rows if r[1] == HS[-1]][0]
    assert last[2] == 0.0 and "below 10x reference error" in last[4]
    # a reference only 2x finer than the study's smallest step cannot check 2^-9 either
    est = (np.max(result.reference.error_q), np.max(result.reference.error_v))
    clear = [r for r in errors.rows if r[2] > 10 * est[0] and r[3] > 10 * est[1]]
    assert HS[0] in [r[1] for r in clear] and HS[-1] not in [r[1] for r in clear]
    assert orders.rows[0][-1] == len(clear)
    assert abs(orders.rows[0][2] - 2) < 0.3


def test_dask_scheduler_runs_the_same_study():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        opts = StudyOptions(methods=["hht-i3"], hs=HS[:2], t_end=T, scheduler=cluster.scheduler_address)
        on_dask = run_study("convergence", PENDULUM, opts, log=lambda s: None)
    local = run_study("convergence", PENDULUM,
                      StudyOptions(methods=["hht-i3"], hs=HS[:2], t_end=T, jobs=1),
                      log=lambda s: None)
    assert on_dask.section("convergence").tables[0].rows == local.section("convergence").tables[0].rows


def test_a_study_on_a_cluster_of_separate_processes(tmp_path):
    # a real cluster: `dask scheduler` and two `dask worker` processes (as on
    # machines of their own), the study run through the command line with
    # --scheduler; the same errors as --jobs 1. The processes are stopped at the end.
    from ..conftest import dask_processes
    distributed = pytest.importorskip("distributed")
    with dask_processes(tmp_path) as address:
        args = ["study", "convergence", str(PENDULUM), "--methods", "hht-i3,hht-si2",
                "--h", f"{HS[0]},{HS[1]}", "--t-end", str(T)]
        with distributed.Client(address, timeout=120) as client:
            client.wait_for_workers(2, timeout=120)
            with distributed.get_task_stream(client) as stream:     # what the workers ran
                assert main(args + ["--scheduler", address, "-o", str(tmp_path / "cluster")]) == 0
        assert len(stream.data) >= 4
        assert main(args + ["--jobs", "1", "-o", str(tmp_path / "local")]) == 0
        cluster = (tmp_path / "cluster" / "convergence.csv").read_text()
        local = (tmp_path / "local" / "convergence.csv").read_text()
        assert cluster == local and "hht-si2" in cluster


def test_h_range():
    assert parse_h_range("2^-7:2^-11") == [2.0**-k for k in range(7, 12)]
    assert parse_h_range("1e-3:2.5e-4") == [1e-3, 5e-4, 2.5e-4]
    with pytest.raises(ValueError, match="power of two apart"):
        parse_h_range("1e-3:3e-4")
    with pytest.raises(ValueError, match="FIRST:LAST"):
        parse_h_range("2^-7")


def test_cli_study_prints_the_table_and_writes_the_folder(tmp_path, capsys):
    out = tmp_path / "conv"
    assert main(["study", "convergence", str(PENDULUM), "--methods", "hht-i3,newmark",
                 "--h", "0.02,0.01", "--t-end", "0.5", "--jobs", "1", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Fitted order" in text and "hht-i3" in text and "newmark" in text
    assert (out / "index.md").exists() and (out / "convergence.png").exists()


@pytest.mark.parametrize("args, message", [
    (["--h-range", "1e-3:3e-4"], "power of two apart"),
    (["--quantity", "rod.omegaa"], "did you mean rod.omega"),
    (["--methods", "hht"], "unknown method 'hht'"),
    (["--joint", "nope", "--h", "0.01"], "no joint 'nope'"),
])
def test_cli_study_errors_are_for_people(args, message, tmp_path, capsys):
    kind = "drift" if "--joint" in args else "convergence"
    status = main(["study", kind, str(PENDULUM), "--t-end", "0.1", "--jobs", "1",
                   "-o", str(tmp_path / "x")] + args)
    err = capsys.readouterr().err
    assert status != 0 and message in err and "Traceback" not in err


def test_convergence_of_a_multiplier_column():
    # --quantity lambda.<joint>.<k>: the reference's multipliers come from the
    # index-1 system at its (q, v) at T; every second-order method, HHT-ADD
    # included (its output lambda is the index-1 one), converges at order 2
    opts = StudyOptions(methods=["newmark", "hht-i3", "hht-add", "hht-si2"],
                        hs=[2.0**-k for k in range(8, 12)], t_end=0.5,
                        quantities=["lambda.O.0"], jobs=1)
    result = run_study("convergence", MODELS / "slider_crank.mbd", opts, log=lambda s: None)
    orders = {row[0]: row for row in result.section("convergence").tables[1].rows}
    for method in ("hht-i3", "hht-add", "hht-si2"):
        _, exp, order, points = orders[method]
        assert exp == 2 and points == 4 and abs(order - 2.0) <= 0.15, (method, order)
    assert abs(orders["newmark"][2] - 1.0) <= 0.15
    with pytest.raises(ValueError, match="lambda.O.0"):
        run_study("convergence", MODELS / "slider_crank.mbd",
                  StudyOptions(methods=["hht-i3"], hs=[1e-3], t_end=0.1,
                               quantities=["lambda.Q.0"], jobs=1), log=lambda s: None)


def test_recommend_picks_a_method_and_an_h_that_meet_each_target():
    # for each target error: a method, an h or a tolerance, and a time; rerunning the
    # chosen method at that h (measured or extrapolated along its order) or tolerance
    # (measured or extrapolated in proportion) meets the target
    from mbdsl.integrators import integrate, make_method
    from mbdsl.integrators.adaptive import StepControl
    opts = StudyOptions(methods=["hht-i3", "nstiff", "hht-si2"], hs=[2.0**-k for k in range(7, 10)],
                        t_end=0.5, quantities=["positions"], repeat=1, jobs=1,
                        tols=(1e-4, 1e-6, 1e-12))
    result = run_study("recommend", MODELS / "slider_crank.mbd", opts, log=lambda s: None)
    rows = result.section("recommend").tables[0].rows
    assert [r[0] for r in rows] == [1e-4, 1e-6, 1e-12]
    assert rows[1][5].startswith("extrapolated, verified")  # below the sweep, checked by a run
    assert rows[2][1] == "none" and rows[2][5].startswith("not reached")   # below the error floor
    rows = rows[:2]
    system = mbdsl.assemble(mbdsl.load(MODELS / "slider_crank.mbd"))
    init = mbdsl.consistent_initial_state(system)
    for target, method, h, tol, _, basis, time_s, engine, runner_up, _ in rows:
        assert method in opts.methods and runner_up in opts.methods and runner_up != method
        assert time_s > 0 and engine.startswith("compiled")
        assert np.isfinite(h) != np.isfinite(tol)                 # a step size or a tolerance
        if np.isfinite(tol):
            sol = integrate(system, make_method(method), 0.5, opts.hs[0], initial=init,
                            control=StepControl(tol, tol))
        else:
            sol = integrate(system, make_method(method), 0.5, h, initial=init)
        error = np.abs(sol.q[-1] - result.reference.q_end).max()
        assert error <= target, (target, method, h, tol, basis, error)


def test_work_precision_by_tolerance(tmp_path):
    """--tol FIRST:LAST on the work-precision study: error-controlled runs, one
    per decade, each starting from the largest h; the achieved error falls
    with the tolerance (against the study's own DOP853 reference)."""
    status = main(["study", "work-precision", str(PENDULUM), "--t-end", "1", "--h", "1e-2",
                   "--methods", "hht-i3,nstiff", "--tol", "1e-4:1e-6", "--repeat", "1",
                   "--jobs", "1", "--quantity", "rod.phi", "-q", "-o", str(tmp_path / "wp")])
    assert status == 0
    rows = list(csv.DictReader(open(tmp_path / "wp" / "work_precision.csv")))
    assert [float(r["tol"]) for r in rows] == [1e-4, 1e-5, 1e-6] * 2
    for method in ("hht-i3", "nstiff"):
        errors = [float(r["error rod.phi"]) for r in rows if r["method"] == method]
        steps = [int(r["steps"]) for r in rows if r["method"] == method]
        assert errors[0] > 10 * errors[-1] and steps[0] < steps[1] < steps[2]
        # the largest error over the run's samples: at least the error at T, falling too
        most = [float(r["max error rod.phi"]) for r in rows if r["method"] == method]
        assert all(m >= e * (1 - 1e-6) for m, e in zip(most, errors)), (most, errors)
        assert most[0] > 10 * most[-1]
        assert all(r["engine"] == "compiled/dense" for r in rows if r["method"] == method)


def test_timed_runs_go_one_at_a_time_after_the_others():
    # two runs timed at once on shared cores disturb each other's time: with two
    # workers the untimed runs share the pool, and the timed ones follow in this
    # process, one at a time, each with its warm-up and its repeats; their results
    # are those of a run alone
    from mbdsl.studies.parallel import run_specs
    from mbdsl.studies.runs import ModelSource, RunSpec
    source = ModelSource(PENDULUM.read_text(), str(PENDULUM))
    specs = [RunSpec("hht-i3", h, 0.2, repeat=r) for h, r in
             ((0.01, 2), (0.02, 0), (0.005, 0), (0.04, 2), (0.0025, 0))]
    order = []
    out = run_specs(source, specs, jobs=2, on_done=lambda data: order.append(data.spec))
    assert [d.spec for d in out] == specs
    assert [s.repeat for s in order] == [0, 0, 0, 2, 2]       # the timed ones last
    assert [s.h for s in order[3:]] == [0.01, 0.04]             # in the order given
    for data in out:
        assert data.completed and len(data.wall_times) == max(data.spec.repeat, 1)
    alone = run_specs(source, [specs[0]], jobs=1)[0]
    assert np.array_equal(alone.q_end, out[0].q_end) and alone.stats == out[0].stats


def test_a_runs_sampled_error_is_its_largest_over_the_run():
    """The tolerance sweep's error: the largest over RUN_SAMPLES times of the
    run, q at those times by cubic Hermite on the steps. On a pendulum run at
    fixed steps, against the study's DOP853 reference: equal to the largest
    of the errors computed directly at the sample times from a run that lands
    a step on each of them (to the Hermite interpolation's error, far below
    the run's own), and at least the error at T."""
    import mbdsl
    from mbdsl.studies.reference import build_reference
    from mbdsl.studies.runs import ModelSource, RunSpec, execute_run, sample_times
    from mbdsl.studies.measures import sampled_error
    source = ModelSource(PENDULUM.read_text(), str(PENDULUM))
    model = source.load()
    data = execute_run(source, RunSpec("hht-i3", 1e-3, 1.0, samples=10))
    assert data.completed and data.t_samples[-1] == pytest.approx(1.0)
    np.testing.assert_allclose(data.t_samples, sample_times(0.0, 1.0, 10))
    ref = build_reference("dop853", model, 1.0, 1e-3)
    got = sampled_error(model, data, ref, "rod.phi")
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=1.0, fixed=True)
    i = model.coordinate_names().index("rod.phi")
    at = np.searchsorted(sol.t, data.t_samples - 1e-12)
    direct = np.max(np.abs(sol.q[at, i] - ref.state(data.t_samples)[0][:, i]))
    assert got == pytest.approx(direct, rel=1e-6)
    assert got >= abs(data.q_end[i] - ref.q_end[i])
