"""The compiled engine's dense inverses of HHT-SI2's two diagonal blocks
(``integrators.compiled.dense``): checked against numpy's solve of the split Newton
matrix, against the band LU of the same split on whole runs (fixed steps, error
control, a failed step), and in its choice by "auto"."""

from __future__ import annotations

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators import NewtonOptions, integrate, make_method
from mbdsl.integrators import compiled as K
from mbdsl.integrators.adaptive import StepControl
from mbdsl.integrators.compiled.condensed import SHARE_TOL
from mbdsl.integrators.condensation import block_codes
from mbdsl.integrators.engine import CompiledModel, linear_solver_plan, newton_size
from mbdsl.integrators.records import LIN_CW
from mbdsl.integrators.solver_plans import dense_split_plan

from ..conftest import MODELS

VALID = MODELS.parent / "tests" / "dsl" / "valid"
SPLIT = ["hht-si2", "genalpha-si2"]


def _system(path, **overrides):
    system = mbdsl.assemble(mbdsl.load(path, overrides=overrides or None))
    return system, mbdsl.consistent_initial_state(system)


def _blocks(system, method, init, rng, h=1e-3):
    """(R, C, V, p, Jb): the kernels' Newton-matrix triplets at step size h [s] and
    the start's iterate
    (a_0, abar = 0, lambda_0, mu = 0), perturbed by ``rng`` where given (multipliers
    nonzero, so that every Hessian block is), and the whole Newton matrix in block
    order (``block_codes``: block 0 = (a, lambda) with the dynamics and velocity
    rows, block 1 = (abar, mu) with the abar and position rows)."""
    cm = CompiledModel(system)
    n, m = system.n, system.m
    size = newton_size(system, method)
    R, C, V = (np.empty(cm.bound, np.int64), np.empty(cm.bound, np.int64), np.empty(cm.bound))
    qx = np.zeros(n + 3)
    qx[:n] = init.q
    w = np.zeros(size) if rng is None else 0.1 * rng.standard_normal(size)
    w[:n] += init.a
    w[2 * n:2 * n + m] += init.lam
    p = cm.K.jacobian_triplets(method.kernel_recipe(h, False), cm.ints, cm.floats, 0.0,
                               np.asarray(init.q, float), np.asarray(init.v, float), np.zeros(n),
                               qx, w, R, C, V, np.zeros(n + 3), np.zeros(n + 3))
    J = np.zeros((size, size))
    np.add.at(J, (R[:p], C[:p]), V[:p])
    rows, cols = block_codes(size, n, m, True)
    Jb = np.zeros_like(J)
    Jb[np.ix_(rows, cols)] = J
    return R, C, V, p, Jb


def _split_solution(Jb, r, n, m, comp):
    """(x, shared): the split solve derived here in numpy, in the original order.
    Block 1 and the lower block L21 are replaced by multiples of block 0's parts,

        J1 -> [[cA A0, cC C0^T], [cB B0, 0]],    L21 -> [[0, 0], [cL B0, 0]]

    (least-squares scalars), where every coordinate group's parts (``comp``: each
    coordinate's group; its rows of A and C^T, its columns of B and L21) are
    within SHARE_TOL of them; then x1 = J0^-1 r1, x2 = J1^-1 (r2 - L21 x1): the
    upper block left out."""
    s = n + m
    size = 2 * s
    rows, cols = block_codes(size, n, m, True)
    J0, J1, L = Jb[:s, :s].copy(), Jb[s:, s:].copy(), Jb[s:, :s].copy()
    A0, C0, B0 = J0[:n, :n], J0[:n, n:], J0[n:, :n]
    A1, C1, B1, LA, LB = J1[:n, :n], J1[:n, n:], J1[n:, :n], L[:n, :n], L[n:, :n]
    cA, cC, cB, cL = (np.sum(x * y) / np.sum(y * y) for x, y in
                      ((A1, A0), (C1, C0), (B1, B0), (LB, B0)))
    shared = not (L[:, n:].any() or J0[n:, n:].any() or J1[n:, n:].any())
    for g in np.unique(comp):
        c = comp == g
        for d, x in ((np.sum((A1[c] - cA * A0[c]) ** 2) + np.sum(LA[c] ** 2), A1[c]),
                     (np.sum((C1[c] - cC * C0[c]) ** 2), C1[c]),
                     (np.sum((B1[:, c] - cB * B0[:, c]) ** 2), B1[:, c]),
                     (np.sum((LB[:, c] - cL * B0[:, c]) ** 2), LB[:, c])):
            shared = shared and d <= SHARE_TOL ** 2 * np.sum(x * x)
    if shared:
        J1 = np.block([[cA * A0, cC * C0], [cB * B0, np.zeros((m, m))]])
        L = np.block([[np.zeros((n, n)), np.zeros((n, m))], [cL * B0, np.zeros((m, m))]])
    b = np.empty(size)
    b[rows] = r
    x1 = np.linalg.solve(J0, b[:s])
    x2 = np.linalg.solve(J1, b[s:] - L @ x1)
    return np.concatenate([x1, x2])[cols], shared


@pytest.mark.parametrize("method", SPLIT)
@pytest.mark.parametrize("path, h, shared", [
    (MODELS / "spatial_slider_crank.mbd", 1e-3, True), (MODELS / "andrews.mbd", 1e-5, True),
    (MODELS / "spatial_double_pendulum.mbd", 1e-3, True), (MODELS / "slider_crank.mbd", 1e-3, True),
    (VALID / "compiled_elements.mbd", 1e-3, None), (MODELS / "motor_fourbar.mbd", 1e-3, None),
    (MODELS / "double_pendulum_stiff.mbd", 1e-3, False),
    (MODELS / "flexible_slider_crank.mbd", 1e-3, False)])
def test_the_split_dense_solve_is_numpys(path, h, shared, method):
    # the blocks' places, the lower block's product, the upper block left out: a
    # misplaced entry or a wrong sign gives another solution. Where block 1 is near a
    # multiple of block 0 (rigid models without stiff elements at their step size),
    # block 0's inverse solves both: the decision and the matrix it stands for derived
    # in numpy (``_split_solution``), at the start's iterate and a perturbed one. The
    # stiff double pendulum (a torsional spring of 1e7 N m/rad: h^2 K against the
    # mass) and the flexible slider crank (the beam's stiffness) keep block 1's own
    # inverse; Andrews' mechanism (its spring against grams of mass) shares at its
    # step of 1e-5 s
    system, init = _system(path)
    method = make_method(method)
    rng = np.random.default_rng(4)
    for perturb in (None, rng):
        R, C, V, p, Jb = _blocks(system, method, init, perturb, h)
        size = Jb.shape[0]
        plan = dense_split_plan(system, method, init.q)
        lin = plan.workspace(size, len(R))
        assert K._factor(K.DENSE_SPLIT, lin, R, C, V, p) == K.CONVERGED
        for _ in range(2):                          # the inverses are reused
            r = rng.standard_normal(size)
            dw = np.empty_like(r)
            K._solve(K.DENSE_SPLIT, lin, r, dw)
            x, decided = _split_solution(Jb, r, system.n, system.m, plan.groups[2:])
            assert bool(lin[LIN_CW][0]) == decided
            assert np.abs(dw - x).max() <= 1e-9 * np.abs(x).max()
        assert perturb is not None or shared is None or decided == shared


def test_a_singular_block_is_reported():
    # a zero constraint row in block 0: no inverse, the Newton status SINGULAR
    system, init = _system(MODELS / "spatial_slider_crank.mbd")
    method = make_method("hht-si2")
    R, C, V, p, _ = _blocks(system, method, init, np.random.default_rng(0))
    n = system.n
    V[:p][R[:p] == 2 * n + system.m] = 0.0          # block 0's first velocity row
    lin = dense_split_plan(system, method, init.q).workspace(newton_size(system, method), len(R))
    assert K._factor(K.DENSE_SPLIT, lin, R, C, V, p) == K.SINGULAR


def test_auto_takes_the_blocks_inverses_where_they_cost_less_than_the_band():
    # two inverses of s = n + m unknowns against the band LU of the split: the spatial
    # slider-crank (s = 71, kl = ku = 16), Andrews' mechanism (s = 41, 9); the planar
    # chain's blocks are condensed, coordinate by coordinate, below both (its band of 4
    # costs less than the inverses); "dense" as asked inverts the whole matrix
    for path, overrides, kind in [(MODELS / "spatial_slider_crank.mbd", {}, "dense"),
                                  (MODELS / "andrews.mbd", {}, "dense"),
                                  (MODELS / "pendulum_chain.mbd", {"N": 25}, "condensed")]:
        system, init = _system(path, **overrides)
        plan = linear_solver_plan(system, make_method("hht-si2"), NewtonOptions(), init.q)
        assert (plan.kind, plan.blocks) == (kind, 2), path.name
        whole = linear_solver_plan(system, make_method("hht-si2"),
                                   NewtonOptions(linear_solver="dense"), init.q)
        assert (whole.kind, whole.blocks) == ("dense", 1)


@pytest.mark.parametrize("method", SPLIT)
def test_split_dense_and_band_runs_agree(method):
    # the same split Newton matrix (block 1 shared or not) as the band LU's: the same
    # solution within Newton's tolerance and the same iterations
    system, init = _system(MODELS / "spatial_slider_crank.mbd")
    runs = {}
    for solver in ("auto", "banded"):
        runs[solver] = integrate(system, make_method(method), 0.5, 1e-3, initial=init,
                                 engine="compiled", newton=NewtonOptions(linear_solver=solver))
        assert runs[solver].status == "completed"
    a, b = runs["auto"], runs["banded"]
    assert a.linear_solver == "dense" and b.linear_solver == "banded"
    assert np.abs(a.q - b.q).max() < 1e-8
    assert np.abs(a.v - b.v).max() < 1e-6
    assert a.stats_total.iterations == pytest.approx(b.stats_total.iterations, rel=0.03)


def test_split_dense_under_error_control():
    # error-controlled steps (rejections invert at a new h): the band LU's steps and
    # solution within Newton's tolerance
    system, init = _system(MODELS / "andrews.mbd")
    ctl = StepControl(1e-5, 1e-5)
    runs = {solver: integrate(system, make_method("hht-si2"), 1e-3, 1e-5, initial=init,
                              engine="compiled", control=ctl,
                              newton=NewtonOptions(linear_solver=solver))
            for solver in ("auto", "banded")}
    a, b = runs["auto"], runs["banded"]
    assert a.status == b.status == "completed" and a.linear_solver == "dense"
    assert len(a.t) == len(b.t) and np.abs(a.t - b.t).max() < 1e-12
    assert np.abs(a.q - b.q).max() < 1e-8


def test_a_failed_split_dense_step_goes_on_with_the_whole_inverse(monkeypatch):
    # two full-Newton iterations cannot take a 20 ms step of the released chain: the
    # split loop stops, the numpy engine halves the step, the loop resumes with the
    # whole matrix's inverse
    import mbdsl.integrators.engine as engine
    monkeypatch.setattr(engine, "linear_solver_plan",
                        lambda system, method, options, q, *a, **k:
                        dense_split_plan(system, method, q))
    system, init = _system(MODELS / "pendulum_chain.mbd", N=15)
    opt = NewtonOptions(max_iter=2, jacobian="full")
    b = integrate(system, make_method("hht-si2"), 0.2, 0.02, initial=init, engine="compiled",
                  newton=opt, on_failure="return")
    a = integrate(system, make_method("hht-si2"), 0.2, 0.02, initial=init, engine="numpy",
                  newton=NewtonOptions(max_iter=2, jacobian="full"), on_failure="return")
    assert b.stats_total.rejected > 0 and b.status == a.status == "completed"
    assert "whole matrix's inverse" in b.linear_solver_note
    assert b.t[-1] == 0.2 and np.abs(a.q[-1] - b.q[-1]).max() < 1e-8
