"""HHT-SI2's split Newton matrix: the two blocks' dense inverses that "auto"
takes on small blocks against the band LU of the same split, per step.

Per model, both solvers run in turn (--repeat times): the run to T minus a
one-step run (the solver plan and the first factorization), over the
remaining steps; the median is printed, with Newton's iterations and
factorizations per step (equal where the two solve the same matrix).

Run:  python benchmarks/split_solvers.py [--repeat 7]
Not part of CI's pass/fail; ``docs/performance.md`` keeps the latest table.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import mbdsl
from mbdsl.integrators import NewtonOptions, integrate, make_method

MODELS = Path(__file__).resolve().parents[1] / "models"
CASES = [("spatial_slider_crank", 2.0, 1e-3), ("spatial_double_pendulum", 2.0, 1e-3),
         ("andrews", 3e-3, 1e-5), ("motor_fourbar", 2.0, 1e-3)]


def per_step(system, init, T, h, solver):
    """(us per step, the T run's solution) of hht-si2 with ``solver``."""
    opt = NewtonOptions(linear_solver=solver)
    t0 = time.perf_counter()
    integrate(system, make_method("hht-si2"), h, h, initial=init, engine="compiled", newton=opt)
    one = time.perf_counter() - t0
    t0 = time.perf_counter()
    sol = integrate(system, make_method("hht-si2"), T, h, initial=init, engine="compiled",
                    newton=opt)
    return (time.perf_counter() - t0 - one) / (len(sol.t) - 2) * 1e6, sol


def main():
    """Print the table (markdown) for the models of ``CASES``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    print("| model | unknowns a block | auto (solver) us/step | band LU us/step "
          "| iterations | factorizations |")
    print("|---|---|---|---|---|---|")
    for name, T, h in CASES:
        system = mbdsl.assemble(mbdsl.load(MODELS / f"{name}.mbd"))
        init = mbdsl.consistent_initial_state(system)
        times = {"auto": [], "banded": []}
        for _ in range(args.repeat):
            for solver in times:
                us, sol = per_step(system, init, T, h, solver)
                times[solver].append(us)
                st, steps = sol.stats_total, len(sol.t) - 1
                if solver == "auto":
                    kind = sol.linear_solver
        print(f"| `{name}` | {system.n + system.m} | {statistics.median(times['auto']):.1f} "
              f"({kind}) | {statistics.median(times['banded']):.1f} | "
              f"{st.iterations / steps:.2f} | {st.factorizations / steps:.3f} |")


if __name__ == "__main__":
    main()
