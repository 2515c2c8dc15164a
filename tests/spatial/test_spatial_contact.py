"""Contacts and joint limits in spatial models: a sphere on a plane, limits on
a spatial revolute's angle and a prismatic joint's distance.

Oracle: each scene reduces to one coordinate along the gap's normal, x'' = b
+ f / m with the Hunt-Crossley law f = K delta^n (1 + chi ddelta/dt /
v_impact) (cut at 0), chi solved here from the restitution by its own
relation chi (1 + e) = ln((1 + chi) / (1 - chi e)), and integrated by scipy's
DOP853 phase by phase, each closing located by solve_ivp's events. The
gaps' gradients and Hessians are checked by central differences; the
Newton matrix's Q_q and Q_v with every spatial gap by
``tests/assembly/test_derivatives.py`` (``spatial_contacts.mbd``).
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import mbdsl
from mbdsl.errors import MbdModelError

G = 9.81

BALL = """
model spatial_ball   # a ball dropped on a floor, thrown sideways
space 3d
gravity (0, 0, -9.81)
body ball { mass 0.5; inertia (0.002, 0.002, 0.002) }
force floor: contact(ball.cm, radius = 0.1, plane = (ground.origin, (0, 0, 1)), k = 1e6,
                     exponent = 1.5, restitution = 0.8)
initial ball.z = 1;  initial ball.vx = 0.5;  initial ball.vy = -0.2
initial ball.orientation = zyx(0, 0, 0);  initial ball.omega_body = (1, 2, 3)
simulate { method hht-i3; h 1e-3; t_end 1.5 }
"""

STOPS = """
model spatial_stops   # a door pushed against its stop, a slider pulled to its end
space 3d
body door { mass 10; inertia (1, 1.2, 0.3); point hinge (0, -0.4, 0) }
body slider { mass 2; inertia (0.01, 0.01, 0.01) }
joint h: revolute(ground.origin, door.hinge, ground.z, door.z)
joint s: prismatic(slider.cm, ground.origin, ground.x)
force stop: limit(h, lower = -0.5, upper = 0.7, k = 1e5, restitution = 0.5)
force end: limit(s, lower = -0.2, upper = 0.3, k = 1e6, exponent = 1, restitution = 0.9)
force push: torque(door, (0, 0, 2))
force pull: force(slider.cm, (-1, 0, 0))
simulate { method hht-i3; h 1e-3; t_end 2 }
"""
J_HINGE = 0.3 + 10 * 0.4 ** 2          # about the hinge: Jz + m d^2 [kg m^2]


def chi_of(e):
    """The damping factor of restitution e, from its defining relation."""
    if e == 1.0:
        return 0.0
    return brentq(lambda c: math.log((1 + c) / (1 - c * e)) - c * (1 + e), 1e-3, 1 / e - 1e-12)


def bounce(x0, v0, b, m, k, n, e, t_end):
    """x(t) of x'' = b + f / m with f the Hunt-Crossley law on delta = -x
    (module notes), from x(0) = x0 > 0, x'(0) = v0: a callable of t."""
    chi, pieces, t, y = chi_of(e), [], 0.0, np.array([x0, v0])
    while t < t_end:
        if y[0] >= 0.0:            # flight, until the gap closes
            def closes(t, y):
                return y[0]
            closes.terminal, closes.direction = True, -1
            rhs = (lambda t, y: [y[1], b])
        else:                      # contact, until it opens
            v_imp = max(-y[1], 1e-3)

            def closes(t, y):
                return y[0]
            closes.terminal, closes.direction = True, 1

            def rhs(t, y, v_imp=v_imp):
                d = max(-y[0], 0.0)
                f = max(k * d ** n * (1 + chi * (-y[1]) / v_imp), 0.0)
                return [y[1], b + f / m]
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-11, atol=1e-13,
                        dense_output=True, events=closes)
        pieces.append((t, sol.t[-1], sol.sol))
        t, y = sol.t[-1], sol.y[:, -1].copy()
        if sol.status == 1:        # nudge across the boundary, into the next phase
            y[0] = -1e-300 if closes.direction == -1 else 0.0
        if len(pieces) > 400:
            break

    def x(ts):
        out = np.empty(len(ts))
        for i, ti in enumerate(ts):
            for a, z, f in pieces:
                if a <= ti <= z:
                    out[i] = f(ti)[0]
                    break
            else:
                out[i] = np.nan
        return out
    return x


ALL = ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
       "genalpha-si2"]


@pytest.mark.parametrize("method", ALL)
def test_a_ball_bounces_on_a_floor_as_the_one_dimensional_impact(method):
    """Dropped from 1 m (0.9 m above contact) with e = 0.8: its height follows
    the reduced impact ODE within 1 mm (NEWMARK, first order: 5 mm) over
    three bounces, the first impact at sqrt(2 g 0.9), its sideways motion and
    spin untouched (frictionless), and its frame orthonormal; every method."""
    sol = mbdsl.simulate(mbdsl.load_text(BALL), method=method, rtol=1e-7, atol=1e-7)
    assert sol.completed and sol.engine == "compiled"
    kinds = [e[2] for e in sol.events]
    assert kinds[:4] == ["closed", "opened", "closed", "opened"]
    assert sol.events[0][3] == pytest.approx(math.sqrt(2 * G * 0.9), rel=1e-5)
    t = sol.column("t")
    z = bounce(0.9, 0.0, -G, 0.5, 1e6, 1.5, 0.8, 1.5)(t) + 0.1
    assert np.max(np.abs(sol.column("ball.z") - z)) < (5e-3 if method == "newmark" else 1e-3)
    # a wrong chi (Lankarani-Nikravesh's 3 (1 - e^2) / 4) would move it by centimetres
    np.testing.assert_allclose(sol.column("ball.x"), 0.5 * t, atol=1e-9)
    np.testing.assert_allclose(sol.column("ball.y"), -0.2 * t, atol=1e-9)
    # the spin: untouched (the methods' numerical damping: NEWMARK takes 4e-4 of it in 1.5 s)
    spin_tol = 1e-3 if method == "newmark" else 1e-7
    for c, w in zip(("wx", "wy", "wz"), (1, 2, 3)):
        np.testing.assert_allclose(sol.column("ball." + c), w, rtol=0, atol=spin_tol * w)
    A = sol.q[:, 3:12].reshape(-1, 3, 3)
    assert np.max(np.abs(A @ np.swapaxes(A, 1, 2) - np.eye(3))) < 1e-10


def test_a_restitution_of_one_keeps_the_energy():
    """e = 1: no damping, the energy after three bounces is the energy at the
    start (the contact's potential counted while closed)."""
    text = BALL.replace("restitution = 0.8", "restitution = 1")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-si2", rtol=1e-8, atol=1e-8)
    E = sol.column("energy.total")
    assert len(sol.events) >= 4
    assert np.max(np.abs(E - E[0])) < 1e-4 * abs(E[0])


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "newmark"])
def test_stops_on_a_spatial_revolute_and_a_prismatic(method):
    """A door pushed by 2 N m against its upper stop at 0.7 rad (e = 0.5) and
    a slider pulled by 1 N to its lower end at -0.2 m (e = 0.9): the joint
    angle and distance follow their reduced impact ODEs; the closings come
    in the order and at the times free motion gives."""
    sol = mbdsl.simulate(mbdsl.load_text(STOPS), method=method, rtol=1e-7, atol=1e-7)
    assert sol.completed
    first = {}
    for t_e, name, kind, speed in sol.events:
        if kind == "closed":
            first.setdefault(name, (t_e, speed))
    alpha = 2 / J_HINGE
    rel = 1e-4 if method == "newmark" else 1e-6      # NEWMARK: first order
    assert first["stop.upper"][0] == pytest.approx(math.sqrt(2 * 0.7 / alpha), rel=rel)
    assert first["end.lower"][0] == pytest.approx(math.sqrt(2 * 0.2 / 0.5), rel=rel)
    assert first["stop.upper"][1] == pytest.approx(math.sqrt(2 * 0.7 * alpha), rel=10 * rel)
    assert "stop.lower" not in first and "end.upper" not in first
    t = sol.column("t")
    angle = 0.7 - bounce(0.7, 0.0, -alpha, J_HINGE, 1e5, 1.0, 0.5, 2.0)(t)
    tol = 1e-2 if method == "newmark" else 2e-4      # NEWMARK: first order
    theta = np.arctan2(sol.column("door.A21"), sol.column("door.A11"))
    assert np.max(np.abs(theta - angle)) < tol
    s = bounce(0.2, 0.0, -0.5, 2.0, 1e6, 1.0, 0.9, 2.0)(t) - 0.2
    assert np.max(np.abs(sol.column("slider.x") - s)) < tol


def test_the_gaps_gradients_and_hessians_are_their_derivatives():
    """Every spatial gap of ``spatial_contacts.mbd`` at random coordinates:
    the gradient the kernels give (the event locator's, ``contact_gaps``)
    against central differences of g."""
    from pathlib import Path
    from mbdsl.assembly.system import assemble
    path = Path(__file__).resolve().parents[1] / "dsl" / "valid" / "spatial_contacts.mbd"
    system = assemble(mbdsl.load(path))
    state = system.contact_state
    rng = np.random.default_rng(3)
    for _ in range(3):
        qx = system._ext(rng.normal(size=system.n))
        g, grad = system.contact_gaps(qx)
        eps = 1e-6
        for a in range(system.n):
            e = np.zeros_like(qx)
            e[a] = eps
            d = (system.contact_gaps(qx + e)[0] - system.contact_gaps(qx - e)[0]) / (2 * eps)
            mine = np.array([grad[i][state.cols[i] == a].sum() for i in range(len(g))])
            np.testing.assert_allclose(mine, d, atol=1e-6 * max(1.0, np.max(np.abs(d))))


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_the_gap_is_a_column_of_the_run(engine):
    """``floor.gap`` of the ball is its centre's height less the radius, at
    fixed steps (the closing landed on: a row where the gap is zero), on both
    engines alike."""
    text = BALL.replace("simulate {", "output h = floor.gap\nsimulate {")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-3, t_end=0.6,
                         engine=engine)
    assert sol.engine == engine
    closing = sol.events[0][0]
    assert closing == pytest.approx(math.sqrt(2 * 0.9 / G), abs=1e-9)
    assert sol.column("output.h")[np.searchsorted(sol.t, closing)] == pytest.approx(0, abs=1e-8)
    np.testing.assert_allclose(sol.column("output.h"), sol.column("ball.z") - 0.1, atol=1e-12)
    assert np.min(sol.column("output.h")) < -1e-3          # the run went through an impact


@pytest.mark.parametrize("line, code, words", [
    ("force f: contact(ball.cm, radius = 0.1, line = (ground.origin, (1, 0)), k = 1e6)",
     "E305", "plane"),
    ("force f: contact(ball.cm, radius = 0.1, plane = (ground.origin, (0, 0, 1)), k = 1e6, "
     "mu = 0.3)", "E205", "friction"),
    ("force f: contact(ball.cm, radius = 0.1, plane = (ground.origin, (0, 0, 0)), k = 1e6)",
     "E303", "normal"),
    ("force f: contact(ball.cm, radius = 0.1, plane = (ball.cm, (0, 0, 1)), k = 1e6)",
     "E402", "itself"),
    ("force f: limit(sp, lower = -1, k = 1e3)", "E305", "spherical"),
    ("force f: limit(rv, lower = -1, upper = 3.2, k = 1e3)", "E303", "pi"),
])
def test_spatial_contact_errors(line, code, words):
    """What a spatial contact or limit refuses, at its line."""
    text = ("model bad\nspace 3d\nbody ball { mass 1; inertia (1, 1, 1) }\n"
            "body arm { mass 1; inertia (1, 1, 1) }\nbody top { mass 1; inertia (1, 1, 1) }\n"
            "joint sp: spherical(ground.origin, arm.cm)\n"
            "joint rv: revolute(ground.origin, top.cm, ground.z, top.z)\n" + line + "\n")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(text)
    found = [d for d in err.value.diagnostics if d.code == code]
    assert found and words in found[0].message and found[0].span.line == 8


def test_a_plane_in_a_planar_model_is_an_error():
    """``plane`` is a spatial contact's: a planar model says so (E305)."""
    text = ("model bad\nbody ball { mass 1; inertia 1 }\n"
            "force f: contact(ball.cm, radius = 0.1, plane = (ground.origin, (0, 0, 1)), "
            "k = 1e6)\n")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(text)
    assert any(d.code == "E305" and "plane" in d.message for d in err.value.diagnostics)


def test_a_ball_rests_on_the_floor_in_static_equilibrium():
    """``initial static``: the ball sinks into the floor until the contact
    carries its weight, K delta^n = m g (its place on the frictionless floor
    and its orientation held by ``initial`` lines: nothing else holds them)."""
    text = """
model resting
space 3d
gravity (0, 0, -9.81)
body ball { mass 0.5; inertia (0.002, 0.002, 0.002) }
force floor: contact(ball.cm, radius = 0.1, plane = (ground.origin, (0, 0, 1)), k = 1e6,
                     exponent = 1.5, restitution = 0.8)
initial ball.x = 0;  initial ball.y = 0;  initial ball.orientation = zyx(0, 0, 0)
guess ball.z = 0.099
initial static
"""
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-3, t_end=0.05)
    delta = (0.5 * G / 1e6) ** (1 / 1.5)
    assert sol.column("ball.z")[0] == pytest.approx(0.1 - delta, abs=1e-12)
    # at rest there, it stays
    assert np.max(np.abs(sol.column("ball.z") - (0.1 - delta))) < 1e-9


def test_a_door_held_by_its_stop_in_static_equilibrium():
    """``initial static`` with the door pushed against its upper stop: the
    stop's torque k (theta - upper) balances the push, theta = 0.7 + 2 / k."""
    text = STOPS.replace("simulate {", "guess door.orientation = zyx(0.705, 0, 0)\n"
                                        "guess slider.x = -0.2001\ninitial static\nsimulate {")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-3, t_end=0.05)
    theta = np.arctan2(sol.column("door.A21"), sol.column("door.A11"))
    assert theta[0] == pytest.approx(0.7 + 2 / 1e5, abs=1e-10)
    assert sol.column("slider.x")[0] == pytest.approx(-0.2 - 1 / 1e6, abs=1e-12)
