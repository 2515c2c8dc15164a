"""The applied loads' one implementation, the kernels (called from Python
through ``AssembledSystem.Q``, ``force_derivatives``, ``Q_lam``,
``potential_energy``, ``power``, ``spring_separations``, ``contact_gaps``
and ``friction_speeds``), against an independent numpy evaluation of the
same equations (``force_oracle.ForceOracle``) at random states, on every
shipped model and every valid test model with loads, on the compiled
kernels and on their uncompiled copy.

The finite-difference checks of Q_q, Q_v and Q_lambda against Q are in
``test_derivatives.py`` and ``tests/contact``; this test pins the values
themselves (a wrong stiffness, sign or missing term that every derivative
shares).
"""

import warnings

import numpy as np
import pytest

import mbdsl

from .force_oracle import ForceOracle
from .kernel_models import FILES, ROOT, kernels, system_on  # noqa: F401 (a fixture)

def _close(got, want, rel=1e-12):
    scale = max(1.0, float(np.abs(want).max(initial=0.0)))
    assert np.shape(got) == np.shape(want)
    assert np.abs(np.asarray(got) - want).max(initial=0.0) <= rel * scale


def _with_loads(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return bool(mbdsl.assemble(mbdsl.load(path)).has_loads)


LOADED = [p for p in FILES if _with_loads(p)]


def _drivers_power(system, q, t, lam):
    """lambda . Phi_t: the power the drivers put in (``AssembledSystem.power``
    adds it to the loads')."""
    return float(lam @ system.Phi_t(q, t)) if system.m else 0.0


@pytest.mark.parametrize("path", LOADED, ids=lambda p: f"{p.parent.name}/{p.stem}")
def test_load_kernels_match_the_numpy_oracle(path, kernels):
    system = system_on(path, kernels)
    o = ForceOracle(system)
    g = system.contact_state
    rng = np.random.default_rng(len(path.stem))
    n, m = system.n, system.m
    for t in (0.0, 0.37, 1.9):
        q = rng.normal(scale=0.4, size=n)
        v, a = rng.normal(size=(2, n))
        lam = rng.normal(size=m)
        speeds = None
        if g is not None:          # some gaps armed, some not
            k = len(g.names)
            g.impact_speed[:] = np.where(rng.random(k) < 0.5, 0.0, rng.uniform(0.1, 3.0, k))
            speeds = g.impact_speed.copy()
        _close(system.Q(t, q, v, lam), o.Q(t, q, v, lam))
        Qq, Qv = system.force_derivatives(t, q, v, lam)
        Oq, Ov = o.derivatives(t, q, v, lam)
        if Qq is None:
            assert not np.any(Oq)
        else:
            _close(Qq, Oq)
        if Qv is None:
            assert not np.any(Ov)
        else:
            _close(Qv, Ov)
        _close(system.potential_energy(q), o.potential(q))
        log = [] if g is None else [(t, i, s) for i, s in enumerate(speeds)]
        p_in, p_diss = system.power(np.array([t]), q[None], v[None], lam[None],
                                    contact_log=log)
        want_in, want_diss = o.power(t, q, v, lam, speeds)
        _close(p_in[0], want_in + _drivers_power(system, q, t, lam))
        _close(p_diss[0], want_diss)
        if system.spring_count:
            _close(system.spring_separations(q), o.spring_separations(q))
        if g is not None:
            (g_got, grad_got), (g_want, grad_want) = (system.contact_gaps(system._ext(q)),
                                                      o.gaps(system._ext(q)))
            _close(g_got, g_want)
            _close(grad_got[:, :6], grad_want)     # a planar gap's six columns
            assert not grad_got[:, 6:].any()          # the rest of the gap's width: none
        if system.frictions:
            _close(system.Q_lam(t, q, v, lam), o.Q_lam(t, q, v, lam))
            _close(system.friction_speeds(q, v), o.friction_speeds(q, v))
            _close(system.friction_speeds(q, v, a), o.friction_speeds(q, v, a))
            k = len(system.frictions)
            slip = np.where(rng.random(k) < 0.3, np.nan, rng.uniform(-1.0, 1.0, k))
            _close(system.Q(t, q, v, lam, slip), o.Q(t, q, v, lam, slip))
    # rows of a stored solution at once, as the output evaluates them
    Q, V = rng.normal(scale=0.4, size=(2, 4, n))
    T, L = np.array([0.0, 0.5, 1.5, 2.0]), rng.normal(size=(4, m))
    _close(system.potential_energy(Q), np.array([o.potential(q) for q in Q]))
    p_in, p_diss = system.power(T, Q, V, L, contact_log=[] if g is None else [
        (0.0, i, s) for i, s in enumerate(g.impact_speed)])
    want = np.array([o.power(t, q, v, lam, None if g is None else g.impact_speed)
                     for t, q, v, lam in zip(T, Q, V, L)])
    _close(p_in, want[:, 0] + np.array([_drivers_power(system, q, t, lam)
                                        for t, q, lam in zip(T, Q, L)]))
    _close(p_diss, want[:, 1])


def test_the_oracle_sees_a_wrong_stiffness(kernels):
    # Sharp: a spring-damper's stiffness off by one part in 10^6 moves Q far
    # above the tolerance of the comparison above.
    system = system_on(ROOT / "models" / "andrews.mbd", kernels)
    q, v = np.random.default_rng(4).normal(scale=0.4, size=(2, system.n))
    want = system.Q(0.0, q, v)
    oracle = ForceOracle(system)
    _close(oracle.Q(0.0, q, v), want)
    spring = next(g for g in oracle.groups if hasattr(g, "l0"))
    spring.k = spring.k * (1.0 + 1e-6)
    assert np.abs(oracle.Q(0.0, q, v) - want).max() > 1e3 * 1e-12 * max(
        1.0, np.abs(want).max())


def test_a_load_derivative_outside_the_pattern_is_refused(kernels):
    # The loads' patterns come from the families' columns; the kernels' triplets
    # are summed into them. A pattern that misses an entry is an error, not a
    # silently dropped term.
    system = system_on(ROOT / "models" / "andrews.mbd", kernels)
    q, v = np.random.default_rng(5).normal(scale=0.4, size=(2, system.n))
    rows, cols = system.pattern_force
    system._load_patterns()["force"] = (rows[1:], cols[1:])
    with pytest.raises(RuntimeError, match="pattern"):
        system.force_derivatives(0.0, q, v)


def test_the_packages_copies_of_the_kernels_constants_agree(kernels):
    # system.py repeats the kernels' selectors so that building a model never
    # imports numba; they must be the kernels' own.
    from mbdsl.assembly import system
    assert (system._L_Q, system._L_QQ, system._L_QV, system._L_QLAM, system._L_ENERGY,
            system._L_POWER, system._L_GAPS, system._L_SPRINGS, system._L_SLIP) == (
        kernels.L_Q, kernels.L_QQ, kernels.L_QV, kernels.L_QLAM, kernels.L_ENERGY,
        kernels.L_POWER, kernels.L_GAPS, kernels.L_SPRINGS, kernels.L_SLIP)


@pytest.mark.parametrize("name", ["tests/dsl/valid/friction_elements.mbd",
                                  "models/incline_friction.mbd"])
def test_friction_Q_lambda_is_the_derivative_of_Q(name, kernels):
    # dQ/dlambda of friction (its normal loads are reactions) against central
    # differences of the kernels' own Q
    system = system_on(ROOT / name, kernels)
    rng = np.random.default_rng(2)
    q = rng.normal(scale=0.4, size=system.n)
    v, lam = rng.normal(size=system.n), rng.normal(size=system.m)
    Ql = system.Q_lam(0.2, q, v, lam)
    eps = 1e-6
    fd = np.stack([(system.Q(0.2, q, v, lam + eps * e) - system.Q(0.2, q, v, lam - eps * e))
                   / (2 * eps) for e in np.eye(system.m)], axis=1)
    assert np.any(Ql)
    np.testing.assert_allclose(Ql, fd, rtol=1e-6, atol=1e-8 * np.abs(fd).max())


def test_every_evaluation_from_python_takes_one_signature():
    # numba's cache loads each signature of an entry point as a library of its
    # own (20-70 ms each): every evaluation Python asks of the elements, on
    # models with every kind of element, one state or rows, passes the same
    # argument types
    import subprocess
    import sys
    from mbdsl.integrators import kernel_cache
    kernel_cache.ensure_loaded("dense")          # built, so that the child only loads
    code = """
import numpy as np, mbdsl
from mbdsl.integrators import compiled
for path in ("models/slider_crank_clearance.mbd", "tests/dsl/valid/friction_elements.mbd",
             "tests/dsl/valid/all_elements.mbd", "tests/dsl/valid/flexible_elements.mbd"):
    s = mbdsl.assemble(mbdsl.load(path))
    q, v = np.random.default_rng(1).normal(scale=0.3, size=(2, s.n))
    lam, t = np.zeros(s.m), np.array([0.0, 0.1])
    s.Q(0.1, q, v, lam)
    s.force_derivatives(0.1, q, v, lam)
    s.potential_energy(q), s.potential_energy(np.stack([q, v]))
    s.power(t, np.stack([q, v]), np.stack([v, q]), np.stack([lam, lam]))
    s.Phi(q, 0.1), s.Phi_q(q, 0.1), s.gamma(q, v, 0.1), s.Phi_t(q, t)
    s.PhiqT_lam_q(q, lam), s.Phiq_v_q(q, v), s.PhiqT_times(q, 0.1, lam)
    if s.frictions:
        s.Q_lam(0.1, q, v, lam)
        s.friction_speeds(q, v), s.friction_speeds(q, v, q)
        s.Q(0.1, q, v, lam, np.zeros(len(s.frictions)))
    if s.contact_state is not None:
        s.contact_state.gaps(s._ext(q))
    if s.spring_count:
        s.spring_separations(q)
print(len(compiled.elements.signatures))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=600, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["1"]


def test_a_build_loads_every_kernel_a_run_may_call():
    # kernel_cache.warm_up is what a build compiles: an entry point it does not call
    # compiles, silently, in the middle of a user's run the first time one needs it
    # (the dense index-1 multipliers of a flexible model's HHT-ADD output: 15 s;
    # generalized-alpha's ``advance`` on the Python stepper). In a fresh process
    # whose cache is built, the warm-up loads every entry point but the kernels'
    # own building blocks and the tests' force_term.
    import subprocess
    import sys
    from mbdsl.integrators import kernel_cache
    kernel_cache.ensure_loaded(None)             # built, so that the child only loads
    code = """
import numba
from mbdsl.integrators import compiled, kernel_cache
kernel_cache.warm_up(kernel_cache.GROUPS, output=True)
print(" ".join(sorted(name for name in dir(compiled) if not name.startswith("_")
                      and isinstance(getattr(compiled, name), numba.core.registry.CPUDispatcher)
                      and not getattr(compiled, name).signatures)))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=600, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["force_term", "forces", "phi"]


def test_no_kernel_is_compiled_once_per_constant_argument():
    # numba types a Python int or bool passed to a kernel by its value
    # (Literal[int](0)) and compiles the kernel once per value and call site:
    # the time loop's library held 11 copies of _emit_beams, 6 of _emit_phiq, 4
    # of _emit_force (7.9 MB of IR, which every process parses as it loads the
    # library; 5.4 MB with each kernel once). Kernels pass schema._0, _YES,
    # _NO or numpy integers. Left as constants: the model data's field indices
    # (a copy per element kind of the accessors _As, _scalar_row_terms, their
    # offsets folded) and _phi_time_add's derivative order (1 or 2); _Au, the
    # joints' point rotation, is inlined where it is called (its side, 0 or 1,
    # folded there).
    import ast
    import importlib
    from mbdsl.integrators import compiled, kernel_cache
    root = kernel_cache.package_root()
    names = [".".join(p.relative_to(root).with_suffix("").parts).removesuffix(".__init__")
             for p in kernel_cache.kernel_sources()]
    modules = [importlib.import_module(name) for name in names]
    trees = [ast.parse(p.read_text()) for p in kernel_cache.kernel_sources()]
    kernels = {f.name for tree in trees for f in tree.body if isinstance(f, ast.FunctionDef)
               and any(ast.unparse(d) in ("_jit", "_hot") for d in f.decorator_list)}
    values = {k: v for m in modules for k, v in vars(m).items() if type(v) in (int, bool)}
    exempt = {"_phi_time_add"}
    assert exempt <= kernels and len(kernels) > 100
    fields = {name.upper() for name, _, _ in compiled.MODEL_SCHEMA}

    def constant(a):
        if isinstance(a, ast.Constant):
            return type(a.value) in (int, bool)
        if isinstance(a, ast.UnaryOp) and isinstance(a.operand, ast.Constant):
            return type(a.operand.value) is int
        return (isinstance(a, ast.Name) and a.id not in fields
                and type(values.get(a.id)) in (int, bool))

    calls = [(node.func.id, node.lineno) for tree in trees for node in ast.walk(tree)
             if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
             and node.func.id in kernels - exempt and any(map(constant, node.args))]
    assert calls == []
