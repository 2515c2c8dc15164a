"""Contact scenes stepped through with events and error-controlled steps.

Oracles: free flight between impacts (a rebound's apex follows from the
state at the opening exactly, y + vy^2 / 2g) against e^2 of the drop height
the restitution promises; energy conservation for a stop with e = 1; the
stop's own restitution from the speeds at its closing and opening.
"""

import json
import math

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import MbdModelError
from pathlib import Path

MODELS = Path(__file__).resolve().parents[2] / "models"
ALL = ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
       "genalpha-si2"]
SECOND_ORDER = ALL[1:]
G = 9.81


def apexes(sol, radius):
    """Heights of the centre above contact at each rebound's apex, from the
    first stored row after each opening (free flight from there)."""
    y, vy = sol.q[:, 1], sol.v[:, 1]
    out = []
    for t_event, _, kind, _ in sol.events:
        if kind == "opened":
            i = np.searchsorted(sol.t, t_event)
            out.append(y[i] + vy[i] ** 2 / (2 * G) - radius)
    return np.array(out)


# every method on the compiled engine and HHT-I3 on the numpy engine in CI; the numpy
# engine's other eight (5-11 s each) run with -m slow
@pytest.mark.parametrize("method, engine", [(m, "compiled") for m in ALL] + [("hht-i3", "numpy")]
                         + [pytest.param(m, "numpy", marks=pytest.mark.slow)
                            for m in ALL if m != "hht-i3"])
def test_bouncing_ball(method, engine):
    """Dropped from 1 m (0.95 m above contact), e = 0.8: the first rebound
    rises to e^2 = 0.64 of the drop within 3 %; no impact adds energy. On
    both engines: the compiled loop returns at each event for the driver's
    event location to land a step on it."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "bouncing_ball.mbd"), method=method,
                         rtol=1e-6, atol=1e-6, engine=engine)
    assert sol.completed and sol.engine == engine
    kinds = [e[2] for e in sol.events]
    assert kinds[:4] == ["closed", "opened", "closed", "opened"]
    assert sol.events[0][3] == pytest.approx(math.sqrt(2 * G * 0.95), rel=2e-5)  # impact speed
    apex = apexes(sol, 0.05)
    assert apex[0] / (0.64 * 0.95) == pytest.approx(1.0, abs=0.03)
    E = sol.column("energy.total")
    for k in range(0, len(sol.events) - 1, 2):
        before = E[np.searchsorted(sol.t, sol.events[k][0]) - 1]
        after = E[np.searchsorted(sol.t, sol.events[k + 1][0])]
        assert after <= before + 1e-9
    # the step sizes follow the scene: long in flight, short in contact
    h = sol.stats["h"][1:]
    assert h.max() > 100 * h.min()


def test_bouncing_ball_fixed_steps_land_on_the_impacts():
    """Without a tolerance the steps are h, except those cut to land on an event
    (the compiled error-controlled loop with its error estimate off)."""
    text = (MODELS / "bouncing_ball.mbd").read_text().replace("; tol 1e-6", "")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-4, t_end=0.6)
    assert sol.control is None and sol.engine == "compiled"
    closing = sol.events[0]
    assert closing[0] == pytest.approx(math.sqrt(2 * 0.95 / G), abs=1e-9)
    i = np.searchsorted(sol.t, closing[0])
    assert sol.q[i, 1] - 0.05 == pytest.approx(0.0, abs=1e-8)     # a row on the closing
    assert sol.event_cuts >= 2
    assert np.median(sol.stats["h"][1:]) == pytest.approx(1e-4)
    assert apexes(sol, 0.05)[0] / (0.64 * 0.95) == pytest.approx(1.0, abs=0.03)


def swing_energy(sol):
    """Total energy above the rest state (hanging: CM 0.5 m below the pivot)."""
    return sol.column("energy.total") + G * 0.5


@pytest.mark.parametrize("method", SECOND_ORDER)
def test_pendulum_against_a_stop_keeps_its_energy(method):
    """Restitution 1 and no other dissipation: after ten impacts the energy of
    the swing is within 1e-3 of its initial 4.17 J (rtol 1e-6)."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "pendulum_stop.mbd", {"e": 1.0}), method=method,
                         rtol=1e-6, atol=1e-6)
    assert sol.completed
    opened = [e for e in sol.events if e[2] == "opened"]
    assert len(opened) >= 10
    E = swing_energy(sol)
    assert E[0] == pytest.approx(0.5 / 3 * 25, rel=1e-12)
    after_ten = E[np.searchsorted(sol.t, opened[9][0])]
    assert abs(after_ten - E[0]) < 1e-3 * E[0]


def test_pendulum_stop_restitution():
    """e = 0.5: each bounce off a stop leaves with half the approach speed
    (gravity acts over the 6 ms of contact: 2 %)."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "pendulum_stop.mbd"), method="hht-si2",
                         rtol=1e-7, atol=1e-7)
    ev = sol.events
    assert ev[0][1] in ("stop.upper", "stop.lower") and ev[0][2] == "closed"
    for k in range(0, 6, 2):
        assert ev[k][1] == ev[k + 1][1] and ev[k + 1][2] == "opened"
        assert ev[k + 1][3] / ev[k][3] == pytest.approx(0.5, abs=0.02)


@pytest.mark.parametrize("method", ALL)
def test_clearance_slider_crank_short(method):
    """The first 0.1 s of the clearance slider crank: no failed step, the pin
    stays near its hole's wall (penetration well below the clearance), and
    the summary counts the events and rejected steps."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "slider_crank_clearance.mbd"), method=method,
                         t_end=0.1)
    assert sol.completed
    assert len(sol.events) >= 1
    text = sol.summary()
    assert "events:" in text and "rejected" in text
    g = sol.system.contact_state
    qx = sol.system._ext(sol.q)
    worst = min(g.gaps_one(0, row) for row in qx)
    assert -1e-4 < worst < 0          # in contact, by less than a fifth of the 0.5 mm clearance


@pytest.mark.parametrize("method", ALL)
def test_clearance_slider_crank_two_seconds(method):
    """The whole 2 s (about 60 000 steps, compiled): no failed step, and the
    pin never sinks into its hole's wall by a fifth of the clearance."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "slider_crank_clearance.mbd"), method=method)
    assert sol.completed and sol.t[-1] == pytest.approx(2.0) and sol.engine == "compiled"
    g = sol.system.contact_state
    worst = min(g.gaps_one(0, row) for row in sol.system._ext(sol.q[::10]))
    assert -1e-4 < worst < 0


def test_events_are_written(tmp_path):
    out = tmp_path / "ball.csv"
    from mbdsl.cli.main import main
    assert main(["simulate", str(MODELS / "bouncing_ball.mbd"), "-o", str(out),
                 "--t-end", "1"]) == 0
    from mbdsl.io.csvfile import read_csv_metadata
    meta, _, _ = read_csv_metadata(out)
    events = json.loads(meta["events"])
    assert [e[1:3] for e in events[:2]] == [["floor", "closed"], ["floor", "opened"]]
    assert int(meta["event_cuts"]) >= 1


@pytest.mark.parametrize("text, code, words", [
    ("force f: contact(b.cm, radius = 0.05, k = 1e6)", "E305", "needs one of"),
    ("force f: contact(b.cm, radius = 0.05, line = (ground.origin, 1), k = 1e6)", "E305",
     "expected line"),
    ("force f: contact(b.cm, radius = 0.05, circle = (ground.origin, 0.04), k = 1e6)", "E303",
     "must exceed"),
    ("force f: contact(b.cm, radius = 0.05, line = (ground.origin, (1, 0)), k = 1e6, "
     "restitution = 1.2)", "E303", "restitution"),
    ("force f: contact(b.cm, radius = 0.05, line = (ground.origin, (1, 0)), k = 0)", "E303",
     "stiffness"),
    ("force f: contact(b.cm, radius = 0.05, line = (ground.origin, (1, 0)), k = 1e6, "
     "mu = -0.1)", "E303", "must not be negative"),
    ("force f: limit(O, k = 1e5)", "E305", "needs 'lower', 'upper'"),
    ("force f: limit(O, lower = 1, upper = 0, k = 1e5)", "E303", "below"),
    ("force f: limit(D, lower = 0, k = 1e5)", "E305", "distance joint"),
])
def test_contact_errors(text, code, words):
    src = f"""model m
body b {{ mass 1; inertia 0.1; point P (0.1, 0) }}
body c {{ mass 1; inertia 0.1 }}
joint O: revolute(ground.origin, b.P)
joint D: distance(b.cm, c.cm, length = 1)
{text}
"""
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(src)
    d = err.value.diagnostics[0]
    assert d.code == code and words in d.message
    assert d.span is not None and d.span.line >= 6


def test_contact_from_python():
    """The same ball built from spec objects: the nested (point, direction)
    pair and the run's events as from the file."""
    from mbdsl import BodySpec, ForceSpec, InitialSpec, ModelSpec, from_spec
    spec = ModelSpec(
        "ball", gravity=(0, -9.81),
        bodies=(BodySpec.rigid("ball", mass=1, inertia=1e-3),),
        forces=(ForceSpec("floor", "contact", ("ball.cm",),
                          {"radius": 0.05, "line": ("ground.origin", (1, 0)), "k": 1e7,
                           "restitution": 0.8}),),
        initials=(InitialSpec("ball.x", 0), InitialSpec("ball.y", 1), InitialSpec("ball.phi", 0)))
    sol = mbdsl.simulate(from_spec(spec), method="hht-i3", h=1e-3, t_end=0.6, rtol=1e-6)
    assert sol.events[0][:3] == pytest.approx((math.sqrt(2 * 0.95 / G), "floor", "closed"))


ROLLING = """model rolling_disk
parameter r = 0.05
parameter m = 1
gravity (0, -9.81)
body disk { mass m; inertia m*r^2/2 }
force floor: contact(disk.cm, radius = r, line = (ground.origin, (1, 0)), k = 1e7,
                     restitution = 0.8, mu = 0.2)
initial disk.x = 0
initial disk.y = r - (m*9.81/1e7)^(2/3)     # resting on the floor under its weight
initial disk.phi = 0
initial disk.vx = 2
initial disk.vy = 0
initial disk.omega = 0
"""


@pytest.mark.parametrize("method", ALL)
def test_friction_at_a_contact_rolls_a_sliding_disk(method):
    """A disk thrown along a floor without spin (mu = 0.2): it slides at
    deceleration mu g while friction spins it up, until v = -omega r at t =
    v0 / (3 mu g); then it rolls at v0 / (1 + I / (m r^2)) = 2/3 v0. The
    energy friction takes, 2 - 4/3 = 2/3 J, is in energy.dissipated."""
    sol = mbdsl.simulate(mbdsl.load_text(ROLLING), method=method, h=1e-3, t_end=0.6,
                         rtol=1e-6, atol=1e-6)
    assert sol.completed
    vx, omega = sol.v[:, 0], sol.v[:, 2]
    i = np.searchsorted(sol.t, 0.2)
    assert vx[i] == pytest.approx(2.0 - 0.2 * G * sol.t[i], abs=1e-3)
    assert vx[-1] == pytest.approx(4.0 / 3.0, rel=1e-6)
    assert -omega[-1] * 0.05 == pytest.approx(4.0 / 3.0, rel=1e-6)
    assert sol.column("energy.dissipated")[-1] == pytest.approx(2.0 / 3.0, rel=0.01)


THROUGH_ZERO = """model through_zero
body b { mass 1; inertia 0.1 }
joint P: prismatic(b.cm, ground.origin, direction = (1, 0))
force sp: spring_damper(ground.origin, b.cm, k = 100, c = 0, length = 0.5)
initial b.x = 0.3
initial b.vx = -6
"""


@pytest.mark.parametrize("engine", ["numpy", "compiled"])
@pytest.mark.parametrize("method", ["hht-i3", "nstiff-si2", "hht-add", "genalpha"])
def test_spring_through_zero_length_is_an_event(method, engine):
    """The spring pushes its points apart (free length 0.5 m) until they pass
    each other; its 50 N force flips there. From x = 0.5 - 0.2 cos 10t - 0.6
    sin 10t the pass is at t = (atan2(0.6, 0.2) - acos(0.5 / sqrt(0.4))) / 10;
    both engines land a step on it (the compiled loop returns at the step
    across), which keeps the energy (20 J) to 1e-2 J: stepping across the
    jump lost 0.19 J (measured with HHT-I3 before the compiled loop located it)."""
    t_pass = (math.atan2(0.6, 0.2) - math.acos(0.5 / math.sqrt(0.4))) / 10
    sol = mbdsl.simulate(mbdsl.load_text(THROUGH_ZERO), method=method, h=1e-3, t_end=0.2,
                         engine=engine)
    assert sol.engine == engine and sol.completed
    assert [e[1:3] for e in sol.events] == [("sp", "passed")]
    # the run's own error at h (BDF2: its BDF1 start-up step's)
    assert sol.events[0][0] == pytest.approx(t_pass, abs=2e-5 if "nstiff" in method else 2e-6)
    assert sol.run_warnings() == []
    assert abs(sol.column("energy.total")[-1] - 20.0) < 1e-2
    assert "1 springs through zero length" in sol.summary()


@pytest.mark.parametrize("tol", [None, 1e-6])
@pytest.mark.parametrize("method", ALL)
def test_both_engines_land_a_spring_pass_alike(method, tol):
    """The compiled loop's event (the step across returned untaken, landed by
    the same ``EventLocator``) against the numpy engine's: the same steps,
    the pass at the same time to the event tolerance (1e-6 h), the same
    states (fixed steps and error-controlled ones)."""
    model = mbdsl.load_text(THROUGH_ZERO)
    runs = [mbdsl.simulate(model, method=method, h=1e-3, t_end=0.2, engine=engine,
                           rtol=tol, atol=tol) for engine in ("numpy", "compiled")]
    a, b = runs
    assert b.engine == "compiled"
    assert len(a.t) == len(b.t) and a.event_cuts == b.event_cuts
    assert [e[1:3] for e in b.events] == [("sp", "passed")]
    assert abs(a.events[0][0] - b.events[0][0]) < 1e-9
    assert np.max(np.abs(a.t - b.t)) < 1e-9
    assert np.max(np.abs(a.q - b.q)) < 1e-8
    assert np.max(np.abs(a.v - b.v)) < 1e-6


SWITCHED = """model switched
body w { mass 1; inertia 0.5 }
joint O: revolute(ground.origin, w.cm)
force motor: torque(w, if(t < 0.3337, 2, 0))
initial w.phi = 0
initial w.omega = 0
"""


@pytest.mark.parametrize("engine", ["numpy", "compiled"])
@pytest.mark.parametrize("method", ALL)
def test_a_torque_that_switches_off_is_landed_on(method, engine):
    """2 N m on 0.5 kg m^2 until t = 0.3337 s, then nothing: omega = 4 t0 after
    it. A step lands on the switch and the method restarts there with the
    new branch's acceleration: exact to round-off at h = 0.01 (NSTIFF's angle
    keeps its BDF1 start-up error), where stepping across is off by 5e-3.
    The compiled loops run from switch to switch (``events.switch_times``)."""
    t0 = 0.3337
    sol = mbdsl.simulate(mbdsl.load_text(SWITCHED), method=method, h=1e-2, t_end=1,
                         engine=engine)
    assert sol.engine == engine
    assert [e[2] for e in sol.events] == ["switched"]
    assert sol.events[0][0] == pytest.approx(t0, abs=1e-14)
    assert sol.column("w.omega")[-1] == pytest.approx(4 * t0, abs=1e-10)
    phi = 2 * t0 ** 2 + 4 * t0 * (1 - t0)
    tol = 1e-3 if method.startswith("nstiff") else 1e-10
    assert sol.column("w.phi")[-1] == pytest.approx(phi, abs=tol)
    # the row at the switch holds the new branch: no torque, no acceleration
    i = np.searchsorted(sol.t, t0)
    assert sol.t[i] == pytest.approx(t0, abs=1e-11) and abs(sol.a[i, 2]) < 1e-12
    assert "1 function switches" in sol.summary()


MIXED = """model mixed_events
gravity (0, -9.81)
particle ball { mass 1 }
ground { point anchor (0, 0.6) }
force floor: contact(ball.cm, radius = 0.05, line = (ground.origin, (1, 0)), k = 1e6,
                     restitution = 0.8)
force sp: spring_damper(ground.anchor, ball.cm, k = 20, c = 0, length = 0.3)
force push: force(ball.cm, (0, if(t < 0.25, 1, 0) + min(0, 0.5 - t)))
initial ball.x = 0
initial ball.y = 1
"""


@pytest.mark.parametrize("method", ALL)
def test_every_kind_of_event_in_one_compiled_run(method):
    """A ball dropped through a spring's anchor onto a floor, pushed by a
    force that switches at 0.25 s (on a node of the step grid) and kinks at
    0.5 s: switches, a spring's pass and impacts in one run. The compiled
    loop lands each as the numpy engine's does (error-controlled steps): the
    same events to 1e-8 s and the same motion to 1e-8 m."""
    a, b = (mbdsl.simulate(mbdsl.load_text(MIXED), method=method, h=1e-3, t_end=1.2,
                           engine=engine, rtol=1e-6, atol=1e-6) for engine in ("numpy", "compiled"))
    assert b.engine == "compiled" and a.completed and b.completed
    kinds = [e[1:3] for e in b.events]
    assert kinds[:5] == [(kinds[0][0], "switched"), ("sp", "passed"), ("floor", "closed"),
                         ("floor", "opened"), (kinds[0][0], "switched")]
    assert [e[1:3] for e in a.events] == kinds
    assert b.events[0][0] == 0.25 and b.events[4][0] == 0.5
    assert max(abs(x[0] - y[0]) for x, y in zip(a.events, b.events)) < 1e-8
    assert len(a.t) == len(b.t) and np.max(np.abs(a.q - b.q)) < 1e-8


@pytest.mark.parametrize("tol", [None, 1e-6])
@pytest.mark.parametrize("method", ALL)
def test_both_engines_land_a_switch_alike(method, tol):
    """The compiled loops' segments from switch to switch against the numpy
    engine's step-by-step landing: the same rows (t, q, v, a) to round-off,
    with fixed steps and error-controlled ones (whose step after the
    switch is the one planned before the shortened one, as the driver's)."""
    model = mbdsl.load_text(SWITCHED.replace("0.3337, 2, 0", "0.3337, 2, min(0.2, 1 - t)"))
    a, b = (mbdsl.simulate(model, method=method, h=1e-2, t_end=1, engine=engine, rtol=tol,
                           atol=tol) for engine in ("numpy", "compiled"))
    assert b.engine == "compiled"
    assert [e[:3] for e in a.events] == [e[:3] for e in b.events]
    assert [e[2] for e in b.events] == ["switched", "switched"]        # 0.3337 and 0.8
    assert len(a.t) == len(b.t)
    for x in ("t", "q", "v", "a"):
        assert np.max(np.abs(getattr(a, x) - getattr(b, x))) < 1e-10, x
