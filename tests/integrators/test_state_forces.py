"""Torques that read the motion: motor curves and joint actuators.

Oracles: closed-form solutions of the reduced ODE (a flywheel under a
linear motor curve; a PD-controlled link, whose tracking error follows from
its transfer function), the rotational spring-damper the same torque law
already is, and the language's errors for every misuse.
"""

import math

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import MbdModelError

SECOND_ORDER = ["hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
                "genalpha-si2"]

FLYWHEEL = """model flywheel
body w { mass 1; inertia 0.5 }
joint O: revolute(ground.origin, w.cm)
force motor: torque(w, 2*(1 - w.omega/10))
initial w.phi = 0
initial w.omega = 0
"""


@pytest.mark.parametrize("engine", ["numpy", "compiled"])
@pytest.mark.parametrize("method", SECOND_ORDER)
def test_flywheel_under_a_motor_curve(method, engine):
    """0.5 omega' = 2 (1 - omega/10): omega(t) = 10 (1 - exp(-0.4 t))."""
    model = mbdsl.load_text(FLYWHEEL)
    sol = mbdsl.simulate(model, method=method, h=1e-3, t_end=1.0, engine=engine)
    assert sol.engine == engine and sol.completed
    omega = sol.column("w.omega")[-1]
    assert abs(omega - 10.0 * (1.0 - math.exp(-0.4))) < 1e-6
    # the derivative of the motor curve is in the Newton matrix: Newton converges
    # as fast as on the constant torque (a lagged or missing Q_v would cost iterations)
    assert sol.stats_total.iterations / sol.stats_total.steps < 4


DOUBLE = """model dp
gravity (0, -9.81)
body l1 { mass 1; inertia 1/12; point O (-0.5, 0); point E (0.5, 0) }
body l2 { mass 1; inertia 1/12; point E (-0.5, 0); point T (0.5, 0) }
joint O: revolute(ground.origin, l1.O)
joint E: revolute(l1.E, l2.E)
FORCE
initial l1.phi = 0
initial l2.phi = 0.5
initial l1.omega = 0
initial l2.omega = 0
"""


@pytest.mark.parametrize("engine", ["numpy", "compiled"])
def test_joint_torque_is_the_rotational_spring_damper_it_restates(engine):
    spring = mbdsl.load_text(DOUBLE.replace(
        "FORCE", "force s: rotational_spring_damper(E, k = 8, c = 0.5, angle = 0.3)"))
    law = mbdsl.load_text(DOUBLE.replace(
        "FORCE", "force s: joint_torque(E, -8*(E.angle - 0.3) - 0.5*E.rate)"))
    a = mbdsl.simulate(spring, method="hht-si2", h=1e-3, t_end=2.0, engine=engine)
    b = mbdsl.simulate(law, method="hht-si2", h=1e-3, t_end=2.0, engine=engine)
    assert np.max(np.abs(a.q - b.q)) < 1e-12
    assert a.stats_total.iterations == b.stats_total.iterations


def test_body_state_reads_the_right_coordinates():
    """A torque on the elbow link of -k (l2.phi - l1.phi) - c (l2.omega -
    l1.omega), with the opposite on l1 written as a second torque, is the
    spring-damper again: body fields read q and v of the named body."""
    spring = mbdsl.load_text(DOUBLE.replace(
        "FORCE", "force s: rotational_spring_damper(E, k = 8, c = 0.5, angle = 0)"))
    law = mbdsl.load_text(DOUBLE.replace("FORCE", (
        "force s2: torque(l2, -8*(l2.phi - l1.phi) - 0.5*(l2.omega - l1.omega))\n"
        "force s1: torque(l1, 8*(l2.phi - l1.phi) + 0.5*(l2.omega - l1.omega))")))
    a = mbdsl.simulate(spring, method="hht-i3", h=1e-3, t_end=1.0)
    b = mbdsl.simulate(law, method="hht-i3", h=1e-3, t_end=1.0)
    assert np.max(np.abs(a.q - b.q)) < 1e-12


SERVO = """model servo
parameter kp = 40
parameter kd = 4
body link { mass 2; inertia 2/12; point O (-0.5, 0) }
joint O: revolute(ground.origin, link.O)
force servo: joint_torque(O, -kp*(O.angle - 0.5*sin(t)) - kd*O.rate)
initial link.phi = 0
initial link.omega = 0
"""


@pytest.mark.parametrize("method", ["hht-i3", "genalpha-si2"])
def test_pd_servo_tracks_as_its_transfer_function_predicts(method):
    """J theta'' = -kp (theta - r) - kd theta', r = 0.5 sin t, J = m L^2/3 about
    the pin (no gravity). The tracking error e = r - theta tends to the
    steady oscillation of amplitude 0.5 |-J + i kd| / |kp - J + i kd| (the
    error transfer function (J s^2 + kd s)/(J s^2 + kd s + kp) at s = i); the
    transient decays as exp(-kd t / (2 J)), below 1e-9 by t = 20 s."""
    sol = mbdsl.simulate(mbdsl.load_text(SERVO), method=method, h=1e-3, t_end=25.0)
    J, kp, kd = 2.0 / 3.0, 40.0, 4.0
    bound = 0.5 * abs(complex(-J, kd)) / abs(complex(kp - J, kd))
    late = sol.t >= 20.0
    err = 0.5 * np.sin(sol.t[late]) - sol.column("link.phi")[late]
    assert np.max(np.abs(err)) == pytest.approx(bound, rel=1e-3)
    # and the whole response is the reduced ODE's (closed form of the linear ODE)
    from scipy.integrate import solve_ivp
    ref = solve_ivp(lambda t, y: [y[1], (-kp * (y[0] - 0.5 * np.sin(t)) - kd * y[1]) / J],
                    (0.0, 25.0), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-12,
                    t_eval=[5.0, 25.0])
    for t, theta in zip(ref.t, ref.y[0]):
        i = int(round(t / 1e-3))
        assert abs(sol.column("link.phi")[i] - theta) < 1e-4


@pytest.mark.parametrize("line, code, text", [
    ("force m: torque(w, 2*(1 - w.omgea/10))", "E304", "did you mean 'omega'?"),
    ("force m: torque(w, 2*(1 - v.omega/10))", "E201", "unknown body or joint 'v'"),
    ("force m: torque(w, O.distance)", "E304", "revolute joint's angle, rate"),
    ("force m: joint_torque(P, 1)", "E305", "'P' is a prismatic joint"),
    ("force m: joint_torque(w, 1)", "E201", "expected the name of a joint"),
    ("force m: spring_damper(w.cm, u.cm, k = w.omega, length = 1)", "E301",
     "'w.omega' is a reference, not a number"),
    ("driver d: u.x = w.omega", "E301", "'w.omega' is a reference, not a number"),
])
def test_misuse_is_reported_with_its_place(line, code, text):
    src = FLYWHEEL + ("body u { mass 1; inertia 1 }\n"
                      "joint P: prismatic(u.cm, ground.origin, direction = (1, 0))\n"
                      f"{line}\n")
    with pytest.raises(MbdModelError) as info:
        mbdsl.load_text(src, "bad.mbd")
    diags = [d for d in info.value.diagnostics if d.code == code]
    assert diags, [str(d) for d in info.value.diagnostics]
    rendered = "\n".join(d.render(src) if hasattr(d, "render") else str(d) for d in diags)
    assert text in rendered or any(text in (d.message + " " + (d.hint or "")) for d in diags)
    assert all(d.span is not None for d in diags)


# -- the energy balance -------------------------------------------------------------------

def test_flywheel_work_is_its_kinetic_energy():
    """No potential, no damper: the motor's work int tau omega dt is the
    kinetic energy 0.5 I omega^2, with omega(1) = 10 (1 - exp(-0.4))."""
    sol = mbdsl.simulate(mbdsl.load_text(FLYWHEEL), method="hht-i3", h=1e-3, t_end=1.0)
    omega = 10.0 * (1.0 - math.exp(-0.4))
    assert sol.column("energy.work")[-1] == pytest.approx(0.25 * omega ** 2, abs=1e-6)
    assert np.all(sol.column("energy.dissipated") == 0.0)
    assert np.max(np.abs(sol.column("energy.balance"))) < 1e-6


@pytest.mark.parametrize("model, method", [("slider_crank.mbd", "hht-i3"),
                                           ("slider_crank.mbd", "nstiff-si2"),
                                           ("slider_crank_driven.mbd", "hht-si2"),
                                           ("slider_crank_driven.mbd", "genalpha")])
def test_energy_balance_closes_at_the_methods_order(model, method):
    """E(t) - E(0) - work + dissipated: below 1e-3 of the largest total energy at
    h = 1e-3 s and falling as h^2 (the damper dissipates 4.2 J in 2 s; the
    driver of the driven slider crank puts in 13.7 J)."""
    from ..conftest import MODELS
    m = mbdsl.load(MODELS / model)
    worst = []
    for h in (1e-3, 5e-4):
        sol = mbdsl.simulate(m, method=method, h=h, t_end=2.0)
        worst.append(np.max(np.abs(sol.column("energy.balance"))))
        assert worst[-1] < 1e-3 * np.max(np.abs(sol.column("energy.total")))
        assert sol.column("energy.dissipated")[-1] > 4.0
    assert 3.0 < worst[0] / worst[1] < 5.5, worst


def test_energy_columns_are_written_and_read_back(tmp_path):
    from mbdsl.cli.main import main
    from mbdsl.io.csvfile import read_csv_metadata
    from ..conftest import MODELS
    out = tmp_path / "d.csv"
    assert main(["simulate", str(MODELS / "slider_crank_driven.mbd"), "--t-end", "0.5", "-q",
                 "-o", str(out)]) == 0
    meta, names, values = read_csv_metadata(out)
    assert {"energy.work", "energy.dissipated", "energy.balance"} <= set(names)
    back = mbdsl.load_solution(out)
    np.testing.assert_allclose(back.column("energy.work"), values[:, names.index("energy.work")])


# -- driving a sliding joint along its line ----------------------------------------------

INCLINE = """model incline_lift
parameter theta = pi/6
parameter m = 2
gravity (0, -9.81)
body block { mass m; inertia 0.01 }
joint P: prismatic(block.cm, ground.origin, direction = (cos(theta), sin(theta)))
driver lift: P.distance = 0.1*t + 0.05*t^2
"""


@pytest.mark.parametrize("engine", ["numpy", "compiled"])
@pytest.mark.parametrize("method, tol, after", [
    ("hht-si2", 1e-8, 0.0), ("nstiff-si2", 1e-8, 0.0), ("hht-add", 1e-8, 0.0),
    ("genalpha-si2", 1e-8, 0.0),
    # index 3: lambda follows the positions through the 1/(beta h^2) rows, and the
    # Newton tolerance on them leaves 2.5e-8 N (hht-i3), 3.4e-8 N (genalpha)
    ("hht-i3", 1e-7, 0.0), ("genalpha", 1e-7, 0.0),
    # BDF2 on the index-3 form: a multiplier start-up transient (0.1-0.2 N over the
    # first steps after the BDF1 start), then 7e-10 N
    ("nstiff", 1e-8, 0.02)])
def test_actuator_force_of_a_driven_prismatic_joint(method, tol, after, engine):
    """A 2 kg block driven up a 30 degree incline with s(t) = 0.1 t + 0.05 t^2:
    the actuator force -lambda.lift.0 = m s'' + m g sin(30) = 0.2 + 9.81 N."""
    sol = mbdsl.simulate(mbdsl.load_text(INCLINE), method=method, h=1e-3, t_end=1.0,
                         engine=engine)
    assert sol.engine == engine
    force = -sol.column("lambda.lift.0")[sol.t >= after]
    assert np.max(np.abs(force - (2 * 0.1 + 2 * 9.81 * 0.5))) < tol
    # the same load by the driver's name
    assert np.array_equal(sol.column("driver.lift.force"), -sol.column("lambda.lift.0"))
    s = np.hypot(sol.column("block.x"), sol.column("block.y"))
    assert np.max(np.abs(s - (0.1 * sol.t + 0.05 * sol.t ** 2))) < 1e-12
    # the actuator's work is the energy the block gains (NSTIFF: 7.5e-6 J from its
    # start-up multipliers, against 12 J put in)
    assert np.max(np.abs(sol.column("energy.balance"))) < (1e-5 if after else 1e-9)


def test_distance_driver_misuse():
    with pytest.raises(MbdModelError) as info:
        mbdsl.load_text(DOUBLE.replace("FORCE", "driver d: E.distance = t"), "bad.mbd")
    d = info.value.diagnostics[0]
    assert d.code == "E201" and "a revolute joint is driven by its 'angle'" in d.message


# -- the shipped models -----------------------------------------------------------------

def test_motor_fourbar_turns_and_its_energy_balance_closes():
    """models/motor_fourbar.mbd: the motor curve lifts the linkage over its
    dead points (the crank turns round), and E - E(0) - work stays below 1e-3
    of the largest energy, falling as h^2 (measured 3.9e-4 and 9.9e-5 J at
    h = 1e-3 and 5e-4 s)."""
    from ..conftest import MODELS
    model = mbdsl.load(MODELS / "motor_fourbar.mbd")
    worst = []
    for h in (1e-3, 5e-4):
        sol = mbdsl.simulate(model, h=h, t_end=3.0)
        assert sol.completed
        assert sol.column("crank.phi")[-1] - sol.column("crank.phi")[0] > 3 * 2 * np.pi
        omega = sol.column("crank.omega")
        assert np.max(omega) < 2 * 10.0 and np.min(omega[sol.t > 0.5]) > 0   # turns one way
        worst.append(np.max(np.abs(sol.column("energy.balance"))))
        assert worst[-1] < 1e-3 * np.max(np.abs(sol.column("energy.total")))
    assert 3.0 < worst[0] / worst[1] < 5.5, worst


def test_servo_arm_tracks_within_the_quasi_static_bound():
    """models/servo_arm.mbd: joint PD control without feed-forward. With the
    error e = r - theta, the closed loop is M e'' + kd e' + kp e = tau_ff(t) +
    O(e^2), tau_ff the torques that move the arm exactly along r (computed
    here by driving the joints along r: the drivers' loads). The references
    (1 and 2 rad/s) are far below the loop's bandwidth sqrt(kp / I), about
    50 rad/s, so the response is quasi-static, |e_j| <= max |tau_ff,j| / kp
    (the factor 1/|1 - I w^2/kp + i kd w/kp| is below 1 here). Measured:
    0.998 and 0.993 of the bound after the start-up transient."""
    from ..conftest import MODELS
    text = (MODELS / "servo_arm.mbd").read_text()
    sol = mbdsl.simulate(mbdsl.load_text(text), h=1e-3, t_end=10.0)
    t = sol.t
    e1 = 0.5 * np.sin(t) - sol.column("link1.phi")
    e2 = 0.4 * np.sin(2 * t) - (sol.column("link2.phi") - sol.column("link1.phi"))
    driven = (text.replace("force shoulder", "# force shoulder")
              .replace("force elbow", "# force elbow")
              .replace("initial link1.phi = 0\ninitial link2.phi = 0\n", "")
              .replace("initial link1.omega = 0\ninitial link2.omega = 0\n", "")
              + "driver dO: O.angle = A1*sin(t)\ndriver dE: E.angle = A2*sin(2*t)\n")
    inv = mbdsl.simulate(mbdsl.load_text(driven), h=1e-3, t_end=10.0)
    late = t > 3.0
    for e, load in ((e1, "lambda.dO.0"), (e2, "lambda.dE.0")):
        bound = np.max(np.abs(inv.column(load))) / 200.0
        assert 0.9 * bound < np.max(np.abs(e[late])) <= bound


def test_driver_loads_by_name_and_zero_reactions(tmp_path):
    """driver.<name>.torque of a driven crank is -lambda of its row, and goes
    to the file and back; a revolute joint's couple is written as 0."""
    from ..conftest import MODELS
    sol = mbdsl.simulate(mbdsl.load(MODELS / "slider_crank_driven.mbd"), h=1e-3, t_end=0.5)
    assert np.array_equal(sol.column("driver.motor.torque"), -sol.column("lambda.motor.0"))
    for joint in ("O", "A"):
        assert np.all(sol.column(f"reaction.{joint}.torque") == 0.0)
    for suffix in (".csv", ".h5"):
        path = tmp_path / f"run{suffix}"
        from mbdsl.io.hdf5 import write_hdf5
        from mbdsl.io.csvfile import write_csv
        (write_hdf5 if suffix == ".h5" else write_csv)(sol, path)
        back = mbdsl.load_solution(path)
        np.testing.assert_array_equal(back.column("driver.motor.torque"),
                                      sol.column("driver.motor.torque"))


# -- forces along sliding joints --------------------------------------------------------

ROD_SLIDER = """model rod_slider
body bar { mass 2; inertia 2/12; point O (-0.5, 0) }
body slider { mass 0.5; inertia 0.001 }
joint O: revolute(ground.origin, bar.O)
joint S: point_on_line(slider.cm, bar.O, direction = (1, 0))
LOAD
initial bar.phi = 0.3
initial bar.omega = 3
guess slider.x = 0.4
guess slider.y = 0.1
"""


@pytest.mark.parametrize("method", ["hht-i3", "nstiff-si2", "genalpha"])
def test_joint_force_on_a_turning_line_is_the_spring_damper_it_restates(method):
    """A slider on a spinning bar, pulled to the pivot: joint_force(S, -k S.distance
    - c S.speed) on the line that turns with the bar is the spring-damper between
    the slider and the pivot (free length 0) while the slider stays on the pivot's
    side it starts on (it comes within 4e-5 m of it). Measured: 3e-11 m apart."""
    spring = mbdsl.load_text(ROD_SLIDER.replace(
        "LOAD", "force k: spring_damper(bar.O, slider.cm, k = 50, c = 1, length = 0)"))
    law = mbdsl.load_text(ROD_SLIDER.replace(
        "LOAD", "force k: joint_force(S, -50*S.distance - 1*S.speed)"))
    a = mbdsl.simulate(spring, method=method, h=1e-3, t_end=2.0)
    b = mbdsl.simulate(law, method=method, h=1e-3, t_end=2.0)
    assert np.min(np.hypot(a.column("slider.x"), a.column("slider.y"))) > 0
    assert np.max(np.abs(a.q - b.q)) < 1e-9
    # the load's work is what it takes out (no potential for it): the balance closes
    assert np.max(np.abs(b.column("energy.balance"))) < 1e-3 * np.max(b.column("energy.total"))


def test_jack_holds_a_block_on_an_incline():
    """joint_force(P, m g sin 30) along the incline balances gravity: the block
    stays where it is (and its actuator does no work)."""
    text = INCLINE.replace("driver lift: P.distance = 0.1*t + 0.05*t^2",
                           "force jack: joint_force(P, m*9.81*sin(theta) + 0*P.speed)")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-si2", h=1e-3, t_end=1.0)
    s = np.hypot(sol.column("block.x"), sol.column("block.y"))
    assert np.max(np.abs(s)) < 1e-12
    assert abs(sol.column("energy.work")[-1]) < 1e-12


def test_sliding_loads_converge_to_the_dop853_reference():
    """sliding_elements.mbd: joint forces on turning and fixed lines, laws that
    read distances, speeds, angles and rates; the compiled engine's q(0.5 s)
    against DOP853 on the index-1 equations, falling as h^2 between h = 1 and
    0.5 ms (measured ratios 4.00, 4.00, 4.02; errors 1.9e-6 to 6.7e-6)."""
    from mbdsl.integrators import make_method

    from ..conftest import ROOT
    from .suite import dop853_error_ratios
    system = mbdsl.assemble(mbdsl.load(ROOT / "tests" / "dsl" / "valid" / "sliding_elements.mbd"))
    init = mbdsl.consistent_initial_state(system)
    runs = dop853_error_ratios(system, init, [make_method(m) for m in ("hht-i3", "hht-si2",
                                                                       "nstiff")], 0.5)
    for name, (errors, ratios) in runs.items():
        assert 3.6 < ratios[0] < 4.4 and errors[-1] < 5e-5, (name, errors)


@pytest.mark.parametrize("line, code, text", [
    ("force m: joint_force(O, 1)", "E305", "a joint force acts along a prismatic"),
    ("force m: joint_force(S, S.sped)", "E304", "did you mean 'speed'?"),
    ("force m: torque(bar, O.distance)", "E304", "revolute joint's angle, rate"),
])
def test_sliding_misuse(line, code, text):
    with pytest.raises(MbdModelError) as info:
        mbdsl.load_text(ROD_SLIDER.replace("LOAD", line), "bad.mbd")
    d = [x for x in info.value.diagnostics if x.code == code]
    assert d and d[0].span is not None
    assert any(text in (x.message + " " + (x.hint or "")) for x in d)


# -- piecewise laws: saturation ------------------------------------------------------------

@pytest.mark.parametrize("engine", ["numpy", "compiled"])
def test_saturated_motor_accelerates_at_its_limit_then_follows_its_curve(engine):
    """torque(w, clip(2*(10 - w.omega), -1, 1)) on a flywheel of 0.5 kg m^2: the
    torque saturates at 1 N m until omega = 9.5 rad/s (t = 4.75 s, uniform
    acceleration 2 rad/s^2), then omega = 10 - 0.5 exp(-4 (t - 4.75))."""
    text = FLYWHEEL.replace("2*(1 - w.omega/10)", "clip(2*(10 - w.omega), -1, 1)")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-3, t_end=6.0,
                         engine=engine)
    assert sol.engine == engine
    t, w = sol.t, sol.column("w.omega")
    early = t <= 4.7
    assert np.max(np.abs(w[early] - 2.0 * t[early])) < 1e-9
    late = t >= 4.8
    exact = 10.0 - 0.5 * np.exp(-4.0 * (t[late] - 4.75))
    assert np.max(np.abs(w[late] - exact)) < 1e-3         # the kink is met within a step
    assert sol.stats_total.rejected == 0
