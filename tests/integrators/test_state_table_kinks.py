"""Kinks of a table of the state: located as events, the steps landing on them.

Oracles: a bilinear oscillator (a unit mass on a track under a force that is
a linear table of its distance, stiffness 4 N/m on one side of the origin
and 1 N/m on the other), in closed form: half sines of 2 and 1 rad/s, the
origin crossed at pi/4 + k 3 pi/2 going down and pi/4 + pi + k 3 pi/2 going
up; a first-order state z' = T(z), T a linear table with a kink at z = 2,
from z = 6: z = 1 + 5 exp(-t) until t = ln 5, then 2 exp(-(t - ln 5)/2).
"""

import math

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators.events import KINK_TOL

BILINEAR = """model bilinear_oscillator
table spring(x) = [(-1 m, 1 N), (0 m, 0 N), (1 m, -4 N)], extrapolation = linear
particle m { mass 1 }
joint track: point_on_line(m.cm, ground.origin, direction = (1, 0))
force k: joint_force(track, spring(track.distance))
initial m.x = 0.25
initial m.vx = 0
"""

PERIOD = 1.5 * math.pi


def bilinear_exact(t):
    """x(t) [m] of BILINEAR: 0.25 cos 2t until pi/4, then a half sine of
    1 rad/s below the origin (amplitude 0.5 m, pi s), a half sine of 2 rad/s
    above it (0.25 m, pi/2 s), and so on."""
    t = np.asarray(t, dtype=float)
    s = np.mod(t - math.pi / 4, PERIOD)
    return np.where(t < math.pi / 4, 0.25 * np.cos(2 * t),
                    np.where(s < math.pi, -0.5 * np.sin(s), 0.25 * np.sin(2 * (s - math.pi))))


def crossings(t_end):
    """The times [s] the mass passes the origin (the table's kink) up to t_end."""
    out, k = [], 0
    while True:
        for t in (math.pi / 4 + k * PERIOD, math.pi / 4 + math.pi + k * PERIOD):
            if t >= t_end:
                return out
            out.append(t)
        k += 1


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("method", ["hht-i3", "nstiff", "hht-si2", "genalpha", "newmark"])
def test_the_steps_land_on_every_kink_of_a_table_of_the_state(method, engine):
    """Each crossing of the origin is an event at the analytic time (to the
    run's own phase error), a step ends on it (|x| at that row below the
    landing tolerance times the speed), and the run keeps its order."""
    model = mbdsl.load_text(BILINEAR)
    h, t_end = 2e-3, 6.0
    sol = mbdsl.simulate(model, method=method, h=h, t_end=t_end, engine=engine)
    assert sol.completed, sol.message
    kinks = [e for e in sol.events if e[2] == "switched"]
    assert [e[1] for e in kinks] == ["spring(track.distance)"] * len(crossings(t_end))
    times = np.array([e[0] for e in kinks])
    phase = 2e-3 if method == "newmark" else 2e-4       # the run's own phase error at 6 s
    np.testing.assert_allclose(times, crossings(t_end), rtol=0, atol=phase)
    x = sol.column("m.x")
    for te in times:                # a step ends within the landing tolerance past it
        row = np.searchsorted(sol.t, te)
        assert 0.0 <= sol.t[row] - te <= KINK_TOL * h
        assert abs(x[row]) <= 0.5 * KINK_TOL * h                # on the kink (speed 0.5 m/s)


@pytest.mark.parametrize("method", ["hht-i3", "nstiff", "genalpha", "newmark"])
def test_a_bilinear_oscillator_converges_at_the_methods_order(method):
    model = mbdsl.load_text(BILINEAR)
    errors = []
    for h in (4e-3, 2e-3):
        sol = mbdsl.simulate(model, method=method, h=h, t_end=5.0)
        errors.append(np.abs(sol.column("m.x") - bilinear_exact(sol.t)).max())
    order = math.log2(errors[0] / errors[1])
    expected = 1.0 if method == "newmark" else 2.0
    assert abs(order - expected) < 0.15, (errors, order)


def test_both_engines_find_the_same_kinks():
    model = mbdsl.load_text(BILINEAR)
    runs = [mbdsl.simulate(model, method="hht-si2", h=1e-3, t_end=4.0, engine=e)
            for e in ("compiled", "numpy")]
    a, b = ([e[0] for e in r.events] for r in runs)
    assert len(a) == len(b) == len(crossings(4.0)) == 2
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    np.testing.assert_allclose(runs[0].q, runs[1].q, rtol=0, atol=1e-10)


def test_error_control_lands_on_the_kinks():
    model = mbdsl.load_text(BILINEAR)
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-2, t_end=6.0, rtol=1e-6, atol=1e-6)
    assert sol.completed, sol.message
    times = [e[0] for e in sol.events if e[2] == "switched"]
    np.testing.assert_allclose(times, crossings(6.0), rtol=0, atol=1e-4)
    assert np.abs(sol.column("m.x") - bilinear_exact(sol.t)).max() < 1e-3


LAG = """model kinked_lag   # z' = T(z), T linear by points with a kink at z = 2
table rate(z) = [(0, 0), (2, -1), (10, -9)], extrapolation = linear
state z { der = rate(z); initial 6 }
"""


def lag_exact(t):
    """z(t) of LAG: 1 + 5 exp(-t) down to 2 at t = ln 5, then 2 exp(-(t - ln 5)/2)."""
    t1 = math.log(5.0)
    return np.where(t < t1, 1.0 + 5.0 * np.exp(-t), 2.0 * np.exp(-(t - t1) / 2.0))


@pytest.mark.parametrize("method", ["hht-i3", "nstiff-si2", "genalpha"])
def test_a_first_order_state_through_a_kink_of_its_own_table(method):
    sol = mbdsl.simulate(mbdsl.load_text(LAG), method=method, h=1e-3, t_end=3.0)
    assert sol.completed, sol.message
    (event,) = sol.events
    assert event[1:3] == ("rate(z)", "switched")
    assert abs(event[0] - math.log(5.0)) < 1e-6
    assert np.abs(sol.column("state.z") - lag_exact(sol.t)).max() < 1e-5
