"""Functions of the state compiled with their exact partial derivatives:
the loads' and the first-order states' f(t, x) of the state variables an
expression reads (``model.functions.StateFunction``), and the kinks of the
tables of the state in them, located as events.
"""

from __future__ import annotations

from ...model.functions import StateFunction, StateSwitch
from ..expressions import ExprError, compile_state_function, diff, kinked_tables


def state_function(c, e, variables, span, context, grads=None):
    """f(t, x) (StateFunction) of an expression ``e`` whose state variables
    are named (``state_expression``), with its exact partial derivatives
    with respect to each of ``variables`` (or ``grads``, where the caller
    has them: one expression per variable); None after reporting."""
    names = tuple(v.name for v in variables)
    try:
        grads = tuple(grads) if grads is not None else tuple(diff(e, name) for name in names)
    except ExprError as err:
        c.expr_error(err, span, context)
        return None
    return StateFunction(compile_state_function(e, names),
                         tuple(compile_state_function(g, names) for g in grads),
                         variables, expr=e, grad_exprs=grads,
                         switches=state_switches(e, names, variables))


def state_switches(e, names, variables) -> tuple:
    """The kinks of the tables of the state in ``e`` (``kinked_tables``), as
    :class:`~mbdsl.model.elements.StateSwitch` es: located as events."""
    from ..unparse import expr_text
    return tuple(StateSwitch(f"{call.table.name}({expr_text(call.arg)})",
                             compile_state_function(call.arg, names), call.arg, variables, kinks)
                 for call, kinks in kinked_tables(e))
