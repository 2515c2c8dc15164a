"""The lowest ten frequencies of a hanging pendulum chain, N = 100, 1000, 3000
links: wall time of each phase (parse and check, assembly, static
equilibrium, linearization and the sparse eigensolver), and the lowest
frequency against the continuous hanging chain's (j_0,1 / 2) sqrt(g / l).

Target: N = 1000 in under 10 s in all. Run:  python benchmarks/modes_chain.py
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import scipy.special

import mbdsl
from mbdsl.modes import modes

MODEL = Path(__file__).resolve().parents[1] / "models" / "pendulum_chain.mbd"


def measure(N: int, k: int = 10) -> dict:
    text = MODEL.read_text().replace("initial link[i].phi = 0 ", "initial link[i].phi = -1.5")
    t0 = time.perf_counter()
    model = mbdsl.load_text(text, overrides={"N": N})
    t1 = time.perf_counter()
    system = mbdsl.assemble(model)
    t2 = time.perf_counter()
    found = modes(system, at="static", k=k, sparse=True)
    t3 = time.perf_counter()
    exact = scipy.special.jn_zeros(0, 1)[0] / 2 * np.sqrt(9.81 / (0.1 * N))
    return {"N": N, "load": t1 - t0, "assemble": t2 - t1, "modes": t3 - t2, "total": t3 - t0,
            "omega1": found.modes[0].omega, "continuous": exact}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="100,1000,3000")
    args = p.parse_args()
    print(f"{'N':>6}  {'load [s]':>9}  {'assemble':>9}  {'static+modes':>12}  {'total':>7}  "
          f"{'omega_1':>9}  {'continuous':>10}")
    for N in (int(x) for x in args.sizes.split(",")):
        r = measure(N)
        print(f"{r['N']:>6}  {r['load']:9.3f}  {r['assemble']:9.3f}  {r['modes']:12.3f}  "
              f"{r['total']:7.3f}  {r['omega1']:9.5f}  {r['continuous']:10.5f}")


if __name__ == "__main__":
    main()
