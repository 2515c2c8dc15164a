"""Particles: point masses with two coordinates (x, y) and no rotation.

Oracles: the exact large-amplitude period of a simple pendulum (complete
elliptic integral), the rod tension 3 m g at the bottom, the reduced
one-degree-of-freedom equation of a rod pendulum carrying a point mass at its
tip (integrated by scipy to 1e-12), the same double pendulum with the point
mass lumped into the first rod (the particle's columns sit between two
bodies'), and the language's errors.
"""

import math

import numpy as np
import pytest
import scipy.integrate
import scipy.special

import mbdsl
from mbdsl.errors import MbdModelError

from .test_mechanisms import _zero_crossings, check_rod_pendulum

PENDULUM = """model particle_pendulum   # a point mass held 1 m from a pivot by a massless rod
gravity (0, -9.81)
particle bob { mass 1; shape circle(cm, 0.05) }
joint rod: distance(ground.origin, bob.cm, length = 1)
initial bob.x = 1
initial bob.vy = 0
"""


def test_a_particle_on_a_rod_has_the_exact_large_amplitude_period():
    """Released horizontally: T = 4 sqrt(L/g) K(sin^2(45 deg)); the bob passes
    the bottom at T/4 and 3T/4. Two coordinates, no rotation column."""
    model = mbdsl.load_text(PENDULUM)
    assert model.n_coordinates == 2 and model.dof == 1
    sol = check_rod_pendulum(model)      # period 1e-6, both engines, tension, length
    assert sol.system.layout.coordinates == ["bob.x", "bob.y"]
    assert "bob.phi" not in sol.columns and "bob.omega" not in sol.columns
    assert np.all(sol.column("reaction.rod.torque") == 0.0)     # a particle takes no couple


@pytest.mark.parametrize("method", list(mbdsl.METHODS))
def test_every_method_swings_a_particle(method):
    model = mbdsl.load_text(PENDULUM)
    exact = 4.0 * math.sqrt(1.0 / 9.81) * scipy.special.ellipk(0.5)
    sol = mbdsl.simulate(model, method=method, h=1e-3, t_end=0.8 * exact)
    assert sol.status == "completed"
    t1, t2 = _zero_crossings(sol.t, sol.column("bob.x"))[:2]
    assert abs(2 * (t2 - t1) - exact) < (1e-2 if method == "newmark" else 1e-3) * exact


TIP_MASS = """model rod_with_tip_mass
parameter M = 2
parameter L = 0.8
parameter m = 0.5
gravity (0, -9.81)
body rod { mass M; inertia M*L^2/12; point O (-L/2, 0); point T (L/2, 0) }
particle tip { mass m }
joint O: revolute(ground.origin, rod.O)
joint T: revolute(rod.T, tip.cm)
initial rod.phi = 0
"""


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_a_tip_mass_matches_the_reduced_equation(engine):
    """I_O theta'' = -(M L/2 + m L) g cos(theta), I_O = M L^2/3 + m L^2 (the
    particle adds mass but no inertia of its own), solved by scipy."""
    M, L, m, g = 2.0, 0.8, 0.5, 9.81
    I_O = M * L ** 2 / 3 + m * L ** 2
    rhs = lambda t, y: [y[1], -(M * L / 2 + m * L) * g * math.cos(y[0]) / I_O]  # noqa: E731
    T = 1.0
    ode = scipy.integrate.solve_ivp(rhs, (0, T), [0.0, 0.0], rtol=1e-12, atol=1e-12,
                                    dense_output=True)
    sol = mbdsl.simulate(mbdsl.load_text(TIP_MASS), method="hht-i3", h=1e-4, t_end=T,
                         engine=engine)
    assert sol.engine == engine
    assert sol.system.layout.coordinates == ["rod.x", "rod.y", "rod.phi", "tip.x", "tip.y"]
    theta = ode.sol(sol.t)[0]
    assert np.max(np.abs(sol.column("rod.phi") - theta)) < 1e-6
    # the particle rides on the rod's tip
    np.testing.assert_allclose(sol.column("tip.x"), L * np.cos(theta), atol=1e-6)
    np.testing.assert_allclose(sol.column("tip.y"), L * np.sin(theta), atol=1e-6)
    # the pin's force on the particle (the joint's second body) is m (a + g):
    # at the start (at rest) the tip falls at a = L theta''(0) = -12.6 m/s^2,
    # faster than g, so the rod pulls it down
    a0 = rhs(0, [0.0, 0.0])[1] * L
    assert a0 < -9.81
    assert sol.column("reaction.T.fy")[0] == pytest.approx(m * (9.81 + a0), rel=1e-6)
    assert sol.column("reaction.T.fx")[0] == pytest.approx(0.0, abs=1e-9)


DOUBLE = """model double_with_elbow_mass
gravity (0, -9.81)
body upper { mass 1; inertia 0.04; point O (-0.3, 0); point E (0.3, 0) }
{elbow}
body lower { mass 0.7; inertia 0.02; point E (-0.25, 0); point T (0.25, 0) }
joint O: revolute(ground.origin, upper.O)
{joints}
force s: spring_damper(ground.origin, lower.T, k = 40, c = 0.3, length = 0.4)
initial upper.phi = -0.4
initial lower.phi = 0.6
initial upper.omega = 1.5
"""


def test_a_particle_between_two_bodies_equals_the_lumped_mass():
    """A point mass of 0.4 kg pinned between the upper and lower arm (its two
    columns sit between the arms') moves them as the same mass lumped into the
    upper arm's tip does (mass 1.4 kg, centre 0.3 * 0.4/1.4 further out,
    inertia 0.04 + parallel axes)."""
    with_particle = DOUBLE.replace("{elbow}", "particle p { mass 0.4 }").replace(
        "{joints}", "joint E1: revolute(upper.E, p.cm)\njoint E2: revolute(p.cm, lower.E)")
    d = 0.3 * 0.4 / 1.4                       # lumped centre of mass, from the old one
    inertia = 0.04 + 1.0 * d ** 2 + 0.4 * (0.3 - d) ** 2
    lumped = DOUBLE.replace(
        "body upper { mass 1; inertia 0.04; point O (-0.3, 0); point E (0.3, 0) }",
        f"body upper {{ mass 1.4; inertia {inertia!r}; point O ({-0.3 - d!r}, 0); "
        f"point E ({0.3 - d!r}, 0) }}").replace("{elbow}", "").replace(
        "{joints}", "joint E: revolute(upper.E, lower.E)")
    a = mbdsl.simulate(mbdsl.load_text(with_particle), method="hht-si2", h=1e-4, t_end=1.0)
    b = mbdsl.simulate(mbdsl.load_text(lumped), method="hht-si2", h=1e-4, t_end=1.0)
    assert a.system.layout.coordinates[3:5] == ["p.x", "p.y"]
    for name in ("upper.phi", "lower.phi", "lower.x", "upper.omega"):
        assert np.max(np.abs(a.column(name) - b.column(name))) < 2e-6, name
    assert np.ptp(a.column("lower.phi")) > 0.5
    # the particle stays on the elbow
    ex = a.column("upper.x") + 0.3 * np.cos(a.column("upper.phi"))
    assert np.max(np.abs(a.column("p.x") - ex)) < 1e-9


def test_particles_in_outputs_animation_and_written_back(tmp_path):
    from mbdsl.dsl.unparse import spec_text
    text = PENDULUM + "output height = bob.cm.y\noutput speed = bob.vx\n"
    src = spec_text(mbdsl.parse_text(text))
    assert "particle bob { mass 1; shape circle(cm, 0.05) }" in src
    model = mbdsl.load_text(src)
    assert model.bodies[0].particle and model.bodies[0].inertia == 0.0
    sol = mbdsl.simulate(model, h=1e-3, t_end=0.2)
    np.testing.assert_array_equal(sol.column("output.height"), sol.column("bob.y"))
    np.testing.assert_array_equal(sol.column("output.speed"), sol.column("bob.vx"))
    assert sol.column_units()["bob.vx"] == "m/s"
    res = mbdsl.animate(sol, tmp_path / "p.gif", fps=10)
    assert (tmp_path / "p.gif").stat().st_size > 0 and res.frames >= 2


BASE = ("model m\nparticle p { mass 1 }\nbody b { mass 1; inertia 0.1; point A (0.2, 0) }\n"
        "joint O: revolute(ground.origin, b.cm)\njoint P: revolute(b.A, p.cm)\n")


@pytest.mark.parametrize("line, code, message", [
    ("particle q { mass 1; inertia 0.1 }", "E304", "particle 'q': unknown property 'inertia'"),
    ("particle q { mass 1; point A (0.1, 0) }", "E304", "a particle has one point, 'cm'"),
    ("particle q { }", "E302", "particle 'q' has no mass"),
    ("particle q { mass 0 }", "E303", "the mass of particle 'q' must be positive"),
    ("initial p.phi = 1", "E502", "particle 'p' does not turn"),
    ("initial p.omega = 1", "E502", "particle 'p' does not turn"),
    ("force t: torque(p, 1)", "E305", "a torque turns a body, and particle 'p' does not turn"),
    ("joint F: fixed(p.cm, ground.origin)", "E305", "locks a relative angle"),
    ("force r: rotational_spring_damper(P, k = 1)", "E305", "particle 'p' does not turn"),
    ("force r: joint_torque(P, 1)", "E305", "particle 'p' does not turn"),
    ("force r: friction(P, mu = 0.1, radius = 0.01)", "E305", "particle 'p' does not turn"),
    ("driver d: p.phi = t", "E305", "a driven angle needs a body that turns"),
    ("driver d: P.angle = t", "E305", "a joint angle is a relative rotation"),
    ("force t: torque(b, p.omega)", "E304", "particle 'p' does not turn"),
    ("force t: torque(b, P.rate)", "E304", "the joint holds particle 'p'"),
    ("output w = p.omega", "E304", "a body's fields are x, y, vx, vy, ax, ay"),
    ("output w = P.angle", "E304", "the joint holds a particle"),
    ("joint L: point_on_line(ground.origin, p.cm, direction = (1, 0))", "E305",
     "holds its line in the second body's frame"),
])
def test_what_needs_a_rotation_is_refused_on_a_particle(line, code, message):
    with pytest.raises(MbdModelError) as info:
        mbdsl.load_text(BASE + line + "\n", file="p.mbd")
    errors = [d for d in info.value.diagnostics if d.is_error]
    assert [d.code for d in errors] == [code], [d.message for d in errors]
    assert message in errors[0].message
    assert errors[0].span is not None and errors[0].span.line >= 2


def test_a_particle_on_a_line_slides():
    """point_on_line with the particle as the point: a bead on a horizontal
    wire pulled by a spring, x'' = -(k/m) x: x = cos(sqrt(k/m) t)."""
    text = ("model bead\nparticle p { mass 0.5 }\n"
            "joint wire: point_on_line(p.cm, ground.origin, direction = (1, 0))\n"
            "force s: spring_damper(ground.origin, p.cm, k = 8, length = 0)\n"
            "initial p.x = 1\ninitial p.vx = 0\n")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-4, t_end=1.0)
    np.testing.assert_allclose(sol.column("p.x"), np.cos(4.0 * sol.t), atol=2e-6)
    assert np.max(np.abs(sol.column("p.y"))) < 1e-12


def test_the_shipped_particle_pendulum_is_the_same_model_in_units():
    """tests/dsl/valid/particle_pendulum.mbd writes the pendulum above with
    units (1 m, 9.81 m/s^2, 1 kg, 0.1 ms): the same run to the last bit."""
    from pathlib import Path
    model = mbdsl.load(Path(__file__).parent / "valid" / "particle_pendulum.mbd")
    assert model.settings["h"] == 1e-4 and model.settings["t_end"] == 2.4
    a = mbdsl.simulate(model, t_end=0.05)
    b = mbdsl.simulate(mbdsl.load_text(PENDULUM), method="hht-i3", h=1e-4, t_end=0.05)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.column("output.height"), b.column("bob.y"))
