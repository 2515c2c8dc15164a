"""Point forces that read the motion: follower forces in body axes, drag
from a point's velocity, loads on flexible beams' cross-sections.

Oracles: closed-form motions (a free body under a thrust fixed in its axes
while it spins at a constant rate, whose centre of mass then traces
x = F/(m w^2) (1 - cos w t), y = F/(m w) (t - sin(w t)/w); a particle falling
against quadratic drag, v = -v_t tanh(g t / v_t), y = -(v_t^2/g) ln cosh(g t
/ v_t)); Beck's column, a cantilever under a tangential follower force at its
tip, whose straight form loses stability by flutter at P = 20.05 EI/L^2
(Beck 1952; Bolotin, Nonconservative Problems of the Theory of Elastic
Stability, 1963): bounded below, growing above, with methods that add no
numerical damping (the trapezoidal rule keeps a linear system's stability
boundary: |1 + h lambda/2| / |1 - h lambda/2| > 1 exactly when Re lambda > 0).
The derivatives against finite differences are in
``tests/assembly/test_derivatives.py`` (``follower_elements.mbd``), the
kernels against an independent numpy evaluation in
``tests/assembly/test_load_kernels.py``.
"""

import math

import numpy as np
import pytest
from scipy.integrate import trapezoid

import mbdsl
from mbdsl.errors import MbdModelError

METHODS = ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
           "genalpha-si2"]

M, F, W = 2.0, 3.0, 1.5

ROCKET = f"""model rocket
body r {{ mass {M}; inertia 0.5; point N (0.2, 0) }}
force thrust: force(r.N, ({F}, 0), frame = body)
initial r.omega = {W}
"""


def _rocket_error(sol):
    t = sol.t
    x = F / (M * W ** 2) * (1 - np.cos(W * t))
    y = F / (M * W) * (t - np.sin(W * t) / W)
    return max(np.abs(sol.column("r.x") - x).max(), np.abs(sol.column("r.y") - y).max())


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("method", METHODS)
def test_a_thrust_fixed_in_a_spinning_body_turns_with_it(method, engine):
    """The thrust along the body's x axis through its centre line exerts no
    torque: omega stays w, and the centre of mass follows the closed form;
    second order (newmark at gamma = 0.6: first), and the thrust's work is
    the kinetic energy's change (the energy balance)."""
    model = mbdsl.load_text(ROCKET)
    errors = []
    for h in (4e-3, 2e-3):
        sol = mbdsl.simulate(model, method=method, h=h, t_end=2.0, engine=engine)
        assert sol.completed and not sol.warnings
        assert np.abs(sol.column("r.omega") - W).max() < 1e-12
        errors.append(_rocket_error(sol))
    order = math.log2(errors[0] / errors[1])
    if method == "newmark":
        assert 0.8 < order < 1.3 and errors[1] < 2e-3
    else:
        assert 1.7 < order < 2.4 and errors[1] < 3e-5, errors
    work = sol.column("energy.work")[-1]
    ke = sol.column("energy.kinetic")
    assert work == pytest.approx(ke[-1] - ke[0], rel=1e-3)


def test_a_thrust_in_world_axes_does_not_turn():
    """The same thrust in world axes (the default frame): a constant force,
    x = F t^2 / (2 m), which second-order methods integrate exactly."""
    model = mbdsl.load_text(ROCKET.replace(", frame = body", ""))
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-2, t_end=1.0)
    assert np.allclose(sol.column("r.x"), F * sol.t ** 2 / (2 * M), atol=1e-12)
    assert np.abs(sol.column("r.y")).max() < 1e-12


C_DRAG, G = 0.4, 9.81
DROP = f"""model drop
gravity (0, -{G})
particle bob {{ mass 1 }}
force air: force(bob.cm, (0, -{C_DRAG}*bob.cm.vy*abs(bob.cm.vy)))
"""


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("method", ["hht-i3", "nstiff", "hht-si2", "genalpha"])
def test_a_particle_falls_against_quadratic_drag(method, engine):
    """m v' = -m g + c v |v| from rest: v = -v_t tanh(g t / v_t), v_t =
    sqrt(m g / c); the drag reads the point's velocity (``bob.cm.vy``)."""
    vt = math.sqrt(G / C_DRAG)
    sol = mbdsl.simulate(mbdsl.load_text(DROP), method=method, h=1e-3, t_end=3.0,
                         engine=engine)
    t = sol.t
    v = -vt * np.tanh(G * t / vt)
    y = -(vt ** 2 / G) * np.log(np.cosh(G * t / vt))
    assert np.abs(sol.column("bob.vy") - v).max() < 1e-4
    assert np.abs(sol.column("bob.y") - y).max() < 1e-4
    assert sol.column("bob.vy")[-1] == pytest.approx(-vt, rel=2e-3)   # near terminal speed


EI, L = 100.0, 1.0
BECK = f"""model beck_column
parameter P = 19 * {EI} / {L}^2       # [N]
flexible_beam rod {{ mass 1; length {L}; E 1e9; area 1e-3; second_moment {EI / 1e9!r}
                    elements 10; point B at end }}
joint clamp: fixed(ground.origin, rod.start)
force follower: force(rod.B, (-P, 0), frame = body)
force kick: force(rod.B, (0, if(t < 0.005, 2, 0)))
"""


def _beck_growth(p, method, **coefficients):
    """Largest tip deflection in the last half of 1 s over that in the first
    0.05 s, Beck's column at P = p EI/L^2 after a 2 N, 5 ms kick."""
    model = mbdsl.load_text(BECK, overrides={"P": p * EI / L ** 2})
    sol = mbdsl.simulate(model, method=method, h=1e-3, t_end=1.0, **coefficients)
    assert sol.completed
    v = np.abs(sol.column("rod.v10"))
    return v[len(v) // 2:].max() / v[:50].max()


@pytest.mark.parametrize("method,coefficients", [("hht-i3", {"alpha": 0.0}),
                                                 ("genalpha", {"rho_inf": 1.0})])
def test_becks_column_flutters_between_19_and_21_EI_over_L2(method, coefficients):
    """The follower force stays tangent to the tip (frame = body on a beam
    point: the cross-section's axes): the column is stable at 19 EI/L^2 and
    flutters at 21 EI/L^2 (Beck's critical load 20.05 EI/L^2)."""
    assert _beck_growth(19.0, method, **coefficients) < 1.5
    assert _beck_growth(21.0, method, **coefficients) > 5.0


@pytest.mark.slow
def test_becks_column_flutter_onset_is_within_one_percent_of_2005():
    """Sharper: stable at 19.8, unstable at 20.3 EI/L^2 (10 elements), so
    the onset is 20.05 to 1.3 %."""
    assert _beck_growth(19.8, "hht-i3", alpha=0.0) < 2.5
    assert _beck_growth(20.3, "hht-i3", alpha=0.0) > 5.0


def test_a_dead_load_on_the_same_column_does_not_flutter():
    """The same compressive load fixed in world axes (a dead load, Euler's
    column: buckling at pi^2/4 EI/L^2 = 2.47 EI/L^2, static) would buckle it;
    below that, at 2 EI/L^2, it only vibrates: the turning of the follower
    load is what makes 19 EI/L^2 stable and 21 flutter."""
    text = BECK.replace(", frame = body", "")
    model = mbdsl.load_text(text, overrides={"P": 2.0 * EI / L ** 2})
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=1.0, alpha=0.0)
    v = np.abs(sol.column("rod.v10"))
    assert v[len(v) // 2:].max() / v[:50].max() < 1.5
    model = mbdsl.load_text(text, overrides={"P": 3.0 * EI / L ** 2})
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=1.0, alpha=0.0,
                         on_failure="return")
    v = np.abs(sol.column("rod.v10"))
    assert v.max() > 10 * v[:50].max()          # above Euler's load it buckles away


@pytest.mark.parametrize("text,code,where", [
    ("force f: force(b.P, (1, 0), frame = moving)", "E305", "moving"),
    ("force f: force(p.cm, (1, 0), frame = body)", "E305", "frame = body"),
    ("force f: force(b.P, (b.P.z, 0))", "E304", "b.P.z"),
    ("force f: force(b.P, (b.Q.x, 0))", "E201", "b.Q.x"),
    ("force f: force(b.P, (rod.w3, 0))", "E304", "rod.w3"),
    ("force f: force(b.P, (rod.theta2_t * b.nope, 0))", "E304", "b.nope"),
])
def test_misused_follower_forces_are_named_at_their_place(text, code, where):
    """A frame that is not world or body, body axes on a particle, a point
    field, point, elastic coordinate or body field that does not exist."""
    base = ("model m\nbody b { mass 1; inertia 1; point P (0.1, 0) }\nparticle p { mass 1 }\n"
            "flexible_beam rod { mass 1; length 1; E 1e9; area 1e-3; second_moment 1e-7\n"
            "                    elements 2; point B at end }\n")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(base + text + "\n")
    diags = [d for d in err.value.diagnostics if d.severity == "error"]
    assert [d.code for d in diags] == [code]
    line = (base + text).splitlines()[diags[0].span.line - 1]
    col = diags[0].span.column - 1
    assert line[col:col + len(where)] == where, (line, diags[0].span)


def test_the_language_docs_example_spins_as_its_text_says():
    """docs/language.md's propeller arm: over a whole turn the thrust's work
    F r 2 pi equals the drag's, c r^3 int omega^2 dphi (gravity's is zero),
    so the angle-mean of omega^2, int omega^3 dt / int omega dt over a turn,
    is F/(c r^2) once the spin has settled."""
    import re
    from pathlib import Path
    doc = (Path(__file__).resolve().parents[2] / "docs" / "language.md").read_text()
    (text,) = [b for b in re.findall(r"```\n(.*?)```", doc, re.S)
               if b.startswith("model propeller_arm")]
    sol = mbdsl.simulate(mbdsl.load_text(text))
    assert sol.completed and not sol.warnings
    w, t, phi = sol.column("arm.omega"), sol.t, sol.column("arm.phi")
    turn = np.floor((phi - phi[0]) / (2 * np.pi))
    last = turn == turn[-1] - 1
    mean_w2 = trapezoid(w[last] ** 3, t[last]) / trapezoid(w[last], t[last])
    assert mean_w2 == pytest.approx(6.0 / (0.5 * 0.6 ** 2), rel=3e-3)
