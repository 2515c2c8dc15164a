"""mbdsl.modes against frequencies derived here independently: minimal-
coordinate linearizations of pendulums written by hand, Euler-Bernoulli's
cantilever, and the methods' amplification against closed forms and a run."""

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

import mbdsl
from mbdsl.cli.main import main
from mbdsl.integrators.spectral import bdf2_amplification, spectrum
from mbdsl.modes import modes

ROOT = Path(__file__).resolve().parents[2]
G = 9.81

TWO_RODS = """model two_rods
parameter L = 1.0;  parameter m = 1.0
gravity (0, -9.81)
body link1 {{ mass m; inertia m*L^2/12; point O (-L/2, 0); point E (L/2, 0) }}
body link2 {{ mass m; inertia m*L^2/12; point E (-L/2, 0); point tip (L/2, 0) }}
joint O: revolute(ground.origin, link1.O)
joint E: revolute(link1.E, link2.E)
{elbow}
initial link1.phi = -1.4;  initial link2.phi = -1.7
"""


def _two_rods(k=0.0, m=1.0, L=1.0):
    """Frequencies [rad/s] of two uniform rods hanging from a pin, angles
    theta_1, theta_2 from the vertical, elbow spring k [N m/rad]: kinetic
    energy 1/2 (4/3 m L^2 th1'^2 + m L^2 th1' th2' + 1/3 m L^2 th2'^2), potential
    -m g L (3/2 cos th1 + 1/2 cos th2) + k (th2 - th1)^2 / 2, linearized."""
    M = m * L * L * np.array([[4 / 3, 1 / 2], [1 / 2, 1 / 3]])
    K = m * G * L * np.array([[3 / 2, 0], [0, 1 / 2]]) + k * np.array([[1, -1], [-1, 1]])
    return np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True))


def test_a_hanging_rod_swings_at_sqrt_3g_over_2l():
    """The uniform rod pinned at its end: omega^2 = m g (L/2) / (m L^2/3) =
    3 g / (2 L) hanging (static), times cos(30 deg) at the shipped model's
    30 degrees (the initial state: gravity's stiffness there)."""
    model = mbdsl.load(ROOT / "models" / "pendulum.mbd")
    static = modes(model, at="static")
    assert static.dof == 1 and len(static.modes) == 1
    assert static.modes[0].omega == pytest.approx(np.sqrt(1.5 * G), rel=1e-9)
    assert static.modes[0].damping_ratio == 0.0
    initial = modes(model)
    assert initial.modes[0].omega == pytest.approx(np.sqrt(1.5 * G * np.cos(np.pi / 6)),
                                                   rel=1e-9)


@pytest.mark.parametrize("k", [0.0, 1e3, 1e7])
def test_two_hanging_rods_match_their_minimal_coordinates(k):
    """Both frequencies of the double pendulum (and of the stiff one: the elbow
    spring k) at the static equilibrium, from mbdsl's 6 coordinates and 4
    constraints against the 2 x 2 linearization in the joint angles."""
    elbow = f"force elbow: rotational_spring_damper(E, k = {k}, c = 0, angle = 0)" if k else ""
    found = modes(mbdsl.load_text(TWO_RODS.format(elbow=elbow)), at="static")
    assert found.dof == 2
    np.testing.assert_allclose([mo.omega for mo in found.modes], _two_rods(k), rtol=1e-8)
    if k == 1e7:                     # the elbow mode: both links, in opposition
        top = found.modes[-1]
        assert {name for name, _ in found.moving_bodies(top)} == {"link1", "link2"}
        assert sum(share for _, share in found.moving_bodies(top, 0.0)) == pytest.approx(1.0)


def test_the_cantilever_beam_has_euler_bernoulli_frequencies():
    """models/spinup_beam.mbd at rest: the hub is held by its driver, so the
    beam is a 10 m cantilever (EI = 14000 N m^2, rho A = 1.2 kg/m); its first
    three frequencies (beta L)^2 sqrt(EI/(rho A L^4)), beta L = 1.8751,
    4.6941, 7.8548, within the 8-element mesh's error (measured 0.01 %,
    0.02 %, 0.07 %)."""
    found = modes(mbdsl.load(ROOT / "models" / "spinup_beam.mbd"), k=3)
    scale = np.sqrt(14000.0 / (1.2 * 10.0 ** 4))
    exact = np.array([1.8751, 4.6941, 7.8548]) ** 2 * scale
    np.testing.assert_allclose([mo.omega for mo in found.modes], exact, rtol=2e-3)
    assert found.moving_bodies(found.modes[0])[0][0] == "beam"


def test_the_sparse_solver_agrees_with_the_dense_one_on_a_chain():
    """A 40-link pendulum chain hanging: the ten lowest frequencies by ARPACK
    on the constrained pencil equal the dense null-space ones to 1e-8."""
    text = (ROOT / "models" / "pendulum_chain.mbd").read_text()
    text = text.replace("initial link[i].phi = 0 ", "initial link[i].phi = -1.5")
    model = mbdsl.load_text(text, overrides={"N": 40})
    dense = modes(model, at="static", k=10, sparse=False)
    sparse = modes(model, at="static", k=10, sparse=True)
    assert sparse.solver == "sparse" and dense.solver == "dense"
    np.testing.assert_allclose([mo.omega for mo in sparse.modes],
                               [mo.omega for mo in dense.modes], rtol=1e-8)


def _newmark_family_roots(W, beta, gamma, left, right):
    """Roots of the characteristic polynomial of a Newmark-family method on
    x'' = -omega^2 x, derived from its difference equations with x_n = X r^n:
    the Newmark formulas give X (r - 1)^2 = B [(1 - gamma) + gamma r + ((1/2 -
    beta) + beta r)(r - 1)] for the acceleration B they integrate, and the
    method's equation of motion ties B to X by left(r) B = -W^2 right(r) X, so

        left(r) (r - 1)^2 + W^2 right(r) [(1 - gamma) + gamma r + ((1/2 - beta) + beta r)(r - 1)] = 0.

    HHT: left = r, right = (1 + alpha) r - alpha; generalized-alpha: left =
    (1 - alpha_m) r + alpha_m, right = (1 - alpha_f) r + alpha_f. (``left``,
    ``right``: coefficient pairs (of r, of 1).)"""
    P = np.polynomial.polynomial
    quad = P.polyadd([1 - gamma, gamma], P.polymul([0.5 - beta, beta], [-1, 1]))
    lhs = P.polymul(left[::-1], P.polymul([-1, 1], [-1, 1]))
    rhs = P.polymul(right[::-1], quad) * W * W
    return P.polyroots(P.polyadd(lhs, rhs))


@pytest.mark.parametrize("name, coefficients", [("hht-i3", {"alpha": -0.05}),
                                                ("hht-i3", {"alpha": -0.3}),
                                                ("genalpha", {"rho_inf": 0.5}),
                                                ("genalpha", {"rho_inf": 0.9})])
def test_the_damping_curves_are_those_of_the_closed_form(name, coefficients):
    """HHT (alpha = -0.05, -0.3) and generalized-alpha (rho_inf = 0.5, 0.9): the
    spectral radius from the amplification matrix equals the largest root of
    the characteristic polynomial written from the difference equations
    (``_newmark_family_roots``) to 1e-10 at omega h = 0.01 .. 50, and tends to
    (1 + alpha)/(1 - alpha) (Hilber, Hughes & Taylor 1977) or rho_inf (Chung
    & Hulbert 1993) as omega h -> infinity. At omega h = 1e7 the roots are
    compared to 1e-6 (they approach a multiple root, computed to about
    sqrt(eps)); generalized-alpha's radius is still 1.5e-5 above rho_inf
    there, as the polynomial's own roots are (its approach goes as
    (omega h)^-2/3)."""
    method = mbdsl.make_method(name, **coefficients)
    p = method.parameters()
    if name == "hht-i3":
        a = p["alpha"]
        left, right, limit = (1.0, 0.0), (1 + a, -a), (1 + a) / (1 - a)
    else:
        left, right = (1 - p["alpha_m"], p["alpha_m"]), (1 - p["alpha_f"], p["alpha_f"])
        limit = coefficients["rho_inf"]
    for W in (0.01, 0.5, 2.0, 50.0):
        roots = _newmark_family_roots(W, p["beta"], p["gamma"], left, right)
        assert spectrum(method.amplification(W), W).rho == \
            pytest.approx(np.max(np.abs(roots)), rel=1e-10)
    far = spectrum(method.amplification(1e7), 1e7).rho
    roots = _newmark_family_roots(1e7, p["beta"], p["gamma"], left, right)
    assert far == pytest.approx(np.max(np.abs(roots)), rel=1e-6)
    assert far == pytest.approx(limit, abs=2e-5)     # genalpha: 1.5e-5 off at 1e7 (~W^-2/3)
    trapezoid = mbdsl.make_method("newmark", beta=0.25, gamma=0.5)
    for W in (0.1, 1.0, 10.0, 1e4):
        assert spectrum(trapezoid.amplification(W), W).rho == pytest.approx(1.0, abs=1e-12)


def test_bdf2_roots_are_those_of_its_characteristic_polynomial():
    """BDF2 on y' = z y / h: (1 - 2/3 z) r^2 - 4/3 r + 1/3 = 0; the oscillator's
    roots are those for z = +-i omega h."""
    for W in (0.05, 1.0, 20.0):
        ours = np.sort_complex(np.linalg.eigvals(bdf2_amplification(W)))
        roots = np.concatenate([np.roots([1 - 2 / 3 * z, -4 / 3, 1 / 3]) for z in (1j * W, -1j * W)])
        np.testing.assert_allclose(ours, np.sort_complex(roots), atol=1e-12)


@pytest.mark.parametrize("method, coefficients", [("hht-i3", {"alpha": -0.3}),
                                                  ("genalpha", {"rho_inf": 0.5}),
                                                  ("nstiff", {})])
def test_a_run_damps_a_mode_as_the_amplification_says(method, coefficients):
    """A particle on a spring (omega = 10 rad/s) run at omega h = 1 for 60
    steps: the decay of its energy per step and its period equal the principal
    root's |lambda| and Omegabar to 1 % (after the spurious roots died out)."""
    text = """model oscillator
particle p { mass 1 }
force s: spring_damper(ground.origin, p.cm, k = 100, c = 0, length = 0)
initial p.x = 0.1;  initial p.y = 0;  initial p.vx = 0;  initial p.vy = 0
"""
    h, n = 0.1, 60
    sol = mbdsl.simulate(mbdsl.load_text(text), method, h, n * h, **coefficients)
    x, v = sol.column("p.x"), sol.column("p.vx")
    energy = 0.5 * v ** 2 + 0.5 * 100 * x ** 2
    sp = spectrum(mbdsl.make_method(method, **coefficients).amplification(1.0), 1.0)
    lam = np.exp(-sp.damping_ratio * (1.0 + sp.period_error) ** -1)  # |lambda| = exp(-xi Omegabar)
    z = x[20:] + 1j * v[20:] / 10                                     # phase from (x, v/omega)
    decay = np.exp(np.polyfit(np.arange(len(z)), np.log(energy[20:]), 1)[0] / 2)
    assert decay == pytest.approx(lam, rel=1e-2)
    turns = np.unwrap(np.angle(z))
    omega_bar = abs(np.polyfit(np.arange(len(z)), turns, 1)[0])
    assert omega_bar == pytest.approx(1.0 / (1.0 + sp.period_error), rel=1e-2)


def test_the_modes_command_prints_frequencies_and_the_methods_damping(capsys):
    code = main(["modes", str(ROOT / "models" / "double_pendulum_stiff.mbd"), "--set",
                 "k=1e5"])
    out = capsys.readouterr().out
    assert code == 0
    assert "2 degrees of freedom" in out and "hht-i3(alpha=-0.3" in out
    assert main(["modes", str(ROOT / "models" / "pendulum.mbd"), "--at", "nothing"]) == 2


def test_a_hanging_chain_has_the_frequencies_of_bernoullis_chain():
    """200 links of 0.1 m hanging: the lowest frequencies approach those of
    the continuous hanging chain of length l = 20 m, omega_k = (j_0,k / 2)
    sqrt(g / l), j_0,k the zeros of the Bessel function J_0 (D. Bernoulli
    1733; Rayleigh, The Theory of Sound, sec. 150); the discrete chain within
    0.2 % for the first five (measured 8e-5 % .. 0.06 %)."""
    import scipy.special
    text = (ROOT / "models" / "pendulum_chain.mbd").read_text()
    text = text.replace("initial link[i].phi = 0 ", "initial link[i].phi = -1.5")
    found = modes(mbdsl.load_text(text, overrides={"N": 200}), at="static", k=5, sparse=True)
    exact = scipy.special.jn_zeros(0, 5) / 2 * np.sqrt(G / 20.0)
    np.testing.assert_allclose([mo.omega for mo in found.modes], exact, rtol=2e-3)


SPRUNG_RODS = """model sprung_rods   # two rods held hanging by two horizontal springs at their free lengths
ground { point A (1, -1); point B (1, -2) }
body link1 { mass 1; inertia 1/12; point O (-0.5, 0); point E (0.5, 0) }
body link2 { mass 1.5; inertia 0.2; point E (-0.5, 0); point tip (0.5, 0) }
joint O: revolute(ground.origin, link1.O)
joint E: revolute(link1.E, link2.E)
force s2: spring_damper(ground.A, link1.E, k = 40, c = 0, length = 1)
force s3: spring_damper(ground.B, link2.tip, k = 70, c = 0, length = 1)
initial link1.phi = -pi/2;  initial link2.phi = -pi/2
"""


def test_exudyn_finds_the_same_frequencies():
    """Exudyn's ComputeODE2Eigenvalues (null space of its constraint
    Jacobian) on the same rods translated element by element
    (benchmarks/exudyn_side.py): equal to 1e-6 (measured 6e-16). The model
    is one whose joints carry no load at the equilibrium: Exudyn 1.13.6
    leaves out the constraint forces' geometric stiffness (a hanging
    pendulum has no frequency there), which the pendulum tests above show
    belongs in. Runs with the ``bench`` extra (Exudyn installed)."""
    pytest.importorskip("exudyn")
    import sys
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import exudyn
    import exudyn_side
    model = mbdsl.load_text(SPRUNG_RODS)
    ours = modes(model, at="static")
    _, mbs, _ = exudyn_side._build(model, ours.q, np.zeros_like(ours.q))
    settings = exudyn.SimulationSettings()
    settings.solutionSettings.writeSolutionToFile = False   # no solution file in the cwd
    w2 = np.real(mbs.ComputeODE2Eigenvalues(settings, useAbsoluteValues=False)[0])
    theirs = np.sqrt(np.sort(w2[np.abs(w2) > 1e-8]))
    np.testing.assert_allclose([mo.omega for mo in ours.modes], theirs, rtol=1e-6)


def test_the_recommendation_is_read_against_the_modes():
    """``study recommend``'s second table on the stiff double pendulum: at the
    recommended h = 5e-4 s genalpha does not follow the elbow mode (k = 1e7
    N m/rad, the 2 x 2 linearization's upper frequency at the released,
    horizontal state where gravity adds no stiffness: 1864 Hz), and the steps
    it takes to remove 99 % of that mode's energy are those of its
    amplification matrix at omega h."""
    from mbdsl.studies.recommend import _recommend_modes
    from mbdsl.studies.tables import Table
    model = mbdsl.load(ROOT / "models" / "double_pendulum_stiff.mbd")
    table = Table("recommend", "", ["target", "method", "h [s]"], [[1e-5, "genalpha", 5e-4]])
    out = _recommend_modes(table, model, mbdsl.assemble(model))
    row = out.rows[0]
    M = np.array([[4 / 3, 1 / 2], [1 / 2, 1 / 3]])          # about the pin, rods horizontal
    K = 1e7 * np.array([[1, -1], [-1, 1]])
    elbow = np.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True)[-1])
    assert row[5] == pytest.approx(elbow / (2 * np.pi), rel=1e-8)
    W = elbow * 5e-4
    assert row[6] == pytest.approx(W, rel=1e-8)
    method = mbdsl.make_method("genalpha", rho_inf=0.9)
    assert row[7] == pytest.approx(spectrum(method.amplification(W), W).steps_to_damp, rel=1e-9)
    assert "1864 Hz" in out.notes[0] and "the spring elbow" in out.notes[0]
    assert row[8].startswith("spring elbow")
    from mbdsl.studies.recommend import _modes_at_model_step
    at_h = _modes_at_model_step(model, mbdsl.assemble(model), ["hht-i3", "nstiff"])
    (mode, f, W, what, hht, bdf2), = at_h.rows          # the model's h = 1e-3 s, alpha = -0.3
    assert mode == 2 and W == pytest.approx(elbow * 1e-3, rel=1e-8)
    assert hht == pytest.approx(spectrum(mbdsl.make_method("hht-i3", alpha=-0.3)
                                         .amplification(W), W).steps_to_damp, rel=1e-9)
    assert bdf2 < hht                                   # BDF2 damps it faster
    assert "the mode that limits h" in at_h.notes[1]


def test_a_spinning_cantilever_has_southwells_frequency():
    """The spin-up beam's cantilever driven at Omega = 4 rad/s from the start
    (tests/flexible/test_stiffening.py): its modes about the spinning
    initial state (a moving state: M's change with q under the centripetal
    acceleration, the gyroscopic damping matrix) give the first in-plane
    frequency in the rotating frame, 4.1636 rad/s, within 1 % of Southwell's
    sqrt(omega_0^2 + 0.1933 Omega^2) = 4.185 (and 0.005 % from the 4.1638 the
    time-domain run measures); zero damping (no damper)."""
    from tests.flexible.test_stiffening import rotating_cantilever
    found = modes(rotating_cantilever(4.0), k=1)
    w0 = 1.8751 ** 2 * np.sqrt(14000.0 / (1.2 * 10.0 ** 4))
    assert found.modes[0].omega == pytest.approx(np.sqrt(w0 ** 2 + 0.1933 * 16.0), rel=1e-2)
    assert abs(found.modes[0].damping_ratio) < 1e-10
    assert any("moving state" in n for n in found.notes)


def test_the_slider_crank_at_rest_matches_its_one_degree_of_freedom_equation():
    """models/slider_crank.mbd about its static equilibrium against the
    reduced equation m(theta) theta'' + c(theta) theta' + V'(theta) = 0 in the
    crank angle, written here from the geometry (A = L1 (cos, sin) theta, B on
    the x axis with |B - A| = L2, to the right of A; the spring from the
    origin to B of free length 0), linearized by central differences:
    omega^2 = V''/m, zeta = c/(2 sqrt(V'' m)), to 1e-6."""
    import scipy.optimize
    L1, m1, L2, m2, k, c = 0.3, 3.0, 0.6, 0.9, 100.0, 5.0
    I1, I2 = m1 * L1 ** 2 / 12, m2 * L2 ** 2 / 12

    def geometry(th):
        A = L1 * np.array([np.cos(th), np.sin(th)])
        xB = A[0] + np.sqrt(L2 ** 2 - A[1] ** 2)
        B = np.array([xB, 0.0])
        return A / 2, (A + B) / 2, np.arctan2(B[1] - A[1], B[0] - A[0]), xB

    def V(th):
        c1, c2, _, xB = geometry(th)
        return G * (m1 * c1[1] + m2 * c2[1]) + 0.5 * k * xB ** 2

    def d(f, th, e=1e-5):
        return (np.asarray(f(th + e)) - np.asarray(f(th - e))) / (2 * e)

    th = scipy.optimize.brentq(lambda x: d(V, x), 3 * np.pi / 2 - 1.2, 3 * np.pi / 2,
                               xtol=1e-14)
    dc1, dc2 = d(lambda x: geometry(x)[0], th), d(lambda x: geometry(x)[1], th)
    dphi, dxB = d(lambda x: geometry(x)[2], th), d(lambda x: geometry(x)[3], th)
    mass = m1 * dc1 @ dc1 + I1 + m2 * dc2 @ dc2 + I2 * dphi ** 2
    stiffness = (V(th + 1e-4) - 2 * V(th) + V(th - 1e-4)) / 1e-8
    damping = c * dxB ** 2
    found = modes(mbdsl.load(ROOT / "models" / "slider_crank.mbd"), at="static")
    assert found.dof == 1
    crank = found.q[found.names.index("crank.phi")]
    assert crank == pytest.approx(th, abs=1e-8)
    mo = found.modes[0]
    assert mo.omega == pytest.approx(np.sqrt(stiffness / mass), rel=1e-6)
    assert mo.damping_ratio == pytest.approx(damping / (2 * np.sqrt(stiffness * mass)), rel=1e-6)


def test_a_mode_names_the_spring_that_holds_its_strain_energy():
    """The stiff double pendulum's upper mode is its elbow's: the rotational
    spring 'elbow' holds all its strain energy (k dtheta^2/2 = omega^2 x^T M x/2
    with no other stiffness at the horizontal start); the suspension's mode
    is its spring's; the free swing (0 Hz) names none."""
    found = modes(mbdsl.load(ROOT / "models" / "double_pendulum_stiff.mbd"))
    assert found.modes[0].stiffened_by == []
    (name, share), = found.modes[1].stiffened_by
    assert name == "elbow" and share == pytest.approx(1.0, rel=1e-6)
    susp = modes(mbdsl.load(ROOT / "models" / "suspension.mbd"), at="static")
    assert susp.modes[0].stiffened_by[0][0] == "spring"


def test_the_modes_command_draws_the_methods_damping(tmp_path, capsys):
    """--plot: the figure of rho, xi_bar and the period error against omega h
    for the methods asked, with the modes marked; a method that does not
    exist is an error, not a traceback."""
    out = tmp_path / "damping.png"
    model = str(ROOT / "models" / "double_pendulum_stiff.mbd")
    assert main(["modes", model, "--plot", str(out), "--methods", "hht-i3,genalpha"]) == 0
    assert out.stat().st_size > 10_000
    assert main(["modes", model, "--plot", str(out), "--methods", "rk4"]) == 2
    assert "unknown method 'rk4'" in capsys.readouterr().err


def test_a_mode_the_step_neither_follows_nor_damps_is_warned_before_the_run():
    """W606: a 1e6 N/m spring on 1 kg (159 Hz) at h = 1e-2 s (omega h = 10)
    under the trapezoidal rule (Newmark 1/4, 1/2: rho = 1 at every omega h)
    is kept undamped for the whole run; HHT with alpha = -0.3 removes 99 % of
    it in 10 steps (its spectral radius 0.54 there): no warning; at h = 1e-4 s
    (omega h = 0.1) the trapezoidal rule follows it: none either."""
    model = mbdsl.load_text("""model trapezoid
body block { mass 1; inertia 0.1 }
joint G: prismatic(ground.origin, block.cm, direction = (1, 0))
force s: spring_damper(ground.origin, block.cm, k = 1e6, c = 0, length = 0)
initial block.x = 0.001;  initial block.vx = 0
simulate { method newmark; gamma 0.5; beta 0.25; h 1e-2; t_end 1 }
""")
    sol = mbdsl.simulate(model)
    (w,) = [d for d in sol.initial.warnings if d.code == "W606"]
    assert "159.2 Hz" in w.message and "the spring s" in w.message
    damped = mbdsl.simulate(model, "hht-i3", alpha=-0.3)
    assert not [d for d in damped.initial.warnings if d.code == "W606"]
    fine = mbdsl.simulate(model, h=1e-4, t_end=0.01)
    assert not [d for d in fine.initial.warnings if d.code == "W606"]
    assert spectrum(mbdsl.make_method("hht-i3", alpha=-0.3).amplification(10.0), 10.0) \
        .steps_to_damp < 100


@pytest.mark.parametrize("c, warned", [(20.0, True), (2000.0, False), (4e4, False)])
def test_a_mode_its_own_damper_removes_is_not_warned(c, warned):
    """The 159 Hz block of the test above with a damper: zeta = c / (2 sqrt(k m))
    = 0.01 keeps 99 % of its energy for 2 ln(10) / (zeta omega) = 0.46 s, more
    than the run's 0.2 s: warned; zeta = 1 (critical) and 20 (overdamped,
    the stiff flyball governor's kind) do not oscillate past the first steps,
    and the trapezoidal rule, A-stable, decays them: not warned."""
    model = mbdsl.load_text(f"""model trapezoid
body block {{ mass 1; inertia 0.1 }}
joint G: prismatic(ground.origin, block.cm, direction = (1, 0))
force s: spring_damper(ground.origin, block.cm, k = 1e6, c = {c}, length = 0)
initial block.x = 0.001;  initial block.vx = 0
simulate {{ method newmark; gamma 0.5; beta 0.25; h 1e-2; t_end 0.2 }}
""")
    sol = mbdsl.simulate(model)
    assert bool([d for d in sol.initial.warnings if d.code == "W606"]) == warned


def test_a_mode_is_animated_as_its_shape_moving(tmp_path, capsys):
    """--animate: the elbow mode's shape moving, one period a second; the
    frames keep the joints closed (each taken back onto Phi = 0) and the
    elbow angle swings by the shape's ratio of the two links' angles."""
    from mbdsl.modes import mode_motion
    model = mbdsl.load(ROOT / "models" / "double_pendulum_stiff.mbd")
    system = mbdsl.assemble(model)
    found = modes(system)
    motion = mode_motion(system, found, 2)
    assert np.max(motion.column("constraint.position")) < 1e-10
    x = found.modes[1].shape
    i1, i2 = found.names.index("link1.phi"), found.names.index("link2.phi")
    swing1 = np.ptp(motion.column("link1.phi"))
    swing2 = np.ptp(motion.column("link2.phi"))
    assert swing2 / swing1 == pytest.approx(abs(x[i2] / x[i1]), rel=0.05)
    out = tmp_path / "elbow.gif"
    assert main(["modes", str(ROOT / "models" / "double_pendulum_stiff.mbd"),
                 "--animate", str(out)]) == 0
    assert out.stat().st_size > 1000 and "mode 2, 1864 Hz" in capsys.readouterr().out


def test_the_sparse_solver_finds_the_highest_modes_too():
    """The five highest frequencies of the 40-link hanging chain by ARPACK on
    the projected M^-1 K equal the dense ones to 1e-9."""
    text = (ROOT / "models" / "pendulum_chain.mbd").read_text()
    text = text.replace("initial link[i].phi = 0 ", "initial link[i].phi = -1.5")
    model = mbdsl.load_text(text, overrides={"N": 40})
    dense = modes(model, at="static", k=5, highest=True, sparse=False)
    sparse = modes(model, at="static", k=5, highest=True, sparse=True)
    np.testing.assert_allclose([mo.omega for mo in sparse.modes],
                               [mo.omega for mo in dense.modes], rtol=1e-9)


def test_the_static_equilibrium_of_a_large_model_is_found_by_sparse_newton(monkeypatch):
    """Above STATIC_DENSE_LIMIT unknowns the static Newton matrix is sparse
    (SuperLU): on a 100-link chain released near hanging it reaches the dense
    Newton's equilibrium to 1e-12 m."""
    import mbdsl.assembly.initial as initial
    text = (ROOT / "models" / "pendulum_chain.mbd").read_text()
    text = text.replace("initial link[i].phi = 0 ", "initial link[i].phi = -1.5")
    system = mbdsl.assemble(mbdsl.load_text(text, overrides={"N": 100}))
    init = mbdsl.consistent_initial_state(system)
    assert system.n + system.m > initial.STATIC_DENSE_LIMIT
    sparse = initial.static_positions(system, 0.0, init.q, init.lam, hold_initials=False)
    monkeypatch.setattr(initial, "STATIC_DENSE_LIMIT", 10 ** 9)
    dense = initial.static_positions(system, 0.0, init.q, init.lam, hold_initials=False)
    np.testing.assert_allclose(sparse, dense, atol=1e-12)
