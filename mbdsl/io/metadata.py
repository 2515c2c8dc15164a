"""What a result file says about its run besides the rows: the metadata, the
columns chosen, and the model rebuilt from the stored source.

A file is self-contained: :func:`rebuild_system` rebuilds the model from the
stored source text and parameter values, so a result can be plotted or
animated on a machine that never saw the ``.mbd`` file.
"""

from __future__ import annotations

import difflib
import json
import re
from dataclasses import asdict

from ..version import __version__
from .rows import RunStats

__all__ = ["select_columns", "metadata", "rebuild_system", "run_description",
           "unfinished_message", "method_parameters", "run_stats"]


def _pattern(text: str) -> str:
    """A column pattern as a regular expression: ``*`` any run of characters,
    ``?`` one, everything else literal (``link[99999].*``: the brackets are
    part of the name, not a character class as in shell globs)."""
    return "".join(".*" if c == "*" else "." if c == "?" else re.escape(c) for c in text)


def select_columns(names, patterns) -> list[str]:
    """The columns of ``names`` that match any of ``patterns`` (``*`` and
    ``?`` wildcards, :func:`_pattern`), in the order of ``names``, with "t"
    always first (``mbdsl simulate --columns``).

    Parameters
    ----------
    names : sequence of str
        Every column of the run (``Solution.columns``).
    patterns : sequence of str

    Raises
    ------
    ValueError
        A pattern that matches no column, with the closest names.
    """
    texts = [p.strip() for p in patterns if p.strip()]
    # one alternation, one match per column (1.4 million columns of a 100 000-link chain)
    anyof = re.compile("(?:" + "|".join(f"(?P<p{k}>{_pattern(p)})" for k, p in enumerate(texts))
                       + r")\Z")
    chosen, hit = ["t"], set()
    for n in names:
        found = anyof.match(n)
        if found is not None:
            hit.add(found.lastgroup)
            if n != "t":
                chosen.append(n)
    for k, text in enumerate(texts):
        if f"p{k}" in hit or any(re.match(_pattern(text) + r"\Z", n) for n in names):
            continue        # (a column that an earlier pattern took as well)
        close = difflib.get_close_matches(text.replace("*", ""), list(names), n=3)
        raise ValueError(f"--columns: '{text}' matches no column of this run"
                         + (f"; did you mean {', '.join(close)}?" if close else
                            " (mbdsl check lists the model's elements)"))
    return chosen


def metadata(solution, extra: dict | None = None, final: bool = True,
             columns: list | None = None) -> dict:
    """Everything about a run that is not a time history, as str -> str.

    Keys: ``mbdsl_version``, ``model``, ``model_file``, ``model_sha256``,
    ``model_source`` (JSON string), ``model_parameters`` (JSON object),
    ``method``, ``formulation``, ``method.<coefficient>``, ``h``, ``t_end``, ``status``,
    ``message``, ``extras`` (JSON list), ``units`` (JSON object: column ->
    SI unit, "" for none or mixed), ``stats_total`` (JSON object),
    ``wall_time``, ``engine``, ``linear_solver``, ``timings`` (JSON object);
    for a model that imports components ``imports`` (JSON object: the file's
    key -> sha256 and source: :attr:`Model.imports`, so that the result file
    rebuilds its model without the library files);
    for a model with tables ``tables`` (JSON object: name -> source, sha256,
    interpolation, extrapolation, x, y: :func:`table_record`);
    for a model with contacts or joint limits ``events`` (JSON list of [t [s],
    gap, "closed" or "opened", speed [m/s or rad/s]]: when and which gap of a
    contact or limit closed or opened, with its approach or separation
    speed) and ``event_cuts`` (steps retaken to land on them); for a finished
    run (``final``) ``warnings`` (JSON list of [code, message]: what the run's
    own rows say is wrong with it, ``Solution.warnings``). A file of some
    columns only (``columns``, :func:`select_columns`) also has ``columns``
    (JSON list of the columns written), and ``units`` has only those.
    """
    model = solution.model
    meta = {
        "mbdsl_version": __version__,
        "model": model.name,
        "model_file": model.file,
        "model_sha256": model.sha256,
        "method": solution.method_name,
        "formulation": getattr(solution, "formulation", "lagrange"),
    }
    meta.update({f"method.{k}": repr(float(v)) for k, v in solution.method_parameters.items()})
    control = getattr(solution, "control", None)
    if control is not None:           # error-controlled steps; h is the first step's size
        meta.update({"rtol": repr(control.rtol), "atol": repr(control.atol)})
    meta.update({"h": repr(solution.h), "t_end": repr(solution.t_end),
                 "status": solution.status, "message": solution.message.replace("\n", " ")})
    if model.parameters:
        meta["parameters"] = ", ".join(f"{k}={float(v)!r}" for k, v in model.parameters.items())
    meta["model_parameters"] = json.dumps({k: float(v) for k, v in model.parameters.items()})
    meta["extras"] = json.dumps(list(solution.extra_names))
    units = solution.column_units()
    if columns is not None:
        meta["columns"] = json.dumps(list(columns))
        units = {k: units[k] for k in columns if k in units}
    meta["units"] = json.dumps(units)
    meta["stats_total"] = json.dumps(asdict(solution.stats_total))
    meta["wall_time"] = repr(float(solution.wall_time))
    meta["engine"] = solution.engine
    meta["linear_solver"] = solution.linear_solver
    meta["timings"] = json.dumps(solution.timings)
    if solution.events or getattr(solution.system, "contact_state", None) is not None:
        meta["events"] = json.dumps([[float(t), name, kind, float(speed)]
                                     for t, name, kind, speed in solution.events])
        meta["event_cuts"] = str(int(solution.event_cuts))
    if getattr(solution, "dense", False):    # not one row per step (integrators.dense)
        meta["rows"] = "at requested times"
    if final:
        meta["warnings"] = json.dumps([[w.code, w.message] for w in solution.warnings])
    if getattr(model, "tables", ()):     # each table's points, where they came from, and how read
        meta["tables"] = json.dumps({t.name: table_record(t) for t in model.tables})
    if getattr(model, "imports", None):  # the component libraries, so the file rebuilds alone
        meta["imports"] = json.dumps({k: {"sha256": sha, "source": text}
                                      for k, (text, sha) in model.imports.items()})
    meta["model_source"] = json.dumps(model.source)      # one line: newlines escaped
    meta.update(extra or {})
    return meta


def table_record(table) -> dict:
    """A table's record in the metadata: its source (a data file's path or
    "inline"), the sha256 of the points as read (the file's bytes), the
    interpolation and extrapolation, and the points [SI]."""
    x = [float(v) for v in table.x]
    y = [table.value(v) for v in x]
    return {"source": table.source, "sha256": table.digest,
            "interpolation": table.interpolation, "extrapolation": table.extrapolation,
            "x": x, "y": y}


def rebuild_system(meta: dict, path):
    """The AssembledSystem of a stored run, from its metadata (source + parameters).

    Raises
    ------
    ValueError
        The file holds no model source (written by an older version or for a
        model built in Python without source text).
    MbdError
        The stored source no longer parses (a newer language version).
    """
    from ..assembly.system import assemble
    from ..dsl.check import check_spec
    from ..dsl.parser import parse_text
    source = json.loads(meta["model_source"]) if "model_source" in meta else None
    if not source:
        raise ValueError(f"{path}: the file holds no model source; load_solution needs it to "
                         "rebuild the model (results of models built in Python without text "
                         "cannot be reloaded)")
    params = json.loads(meta.get("model_parameters", "{}"))
    stored = {k: v["source"] for k, v in json.loads(meta.get("imports", "{}")).items()}
    model = check_spec(parse_text(source, meta.get("model_file", str(path))), params, stored)
    return assemble(model)


def run_description(meta: dict) -> dict:
    """``timings``, ``engine``, ``linear_solver``, ``events``,
    ``event_cuts``, ``dense`` and ``warnings`` of a stored run, for :meth:`Solution.from_arrays`
    (absent from files of older versions)."""
    return {"timings": json.loads(meta.get("timings", "{}")),
            "engine": meta.get("engine", "numpy"),
            "linear_solver": meta.get("linear_solver", "dense"),
            "events": [(float(t), str(name), str(kind), float(speed))
                       for t, name, kind, speed in json.loads(meta.get("events", "[]"))],
            "event_cuts": int(meta.get("event_cuts", 0)),
            "dense": meta.get("rows") == "at requested times",
            "warnings": (None if "warnings" not in meta else
                         [(str(c), str(m)) for c, m in json.loads(meta["warnings"])])}


def unfinished_message(t, t_end: float) -> str:
    """What a result file whose status is still ``running`` says: its run was
    stopped outright while it wrote the file (rows at times t [s])."""
    if not len(t):
        return "the run did not finish: the file has no rows"
    return (f"the run did not finish: the file ends at t = {float(t[-1]):.6g} s of "
            f"{float(t_end):g} s (the process writing it was stopped)")


def method_parameters(meta: dict) -> dict:
    """The method's coefficients of a stored run (its ``method.<name>``
    entries, :func:`metadata`), name -> value (dimensionless)."""
    return {k[7:]: float(v) for k, v in meta.items() if k.startswith("method.")}


def run_stats(meta: dict) -> RunStats:
    """The Newton totals of a stored run (its ``stats_total`` entry), or
    zeros for a file of an older version that has none."""
    return RunStats(**json.loads(meta["stats_total"])) if "stats_total" in meta else RunStats()
