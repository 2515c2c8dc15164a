"""Sensors: ``output`` lines that read multipliers, contacts, friction and
flexible beams.

Oracles, each computed here from other columns or from mechanics, not by
the code under test: the Hunt-Crossley law of docs/contact.md from the
ball's height and speed and the impact speed of its event; Coulomb's law
-mu f tanh(v_t / v_reg) from the normal force and the slip speed; a block
sliding on an incline, whose normal reaction is m g cos(theta); a body
hanging at rest, whose pin carries its weight; a beam's mid-point
deflection from the chord (``Beam.deflection_mid``, another formula), the
crank's pin (a rigid body's point) where the beam is pinned to it, and a
central difference of the beam point's position for its velocity.
"""

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize

import mbdsl
from mbdsl.errors import MbdModelError

MODELS = Path(__file__).resolve().parents[2] / "models"

BALL = """model ball
gravity (0, -9.81)
particle ball {{ mass 1 }}
force floor: contact(ball.cm, radius = 0.05, line = (ground.origin, (1, 0)), k = 1e7,
                     exponent = 1.5, restitution = 0.8{friction})
initial ball.x = 0
initial ball.y = {y0}
initial ball.vx = {vx0}
output N = floor.normal
output g = floor.gap
output gd = floor.gap_rate
output P = floor.power
output F = floor.friction
"""


def chi_of(e):
    """The damping factor that restitutes e exactly (docs/contact.md)."""
    return scipy.optimize.brentq(lambda c: c * (1 + e) - math.log((1 + c) / (1 - c * e)),
                                 1e-6, 1 / e - 1e-9)


def test_a_contacts_sensors_follow_its_law():
    """The bouncing ball's first two impacts, a row per step (rtol 1e-6):
    floor.gap = y - r, floor.gap_rate = vy; floor.normal = K delta^1.5 (1 +
    chi ddelta / v_impact) while in contact (v_impact: the closing event's
    speed), 0 in flight; floor.power = the damping's part times ddelta/dt;
    all to 1e-10 of the force's scale. The unit of floor.normal is N."""
    model = mbdsl.load_text(BALL.format(friction="", y0=1, vx0=0))
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=1.2, rtol=1e-6, atol=1e-6)
    y, vy, t = sol.column("ball.y"), sol.column("ball.vy"), sol.t
    delta, ddelta = 0.05 - y, -vy
    closings = [e for e in sol.events if e[2] == "closed"]
    v_imp = np.zeros(len(t))
    for te, _, _, speed in closings:
        v_imp[t >= te - 1e-12] = speed
    elastic = 1e7 * np.clip(delta, 0, None) ** 1.5
    f = np.where(delta > 0, np.clip(elastic * (1 + chi_of(0.8) * ddelta
                                               / np.where(v_imp > 0, v_imp, 1.0)), 0, None), 0)
    scale = np.max(f)
    assert scale > 1e3 and np.sum(f > 0) > 50         # rows inside the contacts
    assert np.max(np.abs(sol.column("output.N") - f)) < 1e-10 * scale
    assert np.max(np.abs(sol.column("output.g") - (y - 0.05))) < 1e-15
    assert np.max(np.abs(sol.column("output.gd") - vy)) < 1e-15
    power = np.where(delta > 0, (f - elastic) * ddelta, 0.0)
    assert np.max(np.abs(sol.column("output.P") - power)) < 1e-10 * scale * 5
    assert np.all(sol.column("output.F") == 0.0)
    assert sol.column_units()["output.N"] == "N" and sol.column_units()["output.P"] == "W"


def test_contact_friction_follows_coulombs_law():
    """A ball pressed into the floor (started 1 mm into it, sliding at 1
    m/s, mu = 0.3): floor.friction = -mu floor.normal tanh(vx / v_reg) at
    every row, to 1e-10 of the normal force; it slows the ball (F vx < 0)."""
    model = mbdsl.load_text(BALL.format(friction=", mu = 0.3", y0=0.049, vx0=1.0))
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-5, t_end=0.005)
    assert sol.completed
    N, F, vx = sol.column("output.N"), sol.column("output.F"), sol.column("ball.vx")
    assert np.max(N) > 10 and np.sum(N > 0) > 100
    expected = -0.3 * N * np.tanh(vx / 1e-4)
    assert np.max(np.abs(F - expected)) < 1e-10 * np.max(N)
    assert np.all(F[N > 0] * vx[N > 0] < 0)


def test_joint_friction_on_an_incline():
    """The block sliding down the 30-degree incline: its friction element
    reads f.speed = P.speed, f.friction = -mu m g cos(theta) (the normal
    reaction of a block on an incline; tanh = 1 once it slides), f.power =
    -f.friction f.speed, and the dissipated energy equals the integral of
    f.power (trapezoidal, to the rows' quadrature)."""
    text = (MODELS / "incline_friction.mbd").read_text().replace(
        "output s = P.distance", "output s = P.distance\noutput z = f.speed\n"
        "output tau = f.friction\noutput p = f.power\noutput zs = P.speed")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-si2", h=1e-4, t_end=0.5)
    z, tau, p = (sol.column(f"output.{k}") for k in ("z", "tau", "p"))
    assert np.max(np.abs(z - sol.column("output.zs"))) < 1e-12
    sliding = z > 0.01
    assert np.sum(sliding) > 4000
    normal = 2 * 9.81 * math.cos(math.pi / 6)
    assert np.max(np.abs(tau[sliding] + 0.3 * normal)) < 1e-8 * normal
    assert np.max(np.abs(p + tau * z)) < 1e-12
    assert sol.column_units()["output.tau"] == "N" and sol.column_units()["output.p"] == "W"
    dissipated = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(sol.t) * (p[1:] + p[:-1]))])
    assert dissipated[-1] == pytest.approx(sol.column("energy.dissipated")[-1], rel=1e-6)


def test_a_multiplier_by_name():
    """A bar hanging at rest from a pin at its end: lambda.O.1 = -m g (the
    pin's vertical row carries the weight: M a + Phi_q^T lambda = Q at rest),
    lambda.O.0 = 0; the output's unit is the row's, N."""
    text = """model hang
gravity (0, -9.81)
body bar { mass 2; inertia 0.1; point top (0, 0.5) }
joint O: revolute(ground.origin, bar.top)
initial bar.phi = 0
output Ly = lambda.O.1
output Lx = lambda.O.0
"""
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-3, t_end=0.1)
    assert np.allclose(sol.column("output.Ly"), -2 * 9.81, rtol=1e-12, atol=0)
    assert np.max(np.abs(sol.column("output.Lx"))) < 1e-10
    assert sol.column_units()["output.Ly"] == "N"


def test_a_beam_points_sensors():
    """The flexible slider crank (chord frame), fixed steps: rod.M.deflection
    equals the mid-span deflection column (from the chord, another formula);
    rod.A (a beam point) is where crank.A (a rigid body's point) is, to the
    constraints' tolerance; rod.B stays on the slider's line; rod.M.vx
    matches a central difference of rod.M.x (O(h^2)); the units are m, m/s,
    and an elastic coordinate's column is in m."""
    text = (MODELS / "flexible_slider_crank.mbd").read_text().replace(
        "simulate {", "output dm = rod.M.deflection\noutput ax = rod.A.x\noutput cx = crank.A.x\n"
        "output by = rod.B.y\noutput mx = rod.M.x\noutput mvx = rod.M.vx\n"
        "output v1 = rod.v1\nsimulate {")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-4, t_end=0.2)
    dm, mid = sol.column("output.dm"), sol.column("rod.deflection_mid")
    assert np.max(np.abs(mid)) > 1e-7
    assert np.max(np.abs(dm - mid)) < 1e-10 * np.max(np.abs(mid)) + 1e-15
    assert np.max(np.abs(sol.column("output.ax") - sol.column("output.cx"))) < 1e-9
    assert np.max(np.abs(sol.column("output.by"))) < 1e-9
    x, vx, t = sol.column("output.mx"), sol.column("output.mvx"), sol.t
    central = (x[2:] - x[:-2]) / (t[2:] - t[:-2])
    assert np.max(np.abs(central - vx[1:-1])) < 1e-3 * np.max(np.abs(vx))
    assert np.array_equal(sol.column("output.v1"), sol.column("rod.v1"))
    units = sol.column_units()
    assert units["output.dm"] == "m" and units["output.mvx"] == "m/s"
    assert units["rod.u1"] == "m" and units["rod.theta1_t"] == "rad/s"


@pytest.mark.parametrize("line,text", [
    ("output a = lambda.O.5", "'O' has multiplier rows 0 .. 1"),
    ("output a = lambda.Q.0", "a multiplier is lambda.<joint or driver>.<row>"),
    ("output a = stop.gap", "'stop' has gaps lower, upper: name one"),
    ("output a = stop.upper.bogus",
     "a gap's fields are gap, gap_rate, normal, friction, power, energy"),
    ("output a = stop.middle.gap", "'stop' has no gap 'middle'"),
])
def test_sensor_references_that_do_not_exist(line, text):
    source = f"""model x
body b {{ mass 1; inertia 1; point P (1, 0) }}
joint O: revolute(ground.origin, b.P)
force stop: limit(O, lower = -1, upper = 1, k = 1e5, restitution = 0.5)
{line}
"""
    with pytest.raises(MbdModelError) as exc:
        mbdsl.load_text(source)
    assert text in " ".join(d.message for d in exc.value.diagnostics)


def test_a_spring_dampers_sensors():
    """The slider crank's spring (ground.origin to rod.B, k = 100, c = 5, free
    length 0): its length and rate from rod.B's position and velocity
    (the rod's frame: B at (0.3, 0)), tension k l + c dl/dt, energy k l^2 /
    2 (also energy.potential less the bodies' gravity), power c (dl/dt)^2;
    to 1e-12 relative."""
    text = (MODELS / "slider_crank.mbd").read_text().replace(
        "simulate {", "output l = spring.length\noutput ld = spring.rate\n"
        "output f = spring.tension\noutput e = spring.energy\noutput p = spring.power\n"
        "output bx = rod.B.x\noutput by = rod.B.y\noutput bvx = rod.B.vx\n"
        "output bvy = rod.B.vy\nsimulate {")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-3, t_end=0.5)
    c = {k: sol.column(f"output.{k}") for k in ("l", "ld", "f", "e", "p", "bx", "by", "bvx",
                                                  "bvy")}
    length = np.hypot(c["bx"], c["by"])
    rate = (c["bx"] * c["bvx"] + c["by"] * c["bvy"]) / length
    assert np.max(np.abs(c["l"] - length)) < 1e-12 * np.max(length)
    assert np.max(np.abs(c["ld"] - rate)) < 1e-12 * np.max(np.abs(rate))
    assert np.max(np.abs(c["f"] - (100 * length + 5 * rate))) < 1e-10 * np.max(np.abs(c["f"]))
    assert np.max(np.abs(c["e"] - 50 * length ** 2)) < 1e-12 * np.max(c["e"])
    assert np.max(np.abs(c["p"] - 5 * rate ** 2)) < 1e-12 * np.max(c["p"])
    gravity = 9.81 * (3 * sol.column("crank.y") + 0.9 * sol.column("rod.y"))
    assert np.max(np.abs(c["e"] - (sol.column("energy.potential") - gravity))) < 1e-12 * 30
    units = sol.column_units()
    assert (units["output.f"], units["output.e"], units["output.p"]) == ("N", "J", "W")


def test_a_rotational_springs_sensors_and_a_contacts_energy():
    """The stiff double pendulum's elbow (k = 1e7 N m/rad, started 1e-3 rad
    bent): elbow.angle = link2.phi - link1.phi, elbow.torque = k angle,
    elbow.energy = k angle^2 / 2; the bouncing ball's floor.energy = K
    delta^2.5 / 2.5 in contact."""
    text = (MODELS / "double_pendulum_stiff.mbd").read_text().replace(
        "simulate {", "output a = elbow.angle\noutput w = elbow.rate\noutput tq = elbow.torque\n"
        "output e = elbow.energy\nsimulate {")
    model = mbdsl.load_text(text, overrides={"elbow0": "1e-3"})
    sol = mbdsl.simulate(model, h=1e-4, t_end=0.01)
    angle = sol.column("link2.phi") - sol.column("link1.phi")
    rate = sol.column("link2.omega") - sol.column("link1.omega")
    assert np.max(np.abs(sol.column("output.a") - angle)) < 1e-15
    assert np.max(np.abs(sol.column("output.w") - rate)) < 1e-12 * np.max(np.abs(rate))
    assert np.max(np.abs(sol.column("output.tq") - 1e7 * angle)) < 1e-9 * 1e4
    assert np.max(np.abs(sol.column("output.e") - 5e6 * angle ** 2)) < 1e-12 * 5
    assert sol.column_units()["output.tq"] == "N*m"
    ball = mbdsl.load_text(BALL.format(friction="", y0=1, vx0=0).replace(
        "output F = floor.friction", "output E = floor.energy"))
    sol = mbdsl.simulate(ball, method="hht-i3", h=1e-3, t_end=0.6, rtol=1e-6, atol=1e-6)
    delta = np.clip(0.05 - sol.column("ball.y"), 0, None)
    energy = 1e7 * delta ** 2.5 / 2.5
    assert np.max(energy) > 1.0
    assert np.max(np.abs(sol.column("output.E") - energy)) < 1e-12 * np.max(energy)
