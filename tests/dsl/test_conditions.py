"""Comparisons and if(test, then, other) in expressions: a spin-up-and-hold
driver written with if, its velocity and acceleration (Phi_t, Phi_tt from
the symbolic derivative of the chosen branch), the same law on both engines,
a torque that switches on the motion, and the language's errors.

Oracle: the closed form of the profile theta = w t^2/(2 T) for t < T,
w (t - T/2) after it (speed w t/T, then w; acceleration w/T, then 0).
"""

import math

import numpy as np
import pytest

import mbdsl
from mbdsl.dsl.expressions import compile_function, diff, evaluate, substitute
from mbdsl.dsl.parser import parse_expression
from mbdsl.dsl.unparse import expr_text
from mbdsl.errors import MbdModelError

SPIN = """model spin_and_hold
parameter w = 4
parameter T = 1.5
body disk { mass 1; inertia 0.2 }
joint O: revolute(ground.origin, disk.cm)
driver spin: disk.phi = if(t < T, w*t^2/(2*T), w*(t - T/2))
"""


@pytest.mark.parametrize("engine", ["numpy", "compiled"])
def test_spin_up_and_hold_driver_written_with_if(engine):
    sol = mbdsl.simulate(mbdsl.load_text(SPIN), method="hht-si2", h=1e-3, t_end=3.0,
                         engine=engine)
    assert sol.engine == engine and sol.completed
    t = sol.t
    w, T = 4.0, 1.5
    phi = np.where(t < T, w * t ** 2 / (2 * T), w * (t - T / 2))
    omega = np.where(t < T, w * t / T, w)
    assert np.max(np.abs(sol.column("disk.phi") - phi)) < 1e-12
    assert np.max(np.abs(sol.column("disk.omega") - omega)) < 1e-9
    # the driver torque: J alpha = 0.2 w / T while spinning up, 0 after
    torque = sol.column("driver.spin.torque")
    assert np.max(np.abs(torque[(t > 0.1) & (t < 1.4)] - 0.2 * w / T)) < 1e-6
    assert np.max(np.abs(torque[t > 1.6])) < 1e-6


def test_a_torque_switched_in_time():
    """torque(d, if(t < 1, 2, -1)) on J = 0.5: omega = 4 t, then 4 - 2 (t - 1),
    on both engines. The switch falls on a node of the step grid (t = 1000 h):
    a step ending on it would see the new branch at its end, and the Newmark
    formulas, which average the step's end accelerations, would carry an O(h)
    error of h x 6 rad/s^2 / 2 (3.1e-3 at h = 1e-3); both engines end the step
    1e-10 h before it and restart after it on the new branch: exact."""
    text = """model switch
body d { mass 1; inertia 0.5 }
joint O: revolute(ground.origin, d.cm)
force m: torque(d, if(t < 1, 2, -1))   # at t = 1: -1
initial d.phi = 0
initial d.omega = 0
"""
    for engine in ("numpy", "compiled"):
        sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-3, t_end=2.0,
                             engine=engine)
        omega, t = sol.column("d.omega"), sol.t
        exact = np.where(t <= 1.0, 4 * t, 4 - 2 * (t - 1))
        assert [e[2] for e in sol.events] == ["switched"] and sol.events[0][0] == 1.0
        assert np.max(np.abs(omega - exact)) < 1e-9


def test_an_error_controlled_run_from_a_tiny_first_step_finds_the_switch():
    """The switches of the functions of time are found before a compiled run
    on the grid of its first step; a first step of 1e-12 s over 2 s would be
    2e12 nodes: the grid is coarsened to ``SWITCH_GRID_LIMIT`` steps, and the
    switch at t = 1 is still found and landed on. The step before it ends
    ``events.switch_gap`` before it: 1e-10 h would be 1e-22 s, below t's
    round-off, and the step would end on the switch and see the new branch
    (measured 6e-3 rad and rad/s at t = 2 s on both engines before)."""
    from mbdsl.integrators.events import switch_times, time_switches
    text = """model switch
body d { mass 1; inertia 0.5 }
joint O: revolute(ground.origin, d.cm)
force m: torque(d, if(t < 1, 2, -1))
initial d.phi = 0
initial d.omega = 0
"""
    model = mbdsl.load_text(text)
    found = switch_times(time_switches(mbdsl.assemble(model)), 0.0, 2.0, 1e-12)
    assert len(found) == 1 and abs(found[0][0] - 1.0) < 1e-12
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-12, t_end=2.0, rtol=1e-6, atol=1e-6)
    assert sol.engine == "compiled" and sol.status == "completed"
    assert [e[2] for e in sol.events] == ["switched"] and abs(sol.events[0][0] - 1.0) < 1e-9
    for engine in ("compiled", "numpy"):
        sol = mbdsl.simulate(model, method="hht-i3", h=1e-12, t_end=2.0, rtol=1e-6, atol=1e-6,
                             engine=engine)
        t = sol.t
        exact = np.where(t <= 1.0, 2 * t**2, 2 + 4 * (t - 1) - (t - 1) ** 2)
        assert np.max(np.abs(sol.column("d.phi") - exact)) < 1e-10, engine
        assert abs(sol.column("d.omega")[-1] - 2.0) < 1e-10, engine


def test_comparisons_and_if_evaluate_differentiate_and_write_back():
    e = parse_expression("if(t < 2, t^2/2, 2*t - 2) + (t >= 1)*0.5")
    f = compile_function(substitute(e, {}))
    assert [f(x) for x in (0.5, 1.5, 3.0)] == [0.125, 1.625, 4.5]
    df = compile_function(diff(substitute(e, {})))
    assert [df(x) for x in (0.5, 3.0)] == [0.5, 2.0]          # the chosen branch's slope
    assert expr_text(e) == "if(t < 2, t^2/2, 2*t - 2) + (t >= 1)*0.5"
    # only the chosen branch is evaluated where evaluation fails
    assert evaluate(parse_expression("if(1 > 2, sqrt(-1), 3)"), {}) == 3.0
    assert evaluate(parse_expression("(2 <= 2) + (3 > 4) + (1 < 2)"), {}) == 2.0


def test_if_with_the_wrong_number_of_arguments_is_reported():
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(SPIN.replace("if(t < T, w*t^2/(2*T), w*(t - T/2))", "if(t < T, 1)"))
    d = [d for d in err.value.diagnostics if d.code == "E203"]
    assert d and "takes 3 arguments" in d[0].message and d[0].span.line == 6
