"""Geometric stiffening of the floating-frame beam.

Oracles: Southwell's formula for the in-plane first bending frequency of a
clamped uniform cantilever spinning about its root (zero hub radius) in the
rotating frame, omega^2 = omega_0^2 + (phi_1 - 1) Omega^2 with phi_1 =
1.1933; the spin-up beam of Kane, Ryan & Banerjee (1987), whose tip stays
within decimetres when stiffening is modelled (and diverges without it:
``test_deflection_warning.py``); the Euler-Bernoulli first frequency
3.516 sqrt(EI / (rho A L^4)).
"""

import math
from pathlib import Path

import numpy as np
import pytest

import mbdsl

HERE = Path(__file__).parent
EI, RHOA, LENGTH = 14000.0, 1.2, 10.0


def rotating_cantilever(W, stiffening="on"):
    """The spin-up beam's cantilever on a hub turning at W [rad/s] from t = 0,
    kicked at its tip across the beam at t = 0.5 s."""
    kick = "20*exp(-((t - 0.5)/0.05)^2)"
    return mbdsl.load_text(f"""model rotating_cantilever
parameter W = {W}
body hub {{ mass 1; inertia 1 }}
flexible_beam beam {{ mass 12; length 10; E 2.8e11; area 1e-4; second_moment 5e-8
                     elements 8; frame first_node; point tip at end; stiffening {stiffening} }}
joint O: revolute(ground.origin, hub.cm)
joint F: fixed(hub.cm, beam.start)
driver spin: hub.phi = W*t
force kick: force(beam.tip, (-sin(W*t)*{kick}, cos(W*t)*{kick}))
""")


def first_frequency(model, T=20.0, h=5e-3):
    """In the rotating (beam) frame: the tip's transverse elastic coordinate
    after the kick, about its mean; pi over the mean spacing of its zero
    crossings [rad/s]."""
    sol = mbdsl.simulate(model, method="hht-i3", h=h, t_end=T)
    beam = next(b for b in model.bodies if hasattr(b, "mesh"))
    v = sol.q[:, beam.elastic_columns()[beam.mesh.names.index(f"v{beam.elements}")]]
    keep = sol.t > 1.5
    v, t = v[keep] - v[keep].mean(), sol.t[keep]
    i = np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:]))
    crossings = t[i] + (t[i + 1] - t[i]) * v[i] / (v[i] - v[i + 1])
    assert len(crossings) > 20
    return math.pi / float(np.mean(np.diff(crossings)))


def test_southwell_frequency_of_a_spinning_cantilever():
    """omega_0 = 3.7913 measured (3.516 sqrt(EI/(rho A L^4)) = 3.798); spun at
    4 rad/s: 4.1638 against Southwell's 4.1794 (-0.37 %; the issue asks 2 %),
    where the linear beam has omega^2 = omega_0^2 - Omega^2 < 0 (it diverges)."""
    w0 = first_frequency(rotating_cantilever(0.0))
    assert w0 == pytest.approx(3.516 * math.sqrt(EI / (RHOA * LENGTH ** 4)), rel=5e-3)
    W = 4.0
    w = first_frequency(rotating_cantilever(W))
    assert w == pytest.approx(math.sqrt(w0 ** 2 + (1.1933 - 1.0) * W ** 2), rel=0.02)


@pytest.mark.parametrize("ws", [4.0, 10.0])
def test_spin_up_beam_follows_its_quasi_static_deflection(ws):
    """Kane, Ryan & Banerjee's spin-up over Ts = 15 s, then held to 20 s.

    The tip's transverse deflection in the beam frame peaks where the hub's
    angular acceleration alpha = (ws/Ts)(1 - cos(2 pi t/Ts)) loads the beam
    most; the load rho A alpha x alone bends a cantilever by
    11 rho A alpha L^5 / (120 EI), and spinning at Omega(t) scales its first
    mode's stiffness by (omega_0^2 + 0.1933 Omega^2) / omega_0^2 (Southwell,
    in-plane). Measured: 0.4004 m at 6.95 s (ws = 4; that estimate 0.3980)
    and 0.8630 m at 6.46 s (ws = 10; estimate 0.8484), within 2 %; the test
    asks 5 %. ws = 4 stays below 0.5 m; ws = 10 cannot (its acceleration load
    alone bends the beam by 1.0 m), and the linear beam reaches 2.3e4 m by
    9 s (``test_deflection_warning.py``). Held at ws, the tip settles near 0.
    """
    text = (HERE / "spinup_beam.mbd").read_text().replace("stiffening off", "stiffening on")
    text = text.replace("t^2/2 + (Ts/(2*pi))^2*(cos(2*pi*t/Ts) - 1)",
                        "min(t, Ts)^2/2 + (Ts/(2*pi))^2*(cos(2*pi*min(t, Ts)/Ts) - 1)"
                        " + Ts*max(t - Ts, 0)")
    model = mbdsl.load_text(text, overrides={"ws": ws})
    sol = mbdsl.simulate(model, t_end=20.0)
    assert sol.status == "completed"
    beam = next(b for b in model.bodies if hasattr(b, "mesh"))
    tip = sol.q[:, beam.elastic_columns()[beam.mesh.names.index("v8")]]
    k = int(np.argmax(np.abs(tip)))
    t, Ts = sol.t[k], 15.0
    alpha = ws / Ts * (1.0 - math.cos(2 * math.pi * t / Ts))
    Omega = ws / Ts * (t - Ts / (2 * math.pi) * math.sin(2 * math.pi * t / Ts))
    w0sq = 3.516 ** 2 * EI / (RHOA * LENGTH ** 4)
    estimate = (11 * RHOA * alpha * LENGTH ** 5 / (120 * EI)) * w0sq / (w0sq + 0.1933 * Omega ** 2)
    assert abs(tip[k]) == pytest.approx(estimate, rel=0.05)
    assert tip[k] < 0                                   # it lags the spin-up
    if ws == 4.0:
        assert abs(tip[k]) < 0.5
    assert np.max(np.abs(tip[sol.t > 17.0])) < 0.02     # held: back near the axis
    assert sol.run_warnings() == []
    assert sol.column("hub.omega")[-1] == pytest.approx(ws, rel=1e-6)


def test_stiffening_is_a_beam_option():
    from mbdsl.errors import MbdModelError
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text("""model m
flexible_beam b { mass 1; length 1; E 1e9; area 1e-4; second_moment 1e-9; elements 2
                  stiffening maybe }
""")
    assert "E304" in [d.code for d in err.value.diagnostics]
    on = rotating_cantilever(1.0)
    off = rotating_cantilever(1.0, "off")
    assert next(b for b in on.bodies if hasattr(b, "mesh")).stiffening
    assert not next(b for b in off.bodies if hasattr(b, "mesh")).stiffening
