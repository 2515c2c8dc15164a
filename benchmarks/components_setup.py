"""Set-up of a model built from components against the same model written flat.

The pendulum chain (models/pendulum_chain.mbd) against the same chain of
``parts.Link`` instances in a ``for`` block
(tests/dsl/components/chain_parts.mbd): parse + check (the flattening
included) + assemble + consistent initial conditions, best of --repeat
runs in this process, for each N. Target: the components' set-up within
1.5x of the flat model's at N = 100.

Run:  python benchmarks/components_setup.py [--sizes 100,1000,10000] [--repeat 5]
Not part of CI's pass/fail; exit 1 when the target is missed.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FLAT = ROOT / "models" / "pendulum_chain.mbd"
PARTS = ROOT / "tests" / "dsl" / "components" / "chain_parts.mbd"
TARGET = 1.5


def setup_time(path: Path, N: int, repeat: int) -> float:
    """Best wall time [s] of parse + check + assemble + initial conditions."""
    import mbdsl
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        model = mbdsl.check_spec(mbdsl.parse_file(path), {"N": N})
        mbdsl.consistent_initial_state(mbdsl.assemble(model), 0.0)
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv=None) -> int:
    """Print the table; 1 when the N = 100 ratio exceeds the target."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="100,1000,10000")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    setup_time(FLAT, 10, 1)              # imports and kernels loaded once, before timing
    print(f"{'N':>7} {'flat [s]':>10} {'components [s]':>15} {'ratio':>7}")
    ok = True
    for N in (int(s) for s in args.sizes.split(",")):
        flat, parts = setup_time(FLAT, N, args.repeat), setup_time(PARTS, N, args.repeat)
        print(f"{N:>7} {flat:>10.4f} {parts:>15.4f} {parts / flat:>7.2f}")
        if N == 100 and parts / flat > TARGET:
            ok = False
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
