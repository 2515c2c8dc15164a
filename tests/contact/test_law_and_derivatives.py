"""The contact law and its derivatives.

Oracles: the one-body impact of the Hunt-Crossley law integrated with scipy's
solve_ivp (its exit speed is the restitution the damping factor was solved
for), the Lankarani-Nikravesh limit for e -> 1, and central differences of
the gaps and of the generalized forces (the Newton matrix's Q_q and Q_v): of
the kernels (through the system) and of the numpy oracle
(``contact_oracle``) the kernels are compared with in
``test_contact_kernels``.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbdsl
from mbdsl.assembly.system import assemble
from mbdsl.model.contact import damping_factor

from .contact_oracle import ContactOracle, gap, slip


def exit_speed(chi, n):
    """x'' = -x^n (1 + chi x'), x(0) = 0, x'(0) = 1, until x returns to 0."""
    def rhs(_, y):
        return [y[1], -max(y[0], 0.0) ** n * max(0.0, 1.0 + chi * y[1])]

    def out(_, y):
        return y[0]
    out.terminal, out.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 100.0), [0.0, 1.0], events=out, rtol=1e-11, atol=1e-13,
                    max_step=0.01, first_step=1e-4)
    return -sol.y_events[0][0][1]


@pytest.mark.parametrize("e", [0.95, 0.8, 0.5, 0.2])
@pytest.mark.parametrize("n", [1.0, 1.5])
def test_damping_factor_restitutes_e(e, n):
    assert exit_speed(damping_factor(e, n), n) == pytest.approx(e, abs=2e-7)


def test_damping_factor_limits():
    assert damping_factor(1.0) == 0.0
    # Lankarani & Nikravesh (1990): chi = 3 (1 - e^2) / 4 for e -> 1
    e = 0.999
    assert damping_factor(e) == pytest.approx(0.75 * (1 - e * e), rel=2e-3)
    # Flores et al. (2011)'s fit 8 (1 - e) / (5 e) is 7 % above the exact value at 0.8
    assert 8 * 0.2 / 4.0 / damping_factor(0.8) == pytest.approx(1.072, abs=2e-3)
    with pytest.raises(ValueError, match="restitution"):
        damping_factor(0.0)
    with pytest.raises(ValueError, match="exponent"):
        damping_factor(0.5, 0.5)


MODEL = """model contacts
gravity (0, -9.81)
body a { mass 2; inertia 0.05; point P (0.1, 0.02); point C (-0.05, 0.03) }
body b { mass 1.5; inertia 0.03; point L (0.02, -0.01); point Q (0.04, 0.0) }
body s { mass 1; inertia 0.01; point S (0, 0) }
joint O: revolute(ground.origin, b.Q)
joint G: prismatic(s.S, ground.origin, direction = (1, 0.2))
force line: contact(a.P, radius = 0.05, line = (b.L, (1, 0.3)), k = 1e6, exponent = 1.5,
                    restitution = 0.7, mu = 0.3, v_reg = 0.5)
force pin: contact(a.C, radius = 0.01, circle = (b.L, 0.0105), k = 1e8, restitution = 0.6,
                   mu = 0.2, v_reg = 0.5)
force stop: limit(O, lower = -0.3, upper = 0.2, k = 1e4, exponent = 1.0, restitution = 0.5)
force end: limit(G, upper = 0.1, k = 2e5, exponent = 1.5, restitution = 0.8)
force tie: rope(a.C, s.S, length = 0.3, k = 3e3, c = 4)
"""


@pytest.fixture(scope="module")
def system():
    return assemble(mbdsl.load_text(MODEL))


def test_gaps_and_their_derivatives(system):
    g = system.contact_state
    assert g.names == ["line", "pin", "stop.lower", "stop.upper", "end.upper", "tie"]
    rng = np.random.default_rng(3)
    qx = np.zeros(system.nx)
    qx[:system.n] = rng.normal(scale=0.3, size=system.n)
    eps = 1e-6
    values, grads = system.contact_gaps(qx)          # the kernels'
    o = ContactOracle(system)
    for i, ((geo, data), cols) in enumerate(zip(o.geometry, g.cols[:, :6])):
        value, grad, hess = gap(geo, data, qx, system.cmap)
        assert values[i] == pytest.approx(value, abs=1e-15)
        for j, c in enumerate(cols):
            if c >= system.n:
                continue
            dq = np.zeros(system.nx)
            dq[c] = eps
            gp, gradp, _ = gap(geo, data, qx + dq, system.cmap)
            gm, gradm, _ = gap(geo, data, qx - dq, system.cmap)
            assert grad[j] == pytest.approx((gp - gm) / (2 * eps), abs=1e-7), (geo, j)
            fd = (system.contact_gaps(qx + dq)[0][i] - system.contact_gaps(qx - dq)[0][i]) \
                / (2 * eps)
            assert grads[i, j] == pytest.approx(fd, abs=1e-7), (geo, j)
            keep = cols < system.n
            np.testing.assert_allclose(hess[keep, j], ((gradp - gradm) / (2 * eps))[keep],
                                       atol=1e-6, err_msg=geo)


@pytest.mark.parametrize("armed", [True, False])
@pytest.mark.parametrize("name", ["line", "pin", "stop.lower", "stop.upper", "end.upper"])
def test_forces_and_their_derivatives(system, name, armed):
    """A penetrated, moving gap with its impact speed armed (or not yet: a
    trial step into a closing, where the approach speed stands for it): Q_q
    and Q_v against central differences of Q (the damping, the chi/v_impact
    term, the Hessian of the gap and, on the two contacts, friction all
    enter)."""
    g = system.contact_state
    o = ContactOracle(system)
    i = g.names.index(name)
    rng = np.random.default_rng(5)
    n, nx = system.n, system.nx
    g.reset()
    if armed:
        g.arm(i, 2.0, 0.0)
    for _ in range(20000):
        qx, vx = np.zeros(nx), np.zeros(nx)
        qx[:n] = rng.normal(scale=0.4, size=n)
        vx[:n] = rng.normal(scale=0.5, size=n)
        if o.gap(i, qx)[0] < -1e-4 and o.forces(qx, vx, 0.0)[i].any():
            break
    else:
        raise AssertionError(f"no configuration penetrates '{name}'")
    Q = o.forces(qx, vx, 0.0)
    Qq, Qv = o.derivatives(qx, vx, 0.0)
    assert np.any(Qv[i]) == ((o.chi[i] > 0 and armed) or o.mu[i] > 0)
    eps = 1e-7
    cols = g.cols[i, :6]                    # a planar gap: its six columns
    keep = cols < n
    scale = 1.0 + np.max(np.abs(Q[i]))
    for j, c in enumerate(cols):
        if c >= n:
            continue
        d = np.zeros(nx)
        d[c] = eps
        fd_q = (o.forces(qx + d, vx, 0.0)[i] - o.forces(qx - d, vx, 0.0)[i]) / (2 * eps)
        fd_v = (o.forces(qx, vx + d, 0.0)[i] - o.forces(qx, vx - d, 0.0)[i]) / (2 * eps)
        np.testing.assert_allclose(Qq[i][keep, j], fd_q[keep], atol=1e-6 * scale, rtol=1e-5,
                                   err_msg=f"{name} Q_q column {j}")
        np.testing.assert_allclose(Qv[i][keep, j], fd_v[keep], atol=1e-6 * scale, rtol=1e-5,
                                   err_msg=f"{name} Q_v column {j}")
    # the kernels' (every load of the model: gravity and all five gaps) against
    # central differences of their own Q
    q, v = qx[:n], vx[:n]
    KQ = system.Q(0.0, q, v)
    KQq, KQv = system.force_derivatives(0.0, q, v)
    scale = 1.0 + np.max(np.abs(KQ))
    for c in range(n):
        d = np.zeros(n)
        d[c] = eps
        fd_q = (system.Q(0.0, q + d, v) - system.Q(0.0, q - d, v)) / (2 * eps)
        fd_v = (system.Q(0.0, q, v + d) - system.Q(0.0, q, v - d)) / (2 * eps)
        np.testing.assert_allclose(KQq[:, c], fd_q, atol=1e-6 * scale, rtol=1e-5,
                                   err_msg=f"{name} kernels' Q_q column {c}")
        np.testing.assert_allclose(KQv[:, c], fd_v, atol=1e-6 * scale, rtol=1e-5,
                                   err_msg=f"{name} kernels' Q_v column {c}")


@pytest.mark.parametrize("name", ["line", "pin"])
def test_slip_is_the_material_points_relative_speed(system, name):
    """v_t = w . v against the motion of the two bodies' material points that
    sit at the contact point c: fix them in each body's frame, move q by v dt,
    and difference their positions (projected on the tangent)."""
    g = system.contact_state
    i = g.names.index(name)
    geo, data = ContactOracle(system).geometry[i]
    rng = np.random.default_rng(11)
    n, nx = system.n, system.nx
    qx, vx = np.zeros(nx), np.zeros(nx)
    qx[:n] = rng.normal(scale=0.4, size=n)
    vx[:n] = rng.normal(size=n)
    cols = g.cols[i, :6]                    # a planar gap: its six columns
    q = qx[cols]

    def rot(phi):
        return np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])

    a2 = rot(q[5]) @ np.array(data[3])
    p_pin = q[3:5] + a2
    if geo == "line":
        nu = rot(q[2]) @ np.array(data[4])
        r = data[5]
    else:
        d = p_pin - q[0:2] - rot(q[2]) @ np.array(data[1])
        nu, r = -d / np.linalg.norm(d), data[5]
    c = p_pin - r * nu
    tau = np.array([-nu[1], nu[0]])
    s1, s2 = rot(q[2]).T @ (c - q[0:2]), rot(q[5]).T @ (c - q[3:5])   # body-fixed
    dt = 1e-7
    qn = qx[cols] + dt * vx[cols]
    moved = (qn[3:5] + rot(qn[5]) @ s2) - (qn[0:2] + rot(qn[2]) @ s1)
    w, _ = slip(geo, data, qx, system.cmap)
    assert w @ vx[cols] == pytest.approx(tau @ moved / dt, rel=1e-5, abs=1e-6)


def test_force_is_along_the_gap_and_never_pulls(system):
    """Q = f grad g with f >= 0: separating faster than the damping allows
    cuts the force at zero, and an open gap has none."""
    g = system.contact_state
    o = ContactOracle(system)
    n, nx = system.n, system.nx
    qx = np.zeros(nx)
    qx[:n] = np.random.default_rng(7).normal(scale=0.3, size=n)
    g.reset()
    for i in range(len(g.names)):
        g.arm(i, 0.1, 0.0)
    for sign in (1.0, -1.0):
        vx = np.zeros(nx)
        vx[:n] = sign * np.random.default_rng(8).normal(size=n)
        Q = o.forces(qx, vx, 0.0)
        for i, (geo, data) in enumerate(o.geometry):
            value, grad, _ = gap(geo, data, qx, system.cmap)
            if value >= 0:
                assert not np.any(Q[i])
                continue
            if o.mu[i] > 0:             # the normal part only
                w, _ = slip(geo, data, qx, system.cmap)
                _, _, _, _, _, fn, _ = o.law(i, qx, vx, g.impact_speed[i])
                Q[i] = Q[i] - o.friction(i, qx, vx, fn)[0] * w
            f = Q[i] @ grad / (grad @ grad)
            assert f >= 0.0
            np.testing.assert_allclose(Q[i], f * grad, atol=1e-12 * (1 + abs(f)))


def test_duration_of_a_linear_impact(system):
    """For n = 1 the estimate is 3 sqrt(m / K) (pi sqrt(m/K) exactly); for the
    limit on a revolute the mass is the inertia of its body."""
    g = system.contact_state
    i = g.names.index("stop.upper")
    qx = np.zeros(system.nx)
    t = g.duration(i, qx, 1.0, system.mass_diag)
    assert t == pytest.approx(3.0 * math.sqrt(0.03 / 1e4), rel=1e-12)
