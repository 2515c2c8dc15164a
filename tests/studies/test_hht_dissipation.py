"""HHT's numerical dissipation in mbdsl against the method's linear analysis.

On a linear oscillator the HHT-I3 positions obey a linear recurrence whose
dominant roots lambda, conj(lambda) have |lambda|^2 = -r, r the coefficient of
x_{n-1} in x_{n+1} = p x_n + r x_{n-1} (the third, spurious root decays within
a few steps). Fitting p, r by least squares to the simulated x_n measures the
spectral radius of mbdsl's HHT to round-off; the test compares it with the
spectral radius of HHT's amplification matrix computed here (Hilber, Hughes &
Taylor 1977; gamma = 1/2 - alpha, beta = (1 - alpha)^2 / 4).

This also fixes what the energy study can show: the algorithmic damping at
alpha = -0.3 is only about 3.26 times that at alpha = -0.05 for Omega h <= 0.3
(docs/studies.md).
"""

import numpy as np
import pytest

import mbdsl

OMEGA = 2 * np.pi            # rad/s: k = m Omega^2 with m = 1 kg
MODEL = f"""
model oscillator
body b {{ mass 1; inertia 1 }}
force s: spring_damper(ground.origin, b.cm, k = {OMEGA**2!r}, c = 0, length = 0)
initial b.x = 0.1; initial b.y = 0; initial b.phi = 0
initial b.vx = 0; initial b.vy = 0; initial b.omega = 0
"""


def hht_spectral_radius(alpha, omega_h):
    """Largest |eigenvalue| of HHT's amplification matrix for x'' + Omega^2 x = 0."""
    g, b, w2 = 0.5 - alpha, (1 - alpha) ** 2 / 4, omega_h**2
    A = np.array([[(1 + alpha) * w2, 0, 1], [1, 0, -b], [0, 1, -g]])
    B = np.array([[alpha * w2, 0, 0], [1, 1, 0.5 - b], [0, 1, 1 - g]])
    return float(np.max(np.abs(np.linalg.eigvals(np.linalg.solve(A, B)))))


def measured_spectral_radius(x):
    """sqrt(-r) of the least-squares recurrence x_{n+1} = p x_n + r x_{n-1}."""
    x = x[10:]                          # past the spurious root's transient
    (p, r), *_ = np.linalg.lstsq(np.column_stack([x[1:-1], x[:-2]]), x[2:], rcond=None)
    return float(np.sqrt(-r))


@pytest.mark.parametrize("omega_h", [0.3, 1.0])
def test_hht_damping_matches_linear_analysis(omega_h):
    model = mbdsl.load_text(MODEL)
    h = omega_h / OMEGA
    decay = {}
    for alpha in (-0.3, -0.05):
        sol = mbdsl.simulate(model, method="hht-i3", h=h, t_end=200 * h, alpha=alpha)
        rho = measured_spectral_radius(sol.column("b.x"))
        expected = hht_spectral_radius(alpha, omega_h)
        assert rho == pytest.approx(expected, abs=1e-10), alpha
        decay[alpha] = -np.log(expected)
    # the damping ratio between the two alphas: 3.22 at Omega h = 0.3, 3.04 at 1
    assert 2.9 < decay[-0.3] / decay[-0.05] < 3.3
