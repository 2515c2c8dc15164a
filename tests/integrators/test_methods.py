"""The six integrators of Negrut, Jay & Khude: order, start-up, conditioning, statistics.

Shared definitions: suite.py. Split in three files so that CI runs them in parallel.
"""

import numpy as np
import pytest

import mbdsl
from mbdsl.assembly.initial import consistent_initial_state
from mbdsl.integrators import make_method
from mbdsl.studies.index1 import index1_reference

from ..conftest import MODELS
from .suite import HS, INDEX2, METHODS, ORDER, eps_energy, fitted_slope, slider_crank  # noqa: F401


def test_methods_are_the_papers_six_and_generalized_alpha():
    assert set(mbdsl.METHODS) == set(ORDER)
    for name, cls in mbdsl.METHODS.items():
        m = make_method(name)
        assert m.name == name and m.order() == ORDER[name]
        assert m.index == (2 if name in INDEX2 else 3)


@pytest.mark.parametrize("method", METHODS)
def test_order_on_the_slider_crank(method, slider_crank, slider_crank_reference):
    ref = slider_crank_reference["cases"]["damped_x0_zero"]
    err_phi, err_omega = [], []
    for h in HS:
        sol = mbdsl.simulate(slider_crank, method=method, h=h, t_end=2.0)
        assert sol.t[-1] == 2.0
        err_phi.append(sol.column("crank.phi")[-1] - ref["theta1_T"])
        err_omega.append(sol.column("crank.omega")[-1] - ref["omega1_T"])
    for errors in (err_phi, err_omega):
        assert abs(fitted_slope(HS, errors) - ORDER[method]) <= 0.15, (method, errors)


@pytest.mark.parametrize("method", ["nstiff", "nstiff-si2", "hht-i3", "hht-si2", "genalpha",
                                    "genalpha-si2"])
def test_order_from_the_first_step(method, slider_crank):
    """Two-step methods start with one BDF1 step; order 2 must hold over a few steps."""
    system = mbdsl.assemble(slider_crank)
    ref = index1_reference(system, [0.05])
    assert ref.drift < 1e-10
    hs = [0.05 / 2**k for k in range(3, 8)]            # 8 ... 128 steps
    errors = []
    for h in hs:
        sol = mbdsl.simulate(slider_crank, method=method, h=h, t_end=0.05)
        errors.append(np.max(np.abs(sol.q[-1] - ref.q[-1])) + np.max(np.abs(sol.v[-1] - ref.v[-1])))
    assert abs(fitted_slope(hs, errors) - 2) <= 0.2, errors


@pytest.mark.parametrize("method", METHODS)
def test_newton_matrix_well_conditioned_as_h_shrinks(method, slider_crank):
    system = mbdsl.assemble(slider_crank)
    init = consistent_initial_state(system)
    m = make_method(method)
    conds = []
    for h in (1e-2, 1e-3, 1e-5, 1e-7):
        history = m.start(system, init)
        ctx = m.context(system, history, init.t + h, h)
        conds.append(np.linalg.cond(m.jacobian(m.predict(ctx), ctx)))
    assert max(conds) < 100 * conds[0], conds


@pytest.mark.parametrize("method", METHODS)
def test_small_steps_converge_in_few_iterations(method, slider_crank):
    sol = mbdsl.simulate(slider_crank, method=method, h=1e-6, t_end=2e-4)
    assert sol.stats["iterations"][1:].max() <= 3


@pytest.mark.parametrize("method", METHODS)
def test_newton_statistics_are_counted(method, slider_crank):
    sol = mbdsl.simulate(slider_crank, method=method, h=1e-3, t_end=0.2)
    tot = sol.stats_total
    assert tot.steps == 200 and tot.iterations == sol.stats["iterations"].sum()
    assert 1 <= tot.factorizations <= tot.iterations and tot.residuals >= tot.iterations
    # budget: modified Newton on this smooth problem
    assert tot.iterations / tot.steps < 8


@pytest.mark.parametrize("method", METHODS)
def test_failure_keeps_every_accepted_step(method):
    from .test_newton import BLOW_UP
    sol = mbdsl.simulate(mbdsl.load_text(BLOW_UP, "lock.mbd"), method=method, h=1e-2, t_end=5,
                         on_failure="return")
    assert sol.status == "failed"
    assert 3.5 < sol.t[-1] < np.arcsin(2 / 3) / 0.2 and np.all(np.diff(sol.t) > 0)
    assert method in sol.message and "t = 3.6" in sol.message


def test_coefficients_are_validated_with_reasons():
    with pytest.raises(ValueError, match=r"gamma = 0.4 is out of range: gamma >= 1/2"):
        make_method("newmark", gamma=0.4)
    with pytest.raises(ValueError, match=r"beta = 0.25 is out of range: beta >= \(gamma \+ 1/2\)\^2 / 4"):
        make_method("newmark", gamma=0.6, beta=0.25)
    with pytest.raises(ValueError, match=r"b = 0.5 is out of range: b != 1/2"):
        make_method("hht-add", b=0.5)
    for name in ("hht-i3", "hht-si2", "hht-add"):
        with pytest.raises(ValueError, match=r"alpha = 0.1 is out of range: \[-1/3, 0\]"):
            make_method(name, alpha=0.1)
    with pytest.raises(ValueError, match="takes no parameter alpha"):
        make_method("nstiff", alpha=-0.1)
    for name in ("genalpha", "genalpha-si2"):
        with pytest.raises(ValueError, match=r"rho_inf = 1.2 is out of range: \[0, 1\]"):
            make_method(name, rho_inf=1.2)
    m = make_method("hht-i3", alpha=-0.3)
    assert m.gamma == pytest.approx(0.8) and m.beta == pytest.approx(1.3**2 / 4)


def test_index2_methods_write_mu_and_every_method_reactions(slider_crank):
    for method in METHODS:
        sol = mbdsl.simulate(slider_crank, method=method, h=1e-3, t_end=0.05)
        cols = sol.columns
        assert ("mu.O.0" in cols) == (method in ("nstiff-si2", "hht-si2", "genalpha-si2"))
        assert {"reaction.O.fx", "reaction.B.fy", "reaction.A.torque", "lambda.B.0"} <= set(cols)
        assert np.max(np.abs(sol.column("reaction.A.torque"))) < 1e-9   # revolute: no couple


def test_reaction_of_a_swinging_pendulum():
    """Reaction on the rod at its pin = m (a_cm - g)."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "pendulum.mbd"), method="nstiff", h=1e-3, t_end=1.0)
    a = np.gradient(sol.v, sol.t, axis=0)[5:-5, :2]
    F = np.stack([sol.column("reaction.O.fx"), sol.column("reaction.O.fy")], axis=1)[5:-5]
    assert np.max(np.abs(F - 1.0 * (a - np.array([0.0, -9.81])))) < 1e-3 * 9.81


def test_the_registry_is_the_methods_own():
    # the leaf registry (names, coefficients, defaults) that the checks, the CLI
    # and the studies read agrees with the method classes' constructors
    import inspect

    from mbdsl.integrators import METHODS
    from mbdsl.registry import METHOD_COEFFICIENTS, METHOD_NAMES
    assert tuple(METHODS) == METHOD_NAMES
    for name, cls in METHODS.items():
        params = {p.name: p.default for p in inspect.signature(cls.__init__).parameters.values()
                  if p.name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}
        assert params == METHOD_COEFFICIENTS[name], name
        assert cls.name == name
