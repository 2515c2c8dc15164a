"""Malformed model files give the expected code, line and column, exit 1, no traceback."""

import subprocess
import sys
from pathlib import Path

import pytest

from mbdsl.cli.main import main

INVALID = Path(__file__).parent / "invalid"

#: file -> (code, line, column) of the first error
EXPECTED = {
    "e101_bad_character.mbd": ("E101", 2, 19),
    "e103_end_of_file.mbd": ("E103", 4, 22),
    "e104_parameter_without_equals.mbd": ("E104", 2, 13),
    "e105_option_without_equals.mbd": ("E105", 3, 47),
    "e108_unclosed_block.mbd": ("E108", 4, 1),
    "e201_unknown_body.mbd": ("E201", 4, 34),
    "e202_duplicate_body.mbd": ("E202", 3, 6),
    "e204_time_in_parameter.mbd": ("E204", 2, 19),
    "e206_unknown_method.mbd": ("E206", 5, 19),
    "e302_missing_inertia.mbd": ("E302", 3, 6),
    "e303_negative_mass.mbd": ("E303", 3, 17),
    "e401_redundant_joint.mbd": ("E401", 10, 7),
    "e401_parallelogram_with_initial.mbd": ("E401", 13, 7),   # not E501: DOF by rank
    "e503_inconsistent_joints.mbd": ("E503", 4, 7),
    "e501_too_many_initials.mbd": ("E501", 6, 1),
}


def test_every_invalid_file_has_an_expectation():
    assert sorted(p.name for p in INVALID.glob("*.mbd")) == sorted(EXPECTED)
    assert len(EXPECTED) >= 10


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_check_reports_code_line_column(name, capsys):
    code, line, col = EXPECTED[name]
    path = INVALID / name
    status = main(["check", str(path)])
    err = capsys.readouterr().err
    assert status == 1
    assert f"error[{code}]" in err
    assert f"{path}:{line}:{col}" in err
    assert "^" in err                      # the caret under the offending token
    assert "Traceback" not in err


@pytest.mark.parametrize("name", ["e201_unknown_body.mbd", "e104_parameter_without_equals.mbd"])
def test_simulate_on_invalid_file_exits_1_without_traceback(name, tmp_path):
    proc = subprocess.run([sys.executable, "-m", "mbdsl", "simulate", str(INVALID / name),
                           "-o", str(tmp_path / "x.csv")], capture_output=True, text=True)
    assert proc.returncode == 1
    assert "Traceback" not in proc.stderr and "error[E" in proc.stderr
    assert not (tmp_path / "x.csv").exists()


def test_all_errors_of_a_file_are_reported_at_once(tmp_path, capsys):
    path = tmp_path / "many.mbd"
    path.write_text("model m\nbody a { mass 0; inertia 1 }\nbody b { inertia -1 }\n"
                    "joint j: revolut(ground.origin, a.cm)\n")
    assert main(["check", str(path)]) == 1
    err = capsys.readouterr().err
    for code in ("E303", "E302", "E205"):
        assert f"error[{code}]" in err
    assert "did you mean 'revolute'" in err
