"""First-order states (``state i { der = ...; initial ... }``): controller,
filter and circuit states integrated with the mechanism.

Checked against independent solutions: a DC motor with inductance driving a
flywheel is a linear ODE x' = A x + B u with the closed-form solution
x(t) = e^{At} x0 + A^{-1} (e^{At} - I) B u (scipy's expm); the convergence
order of every method on it (2 for the seven second-order methods, 1 for
NEWMARK: the velocity update of each method is its first-order counterpart);
a PI speed controller on the slider crank holds the mean crank speed at the
set point (the integral action: the state's rate w_ref - omega has zero mean
over a period once the state is periodic); error control sees the states.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import mbdsl
from mbdsl.errors import MbdModelError

ROOT = Path(__file__).resolve().parents[2]
MOTOR = ROOT / "models" / "dc_motor_flywheel.mbd"
SECOND_ORDER = ["hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
                "genalpha-si2"]

#: the motor's parameters as the model file declares them
J, B, R, L, K, U = 0.01, 1e-3, 1.0, 0.5, 0.05, 12.0


def motor_exact(t: float) -> np.ndarray:
    """(i [A], w [rad/s], phi [rad]) of the motor model at t from rest: the
    closed form of the linear ODE (i, w, phi)' = A (i, w, phi) + (u/L, 0, 0)."""
    A = np.array([[-R / L, -K / L, 0.0], [K / J, -B / J, 0.0], [0.0, 1.0, 0.0]])
    Bu = np.array([U / L, 0.0, 0.0])
    # augmented matrix: the constant input as a state, x' = [[A, Bu], [0, 0]] [x; 1]
    M = np.zeros((4, 4))
    M[:3, :3], M[:3, 3] = A, Bu
    return (expm(M * t) @ np.array([0.0, 0.0, 0.0, 1.0]))[:3]


def motor_error(sol) -> float:
    """The largest error of i, w and phi at the run's end against the closed form."""
    exact = motor_exact(float(sol.t[-1]))
    got = [sol.column("state.i")[-1], sol.column("wheel.omega")[-1],
           sol.column("wheel.phi")[-1]]
    return float(np.max(np.abs(np.array(got) - exact) / (1.0 + np.abs(exact))))


@pytest.fixture(scope="module")
def motor():
    return mbdsl.load(MOTOR)


def test_the_motor_model_reads_its_state_by_name(motor):
    """The state is the last coordinate's velocity; its rate a load on it."""
    assert [s.name for s in motor.states] == ["i"]
    assert motor.velocity_names()[-1] == "state.i"
    assert motor.coordinate_names()[-1] == "state.i.integral"
    assert motor.acceleration_names()[-1] == "state.i.rate"
    assert motor.dof == 1                     # the wheel's angle; the state is not counted


@pytest.mark.parametrize("method", SECOND_ORDER + ["newmark"])
def test_motor_converges_at_the_methods_order(motor, method):
    """Fixed steps of h and h/2 to t = 1 s: the error falls 4x (order 2), 2x for
    NEWMARK (order 1), in the state and in the motion it drives."""
    e1, e2 = (motor_error(mbdsl.simulate(motor, method=method, h=h, t_end=1.0, fixed=True))
              for h in (4e-3, 2e-3))
    order = np.log2(e1 / e2)
    want = 1.0 if method == "newmark" else 2.0
    assert abs(order - want) < 0.15, (method, e1, e2, order)
    assert e2 < (2e-3 if method == "newmark" else 1e-4)


def test_motor_energy_balance_closes_without_the_state(motor):
    """The kinetic energy is the wheel's alone (J w^2 / 2: the state's unit
    mass carries none) and the balance closes: the motor's work in equals the
    energy gained plus the bearing's dissipation."""
    sol = mbdsl.simulate(motor, method="hht-si2", h=1e-3, t_end=1.0)
    w = sol.column("wheel.omega")
    assert np.allclose(sol.column("energy.kinetic"), 0.5 * J * w ** 2, rtol=1e-12, atol=1e-15)
    work = sol.column("energy.work")[-1]
    assert work > 1.0
    assert abs(sol.column("energy.balance")[-1]) < 1e-5 * work


def test_error_control_sees_the_state(motor):
    """The error at t = 1 s falls at least 100x from rtol 1e-4 to 1e-8."""
    errors = [motor_error(mbdsl.simulate(motor, method="hht-si2", h=1e-3, t_end=1.0,
                                         rtol=tol, atol=tol)) for tol in (1e-4, 1e-8)]
    assert errors[0] / errors[1] > 100.0, errors


PI_CRANK = """
model pi_slider_crank
parameter L1 = 0.3;  parameter m1 = 3
parameter L2 = 0.6;  parameter m2 = 0.9
parameter w_ref = 4; parameter Kp = 20; parameter Ki = 100
gravity (0, -9.81)
body crank { mass m1; inertia m1*L1^2/12; point O (-L1/2, 0); point A (L1/2, 0) }
body rod   { mass m2; inertia m2*L2^2/12; point A (-L2/2, 0); point B (L2/2, 0) }
joint O: revolute(ground.origin, crank.O)
joint A: revolute(crank.A, rod.A)
joint B: point_on_line(rod.B, ground.origin, direction = (1, 0))
force spring: spring_damper(ground.origin, rod.B, k = 100, c = 5, length = 0)
state e { der = w_ref - crank.omega; initial 0 }
force motor: torque(crank, Kp*(w_ref - crank.omega) + Ki*e)
initial crank.phi = 3*pi/2
initial crank.omega = 0
guess rod.phi = 0.5
simulate { method hht-si2; h 1e-3; t_end 20 }
"""


@pytest.mark.parametrize("method", ["hht-si2", "nstiff"])
def test_pi_controller_holds_the_mean_crank_speed(method):
    """A PI speed controller on the paper's slider crank (gravity, spring and
    damper load the crank unevenly over a turn): after the transient the mean
    speed over whole turns, measured from the crank's angle, is the set point
    within 1e-3 rad/s."""
    model = mbdsl.load_text(PI_CRANK)
    sol = mbdsl.simulate(model, method=method, h=1e-3, t_end=20.0)
    t, phi = sol.t, sol.column("crank.phi")
    start = np.searchsorted(t, 12.0)
    # whole turns from t = 12 s: the last time the angle has made an integer number of turns
    turns = np.floor((phi[-1] - phi[start]) / (2 * np.pi))
    end = np.searchsorted(phi, phi[start] + 2 * np.pi * turns)
    assert turns >= 4
    mean = (phi[end] - phi[start]) / (t[end] - t[start])
    assert abs(mean - 4.0) < 1e-3, mean
    # the speed itself is not constant (3.3 to 5.0 rad/s over a turn: the controller
    # does not hide the load), and never reverses (the angle counts whole turns)
    omega = sol.column("crank.omega")[start:]
    assert np.ptp(omega) > 1.0 and omega.min() > 0.0


def test_a_state_starts_where_its_initial_line_says():
    """``initial`` sets z(t_start); a state that no force reads decays alone
    (z' = -z/tau: z = z0 e^(-t/tau))."""
    model = mbdsl.load_text("""model lag
        parameter tau = 0.2
        body b { mass 1; inertia 1 }
        joint p: revolute(ground.origin, b.cm)
        state z { der = -z/tau; initial 3 }
        simulate { method genalpha; h 1e-3; t_end 1 }""")
    sol = mbdsl.simulate(model)
    assert sol.column("state.z")[0] == 3.0
    assert abs(sol.column("state.z")[-1] - 3 * np.exp(-5.0)) < 1e-5
    assert np.allclose(sol.column("state.z.rate"), -sol.column("state.z") / 0.2, atol=2e-4)


def test_states_read_each_other_and_time():
    """Two coupled states, an oscillator z1' = z2, z2' = -w^2 z1 + cos(t): the
    closed form z1 = A cos(w t) + B sin(w t) + cos(t)/(w^2 - 1)."""
    w = 3.0
    model = mbdsl.load_text(f"""model osc
        parameter w = {w}
        body b {{ mass 1; inertia 1 }}
        joint p: revolute(ground.origin, b.cm)
        state z1 {{ der = z2; initial 1 }}
        state z2 {{ der = -w^2*z1 + cos(t); initial 0 }}
        output both = z1 + z2
        simulate {{ method hht-i3; h 5e-4; t_end 2 }}""")
    sol = mbdsl.simulate(model)
    t = sol.t
    c = 1.0 / (w * w - 1.0)
    exact = (1 - c) * np.cos(w * t) + c * np.cos(t)
    assert np.max(np.abs(sol.column("state.z1") - exact)) < 1e-5
    assert np.allclose(sol.column("output.both"),
                       sol.column("state.z1") + sol.column("state.z2"), atol=1e-14)


def test_a_model_built_in_python_has_its_states():
    """``ModelSpec(states=[StateSpec.of(...)])`` checks as the file does."""
    from mbdsl.dsl.spec import (BodySpec, ForceSpec, JointSpec, ModelSpec, StateSpec)
    spec = ModelSpec(name="py", bodies=[BodySpec.rigid("b", 1.0, 1.0)],
                     joints=[JointSpec("p", "revolute", ["ground.origin", "b.cm"])],
                     forces=[ForceSpec("m", "torque", ["b", "i"])],
                     states=[StateSpec.of("i", "1 - i", 0.5)])
    model = mbdsl.from_spec(spec)
    assert model.states[0].initial == 0.5
    sol = mbdsl.simulate(model, method="hht-si2", h=1e-3, t_end=1.0)
    i = 1 - 0.5 * np.exp(-sol.t)
    assert np.max(np.abs(sol.column("state.i") - i)) < 1e-6
    # the torque is i: omega = int i dt (inertia 1)
    assert abs(sol.column("b.omega")[-1] - (1.0 - 0.5 * (1 - np.exp(-1.0)))) < 1e-6


@pytest.mark.parametrize("text, code, where", [
    ("state i { der = 1 }\nstate i { der = 2 }", "E202", (4, 7)),
    ("state L1 { der = 1 }", "E202", (3, 7)),
    ("state s { der = 1; gain = 2 }", "E304", (3, 20)),
    ("state s { initial 1 }", "E302", (3, 7)),
    ("state s { der = w_ref - crank.omegaa }", "E304", (3, 25)),
    ("state s { der = 1 - q }", "E201", (3, 21)),
    ("state sin { der = 1 }", "E202", (3, 7)),
    ("state crank { der = 1 }", "E202", (3, 7)),
    ("state s { der = 1 }\nforce m: torque(crank, state.s)", "E201", (4, 24)),
    ("state s { der = 1 }\noutput o = state.s", "E201", (4, 12)),
])
def test_state_errors_name_the_place(text, code, where):
    """Each mistake in a state block is a coded error at its line and column."""
    source = ("model bad\nparameter L1 = 0.3; parameter w_ref = 1\n" + text + "\n"
              "body crank { mass 1; inertia 1; point O (0, 0) }\n"
              "joint O: revolute(ground.origin, crank.O)\n")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(source)
    d = next(d for d in err.value.diagnostics if d.is_error)
    assert d.code == code, d
    assert (d.span.line, d.span.column) == where, d


def test_static_equilibrium_holds_the_states_at_their_initial_values():
    """``initial static`` solves the mechanism's equilibrium with each state at
    its initial value (its integral held): a servo 10 (0.5 - theta) + 3 e with
    e = 2, a spring 20 theta, gravity on an arm of 0.3 m: 11 - 30 theta -
    m g r cos(theta) = 0."""
    from scipy.optimize import brentq
    model = mbdsl.load_text("""model static_pi
        gravity (0, -9.81)
        body arm { mass 1; inertia 0.05; point O (-0.3, 0) }
        joint O: revolute(ground.origin, arm.O)
        state e { der = 0.5 - O.angle; initial 2 }
        force servo: joint_torque(O, 10*(0.5 - O.angle) + 3*e - 0.5*O.rate)
        force k: rotational_spring_damper(O, k = 20, c = 0.1)
        initial static
        simulate { method hht-si2; h 1e-3; t_end 0.01 }""")
    sol = mbdsl.simulate(model)
    theta = brentq(lambda x: 11 - 30 * x - 9.81 * 0.3 * np.cos(x), 0.0, 1.0, xtol=1e-15)
    assert abs(sol.column("arm.phi")[0] - theta) < 1e-10
    assert sol.column("state.e")[0] == 2.0


def test_a_model_with_states_is_written_back_as_it_reads():
    """``spec_text`` writes the state blocks; the text reads to the same states."""
    from mbdsl.dsl.parser import parse_file, parse_text
    from mbdsl.dsl.unparse import spec_text
    spec = parse_file(MOTOR)
    again = parse_text(spec_text(spec))
    assert [(s.name, [p.name for p in s.properties]) for s in again.states] == \
        [("i", ["der", "initial"])]
    a, b = mbdsl.from_spec(spec), mbdsl.from_spec(again)
    x = np.array([0.3, 20.0])          # (i, wheel.omega)
    fa, fb = (m.states[0].function for m in (a, b))
    assert fa.f(0.0, x) == fb.f(0.0, x) == (12 - 0.3 - 0.05 * 20.0) / 0.5


def test_the_convergence_study_measures_a_state_s_order():
    """``mbdsl study convergence --quantity state.i`` against its index-1 DOP853
    reference: the fitted orders are each method's (the study reads a state as
    any column)."""
    from mbdsl.studies import StudyOptions, run_study
    opts = StudyOptions(methods=["newmark", "hht-i3", "nstiff-si2", "genalpha"],
                        hs=[4e-3, 2e-3, 1e-3], t_end=1.0, jobs=1, quantities=["state.i"])
    result = run_study("convergence", MOTOR, opts, log=lambda s: None)
    orders = {row[0]: row[2] for row in result.section("convergence").tables[1].rows}
    assert abs(orders["newmark"] - 1.0) < 0.05
    for method in ("hht-i3", "nstiff-si2", "genalpha"):
        assert abs(orders[method] - 2.0) < 0.05, orders


def test_an_unclosed_state_block_is_named_at_the_next_declaration():
    """E108: the block left open, at the line of the declaration that follows."""
    from mbdsl.errors import MbdSyntaxError
    with pytest.raises(MbdSyntaxError) as err:
        mbdsl.load_text("model m\nstate i { der = 1\nbody b { mass 1; inertia 1 }\n")
    d = err.value.diagnostics[0]
    assert (d.code, d.span.line, d.span.column) == ("E108", 3, 1)


def test_the_standard_figure_draws_the_states(motor):
    """``mbdsl plot`` adds a panel of the first-order states to its eight."""
    import matplotlib
    matplotlib.use("Agg")
    sol = mbdsl.simulate(motor, t_end=0.2)
    fig = mbdsl.plot(sol)
    panel = next(ax for ax in fig.axes if ax.get_title() == "first-order states")
    (line,) = panel.get_lines()
    assert line.get_label() == "state.i"
    assert np.array_equal(line.get_ydata(), sol.column("state.i"))
    assert len([ax for ax in fig.axes if ax.get_visible()]) == 9


def test_a_rate_that_overflows_at_the_start_names_the_state():
    """E506 at the state's line, not a traceback (the mutation fuzzer's find)."""
    from mbdsl.errors import AssemblyError
    model = mbdsl.load_text("""model m
        body b { mass 1; inertia 1 }
        joint p: revolute(ground.origin, b.cm)
        state z { der = exp(1000*z); initial 1 }
        simulate { h 1e-3; t_end 0.01 }""")
    with pytest.raises(AssemblyError) as err:
        mbdsl.simulate(model)
    d = err.value.diagnostics[0]
    assert d.code == "E506" and "state.z.rate" in d.message and d.span.line == 4
