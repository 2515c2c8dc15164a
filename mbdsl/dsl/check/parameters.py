"""Pass 1, parameters: evaluated in order with their units, ``--set`` overrides
applied. Diagnostics: E202 (duplicate or reserved name), E301 (an override that
is not a finite number or expression), E201 (an override of no parameter).
"""

from __future__ import annotations

import math

from .. import units
from ..expressions import evaluate, ExprError


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
            apply_override(c, p.name, c.overrides.pop(p.name))
            continue
        set_parameter(c, p)
    # an override of no parameter is reported after the loops' pass, which
    # evaluates the parameters of instances in ``for`` blocks (``l[3].L``)


def set_parameter(c, p):
    """Evaluate parameter ``p`` (a ParameterSpec) into ``c.params`` with the
    dimension its units give it; a broken name after reporting."""
    v = c.number(p.value, p.span, f"parameter '{p.name}'")
    if v is None:
        c.broken_names.add(p.name)
        return
    c.params[p.name] = v
    # a parameter written with units has their dimension wherever it is used
    c.param_dims[p.name] = units.dimension(p.value, c.param_dims)


def apply_override(c, name, value):
    """Set parameter ``name`` to a ``--set`` value (a number or an expression
    of the parameters before it); E301 when it is not a finite number."""
    if isinstance(value, str):
        from ..grammar import as_expr
        try:
            value = evaluate(as_expr(value), c.params)
        except ExprError as err:
            c.error("E301", f"--set {name}={value}: {err}", None)
            c.broken_names.add(name)
            return
        except Exception as exc:  # noqa: BLE001 - MbdSyntaxError of the override text
            c.error("E301", f"--set {name}={value}: not a valid expression ({exc})", None)
            c.broken_names.add(name)
            return
    value = float(value)
    if not math.isfinite(value):
        c.error("E301", f"--set {name}: the value is not finite", None)
        c.broken_names.add(name)
        return
    c.params[name] = value
