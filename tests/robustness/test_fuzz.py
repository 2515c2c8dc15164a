"""Bad input never crashes: mutated shipped models give a valid model or diagnostics.

Every mutated text must end in one of: a Model that simulates a few steps
to finite values or stops with E6xx diagnostics; an AssemblyError with
diagnostics; an MbdError whose errors carry a line and column. Any other
exception, a hang (deadline), or a non-finite state in a "completed" run
fails the test. CI runs 600 derandomized examples (about 15 s);
``-m nightly`` runs 20000 random ones (also marked slow, so CI skips them).
"""

import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mbdsl
from mbdsl import AssemblyError, MbdError
from mbdsl.io.observers import RunObserver

from ..conftest import MODELS

# overflow in extreme inputs is expected and handled; its RuntimeWarnings are noise here
pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")

TEXTS = {p.name: p.read_text() for p in sorted(MODELS.glob("*.mbd"))}
# models built from components: a local one (instances, paths) and the library's (import)
COMPONENTS = MODELS.parent / "tests" / "dsl" / "components"
TEXTS.update({p.name: p.read_text() for p in (COMPONENTS / "wishbone.mbd",
                                              COMPONENTS / "slider_crank_parts.mbd")})
TOKEN = re.compile(r"\s+|[A-Za-z_]\w*|\d+(?:\.\d*)?(?:[eE][+-]?\d+)?|\.\.|.", re.S)
NUMBERS = ["0", "-0", "-1", "-2.5", "1e308", "1e-308", "1e400", "nan", "inf", "-inf", "3",
           "0.5", "1e-12", "1e12", "2^1024", "1/0", "0/0", "1e", "١", "½", "--1", "1..2"]
INSERTS = ["kg", "m/s", "{", "}", "(", ")", ",", ";", "=", ":", "..", "é", "→", "\u200b",
           "\U0001f600", "\n", "#", "\\", "\"", "'", "for i in 1..3 {", "t", "pi", "ground",
           "revolute", "body", "joint", "initial", "guess", "driver", "force", "[", "]", "^",
           # the state in force expressions, joint torques and distance drivers
           ".", "omega", "rate", "angle", "distance", "crank.omega", "O.rate", "joint_torque",
           "torque", "prismatic",
           # static starts and output lines
           "static", "initial static\n", "output", "output x = crank.A.y\n", "reaction",
           # friction in joints
           "friction", "mu", "radius", "mu_static", "v_stribeck", "viscous", "v_reg",
           "force f: friction(P, mu = 0.3)\n", "force f: friction(O, mu = 0.1, radius = 0.01)\n",
           # drawn shapes
           "shape", "line", "circle", "polygon", "shape line(E, T)", "shape circle(cm, 0.1); ",
           # distance joints, indexed points, ground points in for blocks
           "distance", "length", "joint R: distance(ground.origin, crank.A, length = 0.2)\n",
           "P[1]", "ground.P[i]", "for i in 1..2 { ground { point P[i] (i, 0) } }\n",
           # comparisons and if
           "<", ">=", "if", "if(t < 1, 0, 1)", " < ", "(t > 2)*",
           # units
           " cm", " deg", " rpm", " N/m", " kg*m^2", " s", " ms", "m^2", "*m", "/s", " mm",
           "5 mm", "(2 kg)*", " + 1 s", "1e400 kg", "initial crank.phi = 270\n",
           # particles
           "particle", "particle q { mass 1 }\n", "q.cm", "particle q { mass 1; inertia 1 }\n",
           "joint Q: distance(ground.origin, q.cm, length = 1)\n",
           # components, instances and imports
           "component", "import", "library", "parts", "parts.Link", "import parts\n",
           "import \"nowhere.mbd\"\n", "parts.Link x(L = 1)\n", "Arm w(L = 2 kg)\n",
           "upper.b.O", "upper.L", "crank.b", "component C(a) { body b { mass a; inertia 1 } }\n",
           "C c\n", "for i in 1..2 { parts.Link l[i](m = i) }\n", "l[1].b.B", "as"]


def tokens(text):
    return TOKEN.findall(text)


@st.composite
def mutated(draw):
    name = draw(st.sampled_from(sorted(TEXTS)))
    toks = tokens(TEXTS[name])
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(toks) - 1))
        op = draw(st.sampled_from(["delete", "duplicate", "swap", "number", "insert", "number"]))
        if op == "delete":
            del toks[i]
        elif op == "duplicate":
            toks.insert(i, toks[i])
        elif op == "swap" and i + 1 < len(toks):
            toks[i], toks[i + 1] = toks[i + 1], toks[i]
        elif op == "number":
            numeric = [k for k, t in enumerate(toks) if t[:1].isdigit()]
            k = numeric[i % len(numeric)]
            toks[k] = draw(st.sampled_from(NUMBERS))
        elif op == "insert":
            toks.insert(i, draw(st.sampled_from(INSERTS) | st.text(min_size=1, max_size=2)))
    return name, "".join(toks)


def check_text(text):
    """The property: one of the allowed outcomes, never anything else."""
    try:
        model = mbdsl.load_text(text, file="fuzz.mbd")
    except MbdError as exc:
        assert exc.diagnostics, "an MbdError without diagnostics"
        for d in exc.diagnostics:
            if d.is_error:
                assert d.code and d.message
                if d.span is not None:
                    assert d.span.line >= 1 and d.span.column >= 1
        assert any(d.is_error and d.span is not None for d in exc.diagnostics) or \
            any(d.code in ("E103", "E107", "E108") for d in exc.diagnostics)
        return "rejected"
    h = model.settings.get("h", 1e-3)
    h = h if 1e-9 < h < 0.1 else 1e-3
    try:
        sol = mbdsl.simulate(model, h=h, t_end=3 * h, on_failure="return",
                             observers=(StepBudget(),))
    except OverBudget:
        return "over budget"
    except AssemblyError as exc:
        assert exc.diagnostics and all(d.code.startswith(("E4", "E5")) for d in exc.diagnostics
                                       if d.is_error)
        return "not assembled"
    assert sol.status in ("completed", "failed")
    if sol.status == "failed":
        assert sol.diagnostics and sol.diagnostics[0].code.startswith("E6")
        return "failed with a message"
    for x in (sol.q, sol.v, sol.a, sol.lam):
        assert np.all(np.isfinite(x)), "a completed run with non-finite values"
    return "ran"


class OverBudget(Exception):
    """A mutated model whose three steps' worth of time takes more than
    ``StepBudget.ROWS`` error-controlled steps."""


class StepBudget(RunObserver):
    """Ends a run past ``ROWS`` recorded steps (its rows reach the observer
    in chunks; whether a run passes the budget does not depend on when):
    a mutation such as ``gravity (1e12, -9.81)`` on the pendulum against a
    joint limit under a tolerance asks for a rod turning at 1.4e6 rad/s,
    steps of 5e-12 s, a billion steps to its end. The run is honest, but
    not one for a test of bad input."""

    ROWS = 200_000

    def on_rows(self, sol, start, stop):
        """Raise OverBudget past ROWS rows."""
        if stop > self.ROWS:
            raise OverBudget


@settings(max_examples=int(__import__("os").environ.get("MBDSL_FUZZ", 600)), deadline=10_000, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_models_never_crash(case):
    name, text = case
    check_text(text)


@pytest.mark.nightly
@pytest.mark.slow
@settings(max_examples=20000, deadline=10_000, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_models_never_crash_nightly(case):
    name, text = case
    check_text(text)


@pytest.mark.parametrize("text", [
    "model m\nparameter a = 1e308 * 10\n",
    "model m\nbody b { mass nan; inertia 1 }\n",
    "model m\nbody b { mass 1; inertia 1e-320; point A (1e308, 0) }\n"
    "joint J: revolute(ground.origin, b.A)\n",
    "model m\nparameter N = 1e9\nfor i in 1..N { body b[i] { mass 1; inertia 1 } }\n",
    "model m\n\x00\n",
    "model m\ngravity (0, -1e308)\nbody b { mass 1e308; inertia 1e308; point A (1, 0) }\n"
    "joint J: revolute(ground.origin, b.A)\nsimulate { h 1e-3; t_end 0.01 }\n",
])
def test_extreme_values(text):
    assert check_text(text) in ("rejected", "not assembled", "failed with a message", "ran")
