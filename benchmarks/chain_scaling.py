"""Pendulum chains N = 10 .. 100 000 (models.md section 5): set-up phase by
phase, the steps, and memory.

Each N runs in a fresh process (its peak resident memory is its own):
parse, check (the ``for`` expansion and every check), assemble, load the
compiled kernels, consistent initial conditions, then --steps steps of
hht-i3 (h = 1e-3 s), the median of --repeat runs (one run above N = 10 000).
Every N's set-up is done in --setup-repeat fresh processes and each phase's
time is their median; the first --repeat of them take the steps too (the
first alone above N = 10 000). A phase timed once varies by 10-20 % from
one process to the next on this 2-core machine (the 10 000-link chain's
assembly: 11.3-13.4 ms in nine processes), more than the growth target's
margin.
Prints a table and checks the targets of the scaling work:

* parse + check + assemble + initial conditions at N = 10 000: at most 1.5 s
  (kernel loading is its own phase: once per process, whatever the model);
* each set-up phase grows at most 12x from N = 10 000 to 100 000 (linear: 10x);
* the per-step cost grows at most linearly from N = 100 to 1 000.

Run:  python benchmarks/chain_scaling.py [--sizes 10,100,1000,10000,100000]
Not part of CI's pass/fail; exit 1 when a target is missed.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

MODEL = Path(__file__).resolve().parents[1] / "models" / "pendulum_chain.mbd"
PHASES = ("parse", "check", "assemble", "kernels", "initial")


def measure(N: int, method: str, h: float, steps: int, repeat: int,
            setup_only: bool = False) -> dict:
    """One chain in this process: each phase's wall time [s], ms per step, peak RSS [MB]
    (the set-up's phases alone with ``setup_only``)."""
    import mbdsl
    from mbdsl.dsl.check import check_spec
    from mbdsl.dsl.parser import parse_file
    from mbdsl.integrators import integrate, make_method
    clock, out = time.perf_counter, {"N": N}
    t = clock()
    spec = parse_file(MODEL)
    out["parse"], t = clock() - t, clock()
    model = check_spec(spec, {"N": N})
    out["check"], t = clock() - t, clock()
    system = mbdsl.assemble(model)
    out["assemble"], t = clock() - t, clock()
    # the compiled kernels the initial conditions call, loaded once per process
    mbdsl.consistent_initial_state(mbdsl.assemble(check_spec(spec, {"N": 2})))
    out["kernels"], t = clock() - t, clock()
    init = mbdsl.consistent_initial_state(system)
    out["initial"] = clock() - t
    out["setup_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    if setup_only:
        return out
    walls, sol = [], None
    for _ in range(repeat if N <= 10_000 else 1):
        t = clock()
        sol = integrate(system, make_method(method), steps * h, h, initial=init,
                        engine="compiled")
        walls.append(clock() - t)
    tot = sol.stats_total
    out.update({"n+m": system.n + system.m, "ms_per_step": 1e3 * statistics.median(walls) / tot.steps,
                "iterations": tot.iterations / tot.steps,
                "factorizations": tot.factorizations / tot.steps, "linear_solver": sol.linear_solver,
                "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024})
    return out


def _median(runs: list) -> dict:
    """One row from the processes' rows: the median of each time, the largest
    memory; the counts are the same in every process that took the steps."""
    out, stepped = dict(runs[0]), [r for r in runs if "ms_per_step" in r]
    for k in PHASES:
        out[k] = statistics.median(r[k] for r in runs)
    out["ms_per_step"] = statistics.median(r["ms_per_step"] for r in stepped)
    out["setup_rss_mb"] = max(r["setup_rss_mb"] for r in runs)
    out["rss_mb"] = max(r["rss_mb"] for r in stepped)
    return out


def main(argv=None) -> int:
    """Print the table; exit 1 if a target is missed."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--method", default="hht-i3")
    p.add_argument("--h", type=float, default=1e-3)
    p.add_argument("--steps", type=int, default=100)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--setup-repeat", type=int, default=5)
    p.add_argument("--sizes", default="10,100,1000,10000,100000")
    p.add_argument("--one", type=int, help=argparse.SUPPRESS)      # a child process: one N, JSON
    p.add_argument("--setup-only", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.one:
        print(json.dumps(measure(args.one, args.method, args.h, args.steps, args.repeat,
                                 args.setup_only)))
        return 0
    rows = []
    for N in (int(x) for x in args.sizes.split(",")):
        runs = []
        for k in range(max(args.setup_repeat, 1)):
            setup_only = ["--setup-only"] if k >= (args.repeat if N <= 10_000 else 1) else []
            proc = subprocess.run([sys.executable, __file__, "--one", str(N), "--method",
                                   args.method, "--h", str(args.h), "--steps", str(args.steps),
                                   "--repeat", str(args.repeat)] + setup_only,
                                  capture_output=True, text=True)
            if proc.returncode:
                print(proc.stderr, file=sys.stderr)
                return 1
            runs.append(json.loads(proc.stdout.strip().splitlines()[-1]))
        rows.append(_median(runs))
    print(f"{'N':>7} {'n+m':>7} " + " ".join(f"{k + ' [s]':>13}" for k in PHASES)
          + f" {'set-up MB':>9} {'ms/step':>9} {'iter/step':>9} {'LU/step':>7} {'peak MB':>8}")
    for r in rows:
        print(f"{r['N']:>7} {r['n+m']:>7} " + " ".join(f"{r[k]:>13.3f}" for k in PHASES)
              + f" {r['setup_rss_mb']:>9.0f} {r['ms_per_step']:>9.2f} {r['iterations']:>9.2f} "
              f"{r['factorizations']:>7.2f} {r['rss_mb']:>8.0f}")
    by_n = {r["N"]: r for r in rows}
    ok = True
    if 10_000 in by_n:
        setup = sum(by_n[10_000][k] for k in PHASES if k != "kernels")
        print(f"set-up at N = 10 000 (parse, check, assemble, initial): {setup:.2f} s (target 1.5 s)")
        ok &= setup <= 1.5
        if 100_000 in by_n:
            for k in PHASES:
                if k in ("parse", "kernels"):           # independent of N
                    continue
                growth = by_n[100_000][k] / by_n[10_000][k]
                print(f"{k}: N = 100 000 / N = 10 000 = {growth:.1f} (linear: 10, target 12)")
                ok &= growth <= 12.0
    if 100 in by_n and 1000 in by_n:
        growth = by_n[1000]["ms_per_step"] / by_n[100]["ms_per_step"]
        print(f"per-step cost N = 1000 / N = 100: {growth:.2f} (linear: 10)")
        ok &= growth <= 10.0
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
