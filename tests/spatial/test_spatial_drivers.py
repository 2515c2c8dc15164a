"""Drivers and rotational spring-dampers in spatial models
(``kernels.joints.spatial_angles``, the dot rows' drivers of
``kernels.joints.spatial``, ``kernels.loads.spatial_rotational``).

Oracles: a body turned about a fixed axis at a prescribed angle needs the
torque J_nn theta'' about that axis (J_nn = n . J n; the gyroscopic moment
has no component along n); a slider driven along a line needs m (s'' - g .
u); a body lifted at z'' = 1 needs m (1 + 9.81); the motion itself is
the drivers' functions (to Newton's tolerance); a torsional oscillator
J x'' + c x' + k x = 0 (closed form). Derivatives against finite
differences are in ``tests/assembly/test_derivatives.py``."""

from __future__ import annotations

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import MbdModelError
from mbdsl.model.spatial import axis_angle

from ..conftest import MODELS

DRIVERS = MODELS.parent / "tests" / "dsl" / "valid" / "spatial_drivers.mbd"
TILT = np.array([0.0, 0.6, 0.8])
SLOPE = np.array([1.0, 0.0, 0.2]) / np.linalg.norm([1.0, 0.0, 0.2])
G = np.array([0.0, 0.0, -9.81])


def _frames(sol, body):
    """The body's directors (N, 3, 3) (columns: its axes in world axes)."""
    names = [f"{body}.A{i}{j}" for j in (1, 2, 3) for i in (1, 2, 3)]
    return np.stack([sol.column(n) for n in names], axis=1).reshape(-1, 3, 3).transpose(0, 2, 1)


@pytest.fixture(scope="module", params=mbdsl.METHODS)
def driven(request):
    return request.param, mbdsl.simulate(mbdsl.load(DRIVERS), method=request.param, h=1e-3,
                                         t_end=1.0)


def test_the_driven_bodies_move_as_their_drivers_say(driven):
    """The rotor turns by f(t) - f(0) about the tilted axis, through a full
    turn (the row wraps); the slider sits at S + s(t) u; the lift is at z =
    t^2 / 2 and turns by +1.5 t about z (its joint's angle is the ground's
    turn relative to the lift, driven at -1.5 t)."""
    method, sol = driven
    t = sol.column("t")
    A, n = _frames(sol, "rotor"), TILT / np.linalg.norm(TILT)
    f = 2 * np.pi * t + 0.3 * np.sin(5 * t)
    for k in range(0, len(t), 50):
        np.testing.assert_allclose(A[k], axis_angle(n, f[k]) @ A[0], atol=1e-8)
    s = 0.1 * np.sin(3 * t)
    for c, name in enumerate("xyz"):
        np.testing.assert_allclose(sol.column(f"slider.{name}"),
                                   np.array([0.0, 3.0, 0.0])[c] + s * SLOPE[c], atol=1e-9)
    np.testing.assert_allclose(sol.column("lift.z"), t * t / 2, atol=1e-9)
    L = _frames(sol, "lift")
    for k in range(0, len(t), 50):
        np.testing.assert_allclose(L[k], axis_angle([0, 0, 1], 1.5 * t[k]) @ L[0], atol=1e-8)


def test_the_drivers_loads_are_what_the_motion_needs(driven):
    """driver.motor.torque = J_nn f'', driver.push.force = m (s'' - g . u),
    driver.up.force = m (1 + 9.81), driver.turn.torque = 0 (a steady turn
    about a principal axis): within 0.1 % of the largest value after 0.1 s
    (the index-3 methods' multipliers start with a transient; measured 1e-9
    to 4.4e-4), NEWMARK (first order) within 1 % (measured 6.3e-3)."""
    method, sol = driven
    t = sol.column("t")
    late = t > 0.1
    nb = np.ones(3) / np.sqrt(3.0)
    J = np.diag([0.02, 0.03, 0.04])
    torque = (nb @ J @ nb) * (-7.5 * np.sin(5 * t))
    force = 1.5 * (-0.9 * np.sin(3 * t) - G @ SLOPE)
    for column, want in (("driver.motor.torque", torque), ("driver.push.force", force),
                         ("driver.up.force", np.full_like(t, 0.5 * (1 + 9.81)))):
        got = sol.column(column)
        scale = np.max(np.abs(want))
        tol = 1e-2 if method == "newmark" else 1e-3
        assert np.max(np.abs(got[late] - want[late])) < tol * scale, (method, column)
    assert np.max(np.abs(sol.column("driver.turn.torque")[late])) < 1e-3


def test_the_energy_balance_holds_with_the_drivers_work(driven):
    """E(t) - E(0) = work in - dissipated: the drivers' power enters the
    work (the balance within 1e-4 of the work put in)."""
    method, sol = driven
    work = np.max(np.abs(sol.column("energy.work")))
    assert work > 1.0
    # NEWMARK's damping; NSTIFF-SI2's BDF1 first step (2e-4 J at step 1). Measured:
    # nstiff 5.8e-5, nstiff-si2 1.3e-4, hht-i3 2.2e-5
    tol = {"newmark": 5e-3, "nstiff-si2": 3e-4}.get(method, 1e-4)
    assert np.max(np.abs(sol.column("energy.balance"))) < tol * work


OSCILLATOR = """model torsion
space 3d
body disk {{ mass 1; inertia (0.2, 0.15, 0.15) }}
joint R: revolute(ground.origin, disk.cm, ground.x, disk.x)
force spring: rotational_spring_damper(R, k = 20, c = 0.3, angle = 0.2)
guess disk.orientation = zyx(0, 0, 0)
simulate {{ method {method}; h {h}; t_end 2 }}
"""


def _oscillator_error(method, h):
    sol = mbdsl.simulate(mbdsl.load_text(OSCILLATOR.format(method=method, h=h)))
    t = sol.column("t")
    theta = np.unwrap(np.arctan2(sol.column("disk.A32"), sol.column("disk.A22")))
    assert abs(theta[0]) < 1e-12 and sol.column("disk.wx")[0] == 0.0
    J, k, c, x0 = 0.2, 20.0, 0.3, -0.2
    wn = np.sqrt(k / J)
    zeta = c / (2 * np.sqrt(k * J))
    wd = wn * np.sqrt(1 - zeta**2)
    x = np.exp(-zeta * wn * t) * (x0 * np.cos(wd * t) + zeta * wn * x0 / wd * np.sin(wd * t))
    return np.max(np.abs(theta - (0.2 + x))), sol


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "genalpha"])
def test_a_torsional_oscillator_follows_its_closed_form(method):
    """A disk on a revolute about x, spring 20 N m/rad at rest angle 0.2
    rad, damper 0.3 N m s/rad, J = 0.2 kg m^2, released at rest at angle 0
    (the assembly keeps the guessed orientation, the least change): the
    angle follows the damped oscillation at order 2; the energy balance
    holds (the damper's dissipation counted)."""
    errors = []
    for h in (2e-3, 1e-3):
        err, sol = _oscillator_error(method, h)
        errors.append(err)
    assert errors[1] < 2e-3, errors
    assert abs(np.log2(errors[0] / errors[1]) - 2.0) < 0.25, errors
    E = sol.column("energy.total")
    assert E[0] == pytest.approx(0.5 * 20 * 0.2**2, rel=1e-9)
    assert sol.column("energy.dissipated")[-1] > 0.5 * E[0]
    assert np.max(np.abs(sol.column("energy.balance"))) < 1e-4 * E[0]


@pytest.mark.parametrize("line, code", [
    ("driver d: S.angle = t", "E201"),            # a prismatic joint has no angle
    ("driver d: R.distance = t", "E201"),         # a revolute has no distance
    ("driver d: slider.phi = t", "E201"),         # a spatial body: x, y or z
    ("force r: rotational_spring_damper(S, k = 1)", "E201"),
    ("driver d: R.angle = 2 m", "E307"),
])
def test_a_wrong_spatial_driver_is_an_error_at_its_line(line, code):
    text = DRIVERS.read_text().replace("simulate {", line + "\nsimulate {")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(text)
    lines = text.splitlines()
    at = next(i for i, s in enumerate(lines, 1) if s == line)
    found = [d for d in err.value.diagnostics if d.code == code]
    assert found and found[0].span.line == at, err.value


OUTPUTS = """
output theta   = R.angle
output theta_t = R.rate
output s       = S.distance
output s_t     = S.speed
output turn    = L.angle
output tip_z   = arm.T.z
output tip_vx  = arm.T.vx
output spin    = lift.wz
output load    = reaction.A.tz
"""


def test_output_lines_read_the_spatial_joints_points_and_bodies():
    """``output`` lines of a spatial model (hht-si2: velocities on their
    constraints): a revolute's angle is its driver's f(t) within half a turn
    and its rate f'(t); a prismatic's distance and speed are s(t), s'(t);
    the lift's joint angle is -1.5 t and its body-axis wz is +1.5 rad/s (the
    ground turns by -1.5 t relative to the lift); a point is r + A s; a
    reaction's couple is its column."""
    text = DRIVERS.read_text().replace("point O (-0.3, 0, 0) }",
                                       "point O (-0.3, 0, 0); point T (0.3, 0.1, -0.2) }")
    text = text.replace("simulate {", OUTPUTS + "simulate {")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-si2", h=1e-3, t_end=1.0)
    t = sol.column("t")
    f = 2 * np.pi * t + 0.3 * np.sin(5 * t)
    np.testing.assert_allclose(sol.column("output.theta"), np.angle(np.exp(1j * f)), atol=1e-9)
    np.testing.assert_allclose(sol.column("output.theta_t"), 2 * np.pi + 1.5 * np.cos(5 * t),
                               atol=1e-8)
    np.testing.assert_allclose(sol.column("output.s"), 0.1 * np.sin(3 * t), atol=1e-12)
    np.testing.assert_allclose(sol.column("output.s_t"), 0.3 * np.cos(3 * t), atol=1e-9)
    np.testing.assert_allclose(sol.column("output.turn"), np.angle(np.exp(-1.5j * t)), atol=1e-9)
    np.testing.assert_allclose(sol.column("output.spin"), 1.5, atol=1e-8)
    A = _frames(sol, "arm")
    s = np.array([0.3, 0.1, -0.2])
    np.testing.assert_allclose(sol.column("output.tip_z"),
                               sol.column("arm.z") + (A @ s)[:, 2], atol=1e-14)
    A_t = np.stack([sol.column(f"arm.A{i}{j}_t") for j in (1, 2, 3) for i in (1, 2, 3)],
                   axis=1).reshape(-1, 3, 3).transpose(0, 2, 1)
    np.testing.assert_allclose(sol.column("output.tip_vx"),
                               sol.column("arm.vx") + (A_t @ s)[:, 0], atol=1e-14)
    np.testing.assert_array_equal(sol.column("output.load"), sol.column("reaction.A.tz"))
    assert sol.column_units()["output.theta_t"] == "rad/s"
    assert sol.column_units()["output.tip_vx"] == "m/s"
    units = sol.column_units()
    assert (units["lambda.up.0"], units["lambda.push.0"], units["lambda.motor.0"]) == (
        "N", "N", "N*m")


@pytest.mark.parametrize("line", ["output w = R.distance", "output w = arm.O.w",
                                  "output w = reaction.R.torque"])
def test_a_wrong_spatial_output_is_an_error(line):
    text = DRIVERS.read_text().replace("simulate {", line + "\nsimulate {")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(text)
    assert err.value.diagnostics[0].code in ("E201", "E304"), err.value


def test_the_spring_dampers_sensors_in_a_spatial_model():
    """``spring.length|rate|tension|energy|power`` of a spatial spring-damper
    (TSDA) and ``angle|rate|torque|energy|power`` of a rotational one: the
    TSDA's energy is the potential energy less gravity's (m g z), its
    length |hook - top| from the body's columns, its rate dl/dt by central
    differences, its power's integral the energy dissipated; the RSDA's
    angle is its joint's, its torque k (theta - 0.2) + c theta' and its
    energy k (theta - 0.2)^2 / 2."""
    text = (MODELS / "spatial_spring_pendulum.mbd").read_text().replace(
        "simulate {", "output l = spring.length\noutput ld = spring.rate\n"
        "output T = spring.tension\noutput e = spring.energy\noutput p = spring.power\n"
        "simulate {")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-si2", h=1e-3, t_end=1.0)
    t = sol.column("t")
    gravity = 2 * 9.81 * sol.column("box.z")
    np.testing.assert_allclose(sol.column("output.e"), sol.column("energy.potential") - gravity,
                               atol=1e-9)
    top = np.column_stack([sol.column(f"box.{c}") for c in "xyz"]) + _frames(sol, "box") @ [
        0.02, 0.01, 0.1]
    l = np.linalg.norm(top - [0, 0, 1], axis=1)
    np.testing.assert_allclose(sol.column("output.l"), l, atol=1e-13)
    ld = sol.column("output.ld")
    np.testing.assert_allclose(ld[1:-1], (l[2:] - l[:-2]) / (t[2:] - t[:-2]),
                               atol=1e-3 * np.max(np.abs(ld)))   # O((omega h)^2)
    np.testing.assert_allclose(sol.column("output.T"), 400 * (l - 0.5) + 0.5 * ld, atol=1e-9)
    p = sol.column("output.p")
    dissipated = np.concatenate([[0.0], np.cumsum(0.5 * np.diff(t) * (p[1:] + p[:-1]))])
    np.testing.assert_allclose(dissipated, sol.column("energy.dissipated"), atol=1e-10)
    text = DRIVERS.read_text().replace(
        "simulate {", "output a = spring.angle\noutput ja = A.angle\noutput r = spring.rate\n"
        "output tq = spring.torque\noutput e = spring.energy\nsimulate {")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-si2", h=1e-3, t_end=1.0)
    a, r = sol.column("output.a"), sol.column("output.r")
    np.testing.assert_array_equal(a, sol.column("output.ja"))
    np.testing.assert_allclose(sol.column("output.tq"), 20 * (a - 0.2) + 0.3 * r, atol=1e-12)
    np.testing.assert_allclose(sol.column("output.e"), 10 * (a - 0.2) ** 2, atol=1e-12)
