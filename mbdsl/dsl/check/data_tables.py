"""Pass 2, tables: ``table NAME(ARG) = [(x, y), ...]`` or ``= "file.csv"``, the
points read (inline: expressions of parameters with units; from a file: two
columns, the path relative to the model file, units in the header, ``x [s], F
[kN]``, or declared, ``units = (s, kN)``) and the interpolant built
(``model.table.build_table``: scipy's interpolators). Diagnostics: E202 (a name
declared twice, or a built-in function's), E303 (points that do not increase,
too few), E304/E305 (options), E307 (points of different kinds), E308 (a data
file missing or malformed: the file's line named).
"""

from __future__ import annotations

import csv
import hashlib
import io
import re
from pathlib import Path

import numpy as np

from ...model.table import EXTRAPOLATIONS, INTERPOLATIONS, build_table
from .. import units
from ..expressions import FUNCTIONS, PAIR_FUNCTIONS, Name, Vec
from ..unparse import expr_text
from .context import did_you_mean

#: a table's options and their defaults
TABLE_OPTIONS = {"interpolation": "linear", "extrapolation": "hold", "units": None}
#: ``x [m]``: a column's unit in a data file's header
_HEADER_UNIT = re.compile(r"\[([^\]]*)\]")


def check_tables(c):
    """Read every table's points and build its interpolant into ``c.tables``
    (name -> ``model.table.Table``), with its (argument, value) dimensions
    among ``c.param_dims`` (``units.table_key``)."""
    c.tables = {}
    spans = {}
    for s in c.spec.tables:
        ctx = f"table '{s.name}'"
        if s.name in spans:
            c.error("E202", f"duplicate table '{s.name}'", s.span, "declared again",
                    secondary=((spans[s.name], "first declared here"),))
            continue
        spans[s.name] = s.span
        if s.name in FUNCTIONS or s.name in PAIR_FUNCTIONS or s.name in ("clip", "if"):
            c.error("E202", f"'{s.name}' is a built-in function and cannot name a table",
                    s.span, "reserved name")
            continue
        opts = _options(c, s, ctx)
        if opts is None:
            continue
        read = _file_points(c, s, opts, ctx) if s.path is not None else _points(c, s, ctx)
        if read is None:
            continue
        x, y, dims, source, digest = read
        try:
            table = build_table(s.name, x, y, opts["interpolation"], opts["extrapolation"],
                                source, digest)
        except ValueError as err:
            c.error("E303", f"{ctx}: {err}", s.source_span or s.span, "not a table",
                    hint="give at least two points (x, y) with x increasing")
            continue
        c.tables[s.name] = table
        c.param_dims[units.table_key(s.name)] = dims


def _options(c, s, ctx) -> dict | None:
    """The table's options: interpolation, extrapolation (words) and units
    (a vector of two unit texts, or None); None after reporting."""
    opts = dict(TABLE_OPTIONS)
    for a in s.args:
        if a.keyword is None:
            c.error("E305", f"{ctx}: options are written 'name = value'", a.span,
                    "not an option", hint="interpolation = pchip, extrapolation = hold")
            return None
        if a.keyword not in TABLE_OPTIONS:
            c.error("E304", f"{ctx}: unknown option '{a.keyword}'", a.span, "unknown option",
                    hint=did_you_mean(a.keyword, TABLE_OPTIONS)
                    or f"options are {', '.join(TABLE_OPTIONS)}")
            return None
        if a.keyword == "units":
            if not isinstance(a.value, Vec):
                c.error("E305", f"{ctx}: 'units' is (unit of x, unit of y)", a.span,
                        "not two units", hint="units = (s, N)")
                return None
            opts["units"] = (expr_text(a.value.x), expr_text(a.value.y))
            continue
        allowed = INTERPOLATIONS if a.keyword == "interpolation" else EXTRAPOLATIONS
        word = a.value.name if isinstance(a.value, Name) else None
        if word not in allowed:
            c.error("E305", f"{ctx}: '{a.keyword}' is one of {', '.join(allowed)}",
                    getattr(a.value, "span", None) or a.span, f"not an {a.keyword}",
                    hint=did_you_mean(word or "", allowed) or f"e.g. {a.keyword} = {allowed[0]}")
            return None
        opts[a.keyword] = word
    return opts


def _points(c, s, ctx):
    """(x, y, (argument, value) dimensions, "inline", digest) of inline points;
    None after reporting."""
    if any(a.keyword == "units" for a in s.args):
        c.error("E304", f"{ctx}: 'units' is for a data file; inline points carry their own",
                s.span, "not for inline points", hint="write (0 rad/s, 20 N*m)")
        return None
    xs, ys, dims = [], [], [None, None]
    for p in s.points:
        for k, (e, out) in enumerate(((p.x, xs), (p.y, ys))):
            v = c.number(e, p.span or s.span, ctx)
            if v is None:
                return None
            try:
                d = units.dimension(e, c.param_dims)
            except units.DimensionError:
                d = None
            if d is not None and dims[k] is not None and d != dims[k]:
                c.error("E307", f"{ctx}: its {'xy'[k]} values are "
                        f"{units.describe(dims[k])} and {units.describe(d)}",
                        getattr(e, "span", None) or p.span, "another kind",
                        hint="give every point's value in units of one kind")
                return None
            dims[k] = dims[k] if d is None else d
            out.append(v)
    digest = hashlib.sha256(np.array(xs + ys, dtype=float).tobytes()).hexdigest()
    return xs, ys, tuple(dims), "inline", digest


def _file_points(c, s, opts, ctx):
    """(x, y [SI], dimensions, path, sha256 of the file) of a data file's two
    columns; None after reporting E308 (or E307 for a unit)."""
    base = Path(c.spec.file).parent if c.spec.file and not c.spec.file.startswith("<") \
        else Path.cwd()
    path = base / s.path
    try:
        data = path.read_bytes()
    except OSError as err:
        c.error("E308", f"{ctx}: cannot read '{s.path}' ({err.strerror or err})",
                s.source_span or s.span, "no such data file",
                hint=f"the path is relative to the model file's folder ({base})")
        return None
    text = data.decode("utf-8", errors="replace")
    rows, header = [], None
    for line_no, row in enumerate(csv.reader(io.StringIO(text)), start=1):
        cells = [x.strip() for x in row]
        if not any(cells) or cells[0].startswith("#"):
            continue
        try:
            values = [float(x) for x in cells if x != ""]
        except ValueError:
            if header is None and not rows:
                header = cells
                continue
            return _malformed(c, s, ctx, line_no, row, "expected two numbers")
        if len(values) != 2:
            return _malformed(c, s, ctx, line_no, row, f"expected two numbers, got {len(values)}")
        rows.append((line_no, cells, values))
    if len(rows) < 2:
        c.error("E308", f"{ctx}: '{s.path}' has {len(rows)} row{'s' * (len(rows) != 1)} of "
                "numbers; a table needs two at least", s.source_span or s.span,
                "too few points", hint="two columns x, y, one point per line")
        return None
    unit = [None, None]
    if header is not None:
        found = [_HEADER_UNIT.search(h) for h in header[:2]]
        unit = [m.group(1).strip() if m else None for m in found]
    if opts["units"] is not None:
        unit = list(opts["units"])
    factors, dims = [], []
    for u in unit:
        if u in (None, "", "1"):
            factors.append(None)
            dims.append(None if u is None else units.NONE)
            continue
        try:
            dims.append(units.unit_dimension(u))
            factors.append(u)
        except units.UnitError as err:
            c.error("E307", f"{ctx}: {err}", s.source_span or s.span, "not a unit",
                    hint="write a unit as in the language: m, mm, s, N, kN, N*m, rad/s")
            return None
    xs, ys = [], []
    for _, cells, values in rows:
        nums = [x for x in cells if x != ""]
        for k, out in enumerate((xs, ys)):
            out.append(values[k] if factors[k] is None else units.to_si(nums[k], factors[k]))
    return xs, ys, tuple(dims), str(s.path), hashlib.sha256(data).hexdigest()


def _malformed(c, s, ctx, line_no, row, what):
    """E308 naming the data file's line; None."""
    shown = ", ".join(row)
    c.error("E308", f"{ctx}: '{s.path}', line {line_no}: {what}, got '{shown}'",
            s.source_span or s.span, "malformed data file",
            hint="two columns of numbers, comma-separated; a header line of names "
                 "(with units in brackets: 'x [m], y [mm]') only first; '#' comments")
    return None
