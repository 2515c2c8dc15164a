"""Rows at requested times (``output_dt``, ``output_times``: dense output).

Oracles: the slider crank's published state at t = 2 s
(tests/reference/slider_crank.json, a 1-DOF Lagrange equation integrated by
scipy), met by a row interpolated inside a step, converging at the method's
order; the bouncing ball's first apex from a reduced one-body ODE of the
same contact law (scipy, tight tolerance); a torque switched in time, whose
motion is exact in closed form; the step rows themselves for an output
interval that is a multiple of a fixed h (bit for bit); the run's counts.
"""

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate
import scipy.optimize

import mbdsl
from mbdsl.integrators.dense import output_times



MODELS = Path(__file__).resolve().parents[2] / "models"
SECOND_ORDER = ["hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
                "genalpha-si2"]
SWITCHED = """model switch
body d { mass 1; inertia 0.5 }
joint O: revolute(ground.origin, d.cm)
force m: torque(d, if(t < 1, 2, -1))
initial d.phi = 0
initial d.omega = 0
"""


def crank_at_2(ref, **kw):
    """(theta1, omega1) errors of the row at t = 2 s of the damped slider crank."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "slider_crank.mbd"), output_times=[2.0], **kw)
    i = int(np.searchsorted(sol.t, 2.0))
    assert sol.completed and sol.t[i] == 2.0
    return (abs(sol.column("crank.phi")[i] - ref["theta1_T"]),
            abs(sol.column("crank.omega")[i] - ref["omega1_T"]))


# every method on the compiled engine, HHT-I3 and HHT-ADD also on the numpy engine in CI;
# the numpy engine's other five (3-5 s each) run with -m slow
@pytest.mark.parametrize("method, engine", [(m, "compiled") for m in SECOND_ORDER]
                         + [(m, "numpy") for m in ("hht-i3", "hht-add")]
                         + [pytest.param(m, "numpy", marks=pytest.mark.slow)
                            for m in SECOND_ORDER if m not in ("hht-i3", "hht-add")])
def test_interpolated_rows_converge_at_the_methods_order(slider_crank_reference, method, engine):
    """t = 2 s halfway through a step (h = 2 / (N + 1/2)): the row there is
    the cubic Hermite interpolant (positions) and its derivative (velocities);
    its error against the reference falls as h^2 (observed 1.93 .. 2.02)."""
    ref = slider_crank_reference["cases"]["damped_x0_zero"]
    errors = []
    for n in (500, 1000, 2000):
        h = 2.0 / (n + 0.5)
        errors.append(crank_at_2(ref, method=method, h=h, t_end=2.0 + h, fixed=True,
                                 engine=engine))
    e = np.array(errors)
    orders = np.log2(e[:-1] / e[1:])
    assert np.all(orders > 1.8) and np.all(orders < 2.2), orders


@pytest.mark.parametrize("method", ["hht-i3", "nstiff-si2", "genalpha"])
def test_interpolated_rows_follow_the_tolerance(slider_crank_reference, method):
    """Under error control the row at t = 2 s, inside a step of a run to
    2.05 s, is as accurate as the step that ends a run at 2 s: within a
    factor 3 of its error, at rtol 1e-5 .. 1e-7, and falling with rtol."""
    ref = slider_crank_reference["cases"]["damped_x0_zero"]
    model = mbdsl.load(MODELS / "slider_crank.mbd")
    inside = []
    for rtol in (1e-5, 1e-6, 1e-7):
        e_row = crank_at_2(ref, method=method, h=1e-3, t_end=2.05, rtol=rtol, atol=rtol)
        end = mbdsl.simulate(model, method=method, h=1e-3, t_end=2.0, rtol=rtol, atol=rtol)
        e_step = abs(end.column("crank.phi")[-1] - ref["theta1_T"])
        assert e_row[0] < 3 * e_step + 1e-9, (rtol, e_row, e_step)
        inside.append(e_row[0])
    assert inside[2] < inside[1] < inside[0]


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("method", ["hht-i3", "nstiff-si2", "genalpha", "hht-add"])
def test_an_interval_that_is_a_multiple_of_h_writes_the_steps(method, engine):
    """Fixed steps of 1 ms, a row every 5 ms: the rows are the steps of
    ``output_every=5`` bit for bit; the counts are the steps' (sums over the
    rows equal the run's totals); the energy integrals are over the steps
    (equal to a run with every step at its rows), not over the rows."""
    model = mbdsl.load(MODELS / "slider_crank.mbd")
    every = mbdsl.simulate(model, method=method, h=1e-3, t_end=0.5, engine=engine)
    stride = mbdsl.simulate(model, method=method, h=1e-3, t_end=0.5, engine=engine,
                            output_every=5)
    dense = mbdsl.simulate(model, method=method, h=1e-3, t_end=0.5, engine=engine,
                           output_dt=5e-3)
    assert len(dense.t) == 101 and np.all(dense.t == stride.t)
    for x in ("q", "v", "a", "lam"):
        assert np.array_equal(getattr(dense, x), getattr(stride, x)), x
    assert np.array_equal(dense.stats["iterations"], stride.stats["iterations"])
    assert dense.stats_total.steps == 500
    assert dense.stats["iterations"].sum() == dense.stats_total.iterations
    for name in ("energy.work", "energy.dissipated", "energy.balance"):
        assert np.allclose(dense.column(name), every.column(name)[::5], rtol=0, atol=1e-12)
    # the strided rows integrate the damper's power over 5 ms: visibly off
    assert np.max(np.abs(stride.column("energy.dissipated")
                         - every.column("energy.dissipated")[::5])) > 1e-5


def apex_of_the_reduced_ode(e=0.8, k=1e7, n=1.5, r=0.05, drop=1.0, g=9.81):
    """Height of the centre at the first rebound's apex: the ball alone,
    m y'' = -m g + k d^n (1 + chi d' / v0), d = r - y > 0 (docs/contact.md),
    from first contact at the free-fall speed, integrated by scipy."""
    chi = scipy.optimize.brentq(lambda c: c * (1 + e) - math.log((1 + c) / (1 - c * e)),
                                1e-6, 1 / e - 1e-9)
    v0 = math.sqrt(2 * g * (drop - r))

    def rhs(_, z):
        d, dd = r - z[0], -z[1]
        f = k * max(d, 0.0) ** n * (1 + chi * dd / v0) if d > 0 else 0.0
        return [z[1], -g + max(f, 0.0)]

    def leaves(_, z):
        return z[0] - r
    leaves.terminal, leaves.direction = True, 1
    out = scipy.integrate.solve_ivp(rhs, (0, 0.1), [r, -v0], method="DOP853", rtol=1e-12,
                                    atol=1e-14, events=leaves, first_step=1e-8)
    y, vy = out.y_events[0][0]
    return y + vy ** 2 / (2 * g)


# the numpy engine with the stabilized index-2 methods (26 s and 16 s) runs with -m slow;
# CI keeps every method compiled and hht-i3 on both engines
@pytest.mark.parametrize("method, engine", [
    ("hht-i3", "compiled"), ("hht-i3", "numpy"), ("nstiff-si2", "compiled"),
    ("genalpha-si2", "compiled"),
    pytest.param("nstiff-si2", "numpy", marks=pytest.mark.slow),
    pytest.param("genalpha-si2", "numpy", marks=pytest.mark.slow)])
def test_bouncing_ball_a_row_every_millisecond(method, engine):
    """Error control at rtol 1e-6, a row every ms: 3001 rows on the grid plus
    two per event (the landed state and the restart, at the event's time); the
    first apex read from the rows (the largest y between the first opening and
    the next closing) within 1e-4 m of the reduced ODE's (gravity acts during
    the 4 ms contact: 0.6560 m, not 0.05 + e^2 0.95 = 0.658); the energy
    balance over the steps, as without dense output (an impact's damping is
    over between two rows)."""
    model = mbdsl.load(MODELS / "bouncing_ball.mbd")
    sol = mbdsl.simulate(model, method=method, rtol=1e-6, atol=1e-6, output_dt=1e-3,
                         engine=engine)
    steps = mbdsl.simulate(model, method=method, rtol=1e-6, atol=1e-6, engine=engine)
    assert sol.completed and sol.dense and len(sol.events) == len(steps.events) >= 8
    t = sol.t
    on_grid = np.abs(t * 1000 - np.round(t * 1000)) < 1e-9
    assert np.sum(on_grid) == 3001 and len(t) == 3001 + 2 * len(sol.events)
    assert np.all(np.diff(t) >= 0)
    for te, *_ in sol.events:
        assert np.sum(np.abs(t - te) < 1e-8) == 2
    opened, closed = sol.events[1][0], sol.events[2][0]
    flight = (t > opened) & (t < closed)
    assert np.max(sol.q[flight, 1]) == pytest.approx(apex_of_the_reduced_ode(), abs=1e-4)
    assert sol.stats_total.steps == steps.stats_total.steps
    assert sol.column("energy.dissipated")[-1] == pytest.approx(
        steps.column("energy.dissipated")[-1], rel=1e-9)
    assert abs(sol.column("energy.balance")[-1]) < 1e-3 and not sol.warnings


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("control", [{}, {"rtol": 1e-6, "atol": 1e-6}])
def test_a_switch_in_time_gets_its_rows(engine, control):
    """torque(d, if(t < 1, 2, -1)) on J = 0.5: omega = 4 t, then 4 - 2 (t - 1);
    rows every 0.1 s, the one at t = 1 exact (the steps end SWITCH_GAP before
    the switch and restart after it: the row there is the restart's), and a
    row at each end of the gap."""
    sol = mbdsl.simulate(mbdsl.load_text(SWITCHED), method="hht-i3", h=1e-3, t_end=2.0,
                         output_dt=0.1, engine=engine, **control)
    t = sol.t
    assert len(t) == 22 and np.sum(np.abs(t - 1.0) < 1e-9) == 2
    omega = np.where(t <= 1.0, 4 * t, 4 - 2 * (t - 1))
    phi = np.where(t <= 1.0, 2 * t ** 2, 2 + 4 * (t - 1) - (t - 1) ** 2)
    assert np.max(np.abs(sol.column("d.omega") - omega)) < 1e-9
    assert np.max(np.abs(sol.column("d.phi") - phi)) < 1e-9


def test_a_failed_run_ends_with_its_last_step():
    """A run that stops early has rows at the requested times it reached and
    one at its last accepted step."""
    from .test_newton import BLOW_UP
    model = mbdsl.load_text(BLOW_UP, "lock.mbd")
    steps = mbdsl.simulate(model, method="hht-i3", h=1e-2, t_end=5, on_failure="return")
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-2, t_end=5, on_failure="return",
                         output_dt=0.5)
    assert sol.status == "failed" and sol.t[-1] == steps.t[-1]
    assert np.array_equal(sol.q[-1], steps.q[-1])
    assert np.allclose(sol.t[:-1], 0.5 * np.arange(len(sol.t) - 1), atol=1e-12)
    assert sol.stats_total.steps == steps.stats_total.steps


def test_output_times():
    """Times from an interval or a list: sorted, after the start, t_end last."""
    assert np.allclose(output_times(0.0, 1.0, dt=0.3), [0.3, 0.6, 0.9, 1.0])
    assert np.allclose(output_times(0.0, 1.0, dt=0.25), [0.25, 0.5, 0.75, 1.0])
    assert np.allclose(output_times(0.0, 2.0, times=[1.5, 0.0, 0.5, 0.5]), [0.5, 1.5, 2.0])
    with pytest.raises(ValueError, match="outside the run"):
        output_times(0.0, 1.0, times=[2.0])
    with pytest.raises(ValueError, match="positive"):
        output_times(0.0, 1.0, dt=-1.0)
    with pytest.raises(ValueError, match="not both"):
        output_times(0.0, 1.0, dt=0.1, times=[0.5])
    model = mbdsl.load(MODELS / "slider_crank.mbd")
    with pytest.raises(ValueError, match="exclude each other"):
        mbdsl.simulate(model, output_times=[0.5], output_every=2)


def test_the_simulate_section_and_the_csv(tmp_path):
    """``output_dt`` in the simulate block; the CSV streamed during the run
    holds the same rows and energies as the Solution, and says its rows are
    at requested times; a loaded file keeps them."""
    text = (MODELS / "slider_crank.mbd").read_text().replace("t_end 2", "t_end 0.5; output_dt 10 ms")
    model = mbdsl.load_text(text)
    out = tmp_path / "run.csv"
    from mbdsl.io.csvfile import CsvStream
    writer = CsvStream(out, interval=0.0)
    sol = mbdsl.simulate(model, observers=[writer])
    assert len(sol.t) == 51 and np.allclose(sol.t, np.linspace(0, 0.5, 51), atol=1e-12)
    back = mbdsl.load_solution(out)
    assert np.allclose(back.t, sol.t) and np.allclose(back.q, sol.q, rtol=1e-12)
    assert np.allclose(back.column("energy.balance"), sol.column("energy.balance"),
                       rtol=1e-9, atol=1e-12)
    assert "# rows: at requested times" in out.read_text()


class _Rows:
    """A stand-in for the Solution: the rows DenseOutput writes."""

    def __init__(self):
        from mbdsl.io.rows import RunStats
        self.stats_total = RunStats()
        self.t, self.q, self.v = [], [], []

    def add_totals(self, counts, h):
        self.stats_total.steps += int(counts[:, 5].sum())

    def append_block(self, t, q, v, a, lam, extras, counts, h, totals=True, flows=None):
        self.t += list(t)
        self.q += list(q[:, 0])
        self.v += list(v[:, 0])


def test_the_interpolant_is_exact_on_a_cubic_and_the_last_time_is_kept():
    """q = t^3 (v = 3 t^2) sampled at uneven steps: the rows at the requested
    times are exact to round-off (a cubic Hermite reproduces cubics, its
    derivative their velocity); a requested t_end the last step ends 1e-13 s
    short of (steps of 1e-12 s) gets the last state."""
    from types import SimpleNamespace
    from mbdsl.integrators.dense import DenseOutput
    system = SimpleNamespace(m=1, has_loads=False, driver_functions=())
    start = SimpleNamespace(t=0.0, q=np.zeros(1), v=np.zeros(1), a=np.zeros(1),
                            lam=np.zeros(1), extra={})
    times = np.array([0.05, 0.3, 0.55, 0.8, 1.0])
    rows = _Rows()
    dense = DenseOutput(system, rows, times, start, None)
    steps = np.array([0.1, 0.25, 0.6, 0.9, 1.0 - 2e-12, 1.0 - 1e-13])

    def block(t):
        k = len(t)
        counts = np.zeros((k, 6), np.int64)
        counts[:, 5] = 1
        return (t, (t ** 3)[:, None], (3 * t ** 2)[:, None], (6 * t)[:, None], np.zeros((k, 1)),
                {}, counts, np.diff(np.concatenate([[0.0], t])))
    dense.append_block(*block(steps[:3]))
    dense.append_block(*block(steps[3:]))
    dense.close()
    t = np.array(rows.t)
    # the grid, the last step (where the run ended), then t_end with its state
    assert np.array_equal(t, np.concatenate([times[:4], [1.0 - 1e-13, 1.0]]))
    assert rows.q[-1] == rows.q[-2] and rows.stats_total.steps == 6
    inner = t < 0.95
    assert np.allclose(np.array(rows.q)[inner], t[inner] ** 3, rtol=1e-14, atol=1e-15)
    assert np.allclose(np.array(rows.v)[inner], 3 * t[inner] ** 2, rtol=1e-13, atol=1e-15)
