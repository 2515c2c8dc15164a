"""The ``mbdsl`` command line: ``simulate``, ``check``, ``plot``, ``animate`` and ``study``.

Calls the public API and nothing else. Every failure a user can cause is a
rendered diagnostic on stderr and a non-zero exit status, never a traceback:

    0  success
    1  the model has errors (syntax, names, values, structure)
    2  bad command-line usage (argparse)
    3  the simulation could not complete (the output file still holds every
       accepted step)
    4  the initial configuration could not be assembled
    130 interrupted by the user (output kept)
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from .. import METHODS, AssemblyError, MbdError, __version__, load, render, simulate
from ..errors import Diagnostic
from ..io import HDF5_SUFFIXES, load_solution
from ..io.csvfile import CsvStream, written_report
from ..io.observers import RunObserver

__all__ = ["main", "build_parser"]


def _parse_set(items):
    out = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise argparse.ArgumentTypeError(f"--set expects NAME=VALUE, got {item!r}")
        out[name.strip()] = value.strip()
    return out


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser of the ``mbdsl`` command."""
    p = argparse.ArgumentParser(prog="mbdsl", description="Dynamics of planar multibody systems.")
    p.add_argument("--version", action="version", version=f"mbdsl {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    _add_simulate(sub)
    _add_check(sub)
    _add_static(sub)
    _add_modes(sub)
    _add_plot(sub)
    _add_animate(sub)
    _add_view(sub)
    _add_study(sub)
    _add_sweep(sub)
    return p


def _add_simulate(sub) -> None:
    """``mbdsl simulate``: run a model and write its time histories."""
    sim = sub.add_parser("simulate", help="simulate a model and write its time histories")
    sim.add_argument("model", help="model file (.mbd)")
    sim.add_argument("-o", "--output", help="output file, CSV or HDF5 by extension (.csv, .h5); "
                     "default: beside the model, MODEL.csv")
    _run_options(sim)
    sim.add_argument("--strict", action="store_true",
                     help="a run that completes with a warning about its own motion (W602 "
                          "energy balance, W603 collapsed steps, W604 alternating reactions, "
                          "W404) is a failed run: exit 3")
    sim.add_argument("--plot", action="store_true",
                     help="also write the standard panels beside the output (run.csv -> run.png)")
    sim.add_argument("--columns", metavar="PATTERNS",
                     help="write only these columns (and t): comma-separated names with * and "
                          "? wildcards, e.g. 'link[99999].*,energy.*' (a model of 100 000 "
                          "bodies has 1.4 million columns)")
    sim.add_argument("--html", action="store_true",
                     help="also write the run as an interactive page beside the output "
                          "(run.csv -> run.html; see mbdsl view)")
    sim.add_argument("-q", "--quiet", action="store_true", help="print no summary, no progress bar")


def _add_check(sub) -> None:
    """``mbdsl check``: every diagnostic of a model file."""
    chk = sub.add_parser("check", help="check a model file and print every diagnostic")
    chk.add_argument("model", help="model file (.mbd)")
    chk.add_argument("--set", action="append", metavar="NAME=VALUE",
                     help="override a model parameter (repeatable)")


def _add_static(sub) -> None:
    """``mbdsl static``: the static equilibrium."""
    sta = sub.add_parser("static", help="find and print the model's static equilibrium "
                         "(as 'initial static' starts a run)")
    sta.add_argument("model", help="model file (.mbd)")
    sta.add_argument("--set", action="append", metavar="NAME=VALUE",
                     help="override a model parameter (repeatable)")


def _add_modes(sub) -> None:
    """``mbdsl modes``: natural frequencies, damping and mode shapes."""
    mod = sub.add_parser("modes", help="linearize the model about a state and print its "
                         "natural frequencies, damping and mode shapes, and what a method "
                         "does to each mode at its step")
    mod.add_argument("model", help="model file (.mbd)")
    mod.add_argument("--at", default="initial", metavar="STATE",
                     help="initial (the consistent initial state, default), static (the static "
                          "equilibrium, only the drivers held), or RESULT:T (a row of a result "
                          "file of this model at time T [s])")
    mod.add_argument("-k", type=_positive_int, metavar="K",
                     help="only the K lowest modes (default: every mode; 10 for models "
                          "solved by the sparse eigensolver)")
    mod.add_argument("--highest", action="store_true", help="the K highest modes instead")
    mod.add_argument("--method", choices=sorted(METHODS),
                     help="integration method whose damping of each mode is shown (default: "
                          "the model's simulate block, else hht-i3)")
    mod.add_argument("--h", type=float, help="step size [s] (default: the model's)")
    mod.add_argument("--plot", metavar="FIGURE",
                     help="also draw each method's spectral radius, damping ratio and period "
                          "error against omega h with the modes marked (.png, .svg, .pdf)")
    mod.add_argument("--methods", help="comma-separated methods of the figure (default: the "
                                       "run's method)")
    mod.add_argument("--animate", metavar="ANIMATION",
                     help="draw a mode's shape moving, one period a second (.gif, or .mp4 "
                          "with ffmpeg)")
    mod.add_argument("--mode", type=_positive_int, metavar="I",
                     help="which mode --animate draws (default: the highest found)")
    mod.add_argument("--set", action="append", metavar="NAME=VALUE",
                     help="override a model parameter (repeatable)")


def _add_plot(sub) -> None:
    """``mbdsl plot``: time histories of a result file."""
    plt = sub.add_parser("plot", help="plot time histories of a result file")
    plt.add_argument("result", help="result file written by simulate (.csv, .h5)")
    plt.add_argument("--y", help="comma-separated columns, one panel each "
                     "(default: the standard panels)")
    plt.add_argument("--x", default="t", help="abscissa column (default t)")
    plt.add_argument("--bodies", help="comma-separated bodies of the standard panels "
                     "(default: the first 4)")
    plt.add_argument("-o", "--output", help="figure file, format by extension (.png, .svg, .pdf); "
                     "default: RESULT.png")


def _add_animate(sub) -> None:
    """``mbdsl animate``: the motion as GIF or MP4."""
    ani = sub.add_parser("animate", help="animate a model (simulated first) or a result file")
    ani.add_argument("source", help="model file (.mbd) or result file (.csv, .h5)")
    ani.add_argument("-o", "--output", help="animation file (.gif, or .mp4 with ffmpeg); "
                     "default: SOURCE.gif")
    ani.add_argument("--fps", type=float, default=25.0, help="frames per second (default 25)")
    ani.add_argument("--deform-scale", type=float, default=1.0, metavar="S",
                     help="draw flexible beams with their elastic displacement times S "
                     "(default 1: true size)")
    ani.add_argument("--speed", type=float, default=1.0,
                     help="simulated seconds per second of video (default 1)")
    _run_options(ani)
    ani.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")


def _add_view(sub) -> None:
    """``mbdsl view``: a run as one interactive HTML page."""
    vw = sub.add_parser("view", help="a run as one interactive HTML page (works offline): the "
                        "mechanism animated with a time slider, time plots that zoom and hover")
    vw.add_argument("source", help="result file (.csv, .h5) or model file (.mbd, simulated first)")
    vw.add_argument("-o", "--output", help="the page (.html); default: SOURCE.html")
    vw.add_argument("--y", help="comma-separated columns, one time plot each "
                    "(default: the standard panels)")
    vw.add_argument("--bodies", help="comma-separated bodies of the standard panels "
                    "(default: the first 4)")
    vw.add_argument("--frames", type=_positive_int, default=None, metavar="N",
                    help="frames of the animation at most (default 200; the time plots show "
                         "every row)")
    vw.add_argument("--deform-scale", type=float, default=1.0, metavar="S",
                    help="draw flexible beams with their elastic displacement times S")
    _run_options(vw)
    vw.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")


def _add_study(sub) -> None:
    """``mbdsl study``: the paper's experiments on a model."""
    from ..studies import KINDS
    st = sub.add_parser("study", help="the paper's experiments on a model: convergence, energy, "
                        "drift, cost, work-precision, or all of them; recommend: the cheapest "
                        "method for target errors")
    st.add_argument("kind", choices=KINDS + ("all",), help="which study")
    st.add_argument("model", help="model file (.mbd)")
    st.add_argument("--methods", default="all",
                    help="'all' or a comma-separated list of methods (default all: the paper's six "
                         "and genalpha, genalpha-si2)")
    hs = st.add_mutually_exclusive_group()
    hs.add_argument("--h", help="comma-separated step sizes [s], e.g. 1e-3,5e-4")
    hs.add_argument("--h-range", help="halvings from FIRST to LAST, e.g. 2^-7:2^-11 "
                    "(default: the model's h times 4 down to h/4)")
    st.add_argument("--t-end", type=float, help="end time T [s] (default: the model's)")
    st.add_argument("--quantity", default="positions,velocities",
                    help="comma-separated quantities compared at T: positions, velocities "
                    "(max over the coordinates) or columns such as crank.omega or "
                    "lambda.O.0 (a multiplier)")
    st.add_argument("--reference", default="auto",
                    help="auto (index-1 DOP853 at 1e-12; hht-si2 at h/16 if the model is stiff), "
                    "dop853, a method name, or a result file of mbdsl simulate")
    st.add_argument("--joint", help="joint of the drift study (default: the first revolute "
                    "joint between two bodies)")
    st.add_argument("--at-h", type=float, help="step of the drift and cost studies "
                    "(default: the middle of the steps)")
    st.add_argument("--tol", default=None,
                    help="recommend: comma-separated target errors in the first quantity "
                    "(default 1e-3,1e-5,1e-7); work-precision: tolerances of error-controlled "
                    "runs instead of step sizes, FIRST:LAST by decades (1e-3:1e-8) or "
                    "comma-separated, each run starting from the largest h")
    st.add_argument("--repeat", type=int, default=3,
                    help="timed repeats of the cost and work-precision runs (median; default 3)")
    st.add_argument("--jobs", type=int,
                    help="worker processes for the runs that are not timed (default: the "
                         "number of cores); timed runs go one at a time")
    st.add_argument("--scheduler", help="address of a Dask scheduler (tcp://host:8786) to run "
                    "on instead of local processes (needs mbdsl[cluster])")
    st.add_argument("-o", "--output", help="folder for tables, figures and index.md "
                    "(default: MODEL_KIND beside the model)")
    st.add_argument("--set", action="append", metavar="NAME=VALUE",
                    help="override a model parameter (repeatable)")
    st.add_argument("-q", "--quiet", action="store_true", help="print no tables, no progress")


def _add_sweep(sub) -> None:
    """``mbdsl sweep``: a model over a grid or random samples of its parameters."""
    sw = sub.add_parser("sweep", help="run a model over a grid or random samples of its "
                        "parameters, on local processes or a Dask cluster, into one table")
    sw.add_argument("model", help="model file (.mbd)")
    sw.add_argument("--set", action="append", metavar="NAME=VALUES", default=[],
                    help="a swept parameter: a:b:n (n values from a to b) or v1,v2,... "
                         "(repeatable; the grid is every combination)")
    sw.add_argument("--samples", type=_positive_int, default=0, metavar="N",
                    help="N random draws of the --distribution parameters (crossed with the grid)")
    sw.add_argument("--distribution", action="append", metavar="NAME=DIST", default=[],
                    help="normal(mu,sigma), uniform(a,b) or lognormal(mu,sigma) (repeatable)")
    sw.add_argument("--seed", type=int, default=0, help="seed of the random draws (default 0)")
    sw.add_argument("--method", choices=sorted(METHODS),
                    help="integration method (default: the model's simulate block)")
    sw.add_argument("--h", type=float, help="step size [s] (default: the model's)")
    sw.add_argument("--t-end", type=float, help="end time [s] (default: the model's)")
    sw.add_argument("--rtol", type=float, help="error-controlled steps, rtol = atol")
    sw.add_argument("--columns", help="comma-separated columns whose final value, minimum and "
                    "maximum each run gives (default: the model's outputs, else the first "
                    "body's coordinates and the total energy)")
    sw.add_argument("--jobs", type=_positive_int, default=None,
                    help="worker processes (default: the number of cores)")
    sw.add_argument("--scheduler", help="address of a Dask scheduler (tcp://host:8786) to run "
                    "on instead of local processes (needs mbdsl[cluster])")
    sw.add_argument("-o", "--output", help="the table (.h5; default: MODEL_sweep.h5); an "
                    "existing table of the same sweep is continued, its runs not redone")
    sw.add_argument("-q", "--quiet", action="store_true", help="print no table, no progress")


def _run_options(p):
    from ..registry import DEFAULT_METHOD, METHOD_COEFFICIENTS, methods_taking

    def coef(name, text):
        """Help of a method coefficient: its range, the methods taking it, its default."""
        users = methods_taking(name)
        default = METHOD_COEFFICIENTS[users[0]][name]
        return f"{text} ({', '.join(users)}; default {default:g})"

    p.add_argument("--method", choices=sorted(METHODS),
                   help=f"integration method (default: the model's simulate block, else "
                        f"{DEFAULT_METHOD})")
    p.add_argument("--h", type=float, help="step size [s] (default: the model's simulate block; "
                   "required without one)")
    p.add_argument("--t-end", type=float, help="end time [s] (default: the model's simulate "
                   "block; required without one)")
    p.add_argument("--alpha", type=float, help=coef("alpha", "HHT alpha in [-1/3, 0]"))
    p.add_argument("--beta", type=float, help=coef("beta", "Newmark beta >= (gamma + 1/2)^2/4"))
    p.add_argument("--gamma", type=float, help=coef("gamma", "Newmark gamma >= 1/2"))
    p.add_argument("--b", type=float, help=coef("b", "HHT-ADD position weight b != 1/2"))
    p.add_argument("--rho-inf", type=float, dest="rho_inf",
                   help=coef("rho_inf", "generalized-alpha spectral radius at infinity in [0, 1]"))
    p.add_argument("--formulation", choices=["lagrange", "augmented"],
                   help="constraint formulation (default: the model's simulate block, else "
                        "lagrange); augmented: the index-3 augmented Lagrangian, through "
                        "singular positions and redundant joints (newmark, hht-i3, nstiff, "
                        "genalpha)")
    p.add_argument("--rtol", type=float, help="relative tolerance of each step's local position "
                   "error: error-controlled step sizes starting from h (default: the model's "
                   "simulate block, else fixed steps)")
    p.add_argument("--atol", type=float, help="absolute tolerance of the local position error "
                   "[m, rad] (default: rtol)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="override a model parameter (repeatable)")
    p.add_argument("--newton", choices=["full", "modified"], default="modified",
                   help="Jacobian policy of the Newton iteration (default modified)")
    # the names of integrators.engine.ENGINES, not imported here: that module
    # loads scipy and the assembly, which `mbdsl check` never needs
    p.add_argument("--engine", choices=["auto", "numpy", "compiled", "uncompiled"],
                   default="auto",
                   help="compiled: the numba kernels, every method and element; uncompiled: "
                        "the same kernels run by the Python interpreter, for debugging them "
                        "(slow, nothing compiled); numpy: the vectorised numpy assembly; auto "
                        "(default): compiled, or the uncompiled kernels while the compiled "
                        "ones are being built, or numpy where the kernels do not apply")
    rows = p.add_mutually_exclusive_group()
    rows.add_argument("--output-every", type=_positive_int, default=1, metavar="K",
                      help="record every K-th step (and the last): less memory on long runs")
    rows.add_argument("--output-dt", type=_positive_time, default=None, metavar="DT",
                      help="a row every DT seconds (and at t_end) instead of one per step, "
                           "interpolated within the steps; events keep their rows")
    rows.add_argument("--output-times", type=_times, default=None, metavar="T1,T2,...",
                      help="rows at exactly these times (and t_end)")


def _positive_time(text):
    """A positive time in seconds from the command line (``--output-dt``)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a time in seconds, got {text!r}") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"expected a positive time in seconds, got {text!r}")
    return value


def _times(text):
    """Comma-separated times in seconds (``--output-times``)."""
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected times in seconds separated by commas, got {text!r}") from None
    if not values:
        raise argparse.ArgumentTypeError("expected at least one time")
    return values


def _positive_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def _print_diagnostics(diags, err=None):
    err = err or sys.stderr
    sources = {}
    for d in diags:
        spans = [] if d.span is None else [d.span] + [s for s, _ in getattr(d.span, "via", ())]
        for span in spans + [s for s, _ in d.secondary]:
            if span.file not in sources:
                try:
                    sources[span.file] = Path(span.file).read_text(encoding="utf-8")
                except (OSError, UnicodeDecodeError):
                    sources[span.file] = None
    for d in diags:
        print(render(d, sources), file=err)
    n_err = sum(d.is_error for d in diags)
    n_warn = len(diags) - n_err
    if diags:
        print(f"{n_err} error{'s' if n_err != 1 else ''}, {n_warn} warning{'s' if n_warn != 1 else ''}",
              file=err)


def _load(args):
    """The checked model, or None after printing its diagnostics; the time
    taken is kept in ``args.load_time`` [s]."""
    import time
    t0 = time.perf_counter()
    try:
        model = load(args.model, _parse_set(args.set))
    except MbdError as exc:
        _print_diagnostics(exc.diagnostics)
        return None
    args.load_time = time.perf_counter() - t0
    _print_diagnostics(model.warnings)
    return model


def _print_rank(structure):
    if structure is not None:
        print(f"  DOF by rank = {structure.dof_rank} (rank of Phi_q {structure.rank} "
              f"at the assembled configuration)")


def _check(args) -> int:
    from .. import assemble, consistent_initial_state
    model = _load(args)
    if model is None:
        return 1
    states = (f", {len(model.states)} first-order state{'s' if len(model.states) != 1 else ''}"
              if model.states else "")
    print(f"{args.model}: model {model.name}, {len(model.bodies)} bodies{states}, "
          f"{model.n_coordinates} coordinates, {model.n_constraints} constraint equations")
    print(f"  DOF by count (Gruebler) = {model.dof}")
    if model.instances:
        from ..dsl.components import element_counts
        print("  built from components (elements by instance, with those it holds):")
        for path, comp, counts in element_counts(model):
            print(f"    {path} ({comp}): " + ", ".join(
                f"{n} {k if n != 1 else k[:-1].replace('ie', 'y')}" for k, n in counts.items()))
    from .. import redundant_policy
    try:
        init = consistent_initial_state(assemble(model), float(model.settings.get("t_start", 0.0)),
                                        redundant=redundant_policy(model))
    except MbdError as exc:
        _print_rank(getattr(exc, "structure", None))
        _print_diagnostics(exc.diagnostics)
        return 1
    _print_rank(init.structure)
    _print_diagnostics(init.warnings)
    print(init.report())
    return 0


def _static(args) -> int:
    """Print the static equilibrium: coordinates, joint reactions, driver and coupler
    loads, rope tensions."""
    import dataclasses

    import numpy as np

    from .. import assemble, consistent_initial_state
    from ..io.derived import LOAD_PREFIXES, derived_columns
    model = _load(args)
    if model is None:
        return 1
    model = dataclasses.replace(model, static=True)
    t0 = float(model.settings.get("t_start", 0.0))
    system = assemble(model)
    try:        # redundant joints (W405): the equilibrium is unique, their reactions not
        init = consistent_initial_state(system, t0, redundant="accept")
    except MbdError as exc:
        _print_diagnostics(exc.diagnostics)
        return 4
    _print_diagnostics(init.warnings)
    print(f"{args.model}: static equilibrium of model {model.name} at t = {t0:g} s")
    for name, value in zip(system.layout.coordinates, init.q):
        print(f"  {name:<24} {value: .9g}")
    derived = derived_columns(system, np.array([t0]), init.q[None], init.v[None],
                              init.lam[None])
    loads = [k for k in derived if k.startswith(LOAD_PREFIXES)]
    if loads:
        indeterminate = init.structure is not None and init.structure.dependent
        print("  loads [N, N m]:" + (" (redundant joints: one set of reactions of many that "
                                      "hold the equilibrium)" if indeterminate else ""))
        for k in loads:
            print(f"  {k:<24} {derived[k][0]: .6g}")
    print(f"  energy.potential         {derived['energy.potential'][0]: .9g} J")
    return 0


def _modes(args) -> int:
    """Print the modes about the chosen state and a method's damping of each."""
    from .. import assemble, load_solution
    from ..integrators import make_method, settings_coefficients
    from ..registry import DEFAULT_METHOD
    from ..modes import modes
    model = _load(args)
    if model is None:
        return 1
    system = assemble(model)
    solution, t, at = None, 0.0, args.at
    if at not in ("initial", "static"):
        path, sep, when = at.rpartition(":")
        try:
            t = float(when)
        except ValueError:
            path = ""
        if not sep or not path:
            raise argparse.ArgumentTypeError(
                f"--at expects initial, static or RESULT:T, got {at!r}")
        try:
            solution = load_solution(path)
        except (OSError, ValueError) as exc:
            print(f"mbdsl: error: cannot read the result {path!r}: {exc}", file=sys.stderr)
            return 1
    try:
        found = modes(system, at=at, k=args.k, highest=args.highest, solution=solution, t=t)
    except MbdError as exc:
        _print_diagnostics(exc.diagnostics)
        return 4
    except ValueError as exc:
        print(f"mbdsl: error: {exc}", file=sys.stderr)
        return 2
    s = model.settings
    name = args.method or s.get("method", DEFAULT_METHOD)
    h = args.h or s.get("h")
    method = make_method(name, **settings_coefficients(s, name))
    print(found.report(method, float(h)) if h else found.report())
    if args.plot:
        if not h:
            print("mbdsl: error: --plot needs a step size (--h or the model's)", file=sys.stderr)
            return 2
        from ..graphics.plotting import plot_mode_damping
        names = [m.strip() for m in args.methods.split(",")] if args.methods else [name]
        unknown = [m for m in names if m not in METHODS]
        if unknown:
            print(f"mbdsl: error: unknown method {unknown[0]!r}; available: "
                  f"{', '.join(sorted(METHODS))}", file=sys.stderr)
            return 2
        try:
            plot_mode_damping(found, [make_method(m, **settings_coefficients(s, m))
                                      for m in names], float(h), args.plot)
        except (OSError, ValueError) as exc:
            print(f"mbdsl: error: cannot write {args.plot!r}: {exc}", file=sys.stderr)
            return 1
        print(f"wrote {args.plot}")
    if args.animate:
        from ..modes import mode_motion
        from ..graphics.plotting import animate_solution
        index = args.mode or len(found.modes)
        try:
            motion = mode_motion(system, found, index)
            period = 2.0 * math.pi / found.modes[index - 1].omega
            animate_solution(motion, args.animate, fps=40.0, speed=period)
        except ValueError as exc:
            print(f"mbdsl: error: {exc}", file=sys.stderr)
            return 2
        except OSError as exc:
            print(f"mbdsl: error: cannot write {args.animate!r}: {exc}", file=sys.stderr)
            return 1
        print(f"wrote {args.animate} (mode {index}, {found.modes[index - 1].frequency:.4g} Hz)")
    return 0


def _run(args, model, observers=()):
    """(solution, exit status) of a model with the run options, or (None, status)."""
    from ..integrators import NewtonOptions
    from ..integrators.kernel_cache import background_allowed
    from ..progress import ProgressBar
    s = model.settings

    def announce(text):
        """Say what the engine is doing about its kernels (stderr; silent with -q)."""
        if not args.quiet:
            print(text, file=sys.stderr, flush=True)

    t_end = args.t_end if args.t_end is not None else s.get("t_end")
    h = args.h if args.h is not None else s.get("h")
    t_start = float(s.get("t_start", 0.0))
    if h is not None and t_end is not None and t_end > t_start and h >= t_end - t_start:
        _print_diagnostics([Diagnostic(
            "warning", "W601", f"the step h = {h:g} s is not smaller than the run "
            f"(t = {t_start:g} .. {t_end:g} s): it takes a single step of {t_end - t_start:g} s",
            None, "one step",
            hint="did you mean a smaller h (e.g. 1e-3), or a later --t-end?")])
    status = 0
    try:
        with ProgressBar(float(s.get("t_start", 0.0)), float(t_end or 0.0),
                         enabled=None if not args.quiet else False) as bar:
            sol = simulate(model, method=args.method, h=args.h, t_end=args.t_end,
                           newton=NewtonOptions(jacobian=args.newton), on_failure="return",
                           progress=bar, observers=observers, alpha=args.alpha, beta=args.beta, gamma=args.gamma,
                           b=args.b, rho_inf=args.rho_inf, engine=args.engine, output_every=args.output_every,
                           announce=announce, formulation=getattr(args, "formulation", None),
                           rtol=getattr(args, "rtol", None), atol=getattr(args, "atol", None),
                           output_dt=getattr(args, "output_dt", None),
                           output_times=getattr(args, "output_times", None),
                           compile_policy="background" if background_allowed() else "wait",
                           setup_time=getattr(args, "load_time", 0.0))
    except AssemblyError as exc:
        _print_diagnostics(exc.diagnostics)
        return None, 4
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return None, 1
    if sol.status == "failed":
        _print_diagnostics(sol.diagnostics)
        status = 3
    elif sol.status == "interrupted":
        print(sol.message, file=sys.stderr)
        status = 130
    return sol, status


class _StdoutColumns(RunObserver):
    """``simulate -o - --columns``: the table goes to standard output once
    the run ends; its columns are checked before the run starts, as a file's
    are (``io.stream.RowStream.on_start``), so that a wrong pattern costs no run."""

    def __init__(self, patterns):
        self.patterns, self.names = patterns, None

    def on_start(self, sol):
        """Choose the columns (``io.metadata.select_columns``); ValueError for a
        pattern matching none."""
        from ..io.metadata import select_columns
        self.names = select_columns(sol.columns, self.patterns)

    def close_unused(self):
        """No file was opened."""


def _simulate(args) -> int:
    model = _load(args)
    if model is None:
        return 1
    to_stdout = args.output == "-"      # the CSV on standard output, once the run ends
    if to_stdout and (args.plot or getattr(args, "html", False)):
        print("error: --plot and --html write files beside the output: give -o FILE, not -o -",
              file=sys.stderr)
        return 2
    out = Path(args.output) if args.output else Path(args.model).with_suffix(".csv")
    columns = ([c for c in args.columns.split(",") if c.strip()]
               if getattr(args, "columns", None) else None)
    try:       # written as the run goes, chunk by chunk
        if to_stdout:
            writer = None if columns is None else _StdoutColumns(columns)
        elif out.suffix.lower() not in HDF5_SUFFIXES:
            writer = CsvStream(out, columns=columns)
        else:
            from ..io.hdf5 import HdfStream
            writer = HdfStream(out, columns=columns)
    except OSError as exc:
        _write_error(out, exc)
        return 1
    try:
        sol, status = _run(args, model, () if writer is None else (writer,))
    except OSError as exc:
        _write_error(out, exc)
        return 1
    if sol is None:
        if writer is not None:
            writer.close_unused()
        return status
    if to_stdout:
        from ..io.csvfile import write_csv
        write_csv(sol, sys.stdout, columns=columns)
        sys.stdout.flush()
    if sol.initial is not None and sol.initial.warnings:
        _print_diagnostics(sol.initial.warnings)
    _print_diagnostics(sol.warnings)
    if sol.warnings and getattr(args, "strict", False) and status == 0:
        print(f"error: --strict: the run completed with {len(sol.warnings)} warning"
              f"{'s' if len(sol.warnings) > 1 else ''} "
              f"({', '.join(w.code for w in sol.warnings)}): counted as a failed run",
              file=sys.stderr)
        status = 3
    if not args.quiet:
        report = sys.stderr if to_stdout else sys.stdout     # stdout holds the table
        print(sol.initial.report(), file=report)
        print(sol.summary(), file=report)
        written = getattr(writer, "names", None) or sol.columns
        print(written_report(None if to_stdout else out, len(sol.t), len(written), sol.timings,
                             isinstance(writer, CsvStream)), file=report)
    if args.plot:
        from ..graphics.plotting import plot_solution
        fig_path = out.with_suffix(".png")
        try:
            plot_solution(sol, path=fig_path)
        except OSError as exc:
            _write_error(fig_path, exc)
            return status or 1
        if not args.quiet:
            print(f"wrote {fig_path}")
    if getattr(args, "html", False):
        return _write_page(sol, out.with_suffix(".html"), args) or status
    return status


def _write_error(path, exc) -> None:
    """Why a file cannot be written, in words (a missing folder named)."""
    path = Path(path)
    if not path.parent.exists():
        print(f"error: cannot write {path}: the folder {path.parent} does not exist",
              file=sys.stderr)
    else:
        print(f"error: cannot write {path}: {getattr(exc, 'strerror', None) or exc}",
              file=sys.stderr)


def _read_result(path):
    """A Solution from a result file, or None after printing why not."""
    if Path(path).suffix.lower() not in (".csv",) + HDF5_SUFFIXES:
        print(f"error: {path} is not a result file: plot reads a .csv or .h5 written by "
              "mbdsl simulate (for a model file, run: mbdsl simulate MODEL --plot)",
              file=sys.stderr)
        return None
    try:
        sol = load_solution(path)
        if sol.status == "running":      # streamed by a process that was stopped outright
            print(f"warning: {path} ended early: {sol.message}", file=sys.stderr)
        return sol
    except MbdError as exc:
        _print_diagnostics(exc.diagnostics)
    except (OSError, ValueError) as exc:
        print(f"error: cannot read {path}: {exc}", file=sys.stderr)
    return None


#: Columns ``mbdsl plot`` draws by default from a file written with some columns only.
MAX_PLOT_COLUMNS = 12


def _plot(args) -> int:
    from ..graphics.plotting import plot_solution
    sol = _read_result(args.result)
    if sol is None:
        return 1
    out = Path(args.output) if args.output else Path(args.result).with_suffix(".png")
    y = [c.strip() for c in args.y.split(",") if c.strip()] if args.y else None
    if y is None and getattr(sol, "written", None) is not None:
        # a file of some columns (simulate --columns) has not the standard panels' columns:
        # a plot of each column it holds
        y = [c for c in sol.written if c != args.x][:MAX_PLOT_COLUMNS]
        if len(sol.written) - 1 > MAX_PLOT_COLUMNS:
            print(f"note: {args.result} holds {len(sol.written) - 1} columns; plotting the first "
                  f"{MAX_PLOT_COLUMNS} (choose others with --y)", file=sys.stderr)
    try:
        bodies = [b.strip() for b in args.bodies.split(",") if b.strip()] if args.bodies \
            else None
        plot_solution(sol, y=y, x=args.x, path=out, bodies=bodies)
    except KeyError as exc:
        print(f"error: {exc.args[0]}", file=sys.stderr)
        return 1
    except OSError as exc:
        _write_error(out, exc)
        return 1
    except ValueError as exc:
        print(f"error: cannot write {out}: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {out}")
    return 0


def _source_run(args):
    """(solution, status) of ``args.source``: a result file read back, or a
    model file simulated with the run options; (None, exit status) after
    saying why there is none."""
    src = Path(args.source)
    if src.suffix.lower() in (".csv",) + HDF5_SUFFIXES:
        sol = _read_result(src)
        if sol is None:
            return None, 1
        missing = ([] if getattr(sol, "written", None) is None else
                   [c for c in sol.system.layout.coordinates if c not in sol.written])
        if missing:         # the mechanism is drawn from every coordinate
            print(f"error: {src} was written with some columns only (simulate --columns) and "
                  f"lacks {len(missing)} of the coordinates the drawing needs ({missing[0]}, "
                  "...): animate or view the model itself, or a file written without "
                  "--columns", file=sys.stderr)
            return None, 1
        return sol, 0
    args.model = args.source
    model = _load(args)
    if model is None:
        return None, 1
    return _run(args, model)


def _animate(args) -> int:
    from ..graphics.plotting import animate_solution
    src = Path(args.source)
    sol, status = _source_run(args)
    if sol is None:
        return status
    out = Path(args.output) if args.output else src.with_suffix(".gif")
    try:
        res = animate_solution(sol, out, fps=args.fps, speed=args.speed,
                               deform_scale=args.deform_scale)
    except OSError as exc:
        _write_error(out, exc)
        return 1
    except ValueError as exc:
        print(f"error: cannot write {out}: {exc}", file=sys.stderr)
        return 1
    if not args.quiet:
        print(f"wrote {out} ({res.frames} frames, t = {res.times[0]:g} .. {res.times[-1]:g} s)")
    return status


def _view(args) -> int:
    """``mbdsl view``: a result file, or a model simulated first, as an HTML page."""
    sol, status = _source_run(args)
    if sol is None:
        return status
    out = Path(args.output) if args.output else Path(args.source).with_suffix(".html")
    return _write_page(sol, out, args) or status


def _write_page(sol, out, args) -> int:
    """Write the run's HTML page (``viewer.write_html``); 0, or 1 after saying why not."""
    from ..graphics.viewer import MAX_FRAMES, write_html

    def listed(text):
        """Comma-separated names as a list, or None."""
        return [c.strip() for c in text.split(",") if c.strip()] if text else None
    try:
        write_html(sol, out, columns=listed(getattr(args, "y", None)),
                   bodies=listed(getattr(args, "bodies", None)),
                   max_frames=getattr(args, "frames", None) or MAX_FRAMES,
                   deform_scale=getattr(args, "deform_scale", 1.0))
    except KeyError as exc:
        print(f"error: {exc.args[0]}", file=sys.stderr)
        return 1
    except ValueError as exc:
        print(f"error: cannot write {out}: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        _write_error(out, exc)
        return 1
    if not args.quiet:
        print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB; open it in a browser)")
    return 0


def _study_options(args, model):
    """StudyOptions from the command line and the model's simulate section."""
    from .. import METHODS
    from ..studies import StudyOptions, parse_h_range
    s = model.settings
    t_end = args.t_end if args.t_end is not None else s.get("t_end")
    if t_end is None:
        raise ValueError("give --t-end (the model has no t_end in its simulate section)")
    if args.h:
        try:
            hs = [float(x) for x in args.h.split(",") if x.strip()]
        except ValueError:
            raise ValueError(f"--h expects comma-separated numbers, got '{args.h}'") from None
    elif args.h_range:
        hs = parse_h_range(args.h_range)
    elif s.get("h") is not None:
        hs = [float(s["h"]) * 2.0**k for k in (2, 1, 0, -1, -2)]
    else:
        raise ValueError("give --h or --h-range (the model has no h in its simulate section)")
    if any(h <= 0 for h in hs):
        raise ValueError("step sizes must be positive")
    methods = list(METHODS) if args.methods == "all" else \
        [m.strip() for m in args.methods.split(",") if m.strip()]
    if args.repeat < 1:
        raise ValueError("--repeat must be at least 1")
    sweep = None
    text = args.tol if args.tol is not None else "1e-3,1e-5,1e-7"
    try:
        if ":" in text:                      # FIRST:LAST, every decade between
            first, _, last = text.partition(":")
            a, b = float(first), float(last)
            k = math.log10(max(a, b) / min(a, b))
            if abs(k - round(k)) > 1e-9:
                raise ValueError
            tols = tuple(float(f"{max(a, b) / 10.0**i:.12g}") for i in range(int(round(k)) + 1))
        else:
            tols = tuple(float(x) for x in text.split(",") if x.strip())
    except (ValueError, ZeroDivisionError):
        raise ValueError(f"--tol expects comma-separated numbers or FIRST:LAST a whole number "
                         f"of decades apart, got '{text}'") from None
    if not tols or any(not (x > 0) for x in tols):
        raise ValueError("--tol: values must be positive")
    if args.tol is not None and args.kind == "work-precision":
        sweep = tols                     # the work-precision study sweeps tolerances
    return StudyOptions(methods=methods, hs=hs, t_end=float(t_end),
                        quantities=[x.strip() for x in args.quantity.split(",") if x.strip()],
                        reference=args.reference, repeat=args.repeat, joint=args.joint,
                        h_single=args.at_h, jobs=args.jobs, scheduler=args.scheduler,
                        tols=tols, sweep_tols=sweep)


def _study(args) -> int:
    from ..progress import TaskBar
    from ..studies import run_study
    model = _load(args)
    if model is None:
        return 1
    try:
        options = _study_options(args, model)
    except ValueError as exc:
        print(f"mbdsl study: error: {exc}", file=sys.stderr)
        return 2
    stem = Path(args.model).with_suffix("")
    out = Path(args.output) if args.output else stem.parent / f"{stem.name}_{args.kind}"
    log = (lambda text: None) if args.quiet else (lambda text: print(text, file=sys.stderr))
    command = "mbdsl " + " ".join(sys.argv[1:]) if sys.argv[1:2] == ["study"] else ""
    try:
        with TaskBar("runs", enabled=False if args.quiet else None) as bar:
            result = run_study(args.kind, args.model, options, _parse_set(args.set),
                               progress=bar, log=log, command=command)
    except AssemblyError as exc:
        _print_diagnostics(exc.diagnostics)
        return 4
    except MbdError as exc:
        _print_diagnostics(exc.diagnostics)
        return 1
    except (ValueError, ImportError, OSError, RuntimeError) as exc:
        print(f"mbdsl study: error: {exc}", file=sys.stderr)
        return 1
    try:
        files = result.write(out)
    except OSError as exc:
        _write_error(out / "index.md", exc)
        return 1
    if not args.quiet:
        print(result.text())
        print(f"\nwrote {len(files)} files to {out} (index: {files[-1]}); "
              f"study wall time {result.wall_time:.1f} s")
    return 0


def _sweep(args) -> int:
    """``mbdsl sweep``: the runs, the table, a summary of it."""
    from ..io.hdf5 import read_sweep
    from ..progress import TaskBar
    from ..studies.sweep import parse_distribution, parse_values, run_sweep, sweep_points
    try:
        grid, dists = {}, {}
        for text in args.set:
            name, eq, values = text.partition("=")
            if not eq or not name.strip():
                raise ValueError(f"--set expects NAME=VALUES, got {text!r}")
            grid[name.strip()] = parse_values(values)
        for text in args.distribution:
            name, eq, dist = text.partition("=")
            if not eq or not name.strip():
                raise ValueError(f"--distribution expects NAME=DIST, got {text!r}")
            dists[name.strip()] = parse_distribution(dist)
        points = sweep_points(grid, args.samples, dists, args.seed)
    except ValueError as exc:
        print(f"mbdsl sweep: error: {exc}", file=sys.stderr)
        return 2
    stem = Path(args.model).with_suffix("")
    out = Path(args.output) if args.output else stem.parent / f"{stem.name}_sweep.h5"
    columns = [c.strip() for c in args.columns.split(",") if c.strip()] if args.columns else None
    asked = {"set": args.set, "samples": args.samples, "distribution": args.distribution,
             "seed": args.seed, "method": args.method, "h": args.h, "t_end": args.t_end,
             "rtol": args.rtol}
    try:
        with TaskBar("runs", enabled=False if args.quiet else None) as bar:
            result = run_sweep(args.model, points, out, method=args.method, h=args.h,
                               t_end=args.t_end, tol=args.rtol, columns=columns,
                               jobs=args.jobs, scheduler=args.scheduler, progress=bar,
                               sweep=asked)
    except MbdError as exc:
        _print_diagnostics(exc.diagnostics)
        return 1
    except KeyError as exc:
        print(f"mbdsl sweep: error: {exc.args[0]}", file=sys.stderr)
        return 1
    except (ValueError, ImportError, OSError) as exc:
        print(f"mbdsl sweep: error: {exc}", file=sys.stderr)
        return 1
    if not args.quiet:
        table = read_sweep(out)
        names = list(grid) + list(dists)
        shown = names + ["status"] + [c for c in table if c.endswith(".final")][:3]
        print("  ".join(f"{c:>14}" for c in shown))
        for i in range(min(len(table["status"]), 20)):
            print("  ".join(f"{table[c][i]:>14.6g}" if c != "status" else
                            f"{table[c][i] + (' ' + table['code'][i] if table['code'][i] else ''):>14}"
                            for c in shown))
        if len(table["status"]) > 20:
            print(f"{'...':>14}")
        print(f"{result.points} points: {result.run} run now, {result.skipped} already in the "
              f"table, {result.failed} failed; wrote {out}")
    return 0


def main(argv=None) -> int:
    """Entry point of the ``mbdsl`` console script; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        commands = {"check": _check, "simulate": _simulate, "plot": _plot, "animate": _animate,
                    "view": _view, "sweep": _sweep,
                    "study": _study, "static": _static, "modes": _modes}
        return commands[args.command](args)
    except BrokenPipeError:           # the reader went away (| head): stop quietly
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except argparse.ArgumentTypeError as exc:
        print(f"mbdsl: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


def run() -> None:
    """The ``mbdsl`` console script and ``python -m mbdsl``: :func:`main`, then
    the process ends with its status without the interpreter's teardown.

    Why: once the compiled kernels are loaded, finalizing the interpreter
    (numba's and LLVM's objects) takes 0.3-0.4 s, a third of a whole
    ``mbdsl simulate models/slider_crank.mbd -o out.csv`` (measured on two
    cores: 1.20-1.48 s with the teardown, 0.94-1.02 s without). Nothing is
    left to it: every file a command writes is closed when the command
    returns (context managers: CSV, HDF5, plots, the study's worker pools),
    the background kernel build is a process of its own, and the output
    streams are flushed here. An exception that escapes :func:`main` (a bug)
    leaves the normal way, with its traceback.
    """
    status = main()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):      # a closed pipe or stream: nothing more to say
            pass
    os._exit(status)


if __name__ == "__main__":
    run()
