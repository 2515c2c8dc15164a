"""The integration methods by name: one leaf registry.

The language checks (``dsl/check.py``), the command line, the studies and the
integrators take method names, their coefficients and their defaults from
here; nothing else lists them. A leaf module (no imports), so that checking a
model file does not import the integrators. The classes themselves live in
``mbdsl/integrators`` (one file per method; ``integrators.METHODS`` maps these
names to them, and a test checks that the coefficients and defaults below are
their constructors').

Adding a method: its file in ``mbdsl/integrators``, one entry here, and its
class in ``integrators/__init__.py``'s ``_CLASSES`` (``docs/architecture.md``).
"""

from __future__ import annotations

__all__ = ["METHOD_COEFFICIENTS", "METHOD_NAMES", "DEFAULT_METHOD", "COEFFICIENTS",
           "methods_taking"]

#: The method names -> {coefficient: default}: the paper's six in the paper's order,
#: then generalized-alpha (beyond the paper) at index 3 and stabilized index 2.
METHOD_COEFFICIENTS: dict[str, dict[str, float]] = {
    "newmark": {"gamma": 0.6, "beta": 0.3025},
    "hht-i3": {"alpha": -0.05},
    "nstiff": {},
    "nstiff-si2": {},
    "hht-add": {"alpha": -0.05, "b": 0.0},
    "hht-si2": {"alpha": -0.05},
    "genalpha": {"rho_inf": 0.9},
    "genalpha-si2": {"rho_inf": 0.9},
}

#: The method names, in order.
METHOD_NAMES: tuple[str, ...] = tuple(METHOD_COEFFICIENTS)

#: The method a model file or a call without one runs.
DEFAULT_METHOD = "hht-i3"

#: Every coefficient any method takes, in first-use order.
COEFFICIENTS: tuple[str, ...] = tuple(dict.fromkeys(
    c for coefs in METHOD_COEFFICIENTS.values() for c in coefs))


def methods_taking(coefficient: str) -> tuple[str, ...]:
    """The methods that take ``coefficient`` (e.g. ``"alpha"``), in order."""
    return tuple(m for m, coefs in METHOD_COEFFICIENTS.items() if coefficient in coefs)
