"""What contact scenes cost per method: the three shipped contact models, every
method, error-controlled steps at the model's tolerance.

Per model and method: the engine, wall time of the time loop [s], accepted and rejected
steps, steps retaken to land on events, events, us per step, and the
model's own accuracy measure:

* ``bouncing_ball``: the first rebound's apex over e^2 of the drop (1 exact);
* ``pendulum_stop`` (run with e = 1): |E - E_0| / E_0 of the swing's energy
  after ten impacts;
* ``slider_crank_clearance``: the crank angle at T against the run with the
  tightest tolerance of the same method (rtol / 100), a self-convergence
  measure of what the tolerance buys.

Run:  python benchmarks/contact_cost.py [--t-end T] [--markdown FILE]
Not part of CI's pass/fail; docs/studies.md keeps the latest table.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import mbdsl

MODELS = Path(__file__).resolve().parents[1] / "models"
METHODS = ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
           "genalpha-si2"]
G = 9.81


def _ball(sol):
    ev = [e for e in sol.events if e[2] == "opened"]
    i = np.searchsorted(sol.t, ev[0][0])
    apex = sol.q[i, 1] + sol.v[i, 1] ** 2 / (2 * G) - 0.05
    return f"apex / e^2 H = {apex / (0.64 * 0.95):.4f}"


def _stop(sol):
    E = sol.column("energy.total") + G * 0.5
    opened = [e for e in sol.events if e[2] == "opened"]
    after = E[np.searchsorted(sol.t, opened[9][0])]
    return f"abs(dE)/E after 10 impacts = {abs(after - E[0]) / E[0]:.1e}"


def run(name, method, overrides=None, t_end=None, rtol=None):
    model = mbdsl.load(MODELS / f"{name}.mbd", overrides)
    kw = {"t_end": t_end} if t_end else {}
    if rtol:
        kw.update(rtol=rtol, atol=rtol)
    t0 = time.perf_counter()
    sol = mbdsl.simulate(model, method=method, **kw)
    return sol, time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=None,
                    help="end time of the clearance slider crank (default: the model's 2 s)")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--markdown", type=Path)
    args = ap.parse_args(argv)
    rows = ["| model | method | engine | loop [s] | steps | rejected | retaken | events | us/step "
            "| accuracy |", "|---|---|---|---|---|---|---|---|---|---|"]
    for name, overrides, measure in (("bouncing_ball", None, _ball),
                                     ("pendulum_stop", {"e": 1.0}, _stop),
                                     ("slider_crank_clearance", None, None)):
        for method in args.methods.split(","):
            t_end = args.t_end if name == "slider_crank_clearance" else None
            sol, _ = run(name, method, overrides, t_end)
            if measure is None:
                fine, _ = run(name, method, overrides, t_end, rtol=1e-8)
                col = sol.system.layout.coordinates.index("crank.phi")
                acc = f"crank angle vs rtol 1e-8: {abs(sol.q[-1, col] - fine.q[-1, col]):.1e} rad"
            else:
                acc = measure(sol)
            tot = sol.stats_total
            loop = sol.timings["integration"]
            rows.append(f"| {name} | {method} | {sol.engine} | {loop:.2f} | {tot.steps} | "
                        f"{tot.rejected} | "
                        f"{sol.event_cuts} | {len(sol.events)} | "
                        f"{1e6 * loop / max(tot.steps, 1):.0f} | {acc} |")
            print(rows[-1], flush=True)
    if args.markdown:
        args.markdown.write_text("\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
