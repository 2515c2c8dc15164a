"""The Newton engine on algebraic problems, and failures that keep their data."""

import numpy as np
import pytest

import mbdsl
from mbdsl.cli.main import main
from mbdsl.integrators.newton import (ROUNDOFF_BAND, JacobianUpdate, Newton, NewtonOptions,
                                      NewtonStatus)
from mbdsl.io.csvfile import read_csv_metadata

from ..conftest import MODELS


def _solve(F, J, w0, **opts):
    n = len(w0)
    return Newton(NewtonOptions(**opts)).solve(F, J, np.array(w0, float), np.zeros(n, bool),
                                               np.ones(n))


def test_full_newton_converges_quadratically():
    F = lambda w: np.array([w[0] ** 2 - 2.0, w[0] * w[1] - 1.0])
    J = lambda w: np.array([[2 * w[0], 0.0], [w[1], w[0]]])
    res = _solve(F, J, [1.0, 1.0], jacobian="full", rtol=1e-14, atol_kinematic=1e-14)
    assert res.converged
    assert res.w == pytest.approx([np.sqrt(2), 1 / np.sqrt(2)], abs=1e-14)
    n = res.norms
    # quadratic: each norm about the square of the previous one (in units of the tolerance)
    ratios = [np.log(n[i + 1] * 1e-14) / np.log(n[i] * 1e-14) for i in range(1, len(n) - 2)]
    assert all(r > 1.8 for r in ratios), (n, ratios)


def test_modified_newton_reuses_its_factorization():
    F = lambda w: np.array([w[0] ** 3 + w[0] - 3.0])
    J = lambda w: np.array([[3 * w[0] ** 2 + 1.0]])
    res = _solve(F, J, [1.1], jacobian="modified", rtol=1e-12, atol_kinematic=1e-12,
                 max_iter=40)
    assert res.converged and res.n_factor == 1 and res.n_iter > 2
    assert abs(res.w[0] ** 3 + res.w[0] - 3.0) < 1e-10


def test_the_stall_ratio_follows_a_rate_refresh_above_one_half():
    """A linear system A w = b with a Newton matrix A / 0.4: each modified
    Newton correction is exactly 0.6 times the last (the error goes as
    (I - 0.4 I)^k). The stall rule (a correction at least 1/2 the last)
    renews such a matrix at every iteration; with rate_refresh 0.8, the
    class of a matrix that costs about ten iterations, 0.6 is contraction
    enough and the one matrix is kept until the iteration reaches the
    round-off band (ROUNDOFF_BAND tolerances), where the slow contraction
    asks for exact Newton whatever the class (module docstring)."""
    A = np.array([[4.0, 1.0], [1.0, 3.0]])
    b = np.array([1.0, 2.0])
    exact = np.linalg.solve(A, b)

    def run(rate):
        calls, at = [], []            # residuals evaluated; their count at each new matrix

        def F(w):
            calls.append(1)
            return A @ w - b

        def J(w):
            at.append(len(calls))
            return A / 0.4

        res = _solve(F, J, [0.0, 0.0], jacobian="modified", rtol=1e-10, atol_kinematic=1e-10,
                     max_iter=80, rate_refresh=rate)
        assert res.converged and res.w == pytest.approx(exact, abs=1e-6)
        # the matrices renewed outside the round-off band (after correction k - 1)
        return res, [k for k in at if k == 0 or res.norms[k - 1] > ROUNDOFF_BAND]

    kept, renewals = run(0.8)
    assert renewals == [0]
    ratios = np.array(kept.norms[1:8]) / np.array(kept.norms[:7])
    assert ratios == pytest.approx(0.6, rel=1e-6)
    renewed, renewals = run(0.3)
    # the stall rule needs two corrections; from the second on, a new matrix after each
    assert len(renewals) > 5 and renewals == [0] + list(range(2, len(renewals) + 1))


def test_divergence_and_singularity_are_detected():
    F = lambda w: np.array([np.arctan(w[0])])          # Newton diverges from |w0| > 1.39
    J = lambda w: np.array([[1.0 / (1.0 + w[0] ** 2)]])
    res = _solve(F, J, [3.0], jacobian="full")
    assert res.status in (NewtonStatus.DIVERGING, NewtonStatus.NONFINITE, NewtonStatus.MAX_ITER)
    assert not res.converged
    res = _solve(lambda w: np.array([1.0, 1.0]), lambda w: np.ones((2, 2)), [0.0, 0.0])
    assert res.status is NewtonStatus.SINGULAR


def test_options_are_validated():
    with pytest.raises(ValueError, match="rtol"):
        NewtonOptions(rtol=-1)
    with pytest.raises(ValueError):
        NewtonOptions(jacobian="sometimes")
    with pytest.raises(ValueError, match="alpha = -0.5 is out of range"):
        mbdsl.simulate(mbdsl.load(MODELS / "pendulum.mbd"), alpha=-0.5)


BLOW_UP = """model locking_slider_crank   # rod shorter than crank: B leaves the x axis
gravity (0, -9.81)
body crank { mass 1; inertia 0.3^2/12; point O (-0.15, 0); point A (0.15, 0) }
body rod   { mass 1; inertia 0.2^2/12; point A (-0.1, 0); point B (0.1, 0) }
joint O: revolute(ground.origin, crank.O)
joint A: revolute(crank.A, rod.A)
joint B: point_on_line(rod.B, ground.origin, direction = (1, 0))
# the loop closes only while 0.3 sin(phi) <= 0.2, i.e. up to t = asin(2/3)/0.2 = 3.65 s
driver motor: crank.phi = 0.2*t
guess rod.phi = -0.1
"""


def test_failed_run_keeps_every_accepted_step(tmp_path, capsys):
    path = tmp_path / "blow_up.mbd"
    path.write_text(BLOW_UP)
    out = tmp_path / "out.csv"
    status = main(["simulate", str(path), "--h", "1e-2", "--t-end", "5", "-o", str(out)])
    err = capsys.readouterr().err
    assert status == 3
    assert "error[E601]" in err and "hht-i3" in err and "t = 3.6" in err
    assert "Traceback" not in err
    meta, names, values = read_csv_metadata(out)
    assert meta["status"] == "failed"
    t = values[:, names.index("t")]
    assert 3.5 < t[-1] < np.arcsin(2 / 3) / 0.2 and np.all(np.diff(t) > 0)

    sol = mbdsl.simulate(mbdsl.load(path), h=1e-2, t_end=5, on_failure="return")
    assert sol.status == "failed" and len(sol.t) == len(t)
    with pytest.raises(mbdsl.ConvergenceError) as info:
        mbdsl.simulate(mbdsl.load(path), h=1e-2, t_end=5)
    assert info.value.solution is not None and info.value.diagnostics[0].code == "E601"


def test_step_halving_recovers_and_grows_back():
    # modified Newton with one iteration allowed cannot take the nominal step
    # near t = 0 where the motion starts; halving lets it through.
    model = mbdsl.load(MODELS / "pendulum.mbd")
    sol = mbdsl.simulate(model, h=0.05, t_end=1.0, newton=NewtonOptions(max_iter=2, jacobian="full"),
                         on_failure="return")
    hs = sol.stats["h"][1:]
    assert sol.status == "completed"
    assert sol.stats_total.rejected > 0 and hs.min() < 0.05
    assert np.isclose(hs[-5:], 0.05).any() or np.isclose(sol.t[-1], 1.0)


def _ulp_flipping_saddle():
    """w = (x, lambda), rows (dynamics, constraint): x - c lambda - f = 0 and
    c x - d = 0 with c = 1e-4, the constraint's residual carrying a
    round-off of 1e-13 that flips sign at every evaluation (as Phi flips
    between +-1 ulp on the light cart-pole near its singular position).
    J^-1 amplifies it by 1/c^2 into lambda (= 1): updates of 1e-5 that no
    iteration reduces."""
    c, f, d, delta = 1e-4, 2.0 - 1e-4, 2e-4, 1e-13
    calls = []

    def F(w):
        calls.append(1)
        return np.array([w[0] - c * w[1] - f, c * w[0] - d + delta * (-1) ** len(calls)])

    def J(w):
        return np.array([[1.0, -c], [c, 0.0]])
    return F, J, np.array([d / c, (d / c - f) / c])


def test_a_stall_at_the_constraints_round_off_is_converged():
    """The update's norm stays far above the round-off band (the constraint
    row's round-off through J^-1), so the update alone cannot tell it from
    divergence; the residual can: the constraint row is at round-off
    (``at_roundoff``) and the update the dynamic row alone asks for meets the
    tolerance. Without the residual test, or with a constraint that is not
    met, the same iteration fails."""
    F, J, exact = _ulp_flipping_saddle()
    kinds, scales = np.array([False, True]), np.array([1.0, 1e3])

    def solve(at_roundoff):
        return Newton(NewtonOptions(jacobian="full")).solve(
            F, J, exact + [1e-3, 0.0], kinds, scales, at_roundoff=at_roundoff)
    plain = solve(None)
    assert not plain.converged and min(plain.norms) > ROUNDOFF_BAND, plain.norms
    assert not solve(lambda w: False).converged
    res = solve(lambda w: abs(1e-4 * w[0] - 2e-4) < 1e-12)
    assert res.converged and res.multipliers_stalled
    # the constraint met to its round-off (x within delta / c), lambda to what that leaves
    assert abs(1e-4 * res.w[0] - 2e-4) <= 2e-13
    assert res.w[1] == pytest.approx(exact[1], rel=1e-4)


def test_modified_newton_stops_where_its_estimate_is_within_kappa():
    """A linear system A w = b with a Newton matrix A / (1 - theta): the
    error goes as theta^k exactly, the k-th update is (1 - theta) times the
    error before it, and the observed rate is theta, so the estimate eta
    ||dw_k|| (eta = theta / (1 - theta)) is the true error of iterate k. At
    theta = 0.05 from an error of 1.6 / theta^4 tolerances, iterate 5's
    error is 0.08 tolerances, within KAPPA = 0.1, its update 1.52: the
    iteration stops there. Where the update itself must be within the
    tolerance (velocity-level rows: ``velocity_rows``), one iteration more;
    the same from an error a fifth larger, whose iterate 5 (0.4) is within
    the tolerance but not within KAPPA of it."""
    from mbdsl.integrators.newton import KAPPA
    theta, tol = 0.05, 1e-6
    A = np.array([[3.0, 1.0], [1.0, 2.0]])
    exact = np.array([0.25, -0.5])
    b = A @ exact
    F = lambda w: A @ w - b
    J = lambda w: A / (1.0 - theta)

    def solve(e0, velocity_rows=False):
        return Newton(NewtonOptions(jacobian="modified", rtol=1e-14, atol_kinematic=tol,
                                    rate_refresh=0.9)).solve(
            F, J, exact + [e0, 0.0], np.zeros(2, bool), np.ones(2), velocity_rows=velocity_rows)
    e0 = 1.6 * tol / theta ** 4
    assert theta ** 5 * e0 / tol <= KAPPA < theta ** 4 * e0 / tol
    res = solve(e0)
    assert res.converged and res.n_iter == 5 and res.n_factor == 1
    assert res.norms[-1] == pytest.approx((1 - theta) * 1.6, rel=1e-6)     # not within it
    assert np.max(np.abs(res.w - exact)) == pytest.approx(0.08 * tol, rel=1e-6)
    held = solve(e0, velocity_rows=True)
    assert held.converged and held.n_iter == 6 and held.norms[-1] <= 1.0
    later = solve(5.0 * tol / theta ** 4)
    assert later.converged and later.n_iter == 6


def test_the_kernels_copies_of_newtons_constants_are_newtons():
    """newton.py's constants are written again in ``kernels.schema`` and
    ``integrators.compiled.newton`` (importing the kernels' modules from
    newton.py would load numba with ``import mbdsl``); the copies must agree,
    the frame test's hold below the bound it protects."""
    from mbdsl.integrators import newton
    from mbdsl.integrators.compiled import newton as compiled_newton
    from mbdsl.kernels import schema
    assert schema.ROUNDOFF_BAND == newton.ROUNDOFF_BAND
    assert schema.FRAME_TOL == newton.FRAME_TOL
    assert schema.FRAME_HOLD == newton.FRAME_HOLD < newton.FRAME_TOL
    assert compiled_newton.ROUNDOFF_ULPS == newton.ROUNDOFF_ULPS
    assert compiled_newton.KAPPA == newton.KAPPA < 1.0
