"""Parameter sweeps: one model run over a grid, or random samples, of its
parameters (``mbdsl sweep``), each run's chosen outputs gathered into one
table.

A sweep is a list of points, each a value for every swept parameter: the
cartesian product of the grid (``--set k=100:1000:10``: ten values from
100 to 1000; ``--set c=1,5,10``: those three), crossed with ``samples``
random draws of the distributed parameters (``--distribution
c=normal(5,0.5)``, ``uniform(a,b)``, ``lognormal(mu,sigma)`` of the
logarithm; numpy's generator with ``seed``: the same sweep draws the same
points). Every point is one run of the model with those parameters
(:func:`run_point`), the runs executed as independent tasks by
:mod:`.parallel` (local processes, or a Dask cluster's workers with
``scheduler``). A run gives, per chosen column, its final value, its
minimum and its maximum over the run, its status: ``completed``, or
``failed`` with the first diagnostic's code (E601, E602, ...) and the
message, which does not stop the sweep, and the engine that ran it.

The table (``hdf5.SweepTable``) gets a row as each run finishes, flushed:
a sweep stopped midway keeps its finished runs, and the same sweep run
again with the same output skips the points already in the table.
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass

import numpy as np

__all__ = ["parse_values", "parse_distribution", "sweep_points", "run_point", "run_sweep",
           "SweepResult"]

_CALL = re.compile(r"^\s*(normal|uniform|lognormal)\s*\(\s*([^,()]+)\s*,\s*([^,()]+)\s*\)\s*$")


def parse_values(text: str) -> list[float]:
    """The values of a swept parameter: ``a:b:n`` (n values evenly from a to
    b, both included), or ``v1,v2,...``.

    Raises
    ------
    ValueError
        Not numbers, or n < 1.
    """
    try:
        if ":" in text:
            a, b, n = text.split(":")
            if int(n) != float(n) or int(n) < 1:
                raise ValueError
            return [float(x) for x in np.linspace(float(a), float(b), int(n))]
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"expected values as a:b:n (n values from a to b) or v1,v2,..., "
                         f"got {text!r}") from None


def parse_distribution(text: str) -> tuple[str, float, float]:
    """``normal(mu,sigma)``, ``uniform(a,b)`` or ``lognormal(mu,sigma)`` ->
    (kind, first, second).

    Raises
    ------
    ValueError
        Another form, a non-number, sigma < 0 or b < a.
    """
    m = _CALL.match(text)
    try:
        kind, p1, p2 = m.group(1), float(m.group(2)), float(m.group(3))
    except (AttributeError, ValueError):
        raise ValueError(f"expected normal(mu,sigma), uniform(a,b) or lognormal(mu,sigma), "
                         f"got {text!r}") from None
    if (kind == "uniform" and p2 < p1) or (kind != "uniform" and p2 < 0):
        raise ValueError(f"{text}: {'b < a' if kind == 'uniform' else 'sigma < 0'}")
    return kind, p1, p2


def sweep_points(grid: dict, samples: int = 0, distributions: dict | None = None,
                 seed: int = 0) -> list[dict]:
    """The sweep's points (module notes): name -> value dicts.

    Parameters
    ----------
    grid : dict of str -> list of float
    samples : int
        Random draws of ``distributions`` (0: none).
    distributions : dict of str -> (kind, p1, p2), optional
        From :func:`parse_distribution`.
    seed : int

    Raises
    ------
    ValueError
        A parameter both on the grid and distributed; distributions without
        samples, or samples without distributions.
    """
    distributions = distributions or {}
    both = set(grid) & set(distributions)
    if both:
        raise ValueError(f"parameter {sorted(both)[0]!r} is both on the grid and distributed")
    if bool(samples) != bool(distributions):
        raise ValueError("random samples need --samples N and at least one --distribution")
    names = list(grid)
    points = [dict(zip(names, values)) for values in itertools.product(*grid.values())]
    if not samples:
        return points
    rng = np.random.default_rng(seed)
    draws = {}
    for name, (kind, p1, p2) in distributions.items():
        draw = {"normal": rng.normal, "uniform": rng.uniform, "lognormal": rng.lognormal}[kind]
        draws[name] = draw(p1, p2, size=samples)
    return [dict(p, **{name: float(d[i]) for name, d in draws.items()})
            for i in range(samples) for p in points]


@dataclass(frozen=True)
class SweepTask:
    """What every run of a sweep shares (picklable: sent to the workers).

    Attributes
    ----------
    text, file : str
        The model's source and file name.
    method : str or None
    h, t_end : float or None [s]
        None: the model's simulate section.
    tol : float or None
        rtol = atol for error-controlled steps (None: the model's setting).
    columns : tuple of str
        The columns whose final value, minimum and maximum each run gives.
    """

    text: str
    file: str
    method: str | None
    h: float | None
    t_end: float | None
    tol: float | None
    columns: tuple


def run_point(task: SweepTask, point: dict) -> dict:
    """One run of a sweep at ``point`` (parameter -> value): a row of the
    table. Never raises for what the model or the run does wrong: the row
    says ``failed`` with the code and message."""
    import time

    from .. import load_text, simulate
    from ..errors import MbdError
    row = dict(point)
    row.update(status="failed", code="", message="", steps=0, wall_time=0.0, engine="")
    t0 = time.perf_counter()
    try:
        model = load_text(task.text, task.file, {k: repr(float(v)) for k, v in point.items()})
        sol = simulate(model, method=task.method, h=task.h, t_end=task.t_end,
                       on_failure="return", rtol=task.tol, atol=task.tol,
                       compile_policy="wait")
    except MbdError as exc:
        diag = exc.diagnostics[0] if exc.diagnostics else None
        row.update(code=diag.code if diag else "", message=str(diag.message if diag else exc))
        return row
    except ValueError as exc:        # options the run refuses (no code: the message says)
        row.update(message=str(exc))
        return row
    row["wall_time"] = time.perf_counter() - t0
    row["steps"] = sol.stats_total.steps
    row["engine"] = sol.engine
    row["status"] = sol.status
    if sol.status != "completed":
        diag = sol.diagnostics[0] if sol.diagnostics else None
        row.update(code=diag.code if diag else "", message=sol.message)
    for name in task.columns:
        values = sol.column(name)
        row[f"{name}.final"] = float(values[-1])
        row[f"{name}.min"] = float(np.min(values))
        row[f"{name}.max"] = float(np.max(values))
    return row


def default_columns(model) -> tuple:
    """The model's ``output`` columns, else the first body's coordinates and
    the total energy."""
    if model.outputs:
        return tuple(f"output.{o.name}" for o in model.outputs)
    first = model.bodies[0]
    coords = ("x", "y") if getattr(first, "particle", False) else ("x", "y", "phi")
    return tuple(f"{first.name}.{c}" for c in coords) + ("energy.total",)


@dataclass
class SweepResult:
    """What :func:`run_sweep` did.

    Attributes
    ----------
    points : int
        The sweep's points.
    run, skipped, failed : int
        Runs made now, points already in the table, runs made now that failed.
    path : Path
    """

    points: int
    run: int
    skipped: int
    failed: int
    path: object


def run_sweep(model_path, points: list, output, *, method=None, h=None, t_end=None, tol=None,
              columns=None, jobs=None, scheduler=None, progress=None, on_row=None,
              sweep: dict | None = None) -> SweepResult:
    """Run a sweep (module notes) into the table at ``output``.

    Parameters
    ----------
    model_path : str or Path
    points : list of dict
        From :func:`sweep_points`.
    output : str or Path
        The HDF5 table; an existing one of the same sweep is continued.
    method, h, t_end, tol : optional
        As :class:`SweepTask`.
    columns : sequence of str, optional
        Default: :func:`default_columns`.
    jobs : int, optional
        Local worker processes (default: the cores).
    scheduler : str, optional
        A Dask scheduler's address.
    progress : callable (done, total), optional
    on_row : callable (dict), optional
        Told each row as it is written.
    sweep : dict, optional
        How the sweep was asked for (stored in the table's attributes).

    Raises
    ------
    MbdError
        The model itself has errors (before any run).
    KeyError
        An unknown column, with the closest names.
    ValueError
        A table at ``output`` written by another sweep (other parameters or
        columns).
    """
    from pathlib import Path

    from .. import load
    from ..io.hdf5 import SweepTable
    from .parallel import run_tasks
    path = Path(model_path)
    model = load(path)                   # the model's own errors, once, before any run
    columns = tuple(columns) if columns else default_columns(model)
    from .. import assemble
    from ..io.derived import result_columns
    known = set(result_columns(assemble(model), ("mu", "psi1")))
    for c in columns:
        if c not in known:
            import difflib
            close = difflib.get_close_matches(c, sorted(known), n=3)
            raise KeyError(f"no column '{c}'" + (f"; did you mean {', '.join(close)}?"
                                                 if close else ""))
    task = SweepTask(path.read_text(encoding="utf-8"), str(path), method, h, t_end, tol,
                     columns)
    params = list(points[0]) if points else []
    names = params + ["status", "code", "message", "steps", "wall_time", "engine"] + [
        f"{c}.{k}" for c in columns for k in ("final", "min", "max")]
    table = SweepTable(output, names, params, {"model": model.name, "model_file": str(path),
                                               "model_source": task.text,
                                               "sweep": repr(sweep or {})})
    done = table.done()
    todo = [p for p in points if tuple(float(p[k]) for k in params) not in done]
    skipped, failed = len(points) - len(todo), 0
    count = [skipped]

    def finished(row):
        """A run's row: into the table, counted, told to the callbacks."""
        nonlocal failed
        table.append(row)
        failed += row["status"] != "completed"
        count[0] += 1
        if on_row is not None:
            on_row(row)
        if progress is not None:
            progress(count[0], len(points))
    try:
        if progress is not None:
            progress(skipped, len(points))
        run_tasks(run_point, [(task, p) for p in todo], jobs=jobs, scheduler=scheduler,
                  on_done=finished)
    finally:
        table.close()
    return SweepResult(len(points), len(todo), skipped, failed, Path(output))
