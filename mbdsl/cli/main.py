"""The ``mbdsl`` command line: ``mbdsl simulate FILE`` and ``mbdsl check FILE``.

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
import sys
from pathlib import Path

from .. import (METHODS, AssemblyError, ConvergenceError, MbdError, __version__, load,
                render, simulate)
from ..output import write_csv

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

    sim = sub.add_parser("simulate", help="simulate a model and write its time histories")
    sim.add_argument("model", help="model file (.mbd)")
    sim.add_argument("-o", "--output", help="output CSV (default: beside the model, MODEL.csv)")
    sim.add_argument("--method", choices=sorted(METHODS), help="integration method")
    sim.add_argument("--h", type=float, help="step size [s]")
    sim.add_argument("--t-end", type=float, help="end time [s]")
    sim.add_argument("--alpha", type=float, help="HHT alpha in [-1/3, 0] (hht-i3, hht-si2, hht-add)")
    sim.add_argument("--beta", type=float, help="Newmark beta >= (gamma + 1/2)^2/4 (newmark)")
    sim.add_argument("--gamma", type=float, help="Newmark gamma >= 1/2 (newmark)")
    sim.add_argument("--b", type=float, help="HHT-ADD position weight b != 1/2 (hht-add)")
    sim.add_argument("--set", action="append", metavar="NAME=VALUE",
                     help="override a model parameter (repeatable)")
    sim.add_argument("--newton", choices=["full", "modified"], default="modified",
                     help="Jacobian policy of the Newton iteration")
    sim.add_argument("-q", "--quiet", action="store_true", help="print no summary")

    chk = sub.add_parser("check", help="check a model file and print every diagnostic")
    chk.add_argument("model", help="model file (.mbd)")
    chk.add_argument("--set", action="append", metavar="NAME=VALUE",
                     help="override a model parameter (repeatable)")
    return p


def _print_diagnostics(diags, err=None):
    err = err or sys.stderr
    sources = {}
    for d in diags:
        if d.span is not None and d.span.file not in sources:
            try:
                sources[d.span.file] = Path(d.span.file).read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError):
                pass
    for d in diags:
        print(render(d, sources), file=err)
    n_err = sum(d.is_error for d in diags)
    n_warn = len(diags) - n_err
    if diags:
        print(f"{n_err} error{'s' if n_err != 1 else ''}, {n_warn} warning{'s' if n_warn != 1 else ''}",
              file=err)


def _load(args):
    """The checked model, or None after printing its diagnostics."""
    try:
        model = load(args.model, _parse_set(args.set))
    except MbdError as exc:
        _print_diagnostics(exc.diagnostics)
        return None
    _print_diagnostics(model.warnings)
    return model


def _check(args) -> int:
    model = _load(args)
    if model is None:
        return 1
    print(f"{args.model}: model {model.name}, {len(model.bodies)} bodies, "
          f"{model.n_coordinates} coordinates, {model.n_constraints} constraints, "
          f"{model.dof} DOF (Gruebler)")
    return 0


def _simulate(args) -> int:
    model = _load(args)
    if model is None:
        return 1
    out = Path(args.output) if args.output else Path(args.model).with_suffix(".csv")
    from ..integrators import NewtonOptions
    status = 0
    try:
        sol = simulate(model, method=args.method, h=args.h, t_end=args.t_end,
                       newton=NewtonOptions(jacobian=args.newton), on_failure="return",
                       alpha=args.alpha, beta=args.beta, gamma=args.gamma, b=args.b)
    except AssemblyError as exc:
        _print_diagnostics(exc.diagnostics)
        return 4
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if sol.status == "failed":
        _print_diagnostics(sol.diagnostics)
        status = 3
    elif sol.status == "interrupted":
        print(sol.message, file=sys.stderr)
        status = 130
    try:
        write_csv(sol, out)
    except OSError as exc:
        print(f"error: cannot write {out}: {exc}", file=sys.stderr)
        return 1
    if not args.quiet:
        print(sol.initial.report())
        print(sol.summary())
        print(f"wrote {out} ({len(sol.t)} rows, {len(sol.columns)} columns)")
    return status


def main(argv=None) -> int:
    """Entry point of the ``mbdsl`` console script; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        if args.command == "check":
            return _check(args)
        return _simulate(args)
    except argparse.ArgumentTypeError as exc:
        print(f"mbdsl: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
