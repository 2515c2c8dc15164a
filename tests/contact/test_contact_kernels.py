"""Contacts and joint limits on the compiled engine.

The kernels' gaps, forces, energy, power and Newton-matrix entries against
the numpy oracle (``contact_oracle``, itself checked against finite
differences and the one-body impact in ``test_law_and_derivatives``) and
against central differences of the kernels' own residual; runs whose compiled loop returns at each event
for the driver to land a step on it, against the numpy engine's runs of the
same model (the same events at the same times) and the restitution the law
promises.
"""

from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.assembly.initial import InitialState
from mbdsl.assembly.system import assemble
from mbdsl.integrators import compiled, make_method
from mbdsl.integrators.engine import CompiledModel, SparseAdapter, unsupported

from ..assembly.force_oracle import ForceOracle
from ..integrators.test_engine import residual_differences, rigid_residual_in_kernel_rows
from .contact_oracle import ContactOracle
from .test_law_and_derivatives import MODEL

MODELS = Path(__file__).resolve().parents[2] / "models"
METHODS = ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
           "genalpha-si2"]
GAPS = ["line", "pin", "stop.lower", "stop.upper", "end.upper", "tie"]


@pytest.fixture(scope="module")
def system():
    # soft contacts: a random state penetrates them deeply, and the law's forces
    # stay of the order of the others, so that central differences are exact
    # to 1e-7 (all of the law's terms are there at any stiffness)
    soft = MODEL
    for k in ("1e6", "1e8", "1e4", "2e5", "3e3"):
        soft = soft.replace(f"k = {k}", "k = 50")
    return assemble(mbdsl.load_text(soft))


def _penetrating(system, name, armed, seed=5):
    """(q, v), shape (n,) each, consistent with the joints (random, then
    projected on Phi = 0 and Phi_q v = 0), with gap ``name`` penetrated and
    pushing; the group's impact speeds set as ``armed`` says."""
    g = system.contact_state
    i = g.names.index(name)
    g.reset()
    if armed:
        g.arm(i, 2.0, 0.0)
    rng = np.random.default_rng(seed)
    n = system.n
    for _ in range(20000):
        q = rng.normal(scale=0.4, size=n)
        for _ in range(20):
            q -= np.linalg.lstsq(system.Phi_q(q), system.Phi(q, 0.0), rcond=None)[0]
        v = rng.normal(scale=0.5, size=n)
        v -= np.linalg.lstsq(system.Phi_q(q), system.Phi_q(q) @ v, rcond=None)[0]
        qx, vx = system._ext(q), system._ext(v)
        if g.gaps_one(i, qx) < -1e-4 and ContactOracle(system).forces(qx, vx, 0.0)[i].any():
            assert np.abs(system.Phi(q, 0.0)).max() < 1e-12
            return q, v
    raise AssertionError(f"no configuration penetrates '{name}'")


def test_every_gap_geometry_has_a_kernel(system):
    assert unsupported(system, make_method("hht-i3")) is None


@pytest.mark.parametrize("armed", [True, False])
@pytest.mark.parametrize("name", GAPS)
def test_kernel_forces_are_the_oracle_s(system, name, armed):
    """Q(q, v) of the kernels (the contact's normal force along the gap's
    gradient, its damping and, on the two contacts, friction), in the time
    loops' ``force_term`` and from Python (``AssembledSystem.Q``), equals
    the numpy oracle's, and so do Q_q and Q_v; the impact speed is the
    kernels' contact state."""
    q, v = _penetrating(system, name, armed)
    g = system.contact_state
    cm = CompiledModel(system)
    cm.impact_speed[:] = g.impact_speed
    out = np.empty(system.n)
    compiled.force_term(cm.ints, cm.floats, 0.0, q, v, np.zeros(system.m), out,
                        np.zeros(system.nx), np.zeros(system.nx), np.zeros(system.nx))
    o = ForceOracle(system)
    Q = o.Q(0.0, q, v, np.zeros(system.m))
    assert np.abs(Q).max() > 1.0                  # the contact pushes
    np.testing.assert_allclose(-out, Q, rtol=0, atol=1e-12 * np.abs(Q).max())
    np.testing.assert_allclose(system.Q(0.0, q, v), Q, rtol=0, atol=1e-12 * np.abs(Q).max())
    for got, want in zip(system.force_derivatives(0.0, q, v), o.derivatives(0.0, q, v)):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("armed", [True, False])
@pytest.mark.parametrize("name", GAPS)
@pytest.mark.parametrize("method", METHODS)
def test_kernel_newton_matrix_with_a_closed_gap(system, method, name, armed):
    """Each method's kernel Newton matrix, with gap ``name`` penetrated (the
    law's Q_q and Q_v, friction's on the contacts), against central
    differences of the kernel residual, and that residual against the numpy
    method's (HHT-ADD: its rows 1, 2 and 5 times M)."""
    q, v = _penetrating(system, name, armed)
    m = make_method(method)
    a, lam = system.index1_state(0.0, q, v)
    s = m.start(system, InitialState(0.0, q, v, a, lam, 0.0, 0.0, 0.0))[-1]
    ad = SparseAdapter(system, m)
    ctx = ad.context(system, [s], s.t + 1e-3, 1e-3)
    rng = np.random.default_rng(3)
    w = m.predict(ctx) + 1e-4 * rng.standard_normal(ad.size)
    J = ad.jacobian(w, ctx).toarray()
    scale = np.abs(J).max()
    # a step of 1e-4: the round-off of the scaled rows is below its truncation error
    assert np.abs(J - residual_differences(ad, w, ctx, 1e-4)).max() < 1e-5 * scale
    ref = rigid_residual_in_kernel_rows(system, m, w, ctx)
    r = ad.residual(w, ctx)
    # round-off: the rows are sums of terms up to 1e3 times the residual near a solution
    assert np.allclose(r, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())


@pytest.mark.parametrize("method", ["hht-i3", "nstiff-si2", "hht-add"])
def test_clearance_joint_runs_compiled_as_on_the_numpy_engine(method):
    """The pin in its hole closes and opens twelve times in 0.05 s: the
    compiled loop returns at each for the driver to land a step on it. The
    same events as the numpy engine, the first three impacts at the same
    times to 1e-7 s (the steps are the same to round-off until an
    error-control choice parts them); then the impacts of this rattling pin
    drift apart (chaotic: by 3 ms at 0.05 s with HHT-ADD)."""
    model = mbdsl.load(MODELS / "slider_crank_clearance.mbd")
    a = mbdsl.simulate(model, method=method, t_end=0.05, engine="numpy")
    b = mbdsl.simulate(model, method=method, t_end=0.05, engine="compiled")
    assert a.engine == "numpy" and b.engine == "compiled" and b.completed
    assert len(a.events) >= 20 and abs(len(a.events) - len(b.events)) <= 2
    common = min(len(a.events), len(b.events))
    assert [e[1:3] for e in b.events[:common]] == [e[1:3] for e in a.events[:common]]
    ta, tb = (np.array([e[0] for e in s.events[:common]]) for s in (a, b))
    # the first three impacts at the same times; then the rattling pin's
    # round-off differences grow (HHT-ADD: 3e-7 s at the 4th impact, 3 ms
    # at 0.05 s), and one engine may see one impact more before t_end
    np.testing.assert_allclose(tb[:6], ta[:6], rtol=0, atol=1e-7)
    np.testing.assert_allclose(tb, ta, rtol=0, atol=5e-3)
    np.testing.assert_allclose([e[3] for e in b.events[:6]], [e[3] for e in a.events[:6]],
                               rtol=1e-4)
    np.testing.assert_allclose(b.q[-1], a.q[-1], rtol=0, atol=1e-3)
    assert b.event_cuts > 0


@pytest.mark.parametrize("method", ["hht-i3", "nstiff"])
def test_fixed_steps_with_contacts_run_compiled_as_on_the_numpy_engine(method, handed_over):
    """Fixed steps of 2 ms on the bouncing ball: Newton fails in the stiff
    contact and the step is halved, then doubled back after four steps;
    each impact is landed on and the step goes back to its size (BDF2
    restarting with BDF1). The compiled loop returns at each failed step,
    the driver's ``StepSizes`` halves it, and the compiled loop takes it
    and the steps at the reduced size until it grows back, none handed to
    the driver's loop: the numpy engine's steps, the same rows, rejected
    steps, events and states (a landing's end within the event tolerance,
    1e-6 h = 2e-9 s, of the other engine's)."""
    text = (MODELS / "bouncing_ball.mbd").read_text().replace("; tol 1e-6", "")
    a, b = (mbdsl.simulate(mbdsl.load_text(text), method=method, h=2e-3, t_end=1.5,
                           engine=engine) for engine in ("numpy", "compiled"))
    assert b.engine == "compiled" and b.control is None and b.completed
    assert a.stats_total.rejected > 0 and not handed_over            # halvings
    assert b.stats_total.rejected == a.stats_total.rejected
    assert b.stats_total.steps == a.stats_total.steps
    assert b.event_cuts == a.event_cuts > 0
    assert len(b.t) == len(a.t)
    np.testing.assert_allclose(b.t, a.t, rtol=0, atol=2e-9)
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-8)
    np.testing.assert_allclose([e[0] for e in b.events], [e[0] for e in a.events], rtol=0,
                               atol=1e-9)


def test_kernel_energy_and_dissipation_over_rows_are_the_oracle_s(system):
    """The output's potential energy and dissipated power per row, by the
    kernels (``AssembledSystem.potential_energy``, ``power``: each row with
    the impact speeds of the contact log at its time), equal the oracle's,
    over rows where every gap is penetrated somewhere, armed and not (speeds
    0)."""
    g = system.contact_state
    o = ForceOracle(system)
    rng = np.random.default_rng(9)
    N, n = 200, system.n
    q = rng.normal(scale=0.4, size=(N, n))
    v = rng.normal(scale=0.5, size=(N, n))
    t = np.arange(N, dtype=float)
    speeds = np.where(rng.random((N, len(g.names))) < 0.5, 0.0,
                      rng.uniform(0.1, 3.0, (N, len(g.names))))
    log = [(t[r], i, speeds[r, i]) for r in range(N) for i in range(len(g.names))]
    np.testing.assert_array_equal(g.speeds_at(t, log), speeds)
    contact = np.array([ContactOracle(system).energy(system._ext(row)) for row in q])
    assert np.count_nonzero(contact) > N // 2
    energy = np.array([o.potential(row) for row in q])
    np.testing.assert_allclose(system.potential_energy(q), energy, rtol=1e-12,
                               atol=1e-12 * np.abs(energy).max())
    assert system.potential_energy(q[3]) == pytest.approx(energy[3], rel=1e-12)
    lam = np.zeros((N, system.m))
    power = np.array([o.power(t[r], q[r], v[r], lam[r], speeds[r]) for r in range(N)])
    assert np.count_nonzero(power[:, 1]) > N // 2
    p_in, p_diss = system.power(t, q, v, lam, contact_log=log)
    np.testing.assert_allclose(p_in, power[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(p_diss, power[:, 1], rtol=1e-11,
                               atol=1e-12 * np.abs(power[:, 1]).max())


def test_hht_add_output_multipliers_take_each_row_s_impact_speeds():
    """HHT-ADD writes the index-1 multipliers at its rows; in a stop's
    contact the damping depends on the impact speed of that contact (the
    contact log), not on the one in force at the end of the run. The
    kernels' rows against the numpy index-1 solve, row by row, with each
    row's impact speeds."""
    model = mbdsl.load(MODELS / "pendulum_stop.mbd")
    sol = mbdsl.simulate(model, method="hht-add", t_end=1.0, engine="compiled")
    system, g = sol.system, sol.system.contact_state
    assert sol.engine == "compiled" and len(sol.events) >= 4
    speeds = g.speeds_at(sol.t, sol.contact_log)
    inside = np.flatnonzero(np.any(speeds > 0, axis=1))
    assert len(inside) > 20 and len(set(map(tuple, speeds[inside]))) >= 2
    kept = g.impact_speed.copy()
    try:
        for i in inside[::5]:
            g.impact_speed[:] = speeds[i]
            ref = system.index1_state(sol.t[i], sol.q[i], sol.v[i])[1]
            np.testing.assert_allclose(sol.lam[i], ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    finally:
        g.impact_speed[:] = kept
