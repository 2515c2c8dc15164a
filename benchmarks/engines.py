"""The three engines on the shipped models: compiled, numpy and uncompiled.

The uncompiled engine runs the compiled engine's kernels and loops in the
interpreter (numba's JIT disabled; ``--engine uncompiled``): the one
implementation, for debugging a kernel. The numpy engine runs the methods'
numpy residuals and Newton matrices over the kernels' joints, drivers and
beams and the groups' vectorised applied loads; its joints and beams run on
the compiled kernels where this process can call them ("numpy"), on their
uncompiled copy on a machine whose kernels are not built yet ("numpy,
first run": the first run takes the numpy engine while the kernels build).
This table is what decides which interpreted engine a first run takes: the
per-step time of each, with the compiled engine's for scale.

Per model (HHT-I3 at the model's step, its end time or ``--t-end``): steps,
and microseconds per step of the time loop (``Solution.timings["integration"]``)
on each engine; the q of the uncompiled and numpy runs against the compiled
run's at the end (round-off: they compute the same equations).

Run:  python benchmarks/engines.py [--t-end T] [--markdown FILE]
Not part of CI's pass/fail; docs/performance.md keeps the latest table.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import mbdsl

MODELS = Path(__file__).resolve().parents[1] / "models"
#: (file, overrides, end time [s] or None for the model's own)
CASES = [("slider_crank.mbd", None, None), ("double_pendulum.mbd", None, None),
         ("slider_crank_driven.mbd", None, None), ("andrews.mbd", None, 0.01),
         ("pendulum_chain.mbd", {"N": 10}, 0.1), ("n_fourbar.mbd", None, 0.2),
         ("flexible_slider_crank.mbd", None, 0.2), ("bouncing_ball.mbd", None, None)]
ENGINES = ("compiled", "numpy", "numpy, first run", "uncompiled")


def _first_run(model, t_end):
    """The numpy engine as on a machine whose kernels are not built: the
    process is told it has none loaded and none cached, so its joints and
    beams evaluate on the uncompiled kernels (``AssembledSystem.kernel_model``)."""
    from mbdsl.integrators import kernel_cache
    saved = kernel_cache.loaded, kernel_cache.kernels_ready
    kernel_cache.loaded = kernel_cache.kernels_ready = lambda: False
    try:
        return mbdsl.simulate(model, method="hht-i3", t_end=t_end, engine="numpy")
    finally:
        kernel_cache.loaded, kernel_cache.kernels_ready = saved


def measure(path, overrides, t_end):
    """{engine: (steps, us/step, final q)} of HHT-I3 runs of one model."""
    model = mbdsl.load(path, overrides=overrides)
    mbdsl.simulate(model, method="hht-i3", t_end=t_end, engine="compiled")   # loads the kernels
    out = {}
    for engine in ENGINES:
        if engine == "numpy, first run":
            sol = _first_run(model, t_end)
        else:
            sol = mbdsl.simulate(model, method="hht-i3", t_end=t_end, engine=engine)
        steps = max(int(sol.stats_total.steps), 1)
        out[engine] = (steps, 1e6 * sol.timings["integration"] / steps, sol.q[-1])
    return out


def main(argv=None) -> int:
    """Print (and with --markdown write) the table; returns 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, help="end time of every run [s]")
    parser.add_argument("--markdown", type=Path, help="write the table as Markdown")
    args = parser.parse_args(argv)
    rows = ["| model | steps | compiled us/step | numpy us/step | numpy, first run us/step | "
            "uncompiled us/step | uncompiled / numpy, first run | max q difference to compiled |",
            "|---|---|---|---|---|---|---|---|"]
    print(rows[0])
    for name, overrides, t_end in CASES:
        r = measure(MODELS / name, overrides, args.t_end or t_end)
        steps = r["compiled"][0]
        diff = max(np.abs(r[e][2] - r["compiled"][2]).max() for e in ENGINES[1:])
        label = name[:-4] + ("".join(f" {k}={v}" for k, v in overrides.items())
                             if overrides else "")
        first = r["numpy, first run"][1]
        rows.append(f"| {label} | {steps} | {r['compiled'][1]:.1f} | {r['numpy'][1]:.0f} | "
                    f"{first:.0f} | {r['uncompiled'][1]:.0f} | {r['uncompiled'][1] / first:.2f} | "
                    f"{diff:.1e} |")
        print(rows[-1], flush=True)
    if args.markdown:
        args.markdown.write_text("\n".join(rows) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
