"""Models built in Python are written in the language: their result files
read back, plot and animate like those of model files.

Oracle: parsing the written text gives the same model (the same assembled
state to the last bit) on every shipped and test model, and writing it again
gives the same text.
"""

from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl import BodySpec, InitialSpec, JointSpec, ModelSpec
from mbdsl.cli.main import main
from mbdsl.dsl.expressions import Binary, Num, Unary
from mbdsl.dsl.grammar import as_expr
from mbdsl.dsl.parser import parse_text
from mbdsl.dsl.unparse import expr_text, spec_text

from ..conftest import MODELS

ROOT = Path(__file__).resolve().parents[2]
FILES = sorted(MODELS.glob("*.mbd")) + sorted((ROOT / "tests" / "dsl" / "valid").glob("*.mbd"))


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_written_text_is_the_same_model(path):
    text = spec_text(parse_text(path.read_text(), str(path)))
    assert spec_text(parse_text(text, "again.mbd")) == text
    first, second = mbdsl.load(path), mbdsl.load_text(text)
    policy = mbdsl.redundant_policy(first)          # redundant joints: as a run takes them
    a = mbdsl.consistent_initial_state(mbdsl.assemble(first), redundant=policy)
    b = mbdsl.consistent_initial_state(mbdsl.assemble(second), redundant=policy)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.v, b.v) and np.array_equal(a.lam, b.lam)


@pytest.mark.parametrize("tree", [
    Binary("-", Num(1.0), Binary("-", Num(2.0), Num(3.0))),       # 1 - (2 - 3)
    Binary("^", Num(2.0), Binary("^", Num(3.0), Num(2.0))),       # right-associative
    Binary("^", Binary("^", Num(2.0), Num(3.0)), Num(2.0)),       # (2^3)^2
    Unary("-", Binary("^", Num(2.0), Num(2.0))),                  # -(2^2)
    Binary("^", Unary("-", Num(2.0)), Num(2.0)),                  # (-2)^2
    Binary("/", Num(1.0), Binary("*", Num(2.0), Num(4.0))),       # 1/(2*4)
    Binary("*", Num(-0.1), Num(3.0)),
    Num(0.1 + 0.2), Num(1e-300), Num(6.02e23),
    Binary("max", Num(-1.0), Binary("min", Binary("*", Num(2.0), Num(3.0)), Num(1.0))),  # clip
    Binary("^", Binary("min", Num(2.0), Num(3.0)), Num(2.0)),
])
def test_expressions_keep_their_tree_and_numbers(tree):
    from mbdsl.dsl.expressions import evaluate, simplify
    back = as_expr(expr_text(tree))
    # the same value to the last bit (a negative number comes back as a negation)
    assert evaluate(back, {}) == evaluate(tree, {})
    assert expr_text(as_expr(expr_text(back))) == expr_text(back)
    assert expr_text(simplify(back)) == expr_text(simplify(tree))


def test_result_of_a_python_built_model_reads_back_plots_and_animates(tmp_path):
    spec = ModelSpec(
        name="pendulum", gravity=(0, -9.81),
        bodies=[BodySpec.rigid("rod", mass=1.0, inertia="1/12", points={"O": (-0.5, 0)})],
        joints=[JointSpec("O", "revolute", ["ground.origin", "rod.O"])],
        initials=[InitialSpec("rod.phi", "-pi/3")])
    sol = mbdsl.simulate(mbdsl.from_spec(spec), h=1e-3, t_end=0.2)
    for suffix in (".h5", ".csv"):
        path = tmp_path / f"api{suffix}"
        mbdsl.write_solution(sol, path)
        back = mbdsl.load_solution(path)
        np.testing.assert_array_equal(back.q, sol.q)
        assert main(["plot", str(path), "-o", str(tmp_path / f"api{suffix}.png")]) == 0
    assert main(["animate", str(tmp_path / "api.h5"), "-o", str(tmp_path / "api.gif"),
                 "--fps", "5"]) == 0
    assert (tmp_path / "api.gif").stat().st_size > 0


def test_piecewise_functions_parse_and_their_arity_is_checked():
    from mbdsl.dsl.expressions import evaluate
    assert evaluate(as_expr("clip(5, -1, 2) + min(3, 4) - max(-2, -3)"), {}) == 2 + 3 + 2
    with pytest.raises(mbdsl.MbdModelError) as info:
        mbdsl.load_text("model m\nparameter a = min(1, 2, 3)\n", "m.mbd")
    d = info.value.diagnostics[0]
    assert d.code == "E203" and "'min' takes 2 arguments, got 3" in d.message
