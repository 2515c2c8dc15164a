"""Couplers between joint coordinates: gears, racks and linear couplers.

Oracles: the reduced one-degree-of-freedom ODE each coupled pair is (two
flywheels meshed n:1 spin up as one body of the reflected inertia
J1 + J2/n^2; a pinion driving a rack as one of J + m r^2), in closed form
for constant torques (q = a t^2 / 2, which every method but the BDF pair
integrates exactly) and as the same method's run on the one body; the
coupler's load on each shaft from that body's own equation of motion
(J2 theta2'' on the driven shaft, m s'' on the rack); the language's
diagnostics for every misuse. The kernels' rows against an independent
numpy evaluation are in ``tests/assembly/test_constraint_kernels.py``
(``coupler_elements.mbd``), their derivatives against finite differences
in ``test_derivatives.py``.
"""

import math
from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import AssemblyError, MbdModelError

METHODS = ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
           "genalpha-si2"]
#: the methods whose start-up is exact on q = a t^2 / 2 (the BDF pair starts with
#: lower-order steps, whose O(h^2) error on the first step stays in q)
EXACT_ON_QUADRATICS = [m for m in METHODS if not m.startswith("nstiff")]

J1, J2, N, TAU, PHI0 = 0.3, 0.8, 3.0, 1.5, 0.2

GEAR = f"""model gear_pair
body w1 {{ mass 1; inertia {J1} }}
body w2 {{ mass 2; inertia {J2} }}
ground {{ point A (0, 0); point B (0.4, 0) }}
joint J1: revolute(ground.A, w1.cm)
joint J2: revolute(ground.B, w2.cm)
joint G: gear(J1, J2, ratio = {N})
force drive: torque(w1, {TAU})
initial w1.phi = {PHI0}
"""

ONE_BODY = f"""model reflected
body w {{ mass 1; inertia {J1 + J2 / N ** 2!r} }}
joint J: revolute(ground.origin, w.cm)
force drive: torque(w, {TAU})
initial w.phi = {PHI0}
"""


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("method", METHODS)
def test_a_gear_pair_spins_up_as_one_body_with_the_reflected_inertia(method, engine):
    """theta1'' (J1 + J2/n^2) = tau, theta2 = theta1 / n from the placed start
    (w2 at 0, w1 at 0.2 rad: the teeth mesh as placed); the gear's load on
    the driven shaft is J2 theta2'' = J2 tau / (n (J1 + J2/n^2))."""
    T, h = 1.0, 1e-2
    sol = mbdsl.simulate(mbdsl.load_text(GEAR), method=method, h=h, t_end=T, engine=engine)
    one = mbdsl.simulate(mbdsl.load_text(ONE_BODY), method=method, h=h, t_end=T, engine=engine)
    assert sol.completed and sol.engine == engine
    acc = TAU / (J1 + J2 / N ** 2)
    th1 = sol.column("w1.phi") - PHI0
    th2 = sol.column("w2.phi")
    np.testing.assert_allclose(th1, one.column("w.phi") - PHI0, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(sol.column("w1.omega"), one.column("w.omega"), rtol=1e-10,
                               atol=1e-13)
    np.testing.assert_allclose(th2, th1 / N, rtol=1e-12, atol=1e-15)
    if method in EXACT_ON_QUADRATICS:
        t = sol.column("t")
        np.testing.assert_allclose(th1, acc * t ** 2 / 2, rtol=1e-10, atol=1e-14)
    # the tooth load: on the driven shaft J2 theta2'', on the driving one the rest
    # of the torque (tau - J1 theta1''); HHT-ADD's lambda from its index-1 system
    on2 = sol.column("coupler.G.J2.angle.torque")[1:]
    on1 = sol.column("coupler.G.J1.angle.torque")[1:]
    np.testing.assert_allclose(on2, J2 * acc / N, rtol=1e-8)
    np.testing.assert_allclose(on1, -(TAU - J1 * acc), rtol=1e-8)
    # ... which is the driven shaft's own J2 theta2'' (every method's acceleration
    # columns are the motion's, HHT-ADD's from its index-1 system too)
    np.testing.assert_allclose(on2, J2 * sol.column("w2.alpha")[1:], rtol=1e-8)


RACK = """model rack_pinion
gravity (0, -9.81)
body pinion { mass 1; inertia 0.5 }
body slide { mass 2; inertia 0.1 }
ground { point S (0, 0.1) }
joint Jp: revolute(ground.S, pinion.cm)
joint Jr: prismatic(slide.cm, ground.origin, direction = (1, 0))
joint R: rack(Jr, Jp, radius = 0.1)
force drive: torque(pinion, 1)
"""


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "genalpha", "newmark"])
def test_a_pinion_drives_a_rack_as_one_body(method):
    """(J + m r^2) theta'' = tau, s = r theta; the tooth force along the rack
    is m s'' (gravity is carried by the guide, not the teeth)."""
    J, m, r, tau, T = 0.5, 2.0, 0.1, 1.0, 1.0
    sol = mbdsl.simulate(mbdsl.load_text(RACK), method=method, h=1e-2, t_end=T)
    assert sol.completed
    acc = tau / (J + m * r ** 2)
    t = sol.column("t")
    np.testing.assert_allclose(sol.column("pinion.phi"), acc * t ** 2 / 2, rtol=1e-10,
                               atol=1e-14)
    np.testing.assert_allclose(sol.column("slide.x"), r * acc * t ** 2 / 2, rtol=1e-10,
                               atol=1e-14)
    np.testing.assert_allclose(sol.column("coupler.R.Jr.distance.force")[1:], m * r * acc,
                               rtol=1e-8)
    np.testing.assert_allclose(sol.column("coupler.R.Jp.angle.torque")[1:],
                               -(tau - J * acc), rtol=1e-8)


def test_a_rack_on_a_turning_arm_holds_its_relation_as_the_line_turns():
    """A rack whose line turns with an arm (the distance's Hessian in the
    Newton matrix, its (Phi_q v)_q in gamma): the relation s - r theta holds
    to round-off at every step, and the run agrees with the numpy engine."""
    path = Path(__file__).resolve().parents[1] / "dsl" / "valid" / "coupler_elements.mbd"
    model = mbdsl.load(path)
    sols = [mbdsl.simulate(model, method="hht-si2", h=1e-3, t_end=1.0, engine=e)
            for e in ("compiled", "numpy")]
    for sol in sols:
        assert sol.completed
        assert np.max(np.abs(sol.column("constraint.position"))) < 1e-11
        assert np.max(np.abs(sol.column("constraint.velocity"))) < 1e-9
    np.testing.assert_allclose(sols[0].q[-1], sols[1].q[-1], rtol=1e-8, atol=1e-10)


def test_the_gear_constant_is_the_value_given_or_the_placed_one():
    """Without ``value`` the relation's value as placed is held (w1 starts at
    0.2 rad: theta1 - 3 theta2 = 0.2); with it, that value (the bodies'
    placement is moved to meet it)."""
    placed = mbdsl.simulate(mbdsl.load_text(GEAR), method="hht-i3", h=1e-2, t_end=0.2)
    rel = placed.column("w1.phi") - N * placed.column("w2.phi")
    np.testing.assert_allclose(rel, PHI0, atol=1e-13)
    given = mbdsl.load_text(GEAR.replace(f"ratio = {N})", f"ratio = {N}, value = -0.4)"))
    assert given.couplers[0].value == -0.4
    sol = mbdsl.simulate(given, method="hht-i3", h=1e-2, t_end=0.2)
    rel = sol.column("w1.phi") - N * sol.column("w2.phi")
    np.testing.assert_allclose(rel, -0.4, atol=1e-13)
    assert sol.column("w1.phi")[0] == pytest.approx(PHI0)     # held by its initial line


def test_a_coupler_counts_one_row_and_reads_as_a_relation():
    model = mbdsl.load_text(GEAR.replace(f"joint G: gear(J1, J2, ratio = {N})",
                                         "joint G: coupler(J1.angle - 3 * J2.angle + 0.1, "
                                         "value = 0.3)"))
    (c,) = model.couplers
    assert c.kind == "coupler" and c.coefficients == (1.0, -3.0)
    assert c.value == pytest.approx(0.2)        # J1 - 3 J2 = 0.3 - 0.1
    assert model.n_constraints == 5 and model.dof == 1
    assert ("G", 0) in model.constraint_names()


THREE = """model gear_train
body a { mass 1; inertia 0.1 }
body b { mass 1; inertia 0.1 }
body c { mass 1; inertia 0.1 }
ground { point A (0, 0); point B (1, 0); point C (2, 0) }
joint Ja: revolute(ground.A, a.cm)
joint Jb: revolute(ground.B, b.cm)
joint Jc: revolute(ground.C, c.cm)
joint G1: gear(Ja, Jb, ratio = 2)
joint G2: gear(Jb, Jc, ratio = 3)
joint G3: gear(Ja, Jc, ratio = RATIO)
force drive: torque(a, 1)
"""


def test_a_redundant_gear_loop_is_named_and_runs_as_one_train():
    """Three gears in a loop whose ratios agree (2 x 3 = 6) repeat one
    relation: W405 names the gear that repeats the others, the run goes on
    with the augmented formulation and the train spins up as one body,
    theta_a'' (Ja + Jb/2^2 + Jc/6^2) = tau."""
    model = mbdsl.load_text(THREE.replace("RATIO", "6"), "train.mbd")
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-2, t_end=0.5)
    assert sol.completed and sol.formulation == "augmented"
    (w,) = sol.initial.warnings
    assert w.code == "W405" and w.span.line == 11
    assert "row 0 of 'G3' repeats the equations of joints 'G1', 'G2'" in w.message
    acc = 1.0 / (0.1 + 0.1 / 4 + 0.1 / 36)
    t = sol.column("t")
    np.testing.assert_allclose(sol.column("a.phi"), acc * t ** 2 / 2, rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(sol.column("c.phi"), sol.column("a.phi") / 6, rtol=1e-12,
                               atol=1e-15)


def test_a_locked_gear_loop_is_named():
    """Ratios that disagree (2 x 3 != 5) lock the train: W402 says nothing
    can move (DOF by rank 0), and nothing does; the torque is held by the
    teeth."""
    model = mbdsl.load_text(THREE.replace("RATIO", "5"), "train.mbd")
    assert model.dof == 0
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-2, t_end=0.1)
    assert sol.completed
    assert [d.code for d in sol.initial.warnings] == ["W402"]
    assert np.max(np.abs(sol.q[:, [2, 5, 8]])) < 1e-12
    # the shafts' torques balance: on a, -1 N m from the teeth
    loads = sum(sol.column(f"coupler.{g}.Ja.angle.torque")[-1] for g in ("G1", "G3"))
    assert loads == pytest.approx(-1.0, rel=1e-9)


@pytest.mark.parametrize("line, code, where, text", [
    ("joint G: gear(J1, P, ratio = 2)", "E305", "P", "prismatic joint"),
    ("joint G: gear(J1, nope, ratio = 2)", "E201", "nope", "expected the name of a joint"),
    ("joint G: gear(J1, J2, ratio = 0)", "E303", "0", "non-zero"),
    ("joint G: gear(J1, J2)", "E304", "gear", "missing option 'ratio'"),
    ("joint G: rack(J1, J2, radius = 0.1)", "E305", "J1", "revolute joint"),
    ("joint G: rack(P, J2, radius = -0.1)", "E303", "-0.1", "positive"),
    ("joint G: coupler(J1.angle * J2.angle)", "E305", "J1.angle", "not linear"),
    ("joint G: coupler(J1.rate - J2.angle)", "E305", "J1.rate", "is a rate"),
    ("joint G: coupler(J1.angle - t)", "E305", "J1.angle", "reads time"),
    ("joint G: gear(J1, J2, ratio = 2 m)", "E307", "2 m", "got a length"),
])
def test_misused_couplers_are_errors_at_their_place(line, code, where, text):
    src = f"""model bad
body w1 {{ mass 1; inertia 0.1 }}
body w2 {{ mass 1; inertia 0.1 }}
body s {{ mass 1; inertia 0.1 }}
ground {{ point A (0, 0); point B (1, 0) }}
joint J1: revolute(ground.A, w1.cm)
joint J2: revolute(ground.B, w2.cm)
joint P: prismatic(s.cm, ground.origin, direction = (1, 0))
{line}
"""
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(src, "bad.mbd")
    (d,) = [d for d in err.value.diagnostics if d.is_error]
    assert d.code == code, d
    assert text in d.message, d.message
    assert d.span.line == 9
    col = line.index(where) + 1
    assert d.span.column in (col, line.index(":") + 3), (d.span, col)


def test_the_coupler_kinds_are_named_when_a_joint_kind_is_unknown():
    src = GEAR.replace("gear(", "gaer(")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(src)
    (d,) = err.value.diagnostics
    assert d.code == "E205" and "gear" in d.hint


def test_the_language_docs_example_moves_as_its_text_says():
    """docs/language.md's gear-and-rack model: the three bodies move as one of
    inertia 0.01 + 0.05/9 + 4 (0.05/3)^2 kg m^2 referred to the motor."""
    import re
    doc = (Path(__file__).resolve().parents[2] / "docs" / "language.md").read_text()
    (text,) = [b for b in re.findall(r"```\n(.*?)```", doc, re.S)
               if b.startswith("model gear_and_rack")]
    sol = mbdsl.simulate(mbdsl.load_text(text))
    assert sol.completed and not sol.warnings
    J = 0.01 + 0.05 / 9 + 4 * (0.05 / 3) ** 2
    t = sol.column("t")
    theta_m = 0.5 * t ** 2 / (2 * J)
    np.testing.assert_allclose(sol.column("motor.phi"), theta_m, rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(sol.column("slide.x") - 0.3, 0.05 * theta_m / 3, rtol=1e-9,
                               atol=1e-14)
    # the tooth force drives the rack: m s''
    np.testing.assert_allclose(sol.column("coupler.R.Jr.distance.force")[1:],
                               4 * 0.05 * 0.5 / J / 3, rtol=1e-8)


def test_a_gear_built_in_python_writes_itself_back_as_the_language():
    """``JointSpec("G", "gear", ["J1", "J2"], {"ratio": 3})``: the same coupler
    as the file's, and the model's source (written from the spec) reads back
    to it."""
    from mbdsl import BodySpec, ForceSpec, JointSpec, ModelSpec
    spec = ModelSpec("gears", bodies=[BodySpec.rigid("w1", mass=1, inertia=J1),
                                      BodySpec.rigid("w2", mass=2, inertia=J2,
                                                     points={"c": (0.4, 0)})],
                     joints=[JointSpec("J1", "revolute", ["ground.origin", "w1.cm"]),
                             JointSpec("J2", "revolute", ["ground.origin", "w2.c"]),
                             JointSpec("G", "gear", ["J1", "J2"], {"ratio": N})],
                     forces=[ForceSpec("d", "torque", ["w1", TAU])])
    model = mbdsl.from_spec(spec)
    assert "joint G: gear(J1, J2, ratio = 3)" in model.source
    again = mbdsl.load_text(model.source)
    assert again.couplers[0].coefficients == model.couplers[0].coefficients == (1.0, -N)
    # w2 turns about its point c, 0.4 m from its centre: J2 + m2 0.4^2 about the pin
    # (its centre on a circle: the method's O(h^2) error, 2e-6 at h = 1e-2 s)
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-2, t_end=1.0)
    acc = TAU / (J1 + (J2 + 2 * 0.4 ** 2) / N ** 2)
    assert sol.column("w1.phi")[-1] == pytest.approx(acc / 2, rel=1e-5)


HOIST = """model hoist
gravity (0, -9.81)
body drum { mass 2; inertia 0.02 }
body load { mass 5; inertia 0.1 }
ground { point D (0, 1); point G (0.1, 0) }
joint Jd: revolute(ground.D, drum.cm)
joint Jl: prismatic(load.cm, ground.G, direction = (0, 1))
joint R: rack(Jl, Jd, radius = 0.1)
force k: rotational_spring_damper(Jd, k = 50, c = 0.5)
"""


def test_a_hoist_held_by_a_spring_rests_and_rings_as_its_reduced_ode():
    """A drum (J = 0.02 kg m^2) winds a hanging load (m = 5 kg) on a rack of
    radius r = 0.1 m, held by a torsion spring k = 50 N m/rad. At rest
    k theta = -m g r (theta = -0.0981 rad, the load 9.81 mm lower), the tooth
    force m g; about it one mode, omega^2 = k / (J + m r^2), damping ratio
    c / (2 sqrt(k (J + m r^2)))."""
    from mbdsl.modes import modes
    J, m, r, k, c, g = 0.02, 5.0, 0.1, 50.0, 0.5, 9.81
    system = mbdsl.assemble(mbdsl.load_text(HOIST))
    found = modes(system, at="static")
    theta = -m * g * r / k
    q = found.q
    assert q[2] == pytest.approx(theta, rel=1e-9)
    assert q[4] == pytest.approx(r * theta, rel=1e-9)
    (mode,) = found.modes
    inertia = J + m * r * r
    assert mode.omega == pytest.approx(math.sqrt(k / inertia), rel=1e-9)
    assert mode.damping_ratio == pytest.approx(c / (2 * math.sqrt(k * inertia)), rel=1e-9)
