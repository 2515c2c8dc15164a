"""Units in model files: ``mass 3 kg``, ``point O (-15 cm, 0)``, ``h 1 ms``.

A number may carry a unit, written right after it on the same line and
without spaces inside the unit (``kg*m^2``, ``N/m``, ``N*m*s/rad``). Every
quantity is converted to SI when the file is parsed; the conversion factor and
the dimension come from pint, the only module of mbdsl that imports it (and
only when a file uses a unit, so that plain models pay nothing for it).

Dimensions are checked where a value has a meaning (a mass, a length, a
stiffness...): :func:`dimension` infers the dimension of an expression and
:func:`expected` names the one a property, option or setting needs. Plain
numbers stay SI and radians, as they always were; an expression is checked
only where every factor carries a unit, so mixing plain SI numbers and
quantities (``0.1 + 5 cm``) is allowed and never a false error.

Angles are dimensionless (the radian is the SI unit of a plane angle and pint
treats it as 1), so ``270 deg`` is accepted wherever an angle or a plain
number is; an angular velocity is 1/s (``60 rpm`` is 2 pi rad/s). ``Hz`` is
deliberately not a unit here: as an angular rate it would silently mean
rad/s, a factor 2 pi from what is usually meant; write ``rev/s`` or ``rpm``.

Conversions are exact in decimal: a factor that pint gives as a short decimal
(``cm``: 0.01) is taken as that decimal, so ``15 cm`` is the same double as
``0.15``, bit for bit, and a model written with units gives the same results to
the last digit as the model written in SI numbers.
"""

from __future__ import annotations

import functools
import math
import re
from fractions import Fraction

__all__ = ["UNIT_PATTERN", "Dimension", "UnitError", "to_si", "unit_dimension", "expected",
           "describe", "dimension", "has_unit", "COLUMN_UNITS", "column_unit",
           "reference_dimension", "unit_text", "DimensionError"]

#: The unit symbols a model may write, longest first so that the lexer's
#: alternation prefers ``mm`` over ``m``. A closed list keeps the language
#: unambiguous: a name after a number is a unit only if it is one of these
#: (``h`` is the step-size setting, not the hour; ``t`` is time, not the tonne).
SYMBOLS = ("kPa", "MPa", "GPa", "rpm", "rev", "rad", "deg", "min", "kg", "mg", "cm", "mm",
           "um", "km", "ms", "us", "kN", "mN", "Pa", "kJ", "kW", "g", "m", "s", "N", "J", "W")
_SYM = "(?:" + "|".join(SYMBOLS) + r")(?![A-Za-z0-9_])(?:\^-?\d+)?"
#: A unit as the lexer reads it: symbols joined by * and / (``kg*m^2/s``).
UNIT_PATTERN = _SYM + r"(?:[*\/]" + _SYM + ")*"      # "\/": the grammar writes it in /.../


class UnitError(ValueError):
    """A unit that cannot be read or converted (raised with the unit text)."""


# ---------------------------------------------------------------------------
# Dimensions: exponents of mass, length and time (angles are dimensionless)
# ---------------------------------------------------------------------------

class Dimension(tuple):
    """Exponents (mass, length, time) of a planar-mechanics quantity.

    Built as ``Dimension((1, 2, 0))`` for kg m^2. Products and quotients add
    and subtract exponents; ``**`` scales them.
    """

    def __mul__(self, other):
        return Dimension(a + b for a, b in zip(self, other))

    def __truediv__(self, other):
        return Dimension(a - b for a, b in zip(self, other))

    def __pow__(self, k):
        return Dimension(a * k for a in self)


NONE = Dimension((0, 0, 0))
#: The base of expected dimensions: SI symbols in mass, length and time.
_BASE = {"kg": (1, 0, 0), "m": (0, 1, 0), "s": (0, 0, 1), "N": (1, 1, -2), "Pa": (1, -1, -2),
         "J": (1, 2, -2), "W": (1, 2, -3), "rad": (0, 0, 0), "1": (0, 0, 0)}
#: What a dimension is called in messages.
_NAMES = {(1, 0, 0): "a mass", (0, 1, 0): "a length", (0, 0, 1): "a time",
          (0, 0, 0): "an angle or a plain number", (1, 2, 0): "a moment of inertia",
          (1, 1, -2): "a force", (1, 2, -2): "a torque or an energy", (0, 1, -1): "a velocity",
          (0, 0, -1): "an angular velocity", (0, 1, -2): "an acceleration",
          (1, 0, -2): "a stiffness (force per length)", (1, 0, -1): "a damping (force per velocity)",
          (1, 2, -1): "a rotational damping (torque per angular velocity)",
          (1, -1, -2): "a pressure or modulus", (0, 2, 0): "an area",
          (0, 4, 0): "a second moment of area", (1, -3, 0): "a density",
          (0, 0, -2): "an angular acceleration"}


@functools.lru_cache(maxsize=None)
def expected(spec: str) -> Dimension:
    """The dimension named by an SI unit string such as ``"kg*m^2"``,
    ``"N*m/rad"`` or ``"1"`` (no pint needed: these are the units the checker
    expects, written with the SI symbols of :data:`_BASE`)."""
    dim = NONE
    for sign, sym, power in re.findall(r"([*/]?)\s*([A-Za-z1]+)(?:\^(-?\d+))?", spec):
        d = Dimension(_BASE[sym]) ** int(power or 1)
        dim = dim / d if sign == "/" else dim * d
    return dim


def describe(dim: Dimension) -> str:
    """``a length``, ``a force``... or the dimension in SI symbols."""
    if tuple(dim) in _NAMES:
        return _NAMES[tuple(dim)]
    parts = [f"{s}^{e}" if e != 1 else s for s, e in zip(("kg", "m", "s"), dim) if e]
    return "kg^a m^b s^c = " + "*".join(parts)


# ---------------------------------------------------------------------------
# pint: conversion factors and dimensions of the units a file writes
# ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def _registry():
    import pint                 # imported only when a model writes a unit
    return pint.UnitRegistry()


_PINT_DIMS = {"[mass]": 0, "[length]": 1, "[time]": 2}


@functools.lru_cache(maxsize=None)
def _unit(text: str) -> tuple[Fraction, Dimension]:
    """(factor to SI as an exact fraction, dimension) of a unit text."""
    reg = _registry()
    pint_text = re.sub(r"\brev\b", "revolution", text.replace("^", "**"))
    try:
        q = reg.Quantity(1, pint_text).to_base_units()
    except Exception as exc:    # noqa: BLE001 - pint raises several types for bad units
        raise UnitError(f"unknown unit '{text}' ({exc})") from None
    exps = [0, 0, 0]
    for name, power in q.dimensionality.items():
        if name not in _PINT_DIMS or power != int(power):
            raise UnitError(f"'{text}' is not a unit of planar mechanics (it has {name})")
        exps[_PINT_DIMS[name]] = int(power)
    factor = float(q.magnitude)
    # a short decimal factor is exact in decimal (cm: 0.01): keep it exact
    return Fraction(repr(factor)), Dimension(exps)


def to_si(number: str, unit: str) -> float:
    """The SI value of ``number unit`` (``"15", "cm"`` -> 0.15), correctly
    rounded from the exact product of the written number and the factor.

    Raises
    ------
    UnitError
        The unit is not known to pint or has a dimension outside mass,
        length and time.
    """
    factor, _ = _unit(unit)
    try:
        return float(Fraction(number) * factor)
    except OverflowError:           # 1e400 kg: infinite, as the plain number 1e400 is
        return float("inf")


def unit_dimension(unit: str) -> Dimension:
    """The dimension of a unit text (``"N/m"`` -> (1, 0, -2))."""
    return _unit(unit)[1]


# ---------------------------------------------------------------------------
# Dimension of an expression
# ---------------------------------------------------------------------------

class DimensionError(ValueError):
    """Two parts of an expression with different dimensions are added or
    compared; ``span`` is the operator's place."""

    def __init__(self, message, span=None):
        super().__init__(message)
        self.span = span


def has_unit(expr) -> bool:
    """Whether any number in the expression carries a unit."""
    from .expressions import Binary, Call, Cond, Num, TableCall, Unary
    if isinstance(expr, Num):
        return expr.unit is not None
    if isinstance(expr, Unary):
        return has_unit(expr.operand)
    if isinstance(expr, Binary):
        return has_unit(expr.left) or has_unit(expr.right)
    if isinstance(expr, (Call, TableCall)):
        return has_unit(expr.arg)
    if isinstance(expr, Cond):
        return any(has_unit(a) for a in (expr.test, expr.then, expr.other))
    return False


#: functions whose argument and value are plain numbers (angles for the trigonometric)
_PLAIN_FUNCTIONS = {"sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh",
                    "exp", "log", "sign"}


def reference_dimension(ref) -> Dimension | None:
    """The dimension of a reference to the state or to a result column by its
    last part (``arm.T.x``: a length; ``reaction.O.fx``: a force), or None."""
    unit = "J" if ref.obj == "energy" else COLUMN_UNITS.get(
        ref.attr if isinstance(ref.attr, str) else "")
    return expected(unit) if unit else None


#: SI units written for a dimension (output columns)
_UNIT_TEXT = {(0, 1, 0): "m", (1, 0, 0): "kg", (0, 0, 1): "s", (1, 1, -2): "N",
              (1, 2, -2): "N*m", (0, 1, -1): "m/s", (0, 0, -1): "rad/s", (0, 1, -2): "m/s^2",
              (0, 0, -2): "rad/s^2", (1, 2, 0): "kg*m^2", (1, 0, -2): "N/m",
              (1, 0, -1): "N*s/m", (1, -1, -2): "Pa", (1, 2, -3): "W", (0, 0, 0): ""}


def unit_text(dim: Dimension | None) -> str:
    """The SI unit of a dimension as a column's metadata writes it (``""``
    for none or undetermined)."""
    if dim is None:
        return ""
    if tuple(dim) in _UNIT_TEXT:
        return _UNIT_TEXT[tuple(dim)]
    return "*".join(f"{s}^{e}" if e != 1 else s for s, e in zip(("kg", "m", "s"), dim) if e)


def _integer(x: float) -> bool:
    """Whether x is a finite whole number of sensible size (an exponent)."""
    return math.isfinite(x) and abs(x) < 1e6 and x == int(x)


class _Soft:
    """The dimension of ``t`` (a time) and of a function's value (a plain
    number) where nothing written fixes it: a factor with that dimension in a
    product or quotient with a determined quantity (``3 kg*t`` is kg s;
    ``A*sin(w*t)`` has A's dimension), but free like a plain number where it
    stands alone or in a sum (``0.72 + t`` is an angle written in SI, with
    an unwritten 1 rad/s)."""

    __slots__ = ("d",)

    def __init__(self, d):
        self.d = Dimension(d)


def dimension(expr, names: dict, references=None) -> Dimension | None:
    """The dimension of ``expr``, or None where it is not determined.

    A number with a unit has that unit's dimension; a plain number, a
    parameter written without units and any reference to the state are
    undetermined (None): they are SI values of whatever dimension the context
    needs (so is ``pi``). ``t`` is a time and a function's value a plain
    number as factors of a product or quotient with a determined part
    (``3 kg*t`` is kg s, ``A*sin(t)`` A's dimension), and undetermined
    otherwise (``0.72 + t`` is an angle in SI). ``names`` maps parameter
    names to their dimension (or None); ``references`` (optional) gives the
    dimension of a dotted reference such as ``arm.T.x``
    (:func:`reference_dimension`). Sums and comparisons of two determined
    parts must agree; products, quotients and powers of determined parts
    combine; anything multiplied by an undetermined part is undetermined.

    Raises
    ------
    DimensionError
        Two determined parts of a sum, a difference, a comparison or the two
        branches of ``if`` differ, or a function of plain numbers gets a
        quantity with a dimension.
    """
    d = _dimension(expr, names, references)
    return d if isinstance(d, Dimension) else None


def _hard(d):
    """A determined dimension, or None (a soft one counts as undetermined)."""
    return d if isinstance(d, Dimension) else None


def _product(a, b, op):
    """a * b or a / b over determined, soft and undetermined (None) parts."""
    if a is None or b is None:
        return None
    da = a.d if isinstance(a, _Soft) else a
    db = b.d if isinstance(b, _Soft) else b
    d = da * db if op == "*" else da / db
    return _Soft(d) if isinstance(a, _Soft) and isinstance(b, _Soft) else d


def table_key(name: str) -> str:
    """The key of a table's (argument, value) dimensions among the names'
    dimensions (``road()``: apart from a parameter of the same name)."""
    return f"{name}()"


def _table_dimension(call, dims, names, references):
    """A table's value's dimension, its argument's checked against the
    table's (``dims``: (argument, value), None where the table's points
    carry no unit)."""
    arg = _hard(_dimension(call.arg, names, references))
    want, value = dims
    if arg is not None and want is not None and arg != want:
        raise DimensionError(f"{call.func}() reads {describe(want)}, got {describe(arg)}",
                             call.span)
    return value


_NODES: tuple = ()


def _nodes() -> tuple:
    """The expression node classes (imported once: expressions imports this module)."""
    global _NODES
    if not _NODES:
        from .expressions import Binary, Call, Cond, Dotted, Name, Num, Unary
        _NODES = (Binary, Call, Cond, Dotted, Name, Num, Unary)
    return _NODES


def _dimension(expr, names: dict, references=None):
    """:func:`dimension` with soft parts (:class:`_Soft`) still soft."""
    Binary, Call, Cond, Dotted, Name, Num, Unary = _NODES or _nodes()
    if isinstance(expr, Num):
        return unit_dimension(expr.unit) if expr.unit is not None else None
    if isinstance(expr, Dotted):
        return references(expr) if references is not None else None
    if isinstance(expr, Name):
        if expr.name == "t":
            return _Soft(expected("s"))
        return names.get(expr.name) if expr.name != "pi" else None
    if isinstance(expr, Unary):
        return _dimension(expr.operand, names, references)
    if isinstance(expr, Binary):
        a = _dimension(expr.left, names, references)
        b = _dimension(expr.right, names, references)
        if expr.op in ("*", "/"):
            return _product(a, b, expr.op)
        if expr.op == "^":
            base = a.d if isinstance(a, _Soft) else a
            if base is None or base == NONE:
                return a
            k = None
            if isinstance(expr.right, Num) and expr.right.unit is None \
                    and _integer(expr.right.value):
                k = int(expr.right.value)
            elif isinstance(expr.right, Unary) and isinstance(expr.right.operand, Num) \
                    and _integer(expr.right.operand.value):
                k = (-int(expr.right.operand.value) if expr.right.op == "-"
                     else int(expr.right.operand.value))
            if k is None:
                return None
            return _Soft(base ** k) if isinstance(a, _Soft) else base ** k
        a, b = _hard(a), _hard(b)              # sums, comparisons: soft parts are free
        if expr.op in ("min", "max"):
            if a is not None and b is not None and a != b:
                raise DimensionError(f"{expr.op}() of {describe(a)} and {describe(b)}",
                                     expr.span)
            return a if a is not None else b
        if expr.op in "+-" or expr.op in ("<", ">", "<=", ">="):
            if a is not None and b is not None and a != b:
                what = "compared with" if expr.op in ("<", ">", "<=", ">=") else \
                    ("added to" if expr.op == "+" else "subtracted from")
                first, second = (b, a) if expr.op in "+-" else (a, b)
                raise DimensionError(f"{describe(first)} {what} {describe(second)}",
                                     expr.span)
            if expr.op in ("<", ">", "<=", ">="):
                return NONE if a is not None or b is not None else None
            return a if a is not None else b
        return None
    if isinstance(expr, Call) and table_key(expr.func) in names:
        return _table_dimension(expr, names[table_key(expr.func)], names, references)
    if isinstance(expr, Call):
        arg = _dimension(expr.arg, names, references)
        if expr.func in _PLAIN_FUNCTIONS:
            d = _hard(arg)
            if d is not None and d != NONE:
                raise DimensionError(f"{expr.func}() takes an angle or a plain number, "
                                     f"got {describe(d)}", expr.span)
            # its value is a plain number: NONE where the argument is one
            return NONE if d is not None else _Soft(NONE)
        if expr.func == "sqrt":
            base = arg.d if isinstance(arg, _Soft) else arg
            if base is not None and all(e % 2 == 0 for e in base):
                half = Dimension(e // 2 for e in base)
                return _Soft(half) if isinstance(arg, _Soft) else half
            return None
        if expr.func == "abs":
            return arg
        return None
    if isinstance(expr, Cond):
        _dimension(expr.test, names, references)
        a = _dimension(expr.then, names, references)
        b = _dimension(expr.other, names, references)
        ha, hb = _hard(a), _hard(b)
        if ha is not None and hb is not None and ha != hb:
            raise DimensionError(f"the branches of if() are {describe(ha)} and {describe(hb)}",
                                 expr.span)
        return ha if ha is not None else hb
    return None


# ---------------------------------------------------------------------------
# Units of result columns (CSV/HDF5 metadata and plot axes)
# ---------------------------------------------------------------------------

#: Unit of a column by its last dotted part (``crank.phi`` -> rad).
COLUMN_UNITS = {"t": "s", "x": "m", "y": "m", "phi": "rad", "vx": "m/s", "vy": "m/s",
                "omega": "rad/s", "ax": "m/s^2", "ay": "m/s^2", "alpha": "rad/s^2",
                "fx": "N", "fy": "N", "torque": "N*m", "force": "N", "kinetic": "J",
                "potential": "J", "total": "J", "elastic": "J", "work": "J", "h": "s",
                "angle": "rad", "rate": "rad/s", "distance": "m", "speed": "m/s",
                "deflection_mid": "m", "tension": "N",
                # spatial bodies (``model.spatial``): directors are numbers, their rates 1/s
                "z": "m", "vz": "m/s", "az": "m/s^2", "fz": "N", "tx": "N*m", "ty": "N*m",
                "tz": "N*m", "wx": "rad/s",
                "wy": "rad/s", "wz": "rad/s", "e0": "", "e1": "", "e2": "", "e3": "",
                "yaw": "rad", "pitch": "rad", "roll": "rad"}
COLUMN_UNITS.update({f"A{i}{j}{rate}": unit for i in "123" for j in "123"
                     for rate, unit in (("", ""), ("_t", "1/s"), ("_tt", "1/s^2"))})


#: A flexible beam's elastic coordinate (nodal u, v, theta) and its rates.
_ELASTIC = re.compile(r"^(u|v|theta)\d+(_t|_tt)?$")


def column_unit(name: str) -> str:
    """The SI unit of a result column (``""`` when it has none or is mixed,
    like the multipliers of a joint's rows and the constraint residuals)."""
    if name.startswith("energy."):
        return "J"
    if name.startswith(("lambda.", "drift.", "output.", "newton.")):
        return ""               # by the row or expression (Solution.column_units), or counts
    last = name.rsplit(".", 1)[-1]
    elastic = _ELASTIC.match(last)
    if elastic and "." in name:       # a beam's nodal displacement (m) or rotation (rad)
        base = "m" if elastic.group(1) in "uv" else "rad"
        return base + {None: "", "_t": "/s", "_tt": "/s^2"}[elastic.group(2)]
    return COLUMN_UNITS.get(last, "")
