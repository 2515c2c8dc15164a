"""The command line: method options, output columns, exit statuses."""

import numpy as np
import pytest

from mbdsl.cli.main import main
from mbdsl.io.csvfile import read_csv_metadata

from ..conftest import MODELS


def run(tmp_path, *args):
    out = tmp_path / "out.csv"
    status = main(["simulate", str(MODELS / "slider_crank.mbd"), "--t-end", "0.1", "-q",
                   "-o", str(out), *args])
    return status, out


@pytest.mark.parametrize("args,params", [
    (["--method", "newmark", "--gamma", "0.7", "--beta", "0.36"], {"gamma": 0.7, "beta": 0.36}),
    (["--method", "hht-si2", "--alpha", "-0.3"], {"alpha": -0.3}),
    (["--method", "hht-add", "--b", "1"], {"b": 1.0}),
    (["--method", "nstiff"], {}),
    (["--method", "genalpha", "--rho-inf", "0.5"], {"rho_inf": 0.5, "alpha_m": 0.0}),
    (["--method", "genalpha-si2", "--rho-inf", "1"], {"rho_inf": 1.0, "alpha_f": 0.5}),
])
def test_method_coefficients_reach_the_run(tmp_path, args, params):
    status, out = run(tmp_path, *args)
    meta, names, values = read_csv_metadata(out)
    assert status == 0 and meta["method"] == args[1]
    for k, v in params.items():
        assert float(meta[f"method.{k}"]) == v


def test_index2_output_has_mu_and_reactions(tmp_path):
    status, out = run(tmp_path, "--method", "nstiff-si2")
    meta, names, values = read_csv_metadata(out)
    assert {"mu.O.0", "mu.B.0", "lambda.A.1", "reaction.B.fx", "newton.iterations"} <= set(names)
    assert np.max(values[:, names.index("constraint.velocity")]) < 1e-9


@pytest.mark.parametrize("args,text", [
    (["--method", "newmark", "--gamma", "0.4"], "gamma = 0.4 is out of range"),
    (["--method", "nstiff", "--alpha", "-0.1"], "takes no parameter alpha"),
    (["--method", "hht-add", "--b", "0.5"], "b = 0.5 is out of range"),
    (["--method", "genalpha", "--rho-inf", "-0.1"], "rho_inf = -0.1 is out of range: [0, 1]"),
    (["--method", "hht-i3", "--rho-inf", "0.5"], "takes no parameter rho_inf"),
])
def test_bad_coefficients_exit_1_with_the_reason(tmp_path, capsys, args, text):
    status, out = run(tmp_path, *args)
    assert status == 1 and text in capsys.readouterr().err and not out.exists()


def test_set_override_and_summary(tmp_path, capsys):
    out = tmp_path / "p.csv"
    status = main(["simulate", str(MODELS / "pendulum.mbd"), "--set", "phi0=-1.2", "--t-end", "0.01",
                   "-o", str(out)])
    text = capsys.readouterr().out
    assert status == 0
    assert "iterations/step" in text and "max |Phi|" in text and "energy:" in text
    meta, names, values = read_csv_metadata(out)
    assert values[0, names.index("rod.phi")] == -1.2
    assert "phi0=-1.2" in meta["parameters"]


def test_check_prints_dof(capsys):
    assert main(["check", str(MODELS / "slider_crank.mbd")]) == 0
    out = capsys.readouterr().out
    assert "DOF by count (Gruebler) = 1" in out and "DOF by rank = 1 (rank of Phi_q 5" in out


def test_simulate_help_shows_the_defaults(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--help"])
    assert exc.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "default: the model's simulate block, else hht-i3" in text
    assert "required without one" in text and "default -0.05" in text
    assert "default 0.6" in text and "default modified" in text and "auto (default)" in text


def test_messages_for_wrong_files_name_the_problem(tmp_path, capsys):
    # no raw Python messages: a model given to plot, a folder that does not
    # exist, a result file cut inside its header
    assert main(["plot", str(MODELS / "slider_crank.mbd")]) == 1
    assert "is not a result file" in capsys.readouterr().err
    missing = tmp_path / "no" / "such" / "out.csv"
    assert main(["simulate", str(MODELS / "slider_crank.mbd"), "-q", "--t-end", "0.01",
                 "-o", str(missing)]) == 1
    err = capsys.readouterr().err
    assert f"the folder {missing.parent} does not exist" in err and "Errno" not in err
    out = tmp_path / "run.csv"
    assert main(["simulate", str(MODELS / "slider_crank.mbd"), "-q", "--t-end", "0.01",
                 "-o", str(out)]) == 0
    cut = tmp_path / "cut.csv"
    cut.write_text(out.read_text()[:300])
    assert main(["plot", str(cut)]) == 1
    assert "the file is truncated" in capsys.readouterr().err


def test_follow_on_errors_are_not_reported(tmp_path, capsys):
    # one mistake, one error: a bad --set value does not also make every use of the
    # parameter an "unknown name", a point that cannot be evaluated is not also
    # "no point" at every joint that uses it
    assert main(["check", str(MODELS / "slider_crank.mbd"), "--set", "k=abc"]) == 1
    err = capsys.readouterr().err
    assert "--set k=abc" in err and "unknown name 'k'" not in err and "1 error," in err
    model = tmp_path / "divz.mbd"
    model.write_text("model divz\nparameter z = 0\n"
                     "body b { mass 1; inertia 1; point p (1/z, 0) }\n"
                     "joint J: revolute(ground.origin, b.p)\n"
                     "joint K: revolute(b.p, ground.origin)\n")
    assert main(["check", str(model)]) == 1
    err = capsys.readouterr().err
    assert "division by zero" in err and "has no point" not in err and "1 error," in err


def test_rho_inf_in_the_simulate_block(tmp_path, capsys):
    text = (MODELS / "pendulum.mbd").read_text().replace(
        "simulate { method hht-i3; h 1e-3; t_end 4 }",
        "simulate { method genalpha; h 1e-3; t_end 0.05; rho_inf 0.25 }")
    path = tmp_path / "ga.mbd"
    path.write_text(text)
    out = tmp_path / "ga.csv"
    assert main(["simulate", str(path), "-q", "-o", str(out)]) == 0
    meta, names, values = read_csv_metadata(out)
    assert meta["method"] == "genalpha" and float(meta["method.rho_inf"]) == 0.25
    path.write_text(text.replace("rho_inf 0.25", "rho_inf 1.5"))
    assert main(["simulate", str(path), "-q", "-o", str(out)]) != 0
    err = capsys.readouterr().err
    assert "E303" in err and "rho_inf = 1.5 is out of range" in err and "ga.mbd:" in err


def test_rows_at_requested_times_from_the_command_line(tmp_path, capsys):
    """--output-dt and --output-times: rows at exactly those times (and
    t_end) in the CSV; an output time outside the run exits 1 naming it;
    --output-every with either is refused by the parser (exit 2)."""
    status, out = run(tmp_path, "--output-dt", "0.02")
    meta, names, values = read_csv_metadata(out)
    assert status == 0 and meta["rows"] == "at requested times"
    assert np.allclose(values[:, 0], [0, 0.02, 0.04, 0.06, 0.08, 0.1], atol=1e-12)
    status, out = run(tmp_path, "--output-times", "0.0375,0.05")
    meta, names, values = read_csv_metadata(out)
    assert status == 0 and np.allclose(values[:, 0], [0, 0.0375, 0.05, 0.1], atol=1e-15)
    status, out = run(tmp_path, "--output-times", "0.05,0.3")
    assert status == 1 and "output time 0.3 s is outside the run" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        run(tmp_path, "--output-dt", "0.02", "--output-every", "2")
    assert exc.value.code == 2 and "not allowed with" in capsys.readouterr().err


def test_csv_on_standard_output(tmp_path, capsys, monkeypatch):
    """-o - writes the CSV to standard output (the report to stderr), the
    same table as a file, and no file named '-'; --plot needs a file."""
    monkeypatch.chdir(tmp_path)
    status, out = run(tmp_path)
    capsys.readouterr()
    assert main(["simulate", str(MODELS / "slider_crank.mbd"), "--t-end", "0.1", "-o", "-"]) == 0
    captured = capsys.readouterr()
    assert not (tmp_path / "-").exists() and "wrote standard output" in captured.err
    (tmp_path / "stdout.csv").write_text(captured.out)
    _, names, values = read_csv_metadata(tmp_path / "stdout.csv")
    _, names_file, values_file = read_csv_metadata(out)
    assert names == names_file and values.shape == values_file.shape
    t, phi = names.index("t"), names.index("crank.phi")
    assert np.array_equal(values[:, [t, phi]], values_file[:, [t, phi]])
    assert main(["simulate", str(MODELS / "slider_crank.mbd"), "-o", "-", "--plot"]) == 2
    assert "give -o FILE" in capsys.readouterr().err


def test_a_csv_slower_to_write_than_the_run_gets_a_note():
    """The line on the written result points at HDF5 and the output options
    when writing the CSV took at least CSV_NOTE_SECONDS and longer than the
    integration (the 100-link chain over 10 s at rtol 1e-3: 38 s of CSV after
    6.4 s of steps), and says nothing more for an HDF5 file, standard output,
    a short write, or a write shorter than the steps."""
    from pathlib import Path

    from mbdsl.io.csvfile import CSV_NOTE_SECONDS, written_report
    slow = {"output": 38.0, "integration": 6.4}
    first, note = written_report(Path("runs/chain.csv"), 68_774, 1414, slow).split("\n")
    assert first == "wrote runs/chain.csv (68774 rows, 1414 columns)"
    assert note.startswith("note: writing 97,246,436 values as CSV took 38 s")
    assert "-o chain.h5" in note and "--output-every" in note and "--columns" in note
    plain = "wrote chain.h5 (68774 rows, 1414 columns)"
    assert written_report(Path("chain.h5"), 68_774, 1414, slow, csv=False) == plain
    assert written_report(None, 2, 3, slow) == "wrote standard output (2 rows, 3 columns)"
    short = {"output": CSV_NOTE_SECONDS - 0.1, "integration": 0.0}
    assert "\n" not in written_report(Path("c.CSV"), 2, 3, short)
    assert "\n" not in written_report(Path("c.csv"), 2, 3, {"output": 38.0, "integration": 40.0})
    assert "\n" not in written_report(Path("c.csv"), 2, 3, {})
