"""Flexible beams (floating frame of reference) against independent results.

* statics of a cantilever: tip deflection P L^3 / (3 E I) (Euler-Bernoulli;
  cubic Hermite elements are exact for end loads);
* eigenfrequencies of the clamped-free beam: beta_k L = 1.8751, 4.6941,
  7.8548 (Euler-Bernoulli);
* the mass matrix against the kinetic energy integrated point by point
  along the beam, and the quadratic velocity vector against Lagrange's
  equations (finite differences of T = v^T M(q) v / 2);
* a free spinning beam keeps its energy and angular momentum, computed
  point by point along the beam.
"""

import numpy as np
import pytest
import scipy.linalg

import mbdsl
from mbdsl.assembly import ffr
from mbdsl.assembly.system import assemble

E, A, I_AREA, RHO, L = 70e9, 4e-4, 1.2e-8, 2700.0, 1.0


def cantilever(elements, frame="first_node", load="", stiffening="off"):
    """The linear beam (stiffening off) unless asked: the Euler-Bernoulli
    results below are linear theory."""
    return mbdsl.load_text(f"""
model cantilever
flexible_beam beam {{ density {RHO}; length {L}; E {E}; area {A}; second_moment {I_AREA}
                      elements {elements}; frame {frame}; point tip at end
                      stiffening {stiffening} }}
joint clamp: fixed(ground.origin, beam.start)
{load}
""")


def static_equilibrium(system, t=0.0):
    """Newton on Q(q, 0) - Phi_q^T lambda = 0, Phi(q) = 0 (linear here: one step
    is exact; iterate to round-off anyway)."""
    n, m = system.n, system.m
    q, lam = np.zeros(n), np.zeros(m)
    for _ in range(10):
        v = np.zeros(n)
        r = np.concatenate([system.Q(t, q, v) - system.Phi_q(q, t).T @ lam, -system.Phi(q, t)])
        Qq, _ = system.force_derivatives(t, q, v)
        K = np.block([[-Qq + system.PhiqT_lam_q(q, lam), system.Phi_q(q, t).T],
                      [system.Phi_q(q, t), np.zeros((m, m))]])
        dx = np.linalg.solve(K, r)
        q, lam = q + dx[:n], lam + dx[n:]
        if np.max(np.abs(dx)) < 1e-15:
            break
    return q


def point_position(system, q, body, x):
    """Global position of the material point at arc length x, from the mesh."""
    b = system.model.bodies[body]
    S = b.mesh.shape(np.atleast_1d(x))                         # (k, 2, nf)
    u = np.stack([np.atleast_1d(x), np.zeros(np.size(x))], 1) + S @ q[b.elastic_columns()]
    c, s = np.cos(q[3 * body + 2]), np.sin(q[3 * body + 2])
    A_ = np.array([[c, -s], [s, c]])
    return q[3 * body: 3 * body + 2] + u @ A_.T


@pytest.mark.parametrize("elements", [1, 3, 8])
def test_cantilever_tip_deflection(elements):
    P = 12.0
    model = cantilever(elements, load=f"force tipload: force(beam.tip, (0, -{P}))")
    system = assemble(model)
    q = static_equilibrium(system)
    tip = point_position(system, q, 0, L)[0]
    exact = P * L ** 3 / (3 * E * I_AREA)
    assert tip[1] == pytest.approx(-exact, rel=1e-6)
    assert abs(tip[0] - L) < 1e-9 * L      # no axial load: the axial coordinates stay 0
    # with geometric stiffening the bent beam foreshortens, free of axial strain:
    # the tip moves in by int v'^2/2 dx = (3/5) delta^2 / L for the cubic deflection
    # curve (exact for any mesh: cubic Hermite elements hold it), and its deflection
    # changes only at O((delta/L)^2) (an element-wise pointwise v'^2 locked it by 6 %)
    system = assemble(cantilever(elements, load=f"force tipload: force(beam.tip, (0, -{P}))",
                                 stiffening="on"))
    q = static_equilibrium(system)
    tip = point_position(system, q, 0, L)[0]
    assert tip[1] == pytest.approx(-exact, rel=1e-4)
    assert L - tip[0] == pytest.approx(0.6 * exact ** 2 / L, rel=1e-3)


def test_cantilever_eigenfrequencies():
    system = assemble(cantilever(8))
    q = np.zeros(system.n)
    M = system.mass_matrix(q)
    Qq, _ = system.force_derivatives(0.0, q, np.zeros(system.n))
    N = scipy.linalg.null_space(system.Phi_q(q, 0.0))          # the clamp's admissible motions
    w2 = scipy.linalg.eigh(N.T @ (-Qq) @ N, N.T @ M @ N, eigvals_only=True)
    omega = np.sqrt(np.sort(w2))
    mu = RHO * A
    bending = np.array([1.8751041, 4.6940911, 7.8547574]) ** 2 * np.sqrt(E * I_AREA / (mu * L ** 4))
    axial = np.pi / (2 * L) * np.sqrt(E / RHO)                  # first axial mode, far above
    found = omega[omega < 0.5 * axial][:3]
    np.testing.assert_allclose(found, bending, rtol=5e-3)
    # the first three are bending modes, and cubic elements are already close
    assert np.max(np.abs(found / bending - 1)) < 1e-3


def free_beam(frame, omega0=4.0, elements=4, extra=""):
    return mbdsl.load_text(f"""
model spinning
flexible_beam beam {{ mass 1.0; length 1.0; E 1e6; area 1e-3; second_moment 1e-6
                      elements {elements}; frame {frame} }}
initial beam.phi = 0.3
initial beam.x = 0.1
initial beam.omega = {omega0}
initial beam.vx = 0.2
initial beam.vy = -0.1
{extra}
""")


def quadrature_energy_momentum(system, q, v, body=0):
    """(T, L_z) of a beam, integrated over 8 Gauss points per element from
    the point kinematics r = R + A u_bar, r' = R' + B u_bar phi' + A S q_f'."""
    b = system.model.bodies[body]
    mesh = b.mesh
    x, w = np.polynomial.legendre.leggauss(8)
    e = np.arange(mesh.elements)[:, None]
    xs = ((e + 0.5 * (x[None] + 1)) * mesh.l).ravel()
    ws = np.broadcast_to(0.5 * mesh.l * w[None], (mesh.elements, 8)).ravel() * b.mass / b.length
    S = mesh.shape(xs)
    cols = b.elastic_columns()
    u = np.stack([xs, 0 * xs], 1) + S @ q[cols]
    ud = S @ v[cols]
    phi, om = q[3 * body + 2], v[3 * body + 2]
    c, s = np.cos(phi), np.sin(phi)
    A_ = np.array([[c, -s], [s, c]])
    B_ = np.array([[-s, -c], [c, -s]])
    r = q[3 * body: 3 * body + 2] + u @ A_.T
    rd = v[3 * body: 3 * body + 2] + om * (u @ B_.T) + ud @ A_.T
    T = 0.5 * np.sum(ws * np.sum(rd * rd, 1))
    Lz = np.sum(ws * (r[:, 0] * rd[:, 1] - r[:, 1] * rd[:, 0]))
    return T, Lz


@pytest.mark.parametrize("frame", ["first_node", "chord"])
def test_mass_matrix_is_the_kinetic_energy(frame):
    system = assemble(free_beam(frame))
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, v = rng.normal(size=system.n), rng.normal(size=system.n)
        q[3:] *= 0.05
        T, _ = quadrature_energy_momentum(system, q, v)
        assert system.kinetic_energy(q, v) == pytest.approx(T, rel=1e-12)


@pytest.mark.parametrize("frame", ["first_node", "chord"])
def test_quadratic_velocity_vector_is_lagrange(frame):
    # Q_v = dT/dq - (M v)_q v for T = v^T M(q) v / 2 (no other force depends on v).
    system = assemble(free_beam(frame))
    rng = np.random.default_rng(4)
    eps = 1e-6
    for _ in range(3):
        q, v = rng.normal(size=system.n), rng.normal(size=system.n)
        q[3:] *= 0.05
        dT = np.array([(system.kinetic_energy(q + eps * e, v) - system.kinetic_energy(q - eps * e, v))
                       / (2 * eps) for e in np.eye(system.n)])
        Mdot_v = np.array([(system.mass_times(q + eps * e, v) - system.mass_times(q - eps * e, v))
                           / (2 * eps) for e in np.eye(system.n)]).T @ v
        Qv = system.Q(0.0, q, v) - system.Q(0.0, q, np.zeros(system.n))
        np.testing.assert_allclose(Qv, dT - Mdot_v, atol=1e-6 * np.max(np.abs(Qv)))


@pytest.mark.parametrize("frame", ["first_node", "chord"])
def test_free_spinning_beam_keeps_energy_and_angular_momentum(frame):
    system = assemble(free_beam(frame))
    sol = mbdsl.simulate(system.model, "hht-i3", h=2e-4, t_end=1.0, alpha=0.0)
    assert sol.completed
    E0 = sol.column("energy.total")
    LT = [quadrature_energy_momentum(system, q, v) for q, v in zip(sol.q, sol.v)]
    T = np.array([x[0] for x in LT])
    Lz = np.array([x[1] for x in LT])
    # the beam really deforms (centrifugal stretch and bending): elastic energy is present
    strain = ffr.energy(system.kernel_model(), sol.q[-1], 0, len(system.model.flexible_bodies),
                        gravity=False)
    assert strain > 1e-6 * E0[0]
    np.testing.assert_allclose(T + (E0 - sol.column("energy.kinetic")), E0[0], rtol=1e-6)
    np.testing.assert_allclose(Lz, Lz[0], rtol=1e-6)
