"""Ropes and cables: tension-only spring-dampers between two points.

Oracles: free fall until the rope goes taut, at t = sqrt(2 (L - d0) / g)
(d0 the drop's start below the anchor); from there the undamped mass on a
linear spring under gravity in closed form, x(t) = (m g / k)(1 - cos w t) +
(v0 / w) sin w t, whose peak tension is k x_max = m g + sqrt((m g)^2 + k m
v0^2); the energy balance of the run's own columns; and the language's
errors. The rope's law and its derivatives are the contact family's
(``tests/contact/test_contact_kernels.py`` runs the kernels against the
numpy oracle on ``rope_elements.mbd``).
"""

import math

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import MbdModelError

G, M, L, K, D0 = 9.81, 2.0, 1.0, 2000.0, 0.2

DROP = f"""model rope_drop
gravity (0, -9.81)
particle m {{ mass {M} }}
force R: rope(ground.origin, m.cm, length = {L}, k = {K}, c = DAMPING)
initial m.x = 0
initial m.y = -{D0}
"""


def _taut_time(sol):
    """The time of the rope's first closing, from the run's contact log."""
    return min(t for t, _, speed in sol.contact_log if speed > 0.0)


@pytest.mark.parametrize("method, tol", [("hht-i3", 1e-9), ("hht-si2", 1e-9),
                                         ("genalpha", 1e-9), ("newmark", 1e-9),
                                         ("nstiff", 5e-6)])
def test_a_dropped_mass_pulls_a_slack_rope_taut_at_the_free_fall_time(method, tol):
    """The event lands on the taut instant: to 1e-9 s of the closed form for
    the methods that integrate free fall exactly (q = g t^2 / 2); NSTIFF's
    BDF1 start leaves an O(h^2) offset in q (1.9e-6 s here)."""
    sol = mbdsl.simulate(mbdsl.load_text(DROP.replace("DAMPING", "0")), method=method,
                         h=1e-3, t_end=0.6)
    assert sol.completed
    t_taut = math.sqrt(2.0 * (L - D0) / G)
    assert abs(_taut_time(sol) - t_taut) < tol
    # slack before: no tension, free fall; never a push
    tension = sol.column("rope.R.tension")
    assert np.all(tension >= 0.0)
    before = sol.t < _taut_time(sol) - 1e-12
    assert np.all(tension[before] == 0.0)
    np.testing.assert_allclose(sol.column("m.y")[before], -D0 - G * sol.t[before] ** 2 / 2,
                               rtol=0, atol=1e-12 if tol < 1e-6 else 1e-5)


def test_the_peak_tension_is_the_springs():
    """Undamped: k x_max = m g + sqrt((m g)^2 + k m v0^2), v0 = g t_taut; the
    rope stretches and springs back, and goes slack again at the same speed."""
    sol = mbdsl.simulate(mbdsl.load_text(DROP.replace("DAMPING", "0")), method="hht-i3",
                         h=2e-4, t_end=0.6, rtol=1e-8)
    v0 = G * math.sqrt(2.0 * (L - D0) / G)
    peak = M * G + math.sqrt((M * G) ** 2 + K * M * v0 ** 2)
    assert sol.column("rope.R.tension").max() == pytest.approx(peak, rel=1e-5)
    opened = [t for t, _, speed in sol.contact_log if speed == 0.0]
    assert opened, "the rope goes slack again"
    i = np.searchsorted(sol.t, opened[0])
    assert abs(sol.column("m.vy")[i]) == pytest.approx(v0, rel=1e-4)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_a_damped_rope_dissipates_what_the_balance_says(engine):
    """c > 0: c (dl/dt)^2 while taut, the law cut where it would push; the
    run's energy balance closes (the guard silent) through the rope's three
    slack-and-taut cycles, and the tension never pushes."""
    sol = mbdsl.simulate(mbdsl.load_text(DROP.replace("DAMPING", "20")), method="hht-si2",
                         h=1e-3, t_end=3.0, engine=engine)
    assert len(sol.contact_log) >= 6
    # no jump where it goes taut at speed: c dl/dt is limited to k (l - L) (0 there)
    for t_event, _, speed in sol.contact_log:
        i = int(np.argmin(np.abs(sol.t - t_event)))
        assert abs(sol.t[i] - t_event) < 1e-8
        assert sol.column("rope.R.tension")[i] < 1e-6 * K
    assert sol.completed and not sol.warnings
    assert np.all(sol.column("rope.R.tension") >= 0.0)
    dissipated = sol.column("energy.dissipated")[-1]
    change = sol.column("energy.total")[-1] - sol.column("energy.total")[0]
    assert dissipated > 1.0
    assert abs(change + dissipated) < 1e-3 * dissipated
    # it settles hanging: k (l - L) = m g
    assert sol.column("m.y")[-1] == pytest.approx(-(L + M * G / K), rel=2e-3)


def test_a_cable_is_a_rope_of_stiffness_ea_over_its_length():
    rope = mbdsl.load_text(DROP.replace("DAMPING", "0"))
    cable = mbdsl.load_text(DROP.replace(f"rope(ground.origin, m.cm, length = {L}, k = {K}, "
                                         "c = DAMPING)",
                                         f"cable(ground.origin, m.cm, length = 2, EA = {2 * K})")
                            .replace(f"initial m.y = -{D0}", "initial m.y = -1.2"))
    assert cable.forces[0].k == K and cable.forces[0].kind == "cable"
    a = mbdsl.simulate(rope, method="hht-i3", h=1e-3, t_end=0.6)
    b = mbdsl.simulate(cable, method="hht-i3", h=1e-3, t_end=0.6)
    np.testing.assert_allclose(b.column("m.y") + 1.0, a.column("m.y"), atol=1e-9)


@pytest.mark.parametrize("line, code, text", [
    ("force R: rope(ground.origin, m.cm, length = 0, k = 10)", "E303", "must be positive"),
    ("force R: rope(ground.origin, m.cm, length = 1)", "E304", "missing option 'k'"),
    ("force R: rope(m.cm, m.cm, length = 1, k = 10)", "E402", "ties a body to itself"),
    ("force R: rope(ground.origin, m.cm, length = 1, k = 10, c = -1)", "E303", "negative"),
    ("force R: cable(ground.origin, m.cm, length = 1, EA = 3 m)", "E307", "got a length"),
])
def test_misused_ropes_are_errors_at_their_line(line, code, text):
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(f"model bad\nparticle m {{ mass 1 }}\n{line}\n", "bad.mbd")
    (d,) = [d for d in err.value.diagnostics if d.is_error]
    assert d.code == code and text in d.message, d
    assert d.span.line == 3
