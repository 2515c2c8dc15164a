"""Spring-damper-actuators of spatial models (TSDA,
``kernels.loads.spatial_springs``): the force's derivatives against finite
differences, a body on a spring along a line against the harmonic
oscillator, and the energy balance with damping."""

from __future__ import annotations

import numpy as np
import pytest

import mbdsl

TEXT = """model spring3d
space 3d
body b {{ mass 2; inertia (0.1, 0.2, 0.25); point P (0.1, 0.05, 0.2) }}
force s: spring_damper(ground.origin, b.{point}, k = 200, c = {c}, length = 0.5)
initial b.orientation = zyx(0, 0, 0)
initial b.omega_body = ({w})
initial b.x = {x}; initial b.y = 0; initial b.z = 0
initial b.vx = 0; initial b.vy = 0; initial b.vz = 0
"""


def _model(point="P", c=3, w="1, 2, 3", x=0.6):
    return mbdsl.load_text(TEXT.format(point=point, c=c, w=w, x=x))


def test_the_spring_forces_derivatives_against_finite_differences():
    """Q_q and Q_v of a damped spring between the ground and a body point, at
    a general state (directors not orthonormal), against central differences
    of Q."""
    system = mbdsl.assemble(_model())
    n = system.n
    rng = np.random.default_rng(11)
    q, v = rng.normal(size=n) * 0.3, rng.normal(size=n)
    q[:3] += [0.7, 0.2, -0.4]                  # the point well away from the origin
    Qq, Qv = system.force_derivatives(0.0, q, v)
    eps = 1e-6
    E = np.eye(n)
    fq = np.column_stack([(system.Q(0.0, q + eps * e, v) - system.Q(0.0, q - eps * e, v))
                          / (2 * eps) for e in E])
    fv = np.column_stack([(system.Q(0.0, q, v + eps * e) - system.Q(0.0, q, v - eps * e))
                          / (2 * eps) for e in E])
    assert np.max(np.abs(Qq - fq)) < 1e-6 * np.max(np.abs(fq)) and np.max(np.abs(fq)) > 10
    assert np.max(np.abs(Qv - fv)) < 1e-6 * np.max(np.abs(fv)) and np.max(np.abs(fv)) > 0.1


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "genalpha"])
def test_a_body_on_a_spring_along_a_line_is_a_harmonic_oscillator(method):
    """The spring on the centre of mass, no gravity, released stretched at
    rest along x: x(t) = l0 + A cos(sqrt(k/m) t), converged at order 2."""
    model = _model(point="cm", c=0, w="0, 0, 0", x=0.6)
    omega = np.sqrt(200 / 2.0)
    errors = []
    for h in (2e-3, 1e-3):
        sol = mbdsl.simulate(model, method=method, h=h, t_end=1.0)
        t = sol.column("t")
        errors.append(np.max(np.abs(sol.column("b.x") - (0.5 + 0.1 * np.cos(omega * t)))))
        assert np.max(np.abs(sol.column("b.y"))) < 1e-12
    assert abs(np.log2(errors[0] / errors[1]) - 2.0) < 0.2, errors


def test_the_damped_spring_closes_the_energy_balance():
    """A turning body on a damped spring: the energy falls by what the damper
    dissipates (energy.balance within 1e-4 of the dissipated energy), and
    without damping it is kept to 1e-4 of its size."""
    sol = mbdsl.simulate(_model(), method="hht-si2", h=1e-3, t_end=2.0)
    diss = sol.column("energy.dissipated")
    assert diss[-1] > 1.0
    assert np.max(np.abs(sol.column("energy.balance"))) < 1e-4 * diss[-1]
    sol = mbdsl.simulate(_model(c=0), method="hht-si2", h=1e-3, t_end=2.0)
    E = sol.column("energy.total")
    assert np.max(np.abs(E - E[0])) < 1e-4 * np.max(np.abs(E))
