"""The language: expressions, time derivatives, grammar/transformer contract,
the Python-built model, and semantic checks that are not syntax."""

import math
from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.dsl import transformer as T
from mbdsl.dsl.expressions import (ExprError, compile_function, diff, evaluate, substitute)
from mbdsl.dsl.parser import grammar_parser, parse_expression, parse_text
from mbdsl.dsl.spec import (BodySpec, ForceSpec, InitialSpec, JointSpec, ModelSpec,
                            ParameterSpec, SettingSpec)

from ..conftest import MODELS

ROOT = Path(__file__).resolve().parents[2]


def ev(text, **env):
    return evaluate(parse_expression(text), env, allow_t="t" in env, t=env.get("t", 0.0))


def test_precedence_and_functions():
    assert ev("1 + 2 * 3 ^ 2") == 19
    assert ev("-2^2") == -4                 # unary minus binds looser than ^
    assert ev("2^-1") == 0.5
    assert ev("2^3^2") == 512               # right-associative
    assert ev("(1 + 2) * 3") == 9
    assert ev("sqrt(16) + abs(-3) + exp(0) + cos(pi)") == pytest.approx(7.0)
    assert ev("m1 * L1^2 / 12", m1=3.0, L1=0.3) == pytest.approx(0.0225)


@pytest.mark.parametrize("text,code", [("1/0", "E301"), ("sqrt(-1)", "E301"),
                                       ("foo(1)", "E203"), ("x + 1", "E201"), ("t", "E204")])
def test_evaluation_errors(text, code):
    with pytest.raises(ExprError) as info:
        evaluate(parse_expression(text), {})
    assert info.value.code == code


@pytest.mark.parametrize("text", ["3*pi/2 + w*t", "0.5*sin(w*t) + 0.1*t^2", "exp(-t)*cos(3*t)",
                                  "sqrt(1 + t^2)", "tan(t/3) - atan(t)", "t^t", "log(2 + t) / (1 + t)"])
def test_time_derivatives_match_finite_differences(text):
    e = substitute(parse_expression(text), {"w": 2.0})
    f, d1, d2 = compile_function(e), compile_function(diff(e)), compile_function(diff(diff(e)))
    for t in (0.3, 1.1, 2.7):
        h = 1e-4
        # central differences: truncation error ~ h^2 f'''(t) / 6, about 1e-8 here
        assert d1(t) == pytest.approx((f(t + h) - f(t - h)) / (2 * h), rel=1e-6, abs=1e-8)
        assert d2(t) == pytest.approx((d1(t + h) - d1(t - h)) / (2 * h), rel=1e-6, abs=1e-8)


def test_grammar_and_transformer_stay_in_step():
    """Every rule and alias of mbd.lark has a transformer method, and no lark
    Tree survives in the spec of a valid model."""
    from lark import Tree
    parser = grammar_parser()
    names = set()
    for rule in parser.rules:
        kept = [x for x in rule.expansion if not (x.is_term and x.filter_out)]
        if rule.alias is None and rule.options.expand1 and len(kept) == 1:
            continue                          # ?rule passing its only child through
        name = rule.alias or rule.origin.name
        name = getattr(name, "value", name)
        if not str(name).startswith("_") and str(name) not in ("start",):
            names.add(str(name))
    missing = {n for n in names if not hasattr(T.ToSpec, n)}
    assert not missing, f"rules without a transformer method: {missing}"

    def walk(x):
        assert not isinstance(x, Tree), x
        if isinstance(x, (list, tuple)):
            for y in x:
                walk(y)
        elif hasattr(x, "__dataclass_fields__"):
            for f in x.__dataclass_fields__:
                walk(getattr(x, f))
    for path in list((ROOT / "models").glob("*.mbd")) + list((ROOT / "tests/dsl/valid").glob("*.mbd")):
        walk(parse_text(path.read_text(), str(path)))


def test_model_built_in_python_equals_the_parsed_file():
    spec = ModelSpec(
        name="pendulum",
        parameters=[ParameterSpec("L", 1.0), ParameterSpec("m", 1.0),
                    ParameterSpec("phi0", "-pi/2 + pi/6")],
        gravity=(0, -9.81),
        bodies=[BodySpec.rigid("rod", mass="m", inertia="m*L^2/12",
                               points={"O": ("-L/2", 0), "tip": ("L/2", 0)})],
        joints=[JointSpec("O", "revolute", ["ground.origin", "rod.O"])],
        initials=[InitialSpec("rod.phi", "phi0"), InitialSpec("rod.omega", 0)],
        settings=[SettingSpec("method", "hht-i3"), SettingSpec("h", 1e-3), SettingSpec("t_end", 0.5)])
    a = mbdsl.simulate(mbdsl.from_spec(spec))
    b = mbdsl.simulate(mbdsl.load(ROOT / "models" / "pendulum.mbd"), t_end=0.5)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.lam, b.lam)


def test_keyword_options_from_python():
    spec = ModelSpec(name="s", bodies=[BodySpec.rigid("b", 1.0, 0.1)],
                     joints=[JointSpec("P", "prismatic", ["b.cm", "ground.origin"],
                                       options={"direction": (1, 0)})],
                     forces=[ForceSpec("s", "spring_damper", ["ground.origin", "b.cm"],
                                       options={"k": 10, "length": 0.5})],
                     initials=[InitialSpec("b.x", 1.0)])
    model = mbdsl.from_spec(spec)
    sol = mbdsl.simulate(model, h=1e-3, t_end=1.0)
    # a 1 kg mass on a 10 N/m spring along x, free length 0.5, released at x = 1
    w = math.sqrt(10.0)
    x_exact = 0.5 + 0.5 * np.cos(w * sol.t)
    assert np.max(np.abs(sol.column("b.x") - x_exact)) < 1e-5
    assert np.max(np.abs(sol.column("b.y"))) < 1e-12


def test_overrides_and_their_errors():
    path = ROOT / "models" / "pendulum.mbd"
    assert mbdsl.load(path, {"L": "2*0.75"}).parameters["L"] == 1.5
    with pytest.raises(mbdsl.MbdModelError) as info:
        mbdsl.load(path, {"Lx": 2})
    assert info.value.diagnostics[0].code == "E201"
    assert "did you mean 'L'" in info.value.diagnostics[0].hint


def test_unconnected_body_is_a_warning():
    model = mbdsl.load_text("model m\nbody a { mass 1; inertia 1 }\n")
    assert [d.code for d in model.warnings] == ["W401"]
    assert model.dof == 3


def test_dof_counts():
    model = mbdsl.load(ROOT / "models" / "slider_crank.mbd")
    assert (model.n_coordinates, model.n_constraints, model.dof) == (6, 5, 1)
    model = mbdsl.load(ROOT / "tests" / "dsl" / "valid" / "all_elements.mbd")
    assert model.n_constraints == 14


@pytest.mark.parametrize("method, setting, value", [
    ("newmark", "gamma", 0.4), ("newmark", "beta", 0.25), ("hht-i3", "alpha", 0.1),
    ("hht-add", "b", 0.5), ("genalpha", "rho_inf", 1.2)])
def test_the_simulate_section_refuses_a_coefficient_as_the_method_does(method, setting, value):
    """One range per coefficient (``registry.check_coefficient``): the model
    file's check refuses the value the method's constructor refuses, with the
    constructor's message, at the value's line and column."""
    text = (MODELS / "slider_crank.mbd").read_text().replace(
        "simulate { method hht-i3; h 1e-3; t_end 2 }",
        f"simulate {{ method {method}; h 1e-3; t_end 2;\n {setting} {value} }}")
    with pytest.raises(ValueError) as constructor:
        mbdsl.make_method(method, **{setting: value})
    with pytest.raises(mbdsl.MbdModelError) as checked:
        mbdsl.load_text(text, "coef.mbd")
    (d,) = [d for d in checked.value.diagnostics if d.is_error]
    assert d.code == "E303" and str(constructor.value) in d.message
    assert (d.span.line, d.span.column) == (text.splitlines().index(f" {setting} {value} }}") + 1,
                                            len(setting) + 3)



def test_the_check_is_named_passes_each_stating_its_diagnostics():
    """``check_spec`` runs the passes of ``dsl/check/`` in the order it lists
    them, each a function of its own module; every code a module reports is
    named in that module's docstring, so that a reader finds where E303 or
    W301 can come from."""
    import importlib
    import pkgutil
    import re

    from mbdsl.dsl import check
    names = [name for name, _ in check.PASSES]
    assert names == ["parameters", "tables", "loops", "space", "ground", "bodies", "gravity",
                     "joints",
                     "couplers", "drivers", "states", "forces", "initials", "outputs",
                     "settings"]
    assert {fn.__module__ for _, fn in check.PASSES} <= {
        f"mbdsl.dsl.check.{m.name}" for m in pkgutil.iter_modules(check.__path__)}
    for info in pkgutil.iter_modules(check.__path__):
        module = importlib.import_module(f"mbdsl.dsl.check.{info.name}")
        text = Path(module.__file__).read_text()
        body = text.split('"""', 2)[2]
        reported = set(re.findall(r'"([EW]\d{3})"', body))
        assert reported <= set(re.findall(r"\b([EW]\d{3})\b", module.__doc__)), info.name
