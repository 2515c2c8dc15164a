"""Spatial forces and torques that read the motion (``force``, ``torque`` in a
``space 3d`` model whose components read bodies and points:
``model.spatial.SpatialStateLoad``, ``dsl.check.spatial_state``).

Oracles, each independent of mbdsl's equations:
* a body under gravity and linear drag -c v: the closed form of m v' = m g - c v;
* a body under a damping torque -c w: Euler's equations J w' = (J w) x w - c w,
  integrated by scipy's DOP853 at rtol 1e-12;
* a point pulled to a fixed point by the vector spring -k (p - p0): the same
  force as a spring-damper of zero free length (an independent element);
* a body hanging on such a spring at rest: z = z0 - m g / k.
(Q_q and Q_v against central differences: ``tests/assembly/test_derivatives.py``,
``tests/dsl/valid/spatial_state_loads.mbd``.)
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbdsl
from mbdsl.errors import MbdModelError

METHODS = ("newmark", "hht-i3", "hht-add", "hht-si2", "nstiff", "nstiff-si2", "genalpha",
           "genalpha-si2")

BODY = """model state_loads3d
space 3d
{gravity}
ground {{ point F (0.2, -0.1, 1.0) }}
body b {{ mass 2; inertia ({J}); point P (0.3, -0.1, 0.2) }}
{loads}
initial b.orientation = zyx(0.3, -0.2, 0.5)
initial b.omega_body = ({w})
initial b.x = 0; initial b.y = 0; initial b.z = 0
initial b.vx = {v0}; initial b.vy = -0.5; initial b.vz = 3
"""


def _model(loads, J="0.1, 0.2, 0.25", w="0, 0, 0", gravity="gravity (0, 0, -9.81)", v0=1):
    return mbdsl.load_text(BODY.format(loads=loads, J=J, w=w, gravity=gravity, v0=v0))


def _drag_exact(t, v0, m, c, g):
    """Position and velocity (N, 3) of m x'' = m g - c x' from x = 0, x' = v0."""
    tau, vinf = m / c, m * np.asarray(g) / c
    e = np.exp(-np.asarray(t)[:, None] / tau)
    v = vinf + (np.asarray(v0) - vinf) * e
    x = vinf * np.asarray(t)[:, None] + (np.asarray(v0) - vinf) * tau * (1 - e)
    return x, v


@pytest.mark.parametrize("method", METHODS)
def test_linear_drag_against_the_closed_form(method):
    """A body thrown under gravity with drag -c v (c = 0.5 N s/m) on its
    centre of mass, 2 s at h = 1e-3: its path within 2e-6 m of the closed
    form (NEWMARK, first order: 2e-3 m; the BDF2 methods 1e-5: NSTIFF-SI2's
    BDF1 first step leaves h^2 |g| / 2 = 5e-6 m, NSTIFF measured 4.2e-6 m,
    HHT-I3 3.4e-7 m), and the work the drag takes equals the
    mechanical energy lost (the energy balance holds: the drag's power is
    counted)."""
    model = _model("force drag: force(b.cm, (-0.5*b.vx, -0.5*b.vy, -0.5*b.vz))")
    sol = mbdsl.simulate(model, method=method, h=1e-3, t_end=2.0)
    t = sol.column("t")
    x, v = _drag_exact(t, (1.0, -0.5, 3.0), 2.0, 0.5, (0.0, 0.0, -9.81))
    got = np.column_stack([sol.column(f"b.{c}") for c in "xyz"])
    tol = {"newmark": 2e-3, "nstiff": 1e-5, "nstiff-si2": 1e-5}.get(method, 2e-6)
    assert np.max(np.abs(got - x)) < tol
    assert np.max(np.abs(sol.column("b.vz") - v[:, 2])) < 50 * tol
    total = sol.column("energy.kinetic") + sol.column("energy.potential")
    lost = total[-1] - total[0]
    assert lost < -1.0
    assert sol.column("energy.work")[-1] == pytest.approx(lost, rel=1e-3 if method == "newmark"
                                                          else 1e-5)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_both_engines_give_the_same_motion(engine):
    """The compiled and numpy engines agree with the closed form alike."""
    model = _model("force drag: force(b.cm, (-0.5*b.vx, -0.5*b.vy, -0.5*b.vz))")
    sol = mbdsl.simulate(model, method="hht-si2", h=2e-3, t_end=0.5, engine=engine)
    x, _ = _drag_exact(sol.column("t"), (1.0, -0.5, 3.0), 2.0, 0.5, (0.0, 0.0, -9.81))
    got = np.column_stack([sol.column(f"b.{c}") for c in "xyz"])
    assert np.max(np.abs(got - x)) < 2e-6


def _euler_damped(J, w0, c, t):
    """Body-axis angular velocity (N, 3) of J w' = (J w) x w - c w."""
    J = np.asarray(J)
    sol = solve_ivp(lambda _, w: (np.cross(J * w, w) - c * w) / J, (0, t[-1]), w0,
                    method="DOP853", t_eval=t, rtol=1e-12, atol=1e-14)
    return sol.y.T


@pytest.mark.parametrize("method", ["hht-i3", "nstiff-si2", "genalpha"])
@pytest.mark.parametrize("frame", ["body", "world"])
def test_a_damping_torque_against_eulers_equations(method, frame):
    """A tumbling body (J = 0.1, 0.2, 0.25 kg m^2) under the damping torque
    -c w (c = 0.05 N m s): in body axes it reads wx, wy, wz; in world axes
    the same torque reads the directors too, -c A w'. Its body-axis angular
    velocity converges to Euler's equations at order 2; the kinetic energy
    it takes equals the work of the torque."""
    w0, c = np.array([0.4, 3.0, 0.8]), 0.05
    if frame == "body":
        load = "force d: torque(b, (-0.05*b.wx, -0.05*b.wy, -0.05*b.wz), frame = body)"
    else:
        comps = [" + ".join(f"b.A{i}{k}*b.w{'xyz'[k - 1]}" for k in (1, 2, 3)) for i in (1, 2, 3)]
        load = "force d: torque(b, ({}))".format(", ".join(f"-0.05*({e})" for e in comps))
    model = _model(load, w="0.4, 3, 0.8", gravity="")
    errors = []
    for h in (4e-3, 2e-3):
        sol = mbdsl.simulate(model, method=method, h=h, t_end=3.0)
        t = sol.column("t")
        w = np.column_stack([sol.column(f"b.w{a}") for a in "xyz"])
        late = t >= 0.5                        # NSTIFF's first step: O(h) in the velocity
        errors.append(np.max(np.abs(w - _euler_damped((0.1, 0.2, 0.25), w0, c, t))[late]))
        gained = sol.column("energy.kinetic")[-1] - sol.column("energy.kinetic")[0]
        assert gained < -0.05
        # the work's quadrature against the method's own kinetic energy: O(h^2)
        # (NSTIFF's first step O(h), 1.1e-4 at h = 4e-3)
        assert sol.column("energy.work")[-1] == pytest.approx(
            gained, rel=5e-4 if method == "nstiff-si2" else 1e-4)
    assert errors[1] < 1e-4
    assert abs(np.log2(errors[0] / errors[1]) - 2.0) < 0.2, errors


@pytest.mark.parametrize("method", ["hht-si2", "nstiff"])
def test_a_spring_reading_a_point_equals_a_spring_damper(method):
    """The vector spring -k (b.P - F) (k = 50 N/m) written as a force that
    reads the point b.P moves the body as a spring-damper of zero free length
    between the same points (c = 0: the same force, F = -k d): both runs agree
    to the Newton tolerance's level."""
    vector = ("force s: force(b.P, (-50*(b.P.x - 0.2), -50*(b.P.y + 0.1), "
              "-50*(b.P.z - 1)))")
    spring = "force s: spring_damper(b.P, ground.F, k = 50, c = 0, length = 0)"
    runs = [mbdsl.simulate(_model(load, w="1, -2, 0.5"), method=method, h=1e-3, t_end=1.5)
            for load in (vector, spring)]
    for col in ("b.x", "b.y", "b.z", "b.A12", "b.A31", "b.wz"):
        assert np.max(np.abs(runs[0].column(col) - runs[1].column(col))) < 1e-7, col
    assert np.ptp(runs[0].column("b.wz")) > 0.5          # the spring turns the body


def test_initial_static_with_a_spring_reading_the_motion():
    """A body hung on the vertical spring -k (z - 1) at its centre of mass
    (k = 100 N/m), turning held by its orientation line: at rest at z = 1 -
    m g / k."""
    text = BODY.format(loads="force s: force(b.cm, (-100*b.x, -100*b.y, -100*(b.z - 1)))",
                       J="0.1, 0.2, 0.25", w="0, 0, 0", gravity="gravity (0, 0, -9.81)", v0=0)
    text = text.replace("initial b.x = 0; initial b.y = 0; initial b.z = 0\n", "")
    text = text.replace("initial b.vx = 0; initial b.vy = -0.5; initial b.vz = 3\n",
                        "initial static\n")
    sol = mbdsl.simulate(mbdsl.load_text(text), h=1e-3, t_end=0.01)
    assert sol.column("b.z")[0] == pytest.approx(1 - 2 * 9.81 / 100, abs=1e-10)
    assert abs(sol.column("b.x")[0]) < 1e-12
    assert np.max(np.abs(sol.column("b.vz"))) < 1e-9


@pytest.mark.parametrize("line, code", [
    ("force m: torque(b, (b.yaw, 0, 0))", "E304"),
    ("force m: torque(b, (c.wx, 0, 0))", "E201"),
    ("force f: force(b.P, (b.Z.vx, 0, 0))", "E201"),
    ("force f: force(b.P, (b.P.omega, 0, 0))", "E304"),
    ("force f: force(b.P, (-b.vx, 0, 0))\njoint J: spherical(ground.F, b.P)\n"
     "force m: torque(b, (J.angle, 0, 0))", "E304"),
])
def test_a_wrong_read_is_an_error_at_its_line(line, code):
    """An unknown field, body or point, or the angle of a joint that has
    none (a spherical), is reported at the load's line."""
    with pytest.raises(MbdModelError) as err:
        _model(line)
    d = err.value.diagnostics[0]
    assert d.code == code, (d.code, d.message)
    assert d.span.line == 6 + line.count("\n"), d.span


ROTOR = """model rotor_pd
space 3d
ground {{ axis tilt (0, 0.6, 0.8) }}
body rotor {{ mass 2; inertia (0.02, 0.03, 0.04) }}
joint R: revolute(ground.origin, rotor.cm, ground.tilt, rotor.z)
{load}
output angle = R.angle
"""


def _damped(t, x0, xref, k, c, m):
    """x(t) of m x'' = -k (x - xref) - c x' from x0 at rest (underdamped)."""
    wn, zeta = np.sqrt(k / m), c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - zeta ** 2)
    return xref + (x0 - xref) * np.exp(-zeta * wn * t) * (
        np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "nstiff-si2", "genalpha"])
def test_a_joint_torque_reading_the_joints_angle_and_rate(method):
    """A rotor about a tilted axis under joint_torque(R, -k (R.angle - 0.5)
    - c R.rate) (k = 8 N m/rad, c = 0.1 N m s/rad; J = 0.04 kg m^2 about its
    axis): the damped oscillation's closed form within 1e-4 rad at h = 1e-3
    (nstiff-si2: 1e-3), the same motion as a rotational spring-damper with
    the same k, c and angle (an independent element) to 1e-7 rad, and the work
    it does equals the kinetic energy gained."""
    pd = mbdsl.load_text(ROTOR.format(
        load="force pd: joint_torque(R, -8*(R.angle - 0.5) - 0.1*R.rate)"))
    rsda = mbdsl.load_text(ROTOR.format(
        load="force pd: rotational_spring_damper(R, k = 8, c = 0.1, angle = 0.5)"))
    sol = mbdsl.simulate(pd, method=method, h=1e-3, t_end=2.0)
    ref = mbdsl.simulate(rsda, method=method, h=1e-3, t_end=2.0)
    t, theta = sol.column("t"), sol.column("output.angle")
    exact = _damped(t, theta[0], 0.5, 8.0, 0.1, 0.04)
    assert np.max(np.abs(theta - exact)) < (1e-3 if method == "nstiff-si2" else 1e-4)
    assert np.max(np.abs(theta - ref.column("output.angle"))) < 1e-7
    kinetic = sol.column("energy.kinetic")
    assert np.max(kinetic) > 0.5                     # 1/2 k (0.5 - theta0)^2 at the first pass
    work = sol.column("energy.work")
    tol = 3e-4 if method == "nstiff-si2" else 1e-4     # NSTIFF-SI2's BDF1 first step: O(h)
    assert np.max(np.abs(work - (kinetic - kinetic[0]))) < tol * np.max(kinetic)


def test_a_joint_force_reading_the_joints_distance_and_speed():
    """A slider on a prismatic joint along a slope under gravity, pushed by
    joint_force(S, -k S.distance - c S.speed) (k = 50 N/m, c = 1 N s/m, m =
    1.5 kg): s oscillates about m g . u / k as the closed form says, within
    1e-5 m at h = 1e-3 (hht-si2)."""
    text = """model slide_pd
space 3d
gravity (0, 0, -9.81)
ground { axis slope (1, 0, 0.2); point S (0, 3, 0) }
body slider { mass 1.5; inertia (0.01, 0.01, 0.01) }
joint S: prismatic(slider.cm, ground.S, ground.slope)
force push: joint_force(S, -50*S.distance - S.speed)
output s = S.distance
initial slider.x = 0.3
"""
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-si2", h=1e-3, t_end=2.0)
    t, s = sol.column("t"), sol.column("output.s")
    u = np.array([1.0, 0.0, 0.2]) / np.linalg.norm([1.0, 0.0, 0.2])
    s_eq = 1.5 * (-9.81 * u[2]) / 50
    assert s[0] == pytest.approx(0.3 / u[0], abs=1e-12)        # x = 0.3 on the line
    assert np.max(np.abs(s - _damped(t, s[0], s_eq, 50.0, 1.0, 1.5))) < 1e-5


@pytest.mark.parametrize("line, code", [
    ("force m: joint_torque(R, 1)\njoint B: spherical(ground.origin, rotor.cm)", "E305"),
    ("force m: joint_force(R, 1)", "E305"),
    ("force m: torque(rotor, (R.distance, 0, 0))", "E304"),
])
def test_a_wrong_joint_load_is_an_error_at_its_line(line, code):
    """A joint torque in a joint without an angle, a joint force in one
    without a line, a distance of a revolute: errors at the load's line."""
    text = ROTOR.format(load=line)
    if "joint B" in line:
        text = text.replace("joint_torque(R, 1)", "joint_torque(B, 1)")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(text)
    d = err.value.diagnostics[0]
    assert (d.code, d.span.line) == (code, 6), (d.code, d.span.line, d.message)


def _arm_pitch_at_rest(kp=200.0, setpoint=-0.3):
    """The arm's pitch at rest in models/spatial_arm.mbd: the servo's torque
    kp (set - theta) against gravity's (m_arm 0.3 + m_payload 0.6) g cos(theta)
    about the pitch axis (a positive pitch lowers the tip)."""
    from scipy.optimize import brentq
    moment = (2.0 * 0.3 + 1.0 * 0.6) * 9.81
    return brentq(lambda th: kp * (setpoint - th) + moment * np.cos(th), -1.5, 1.5)


def test_the_servoed_arm_comes_to_rest_where_its_torques_balance():
    """models/spatial_arm.mbd (PD joint torques on a yaw and a pitch joint, a
    particle payload): after 6 s the yaw stands at its set point 0.8 rad and
    the pitch where the servo balances gravity (brentq on the two torques),
    both within 1e-5 rad; ``initial static`` finds the same pitch at once
    (1e-10 rad)."""
    from tests.conftest import MODELS
    text = (MODELS / "spatial_arm.mbd").read_text()
    pitch = _arm_pitch_at_rest()
    assert pitch == pytest.approx(-0.243, abs=2e-3)
    sol = mbdsl.simulate(mbdsl.load_text(text.replace(
        "output tip_height = payload.z", "output tip_height = payload.z\n"
        "output pitch_angle = pitch.angle\noutput yaw_angle = yaw.angle")),
        method="hht-si2", h=2e-3, t_end=6.0)
    assert sol.column("output.yaw_angle")[-1] == pytest.approx(0.8, abs=1e-5)
    assert sol.column("output.pitch_angle")[-1] == pytest.approx(pitch, abs=1e-5)
    assert sol.column("output.tip_height")[-1] == pytest.approx(
        0.6 - 0.6 * np.sin(pitch), abs=1e-5)
    rest = mbdsl.simulate(mbdsl.load_text(text.replace(
        "output tip_height = payload.z", "output pitch_angle = pitch.angle\ninitial static")),
        method="hht-si2", h=2e-3, t_end=0.01)
    assert rest.column("output.pitch_angle")[0] == pytest.approx(pitch, abs=1e-10)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_a_servo_under_error_controlled_steps(engine):
    """The PD rotor of ``test_a_joint_torque_reading_the_joints_angle_and_rate``
    with error-controlled steps (rtol = atol = 1e-7, hht-i3), on both
    engines: the closed form within 1e-5 rad at every output row; on the
    compiled engine over 2 s, the steps of the settled end longer than those
    of the fast start (the numpy engine runs the first 0.3 s: its time)."""
    pd = mbdsl.load_text(ROTOR.format(
        load="force pd: joint_torque(R, -8*(R.angle - 0.5) - 0.1*R.rate)"))
    t_end = 2.0 if engine == "compiled" else 0.3
    sol = mbdsl.simulate(pd, method="hht-i3", h=1e-3, t_end=t_end, rtol=1e-7, atol=1e-7,
                         engine=engine)
    t, theta = sol.column("t"), sol.column("output.angle")
    assert np.max(np.abs(theta - _damped(t, theta[0], 0.5, 8.0, 0.1, 0.04))) < 1e-5
    if engine == "compiled":
        h = sol.column("step.h")
        assert np.median(h[t > 1.5]) > 1.5 * np.median(h[(t > 0.05) & (t < 0.5)])


def test_the_arm_through_the_command_line(tmp_path):
    """``mbdsl simulate models/spatial_arm.mbd -o arm.h5`` then ``mbdsl view``:
    the file holds the payload's columns and the servo's work, and the page
    is written (the whole path a user takes, joint loads and a particle in
    it)."""
    from mbdsl.cli.main import main
    from tests.conftest import MODELS
    out = tmp_path / "arm.h5"
    assert main(["simulate", str(MODELS / "spatial_arm.mbd"), "--t-end", "0.2",
                 "-o", str(out)]) == 0
    sol = mbdsl.load_solution(out)
    assert {"payload.x", "payload.vz", "energy.work"} <= set(sol.columns)
    assert abs(sol.column("energy.work")[-1]) > 1e-3            # the servos work
    assert main(["view", str(out), "-o", str(tmp_path / "arm.html")]) == 0
    assert (tmp_path / "arm.html").stat().st_size > 1e5
