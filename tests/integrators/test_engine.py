"""The compiled engine (numba kernels) against DOP853, finite differences and the numpy engine.

Every method on the rigid element models converges to an independent DOP853
solution of the index-1 equations with its order (a 0.1 % error in the
forces leaves an error that does not fall with h: measured ratio 1.00
against 4.00); the kernel Newton matrix equals finite differences of the
kernel residual; where no DOP853 reference is cheap (flexible beams, which
make it crawl, and the linear solvers' paths) the numpy engine, independent
code over the same equations (scalar kernels vs vectorised groups), agrees
to round-off. Each check can fail: a wrong sign, a missing term or a
mis-scattered entry moves the results by far more than the tolerances below.
"""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators import NewtonOptions, integrate, make_method
from mbdsl.integrators.adaptive import StepControl
from mbdsl.integrators import engine as engine_module
from mbdsl.integrators import loop as loop_module
from mbdsl.integrators.common import force_term
from mbdsl.integrators.engine import (CompiledModel, SparseAdapter, band_ordering,
                                     linear_solver_plan, newton_size, select_engine,
                                     unsupported)

from ..conftest import MODELS, interrupted_run

VALID = MODELS.parent / "tests" / "dsl" / "valid"
#: The methods the kernels run from their recipes.
RECIPE_METHODS = ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
                  "genalpha-si2"]
#: Flexible beams the kernels run: the paper's flexible slider crank, every joint kernel
#: on beam points (three beams, two groups, chord, first-node and default frames,
#: stiffening), the same with a spring-damper and a point force on beam points, and
#: distance joints between beam points and to a rigid body.
FLEXIBLE = [(MODELS / "flexible_slider_crank.mbd", {}), (VALID / "flexible_joints.mbd", {}),
            (VALID / "flexible_elements.mbd", {}), (VALID / "flexible_distance.mbd", {})]


def residual_differences(ad, w, ctx, rel):
    """Central differences of the kernel residual (``SparseAdapter.residual``)
    at w, column j with the step rel max(1, |w_j|): shape (size, size)."""
    fd = np.empty((ad.size, ad.size))
    for j in range(ad.size):
        e = np.zeros(ad.size)
        e[j] = step = rel * max(1.0, abs(w[j]))
        fd[:, j] = (ad.residual(w + e, ctx) - ad.residual(w - e, ctx)) / (2 * step)
    return fd


def rigid_residual_in_kernel_rows(system, m, w, ctx):
    """The numpy method m's residual at w in the rows the kernels form
    (HHT-ADD: its rows 1, 2 and 5 times M, a rigid model's constant diagonal)."""
    ref = m.residual(w, ctx)
    if m.name == "hht-add":
        M = system.mass_diag
        ref = np.concatenate([M, M, np.ones(2 * system.m), M]) * ref
    return ref


def _system(path, **overrides):
    model = mbdsl.load(path, overrides=overrides or None)
    system = mbdsl.assemble(model)
    return system, mbdsl.consistent_initial_state(system)


#: Rigid models whose elements the kernels evaluate, with the end time of the
#: convergence runs: the slider crank, every joint, driver and force kernel
#: (constant and functions of time), the loads of the state, friction in joints
#: distance joints and couplers.
RIGID = [(MODELS / "slider_crank.mbd", 0.5), (VALID / "compiled_elements.mbd", 0.3),
         (VALID / "all_elements.mbd", 0.3), (VALID / "friction_elements.mbd", 0.3),
         (VALID / "distance_elements.mbd", 0.3), (VALID / "coupler_elements.mbd", 0.3)]


@pytest.fixture(scope="module")
def dop853_references():
    """{path: (system, initial state, q, v, lambda at T)}: the index-1 equations
    integrated by scipy's DOP853 at rtol = atol = 1e-12 (``mbdsl.studies.index1``),
    lambda from the index-1 system at the reference's (q, v); none of the
    methods' formulas, and the vectorised numpy assembly, not the kernels."""
    from mbdsl.studies.index1 import index1_reference
    refs = {}
    for path, T in RIGID:
        system, init = _system(path)
        ref = index1_reference(system, [T], initial=init)
        lam = system.index1_multipliers(np.array([T]), ref.q[-1:], ref.v[-1:])[0]
        refs[path] = (system, init, ref.q[-1], ref.v[-1], lam)
    return refs


@pytest.mark.parametrize("method", RECIPE_METHODS)
@pytest.mark.parametrize("path, T", RIGID)
def test_compiled_engine_converges_to_the_dop853_reference(dop853_references, path, T, method):
    """Each method on the compiled engine against the DOP853 reference at T:
    q, v and lambda at h = 1 ms and 0.5 ms, their errors falling by 2^p, p
    the method's order as it declares it on the model (``Method.order``: 2;
    NEWMARK's default gamma = 0.6 and HHT-ADD with friction, whose normal
    load is psi_II, 1: docs/methods.md).
    Measured ratios 3.83-4.05 (order 2) and 1.95-2.09 (order 1), errors at
    0.5 ms from 3e-7 to 1.3e-3 (q). A wrong sign or a missing term in a kernel
    leaves an error that does not fall with h. Newton's tolerance is set
    100 times below its default, so that the order is the discretization's:
    the default admits multipliers about 2e-7 (relative) off the step's
    solution, which the friction elements' 1.5e-6 at 0.5 ms shows (ratio
    3.44 for genalpha)."""
    system, init, q_ref, v_ref, lam_ref = dop853_references[path]
    tight = NewtonOptions(rtol=1e-10, atol_kinematic=1e-11, atol_multiplier=1e-11)
    order = make_method(method).order(system)
    assert order == (1 if method == "newmark" or (method == "hht-add" and "friction" in path.name)
                     else 2)
    errors = []
    for h in (1e-3, 5e-4):
        sol = integrate(system, make_method(method), T, h, initial=init, engine="compiled",
                        newton=tight)
        assert sol.engine == "compiled" and sol.status == "completed"
        errors.append(np.array([np.abs(sol.q[-1] - q_ref).max(),
                                np.abs(sol.v[-1] - v_ref).max(),
                                np.abs(sol.lam[-1] - lam_ref).max() / np.abs(lam_ref).max()]))
    ratio = errors[0] / errors[1]
    low, high = (1.7, 2.4) if order == 1 else (3.5, 4.5)
    assert np.all((ratio > low) & (ratio < high)), (errors, ratio)
    assert errors[1][0] < 3e-3 and errors[1][1] < 2e-2, errors[1]


@pytest.mark.parametrize("method", RECIPE_METHODS)
def test_sparse_path_matches_the_compiled_loop(method):
    # the kernels' residual and Newton matrix under the driver's Newton with SuperLU
    # against the whole compiled loop with its dense inverse (the path tested against
    # DOP853 above): a mis-assembled CSC pattern gives another solution or none
    system, init = _system(MODELS / "pendulum_chain.mbd", N=12)
    dense = NewtonOptions(rate_refresh=0.1, linear_solver="dense")
    opt = NewtonOptions(rate_refresh=0.1, linear_solver="sparse")
    a = integrate(system, make_method(method), 0.05, 1e-3, initial=init, engine="compiled",
                  newton=dense)
    b = integrate(system, make_method(method), 0.05, 1e-3, initial=init, engine="compiled",
                  newton=opt)
    assert b.engine == "compiled" and (a.linear_solver, b.linear_solver) == ("dense", "sparse")
    assert np.abs(a.q - b.q).max() < 1e-11 and np.abs(a.v - b.v).max() < 1e-8


@pytest.mark.parametrize("method", ["nstiff", "nstiff-si2"])
def test_sparse_path_takes_bdf2_of_the_step_ratio(method):
    # error-controlled steps through SuperLU (the kernels' residual under the Python
    # Newton): BDF2 with unequal steps needs the ratio's coefficients in the recipe, not
    # the fixed-step ones (with those NSTIFF could not meet the tolerance at 0.057 s);
    # the same steps and states as the whole compiled loop with its dense inverse
    system, init = _system(MODELS / "double_pendulum.mbd")
    sparse = NewtonOptions(linear_solver="sparse")
    a = integrate(system, make_method(method), 0.3, 1e-3, initial=init, engine="compiled",
                  control=StepControl(1e-6, 1e-6))
    b = integrate(system, make_method(method), 0.3, 1e-3, initial=init, engine="compiled",
                  control=StepControl(1e-6, 1e-6), newton=sparse)
    assert b.linear_solver == "sparse" and a.linear_solver == "dense" and len(a.t) == len(b.t) > 50
    assert np.abs(a.t - b.t).max() < 1e-9 and np.abs(a.q - b.q).max() < 1e-9


@pytest.mark.parametrize("method", RECIPE_METHODS)
@pytest.mark.parametrize("path, overrides", [(MODELS / "pendulum_chain.mbd", {"N": 12}),
                                             (VALID / "compiled_elements.mbd", {})])
def test_band_lu_matches_the_dense_inverse(path, overrides, method):
    # LAPACK's band LU called from the kernels, on the reverse Cuthill-McKee
    # ordering: a mis-placed band entry, a wrong ordering or a wrong LAPACK
    # argument gives a wrong Newton update and no convergence, or another solution
    system, init = _system(path, **overrides)
    band = NewtonOptions(rate_refresh=0.1, linear_solver="banded")
    dense = NewtonOptions(rate_refresh=0.1, linear_solver="dense")
    a = integrate(system, make_method(method), 0.1, 1e-3, initial=init, engine="compiled",
                  newton=band)
    b = integrate(system, make_method(method), 0.1, 1e-3, initial=init, engine="compiled",
                  newton=dense)
    assert a.linear_solver == "banded" and b.linear_solver == "dense"
    assert a.status == "completed" and a.stats_total.rejected == 0
    assert np.abs(a.q - b.q).max() < 1e-10
    assert np.abs(a.v - b.v).max() < 1e-8
    assert np.abs(a.lam - b.lam).max() < 1e-7 * max(1.0, np.abs(a.lam).max())
    if method not in ("hht-si2", "genalpha-si2"):    # the same Newton matrix: the same iterations
        assert a.stats_total.iterations == pytest.approx(b.stats_total.iterations, rel=0.02)
    else:                      # the split SI2 matrix leaves out O(h) terms: a few more
        assert b.stats_total.iterations <= a.stats_total.iterations <= 1.2 * b.stats_total.iterations


def test_whole_and_split_si2_band_matrices_reach_the_same_solution(monkeypatch):
    import mbdsl.integrators.engine as engine
    system, init = _system(MODELS / "pendulum_chain.mbd", N=15)
    plan = engine.linear_solver_plan
    runs = {}
    for split in (True, False):
        monkeypatch.setattr(engine, "linear_solver_plan",
                            lambda *a, split=split, **k: plan(*a, **{**k, "split_si2": split}))
        runs[split] = integrate(system, make_method("hht-si2"), 0.1, 1e-3, initial=init,
                                engine="compiled", newton=NewtonOptions(linear_solver="banded"))
    assert runs[True].linear_solver == runs[False].linear_solver == "banded"
    assert np.abs(runs[True].q - runs[False].q).max() < 1e-10
    assert np.abs(runs[True].v - runs[False].v).max() < 1e-8


def test_band_factor_and_solve_against_numpy():
    from mbdsl.integrators import compiled as K
    from mbdsl.integrators.engine import LinearSolverPlan
    rng = np.random.default_rng(7)
    size, kl, ku = 40, 3, 2
    A = np.zeros((size, size))
    for i in range(size):
        for j in range(max(0, i - kl), min(size, i + ku + 1)):
            A[i, j] = rng.standard_normal()
    A += 4 * np.eye(size)
    perm = rng.permutation(size)               # the ordering the kernels undo
    iperm = np.empty(size, np.int64)
    iperm[perm] = np.arange(size)
    B = A[np.ix_(iperm, iperm)]               # unknown i is row iperm[i] of A
    R, C = np.nonzero(B)
    V = B[R, C]
    plan = LinearSolverPlan("banded", "test", iperm, iperm, kl, ku, 1, K.lapack_band_addresses())
    lin = plan.workspace(size, 1)
    assert K._factor(K.BANDED, lin, R, C, V, len(R)) == K.CONVERGED
    r = rng.standard_normal(size)
    dw = np.empty(size)
    K._solve(K.BANDED, lin, r, dw)
    assert np.abs(dw - np.linalg.solve(B, r)).max() < 1e-12 * np.abs(dw).max()
    # a zero column is singular, a non-finite entry is reported as such
    keep = C != 5
    assert K._factor(K.BANDED, lin, R[keep], C[keep], V[keep], int(keep.sum())) == K.SINGULAR
    V[0] = np.nan
    assert K._factor(K.BANDED, lin, R, C, V, len(R)) == K.NONFINITE


@pytest.mark.parametrize("size, kl, ku", [(60, 4, 4), (200, 2, 7), (30, 0, 3), (40, 3, 0),
                                          (1, 2, 2), (7, 5, 5)])
def test_band_substitution_is_lapacks_dgbtrs(size, kl, ku):
    """The kernels' band substitution on dgbtrf's factors gives LAPACK's
    dgbtrs result (scipy's, the same library) to rounding, on random band
    matrices that pivot, with the factors of a second block beside the first
    (HHT-SI2's split) and with no sub- or superdiagonal. Both run the
    reference algorithm's operations in its order; the optimized BLAS
    kernels LAPACK calls may fuse multiply-adds (OpenBLAS 0.3.30, scipy 1.17,
    differs in the last bits where older builds agreed bit for bit), and
    these random matrices are ill-conditioned (solutions up to 1e12), where
    back substitution grows that difference: agreement to 1e-12 of the
    largest entry (a wrong pivot or index is off by the entry's size)."""
    from scipy.linalg import lapack
    from mbdsl.integrators.compiled.band import _band_substitute
    rng = np.random.default_rng(size + 10 * kl + 100 * ku)
    ldab = 2 * kl + ku + 1
    ab = np.zeros((ldab, size))                    # LAPACK's band storage, column-major
    for j in range(size):
        for i in range(max(0, j - ku), min(size, j + kl + 1)):
            ab[kl + ku + i - j, j] = rng.standard_normal()
    lu, piv, info = lapack.dgbtrf(ab, kl, ku)
    assert info == 0
    if kl and size > 1:
        assert (piv != np.arange(size)).any()      # rows were interchanged
    b = rng.standard_normal(size)
    x_lapack, info = lapack.dgbtrs(lu, kl, ku, b, piv)
    assert info == 0
    AB = np.vstack([np.zeros((size, ldab)), lu.T])  # the kernels' (size x ldab) storage
    ipiv = np.concatenate([np.ones(size), piv + 1]).astype(np.int32)   # 1-based
    x = np.concatenate([np.full(size, 7.0), b])
    _band_substitute(AB, ipiv, x, size, size, kl, ku, size)
    assert np.max(np.abs(x[size:] - x_lapack)) <= 1e-12 * np.max(np.abs(x_lapack))
    assert (x[:size] == 7.0).all()                 # the other block untouched
    A = np.zeros((size, size))                     # and it solves the matrix
    for j in range(size):
        for i in range(max(0, j - ku), min(size, j + kl + 1)):
            A[i, j] = ab[kl + ku + i - j, j]
    assert np.abs(A @ x[size:] - b).max() < 1e-10 * max(1.0, np.abs(x_lapack).max())


@pytest.mark.parametrize("size, kd", [(4, 3), (50, 3), (60, 4), (200, 9), (30, 0), (1, 2),
                                      (7, 6)])
def test_band_cholesky_against_lapack_and_the_dense_solve(size, kd):
    """The kernels' band Cholesky (the output's index-1 multipliers) gives
    LAPACK's dpbtrf factor and dpbtrs solution to round-off on random SPD
    band matrices, solves the matrix, and refuses an indefinite one."""
    from scipy.linalg import lapack
    from mbdsl.integrators.compiled.band import (NO_RECIPROCAL, _band_cholesky,
                                                 _band_cholesky_solve)
    rng = np.random.default_rng(size + 10 * kd)
    A = np.zeros((size, size))
    for d in range(0, min(kd, size - 1) + 1):
        vals = rng.standard_normal(size - d)
        A += np.diag(vals, d) + (np.diag(vals, -d) if d else 0.0)
    A += (np.abs(A).sum(axis=1).max() + 1.0) * np.eye(size)     # diagonally dominant: SPD
    AB = np.zeros((size, kd + 1))                  # A(i, j), i <= j, at AB[j, kd + i - j]
    for j in range(size):
        for i in range(max(0, j - kd), j + 1):
            AB[j, kd + i - j] = A[i, j]
    U_lapack, info = lapack.dpbtrf(np.ascontiguousarray(AB.T))
    assert info == 0
    # the same matrix in the upper part of the band LU's storage (diagonal at dg =
    # kl + ku), below 3 other rows, and its right-hand side at an offset: the
    # condensed solver's use (``condensed._unit_groups``): the same factor, to the bit
    kl = kd + 2
    dg, off, boff = 2 * kl, 3, 5
    big = np.full((off + size, 3 * kl + 1), np.nan)
    big[off:, dg - kd:dg + 1] = AB
    zero = np.int64(0)
    assert _band_cholesky(AB, zero, size, kd, kd)
    assert np.allclose(AB, U_lapack.T, rtol=1e-13, atol=1e-13 * np.abs(U_lapack).max())
    assert _band_cholesky(big, np.int64(off), size, kd, dg)
    assert np.array_equal(big[off:, dg - kd:dg + 1], AB) and np.isnan(big[:off]).all()
    b = rng.standard_normal(size)
    x_lapack, info = lapack.dpbtrs(U_lapack, b)
    x = b.copy()
    _band_cholesky_solve(AB, zero, size, kd, kd, x, zero, NO_RECIPROCAL)
    assert np.allclose(x, x_lapack, rtol=1e-12, atol=1e-14)
    assert np.abs(A @ x - b).max() < 1e-12 * np.abs(A).max() * max(1.0, np.abs(x).max())
    y = np.concatenate([np.zeros(boff), b])
    _band_cholesky_solve(big, np.int64(off), size, kd, dg, y, np.int64(boff), NO_RECIPROCAL)
    assert np.array_equal(y[boff:], x)
    big[off:, dg + 1] = 1.0 / big[off:, dg]        # the reciprocals' column: products
    z = np.concatenate([np.zeros(boff), b])
    _band_cholesky_solve(big, np.int64(off), size, kd, dg, z, np.int64(boff), np.int64(dg + 1))
    assert np.allclose(z[boff:], x, rtol=1e-12, atol=1e-14)
    # the loop's operations in its order, run by the interpreter: equal to the bit,
    # also at kd = 3, whose sweeps are written out (``band._cholesky_solve_3``)
    w = b.copy()
    for j in range(size):
        acc = w[j]
        for k in range(max(0, j - kd), j):
            acc -= big[off + j, dg + k - j] * w[k]
        w[j] = acc * big[off + j, dg + 1]
    for j in range(size - 1, -1, -1):
        acc = w[j]
        for k in range(j + 1, min(size, j + kd + 1)):
            acc -= big[off + k, dg + j - k] * w[k]
        w[j] = acc * big[off + j, dg + 1]
    assert np.array_equal(z[boff:], w)
    if size > 1:                                   # indefinite: a negative pivot is refused
        AB2 = np.zeros_like(AB)
        AB2[:, kd] = 1.0
        AB2[-1, kd] = -1.0
        assert not _band_cholesky(AB2, zero, size, kd, kd)


def test_band_ordering_of_a_chain_and_the_automatic_choice():
    # a pendulum chain is a path graph: each link couples only to its neighbours,
    # so the reordered HHT-I3 matrix (3 coordinates + 2 multipliers per link) has a
    # band of about one link, whatever N; the slider crank is too small for a band
    for N in (12, 60):
        system, init = _system(MODELS / "pendulum_chain.mbd", N=N)
        rperm, cperm, kl, ku, blocks = band_ordering(system, make_method("hht-i3"), init.q)
        assert blocks == 1 and rperm is cperm
        assert sorted(rperm) == list(range(5 * N)) and 3 <= kl <= 6 and 3 <= ku <= 6
        # HHT-SI2 whole: about two links' unknowns; split: two blocks of one link's band
        _, _, kl2, ku2, _ = band_ordering(system, make_method("hht-si2"), init.q)
        assert 8 <= kl2 <= 14 and 8 <= ku2 <= 14
        rperm, cperm, kl, ku, blocks = band_ordering(system, make_method("hht-si2"), init.q,
                                                     split=True)
        assert blocks == 2 and 3 <= kl <= 6 and 3 <= ku <= 6
        assert sorted(rperm) == sorted(cperm) == list(range(10 * N))
        n, m = system.n, system.m             # a, lambda and R1, R4 in block 0
        assert cperm[:n].max() < n + m and cperm[2 * n:2 * n + m].max() < n + m
        assert rperm[2 * n + m:].max() < n + m and rperm[n:2 * n].min() >= n + m
        # HHT-ADD: equations paired with unknowns (E5 with a, E3 and E4 with psi)
        # before the ordering, so that its band is a few links wide too
        rperm, cperm, kl3, ku3, _ = band_ordering(system, make_method("hht-add"), init.q)
        assert sorted(rperm) == sorted(cperm) == list(range(13 * N))
        assert kl3 <= 16 and ku3 <= 16
    # "auto" eliminates the chain's coordinates one by one (its coordinate block is
    # diagonal: ``test_condensed``); HHT-ADD's additive form keeps the band LU
    plan = linear_solver_plan(system, make_method("hht-i3"), NewtonOptions(), init.q)
    assert plan.kind == "condensed" and plan.condensed.unit
    plan = linear_solver_plan(system, make_method("hht-add"), NewtonOptions(), init.q)
    assert plan.kind == "banded"
    crank, init = _system(MODELS / "slider_crank.mbd")
    assert linear_solver_plan(crank, make_method("hht-i3"), NewtonOptions(), init.q).kind == "dense"
    with pytest.raises(ValueError, match="compiled engine"):
        integrate(crank, make_method("hht-i3"), 0.01, 1e-3, initial=init, engine="numpy",
                  newton=NewtonOptions(linear_solver="banded"))


@pytest.mark.parametrize("model", ["compiled_elements.mbd", "all_elements.mbd",
                                   "sliding_elements.mbd", "friction_elements.mbd",
                                   "distance_elements.mbd", "coupler_elements.mbd"])
@pytest.mark.parametrize("first", [True, False])
@pytest.mark.parametrize("method", RECIPE_METHODS)
def test_kernel_newton_matrix_is_the_derivative_of_the_kernel_residual(method, first, model):
    # all_elements: drivers, a torque and a point force that are functions of time
    system, init = _system(VALID / model)
    m = make_method(method)
    ad = SparseAdapter(system, m)
    hist = m.start(system, init)
    if not first:        # a second state h later: BDF2's steady step (one-step methods: the same)
        s = hist[-1]
        later = type(s)(s.t + 1e-2, s.q + 1e-2 * s.v, s.v + 1e-2 * s.a, s.a, s.lam)
        later.extra.update(s.extra)       # mu, psi1; the cached force terms of the later state:
        later.extra["F"] = force_term(system, later.t, later.q, later.v, later.lam)
        later.extra["f"] = system.mass_solve(later.q, system.Q(later.t, later.q, later.v,
                                                                    later.lam))
        hist = [s, later]
    assert m.first_step(hist, 1e-2) == (first and method.startswith("nstiff"))
    ctx = ad.context(system, hist, hist[-1].t + 1e-2, 1e-2)
    rng = np.random.default_rng(3)
    w = m.predict(ctx) + 0.1 * rng.standard_normal(ad.size)
    J = ad.jacobian(w, ctx).toarray()
    scale = np.abs(J).max()
    assert np.abs(J - residual_differences(ad, w, ctx, 1e-6)).max() < 1e-6 * scale
    # and the kernel residual is the numpy residual (HHT-ADD: rows 1, 2 and 5 times M)
    ref = rigid_residual_in_kernel_rows(system, m, w, ctx)
    assert np.allclose(ad.residual(w, ctx), ref, rtol=1e-12, atol=1e-10 * scale)


@pytest.mark.parametrize("path, overrides", FLEXIBLE)
@pytest.mark.parametrize("first", [True, False])
@pytest.mark.parametrize("method", RECIPE_METHODS)
def test_kernel_newton_matrix_of_flexible_beams(method, first, path, overrides):
    # The FFR beam's M(q), (M x)_q, Q, Q_q and Q_v, and the elastic columns of the
    # joints on beam points: the kernel Newton matrix against differences of the
    # kernel residual, and both against the numpy engine's (the methods' numpy
    # assembly; the joints' vectorised groups; the beams' blocks from the kernels,
    # which ``tests/flexible/test_beam_kernels.py`` checks against an independent
    # oracle). The second comparison is the sharp one: a sign flipped in one mixed
    # (phi, q_f) entry of a joint's Hessian moves the matrix by 1e-7 of its largest
    # entry, inside the differences' tolerance, 1e10 times the round-off the two
    # engines agree to.
    system, init = _system(path, **overrides)
    m = make_method(method)
    ad = SparseAdapter(system, m)
    hist = m.start(system, init)
    if not first:
        s = hist[-1]
        later = type(s)(s.t + 1e-2, s.q + 1e-2 * s.v, s.v + 1e-2 * s.a, s.a, s.lam)
        later.extra.update(s.extra)
        later.extra["F"] = force_term(system, later.t, later.q, later.v, later.lam)
        later.extra["f"] = system.mass_solve(later.q, system.Q(later.t, later.q, later.v,
                                                                    later.lam))
        hist = [s, later]
    ctx = ad.context(system, hist, hist[-1].t + 1e-2, 1e-2)
    w = m.predict(ctx) + 0.1 * np.random.default_rng(5).standard_normal(ad.size)
    J = ad.jacobian(w, ctx).toarray()
    err = np.full_like(J, np.inf)
    # HHT-ADD's M_b^-1 products: a truncation error of 1.2e-6 at the step 1e-6 on the
    # flexible slider crank, a round-off error of 1.1e-5 there on flexible_elements (7e-7
    # at 1e-5): each entry against the closer of the two differences
    for rel in ((1e-6, 1e-5) if method == "hht-add" else (1e-6,)):
        err = np.minimum(err, np.abs(J - residual_differences(ad, w, ctx, rel)))
    scale = np.abs(J).max()
    assert err.max() < (1e-5 if method == "hht-add" else 1e-6) * scale
    # HHT-ADD: rows 1, 2 and 5 times the rigid bodies' masses (a constant diagonal), a
    # beam's rows as they are; the M_b^-1 products make its round-off larger
    d, tol = np.ones(ad.size), 1e-13
    if method == "hht-add":
        n, m2, tol = system.n, system.m, 1e-10
        rigid = system.mass_diag.copy()
        rigid[np.concatenate([s.cols.ravel() for s in system.beam_sets])] = 1.0
        for r0 in (0, n, 2 * n + 2 * m2):
            d[r0:r0 + n] = rigid
    Jn = m.jacobian(w, ctx)
    Jn = Jn.toarray() if hasattr(Jn, "toarray") else np.asarray(Jn)
    assert np.abs(J - d[:, None] * Jn).max() < tol * scale
    ref = d * m.residual(w, ctx)
    assert np.abs(ad.residual(w, ctx) - ref).max() < tol * max(1.0, np.abs(ref).max())


#: Flexible models against DOP853: beams 10^4 times softer than the test models'
#: (E / 1e4), whose elastic modes DOP853, an explicit method, can follow at 1e-12.
SOFT = [MODELS / "flexible_slider_crank.mbd", VALID / "flexible_joints.mbd",
        VALID / "flexible_elements.mbd"]


def _soft_system(path):
    """The model at path with every Young's modulus divided by 1e4 (the
    beams' ``E`` entries and the slider crank's parameter E)."""
    import re
    text = re.sub(r"\bE (\d[\d.e+-]*)", lambda g: f"E {float(g.group(1)) / 1e4:.6g}",
                  path.read_text())
    model = mbdsl.load_text(text, file=str(path),
                            overrides={"E": 2e5} if path.stem == "flexible_slider_crank" else None)
    system = mbdsl.assemble(model)
    return system, mbdsl.consistent_initial_state(system)


@pytest.fixture(scope="module")
def soft_references():
    """{path: (system, initial state, q at T = 0.1 s)}: DOP853 at 1e-12 on the
    index-1 equations of the soft beams (numpy assembly)."""
    from mbdsl.studies.index1 import index1_reference
    refs = {}
    for path in SOFT:
        system, init = _soft_system(path)
        refs[path] = (system, init, index1_reference(system, [0.1], initial=init).q[-1])
    return refs


def _errors(system, init, q_ref, method, steps=(1e-3, 5e-4)):
    """max |q(T) - q_ref| of compiled runs at each h of steps."""
    out = []
    for h in steps:
        sol = integrate(system, method, 0.1, h, initial=init, engine="compiled")
        assert sol.engine == "compiled" and sol.status == "completed"
        out.append(np.abs(sol.q[-1] - q_ref).max())
    return np.array(out)


@pytest.mark.parametrize("method", [m for m in RECIPE_METHODS if m != "hht-i3"])
@pytest.mark.parametrize("path", SOFT)
def test_flexible_beams_converge_to_the_dop853_reference(soft_references, path, method):
    """The floating frame of reference in the kernels (mass matrix, quadratic
    velocity vector, elastic forces, joints, springs and forces on beam
    points) against DOP853: q(0.1 s) errors at h = 1 and 0.5 ms falling by
    2^p (measured 3.86-4.05 for order 2, 2.05-2.33 for NEWMARK), at most
    7e-4 at 0.5 ms. HHT-I3: the next test."""
    system, init, q_ref = soft_references[path]
    e = _errors(system, init, q_ref, make_method(method))
    low, high = (1.6, 2.6) if make_method(method).order(system) == 1 else (3.5, 4.5)
    assert low < e[0] / e[1] < high, e
    assert e[1] < 2e-3, e


def test_hht_i3_is_of_order_one_on_flexible_beams_unless_alpha_is_zero(soft_references):
    """HHT-I3's residual takes M(q_{n+1}) a_{n+1}, where a_{n+1} approximates
    the acceleration at t_n + (1 + alpha) h (docs/methods.md): with a mass
    matrix that changes with q (a flexible beam) the mismatch is O(alpha h),
    and the method falls to order 1 as h -> 0 (HHT-SI2 takes M at that
    mid-step configuration and keeps order 2, as the test above shows). With
    alpha = 0 (Newmark's trapezoidal rule) it is of order 2. Measured on the
    soft flexible_elements: alpha = 0 ratios 4.00, 4.01; alpha = -0.3 1.90,
    1.95."""
    system, init, q_ref = soft_references[VALID / "flexible_elements.mbd"]
    steps = (1e-3, 5e-4, 2.5e-4)
    e0 = _errors(system, init, q_ref, make_method("hht-i3", alpha=0.0), steps)
    e3 = _errors(system, init, q_ref, make_method("hht-i3", alpha=-0.3), steps)
    assert np.all((e0[:-1] / e0[1:] > 3.6) & (e0[:-1] / e0[1:] < 4.4)), e0
    assert np.all((e3[:-1] / e3[1:] > 1.7) & (e3[:-1] / e3[1:] < 2.3)), e3


@pytest.fixture(scope="module")
def soft_distance_reference():
    """(system, initial state, q at T = 0.1 s) of flexible_distance with its
    beams' E / 1e4: DOP853 at 1e-12 on the index-1 equations."""
    from mbdsl.studies.index1 import index1_reference
    system, init = _soft_system(VALID / "flexible_distance.mbd")
    return system, init, index1_reference(system, [0.1], initial=init).q[-1]


@pytest.mark.parametrize("method", [m for m in RECIPE_METHODS if m != "hht-i3"])
def test_distance_joints_on_beams_converge_to_the_dop853_reference(soft_distance_reference,
                                                                   method):
    """Distance joints between beam points (their elastic Hessian and G
    blocks) against DOP853, as the test above, at h = 0.5 and 0.25 ms: at 1
    and 0.5 ms the soft model is not yet in the asymptotic range (ratios
    3.49-3.58). Measured: order 2 ratios 3.70-4.08, NEWMARK 1.97; errors at
    0.25 ms 0.9e-3 to 5e-3 (NEWMARK 0.04)."""
    system, init, q_ref = soft_distance_reference
    m = make_method(method)
    e = _errors(system, init, q_ref, m, steps=(5e-4, 2.5e-4))
    low, high = (1.6, 2.6) if m.order(system) == 1 else (3.5, 4.5)
    assert low < e[0] / e[1] < high, e
    assert e[1] < (0.08 if m.order(system) == 1 else 1e-2), e


def test_the_compiled_loop_halves_a_failed_step_as_the_driver_says(soft_distance_reference,
                                                                   handed_over):
    """NSTIFF-SI2 on the soft flexible_distance at h = 0.5 ms: the compiled
    loop's modified Newton fails twice (t = 0.0725 and 0.0765 s); the kernels
    return there and the driver's ``StepSizes`` halves the step, which the
    compiled loop takes, at the reduced size, BDF2 going on at the ratio of
    the steps, until it grows back: no step goes to the driver's loop, two
    rejected, four rows more (measured). Its q(0.1 s) is as close to DOP853's
    as the driver's loop's on the same kernels, whose own Newton took those
    steps whole (measured 0.01345 against 0.01438). The compiled loop starts
    each step from the last state's values here (``NewtonOptions.start``):
    from its default extrapolated start it takes those two steps whole."""
    system, init, q_ref = soft_distance_reference
    last = NewtonOptions(start="last")
    a = integrate(system, make_method("nstiff-si2"), 0.1, 5e-4, initial=init,
                  engine="compiled", python_loop=True, newton=last)
    b = integrate(system, make_method("nstiff-si2"), 0.1, 5e-4, initial=init,
                  engine="compiled", newton=last)
    assert not handed_over and b.engine == "compiled" and b.status == "completed"
    assert b.stats_total.rejected == 2 and len(b.t) == len(a.t) + 4
    halved = np.isclose(b.stats["h"], 2.5e-4)
    assert halved.sum() == 8                # two halvings, four steps each before growing
    assert np.abs(b.q[-1] - q_ref).max() < 1.05 * np.abs(a.q[-1] - q_ref).max()


def test_a_two_step_method_handed_to_the_fallback_goes_on_with_bdf2(soft_distance_reference,
                                                                    handed_over):
    """The same run with no halving allowed (max_halvings = 0): each step
    the compiled loop's modified Newton cannot converge goes to the Python
    stepper on the same kernels, which takes it with its own Newton, and
    the run goes back to the compiled loop (three, measured). It goes on
    from the loop's previous state too (BDF2, as the Python stepper run
    alone does): the whole run equals the Python stepper's on the same
    kernels to 1e-8 (measured 1.6e-10). Restarted with a BDF1 step there,
    it ended 2e-3 away. (The last state's start, as above.)"""
    system, init, _ = soft_distance_reference
    last = NewtonOptions(start="last")
    a = integrate(system, make_method("nstiff-si2"), 0.1, 5e-4, initial=init,
                  engine="compiled", python_loop=True, max_halvings=0, newton=last)
    b = integrate(system, make_method("nstiff-si2"), 0.1, 5e-4, initial=init,
                  engine="compiled", max_halvings=0, newton=last)
    assert len(handed_over) == 3 and b.linear_solver == "dense" and b.status == "completed"
    assert b.stats_total.rejected == a.stats_total.rejected + 3
    assert len(b.t) == len(a.t) and np.abs(b.q - a.q).max() < 1e-8


def test_with_error_control_the_fallback_takes_one_step_and_hands_the_run_back(
        soft_distance_reference, handed_over, monkeypatch):
    """The same model and failures under error control with h_min = h_max =
    0.5 ms (no smaller step to try): each step the compiled loop cannot
    converge goes to the Python stepper, which takes that one step and
    hands the run back with the size it planned next, instead of taking
    the rest of the run (three hand-overs of one step each, measured); the
    run equals the Python stepper alone to 1e-8 (measured 1.6e-10). (The
    last state's start, as above.)"""
    system, init, _ = soft_distance_reference
    last = NewtonOptions(start="last")
    from mbdsl.integrators.python_stepper import PythonStepper
    advance, steps = PythonStepper.advance, []

    def counted(self, loop, mode, h, limit):
        status, taken = advance(self, loop, mode, h, limit)
        if loop.stepper is loop.fallback:
            steps.append(taken)
        return status, taken
    monkeypatch.setattr(PythonStepper, "advance", counted)
    # a tolerance every step of 0.5 ms meets (per unit step: 1e-3 m of local error per
    # step of 0.5 ms is 2 per second), so that only Newton's failures matter here
    control = StepControl(rtol=5.0, atol=5.0, h_min=5e-4, h_max=5e-4)
    a = integrate(system, make_method("nstiff-si2"), 0.1, 5e-4, initial=init,
                  engine="compiled", python_loop=True, control=control, newton=last)
    assert not steps and not handed_over
    b = integrate(system, make_method("nstiff-si2"), 0.1, 5e-4, initial=init,
                  engine="compiled", control=control, newton=last)
    assert len(handed_over) == 3 and steps == [1, 1, 1]
    assert b.engine == "compiled" and b.status == "completed"
    assert len(b.t) == len(a.t) and np.abs(b.q - a.q).max() < 1e-8


@pytest.mark.parametrize("path", [MODELS / "slider_crank_driven.mbd", MODELS / "double_pendulum.mbd",
                                  VALID / "all_elements.mbd", VALID / "friction_elements.mbd",
                                  VALID / "flexible_joints.mbd"])
def test_index1_multipliers_of_the_kernels_are_the_systems_dense_solves(path):
    # the output's Lagrange multipliers of HHT-ADD: [[M, Phi_q^T], [Phi_q, 0]] [a; lambda]
    # = [Q; gamma] row by row in a kernel, against the system's per-row dense solve
    # (numpy's LU) on the rows of a run (drivers' Phi_tt, friction's fixed point on
    # lambda, beams' M(q))
    from mbdsl.integrators import compiled, kernel_cache
    from mbdsl.integrators.engine import index1_multipliers
    kernel_cache.ensure_loaded("dense")
    # Rigid bodies take the Schur complement Phi_q M^-1 Phi_q^T in a band Cholesky
    # (``engine._index1_band``), beams the dense index-1 matrix; both are checked here.
    system, init = _system(path)
    sol = integrate(system, make_method("hht-i3"), 0.05, 1e-3, initial=init, engine="numpy",
                    output_every=5)
    a = system.index1_multipliers(sol.t, sol.q, sol.v)
    b = index1_multipliers(system, sol.t, sol.q, sol.v)
    assert (engine_module._index1_band(system) is None) == ("flexible" in path.name)
    assert np.isfinite(a).all()
    assert np.abs(a - b).max() < 1e-10 * max(1.0, np.abs(a).max())
    # and they are the multipliers the index-3 run converged to, to its O(h^2) accuracy
    assert np.abs(b - sol.lam).max() < 1e-2 * max(1.0, np.abs(sol.lam).max())
    # with the accelerations they give (the band kernel's own from its Phi_q and Q; for
    # beams the system's): the system's M a = Q - Phi_q^T lambda, evaluated in numpy
    b2, acc = index1_multipliers(system, sol.t, sol.q, sol.v, accelerations=True)
    assert np.array_equal(b2, b)
    ref = system.accelerations(sol.t, sol.q, sol.v, b)
    assert np.abs(acc - ref).max() < 1e-12 * max(1.0, np.abs(ref).max())
    cm = CompiledModel(system)
    R, C = np.empty(cm.bound, np.int64), np.empty(cm.bound, np.int64)
    if system.mass_is_constant:    # the dense kernel on rigid bodies too: the same multipliers
        dense = np.empty_like(b)
        compiled.index1_multipliers(cm.ints, cm.floats, sol.t, sol.q, sol.v, dense, R, C,
                                    np.empty(cm.bound), system.FRICTION_ITERATIONS)
        assert np.abs(dense - b).max() < 1e-10 * max(1.0, np.abs(a).max())
    # a singular matrix gives NaN for its row, not an exception (both kernels)
    bad_q, zero_v = np.full((1, system.n), np.nan), np.zeros((1, system.n))
    out = np.empty((1, system.m))
    compiled.index1_multipliers(cm.ints, cm.floats, np.zeros(1), bad_q, zero_v, out, R, C,
                                np.empty(cm.bound), 5)
    assert np.isnan(out).all()
    if system.mass_is_constant:
        out[:] = 0.0
        acc = np.zeros((1, system.n))
        compiled.index1_multipliers_band(cm.ints, cm.floats, np.zeros(1), bad_q, zero_v, out, R,
                                         C, np.empty(cm.bound), 5,
                                         *engine_module._index1_band(system), acc)
        assert np.isnan(out).all() and np.isnan(acc).all()


def test_index1_multipliers_of_redundant_joints_are_nan_in_the_band_kernel():
    # Phi_q M^-1 Phi_q^T of a parallelogram with a redundant link is singular, but round-off
    # leaves its last Cholesky pivot at 3e-15 of the largest, which LAPACK accepts: the
    # kernel must refuse it (NaN rows), not return one of the many lambda
    from mbdsl.integrators import compiled, kernel_cache
    kernel_cache.ensure_loaded("dense")
    model = mbdsl.load(MODELS / "parallelogram_redundant.mbd")
    system = mbdsl.assemble(model)
    rows, cols = system.pattern_Phi_q
    q = mbdsl.consistent_initial_state(system, redundant="accept").q
    Pq = np.zeros((system.m, system.n))
    np.add.at(Pq, (rows, cols), system.Phi_q_values(q, 0.0))
    assert np.linalg.matrix_rank(Pq) < system.m          # the premise: redundant rows
    cm = CompiledModel(system)
    R, C = np.empty(cm.bound, np.int64), np.empty(cm.bound, np.int64)
    out = np.zeros((1, system.m))
    acc = np.zeros((1, system.n))
    compiled.index1_multipliers_band(cm.ints, cm.floats, np.zeros(1), q[None, :],
                                     np.zeros((1, system.n)), out, R, C, np.empty(cm.bound),
                                     5, *engine_module._index1_band(system), acc)
    assert np.isnan(out).all() and np.isnan(acc).all()


def test_output_stride_keeps_every_kth_step_and_the_last():
    system, init = _system(MODELS / "double_pendulum.mbd")
    for engine in ("compiled", "numpy"):
        full = integrate(system, make_method("hht-i3"), 0.105, 1e-3, initial=init, engine=engine)
        part = integrate(system, make_method("hht-i3"), 0.105, 1e-3, initial=init, engine=engine,
                         output_every=10)
        assert len(part.t) == 1 + 10 + 1                    # t0, every 10th step, t_end
        assert part.t[-1] == 0.105 and full.t[-1] == 0.105
        assert np.allclose(part.t[1:-1], full.t[10:-1:10])
        assert np.abs(part.q[1:-1] - full.q[10:-1:10]).max() < 1e-12
        assert np.abs(part.q[-1] - full.q[-1]).max() < 1e-12
        assert part.stats_total.steps == full.stats_total.steps == 105
        assert part.stats_total.iterations == full.stats_total.iterations
        assert part.stats["iterations"][1:].sum() == full.stats["iterations"][1:].sum()


@pytest.mark.parametrize("control", [None, StepControl(rtol=1e-9, atol=1e-9, h_min=0.01)])
def test_a_failing_compiled_step_is_halved_by_the_driver(monkeypatch, control):
    # two full-Newton iterations cannot take the first step of the released pendulum:
    # the compiled loop returns, the driver halves the step (StepSizes) and the
    # compiled loop takes it at the reduced size, none handed to the driver's loop;
    # the numpy engine's run, with the same halvings, is the reference. With error
    # control and h_min = 0.01 s the step is out of reach: handed to the driver's
    # loop on the kernels' residual, which says why
    system, init = _system(MODELS / "pendulum.mbd")
    # the numpy engine's start: the last state's
    opt = NewtonOptions(max_iter=2, jacobian="full", start="last")
    a = integrate(system, make_method("hht-i3"), 1.0, 0.05, initial=init, engine="numpy",
                  newton=opt, on_failure="return", control=control)
    calls = []
    residual = SparseAdapter.residual

    def counted(self, w, ctx):
        calls.append(1)
        return residual(self, w, ctx)
    monkeypatch.setattr(SparseAdapter, "residual", counted)
    b = integrate(system, make_method("hht-i3"), 1.0, 0.05, initial=init, engine="compiled",
                  newton=opt, on_failure="return", control=control)
    assert b.engine == "compiled"
    if control is not None:   # out of reach at h_min: the driver's loop says why, as numpy's
        assert calls, "the failed step was not handed to the driver's loop on the kernels"
        assert b.status == a.status == "failed" and b.message == a.message
        assert b.diagnostics[0].code == "E602"
        return
    assert not calls
    assert b.stats_total.rejected == a.stats_total.rejected > 0
    assert b.status == a.status == "completed" and len(b.t) == len(a.t)
    assert np.any(b.stats["h"][1:] < 0.05)
    np.testing.assert_allclose(b.t, a.t, rtol=0, atol=1e-12)
    assert b.t[-1] == 1.0 and np.abs(a.q - b.q).max() < 1e-8


def test_the_compiled_loop_tells_progress_and_observers_what_it_recorded():
    # the rows are buffered across the kernels' calls and go out together: the
    # progress callback is told the mean Newton iterations per step of the steps
    # since it was last called (the run's 6021 iterations over 2000 steps: 3),
    # not the run's total so far, and an observer is told of every row once, in
    # order: on_start with the initial row, contiguous on_rows, on_end at the end
    from mbdsl.io.observers import RunObserver
    system, init = _system(MODELS / "slider_crank.mbd")
    told, seen = [], []

    class Watcher(RunObserver):
        def on_start(self, sol):
            seen.append(("start", sol.n_rows))

        def on_rows(self, sol, start, stop):
            seen.append((start, stop))

        def on_end(self, sol):
            seen.append(("end", len(sol.t)))

    sol = integrate(system, make_method("hht-i3"), 2.0, 1e-3, initial=init, engine="compiled",
                    progress=lambda t, h, it: told.append((t, h, it)), observers=[Watcher()])
    assert sol.engine == "compiled" and sol.status == "completed"
    tot = sol.stats_total
    assert tot.steps == 2000 and 2.5 < tot.iterations / tot.steps < 3.5
    assert told and told[-1][0] == 2.0 and told[-1][1] == pytest.approx(1e-3)
    assert all(1 <= it <= 8 for _, _, it in told), told
    if len(told) == 1:
        assert told[0][2] == round(tot.iterations / tot.steps)
    assert seen[0] == ("start", 1) and seen[-1] == ("end", 2001) == ("end", len(sol.t))
    ranges = seen[1:-1]
    assert ranges and ranges[0][0] == 1 and ranges[-1][1] == 2001
    assert all(a[1] == b[0] and a[0] < a[1] for a, b in zip(ranges, ranges[1:] + [(2001,)]))


def test_ctrl_c_reaches_a_compiled_run_that_records_every_500th_step(monkeypatch):
    # the compiled loop takes CHUNK (2000) steps in a call at most, whatever the
    # output stride: an interrupt raised by the progress callback (told after
    # every call here) once t >= 1 s ends the 6 s run at the first call's end,
    # t = 2 s, not at t_end; the rows are the uninterrupted run's, bit for bit
    monkeypatch.setattr(loop_module, "FLUSH_INTERVAL", 0.0)
    system, init = _system(MODELS / "slider_crank.mbd")
    full, cut = interrupted_run(system, 6.0, 1.0, initial=init, engine="compiled",
                                output_every=500)
    assert full.status == "completed" and cut.status == "interrupted"
    np.testing.assert_allclose(cut.t, [0.0, 0.5, 1.0, 1.5, 2.0], rtol=0, atol=1e-12)
    assert np.array_equal(cut.q, full.q[:5]) and np.array_equal(cut.lam, full.lam[:5])


def test_when_the_rows_go_out_does_not_change_them(monkeypatch):
    # the compiled loop's rows go to the Solution every FLUSH_INTERVAL of wall
    # time; the steps must not depend on it (a kernel call starts a new Newton
    # matrix, so where the calls end must follow from the steps alone): the
    # clearance slider crank, whose contact events make the loop return 40 times
    # in 0.1 s, with rows sent after every call and never before the end
    system, init = _system(MODELS / "slider_crank_clearance.mbd")
    runs = []
    for interval in (0.0, np.inf):
        monkeypatch.setattr(loop_module, "FLUSH_INTERVAL", interval)
        runs.append(integrate(system, make_method("hht-i3"), 0.1, 1e-4, initial=init,
                              engine="compiled", control=StepControl(rtol=1e-6, atol=1e-6)))
    a, b = runs
    assert a.engine == b.engine == "compiled" and a.status == b.status == "completed"
    assert len(a.events) > 5 and a.events == b.events
    assert np.array_equal(a.t, b.t) and np.array_equal(a.q, b.q)
    assert np.array_equal(a.stats["iterations"], b.stats["iterations"])


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_a_run_steps_on_one_blas_thread_and_gives_the_threads_back(engine):
    # a threaded BLAS on a step's small Newton matrices only waits for cores
    # (mbdsl.integrators.blas_threads): within the run every BLAS library runs one
    # thread, seen from the run's own progress callback; after it, the count the
    # caller had set
    from threadpoolctl import threadpool_info, threadpool_limits
    system, init = _system(MODELS / "slider_crank.mbd")
    inside = []

    def progress(t, h, iterations):
        inside.extend(lib["num_threads"] for lib in threadpool_info()
                      if lib["user_api"] == "blas")

    with threadpool_limits(limits=2, user_api="blas"):
        sol = integrate(system, make_method("hht-i3"), 0.05, 1e-3, initial=init,
                        engine=engine, progress=progress)
        after = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
    assert sol.status == "completed" and sol.engine == engine
    assert inside and set(inside) == {1}
    assert after and set(after) == {2}


def test_engine_selection_says_why(monkeypatch):
    flex, _ = _system(MODELS / "flexible_slider_crank.mbd")
    assert all(unsupported(flex, make_method(m)) is None for m in RECIPE_METHODS)
    rigid, init = _system(MODELS / "slider_crank.mbd")
    assert all(unsupported(rigid, make_method(m)) is None for m in RECIPE_METHODS)
    for name in ("flexible_elements.mbd", "flexible_distance.mbd"):   # elements on beam points
        assert unsupported(_system(VALID / name)[0], make_method("hht-i3")) is None
    assert select_engine("auto", flex, make_method("hht-add")) == "compiled"
    assert select_engine("auto", rigid, make_method("hht-i3")) == "compiled"
    # an element without a kernel (none is left among the language's): said, and numpy
    monkeypatch.setattr(engine_module, "_unsupported_elements",
                        lambda system: "no kernel for a NewGroup")
    assert unsupported(rigid, make_method("hht-i3")) == "no kernel for a NewGroup"
    assert select_engine("auto", rigid, make_method("hht-i3")) == "numpy"
    with pytest.raises(ValueError, match="NewGroup"):
        integrate(rigid, make_method("hht-i3"), 0.01, 1e-3, initial=init, engine="compiled")
    monkeypatch.undo()
    with pytest.raises(ValueError, match="unknown engine"):
        integrate(rigid, make_method("hht-i3"), 0.01, 1e-3, initial=init, engine="fast")
    with pytest.raises(ValueError, match="output_every"):
        integrate(rigid, make_method("hht-i3"), 0.01, 1e-3, initial=init, output_every=0)
    timed, _ = _system(VALID / "all_elements.mbd")      # functions of time are compiled
    assert unsupported(timed, make_method("hht-i3")) is None


def test_packed_model_data_round_trips():
    from mbdsl.integrators import compiled
    system, _ = _system(VALID / "compiled_elements.mbd")
    cm = CompiledModel(system)
    fields = compiled.unpack(cm.ints, cm.floats)
    assert set(fields) == set(compiled.MODEL_FIELDS)
    assert np.array_equal(fields["mass"], system.mass_diag)
    assert fields["crow"].shape == (3, 2) and fields["prow"].shape == (4,)
    assert [list(r) for r in fields["pfn"]].count([-1, -1, -1]) == 3    # D3 is the fourth row
    assert fields["spar"].shape == (3, 5) and fields["n_elements"] == system.layout.n_elements
    assert np.all(fields["spar"][:, 3:] == 0.0)        # no spring direction held at the start
    # T2 reads J6.angle, J6.rate, a.omega, c.phi; T3 d.omega, b.x, e.vy: 7 variables,
    # 2 torques of the state with one partial derivative per variable they read
    assert fields["var"].shape == (7, 4) and fields["stq"].shape == (2, 4)
    assert fields["sdv"].shape == (7, 3) and fields["xval"].shape == (7,)
    J6 = [k for k in range(7) if fields["var"][k, 0] == 0 and fields["varc"][k, 1] == -1.0]
    assert len(J6) == 1           # J6.angle = f.phi - b.phi, no sliding line
    assert list(fields["var"][J6[0], 1:]) == [3 * 5 + 2, 3 * 1 + 2, -1]
    assert fields["geo"].shape == (0, 6)
    # sliding_elements: three joint forces on three lines, and the distances and
    # speeds read on them: each line packed once
    sliding, _ = _system(VALID / "sliding_elements.mbd")
    f2 = compiled.unpack(*(lambda c: (c.ints, c.floats))(CompiledModel(sliding)))
    assert f2["geo"].shape == (3, 6) and list(f2["stq"][:, 3]) .count(-1) == 1


def test_a_failed_split_si2_step_goes_on_with_the_whole_band_matrix():
    # two full-Newton iterations cannot take a 20 ms step of the released chain: the
    # split loop stops, the numpy engine halves the step, the loop resumes unsplit
    system, init = _system(MODELS / "pendulum_chain.mbd", N=15)
    opt = NewtonOptions(max_iter=2, jacobian="full", linear_solver="banded")
    b = integrate(system, make_method("hht-si2"), 0.2, 0.02, initial=init, engine="compiled",
                  newton=opt, on_failure="return")
    a = integrate(system, make_method("hht-si2"), 0.2, 0.02, initial=init, engine="numpy",
                  newton=NewtonOptions(max_iter=2, jacobian="full"), on_failure="return")
    assert b.stats_total.rejected > 0 and b.status == a.status == "completed"
    assert "whole band matrix" in b.linear_solver_note
    assert b.t[-1] == 0.2 and np.abs(a.q[-1] - b.q[-1]).max() < 1e-8


@pytest.mark.parametrize("expr", ["0.3*cos(t)", "t^2/(1 + t) - 2^t", "exp(-t)*sin(3*t)",
                                  "sqrt(t) + log(1 + t) - atan(t)",
                                  "abs(sin(t)) - tanh(t) + cosh(t/5) - sinh(t/7)",
                                  "asin(t/10) + acos(t/10) + tan(t/4)", "-(t - 1)^3",
                                  "1/(t - 1)", "log(1.5 - t)",
                                  "clip(3*t - 1, -0.5, 2) + min(t, 1.2)*max(0.5, t^2)",
                                  "sign(t - 1)*t + abs(t - 1)",
                                  "if(t < 1, t^2, 2*t - 1) + (t >= 0.5) - 2*(t > 2.5)",
                                  "if(t <= 0.5, sqrt(0.5 - t), log(t - 0.5))"])
def test_compiled_functions_of_time_are_the_language_s(expr):
    # a torque f(t) evaluated by the kernels' postfix programs against the
    # language's own evaluation (compile_function), also where f is not finite
    from mbdsl.integrators import compiled
    text = f"""model f
body b {{ mass 2; inertia 0.1 }}
force T: torque(b, {expr})
"""
    system = mbdsl.assemble(mbdsl.load_text(text, file="<f>"))
    cm = CompiledModel(system)
    q = v = np.zeros(3)
    fn = system.model.forces[0].function
    for t in (0.0, 0.5, 1.0, 2.5):
        out = np.empty(3)
        compiled.force_term(cm.ints, cm.floats, t, q, v, np.zeros(0), out, np.zeros(6),
                            np.zeros(6), np.zeros(6))
        assert np.array_equal(-out[2], fn.f(t), equal_nan=True) or \
            -out[2] == pytest.approx(fn.f(t), rel=1e-14, abs=1e-15)


def test_one_compiled_loop_serves_fixed_steps_error_control_and_events():
    """One compiled time loop (``compiled.run``) with one signature: after
    ``kernel_cache.warm_up`` of the dense group, a fixed-step run, an
    error-controlled one and a fixed-step run of a model with events
    (Andrews' spring with a free length) load no other library of it. A
    second signature (a second library for numba to load from its cache,
    0.15 s on the slider crank's command) counts 2."""
    from mbdsl.integrators import kernel_cache
    kernel_cache.ensure_loaded("dense")          # built, so that the child only loads
    code = ("import mbdsl\n"
            "from mbdsl.integrators import compiled, kernel_cache, integrate, make_method\n"
            "from mbdsl.integrators.adaptive import StepControl\n"
            "kernel_cache.warm_up(('dense',), output=False)\n"
            "print(len(compiled.run.signatures))\n"
            f"s = mbdsl.assemble(mbdsl.load({str(MODELS / 'slider_crank.mbd')!r}))\n"
            "r = [integrate(s, make_method('hht-i3'), 0.05, 1e-3, engine='compiled'),\n"
            "     integrate(s, make_method('nstiff'), 0.05, 1e-3, engine='compiled',\n"
            "               control=StepControl(1e-6, 1e-6))]\n"
            f"s = mbdsl.assemble(mbdsl.load({str(MODELS / 'andrews.mbd')!r}))\n"
            "r.append(integrate(s, make_method('hht-i3'), 1e-3, 1e-5, engine='compiled'))\n"
            "print(*[x.engine + '/' + x.status for x in r])\n"
            "print(len(compiled.run.signatures))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=600, cwd=Path(mbdsl.__file__).parents[1])
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["1"] + ["compiled/completed"] * 3 + ["1"]


COINCIDENT = """model coincident
gravity (0, -9.81)
body rod { mass 1; inertia 0.1; point O (-0.5, 0) }
joint O: revolute(ground.origin, rod.O)
force s: spring_damper(ground.origin, rod.O, k = 100, c = 1, length = 0)
initial rod.phi = 0.3
"""


def test_a_spring_between_coincident_points_has_no_force_in_the_kernels(monkeypatch):
    """A spring-damper whose points coincide (on the revolute joint's pin,
    exactly at the consistent start) has no direction: no force, as in the
    numpy oracle (``tests/assembly/force_oracle.py``). The kernels divided by l = 0,
    and the NaN sent every step to the numpy engine (1267 us/step against 6)."""
    from mbdsl.integrators import compiled, driver
    system = mbdsl.assemble(mbdsl.load_text(COINCIDENT))
    init = mbdsl.consistent_initial_state(system)
    cm = CompiledModel(system)
    qx, vx = np.zeros(system.n + 3), np.zeros(system.n + 3)
    qx[:system.n] = init.q
    Q = np.empty(system.n + 3)
    compiled.forces(cm.ints, cm.floats, 0.0, qx, vx, init.lam, Q)
    from ..assembly.force_oracle import ForceOracle
    want = ForceOracle(system).Q(0.0, init.q, np.zeros(system.n), init.lam)
    assert np.all(np.isfinite(Q)) and np.abs(Q[:system.n] - want).max() < 1e-12
    assert np.allclose(want, system.gravity_force)        # the spring: no force
    handed = []
    numpy_integrate = driver.integrate

    def watch(*args, **kw):
        """driver.integrate, noting the runs handed to the numpy engine."""
        handed.append(kw.get("engine"))
        return numpy_integrate(*args, **kw)
    monkeypatch.setattr(driver, "integrate", watch)
    a = integrate(system, make_method("hht-i3"), 0.2, 1e-3, initial=init, engine="numpy")
    b = integrate(system, make_method("hht-i3"), 0.2, 1e-3, initial=init, engine="compiled")
    assert handed == [] and b.engine == "compiled"        # no step handed to the numpy engine
    assert np.abs(a.q - b.q).max() < 1e-10


_FREE_FALL = """model free_fall
gravity (0, -9.81)
particle ball { mass 2 }
initial ball.y = 3
initial ball.vx = 0.5
"""


@pytest.mark.parametrize("solver", ["dense", "banded", "sparse"])
@pytest.mark.parametrize("method", RECIPE_METHODS)
def test_a_model_without_constraints_steps_with_every_solver(method, solver):
    """A particle in free fall, no joint (m = 0): the methods with a second block
    of multipliers (mu of the stabilized index-2 methods, HHT-ADD's psi) carry
    empty blocks, whatever the linear solver (the sparse one's Python loop
    raised KeyError 'mu' at the first accepted step). The Newmark family
    integrates a constant acceleration exactly: y = 3 - g t^2/2, x = 0.5 t; the
    BDF methods too after their BDF1 start, whose O(g h^2) offset they carry."""
    system = mbdsl.assemble(mbdsl.load_text(_FREE_FALL))
    sol = integrate(system, make_method(method), 0.05, 1e-3, engine="compiled",
                    newton=NewtonOptions(linear_solver=solver))
    assert sol.status == "completed"
    t = np.asarray(sol.t)
    offset = 9.81 * 1e-3 ** 2 if method.startswith("nstiff") else 1e-12
    np.testing.assert_allclose(sol.q[:, 1], 3.0 - 9.81 * t ** 2 / 2, rtol=0, atol=offset)
    np.testing.assert_allclose(sol.q[:, 0], 0.5 * t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sol.v[-1], [0.5, -9.81 * 0.05], rtol=0, atol=1e-12)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
def test_observers_are_told_of_every_event_after_the_rows_before_it(engine):
    """The ball's impacts (contact closed, opened) reach an observer once each,
    in the Solution's order, each after the rows up to its time were told."""
    from mbdsl.io.observers import RunObserver
    events = []

    class Watcher(RunObserver):
        rows = None

        def on_start(self, sol):
            self.rows = sol.n_rows                # the initial row

        def on_rows(self, sol, start, stop):
            assert start == self.rows          # contiguous, none twice
            self.rows = stop

        def on_event(self, sol, event):
            assert self.rows >= 1 and sol.rows(self.rows - 1, self.rows)["t"][0] >= \
                event[0] - 1e-12
            events.append(event)

    model = mbdsl.load(MODELS / "bouncing_ball.mbd")
    sol = mbdsl.simulate(model, rtol=1e-6, t_end=1.0, engine=engine, observers=[Watcher()])
    assert sol.status == "completed"
    kinds = [e[2] for e in sol.events]
    assert "closed" in kinds and "opened" in kinds
    assert events == list(sol.events)


@pytest.mark.parametrize("path, overrides", [(MODELS / "pendulum_chain.mbd", {"N": 4}),
                                             (MODELS / "spatial_slider_crank.mbd", {}),
                                             (VALID / "all_elements.mbd", {}),
                                             (VALID / "compiled_elements.mbd", {}),
                                             (VALID / "flexible_distance.mbd", {})])
def test_phi_and_its_transpose_product_in_one_pass_are_the_two_passes(path, overrides):
    # the index-3 residual's joint terms: Phi and Phi_q^T lambda, the revolute joints'
    # rows in one pass (system.phi_phiqT_add), are phi's and phiqT_add's to the bit
    from mbdsl.kernels import system as kernels
    system, init = _system(path, **overrides)
    cm = CompiledModel(system)
    n, m = system.n, system.m
    rng = np.random.default_rng(5)
    qx, lam = np.zeros(n + 3), rng.standard_normal(m)
    qx[:n] = np.asarray(init.q, float) + 0.1 * rng.standard_normal(n)
    phi_two, f_two = np.full(m, np.nan), rng.standard_normal(n + 3)
    phi_one, f_one = np.full(m, np.nan), f_two.copy()
    kernels.phi(cm.ints, cm.floats, 0.3, qx, phi_two)
    kernels.phiqT_add(cm.ints, cm.floats, qx, lam, 1.0, f_two)
    kernels.phi_phiqT_add(cm.ints, cm.floats, 0.3, qx, lam, phi_one, f_one)
    assert np.array_equal(phi_one, phi_two) and np.array_equal(f_one, f_two)
    assert np.isfinite(phi_one).all() and m > 0


@pytest.mark.parametrize("method", ["hht-si2", "nstiff-si2", "genalpha-si2", "hht-i3"])
@pytest.mark.parametrize("path, overrides", [(MODELS / "spatial_chain.mbd", {"N": 3}),
                                             (MODELS / "spatial_slider_crank.mbd", {}),
                                             (VALID / "spatial_drivers.mbd", {}),
                                             (VALID / "compiled_elements.mbd", {}),
                                             (VALID / "flexible_distance.mbd", {})])
def test_the_residuals_products_in_one_pass_are_the_three_passes(path, overrides, method):
    # with a scratch of 2 (n + 3) the stabilized index-2 residual makes Phi_q^T lambda,
    # Phi_q^T mu and Phi_q v in one pass over the rows (system.phiq_products), with
    # n + 3 in three (phiqT_add twice, phiq_times): the same sums in the same order,
    # so the same numbers to the bit, in every row
    system, init = _system(path, **overrides)
    cm = CompiledModel(system)
    n, m = system.n, system.m
    meth = make_method(method)
    size = newton_size(system, meth)
    rng = np.random.default_rng(11)
    w = rng.standard_normal(size)
    rec = meth.kernel_recipe(1e-3, False)
    out = []
    for width in (n + 3, 2 * (n + 3)):
        r, qx = np.empty(size), np.zeros(n + 3)
        assert cm.K.residual(rec, cm.ints, cm.floats, 0.1, np.asarray(init.q, float),
                             np.asarray(init.v, float) + 0.5,
                             np.zeros(n), qx.copy(), w, r, qx, np.zeros(n + 3), np.zeros(width))
        out.append(r)
    assert np.array_equal(out[0], out[1])
    assert np.abs(out[0]).max() > 0.0
