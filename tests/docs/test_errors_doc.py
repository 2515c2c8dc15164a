"""docs/errors.md: every code has an example, and every example produces its code."""

import re
import shlex
from pathlib import Path

import pytest

from mbdsl.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "errors.md").read_text()
SECTION = re.compile(r"^## ([EW]\d{3}):.*?\n(.*?)(?=^## |\Z)", re.M | re.S)
BLOCK = re.compile(r"```(mbd|sh)\n(.*?)```", re.S)
EXAMPLES = {code: BLOCK.search(body).groups() for code, body in SECTION.findall(DOC)}


def test_every_code_of_the_source_is_documented():
    source = "".join(p.read_text() for p in (ROOT / "mbdsl").rglob("*.py"))
    emitted = set(re.findall(r"\"([EW]\d{3})\"", source))
    assert emitted == set(EXAMPLES), (emitted ^ set(EXAMPLES))


@pytest.mark.parametrize("code", sorted(EXAMPLES))
def test_example_produces_its_code(code, tmp_path, capsys, monkeypatch):
    kind, text = EXAMPLES[code]
    monkeypatch.chdir(tmp_path)
    if kind == "sh":
        argv = shlex.split(text.strip())[1:]           # drop "mbdsl"
    else:
        (tmp_path / "example.mbd").write_text(text)
        argv = ["simulate", "example.mbd", "-q", "-o", "out.csv"]
        if "t_end" not in text:
            argv += ["--h", "1e-3", "--t-end", "0.01"]
    status = main(argv)
    err = capsys.readouterr().err
    kind_word = "warning" if code.startswith("W") else "error"
    assert f"{kind_word}[{code}]" in err, err
    assert "Traceback" not in err
    # a warning's example completes (exit 0), unless its text shows a run that
    # also stops (E602 beside W603: exit 3)
    expected = 0 if code.startswith("W") else None
    if code.startswith("W") and re.search(r"also stops \(E6\d\d[^)]*exit 3",
                                          dict(SECTION.findall(DOC))[code]):
        expected = 3
    assert (status == expected) if expected is not None else status != 0


def _named(code):
    """The backticked names of a section's text after its example."""
    body = dict(SECTION.findall(DOC))[code]
    return set(re.findall(r"`([a-z0-9_-]+)`", body.split("```")[-1]))


def test_the_kinds_and_methods_listed_are_the_languages():
    from mbdsl import METHODS
    from mbdsl.dsl.check import FORCE_KINDS, JOINT_KINDS
    from mbdsl.dsl.check.spatial import SPATIAL_JOINT_KINDS
    from mbdsl.dsl.check.tables import COUPLER_KINDS
    assert _named("E205") == (set(JOINT_KINDS) | set(COUPLER_KINDS) | set(FORCE_KINDS)
                              | set(SPATIAL_JOINT_KINDS))
    assert _named("E206") == set(METHODS)
