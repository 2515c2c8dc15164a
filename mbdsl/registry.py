"""The integration methods by name: one leaf registry.

The language checks (``dsl/check/``), the command line, the studies and the
integrators take method names, their coefficients and their defaults from
here, and the coefficients' ranges (``check_coefficient``): the integrators'
constructors and the checks of a model file's ``simulate`` section refuse the same
values with the same message. A leaf module (only ``math``), so that checking a
model file does not import the integrators. The classes themselves live in
``mbdsl/integrators`` (one file per method; ``integrators.METHODS`` maps these
names to them, and a test checks that the coefficients and defaults below are
their constructors').

Adding a method: its file in ``mbdsl/integrators``, one entry here, and its
class in ``integrators/__init__.py``'s ``_CLASSES`` (``docs/architecture.md``).
"""

from __future__ import annotations

import math

__all__ = ["METHOD_COEFFICIENTS", "METHOD_NAMES", "DEFAULT_METHOD", "COEFFICIENTS",
           "methods_taking", "check_range", "check_coefficient"]

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


def check_range(name: str, value: float, ok: bool, allowed: str, reason: str) -> float:
    """Validate a method coefficient.

    Parameters
    ----------
    name : str
        The coefficient's name, as in the model file (``alpha``).
    value : float
        Its value (dimensionless).
    ok : bool
        Whether ``value`` is in the allowed range.
    allowed, reason : str
        The range and why, for the message.

    Returns
    -------
    float
        ``value`` as a float.

    Raises
    ------
    ValueError
        Naming the parameter, the value, the allowed range and the reason, when
        ``ok`` is false or the value is not finite.
    """
    value = float(value)
    if not math.isfinite(value) or not ok:
        raise ValueError(f"{name} = {value:g} is out of range: {allowed} ({reason})")
    return value


def check_coefficient(name: str, value: float, gamma: float = 0.5) -> float:
    """Validate one method coefficient against its range.

    The ranges are those of unconditional stability and of the order the
    methods are named for (docs/methods.md): HHT's alpha in [-1/3, 0] (Hilber,
    Hughes and Taylor 1977), Newmark's gamma >= 1/2 and beta >= (gamma + 1/2)^2/4
    (Newmark 1959), generalized-alpha's rho_inf in [0, 1] (Chung and Hulbert
    1993), HHT-ADD's free coefficient b != 1/2 (Negrut, Jay and Khude).

    Parameters
    ----------
    name : str
        One of :data:`COEFFICIENTS`.
    value : float
        Its value (dimensionless).
    gamma : float, optional
        Newmark's gamma, which bounds beta (only read for ``"beta"``).

    Returns
    -------
    float
        ``value`` as a float.

    Raises
    ------
    ValueError
        The value out of its range (naming range and reason), or an unknown name.
    """
    value = float(value)
    if name == "alpha":
        return check_range("alpha", value, -1.0 / 3.0 - 1e-12 <= value <= 0.0, "[-1/3, 0]",
                           "HHT is unconditionally stable and second order only in this range")
    if name == "gamma":
        return check_range("gamma", value, value >= 0.5, "gamma >= 1/2",
                           "smaller gamma amplifies high frequencies")
    if name == "beta":
        limit = (gamma + 0.5) ** 2 / 4.0
        return check_range("beta", value, value >= limit * (1.0 - 1e-12),
                           f"beta >= (gamma + 1/2)^2 / 4 = {limit:g}",
                           "unconditional stability of the linear test problem")
    if name == "rho_inf":
        return check_range("rho_inf", value, 0.0 <= value <= 1.0, "[0, 1]",
                           "the spectral radius at infinity of a stable method")
    if name == "b":
        return check_range("b", value, abs(value - 0.5) > 1e-12, "b != 1/2",
                           "with b = 1/2 the Newton matrix is singular as h -> 0")
    raise ValueError(f"unknown method coefficient '{name}'; coefficients are "
                     f"{', '.join(COEFFICIENTS)}")
