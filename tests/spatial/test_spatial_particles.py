"""Particles in spatial models (``particle NAME { mass m }`` in ``space 3d``:
``model.spatial.SpatialParticle``, three coordinates x, y, z).

Oracles, each independent of mbdsl's equations:
* the spherical pendulum in spherical coordinates (theta from the downward
  vertical, phi about it), Lagrange's equations integrated by DOP853;
* a particle sliding on an inclined frictionless plane: uniform acceleration
  g sin(alpha) down the slope, the plane's reaction m g cos(alpha);
* two particles on a spring in free space: the centre of mass moves
  uniformly, the stretch oscillates at sqrt(k / mu), mu = m1 m2 / (m1 + m2);
* a particle dropped on a floor: it closes at sqrt(2 (z0 - r) / g).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbdsl
from mbdsl.errors import MbdModelError

METHODS = ("newmark", "hht-i3", "hht-add", "hht-si2", "nstiff", "nstiff-si2", "genalpha",
           "genalpha-si2")


def start(name, x, v, guess=()):
    """The ``initial`` lines of a particle's position x (3,) [m] and velocity
    v (3,) [m/s]; the fields named in ``guess`` (``"z"``, ``"vz"``) as
    ``guess`` lines, for the assembly to solve from its joints."""
    lines = []
    for fields, values in (("xyz", x), (("vx", "vy", "vz"), v)):
        for f, value in zip(fields, values):
            lines.append(f"{'guess' if f in guess else 'initial'} {name}.{f} = {value!r}")
    return "\n".join(lines) + "\n"

PENDULUM = """model spherical_pendulum
space 3d
gravity (0, 0, -9.81)
particle bob {{ mass 0.5; shape sphere(cm, 0.03) }}
joint rod: distance(ground.origin, bob.cm, length = 1)
""" + start("bob", (0.6, 0, -0.8), (0, 1.5, 0), guess=("z", "vz")) + """{extra}
"""


def spherical_pendulum(t, g=9.81, l=1.0, theta0=np.arcsin(0.6), dphi0=2.5):
    """World positions (N, 3) of the spherical pendulum from theta0 at rest in
    theta, turning at dphi0 about the vertical: theta'' = sin cos phi'^2 -
    g/l sin, phi'' = -2 theta' phi' cos / sin (Lagrange's equations)."""
    def rhs(_, y):
        th, ph, dth, dph = y
        s, c = np.sin(th), np.cos(th)
        return [dth, dph, s * c * dph ** 2 - g / l * s, -2.0 * dth * dph * c / s]
    sol = solve_ivp(rhs, (0.0, t[-1]), [theta0, 0.0, 0.0, dphi0], method="DOP853",
                    t_eval=t, rtol=1e-12, atol=1e-13)
    th, ph = sol.y[0], sol.y[1]
    return l * np.column_stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)])


@pytest.fixture(scope="module")
def pendulum():
    return mbdsl.load_text(PENDULUM.format(extra=""))


def test_a_particle_has_three_coordinates(pendulum):
    """n = 3, m = 1: no directors, no frame rows; DOF 2 by count; its columns
    are x, y, z and their rates, no orientation."""
    system = mbdsl.assemble(pendulum)
    assert (system.n, system.m) == (3, 1)
    assert pendulum.dof == 2
    sol = mbdsl.simulate(pendulum, h=1e-3, t_end=0.01)
    assert {"bob.x", "bob.vz", "bob.az"} <= set(sol.columns)
    assert not [c for c in sol.columns if c.startswith("bob.") and c.split(".")[1]
                in ("e0", "yaw", "wx", "A11")]


@pytest.mark.parametrize("method", METHODS)
def test_the_spherical_pendulum_against_lagranges_equations(pendulum, method):
    """2 s at h = 1e-3 and 5e-4: the bob within 1e-4 m of the DOP853 solution
    (NEWMARK, first order: 5e-2 m) and converging at the method's order; on
    its sphere to Newton's tolerance."""
    errors = []
    for h in (1e-3, 5e-4):
        sol = mbdsl.simulate(pendulum, method=method, h=h, t_end=2.0)
        t = sol.column("t")
        p = np.column_stack([sol.column(f"bob.{c}") for c in "xyz"])
        errors.append(np.max(np.abs(p - spherical_pendulum(t))))
        assert np.max(np.abs(np.linalg.norm(p, axis=1) - 1.0)) < 1e-9
    order = np.log2(errors[0] / errors[1])
    if method == "newmark":
        assert errors[1] < 5e-2 and abs(order - 1.0) < 0.2, (errors, order)
    else:
        assert errors[1] < 1e-4 and abs(order - 2.0) < 0.2, (errors, order)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_both_engines_and_the_rods_tension(pendulum, engine):
    """Both engines agree with the oracle; the rod's reaction on the bob is
    along the rod and, with the energy, gives the centripetal balance
    T = m (v^2 / l + g cos theta) (its tension, the multiplier's force)."""
    sol = mbdsl.simulate(pendulum, method="hht-si2", h=1e-3, t_end=0.5, engine=engine)
    t = sol.column("t")
    p = np.column_stack([sol.column(f"bob.{c}") for c in "xyz"])
    assert np.max(np.abs(p - spherical_pendulum(t))) < 1e-5
    v2 = sum(sol.column(f"bob.v{c}") ** 2 for c in "xyz")
    tension = 0.5 * (v2 / 1.0 + 9.81 * (-p[:, 2]))
    F = np.column_stack([sol.column(f"reaction.rod.f{c}") for c in "xyz"])
    assert np.max(np.abs(F + tension[:, None] * p)) < 1e-4 * np.max(tension)
    assert np.max(np.abs(np.column_stack([sol.column(f"reaction.rod.t{c}") for c in "xyz"]))) \
        < 1e-12


def test_a_particle_on_an_inclined_plane():
    """point_on_plane holds a particle on a frictionless slope of 30 deg: it
    slides down at g sin(alpha), the reaction is m g cos(alpha) along the
    normal, and its sideways velocity is kept."""
    a = np.radians(30.0)
    n = (-float(np.sin(a)), 0.0, float(np.cos(a)))
    text = f"""model incline
space 3d
gravity (0, 0, -9.81)
ground {{ axis n ({n[0]!r}, 0, {n[2]!r}) }}
particle p {{ mass 2 }}
joint J: point_on_plane(p.cm, ground.origin, ground.n)
""" + start("p", (0, 0, 0), (0, 0.3, 0), guess=("z", "vz"))
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-i3", h=1e-3, t_end=1.0)
    t = sol.column("t")
    down = np.array([-np.cos(a), 0.0, -np.sin(a)])       # down the slope
    s = 0.5 * 9.81 * np.sin(a) * t ** 2
    p = np.column_stack([sol.column(f"p.{c}") for c in "xyz"])
    expected = np.outer(s, down) + np.outer(0.3 * t, [0.0, 1.0, 0.0])
    assert np.max(np.abs(p - expected)) < 1e-9
    F = np.column_stack([sol.column(f"reaction.J.f{c}") for c in "xyz"])
    np.testing.assert_allclose(F[5:], np.tile(-2 * 9.81 * np.cos(a) * np.array(n), (len(t) - 5, 1)),
                               atol=1e-6)


def test_two_particles_on_a_spring():
    """Two particles (1 and 3 kg) on a spring-damper (k = 120 N/m, c = 0,
    free length 0.5 m) without gravity, stretched along x and thrown
    sideways: the centre of mass moves uniformly, and the energy is kept
    (hht-si2 at h = 1e-4: 1e-6 of it)."""
    text = """model dumbbell
space 3d
particle a { mass 1 }
particle b { mass 3 }
force s: spring_damper(a.cm, b.cm, k = 120, c = 0, length = 0.5)
""" + start("a", (0, 0, 0), (0, 0.9, 0.1)) + start("b", (0.7, 0, 0), (0.2, -0.1, 0))
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-si2", h=1e-4, t_end=1.0)
    t = sol.column("t")
    cm = (np.column_stack([sol.column(f"a.{c}") for c in "xyz"])
          + 3 * np.column_stack([sol.column(f"b.{c}") for c in "xyz"])) / 4
    v0 = (np.array([0.0, 0.9, 0.1]) + 3 * np.array([0.2, -0.1, 0.0])) / 4
    cm0 = np.array([3 * 0.7, 0.0, 0.0]) / 4
    assert np.max(np.abs(cm - (cm0 + np.outer(t, v0)))) < 1e-9
    e = sol.column("energy.total")
    assert np.ptp(e) < 1e-6 * e[0]
    length = np.linalg.norm(np.column_stack([sol.column(f"b.{c}") - sol.column(f"a.{c}")
                                             for c in "xyz"]), axis=1)
    assert np.ptp(length) > 0.05                     # the spring works


def test_a_particle_dropped_on_a_floor():
    """A particle of radius 0.1 m on a floor (contact, e = 0.8) dropped from
    1 m: it first closes at sqrt(2 (1 - 0.1) / g) and bounces back up; its
    sideways motion is kept."""
    text = """model drop
space 3d
gravity (0, 0, -9.81)
particle ball { mass 0.2 }
force floor: contact(ball.cm, radius = 0.1, plane = (ground.origin, (0, 0, 1)), k = 1e6,
                     exponent = 1.5, restitution = 0.8)
""" + start("ball", (0, 0, 1), (0.5, 0, 0))
    model = mbdsl.load_text(text)
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=0.8, rtol=1e-7, atol=1e-7)
    assert [e[2] for e in sol.events][:2] == ["closed", "opened"]
    assert sol.events[0][0] == pytest.approx(np.sqrt(2 * 0.9 / 9.81), abs=1e-6)
    assert sol.events[0][3] == pytest.approx(np.sqrt(2 * 9.81 * 0.9), rel=1e-5)
    t, after = sol.column("t"), sol.events[1][0]              # after it opens: e v up
    assert np.max(sol.column("ball.vz")[t > after]) > 0.75 * np.sqrt(2 * 9.81 * 0.9)
    np.testing.assert_allclose(sol.column("ball.vx"), 0.5, atol=1e-9)


def test_a_force_of_the_motion_and_an_output_line_on_a_particle():
    """Drag -c v on a particle thrown upward, no gravity: v = v0 exp(-c t / m);
    an output line reads its z."""
    text = """model drag
space 3d
particle p { mass 2 }
force drag: force(p.cm, (-0.5*p.vx, -0.5*p.vy, -0.5*p.vz))
output up = p.z
""" + start("p", (0, 0, 0), (1, 0, 3))
    sol = mbdsl.simulate(mbdsl.load_text(text), method="genalpha", h=1e-3, t_end=2.0)
    t = sol.column("t")
    np.testing.assert_allclose(sol.column("p.vz"), 3 * np.exp(-0.25 * t), atol=1e-6)
    np.testing.assert_allclose(sol.column("output.up"), 12 * (1 - np.exp(-0.25 * t)), atol=1e-6)


def test_a_particle_hangs_on_a_body():
    """A rod on a spherical joint at the ground with a particle 0.4 m from
    its tip (a distance joint: a spatial double pendulum with a point mass):
    1 s of hht-si2 at h = 1e-4 keeps the energy to 1e-5 of the largest
    kinetic energy and the joints to 1e-10."""
    text = """model rod_and_bob
space 3d
gravity (0, 0, -9.81)
body rod { mass 1; inertia (0.08, 0.08, 0.001); point top (0, 0, 0.5); point tip (0, 0, -0.5) }
particle bob { mass 0.3 }
joint O: spherical(ground.origin, rod.top)
joint T: distance(rod.tip, bob.cm, length = 0.4)
initial rod.orientation = zyx(0, 40 deg, 0)
initial rod.omega = (0, 0, 2)
""" + start("bob", (-0.55, 0, -0.7), (0, 0.5, 0), guess=("y", "z", "vx", "vz"))
    model = mbdsl.load_text(text)
    sol = mbdsl.simulate(model, method="hht-si2", h=1e-4, t_end=1.0)
    e, k = sol.column("energy.total"), sol.column("energy.kinetic")
    assert np.ptp(e) < 1e-5 * np.max(k)
    assert np.max(sol.column("constraint.position")) < 1e-10
    tip = np.column_stack([sol.column(f"bob.{c}") for c in "xyz"])
    assert np.ptp(tip[:, 2]) > 0.01


@pytest.mark.parametrize("text, code, line", [
    ("joint H: revolute(ground.origin, bob.cm, ground.z, bob.z)", "E305", 12),
    ("joint H: prismatic(bob.cm, ground.origin, ground.z)", "E305", 12),
    ("force m: torque(bob, (0, 0, 1))", "E305", 12),
    ("force f: force(bob.cm, (1, 0, 0), frame = body)", "E305", 12),
    ("initial bob.orientation = zyx(0, 0, 0)", "E502", 12),
    ("force f: force(bob.cm, (-bob.wx, 0, 0))", "E304", 12),
    ("output w = bob.wx", "E304", 12),
])
def test_what_a_particle_does_not_have_is_an_error_at_its_line(text, code, line):
    """A particle does not turn: its axes, a torque, a follower force, an
    orientation, an angular velocity are errors at the line."""
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(PENDULUM.format(extra=text))
    d = err.value.diagnostics[0]
    assert (d.code, d.span.line) == (code, line), (d.code, d.span.line, d.message)


def test_a_particle_has_no_inertia():
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(PENDULUM.format(extra="").replace(
            "particle bob { mass 0.5;", "particle bob { mass 0.5; inertia (1, 1, 1);"))
    assert err.value.diagnostics[0].code == "E304"


def test_the_3d_scene_draws_a_particle_at_its_position(pendulum):
    """The view's items of a particle (its sphere, its centre) sit at its x,
    y, z in every frame."""
    from mbdsl.graphics.scene3d import SpatialScene
    sol = mbdsl.simulate(pendulum, h=1e-3, t_end=0.3)
    scene = SpatialScene(pendulum)
    for row in (0, 150, 300):
        q = sol.q[row]
        for item, w in zip(scene.items, scene.coordinates(q)):
            if item.body == "bob" and item.kind == "cm":
                np.testing.assert_allclose(w[0], q[:3], atol=1e-14)
