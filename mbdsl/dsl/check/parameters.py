"""Pass 1, parameters: evaluated in order with their units, ``--set`` overrides
applied. Diagnostics: E202 (duplicate or reserved name), E301 (an override that
is not a finite number or expression), E201 (an override of no parameter).
"""

from __future__ import annotations

import math

from .. import units
from ..expressions import evaluate, ExprError
from .context import did_you_mean


# -- passes ---------------------------------------------------------------
def check_parameters(c):
    """Evaluate parameters in order, applying overrides."""
    spans = {}
    for p in c.spec.parameters:
        if p.name in spans:
            c.error("E202", f"duplicate parameter '{p.name}'", p.span,
                    "declared again", secondary=((spans[p.name], "first declared here"),)
                    if spans[p.name] else ())
            continue
        spans[p.name] = p.span
        if p.name in ("t", "pi"):
            c.error("E202", f"'{p.name}' is reserved and cannot be a parameter", p.span,
                    "reserved name")
            continue
        if p.name in c.overrides:
            value = c.overrides.pop(p.name)
            if isinstance(value, str):
                from ..grammar import as_expr
                try:
                    value = evaluate(as_expr(value), c.params)
                except ExprError as err:
                    c.error("E301", f"--set {p.name}={value}: {err}", None)
                    c.broken_names.add(p.name)
                    continue
                except Exception as exc:  # noqa: BLE001 - MbdSyntaxError of the override text
                    c.error("E301", f"--set {p.name}={value}: not a valid expression ({exc})", None)
                    c.broken_names.add(p.name)
                    continue
            value = float(value)
            if not math.isfinite(value):
                c.error("E301", f"--set {p.name}: the value is not finite", None)
                c.broken_names.add(p.name)
                continue
            c.params[p.name] = value
            continue
        v = c.number(p.value, p.span, f"parameter '{p.name}'")
        if v is not None:
            c.params[p.name] = v
            # a parameter written with units has their dimension wherever it is used
            c.param_dims[p.name] = units.dimension(p.value, c.param_dims)
        else:
            c.broken_names.add(p.name)
    for name in c.overrides:
        c.error("E201", f"--set {name}: the model has no parameter '{name}'", None,
                hint=did_you_mean(name, spans) or
                f"its parameters are {', '.join(spans) or '(none)'}")
