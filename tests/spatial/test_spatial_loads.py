"""Forces on points and torques on spatial bodies (``force``, ``torque`` in a
``space 3d`` model; ``kernels.loads.spatial_loads``): the generalized force
against the virtual work of the load, its derivatives against finite
differences, a constant torque and a follower force against closed-form
motions, the work they put in, and the language's errors."""

from __future__ import annotations

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import MbdModelError
from mbdsl.model.spatial import axis_angle

TEXT = """model loads3d
space 3d
body b {{ mass 2; inertia ({J}); point P (0.3, -0.1, 0.2) }}
{loads}
initial b.orientation = zyx(0.3, -0.2, 0.5)
initial b.omega_body = ({w})
initial b.x = 0; initial b.y = 0; initial b.z = 0
initial b.vx = 0; initial b.vy = 0; initial b.vz = 0
"""


def _model(loads, J="0.1, 0.2, 0.25", w="0, 0, 0"):
    return mbdsl.load_text(TEXT.format(loads=loads, J=J, w=w))


@pytest.mark.parametrize("load", [
    "force f: force(b.P, (1, -2, 3))",
    "force f: force(b.P, (1, -2, 3), frame = body)",
    "force m: torque(b, (0.4, -0.1, 0.7))",
    "force m: torque(b, (0.4, -0.1, 0.7), frame = body)",
])
def test_the_generalized_force_does_the_loads_virtual_work(load):
    """At an orthonormal frame: Q . dq for the velocity of a rigid motion
    (dr = u, da_k = w x a_k) equals F . (u + w x A s) for a force and T . w
    for a torque; and Q_q equals central differences of Q at a general
    (not orthonormal) state."""
    system = mbdsl.assemble(_model(load))
    q = mbdsl.consistent_initial_state(system).q
    A = q[3:12].reshape(3, 3).T
    F = np.array([1.0, -2.0, 3.0]) if "force(" in load else np.array([0.4, -0.1, 0.7])
    F = A @ F if "body" in load else F
    Q = system.Q(0.0, q, np.zeros(system.n))
    rng = np.random.default_rng(5)
    for _ in range(3):
        u, w = rng.normal(size=3), rng.normal(size=3)
        dq = np.r_[u, np.cross(w, A.T).ravel()]            # rows: w x a_k, k = 1, 2, 3
        if "force(" in load:
            expected = F @ (u + np.cross(w, A @ np.array([0.3, -0.1, 0.2])))
        else:
            expected = F @ w
        assert Q[:12] @ dq == pytest.approx(expected, rel=1e-12, abs=1e-12)
    qg = q + rng.normal(size=system.n) * 0.2
    Qq, _ = system.force_derivatives(0.0, qg, np.zeros(system.n))
    eps = 1e-6
    fq = np.column_stack([(system.Q(0.0, qg + eps * e, np.zeros(system.n))
                           - system.Q(0.0, qg - eps * e, np.zeros(system.n))) / (2 * eps)
                          for e in np.eye(system.n)])
    assert np.max(np.abs(Qq - fq)) < 1e-8


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "genalpha"])
def test_a_constant_torque_turns_a_round_body_about_a_fixed_axis(method):
    """Inertia J I (a sphere) at rest, torque T in world axes: it turns about
    T by |T| t^2 / (2 J); its orientation converges to that at order 2."""
    T, J = np.array([0.4, -0.1, 0.7]), 0.2
    model = _model("force m: torque(b, (0.4, -0.1, 0.7))", J="0.2, 0.2, 0.2")
    A0 = mbdsl.simulate(model, h=1e-3, t_end=1e-3).q[0][3:12].reshape(3, 3).T
    errors = []
    for h in (4e-3, 2e-3):
        sol = mbdsl.simulate(model, method=method, h=h, t_end=1.0)
        q, t = sol.q[-1], sol.column("t")[-1]
        exact = axis_angle(T, np.linalg.norm(T) * t * t / (2 * J)) @ A0
        errors.append(np.max(np.abs(q[3:12].reshape(3, 3).T - exact)))
        w_world = q[3:12].reshape(3, 3).T @ np.array([sol.column(f"b.w{c}")[-1] for c in "xyz"])
        np.testing.assert_allclose(w_world, T * t / J, rtol=1e-3)   # index 3: v to O(h)
    assert abs(np.log2(errors[0] / errors[1]) - 2.0) < 0.25, errors


def test_a_follower_force_and_torque_in_body_axes():
    """A body spinning about its body z at w0, a torque (0, 0, T) in body
    axes and a force (F, 0, 0) in body axes at its centre of mass: w_z = w0 +
    T t / J3, and the centre of mass moves on the curve of the force turning
    with the body: v = F / m int (cos th, sin th) dt, th = w0 t + T t^2 /(2 J3),
    checked against a quadrature; the work the loads put in equals the
    kinetic energy gained (no other load)."""
    from scipy.integrate import quad
    m, J3, F, T, w0 = 2.0, 0.25, 1.5, 0.3, 2.0
    text = TEXT.format(loads="force f: force(b.cm, (1.5, 0, 0), frame = body)\n"
                             "force m: torque(b, (0, 0, 0.3), frame = body)",
                       J="0.1, 0.2, 0.25", w="0, 0, 2")
    text = text.replace("zyx(0.3, -0.2, 0.5)", "zyx(0, 0, 0)")
    sol = mbdsl.simulate(mbdsl.load_text(text), method="hht-si2", h=1e-3, t_end=1.0)
    t = sol.column("t")[-1]
    assert sol.column("b.wz")[-1] == pytest.approx(w0 + T * t / J3, rel=1e-5)   # O(h^2)
    th = lambda s: w0 * s + T * s * s / (2 * J3)            # noqa: E731
    vx = F / m * quad(lambda s: np.cos(th(s)), 0, t, epsabs=1e-13)[0]
    vy = F / m * quad(lambda s: np.sin(th(s)), 0, t, epsabs=1e-13)[0]
    assert sol.column("b.vx")[-1] == pytest.approx(vx, abs=2e-6)
    assert sol.column("b.vy")[-1] == pytest.approx(vy, abs=2e-6)
    gained = sol.column("energy.kinetic")[-1] - sol.column("energy.kinetic")[0]
    assert sol.column("energy.work")[-1] == pytest.approx(gained, rel=1e-5)


@pytest.mark.parametrize("line, code", [
    ("force m: torque(b, (1, 2))", "E305"),
    ("force m: torque(b, (b.yaw, 0, 0))", "E304"),
    ("force f: force(ground.origin, (1, 2, 3))", "E402"),
    ("force f: force(b.P, (1, 2, 3), frame = sideways)", "E305"),
    ("force m: torque(c, (1, 2, 3))", "E201"),
])
def test_a_wrong_spatial_load_is_an_error_at_its_line(line, code):
    with pytest.raises(MbdModelError) as err:
        _model(line)
    d = err.value.diagnostics[0]
    assert d.code == code and d.span.line == 4, (d.code, d.message)


def test_a_planar_torque_has_no_frame():
    text = ("model t\nbody b { mass 1; inertia 1; point A (0, 0) }\n"
            "joint A: revolute(ground.origin, b.A)\nforce m: torque(b, 1, frame = body)\n")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(text)
    assert err.value.diagnostics[0].code == "E304"
