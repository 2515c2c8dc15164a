"""Pendulum chains N = 10, 100, 1000 (models.md section 5): wall time per step.

Checks that the per-step cost grows at most linearly in N from N = 100 to
N = 1000 (issue: hard cases). Run:  python benchmarks/chain_scaling.py
Model parsing, checking, assembly and the consistent initial state are timed
separately from the steps; each case is the median of --repeat runs.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import mbdsl
from mbdsl.integrators import integrate, make_method

MODEL = Path(__file__).resolve().parents[1] / "models" / "pendulum_chain.mbd"


def measure(N: int, method: str, h: float, steps: int, repeat: int) -> dict:
    t0 = time.perf_counter()
    model = mbdsl.load(MODEL, overrides={"N": N})
    system = mbdsl.assemble(model)
    init = mbdsl.consistent_initial_state(system)
    setup = time.perf_counter() - t0
    walls, sol = [], None
    for _ in range(repeat):
        t1 = time.perf_counter()
        sol = integrate(system, make_method(method), steps * h, h, initial=init)
        walls.append(time.perf_counter() - t1)
    tot = sol.stats_total
    return {"N": N, "n+m": system.n + system.m, "setup_s": setup,
            "ms_per_step": 1e3 * statistics.median(walls) / tot.steps,
            "iterations": tot.iterations / tot.steps, "factorizations": tot.factorizations / tot.steps}


def main(argv=None) -> int:
    """Print the table; exit 1 if the cost grows faster than linearly from 100 to 1000."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--method", default="hht-i3")
    p.add_argument("--h", type=float, default=1e-3)
    p.add_argument("--steps", type=int, default=100)
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args(argv)
    rows = [measure(N, args.method, args.h, args.steps, args.repeat) for N in (10, 100, 1000)]
    print(f"{'N':>6} {'n+m':>6} {'setup [s]':>10} {'ms/step':>9} {'iter/step':>10} {'LU/step':>8}")
    for r in rows:
        print(f"{r['N']:>6} {r['n+m']:>6} {r['setup_s']:>10.3f} {r['ms_per_step']:>9.2f} "
              f"{r['iterations']:>10.2f} {r['factorizations']:>8.2f}")
    growth = rows[2]["ms_per_step"] / rows[1]["ms_per_step"]
    print(f"per-step cost N = 1000 / N = 100: {growth:.2f} (linear: 10)")
    return 0 if growth <= 10.0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
