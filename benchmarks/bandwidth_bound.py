"""The pendulum chain's step against the memory-bandwidth bound.

A step of an implicit method on a chain of N links moves a known amount of
data: per Newton iteration the residual reads the model data and a dozen
vectors, and one banded solve reads the LU factors; per factorization the
Newton matrix's triplets are written, accumulated into the band and
factored in place. No step can take less than those bytes over the rate
the machine moves data at, for a working set of that size (its caches or
its memory). This script counts the bytes from the model's and the band's
sizes and the measured iterations and factorizations per step, measures
the machine's copy rate (numpy ``copyto``, read + write) at the step's
working-set size, and prints the bound and the measured step beside it
(the run's time less a one-step run's, the set-up, as benchmarks/speed.py
times a step).

Bytes per step (8-byte floats, n coordinates, m rows, size = n + m
unknowns, band storage (2 kl + ku + 1) x size, triplet bound P):

* per iteration: the residual, model data (ints + floats) + 10 vectors of
  size; the band solve (``band._band_substitute``), the factors + pivots + 6
  vectors of size (permutation in, two triangular sweeps, permutation
  out); the iteration's own updates, 5 vectors of size;
* per factorization: the triplets written and read back (24 bytes each,
  twice), their positions in the band (8 bytes each), the band zeroed,
  filled and factored in place (3 passes over it);
* per step: prediction, weights (the constraint Jacobian's triplets for
  the multipliers' mobility, model data + 2 vectors), the output row:
  10 vectors of size.

Where "auto" takes the condensed solver (the planar chains: each
coordinate eliminated on its own, the constraint rows' Schur complement S
factored by Cholesky, ``integrators.compiled.condensed``), the solve's
bytes are its plan's integer arrays that a solve reads (each group's
offsets and rows, each row's entries of B, the orderings), the groups'
workspace (A_g, X_g, B_g) and S's factor, and 6 vectors of size (4 where
the block is solved in the update's own array, without the row and column
codes: the index-3 forms); a
factorization's, the triplets written, read back and checked against the
plan's (24 + 24 + 16 bytes each) with their places (8), the workspace and
S's band zeroed, filled and factored (3 passes over each). ``--solver
banded`` counts and measures the band LU of the whole matrix instead.

The count leaves out the arithmetic, the band LU's per-column library
calls and every cache miss beyond one pass: it is a lower bound.

Run:  python benchmarks/bandwidth_bound.py [--sizes 1000,10000] [--method hht-i3]
      [--solver auto|banded|condensed]
Not part of CI; docs/performance.md keeps the latest figures.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

MODEL = Path(__file__).resolve().parents[1] / "models" / "pendulum_chain.mbd"


def copy_rate(nbytes: int, repeat: int = 5) -> float:
    """The machine's copy rate [bytes/s, read + write] for two arrays of
    ``nbytes`` together: the best of ``repeat`` timings."""
    n = max(nbytes // 16, 1024)
    a, b = np.random.rand(n), np.empty(n)
    reps = max(1, int(2e9 // (16 * n)))
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(reps):
            np.copyto(b, a)
        best = min(best, time.perf_counter() - t)
    return 16 * n * reps / best


def band_bytes(size: int, ldab: int, bound: int) -> tuple[int, int, int]:
    """(bytes a solve reads, bytes a factorization moves, the band's bytes) of
    the band LU of the whole Newton matrix, by the count of the module notes."""
    band = ldab * size * 8
    return band + 4 * size + 6 * size * 8, 2 * 24 * bound + 8 * bound + 3 * band, band


def condensed_bytes(plan, size: int, bound: int) -> tuple[int, int, int]:
    """(bytes a solve reads, bytes a factorization moves, workspace bytes) of
    the condensed solver's plan, by the count of the module notes."""
    from mbdsl.integrators.records import (CP_BRPTR, CP_DIRECT, CP_GROFF, CP_GROUPS, CP_M,
                                           CP_WSTRIDE)
    c = plan.condensed
    cp, f = c.cp, 8
    G, m, ws = int(cp[CP_GROUPS]), int(cp[CP_M]), int(cp[CP_WSTRIDE])
    rows = int(cp[cp[CP_GROFF] + G])                   # the groups' slotted rows
    entries = int(cp[cp[CP_BRPTR] + m]) if c.unit else rows
    direct = bool(cp[CP_DIRECT])                       # solved in place: no row, column codes
    ints = f * (3 * G + 1 + rows + m + 1 + 2 * entries + m + (0 if direct else 2 * size))
    band = c.blocks * m * (2 * c.kl + c.ku + 1) * f
    work = c.blocks * ws * f
    solve = ints + work + band + (4 if direct else 6) * size * f
    factor = (24 + 24 + 16 + 8) * bound + 3 * work + 3 * band
    return solve, factor, work + band + ints


def step_bytes(n: int, m: int, ldab: int, model_bytes: int, bound: int,
               iterations: float, factorizations: float) -> tuple[float, float]:
    """(bytes moved per step, working-set bytes) by the count of the module
    notes, with the band LU of the whole Newton matrix."""
    size, f = n + m, 8
    solve, factorization, band = band_bytes(size, ldab, bound)
    residual = model_bytes + 10 * size * f
    iteration = residual + solve + 5 * size * f
    step = model_bytes + 12 * size * f
    working = band + 32 * bound + model_bytes + 20 * size * f
    return iterations * iteration + factorizations * factorization + step, working


def measure(N: int, method: str, steps: int, repeat: int, solver: str = "auto") -> dict:
    """One chain: its step measured, and the bound."""
    import mbdsl
    from mbdsl.assembly.packing import PackedModel
    from mbdsl.integrators import engine, integrate, make_method
    from mbdsl.integrators.newton import NewtonOptions
    from mbdsl.kernels import cache
    system = mbdsl.assemble(mbdsl.load(MODEL, overrides={"N": N}))
    init = mbdsl.consistent_initial_state(system)
    meth = make_method(method)
    opts = NewtonOptions(linear_solver=solver)
    h = 1e-3
    integrate(system, meth, 2 * h, h, initial=init, engine="compiled", newton=opts)  # loaded
    walls, sol = [], None
    for _ in range(repeat):                     # as benchmarks/speed.py: a one-step run's
        t = time.perf_counter()                 # time (the set-up) subtracted
        integrate(system, meth, h, h, initial=init, engine="compiled", newton=opts)
        one = time.perf_counter() - t
        t = time.perf_counter()
        sol = integrate(system, meth, steps * h, h, initial=init, engine="compiled", newton=opts)
        walls.append((time.perf_counter() - t - one) / (sol.stats_total.steps - 1))
    tot = sol.stats_total
    plan = engine.linear_solver_plan(system, meth, opts, init.q)
    if plan.kind not in ("banded", "condensed"):
        raise SystemExit(f"N = {N}: the {plan.kind} solver: no bound counted")
    cm = PackedModel(system, cache.element_kernels(uncompiled=True))
    ldab = 2 * plan.kl + plan.ku + 1
    its, lus = tot.iterations / tot.steps, tot.factorizations / tot.steps
    moved, working = step_bytes(system.n, system.m, ldab, cm.ints.nbytes + cm.floats.nbytes,
                                cm.bound, its, lus)
    if plan.kind == "condensed":                 # its solve and factorization for the band's
        size = system.n + system.m
        band_solve, band_factor, band = band_bytes(size, ldab, cm.bound)
        solve, factor, work = condensed_bytes(plan, size, cm.bound)
        moved += its * (solve - band_solve) + lus * (factor - band_factor)
        working += work - band
    rate = copy_rate(int(working))
    step = statistics.median(walls)
    return {"N": N, "size": system.n + system.m, "solver": plan.kind, "kl": plan.kl,
            "ku": plan.ku,
            "iterations": tot.iterations / tot.steps,
            "factorizations": tot.factorizations / tot.steps,
            "MB/step": moved / 1e6, "working MB": working / 1e6, "GB/s": rate / 1e9,
            "bound ms": 1e3 * moved / rate, "ms/step": 1e3 * step,
            "ratio": step * rate / moved}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="1000,10000")
    p.add_argument("--method", default="hht-i3")
    p.add_argument("--steps", type=int, default=100)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--solver", default="auto", choices=("auto", "banded", "condensed"))
    args = p.parse_args(argv)
    cols = ("N", "size", "solver", "kl", "ku", "iterations", "factorizations", "MB/step", "working MB",
            "GB/s", "bound ms", "ms/step", "ratio")
    print(" ".join(f"{c:>14}" for c in cols))
    for N in (int(x) for x in args.sizes.split(",")):
        r = measure(N, args.method, args.steps, args.repeat, args.solver)
        print(" ".join(f"{r[c]:>14.3g}" if isinstance(r[c], float) else f"{r[c]:>14}"
                       for c in cols))
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
