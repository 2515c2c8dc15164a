"""Units in model files: conversion to SI (pint), dimension checks, the angle
warning, units of result columns, and the language around them.

Oracles: the same model written in plain SI numbers (its CSV must be equal to
the last digit), the SI values of the units by definition (1 cm = 0.01 m,
1 deg = pi/180 rad, 1 rpm = 2 pi/60 rad/s), and the dimensions of the
quantities by their physics.
"""

import io
import json
import math

import numpy as np
import pytest

import mbdsl
from mbdsl.dsl import units
from mbdsl.dsl.parser import grammar_parser, parse_expression
from mbdsl.dsl.unparse import expr_text
from mbdsl.errors import MbdModelError, MbdSyntaxError
from mbdsl.io.csvfile import write_csv

WITH_UNITS = """model slider_crank_units
parameter L1 = 30 cm
parameter m1 = 3 kg
parameter L2 = 600 mm
gravity (0, -9.81 m/s^2)
body crank { mass m1; inertia m1*L1^2/12; point O (-15 cm, 0); point A (L1/2, 0) }
body rod   { mass 900 g; inertia 0.027 kg*m^2; point A (-L2/2, 0); point B (L2/2, 0) }
joint O: revolute(ground.origin, crank.O)
joint A: revolute(crank.A, rod.A)
joint B: point_on_line(rod.B, ground.origin, direction = (1, 0))
force s: spring_damper(ground.origin, rod.B, k = 100 N/m, c = 5 N*s/m, length = 0 m)
force m: torque(crank, 0.5 N*m)
initial crank.phi = 270 deg
initial crank.omega = 60 rpm
simulate { method hht-i3; h 1 ms; t_end 200 ms }
"""

IN_SI = """model slider_crank_units
parameter L1 = 0.3
parameter m1 = 3
parameter L2 = 0.6
gravity (0, -9.81)
body crank { mass m1; inertia m1*L1^2/12; point O (-0.15, 0); point A (L1/2, 0) }
body rod   { mass 0.9; inertia 0.027; point A (-L2/2, 0); point B (L2/2, 0) }
joint O: revolute(ground.origin, crank.O)
joint A: revolute(crank.A, rod.A)
joint B: point_on_line(rod.B, ground.origin, direction = (1, 0))
force s: spring_damper(ground.origin, rod.B, k = 100, c = 5, length = 0)
force m: torque(crank, 0.5)
initial crank.phi = 3*pi/2
initial crank.omega = 2*pi
simulate { method hht-i3; h 0.001; t_end 0.2 }
"""


def _rows(model, engine):
    sol = mbdsl.simulate(model, engine=engine)
    assert sol.status == "completed"
    buf = io.StringIO()
    path = f"/tmp/units_{engine}_{id(model)}.csv"
    write_csv(sol, path)
    with open(path) as f:
        buf.write("".join(line for line in f if not line.startswith("#")))
    return buf.getvalue()


@pytest.mark.parametrize("engine", ["numpy", "compiled"])
def test_a_model_with_units_gives_the_si_models_csv_to_the_last_digit(engine):
    a, b = mbdsl.load_text(WITH_UNITS), mbdsl.load_text(IN_SI)
    assert a.settings == b.settings
    assert a.parameters == b.parameters
    rows_a, rows_b = _rows(a, engine), _rows(b, engine)
    assert rows_a.count("\n") == 202          # header line and 201 rows
    assert rows_a == rows_b


@pytest.mark.parametrize("text, si", [
    ("15 cm", 0.15), ("600 mm", 0.6), ("900 g", 0.9), ("0.0225 kg*m^2", 0.0225),
    ("1 ms", 0.001), ("2 min", 120.0), ("3 kN", 3000.0), ("210 GPa", 210e9),
    ("5 um", 5e-6), ("1.5 km", 1500.0), ("270 deg", 3 * math.pi / 2),
    ("60 rpm", 2 * math.pi), ("1 rev", 2 * math.pi), ("100 N/m", 100.0),
    ("2 N*m*s/rad", 2.0), ("7 kg*m/s^2", 7.0), ("4 s^-2", 4.0), ("15cm", 0.15),
    ("2.5e-3 m", 2.5e-3),
])
def test_quantities_convert_to_si_exactly(text, si):
    e = parse_expression(text)
    assert e.value == si                          # bit for bit (decimal factors exact)
    assert units.to_si(e.written, e.unit) == si


def test_dimensions_of_units():
    assert units.unit_dimension("N/m") == units.expected("kg/s^2") == (1, 0, -2)
    assert units.unit_dimension("kg*m^2") == units.expected("kg*m^2") == (1, 2, 0)
    assert units.unit_dimension("rpm") == units.expected("rad/s") == (0, 0, -1)
    assert units.unit_dimension("deg") == units.expected("rad") == (0, 0, 0)
    assert units.unit_dimension("GPa") == units.expected("Pa") == (1, -1, -2)
    assert units.unit_dimension("N*m") == units.expected("J") == (1, 2, -2)


def test_the_grammar_reads_the_units_the_module_lists():
    """The QUANTITY terminal of mbd.lark carries units.UNIT_PATTERN verbatim."""
    term = next(t for t in grammar_parser().terminals if t.name == "QUANTITY")
    assert units.UNIT_PATTERN in term.pattern.value
    for sym in units.SYMBOLS:
        assert parse_expression(f"2 {sym}").unit == sym


def test_names_after_numbers_that_are_not_units_keep_their_meaning():
    # h is the step size, not the hour; t is time, not the tonne
    model = mbdsl.load_text("model m\nbody b { mass 1 inertia 0.1 }\n"
                            "joint O: revolute(ground.origin, b.cm)\n"
                            "simulate { t_end 2 h 1e-3 }\n")
    assert model.settings["h"] == 1e-3 and model.settings["t_end"] == 2.0
    assert model.bodies[0].mass == 1.0 and model.bodies[0].inertia == 0.1
    # a unit reads as far as its symbols go: 3 m/L is (3 m)/L
    e = parse_expression("3 m/L")
    assert e.op == "/" and e.left.unit == "m" and e.right.name == "L"


def _diag(text):
    with pytest.raises((MbdModelError, MbdSyntaxError)) as info:
        mbdsl.load_text(text, file="u.mbd")
    return [d for d in info.value.diagnostics if d.is_error]


@pytest.mark.parametrize("line, message, column", [
    ("body b { mass 3 m; inertia 1 }", "mass of body 'b': expected a mass [kg], got a length",
     15),
    ("body b { mass 3; inertia 1 kg*m^2 + 2 kg }",
     "a mass added to a moment of inertia", 26),
    ("body b { mass 3; inertia 1; point P (1 s, 0) }", "expected a length [m], got a time", 38),
    ("body b { mass 3; inertia 1; point P (sin(1 m), 0) }",
     "sin() takes an angle or a plain number, got a length", 38),
    ("body b { mass 3 kg; inertia 3 kg*m }",
     "expected a moment of inertia [kg*m^2], got kg^a m^b s^c = kg*m", 29),
])
def test_a_wrong_dimension_is_an_error_at_its_place(line, message, column):
    errors = _diag(f"model m\n{line}\n")
    assert [d.code for d in errors] == ["E307"]
    assert message in errors[0].message
    assert (errors[0].span.line, errors[0].span.column) == (2, column)


def test_dimension_errors_in_every_kind_of_value():
    base = ("model m\nbody b { mass 1; inertia 0.1; point O (0, 0) }\n"
            "body c { mass 1; inertia 0.1 }\n"
            "joint O: revolute(ground.origin, b.O)\njoint C: revolute(b.cm, c.cm)\n")
    cases = {
        "force s: spring_damper(ground.origin, c.cm, k = 100 N, length = 0)":
            "expected a stiffness (force per length) [N/m], got a force",
        "force s: rotational_spring_damper(C, k = 2 N/m)": "[N*m/rad], got a stiffness",
        "force s: torque(b, 2 N)": "expected a torque or an energy [N*m], got a force",
        "force s: force(c.cm, (1 N*m, 0))": "expected a force [N], got a torque",
        "force s: friction(O, mu = 0.1 m, radius = 1 cm)": "[1], got a length",
        "driver d: b.phi = 2 s": "expected an angle or a plain number [rad], got a time",
        "initial b.omega = 3 m/s": "expected an angular velocity [rad/s], got a velocity",
        "gravity (0, -9.81 m/s)": "expected an acceleration [m/s^2], got a velocity",
        "simulate { h 1 kg }": "expected a time [s], got a mass",
        "simulate { alpha -0.1 s }": "[1], got a time",
        "parameter L = 1 m + 1 s": "a time added to a length",
    }
    for line, message in cases.items():
        errors = _diag(base + line + "\n")
        assert [d.code for d in errors] == ["E307"], line
        assert message in errors[0].message, (line, errors[0].message)
        assert errors[0].span is not None and errors[0].span.line == 6, line


def test_parameters_keep_their_dimensions():
    ok = ("model m\nparameter m = 900 g\nparameter L = 60 cm\nparameter k = 100 N/m\n"
          "parameter w = sqrt(k/m)\nbody b { mass m; inertia m*L^2 }\n"
          "joint O: revolute(ground.origin, b.cm)\ninitial b.omega = w\n")
    model = mbdsl.load_text(ok)
    assert model.bodies[0].inertia == pytest.approx(0.9 * 0.36, rel=1e-15)
    assert model.parameters["w"] == pytest.approx(math.sqrt(100 / 0.9), rel=1e-15)
    errors = _diag(ok.replace("60 cm", "60 s"))
    assert [d.code for d in errors] == ["E307"]
    assert "inertia of body 'b': expected a moment of inertia [kg*m^2], got " \
           "kg^a m^b s^c = kg*s^2" in errors[0].message
    errors = _diag(ok.replace("initial b.omega", "initial b.x"))
    assert "initial b.x: expected a length [m], got an angular velocity" in errors[0].message
    # a plain number in a product leaves the product undetermined (it may be
    # an SI length): m*L^2/12 is not checked, and never falsely refused
    assert mbdsl.load_text(ok.replace("m*L^2", "m*L^2/12").replace("60 cm", "60 s"))
    # plain numbers and parameters without units are SI of any kind: never a false error
    mixed = mbdsl.load_text("model m\nparameter L = 0.6\nbody b { mass 2; inertia 2*L^2/12; "
                            "point P (L/2 + 5 cm, 0.1 + 1 mm) }\n")
    assert mixed.bodies[0].points["P"][0] == pytest.approx(0.35, rel=1e-15)


def test_an_angle_above_a_turn_without_a_unit_is_a_warning():
    text = ("model m\nbody rod { mass 1; inertia 0.1; point O (-0.5, 0) }\n"
            "joint O: revolute(ground.origin, rod.O)\ninitial rod.phi = {}\n")
    model = mbdsl.load_text(text.replace("{}", "270"))
    assert [d.code for d in model.warnings] == ["W301"]
    assert "270 rad is more than a full turn" in model.warnings[0].message
    assert "270 deg" in model.warnings[0].hint
    assert model.warnings[0].span.line == 4
    for written in ("270 deg", "3*pi/2", "-6.2", "4 rev"):
        assert not mbdsl.load_text(text.replace("{}", written)).warnings, written
    spring = ("model m\nbody b { mass 1; inertia 0.1 }\njoint O: revolute(ground.origin, b.cm)\n"
              "force s: rotational_spring_damper(O, k = 1, angle = 90)\n")
    assert [d.code for d in mbdsl.load_text(spring).warnings] == ["W301"]


def test_columns_carry_their_units_in_csv_hdf5_and_plots(tmp_path):
    model = mbdsl.load_text(WITH_UNITS + "output tip = rod.B.x + 5 cm\n"
                            "output moment = reaction.O.fx * 10 cm\noutput plain = 2*rod.B.x\n")
    sol = mbdsl.simulate(model, t_end=0.01)
    u = sol.column_units()
    assert list(u) == sol.columns
    expected = {"t": "s", "crank.x": "m", "crank.phi": "rad", "rod.vy": "m/s",
                "crank.omega": "rad/s", "rod.ax": "m/s^2", "rod.alpha": "rad/s^2",
                "energy.total": "J", "lambda.O.0": "N", "lambda.B.0": "N",
                "reaction.A.fy": "N", "reaction.A.torque": "N*m", "output.tip": "m",
                "output.moment": "N*m", "output.plain": "", "constraint.position": "",
                "step.h": "s", "newton.iterations": ""}
    assert {k: u[k] for k in expected} == expected
    csv = tmp_path / "r.csv"
    mbdsl.write_solution(sol, csv)
    head = [line for line in csv.read_text().splitlines() if line.startswith("# units: ")]
    assert json.loads(head[0][len("# units: "):]) == u
    h5 = tmp_path / "r.h5"
    mbdsl.write_solution(sol, h5)
    import h5py
    with h5py.File(h5) as f:
        assert json.loads(f.attrs["units"]) == u
    fig = mbdsl.plot(mbdsl.load_solution(csv), y=["output.tip", "crank.phi", "lambda.O.1"])
    assert [ax.get_ylabel() for ax in fig.axes] == ["output.tip [m]", "crank.phi [rad]",
                                                    "lambda.O.1 [N]"]
    assert fig.axes[-1].get_xlabel() == "t [s]"


def test_driver_and_fixed_joint_multipliers_have_load_units():
    model = mbdsl.load_text(
        "model m\nbody a { mass 1; inertia 0.1 }\nbody b { mass 1; inertia 0.1 }\n"
        "joint O: revolute(ground.origin, a.cm)\njoint F: fixed(a.cm, b.cm)\n"
        "driver d: O.angle = t\n")
    u = mbdsl.simulate(model, t_end=0.002, h=1e-3).column_units()
    assert [u[f"lambda.F.{k}"] for k in range(3)] == ["N", "N", "N*m"]
    assert u["lambda.d.0"] == "N*m" and u["driver.d.torque"] == "N*m"


def test_units_are_written_back_as_written():
    e = parse_expression("(2 kg)*m + 15 cm*L")
    text = expr_text(e)
    assert text == "(2 kg)*m + (15 cm)*L"
    again = parse_expression(text)
    assert expr_text(again) == text
    assert again.left.left.value == 2.0 and again.right.left.value == 0.15
    model = mbdsl.load_text(WITH_UNITS)
    from mbdsl.dsl.unparse import spec_text
    src = spec_text(mbdsl.parse_text(WITH_UNITS))
    assert "inertia 0.027 kg*m^2" in src and "initial crank.phi = 270 deg" in src
    again = mbdsl.load_text(src)
    assert again.parameters == model.parameters
    assert [b.inertia for b in again.bodies] == [b.inertia for b in model.bodies]


def test_a_plain_model_does_not_import_pint():
    import subprocess
    import sys
    code = ("import sys, mbdsl; mbdsl.load('models/slider_crank.mbd'); "
            "print('pint' in sys.modules)")
    from ..conftest import ROOT
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout.strip()
    assert out == "False"
    assert np.isfinite(units.to_si("1", "kg"))
