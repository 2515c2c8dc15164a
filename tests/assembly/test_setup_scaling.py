"""Set-up that grows linearly with the model: the ``for`` expansion, the
checks, the assembly and the consistent initial conditions of long chains.

No test here reads a clock: the work and the memory of the set-up are
counted (evaluations of expressions, bytes allocated), so that a quadratic
phase fails on any machine; the motion of a long chain is checked against
free fall. ``benchmarks/chain_scaling.py`` times the phases."""

import gc
import importlib
import pkgutil
import tracemalloc

import numpy as np
import pytest

import mbdsl
from mbdsl.dsl import check as check_module
from mbdsl.dsl.parser import parse_file

from ..conftest import MODELS

CHAIN = MODELS / "pendulum_chain.mbd"


def test_the_for_expansion_evaluates_each_shared_expression_once(monkeypatch):
    """``mass m; inertia m*L^2/12`` and the points of 2000 links are one
    template: evaluated once, not once per link; the indices that are
    expressions (``link[i-1]``) are evaluated per link. The count of evaluations doubles
    with N (plus a constant), as linear work does."""
    counts = []
    real = check_module.context.evaluate

    def counting(*args, **kwargs):
        counts[-1] += 1
        return real(*args, **kwargs)
    for info in pkgutil.iter_modules(check_module.__path__):      # the passes' modules
        module = importlib.import_module(f"{check_module.__name__}.{info.name}")
        if hasattr(module, "evaluate"):
            monkeypatch.setattr(module, "evaluate", counting)
    spec = parse_file(CHAIN)
    for N in (1000, 2000):
        counts.append(0)
        model = check_module.check_spec(spec, {"N": N})
        assert len(model.bodies) == N and len(model.joints) == N
    # per link: the index ``i - 1`` of the joint's first point is evaluated; the
    # indices that are the loop variable itself (the body's, the initial lines',
    # the joint's name, its second point's) are read from the loop's values, and
    # the masses not again
    assert counts[1] - counts[0] == 1 * 1000


def test_instances_of_a_for_block_are_right_and_distinct():
    """The copies share their unchanged parts, but each instance is its own:
    link[k]'s points, mass and inertia as declared, joint J[k] between
    link[k-1].B and link[k].A, initial lines on link[k]."""
    model = mbdsl.load(CHAIN, {"N": 5})
    names = [b.name for b in model.bodies]
    assert names == [f"link[{k}]" for k in range(1, 6)]
    for b in model.bodies:
        assert b.mass == pytest.approx(0.1) and b.inertia == pytest.approx(0.1 * 0.01 / 12)
        np.testing.assert_array_equal(b.points["A"], [-0.05, 0.0])
        np.testing.assert_array_equal(b.points["B"], [0.05, 0.0])
    for k, j in enumerate(model.joints[1:], start=2):
        assert j.name == f"J[{k}]"
        assert (j.first.body, j.second.body) == (k - 2, k - 1)
    assert sorted({(ic.body, ic.field) for ic in model.initials}) == \
        sorted({(b, f) for b in range(5) for f in ("phi", "omega")})


def _setup_peak(N):
    """Peak bytes allocated by check, assembly and initial conditions of the chain."""
    spec = parse_file(CHAIN)
    tracemalloc.start()
    try:
        system = mbdsl.assemble(check_module.check_spec(spec, {"N": N}))
        mbdsl.consistent_initial_state(system)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_setup_memory_grows_linearly():
    """From 2000 to 4000 links (6000 to 12000 coordinates, past the size where
    the initial conditions go sparse) the set-up's peak memory at most about
    doubles: a dense m x n or n x n array on the way (the selection of the
    fixed angles was one, 2.4 GB at 10 000 links) would quadruple it."""
    mbdsl.consistent_initial_state(mbdsl.assemble(mbdsl.load(CHAIN, {"N": 2})))  # kernels
    small, large = _setup_peak(2000), _setup_peak(4000)
    assert large / small < 2.5, (small, large)


def test_the_collector_runs_again_after_each_phase():
    """The set-up phases pause the cyclic garbage collector (its passes over
    the model's many objects were most of the set-up of long chains) and
    resume it when they return, and when they raise."""
    assert gc.isenabled()
    system = mbdsl.assemble(mbdsl.load(CHAIN, {"N": 3}))
    mbdsl.consistent_initial_state(system)
    assert gc.isenabled()
    with pytest.raises(mbdsl.MbdModelError):
        mbdsl.load_text("model m\nbody b { mass -1; inertia 1 }\n")
    assert gc.isenabled()


@pytest.mark.parametrize("N", [
    10_000,
    pytest.param(100_000, marks=pytest.mark.slow),        # 300 000 coordinates
])
def test_a_long_chain_falls_freely_away_from_its_support(tmp_path, N):
    """A horizontal chain released from rest: away from the pinned end the
    links stay horizontal and the joints' forces along them are horizontal
    (the inextensible chain is pulled toward the support as its first links
    swing down), so the middle link falls freely, y = -g t^2 / 2, which
    Newmark-family steps reproduce to round-off (constant acceleration),
    with its neighbour one link length further; 100 steps of hht-i3 from the
    command line, the last row only."""
    from mbdsl.cli.main import main
    out = tmp_path / "chain.h5"
    assert main(["simulate", str(CHAIN), "--set", f"N={N}", "--t-end", "0.1",
                 "--output-every", "100", "-q", "-o", str(out)]) == 0
    sol = mbdsl.load_solution(out)
    assert sol.completed and len(sol.t) == 2 and sol.t[-1] == pytest.approx(0.1)
    k = N // 2
    g, t = 9.81, sol.t[-1]
    assert sol.column(f"link[{k}].y")[-1] == pytest.approx(-0.5 * g * t * t, rel=1e-9)
    spacing = sol.column(f"link[{k + 1}].x")[-1] - sol.column(f"link[{k}].x")[-1]
    assert spacing == pytest.approx(0.1, rel=1e-9)
    assert abs(sol.column(f"link[{k}].phi")[-1]) < 1e-9
    # the pinned end is held: the first link turns
    assert sol.column("link[1].phi")[-1] < -1e-3
