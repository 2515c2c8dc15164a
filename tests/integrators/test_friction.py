"""Coulomb friction in joints: a block on an incline, a spinning disk on a pin,
a pendulum with pin friction, Stribeck's static peak.

Oracles: the closed-form motion of a block sliding down an incline (constant
acceleration g (sin theta - mu cos theta)) and the creep speed of the
regularised law when it sticks, v_reg atanh(tan theta / mu); the disk's
closed-form spin-down under a constant pin friction torque and a viscous term;
DOP853 on the reduced one-coordinate ODE (Stribeck); the energy balance
E - E0 - work + dissipated = 0 of the exact motion; central differences of the
residual for the Newton matrix (``test_method_jacobians.py``, model
``tests/dsl/valid/friction_elements.mbd``).
"""

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.integrate

import mbdsl
from mbdsl.errors import MbdModelError

METHODS = list(mbdsl.METHODS)
SECOND_ORDER = [m for m in METHODS if m != "newmark"]
INCLINE = Path(__file__).parents[2] / "models" / "incline_friction.mbd"
G = 9.81
THETA = math.pi / 6


@pytest.mark.parametrize("method", METHODS)
def test_block_slides_down_the_incline(method):
    """mu = 0.3 < tan 30: s(1) = a/2, a = g (sin 30 - 0.3 cos 30) = 2.3563 m/s^2.

    The Coulomb start (``initial.coulomb_start``) gives a_0 = a: the Newmark
    formulas and NSTIFF are then exact on this constant acceleration (1e-15 to
    1e-13), NSTIFF-SI2 has its BDF1 start-up step (1.8e-6). Without it, a_0 =
    g sin 30 (no friction at v = 0 in the regularised law) cost the
    trapezoidal methods 1.08e-3.
    """
    model = mbdsl.load(INCLINE)
    sol = mbdsl.simulate(model, method=method, h=1e-3, t_end=1.0)
    a = G * (math.sin(THETA) - 0.3 * math.cos(THETA))
    assert abs(a - 2.3563) < 1e-4
    s = sol.column("output.s")[-1]
    assert abs(s - a / 2) < 1e-5 * (a / 2)
    # the normal reaction is m g cos 30 (index-3 multipliers: to 3e-9)
    assert abs(sol.column("lambda.P.0")[-1]) == pytest.approx(2 * G * math.cos(THETA), rel=1e-7)
    diss = sol.column("energy.dissipated")[-1]
    assert diss == pytest.approx(0.3 * 2 * G * math.cos(THETA) * a / 2, rel=1e-5)
    assert sol.stats_total.iterations / sol.stats_total.steps < 3.5


@pytest.mark.parametrize("method", METHODS)
def test_block_sticks_on_the_incline_above_tan_theta(method):
    """mu = 0.7 > tan 30: the block holds, creeping at the regularised law's
    speed v_reg atanh(tan 30 / 0.7) = 1.171 v_reg: < 2 v_reg x 1 s, < 1e-3 m."""
    model = mbdsl.load(INCLINE, overrides={"mu": 0.7})
    sol = mbdsl.simulate(model, method=method, h=1e-3, t_end=1.0)
    v_reg = 1e-4
    s = sol.column("output.s")[-1]
    assert 0.0 < s < min(2 * v_reg * 1.0, 1e-3)
    creep = v_reg * math.atanh(math.tan(THETA) / 0.7)
    assert s == pytest.approx(creep * 1.0, rel=0.02)
    # it starts stuck (Coulomb start: a_0 = 0 along the incline), no slip transient
    assert np.max(np.abs(sol.column("block.vx"))) < 2 * v_reg


DISK = """model disk
gravity (0, -9.81)
body w { mass 3; inertia 0.06 }
joint O: revolute(ground.origin, w.cm)
force f: friction(O, mu = 0.2, radius = 0.02, viscous = 0.01)
initial w.phi = 0
initial w.omega = 5
"""


@pytest.mark.parametrize("method", METHODS)
def test_disk_spins_down_on_a_pin_with_friction(method):
    """J w' = -(mu r m g + c w): w = (w0 + b/c) exp(-c t/J) - b/c until it stops
    at t = J/c ln((w0 + b/c)/(b/c)) = 2.12 s; the pin's reaction is m g."""
    model = mbdsl.load_text(DISK)
    sol = mbdsl.simulate(model, method=method, h=1e-3, t_end=3.0)
    b, c, J, w0 = 0.2 * 0.02 * 3 * G, 0.01, 0.06, 5.0
    t, w = sol.t, sol.column("w.omega")
    i = int(np.searchsorted(t, 1.0))
    exact = (w0 + b / c) * math.exp(-c * t[i] / J) - b / c
    assert abs(w[i] - exact) < (1e-4 if method == "newmark" else 1e-6)   # 2e-9 HHT, 2.7e-7 BDF2
    stop = J / c * math.log((w0 + b / c) / (b / c))
    assert np.max(np.abs(w[t > stop + 0.05])) < 1e-6          # stopped, and stays
    # what the disk lost went into the pin: 1/2 J w0^2 dissipated, balance closed
    assert sol.column("energy.dissipated")[-1] == pytest.approx(
        0.5 * J * w0 ** 2, rel=1e-4 if method == "newmark" else 1e-6)


PENDULUM = """model pendulum_pin_friction
gravity (0, -9.81)
body rod { mass 1; inertia 1/48; point O (-0.25, 0) }
joint O: revolute(ground.origin, rod.O)
force f: friction(O, mu = 0.3, radius = 0.02, v_reg = 1e-2)
initial rod.phi = 0
initial rod.omega = 0
"""


@pytest.mark.parametrize("method", METHODS)
def test_energy_balance_with_friction_falls_at_the_methods_order(method):
    """A pendulum released horizontal with pin friction (its reaction changes
    with the swing): max |energy.balance| below 1e-3 of the largest |E| at
    h = 1e-3 and falling as h^2. NEWMARK (gamma = 0.6) is first order and its
    numerical damping is what the balance measures: 2.6 % at h = 1e-3, falling
    as h. HHT-ADD's friction reads its
    multiplier psi_II, which converges to lambda at order 1 only (``hht_add``):
    there the balance falls at order 1 (0.80-0.91 measured)."""
    model = mbdsl.load_text(PENDULUM)
    bal, top = [], []
    for h in (1e-3, 5e-4):
        sol = mbdsl.simulate(model, method=method, h=h, t_end=1.0)
        bal.append(np.max(np.abs(sol.column("energy.balance"))))
        top.append(np.max(np.abs(sol.column("energy.total"))))
    assert bal[0] < (5e-2 if method == "newmark" else 1e-3) * top[0]
    order = math.log2(bal[0] / bal[1])
    expected = 1.0 if method in ("newmark", "hht-add") else 2.0
    lo = 0.75 if method == "hht-add" else expected - 0.1
    assert lo < order < expected + 0.1, order


def test_pendulum_with_pin_friction_against_the_index1_reference():
    """The same pendulum against DOP853 on the index-1 equations (whose
    multipliers, and so the friction, come from the same fixed point):
    second-order methods within 3e-4 rad at h = 1e-3 (measured 4.3e-5 to
    1.9e-4; without the friction the rod is 0.108 rad further on)."""
    from mbdsl.studies.index1 import index1_reference
    model = mbdsl.load_text(PENDULUM)
    ref = index1_reference(mbdsl.assemble(model), np.array([1.0]), rtol=1e-11, atol=1e-11)
    for method in SECOND_ORDER:
        sol = mbdsl.simulate(model, method=method, h=1e-3, t_end=1.0)
        err = abs(sol.q[-1, 2] - ref.q[-1, 2])
        assert err < 3e-4, (method, err)


STRIBECK = """model stribeck
gravity (0, -9.81)
body block { mass 1; inertia 0.01 }
joint P: prismatic(block.cm, ground.origin, direction = (1, 0))
force f: friction(P, mu = 0.2, mu_static = 0.4, v_stribeck = 0.1, viscous = 0.5, v_reg = 1e-4)
force push: force(block.cm, (F, 0))
initial block.x = 0
initial block.vx = V0
"""


@pytest.mark.parametrize("method", ["hht-i3", "nstiff-si2", "genalpha"])
def test_stribeck_static_peak_holds_and_the_slide_follows_the_law(method):
    """At rest under F = 3 N, between mu N = 1.96 N and mu_static N = 3.92 N,
    the block holds (the static peak); released at 0.5 m/s with no push it
    follows m v' = -N mu(v) tanh(v/v_reg) - c v, integrated by DOP853."""
    held = mbdsl.load_text(STRIBECK.replace("F, 0", "3, 0").replace("V0", "0"))
    sol = mbdsl.simulate(held, method=method, h=1e-3, t_end=1.0)
    assert abs(sol.column("block.x")[-1]) < 2e-4
    unpeaked = mbdsl.load_text(STRIBECK.replace("F, 0", "3, 0").replace("V0", "0")
                               .replace("mu_static = 0.4, v_stribeck = 0.1, ", ""))
    sol = mbdsl.simulate(unpeaked, method=method, h=1e-3, t_end=1.0)
    assert sol.column("block.x")[-1] > 0.3                 # without the peak it slides

    slide = mbdsl.load_text(STRIBECK.replace("F, 0", "0, 0").replace("V0", "0.5"))
    sol = mbdsl.simulate(slide, method=method, h=1e-4, t_end=0.1)
    N = G

    def rhs(t, y):
        v = y[0]
        mu = 0.2 + 0.2 * math.exp(-(v / 0.1) ** 2)
        return [-N * mu * math.tanh(v / 1e-4) - 0.5 * v]
    ref = scipy.integrate.solve_ivp(rhs, (0.0, 0.1), [0.5], method="DOP853",
                                    rtol=1e-12, atol=1e-12)
    assert abs(sol.column("block.vx")[-1] - ref.y[0, -1]) < 1e-6


@pytest.mark.parametrize("text,code,where", [
    ("force f: friction(W, mu = 0.3)", "E305", (7, 19)),
    ("force f: friction(P, mu = -0.3)", "E303", (7, 22)),
    ("force f: friction(O, mu = 0.1)", "E304", (7, 10)),
    ("force f: friction(P, mu = 0.1, radius = 0.01)", "E304", (7, 32)),
    ("force f: friction(P, mu = 0.1, mu_static = 0.2)", "E304", (7, 32)),
    ("force f: friction(P, mu = 0.1, v_reg = 0)", "E303", (7, 32)),
    ("force f: friction(P)", "E304", (7, 10)),
    ("force f: friction(P, mu = 0.1, rate = 2)", "E304", (7, 32)),
])
def test_friction_misuse_is_reported_with_its_place(text, code, where):
    base = """model m
body a { mass 1; inertia 0.1 }
body b { mass 1; inertia 0.1 }
joint O: revolute(ground.origin, a.cm)
joint P: prismatic(b.cm, ground.origin, direction = (1, 0))
joint W: fixed(a.cm, b.cm)
"""
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(base + text + "\n")
    d = [d for d in err.value.diagnostics if d.code == code]
    assert d, [x.code for x in err.value.diagnostics]
    assert (d[0].span.line, d[0].span.column) == where


@pytest.mark.parametrize("method", METHODS)
def test_energy_balance_on_the_incline(method):
    """E - E0 - work + dissipated on the sliding block: its acceleration is
    constant, which the Newmark-type formulas and NSTIFF (its start-up step
    trapezoidal in q) integrate exactly (balance at round-off, 1e-13 to
    7e-11 J of 6 J); NSTIFF-SI2's BDF1 start-up step leaves 1.7e-5 J at
    h = 1e-3, falling as h^2."""
    model = mbdsl.load(INCLINE)
    worst = []
    for h in (1e-3, 5e-4):
        sol = mbdsl.simulate(model, method=method, h=h, t_end=1.0)
        worst.append(np.max(np.abs(sol.column("energy.balance"))))
        top = np.max(np.abs(sol.column("energy.total")))
        assert top > 5.9
        assert worst[-1] < (1e-5 if method == "nstiff-si2" else 1e-10) * top
    if method == "nstiff-si2":
        assert 3.5 < worst[0] / worst[1] < 4.5, worst


def test_the_summary_says_why_a_model_runs_on_the_numpy_engine(monkeypatch):
    from ..conftest import MODELS
    # every element of the language has a kernel: one without, as a new one would be
    from mbdsl.integrators import engine
    monkeypatch.setattr(engine, "_unsupported_elements",
                        lambda system: "no kernel for a NewGroup")
    sol = mbdsl.simulate(mbdsl.load(MODELS / "slider_crank.mbd"), h=1e-3, t_end=0.003)
    assert sol.engine == "numpy"
    assert "not compiled: no kernel for a NewGroup" in sol.summary()
