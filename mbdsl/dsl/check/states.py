"""Pass 10, first-order states: ``state NAME { der = expr; initial expr }``, each
state named (its name read by every expression after this pass, as a body's
field is), then its rate compiled as a force's magnitude is
(``forces.force_function``: of time, or of time and the state with exact partial
derivatives) and its initial value evaluated. Diagnostics: E202 (a name taken by
a parameter, a table, an element or another state, or reserved), E302 (no
``der``), E304 (an unknown property), E301/E307 (values).
"""

from __future__ import annotations

from ...model.elements import FirstOrderState
from ..expressions import CONSTANTS, FUNCTIONS, PAIR_FUNCTIONS
from .context import did_you_mean

#: a state's properties
STATE_PROPERTIES = ("der", "initial")


def check_states(c):
    """Name every state (``c.states``: name -> FirstOrderState index), then build
    ``c.first_order`` (the FirstOrderState elements, in declaration order)."""
    c.states, c.first_order = {}, []
    declared = []
    for s in c.spec.states:
        if s.name in ("t",) or s.name in CONSTANTS or s.name in FUNCTIONS \
                or s.name in PAIR_FUNCTIONS or s.name in ("clip", "if"):
            c.error("E202", f"'{s.name}' is a built-in name and cannot name a state", s.span,
                    "reserved name", hint="choose another name")
            continue
        taken = ("parameter" if s.name in c.params else "table" if s.name in c.tables
                 else None)
        if taken is not None:
            c.error("E202", f"state '{s.name}': the name is a {taken}'s", s.span,
                    "name taken", hint="states, parameters and tables share the names an "
                    "expression reads: choose another name")
            continue
        if not c.claim(s.name, s.span, "state"):
            continue
        c.states[s.name] = len(declared)
        declared.append(s)
    for k, s in enumerate(declared):
        state = _state(c, s, k)
        if state is None:
            c.broken_names.add(s.name)
        c.first_order.append(state)
    if any(s is None for s in c.first_order):
        c.first_order = [s for s in c.first_order if s is not None]


def _state(c, s, k):
    """The FirstOrderState of a declaration (index k); None after reporting."""
    from .forces import force_function
    ctx = f"state '{s.name}'"
    props = {}
    for p in s.properties:
        if p.name not in STATE_PROPERTIES:
            c.error("E304", f"{ctx}: unknown property '{p.name}'", p.span, "unknown property",
                    hint=did_you_mean(p.name, STATE_PROPERTIES)
                    or "a state has 'der = <its rate>' and 'initial <value>'")
            return None
        if p.name in props:
            c.error("E202", f"{ctx}: '{p.name}' given twice", p.span, "given again")
            return None
        props[p.name] = p
    if "der" not in props:
        c.error("E302", f"{ctx} has no rate", s.span, "der missing",
                hint=f"write its differential equation: state {s.name} {{ der = ...; "
                "initial 0 }")
        return None
    der = props["der"]
    fn = force_function(c, der.value, der.span, f"{ctx}: der")
    if fn is None:
        return None
    initial = 0.0
    if "initial" in props:
        p = props["initial"]
        initial = c.number(p.value, p.span, f"{ctx}: initial")
        if initial is None:
            return None
    return FirstOrderState(s.name, k, fn, float(initial), s.span)
