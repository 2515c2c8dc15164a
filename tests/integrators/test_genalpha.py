"""Generalized-alpha (GENALPHA, GENALPHA-SI2): what rho_inf means, and what
the generalized-alpha formulas must give beyond the orders and Newton
matrices the method suite checks for every method (test_methods*.py,
test_method_jacobians.py, test_hard_cases.py, the flexible slider crank).

Oracles: Chung & Hulbert's spectral analysis (the spectral radius of one
step of an undamped oscillator tends to rho_inf as omega h -> infinity and
to 1 as omega h -> 0); HHT as the member alpha_m = 0 (identical on rigid
models, whose M is constant); the velocity constraints themselves; an
unbroken run against one resumed from its carried state.
"""

import numpy as np
import pytest

import mbdsl
from mbdsl.assembly.initial import InitialState, consistent_initial_state
from mbdsl.integrators import integrate, make_method
from mbdsl.integrators.genalpha import genalpha_coefficients

from ..conftest import MODELS

#: A disc pinned at its centre with a torsional spring: I phi'' = -k phi, exactly linear.
OSCILLATOR = """model oscillator
parameter k = 1
body disc { mass 1; inertia 1; point c (0, 0) }
joint O: revolute(ground.origin, disc.c)
force spring: rotational_spring_damper(O, k = k, c = 0, angle = 0)
initial disc.phi = 0.1
initial disc.omega = 0
"""


def test_chung_hulbert_coefficients():
    # rho_inf = 1: the trapezoidal rule (alpha_m = alpha_f = 1/2, gamma = 1/2, beta = 1/4)
    assert genalpha_coefficients(1.0)[1:] == pytest.approx((0.5, 0.5, 0.25, 0.5))
    # rho_inf = 0: asymptotic annihilation, alpha_m = -1, alpha_f = 0, gamma = 3/2, beta = 1
    assert genalpha_coefficients(0.0)[1:] == pytest.approx((-1.0, 0.0, 1.0, 1.5))
    # rho_inf = 1/2 has alpha_m = 0: HHT with alpha = -alpha_f = -1/3 (its beta, gamma)
    rho, am, af, beta, gamma = genalpha_coefficients(0.5)
    hht = make_method("hht-i3", alpha=-1.0 / 3.0)
    assert am == pytest.approx(0.0, abs=1e-15) and af == pytest.approx(1.0 / 3.0)
    assert (beta, gamma) == pytest.approx((hht.beta, hht.gamma))


def _amplification(method, omega_h):
    """The one-step map of (phi, omega, qdd, aux) of the undamped oscillator
    with omega h = omega_h (h = 1 s), built column by column from unit states."""
    system = mbdsl.assemble(mbdsl.load_text(OSCILLATOR, overrides={"k": omega_h ** 2}))
    j = system.layout.coordinates.index("disc.phi")
    A = np.zeros((4, 4))
    for col in range(4):
        x = np.zeros(4)
        x[col] = 1.0
        q, v, a, aux = (np.zeros(system.n) for _ in range(4))
        q[j], v[j], a[j], aux[j] = x
        init = InitialState(0.0, q, v, a, np.zeros(system.m), 0.0, 0.0, 0.0,
                            method_state={"aux": aux})
        sol = integrate(system, method, 1.0, 1.0, initial=init, engine="numpy")
        s = sol.last_state
        A[:, col] = (s.q[j], s.v[j], s.a[j], s.extra["aux"][j])
    return A


@pytest.mark.parametrize("name", ["genalpha", "genalpha-si2"])
@pytest.mark.parametrize("rho_inf", [0.0, 0.5, 0.9, 1.0])
def test_rho_inf_is_the_spectral_radius_at_infinity(name, rho_inf):
    method = make_method(name, rho_inf=rho_inf)
    high = max(abs(np.linalg.eigvals(_amplification(method, 1e5))))
    assert high == pytest.approx(rho_inf, abs=1e-3)
    # resolved motion is kept: at omega h = 0.05 (125 steps per period) the
    # spectral radius is 1 - O((omega h)^4) (Chung & Hulbert 1993, sec. 4)
    low = max(abs(np.linalg.eigvals(_amplification(method, 0.05))))
    assert 1.0 - 1e-4 < low <= 1.0 + 1e-12


def test_alpha_m_zero_is_hht_on_rigid_models():
    """rho_inf = 1/2 gives alpha_m = 0: on a rigid model (M constant) the
    recursion M a_{n+1} = (1 - alpha_f) M qdd_{n+1} + alpha_f M qdd_n is
    HHT's averaged force; the two runs agree to the Newton tolerance."""
    model = mbdsl.load(MODELS / "slider_crank.mbd")
    ga = mbdsl.simulate(model, method="genalpha", h=1e-3, t_end=1.0, rho_inf=0.5)
    hht = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=1.0, alpha=-1.0 / 3.0)
    assert np.max(np.abs(ga.q[-1] - hht.q[-1])) < 1e-8
    assert np.max(np.abs(ga.v[-1] - hht.v[-1])) < 1e-6
    # and a different rho_inf is a different method
    other = mbdsl.simulate(model, method="genalpha", h=1e-3, t_end=1.0, rho_inf=0.8)
    assert np.max(np.abs(other.q[-1] - hht.q[-1])) > 1e-6


def test_genalpha_si2_velocity_constraints_at_roundoff():
    """Slider crank, 10 s at h = 2^-10: Phi_q v + Phi_t at round-off (the
    index-3 GENALPHA leaves it O(h^2))."""
    model = mbdsl.load(MODELS / "slider_crank.mbd")
    si2 = mbdsl.simulate(model, method="genalpha-si2", h=2.0 ** -10, t_end=10.0)
    assert si2.completed
    assert np.max(si2.column("constraint.velocity")) < 1e-10
    assert np.max(si2.column("constraint.position")) < 1e-10
    i3 = mbdsl.simulate(model, method="genalpha", h=2.0 ** -10, t_end=10.0)
    assert np.max(i3.column("constraint.velocity")) > 1e-7


@pytest.mark.parametrize("name", ["genalpha", "genalpha-si2"])
def test_a_run_resumed_from_its_carried_state_is_the_same_run(name):
    """The auxiliary acceleration is state: stopping at t = 0.5 s and going on
    from the last state (q, v, qdd, lambda and aux) gives the unbroken run,
    which is what a step handed between the engines relies on."""
    system = mbdsl.assemble(mbdsl.load(MODELS / "double_pendulum.mbd"))
    init = consistent_initial_state(system)
    m = make_method(name, rho_inf=0.6)
    whole = integrate(system, m, 1.0, 1e-3, initial=init, engine="numpy")
    first = integrate(system, m, 0.5, 1e-3, initial=init, engine="numpy")
    s = first.last_state
    resumed = InitialState(s.t, s.q, s.v, s.a, s.lam, 0.0, 0.0, 0.0,
                           method_state={"aux": s.extra["aux"]})
    second = integrate(system, m, 1.0, 1e-3, t_start=0.5, initial=resumed, engine="numpy")
    # the same to the Newton tolerance (the resumed run starts with a fresh
    # Newton matrix): measured 1.2e-11 rad (genalpha), 8e-13 rad (genalpha-si2)
    assert np.max(np.abs(second.q[-1] - whole.q[-1])) < 1e-10
    # restarted from aux = qdd instead, the run differs by 8.9e-7 rad
    restarted = InitialState(s.t, s.q, s.v, s.a, s.lam, 0.0, 0.0, 0.0)
    other = integrate(system, m, 1.0, 1e-3, t_start=0.5, initial=restarted, engine="numpy")
    assert np.max(np.abs(other.q[-1] - whole.q[-1])) > 1e-7


def test_compiled_engine_converges_to_dop853_over_a_long_run():
    """The double pendulum over 2 s (rho_inf = 0.7): q(2 s) on the compiled
    engine against DOP853 on the index-1 equations, of order 2 between h = 1
    and 0.5 ms (measured ratios 4.00, 4.00; errors 3.2e-5, 2.7e-5)."""
    from .suite import dop853_error_ratios
    system = mbdsl.assemble(mbdsl.load(MODELS / "double_pendulum.mbd"))
    init = consistent_initial_state(system)
    runs = dop853_error_ratios(system, init, [make_method(name, rho_inf=0.7)
                                              for name in ("genalpha", "genalpha-si2")], 2.0)
    for name, (errors, ratios) in runs.items():
        assert 3.6 < ratios[0] < 4.4 and errors[-1] < 1e-4, (name, errors)


def elbow_energy(sol):
    k = sol.model.parameters["k"]
    return 0.5 * k * (sol.column("link2.phi") - sol.column("link1.phi")) ** 2


@pytest.mark.parametrize("name,hht", [("genalpha", "hht-i3"), ("genalpha-si2", "hht-si2")])
def test_stiff_pendulum_mode_removed_and_resolved_energy_kept(name, hht):
    """The stiff double pendulum with 5 J in its unresolved elbow mode
    (k = 1e7, omega h of order 10): at rho_inf = 0.5 the mode is gone within a
    few steps (elbow energy below 1 % for good by 0.05 s; measured 0.007 s,
    as HHT at alpha = -1/3) and the resolved swing loses what HHT at the
    same rho_inf loses between 0.1 s and 2 s (measured 1.59e-4 J for the
    index-3 pair, 1.16e-4 J for the SI2 pair, against a kinetic energy of 19.6 J)."""
    model = mbdsl.load(MODELS / "double_pendulum_stiff.mbd", overrides={"elbow0": 1e-3})
    ga = mbdsl.simulate(model, method=name, h=1e-3, t_end=2.0, rho_inf=0.5)
    ref = mbdsl.simulate(model, method=hht, h=1e-3, t_end=2.0, alpha=-1.0 / 3.0)
    for sol in (ga, ref):
        assert sol.completed and sol.stats_total.rejected == 0
        e = elbow_energy(sol)
        assert e[0] == pytest.approx(5.0)
        assert np.max(e[sol.t >= 0.05]) < 0.01 * e[0]

    def resolved_loss(sol):
        E = sol.column("energy.total")
        return E[np.searchsorted(sol.t, 0.1)] - E[-1]
    assert 0 < resolved_loss(ga) < 1e-3 * np.max(ga.column("energy.kinetic"))
    assert resolved_loss(ga) == pytest.approx(resolved_loss(ref), rel=0.05)
