"""The compiled engine's condensed linear solver (``integrators.compiled.condensed``):
the coordinates eliminated group by group, the constraint rows' Schur complement
factored as a band. Checked against numpy's dense solve of the same Newton matrix,
against the band LU on whole runs, and in its choice by "auto"."""

from __future__ import annotations

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators import NewtonOptions, integrate, make_method
from mbdsl.integrators import compiled as K
from mbdsl.integrators.adaptive import StepControl
from mbdsl.integrators.compiled.condensed import SHARE_TOL
from mbdsl.integrators.condensation import band_flops, block_codes, condensed_plan
from mbdsl.integrators.solver_plans import CONDENSED_GAIN, UNIT_GAIN, condensed_cost
from mbdsl.integrators.records import (CP_BRCOORD, CP_BRPTR, CP_BRSRC, CP_CMAP, CP_LOWER,
                                       CP_RMAP, CP_SHARE, CP_UNIT, LIN_CP, LIN_CW, LIN_IPIV)
from mbdsl.integrators.engine import (CompiledModel, condensed_solver_plan, linear_solver_plan,
                                      newton_pattern, newton_size)

from ..conftest import MODELS

VALID = MODELS.parent / "tests" / "dsl" / "valid"

#: Methods whose Newton matrix is laid out as coordinates and multipliers (one
#: block), or split in two such blocks (HHT-SI2, generalized-alpha SI2)
CONDENSABLE = ["newmark", "hht-i3", "nstiff", "genalpha", "hht-si2", "genalpha-si2"]


def _system(path, **overrides):
    system = mbdsl.assemble(mbdsl.load(path, overrides=overrides or None))
    return system, mbdsl.consistent_initial_state(system)


def _newton_matrix(system, method, init, rng):
    """(plan, R, C, V, p, J): the kernels' Newton-matrix triplets at a perturbed
    iterate (multipliers nonzero, so that every Hessian block is), and the
    dense matrix the condensed solver solves: the whole one, or for a split
    method its block lower-triangular part (the upper block left out, as in
    the band solver)."""
    cm = CompiledModel(system)
    n, m = system.n, system.m
    size = newton_size(system, method)
    split = method.name in ("hht-si2", "genalpha-si2")
    plan = condensed_solver_plan(system, method, init.q, split, K.lapack_band_addresses(), cm)
    assert plan is not None and plan.kind == "condensed"
    R, C, V = (np.empty(cm.bound, np.int64), np.empty(cm.bound, np.int64), np.empty(cm.bound))
    qx = np.zeros(n + 3)
    qx[:n] = init.q
    w = 0.1 * rng.standard_normal(size)
    w[:n] += init.a
    p = cm.K.jacobian_triplets(method.kernel_recipe(1e-3, False), cm.ints, cm.floats, 0.0,
                               np.asarray(init.q, float), np.asarray(init.v, float), np.zeros(n),
                               qx, w, R, C, V, np.zeros(n + 3), np.zeros(n + 3))
    J = np.zeros((size, size))
    np.add.at(J, (R[:p], C[:p]), V[:p])
    if split:
        rows, cols = block_codes(size, n, m, True)
        J[(rows[:, None] // (n + m)) < (cols[None, :] // (n + m))] = 0.0
    return plan, R, C, V, p, J


def _shared_matrix(J, plan, n, m):
    """The split Newton matrix J as the condensed solver solves it, derived here
    in numpy: block 1 and the lower block replaced by multiples of block 0's parts,

        J1 -> [[cA A0, cC C0^T], [cB B0, 0]],    L21 -> [[0, 0], [cL B0, 0]],

    (least-squares scalars) where every group's parts are within SHARE_TOL of
    them (``condensed._shareable``); else J itself. (matrix, shared)."""
    size, s = J.shape[0], n + m
    rows, cols = block_codes(size, n, m, True)
    Jb = np.zeros_like(J)
    Jb[np.ix_(rows, cols)] = J
    A0, C0, B0 = Jb[:n, :n], Jb[:n, n:s], Jb[n:s, :n]
    A1, C1, B1 = Jb[s:s + n, s:s + n], Jb[s:s + n, s + n:], Jb[s + n:, s:s + n]
    LA, LB, Lm = Jb[s:s + n, :n], Jb[s + n:, :n], Jb[s:, n:s]
    cA, cC, cB, cL = (np.sum(x * y) / np.sum(y * y) for x, y in
                      ((A1, A0), (C1, C0), (B1, B0), (LB, B0)))
    inside = np.zeros((n, n), bool)
    for g in plan.condensed.groups:
        inside[np.ix_(g, g)] = True
    shared = not Lm.any() and not LA[~inside].any()
    for g in plan.condensed.groups:
        a = np.ix_(g, g)
        for d, x in ((np.sum((A1[a] - cA * A0[a]) ** 2) + np.sum(LA[a] ** 2), A1[a]),
                     (np.sum((C1[g] - cC * C0[g]) ** 2), C1[g]),
                     (np.sum((B1[:, g] - cB * B0[:, g]) ** 2), B1[:, g]),
                     (np.sum((LB[:, g] - cL * B0[:, g]) ** 2), LB[:, g])):
            shared = shared and d <= SHARE_TOL ** 2 * np.sum(x * x)
    if not shared:
        return J, False
    Jt = np.zeros_like(Jb)
    Jt[:s, :s] = Jb[:s, :s]
    Jt[s:s + n, s:s + n], Jt[s:s + n, s + n:], Jt[s + n:, s:s + n] = cA * A0, cC * C0, cB * B0
    Jt[s + n:, :n] = cL * B0
    return Jt[np.ix_(rows, cols)], True


@pytest.mark.parametrize("method", CONDENSABLE)
@pytest.mark.parametrize("path, overrides", [
    (MODELS / "spatial_chain.mbd", {"N": 4}), (MODELS / "spatial_slider_crank.mbd", {}),
    (MODELS / "spherical_pendulum.mbd", {}), (MODELS / "spatial_spring_pendulum.mbd", {}),
    (VALID / "spatial_drivers.mbd", {}), (MODELS / "pendulum_chain.mbd", {"N": 6}),
    (VALID / "compiled_elements.mbd", {}), (MODELS / "double_pendulum_stiff.mbd", {})])
def test_the_condensed_solve_is_numpys_dense_solve(path, overrides, method):
    # the elimination of each coordinate group, the Schur complement's band and its
    # ordering, the lower block of a split matrix: a misplaced entry, a wrong slot or
    # a wrong sign gives another solution. A split matrix whose block 1 is near a
    # multiple of block 0 is solved with block 0's factors: the matrix that solve
    # inverts, and the decision, derived in numpy (``_shared_matrix``); the stiff
    # double pendulum (its torsional spring of 1e7 N m/rad: h^2 K against the mass) keeps
    # its own block 1
    system, init = _system(path, **overrides)
    rng = np.random.default_rng(3)
    method = make_method(method)
    plan, R, C, V, p, J = _newton_matrix(system, method, init, rng)
    lin = plan.workspace(J.shape[0], len(R))
    assert K._factor(K.CONDENSED, lin, R, C, V, p) == K.CONVERGED
    if method.name in ("hht-si2", "genalpha-si2"):
        J, shared = _shared_matrix(J, plan, system.n, system.m)
        cp = lin[LIN_CP]
        assert bool(lin[LIN_CW][cp[CP_SHARE]]) == shared
        assert shared == (path.name != "double_pendulum_stiff.mbd")
    for _ in range(2):                          # the factorization is reused
        r = rng.standard_normal(J.shape[0])
        dw = np.empty_like(r)
        K._solve(K.CONDENSED, lin, r, dw)
        x = np.linalg.solve(J, r)
        assert np.abs(dw - x).max() <= 1e-9 * np.abs(x).max()
        assert np.abs(J @ dw - r).max() <= 1e-9 * np.abs(J).max() * np.abs(dw).max()


def test_triplets_out_of_the_plans_order_are_placed_one_by_one():
    # the planned scatter trusts the triplets' order fixed at build and checks it;
    # shuffled, the solver places each by its row's slot search, to the same solve,
    # and a triplet outside the plan's groups makes the matrix singular, not wrong
    system, init = _system(MODELS / "spatial_chain.mbd", N=3)
    rng = np.random.default_rng(5)
    plan, R, C, V, p, J = _newton_matrix(system, make_method("hht-si2"), init, rng)
    J, shared = _shared_matrix(J, plan, system.n, system.m)
    assert shared
    order = rng.permutation(p)
    R2, C2, V2 = R[:p][order].copy(), C[:p][order].copy(), V[:p][order].copy()
    lin = plan.workspace(J.shape[0], len(R))
    assert K._factor(K.CONDENSED, lin, R2, C2, V2, p) == K.CONVERGED
    r = rng.standard_normal(J.shape[0])
    dw = np.empty_like(r)
    K._solve(K.CONDENSED, lin, r, dw)
    assert np.abs(dw - np.linalg.solve(J, r)).max() <= 1e-9 * np.abs(dw).max()
    n = system.n                                # body 1's x row against body 2's x column
    extra = np.array([0]), np.array([12]), np.array([1.0])
    R3, C3, V3 = (np.concatenate([a, b]) for a, b in zip((R2, C2, V2), extra))
    assert n > 12 and K._factor(K.CONDENSED, lin, R3, C3, V3, p + 1) == K.SINGULAR


@pytest.mark.parametrize("method", ["hht-si2", "genalpha-si2"])
@pytest.mark.parametrize("path, overrides", [
    (MODELS / "spatial_chain.mbd", {"N": 4}), (MODELS / "spatial_spring_pendulum.mbd", {}),
    (VALID / "spatial_drivers.mbd", {}), (MODELS / "double_pendulum_stiff.mbd", {})])
def test_the_lower_blocks_places_found_at_build_are_the_ones_found_one_by_one(path, overrides,
                                                                            method):
    # the plan places each lower-block triplet in the sharing test's area at build
    # (``lplace``); triplets out of the plan's order are placed one by one by their
    # rows' slots (``_lower_places``): the same area (up to the order of the sums of
    # duplicate entries) and the same decision, shared or not
    system, init = _system(path, **overrides)
    rng = np.random.default_rng(7)
    plan, R, C, V, p, J = _newton_matrix(system, make_method(method), init, rng)
    cp = plan.condensed.cp
    lower, share = cp[CP_LOWER], cp[CP_SHARE]
    order = rng.permutation(p)
    areas = []
    for rows, cols, vals in [(R, C, V), (R[:p][order].copy(), C[:p][order].copy(),
                                         V[:p][order].copy())]:
        lin = plan.workspace(J.shape[0], len(R))
        assert K._factor(K.CONDENSED, lin, rows, cols, vals, p) == K.CONVERGED
        areas.append((lin[LIN_CW][lower:share].copy(), lin[LIN_CW][share]))
    (planned, shared), (one_by_one, shared_too) = areas
    assert np.any(planned != 0.0) and shared == shared_too
    assert np.abs(planned - one_by_one).max() <= 1e-14 * np.abs(planned).max()


def test_the_shared_pair_is_two_solves_of_block_0_to_the_bit():
    # with the shared factorization both blocks' right-hand sides go through block
    # 0's factors interleaved; each must get the operations of a solve of its own,
    # in the same order: block 0's through the solver with the sharing switched off
    # (block 0 then solved alone), block 1's as a block-0 right-hand side there, its
    # (x, y) then divided by cA and cC (``_shared_pair``, ``_condensed_solve``)
    system, init = _system(MODELS / "spatial_chain.mbd", N=4)
    rng = np.random.default_rng(11)
    plan, R, C, V, p, J = _newton_matrix(system, make_method("hht-si2"), init, rng)
    lin = plan.workspace(J.shape[0], len(R))
    assert K._factor(K.CONDENSED, lin, R, C, V, p) == K.CONVERGED
    cp, cw = lin[LIN_CP], lin[LIN_CW]
    sh, n, m = cp[CP_SHARE], system.n, system.m
    s = n + m
    assert cw[sh] == 1.0
    rmap = cp[cp[CP_RMAP]:cp[CP_RMAP] + 2 * s]
    cmap = cp[cp[CP_CMAP]:cp[CP_CMAP] + 2 * s]
    r = rng.standard_normal(2 * s)
    dw = np.empty_like(r)
    K._solve(K.CONDENSED, lin, r, dw)
    b = np.empty(2 * s)
    b[rmap] = r
    b1 = b[s:].copy()                           # block 1's right-hand side for block 0
    b1[n:] = cw[sh + 1] / cw[sh + 3] * (b1[n:] - cw[sh + 4] * b[n:s])
    cw[sh] = 0.0                                # block 0 alone (block 1's part unused)
    x0, x1 = np.empty_like(r), np.empty_like(r)
    with np.errstate(all="ignore"):
        K._solve(K.CONDENSED, lin, r, x0)
        b2 = b.copy()
        b2[:s] = b1
        K._solve(K.CONDENSED, lin, b2[rmap], x1)
    first = cmap < s
    assert np.array_equal(dw[first], x0[first])
    y = np.empty(2 * s)
    y[cmap] = x1
    expect = np.concatenate([y[:n] / cw[sh + 1], y[n:s] / cw[sh + 2]])
    assert np.array_equal(dw[~first], expect[cmap[~first] - s])


def test_a_singular_schur_complement_is_reported():
    # a constraint row without entries (its joint lost) makes the Newton matrix
    # singular whatever the solver: the Schur complement's row is zero, and the
    # condensed solver says SINGULAR rather than solving
    system, init = _system(MODELS / "spatial_chain.mbd", N=3)
    rng = np.random.default_rng(2)
    plan, R, C, V, p, J = _newton_matrix(system, make_method("hht-i3"), init, rng)
    V = V.copy()
    V[:p][R[:p] == system.n + 4] = 0.0           # constraint row 4: a zero row of J
    lin = plan.workspace(J.shape[0], len(R))
    assert K._factor(K.CONDENSED, lin, R, C, V, p) == K.SINGULAR
    # the augmented formulation of redundant joints (Bricard's linkage) couples the
    # multipliers: not the condensed solver's
    model = mbdsl.load(MODELS / "bricard.mbd")
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=2e-3)
    assert sol.completed and sol.linear_solver != "condensed"


def test_the_groups_of_a_spatial_chain():
    # a spatial body's 12 coordinates fall into its 3 positions (coupled by nothing
    # but its joints) and its 9 directors (coupled by the frame rows' Hessian),
    # each touched by the same rows: 2 groups per body, a Schur complement on the
    # 6 frame and 3 joint rows per body whose band does not grow with N
    for N in (4, 12):
        system, init = _system(MODELS / "spatial_chain.mbd", N=N)
        R, C = newton_pattern(system, make_method("hht-i3"), init.q)
        plan = condensed_plan(R, C, system.n, system.m)
        assert len(plan.groups) == 2 * N
        assert sorted(len(g) for g in plan.groups) == [3] * N + [9] * N
        assert plan.m == 9 * N and plan.kl <= 12 and plan.ku <= 12
    # NSTIFF-SI2's unsplit stabilized index-2 layout and HHT-ADD's additive form
    # are not coordinates-then-multipliers: the band LU's
    for name in ("nstiff-si2", "hht-add"):
        assert condensed_solver_plan(system, make_method(name), init.q, False,
                                     K.lapack_band_addresses()) is None
    with pytest.raises(ValueError, match="does not apply"):
        linear_solver_plan(system, make_method("nstiff-si2"),
                           NewtonOptions(linear_solver="condensed"), init.q)


def test_auto_takes_the_condensed_solver_where_it_costs_a_quarter():
    # the spatial chain's band (29 each way) costs five times the condensed flops;
    # the planar chain's band (4 each way) about twice, the N-four-bar's three
    # times, but their coordinate blocks are diagonal: one-coordinate groups, whose
    # loops take the condensed solver at 0.6 of the band's flops (``UNIT_GAIN``);
    # small models keep the dense inverse (the spatial slider-crank's split HHT-SI2
    # matrix its two blocks' inverses)
    system, init = _system(MODELS / "spatial_chain.mbd", N=10)
    for name in ("hht-i3", "hht-si2", "genalpha"):
        plan = linear_solver_plan(system, make_method(name), NewtonOptions(), init.q)
        assert plan.kind == "condensed" and plan.blocks == (2 if name == "hht-si2" else 1)
        assert not plan.condensed.unit
    for path, overrides, kinds in [(MODELS / "pendulum_chain.mbd", {"N": 60},
                                    ("condensed", "condensed")),
                                   (MODELS / "n_fourbar.mbd", {}, ("condensed", "condensed")),
                                   (MODELS / "spatial_slider_crank.mbd", {}, ("dense", "dense"))]:
        system, init = _system(path, **overrides)
        for name, kind in zip(("hht-i3", "hht-si2"), kinds):
            plan = linear_solver_plan(system, make_method(name), NewtonOptions(), init.q)
            assert plan.kind == kind, (path.name, name)
            assert kind != "condensed" or plan.condensed.unit
    # without the one-coordinate loops' gain the planar chain keeps its band LU: the
    # rule, not the flops, made the choice
    system, init = _system(MODELS / "pendulum_chain.mbd", N=60)
    plan = linear_solver_plan(system, make_method("hht-i3"), NewtonOptions(), init.q)
    flops = condensed_cost(plan)
    band = linear_solver_plan(system, make_method("hht-i3"),
                              NewtonOptions(linear_solver="banded"), init.q)
    cost = sum(f * w for f, w in zip(band_flops(5 * 60, band.kl, band.ku, 1), (1, 6)))
    assert CONDENSED_GAIN * cost < flops <= UNIT_GAIN * cost


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "genalpha", "nstiff"])
def test_condensed_and_band_runs_agree(method):
    # the same Newton matrix (the same split one for HHT-SI2) in other arithmetic,
    # refreshed by the same rule: the same steps and iterations, within Newton's
    # tolerance
    system, init = _system(MODELS / "spatial_chain.mbd", N=5)
    runs = {}
    for solver in ("condensed", "banded"):
        runs[solver] = integrate(system, make_method(method), 0.2, 1e-3, initial=init,
                                 engine="compiled",
                                 newton=NewtonOptions(linear_solver=solver, rate_refresh=0.3))
        assert runs[solver].status == "completed"
        assert runs[solver].linear_solver == solver
    a, b = runs["condensed"], runs["banded"]
    assert np.abs(a.q - b.q).max() < 1e-9
    assert np.abs(a.v - b.v).max() < 1e-7
    assert a.stats_total.iterations == pytest.approx(b.stats_total.iterations, rel=0.03)


def test_condensed_under_error_control_and_a_failed_split_step():
    # error-controlled steps (rejections refactor at a new h) and, for HHT-SI2, the
    # fallback to the whole band matrix after a failed step keep the run's solution
    system, init = _system(MODELS / "spatial_double_pendulum.mbd")
    ctl = StepControl(1e-6, 1e-6)
    a = integrate(system, make_method("hht-si2"), 0.5, 1e-3, initial=init, engine="compiled",
                  control=ctl, newton=NewtonOptions(linear_solver="condensed"))
    b = integrate(system, make_method("hht-si2"), 0.5, 1e-3, initial=init, engine="compiled",
                  control=ctl, newton=NewtonOptions(linear_solver="banded"))
    assert a.status == b.status == "completed" and a.linear_solver == "condensed"
    assert len(a.t) == len(b.t) and np.abs(a.t - b.t).max() < 1e-9
    assert np.abs(a.q - b.q).max() < 1e-8


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "genalpha"])
@pytest.mark.parametrize("path", [VALID / "spatial_contacts.mbd", VALID / "spatial_state_loads.mbd",
                                  MODELS / "spatial_spring_pendulum.mbd"])
def test_condensed_runs_with_contacts_limits_springs_and_loads_of_the_state(path, method):
    # the elements where they meet the solver: contacts and joint limits (events land
    # steps and change the law between calls), springs between bodies (their
    # Jacobian couples two bodies' groups: one larger group), loads reading the
    # motion; under error control; the band LU's solution within Newton's tolerance
    # (the step sizes follow the error estimate, which Newton's tolerance perturbs)
    system, init = _system(path)
    ctl = StepControl(1e-5, 1e-5)
    runs = {}
    for solver in ("condensed", "banded"):
        runs[solver] = integrate(system, make_method(method), 0.4, 1e-3, initial=init,
                                 engine="compiled", control=ctl,
                                 newton=NewtonOptions(linear_solver=solver, rate_refresh=0.3))
    a, b = runs["condensed"], runs["banded"]
    assert a.status == b.status == "completed" and a.linear_solver == "condensed"
    assert len(a.t) == len(b.t) and np.abs(a.t - b.t).max() < 1e-7
    assert np.abs(a.q - b.q).max() < 1e-6


def _plan_array(cp, field, length):
    return cp[cp[field]:cp[field] + length]


def test_a_diagonal_coordinate_block_is_planned_as_one_coordinate_groups():
    # the planar chain's coordinate block is diagonal (the mass, and each revolute
    # joint's Hessian on its body's angle alone): every group is one coordinate, and
    # the plan lists each constraint row's entries of B with their places in the
    # workspace, which after the scatter hold the Newton matrix's B (rows n + i,
    # coordinate columns): every entry of B once, and nothing else
    system, init = _system(MODELS / "pendulum_chain.mbd", N=7)
    n, m = system.n, system.m
    plan, R, C, V, p, J = _newton_matrix(system, make_method("hht-i3"), init,
                                         np.random.default_rng(13))
    c = plan.condensed
    assert c.unit and all(len(g) == 1 for g in c.groups) and len(c.groups) == n
    lin = plan.workspace(J.shape[0], len(R))
    assert K._factor(K.CONDENSED, lin, R, C, V, p) == K.CONVERGED
    cp, cw = lin[LIN_CP], lin[LIN_CW]
    assert cp[CP_UNIT] == 1
    ptr = _plan_array(cp, CP_BRPTR, m + 1)
    src = _plan_array(cp, CP_BRSRC, ptr[-1])
    coord = _plan_array(cp, CP_BRCOORD, ptr[-1])
    B = np.zeros((m, n))
    for i in range(m):
        for k in range(ptr[i], ptr[i + 1]):
            B[i, coord[k]] += cw[src[k]]
    Bj = J[n:, :n]
    assert np.count_nonzero(Bj) == ptr[-1]
    assert np.array_equal(B, Bj)
    # a spatial body's groups are not one coordinate: the k x k code, no rows listed
    system, init = _system(MODELS / "spatial_chain.mbd", N=3)
    R, C = newton_pattern(system, make_method("hht-i3"), init.q)
    c = condensed_plan(R, C, system.n, system.m)
    assert not c.unit and c.cp[CP_UNIT] == 0
    assert _plan_array(c.cp, CP_BRPTR, system.m + 1).max() == 0


@pytest.mark.parametrize("method", ["hht-i3", "genalpha", "nstiff", "hht-si2", "newmark"])
def test_the_one_coordinate_loops_are_the_k_by_k_code(method):
    # the one-coordinate loops (``_unit_groups``, ``_unit_block``) against the k x k
    # code on the same plan, switched to it by the plan's flag, and both against
    # numpy's dense solve. Where the coordinate block is positive and the constraint
    # columns are the constraint rows' transpose (derived here from the dense
    # matrix), S = B A^-1 B^T is factored by Cholesky (a zero first pivot marks it),
    # else by the band LU; HHT-SI2's blocks, shared or not
    system, init = _system(MODELS / "pendulum_chain.mbd", N=40)
    n, m = system.n, system.m
    rng = np.random.default_rng(17)
    plan, R, C, V, p, J = _newton_matrix(system, make_method(method), init, rng)
    split = method == "hht-si2"
    Jd = _shared_matrix(J, plan, n, m)[0] if split else J
    s = n + m
    A, Ct, B = J[:n, :n], J[:n, n:s], J[n:s, :n]
    spd = bool(np.all(np.diag(A) > 0) and np.array_equal(B, Ct.T))
    r = rng.standard_normal(J.shape[0])
    x = np.linalg.solve(Jd, r)
    out = {}
    for unit in (1, 0):
        lin = plan.workspace(J.shape[0], len(R))
        lin[LIN_CP][CP_UNIT] = unit
        assert K._factor(K.CONDENSED, lin, R, C, V, p) == K.CONVERGED
        assert (lin[LIN_IPIV][0] == 0) == (unit == 1 and spd)
        dw = np.empty_like(r)
        K._solve(K.CONDENSED, lin, r, dw)
        assert np.abs(dw - x).max() <= 1e-9 * np.abs(x).max()
        out[unit] = dw
    assert np.abs(out[1] - out[0]).max() <= 1e-12 * np.abs(out[0]).max()
    if method in ("hht-i3", "genalpha"):        # the chain's own case: Cholesky taken
        assert spd


def test_an_indefinite_schur_complement_takes_the_band_lu():
    # the coordinate block made negative (a_g < 0: S negative definite) or one
    # constraint row's column scaled (B != C^T: S not symmetric): the one-coordinate
    # loops keep the band LU, and the solve is numpy's
    system, init = _system(MODELS / "pendulum_chain.mbd", N=12)
    n = system.n
    rng = np.random.default_rng(19)
    plan, R, C, V, p, J = _newton_matrix(system, make_method("hht-i3"), init, rng)
    for change in ("negative", "unsymmetric"):
        V2 = V.copy()
        if change == "negative":
            V2[:p][(R[:p] < n) & (C[:p] < n)] *= -1.0
        else:
            V2[:p][(R[:p] < n) & (C[:p] == n + 3)] *= 1.5
        J2 = np.zeros_like(J)
        np.add.at(J2, (R[:p], C[:p]), V2[:p])
        lin = plan.workspace(J.shape[0], len(R))
        assert K._factor(K.CONDENSED, lin, R, C, V2, p) == K.CONVERGED
        assert lin[LIN_IPIV][0] != 0, change
        r = rng.standard_normal(J.shape[0])
        dw = np.empty_like(r)
        K._solve(K.CONDENSED, lin, r, dw)
        x = np.linalg.solve(J2, r)
        assert np.abs(dw - x).max() <= 1e-9 * np.abs(x).max(), change
