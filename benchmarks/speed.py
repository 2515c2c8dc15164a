"""Per-step cost of the methods against Exudyn, side by side in one process,
and the whole ``mbdsl simulate`` command as a user runs it.

Models (h = 1e-3 s unless said): the slider crank (T = 2 s), the double
pendulum (T = 2 s), pendulum chains of N = 10 (T = 1 s), 100 and 1000 links
(T = 0.1 s, 100 steps), the flexible slider crank (T = 0.2 s), Andrews'
mechanism (h = 1e-5 s, T = 3e-3 s), and spatial models: the IFToMM spatial
slider-crank (T = 2 s) and spatial chains of N = 10 (T = 1 s), 100 and 1000
links (T = 0.1 s). Per model and method (all six by
default, ``--methods``) it prints:

* set-up, timed apart from the steps: parse and check, assembly, consistent
  initial state [ms];
* wall time per step, the median of --repeat runs (the first, which loads the
  compiled kernels, is reported separately as "first run"), Exudyn's run and
  each method's taken in turn, so that the machine's drift in speed between
  runs falls on both sides of the ratio. Both sides are timed alike: the run
  to T minus a one-step run of the same model (each code's set-up of the
  integration: mbdsl's linear-solver plan and compiled model, Exudyn's
  solver initialization), over the remaining steps. mbdsl's set-up is
  reported apart ("integrate set-up ms");
* Newton iterations, Jacobian evaluations and factorizations per step;
* the error at T: max |q - q_ref| over all coordinates, against the published
  slider-crank reference (tests/reference/slider_crank.json: crank angle) or
  an independent index-1 DOP853 solution at 1e-12 (``mbdsl.studies.index1``); the
  chain of 1000 links has none (its index-1 solution is too costly);
* with exudyn installed (``pip install -e ".[bench]"``), the same model run in
  Exudyn (``exudyn_side.py``; rigid models with the elements it translates),
  its time per step, iterations and error, the ratio mbdsl / Exudyn of the
  times per step and of the errors. Exudyn runs generalized-alpha at the
  spectral radius rho_inf = (1 + alpha)/(1 - alpha); mbdsl's ``genalpha`` and
  ``genalpha-si2`` run at the same rho_inf, the HHT methods at alpha, so the
  error ratio of ``genalpha`` compares the same formula in two codes.

Also: start-up of the slider crank (import, parse, check, assemble, in a
fresh interpreter), the per-step growth from N = 100 to N = 1000, and the
whole command ``mbdsl simulate models/slider_crank.mbd -o out.csv`` (and
``-o out.h5``) in a fresh process with a warm kernel cache: its wall time and
the us/step its summary reports.

Run:  python benchmarks/speed.py [--repeat 5] [--quick] [--markdown FILE]
Not part of CI's pass/fail; ``docs/performance.md`` keeps the latest table.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

import mbdsl  # noqa: E402
from mbdsl.integrators import METHODS, integrate, make_method, method_parameters  # noqa: E402
from mbdsl.studies.index1 import index1_reference

import exudyn_side  # noqa: E402

H = 1e-3
CASES = [  # (label, model file, overrides, T, reference, h)
    ("slider crank", "slider_crank.mbd", None, 2.0, "published", H),
    ("driven slider crank", "slider_crank_driven.mbd", None, 2.0, "index1", H),
    ("double pendulum", "double_pendulum.mbd", None, 2.0, "index1", H),
    ("chain N=10", "pendulum_chain.mbd", {"N": 10}, 1.0, "index1", H),
    ("chain N=100", "pendulum_chain.mbd", {"N": 100}, 0.1, "index1", H),
    ("chain N=1000", "pendulum_chain.mbd", {"N": 1000}, 0.1, None, H),
    ("flexible slider crank", "flexible_slider_crank.mbd", None, 0.2, None, H),
    ("andrews", "andrews.mbd", None, 3e-3, None, 1e-5),
    ("spatial slider crank", "spatial_slider_crank.mbd", None, 2.0, "index1", H),
    ("spatial chain N=10", "spatial_chain.mbd", {"N": 10}, 1.0, "index1", H),
    ("spatial chain N=100", "spatial_chain.mbd", {"N": 100}, 0.1, None, H),
    ("spatial chain N=1000", "spatial_chain.mbd", {"N": 1000}, 0.1, None, H),
]


def startup_seconds() -> float:
    """Import, parse, check and assemble the slider crank in a fresh interpreter:
    the best of 3 runs after one that writes the bytecode caches (pip writes
    them at install; with PYTHONDONTWRITEBYTECODE set every run would compile
    mbdsl's sources again, about 0.1 s that no installed copy pays)."""
    code = ("import time; t0 = time.perf_counter(); import mbdsl; "
            f"m = mbdsl.load({str(ROOT / 'models' / 'slider_crank.mbd')!r}); "
            "s = mbdsl.assemble(m); print(time.perf_counter() - t0)")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    runs = [float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                 check=True, env=env).stdout) for _ in range(4)]
    return min(runs[1:])


def reference_q(kind, system, T):
    """(reference q at T, mask of compared coordinates) or None."""
    if kind == "published":
        ref = json.loads((ROOT / "tests" / "reference" / "slider_crank.json").read_text())
        case = ref["cases"]["damped_x0_zero"]
        q = np.full(system.n, np.nan)
        q[2] = case["theta1_T"]                       # crank angle: the published quantity
        return q
    if kind == "index1":
        return index1_reference(system, [T]).q[-1]
    return None


def error(q, qref):
    """max |q - q_ref| over the coordinates the reference gives."""
    if qref is None:
        return float("nan")
    ok = np.isfinite(qref)
    return float(np.max(np.abs(q[ok] - qref[ok])))


def whole_command(suffix: str, repeat: int = 3) -> tuple[float, float]:
    """(best wall time [s], the summary's us/step) of ``mbdsl simulate
    models/slider_crank.mbd -o out<suffix>`` in a fresh process, after one
    run that fills the bytecode and kernel caches."""
    import re
    import tempfile
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    best, us = float("inf"), float("nan")
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "mbdsl", "simulate", str(ROOT / "models" / "slider_crank.mbd"),
               "-o", str(Path(tmp) / f"out{suffix}")]
        for k in range(repeat + 1):
            t0 = time.perf_counter()
            out = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env).stdout
            wall = time.perf_counter() - t0
            if k:
                best = min(best, wall)
                us = float(re.search(r"([0-9.]+) us/step", out).group(1))
    return best, us


def measure(label, file, overrides, T, ref_kind, h, methods, repeat, with_exudyn,
            alpha=-0.05):
    rows = []
    t0 = time.perf_counter()
    model = mbdsl.load(ROOT / "models" / file, overrides=overrides)
    t1 = time.perf_counter()
    system = mbdsl.assemble(model)
    t2 = time.perf_counter()
    init = mbdsl.consistent_initial_state(system)
    t3 = time.perf_counter()
    qref = reference_q(ref_kind, system, T)

    def method_of(name):
        """The method with HHT's alpha where it takes one, and generalized-alpha at
        the same spectral radius at infinity, rho_inf = (1 + alpha)/(1 - alpha)."""
        taken = method_parameters(name)
        given = {"alpha": alpha, "rho_inf": (1.0 + alpha) / (1.0 - alpha)}
        return make_method(name, **{k: v for k, v in given.items() if k in taken})

    first, walls, sols = {}, {name: [] for name in methods}, {}
    setups = {name: [] for name in methods}
    for name in methods:
        f0 = time.perf_counter()
        sols[name] = integrate(system, method_of(name), T, h, initial=init)
        first[name] = time.perf_counter() - f0
    # Exudyn and each method in turn, repeat times: the machine's speed drifts
    # between runs (by up to a third on this one), and the ratio of two medians
    # taken minutes apart carried that drift
    exu, exu_walls = None, []
    for _ in range(repeat):
        if with_exudyn and exu is not False:
            try:
                exu = exudyn_side.run_exudyn(model, init.q, init.v, T, h, alpha, repeat=1)
                exu_walls.append(exu["s_per_step"])
            except NotImplementedError as exc:      # an element Exudyn's side lacks
                print(f"  {label}: not run in Exudyn ({exc})", file=sys.stderr)
                exu = False
        for name in methods:
            # as exudyn_side times Exudyn: the run to T minus a one-step run (the set-up)
            w0 = time.perf_counter()
            integrate(system, method_of(name), h, h, initial=init)
            one = time.perf_counter() - w0
            w0 = time.perf_counter()
            sols[name] = integrate(system, method_of(name), T, h, initial=init)
            full = time.perf_counter() - w0
            steps = sols[name].stats_total.steps
            walls[name].append(max(full - one, 0.0) / max(steps - 1, 1))
            setups[name].append(max(one - walls[name][-1], 0.0))
    if exu:
        exu["s_per_step"] = statistics.median(exu_walls)
        exu["error"] = error(exu["q"], qref)
    else:
        exu = None

    for name in methods:
        sol, first_run = sols[name], first[name]
        tot = sol.stats_total
        row = {"model": label, "method": name, "n+m": system.n + system.m,
               "engine": f"{sol.engine}/{sol.linear_solver}",
               "parse_ms": 1e3 * (t1 - t0), "assemble_ms": 1e3 * (t2 - t1),
               "initial_ms": 1e3 * (t3 - t2), "first_s": first_run,
               "setup_ms": 1e3 * statistics.median(setups[name]),
               "us_per_step": 1e6 * statistics.median(walls[name]),
               "iterations": tot.iterations / tot.steps, "jacobians": tot.jacobians / tot.steps,
               "factorizations": tot.factorizations / tot.steps,
               "error": error(sol.q[-1], qref), "status": sol.status}
        if exu is not None:
            row.update(exu_us=1e6 * exu["s_per_step"], exu_iterations=exu["iterations"],
                       exu_jacobians=exu["jacobians"], exu_error=exu["error"],
                       ratio=row["us_per_step"] / (1e6 * exu["s_per_step"]),
                       error_ratio=row["error"] / exu["error"])
        rows.append(row)
    return rows


def table(rows, markdown=False) -> str:
    head = ["model", "method", "n+m", "engine", "parse+check ms", "assemble ms", "initial ms",
            "first run s", "integrate set-up ms", "us/step", "iter/step", "Jac/step", "LU/step",
            "error q(T)",
            "Exudyn us/step", "Exudyn iter/step", "Exudyn error q(T)", "mbdsl/Exudyn",
            "error/Exudyn error"]
    lines = []
    fmt = lambda x, f: "—" if x is None or (isinstance(x, float) and np.isnan(x)) else f.format(x)  # noqa: E731
    for r in rows:
        lines.append([r["model"], r["method"], str(r["n+m"]), r["engine"],
                      fmt(r["parse_ms"], "{:.1f}"), fmt(r["assemble_ms"], "{:.1f}"),
                      fmt(r["initial_ms"], "{:.1f}"), fmt(r["first_s"], "{:.3f}"),
                      fmt(r["setup_ms"], "{:.1f}"), fmt(r["us_per_step"], "{:.1f}"),
                      fmt(r["iterations"], "{:.2f}"),
                      fmt(r["jacobians"], "{:.3f}"), fmt(r["factorizations"], "{:.3f}"),
                      fmt(r["error"], "{:.2e}"), fmt(r.get("exu_us"), "{:.1f}"),
                      fmt(r.get("exu_iterations"), "{:.2f}"), fmt(r.get("exu_error"), "{:.2e}"),
                      fmt(r.get("ratio"), "{:.2f}"), fmt(r.get("error_ratio"), "{:.3f}")])
    if markdown:
        out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        out += ["| " + " | ".join(x) + " |" for x in lines]
        return "\n".join(out)
    widths = [max(len(h), *(len(x[i]) for x in lines)) for i, h in enumerate(head)]
    out = ["  ".join(h.rjust(w) for h, w in zip(head, widths))]
    out += ["  ".join(x.rjust(w) for x, w in zip(line, widths)) for line in lines]
    return "\n".join(out)


def machine() -> str:
    """One line: CPU, cores, Python, numpy, numba and exudyn versions."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import numba
    parts = [cpu, f"{os.cpu_count()} cores", f"Python {platform.python_version()}",
             f"numpy {np.__version__}", f"numba {numba.__version__}"]
    if exudyn_side.available():
        parts.append(f"exudyn {exudyn_side.version()}")
    return ", ".join(parts)


def main(argv=None) -> int:
    """Print the table (and write it as markdown with --markdown)."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--methods", default="all", help="comma-separated, or all (default)")
    p.add_argument("--quick", action="store_true", help="skip the chain of 1000 links")
    p.add_argument("--no-exudyn", action="store_true")
    p.add_argument("--markdown", help="write the table to this file as markdown")
    p.add_argument("--alpha", type=float, default=-0.05,
                   help="HHT alpha; Exudyn's spectral radius is (1 + alpha) / (1 - alpha)")
    p.add_argument("--only", help="comma-separated model labels to run (default: all)")
    args = p.parse_args(argv)
    with_exudyn = exudyn_side.available() and not args.no_exudyn
    methods = list(METHODS) if args.methods == "all" else args.methods.split(",")
    startup = startup_seconds()
    commands = {suffix: whole_command(suffix) for suffix in (".csv", ".h5")}
    rows = []
    for case in CASES:
        if (args.quick and case[0].endswith("chain N=1000")) or (
                args.only and case[0] not in args.only.split(",")):
            continue
        rows += measure(*case, methods, args.repeat, with_exudyn, alpha=args.alpha)
        print(f"  measured {case[0]}", file=sys.stderr)
    text = table(rows)
    print(machine())
    print(f"h = {H:g} s, alpha = {args.alpha:g} (Exudyn: generalized-alpha, spectral radius "
          f"{(1 + args.alpha) / (1 - args.alpha):.4g})")
    print(text)
    print(f"start-up of the slider crank (import, parse, check, assemble): {startup:.3f} s")
    for suffix, (wall, us) in commands.items():
        print(f"mbdsl simulate models/slider_crank.mbd -o out{suffix}: {wall:.2f} s in all, "
              f"summary {us:.1f} us/step")
    growth = {}
    for name in methods:
        per = {r["model"]: r["us_per_step"] for r in rows if r["method"] == name}
        if "chain N=1000" in per and "chain N=100" in per:       # both measured (--only)
            growth[name] = per["chain N=1000"] / per["chain N=100"]
            print(f"{name}: per-step cost N = 1000 / N = 100 = {growth[name]:.2f} (linear: 10)")
    if args.markdown:
        Path(args.markdown).write_text(
            f"Machine: {machine()}\n\nh = {H:g} s, alpha = {args.alpha:g} (Exudyn: "
            f"generalized-alpha, spectral radius {(1 + args.alpha) / (1 - args.alpha):.4g})\n\n"
            f"{table(rows, markdown=True)}\n\n"
            f"Start-up of the slider crank (import, parse, check, assemble, fresh "
            f"interpreter, best of 3): {startup:.3f} s\n\n"
            + "".join(f"`mbdsl simulate models/slider_crank.mbd -o out{k}` (fresh process, warm "
                      f"caches, best of 3): {w:.2f} s in all, summary {u:.1f} us/step\n\n"
                      for k, (w, u) in commands.items())
            + "".join(f"Per-step cost {k}, N = 1000 / N = 100: {g:.2f} (linear: 10)\n\n"
                      for k, g in growth.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
