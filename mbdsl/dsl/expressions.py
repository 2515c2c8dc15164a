"""Whitelisted arithmetic expressions: evaluation, time derivatives, compilation.

Parameter values, body data and time functions in a model file are small
expression trees (never Python ``eval``). The allowed vocabulary is
``+ - * / ^``, parentheses, numbers, declared parameters, ``pi``, ``t`` (only
where a function of time is allowed) and the functions in :data:`FUNCTIONS`.

Rheonomic constraints need Phi_t and Phi_tt, so a time function f(t) is
differentiated symbolically here (:func:`diff`) rather than by finite
differences: the derivatives are exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Union

from ..errors import Span

__all__ = [
    "Num", "Name", "IndexedName", "Dotted", "Unary", "Binary", "Call", "TableCall", "Vec", "Expr",
    "FUNCTIONS", "PAIR_FUNCTIONS", "OPCODES", "ExprError", "evaluate", "evaluate_rows", "free_names",
    "substitute", "diff", "sum_of",
    "postfix",
    "simplify", "compile_function", "compile_state_function",
]


@dataclass(frozen=True)
class Num:
    """A number literal; ``value`` in SI. A number written with a unit
    (``15 cm``) keeps the number as written and the unit (``"15"``, ``"cm"``)
    for messages, dimension checks and writing the model back."""

    value: float
    span: Span | None = None
    unit: str | None = None
    written: str | None = None


@dataclass(frozen=True)
class Name:
    """A reference to a parameter, ``pi`` or ``t``."""

    name: str
    span: Span | None = None


@dataclass(frozen=True)
class IndexedName:
    """``link[i]``: a name indexed by an integer expression (inside for blocks).

    Resolved to the plain name ``"link[3]"`` when the loop is expanded.

    ``base`` is a str, or an IndexedName itself where an indexed name is
    nested in an indexed instance of a component (``l[i].s[j]``); ``suffix``
    follows the index (``".b"`` in ``l[i].b``, a body of component instance
    ``l[i]``), so the name resolves to ``"l[3].b"``.
    """

    base: object
    index: "Expr"
    span: Span | None = None
    suffix: str = ""

    @property
    def text(self) -> str:
        """The name as written, e.g. ``"link[...]"``."""
        base = self.base.text if isinstance(self.base, IndexedName) else self.base
        return f"{base}[...]{self.suffix}"


@dataclass(frozen=True)
class Dotted:
    """``body.point`` (or ``joint.angle``): a reference, not a number.

    ``obj`` is a str, or an IndexedName before loop expansion.
    """

    obj: object
    attr: str
    span: Span | None = None

    @property
    def text(self) -> str:
        """The reference as written, e.g. ``"crank.O"`` (``"arm.T.x"``: obj is
        itself a Dotted, a point of a body)."""
        obj = self.obj.text if isinstance(self.obj, (IndexedName, Dotted)) else self.obj
        attr = self.attr.text if isinstance(self.attr, IndexedName) else self.attr
        return f"{obj}.{attr}"


@dataclass(frozen=True)
class Unary:
    """``-x``."""

    op: str
    operand: "Expr"
    span: Span | None = None


@dataclass(frozen=True)
class Binary:
    """``a op b`` with op in ``+ - * / ^``."""

    op: str
    left: "Expr"
    right: "Expr"
    span: Span | None = None


@dataclass(frozen=True)
class Call:
    """``f(x)`` for f in :data:`FUNCTIONS`."""

    func: str
    arg: "Expr"
    span: Span | None = None


@dataclass(frozen=True)
class TableCall:
    """``road(x)``: a declared table (``model.table.Table``) at its argument,
    after :func:`substitute`; ``order`` > 0: its order-th derivative with
    respect to the argument (from :func:`diff`)."""

    table: object
    arg: "Expr"
    order: int = 0
    span: Span | None = None


@dataclass(frozen=True)
class Cond:
    """``if(test, then, other)``: ``then`` where ``test`` is not 0, else
    ``other``; only the chosen branch is evaluated where evaluation can fail
    (:func:`evaluate`), and the derivative is that of the chosen branch."""

    test: "Expr"
    then: "Expr"
    other: "Expr"
    span: Span | None = None


@dataclass(frozen=True)
class Vec:
    """A vector ``(x, y)`` of two expressions, or ``(x, y, z)`` of three in a
    spatial model (``z`` None in a planar vector)."""

    x: "Expr"
    y: "Expr"
    span: Span | None = None
    z: "Expr | None" = None


Expr = Union[Num, Name, Dotted, Unary, Binary, Call, Cond, IndexedName, TableCall]

#: Functions an expression may call, with their derivative as an expression builder.
FUNCTIONS: dict[str, Callable[[float], float]] = {
    "sin": math.sin, "cos": math.cos, "tan": math.tan,
    "asin": math.asin, "acos": math.acos, "atan": math.atan,
    "sinh": math.sinh, "cosh": math.cosh, "tanh": math.tanh,
    "sqrt": math.sqrt, "exp": math.exp, "log": math.log, "abs": abs,
    "sign": lambda x: 1.0 if x > 0 else (-1.0 if x < 0 else 0.0 * x),
}

#: Functions of two arguments, written as calls (``min(a, b)``) and held as
#: Binary nodes; ``clip(x, lo, hi)`` is max(lo, min(x, hi)).
PAIR_FUNCTIONS = ("min", "max")

#: Comparisons, Binary nodes worth 1.0 (true) or 0.0 (false); derivative 0.
COMPARISONS = ("<", ">", "<=", ">=")

CONSTANTS = {"pi": math.pi}

#: Opcodes of a compiled program (:func:`postfix`), by number: a constant (its
#: index in the constant table follows), t, negation, the binary operators, one
#: per entry of :data:`FUNCTIONS` in order, then a state variable (its index
#: in the model's table of state variables follows), then min and max (binary),
#: the comparisons, ``if``, and a table (its row in the model's tables and the
#: derivative's order follow).
OPCODES = (("const", "t", "neg", "+", "-", "*", "/", "^") + tuple(FUNCTIONS) + ("x",)
           + PAIR_FUNCTIONS + COMPARISONS + ("if", "table"))


class ExprError(ValueError):
    """An expression cannot be evaluated (unknown name, domain error, ...).

    Attributes
    ----------
    code : str
        Diagnostic code (E201 unknown name, E203 unknown function,
        E204 time not allowed, E301 domain error or non-finite value).
    span : Span or None
    hint : str
    name : str
        The offending name, if any.
    """

    def __init__(self, message, code, span=None, hint="", name=""):
        super().__init__(message)
        self.code, self.span, self.hint, self.name = code, span, hint, name


def _apply(op: str, a: float, b: float, span) -> float:
    try:
        if op == "+":
            r = a + b
        elif op == "-":
            r = a - b
        elif op == "*":
            r = a * b
        elif op == "/":
            if b == 0.0:
                raise ExprError("division by zero", "E301", span,
                                "check the divisor's parameters")
            r = a / b
        elif op == "min":
            r = min(a, b)
        elif op == "max":
            r = max(a, b)
        elif op in COMPARISONS:
            r = _compare(op, a, b)
        else:
            r = math.pow(a, b)
    except (OverflowError, ValueError) as exc:
        raise ExprError(f"cannot evaluate '{op}': {exc}", "E301", span) from None
    return r


def _compare(op: str, a: float, b: float) -> float:
    """1.0 when ``a op b`` holds, else 0.0."""
    return float(a < b if op == "<" else a > b if op == ">" else a <= b if op == "<=" else a >= b)


def evaluate(expr: Expr, env: dict[str, float], allow_t: bool = False,
             t: float = 0.0) -> float:
    """Evaluate an expression to a float.

    Parameters
    ----------
    expr : Expr
    env : dict
        Parameter values by name.
    allow_t : bool
        Whether the time ``t`` [s] may appear.
    t : float
        Value of ``t`` when allowed.

    Returns
    -------
    float

    Raises
    ------
    ExprError
        Unknown name or function, ``t`` where it is not allowed, a domain
        error (``sqrt(-1)``, division by zero) or a non-finite result.
    """
    def _ev(e):
        if isinstance(e, Num):
            return e.value
        if isinstance(e, Name):
            if e.name in env:
                return env[e.name]
            if e.name in CONSTANTS:
                return CONSTANTS[e.name]
            if e.name == "t":
                if allow_t:
                    return t
                raise ExprError("time 't' cannot appear here", "E204", e.span,
                                "only drivers, torques and forces may depend on time",
                                name="t")
            raise ExprError(f"unknown name '{e.name}'", "E201", e.span, name=e.name)
        if isinstance(e, (Dotted, IndexedName)):
            raise ExprError(f"'{e.text}' is a reference, not a number", "E301", e.span,
                            "a number or an expression of parameters is expected here")
        if isinstance(e, Unary):
            return -_ev(e.operand)
        if isinstance(e, Binary):
            return _apply(e.op, _ev(e.left), _ev(e.right), e.span)
        if isinstance(e, Cond):
            return _ev(e.then) if _ev(e.test) != 0.0 else _ev(e.other)
        if isinstance(e, TableCall):
            return e.table.value(_ev(e.arg), e.order)
        if isinstance(e, Call):
            f = FUNCTIONS.get(e.func)
            if f is None:
                raise _function_error(e)
            x = _ev(e.arg)
            try:
                return f(x)
            except (ValueError, OverflowError) as exc:
                raise ExprError(f"{e.func}({x:g}) is not defined ({exc})", "E301",
                                e.span) from None
        raise TypeError(f"not an expression: {e!r}")

    value = _ev(expr)
    if not math.isfinite(value):
        raise ExprError(f"the value is not finite ({value})", "E301",
                        getattr(expr, "span", None))
    return float(value)


def evaluate_rows(expr: Expr, env: dict, t):
    """A substituted expression over rows: names are looked up in ``env``
    (name -> array of shape (N,)), ``t`` is the array of times (N,); numpy
    arithmetic, so a division by zero or a domain error gives inf or NaN in
    that row instead of raising.

    Raises
    ------
    TypeError
        A node that is not a number, a known name or an operator or function.
    """
    import numpy as np
    ufuncs = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "asin": np.arcsin,
              "acos": np.arccos, "atan": np.arctan, "sinh": np.sinh, "cosh": np.cosh,
              "tanh": np.tanh, "sqrt": np.sqrt, "exp": np.exp, "log": np.log, "abs": np.abs,
              "sign": np.sign}

    def _ev(e):
        if isinstance(e, Num):
            return np.full(np.shape(t), float(e.value))
        if isinstance(e, Name):
            return np.asarray(t, dtype=float) if e.name == "t" else np.asarray(env[e.name])
        if isinstance(e, Unary):
            return -_ev(e.operand)
        if isinstance(e, Binary):
            a, b = _ev(e.left), _ev(e.right)
            if e.op in COMPARISONS:
                return {"<": np.less, ">": np.greater, "<=": np.less_equal,
                        ">=": np.greater_equal}[e.op](a, b).astype(float)
            return {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide,
                    "^": np.power, "min": np.minimum, "max": np.maximum}[e.op](a, b)
        if isinstance(e, Cond):
            return np.where(_ev(e.test) != 0.0, _ev(e.then), _ev(e.other))
        if isinstance(e, TableCall):
            return e.table.values(_ev(e.arg), e.order)
        if isinstance(e, Call):
            return ufuncs[e.func](_ev(e.arg))
        raise TypeError(f"cannot evaluate {e!r}")

    with np.errstate(all="ignore"):
        return _ev(expr)


def children(expr: Expr) -> tuple:
    """The sub-expressions an expression node holds, in reading order (none
    for a number or a name)."""
    if isinstance(expr, Unary):
        return (expr.operand,)
    if isinstance(expr, Binary):
        return (expr.left, expr.right)
    if isinstance(expr, (Call, TableCall)):
        return (expr.arg,)
    if isinstance(expr, Cond):
        return (expr.test, expr.then, expr.other)
    return ()


def free_names(expr: Expr) -> set[str]:
    """Names an expression refers to (parameters, ``t``, ``pi``)."""
    if isinstance(expr, Name):
        return {expr.name}
    return set().union(*(free_names(c) for c in children(expr)))


def substitute(expr: Expr, env: dict[str, float],
               state: Callable[[Dotted], str] | None = None, tables: dict | None = None
               ) -> Expr:
    """Replace parameters (and ``pi``) by their values, keeping ``t``, and
    calls of the model's tables (``tables``: name -> ``model.table.Table``)
    by :class:`TableCall` nodes.

    ``state``: where the expression may use the state of the model (forces of
    the motion), it maps a reference such as ``crank.omega`` to the name of
    a state variable (a :class:`Name` in the result) or to an expression in
    such names (``arm.T.vx``, a point's velocity), or raises ExprError; it is
    also asked about a plain name that is no parameter (a first-order state,
    ``i``), and returns None for one it does not know.

    Raises
    ------
    ExprError
        For names that are neither parameters, ``pi`` nor ``t``, unknown
        functions, and references where no state is allowed (or that
        ``state`` refuses).
    """
    if isinstance(expr, Name):
        if expr.name == "t":
            return expr
        if expr.name in env:
            return Num(env[expr.name], expr.span)
        if expr.name in CONSTANTS:
            return Num(CONSTANTS[expr.name], expr.span)
        got = state(expr) if state is not None else None
        if got is not None:
            return Name(got, expr.span) if isinstance(got, str) else got
        raise ExprError(f"unknown name '{expr.name}'", "E201", expr.span, name=expr.name)
    def sub(e):
        """A child node, substituted alike."""
        return substitute(e, env, state, tables)
    if isinstance(expr, Unary):
        return Unary(expr.op, sub(expr.operand), expr.span)
    if isinstance(expr, Binary):
        return Binary(expr.op, sub(expr.left), sub(expr.right), expr.span)
    if isinstance(expr, Call):
        if tables and expr.func in tables:
            return TableCall(tables[expr.func], sub(expr.arg), 0, expr.span)
        if expr.func not in FUNCTIONS:
            raise _function_error(expr)
        return Call(expr.func, sub(expr.arg), expr.span)
    if isinstance(expr, TableCall):
        return TableCall(expr.table, sub(expr.arg), expr.order, expr.span)
    if isinstance(expr, Cond):
        return Cond(sub(expr.test), sub(expr.then), sub(expr.other), expr.span)
    if isinstance(expr, Dotted):
        if state is not None:
            got = state(expr)
            return Name(got, expr.span) if isinstance(got, str) else got
        raise ExprError(f"'{expr.text}' is a reference, not a number", "E301", expr.span)
    return expr


def _function_error(call: Call) -> ExprError:
    """E203 for a call of an unknown function, or of a known one with the wrong
    number of arguments (the parser writes those as ``name/count``)."""
    name, _, count = call.func.partition("/")
    if count:
        arity = {"min": 2, "max": 2, "clip": 3, "if": 3}.get(name, 1)
        return ExprError(f"'{name}' takes {arity} argument{'s' if arity > 1 else ''}, got {count}",
                         "E203", call.span, name=name)
    return ExprError(f"unknown function '{call.func}'", "E203", call.span, name=call.func)


def _n(v: float) -> Num:
    return Num(float(v))


def sum_of(terms) -> Expr:
    """The expression sum of the expressions ``terms``, left to right
    (Num 0 for none): a load's terms as the check writes them."""
    out = None
    for e in terms:
        out = e if out is None else Binary("+", out, e)
    return Num(0.0) if out is None else out


def _is(e: Expr, v: float) -> bool:
    return isinstance(e, Num) and e.value == v


def simplify(e: Expr) -> Expr:
    """Fold constant subtrees and drop the neutral elements 0 and 1."""
    if isinstance(e, Cond):
        test = simplify(e.test)
        if isinstance(test, Num):
            return simplify(e.then) if test.value != 0.0 else simplify(e.other)
        return Cond(test, simplify(e.then), simplify(e.other), e.span)
    if isinstance(e, Unary):
        x = simplify(e.operand)
        if isinstance(x, Num):
            return _n(-x.value)
        return Unary("-", x)
    if isinstance(e, TableCall):
        x = simplify(e.arg)
        if isinstance(x, Num):
            v = e.table.value(x.value, e.order)
            if math.isfinite(v):
                return _n(v)
        return TableCall(e.table, x, e.order, e.span)
    if isinstance(e, Call):
        x = simplify(e.arg)
        if isinstance(x, Num):
            try:
                return _n(FUNCTIONS[e.func](x.value))
            except (ValueError, OverflowError):
                return Call(e.func, x, e.span)
        return Call(e.func, x, e.span)
    if isinstance(e, Binary):
        a, b = simplify(e.left), simplify(e.right)
        if isinstance(a, Num) and isinstance(b, Num):
            try:
                return _n(_apply(e.op, a.value, b.value, None))
            except ExprError:
                return Binary(e.op, a, b, e.span)
        if e.op == "+":
            if _is(a, 0):
                return b
            if _is(b, 0):
                return a
        if e.op == "-":
            if _is(b, 0):
                return a
            if _is(a, 0):
                return Unary("-", b)
        if e.op == "*":
            if _is(a, 0) or _is(b, 0):
                return _n(0)
            if _is(a, 1):
                return b
            if _is(b, 1):
                return a
        if e.op == "/":
            if _is(a, 0):
                return _n(0)
            if _is(b, 1):
                return a
        if e.op == "^":
            if _is(b, 0):
                return _n(1)
            if _is(b, 1):
                return a
        return Binary(e.op, a, b, e.span)
    return e


def _b(op, a, b):
    return Binary(op, a, b)


def diff(e: Expr, var: str = "t") -> Expr:
    """Symbolic derivative of an expression with respect to ``var``.

    Parameters must have been substituted first (:func:`substitute`), so
    every :class:`Name` left is ``var``. The result is simplified.

    Raises
    ------
    ExprError
        ``abs`` at a kink is handled by sign(x) (its derivative almost
        everywhere); a non-constant exponent uses the general power rule.
    """
    def _d(e):
        if isinstance(e, Num):
            return _n(0)
        if isinstance(e, Name):
            return _n(1) if e.name == var else _n(0)
        if isinstance(e, Unary):
            return Unary("-", _d(e.operand))
        if isinstance(e, Binary):
            a, b = e.left, e.right
            da, db = _d(a), _d(b)
            if e.op in COMPARISONS:
                return _n(0)                    # piecewise constant
            if e.op in "+-":
                return _b(e.op, da, db)
            if e.op == "*":
                return _b("+", _b("*", da, b), _b("*", a, db))
            if e.op == "/":
                return _b("/", _b("-", _b("*", da, b), _b("*", a, db)), _b("^", b, _n(2)))
            if e.op in PAIR_FUNCTIONS:
                # d min(a, b) = (da + db)/2 - sign(a - b) (da - db)/2 (max: + ...): the
                # derivative of the active argument, their mean where a = b
                half = _b("/", _b("-", da, db), _n(2))
                switch = _b("*", Call("sign", _b("-", a, b)), half)
                return _b("-" if e.op == "min" else "+", _b("/", _b("+", da, db), _n(2)), switch)
            # power: d(a^b) = b a^(b-1) da + a^b log(a) db
            term1 = _b("*", _b("*", b, _b("^", a, _b("-", b, _n(1)))), da)
            if _is(simplify(db), 0):
                return term1
            return _b("+", term1, _b("*", _b("*", e, Call("log", a)), db))
        if isinstance(e, Cond):                # the chosen branch's derivative
            return Cond(e.test, _d(e.then), _d(e.other), e.span)
        if isinstance(e, TableCall):           # the chain rule through the table's slope
            return _b("*", TableCall(e.table, e.arg, e.order + 1, e.span), _d(e.arg))
        if isinstance(e, Call):
            x, dx = e.arg, _d(e.arg)
            f = e.func
            if f == "sin":
                g = Call("cos", x)
            elif f == "cos":
                g = Unary("-", Call("sin", x))
            elif f == "tan":
                g = _b("+", _n(1), _b("^", Call("tan", x), _n(2)))
            elif f == "asin":
                g = _b("/", _n(1), Call("sqrt", _b("-", _n(1), _b("^", x, _n(2)))))
            elif f == "acos":
                g = Unary("-", _b("/", _n(1), Call("sqrt", _b("-", _n(1), _b("^", x, _n(2))))))
            elif f == "atan":
                g = _b("/", _n(1), _b("+", _n(1), _b("^", x, _n(2))))
            elif f == "sinh":
                g = Call("cosh", x)
            elif f == "cosh":
                g = Call("sinh", x)
            elif f == "tanh":
                g = _b("-", _n(1), _b("^", Call("tanh", x), _n(2)))
            elif f == "sqrt":
                g = _b("/", _n(0.5), Call("sqrt", x))
            elif f == "exp":
                g = Call("exp", x)
            elif f == "log":
                g = _b("/", _n(1), x)
            elif f == "abs":
                g = Call("sign", x)             # 0 at the kink: a subgradient
            elif f == "sign":
                g = _n(0)
            else:
                raise ExprError(f"unknown function '{f}'", "E203", e.span, name=f)
            return _b("*", g, dx)
        raise TypeError(f"cannot differentiate {e!r}")

    return simplify(_d(e))


def _div(a: float, b: float) -> float:
    try:
        return a / b
    except ZeroDivisionError:
        return math.copysign(math.inf, a) if a != 0 else math.nan


def _pow(a: float, b: float) -> float:
    try:
        r = a ** b
    except (OverflowError, ZeroDivisionError):
        return math.inf
    return r if isinstance(r, float) else math.nan   # negative ** fraction -> complex


def _safe(fn):
    def _call(x):
        try:
            return fn(x)
        except (ValueError, OverflowError):
            return math.nan
    return _call


def compile_function(e: Expr, var: str = "t") -> Callable[[float], float]:
    """Compile a substituted expression of one variable into a fast closure.

    Constant subtrees are folded once, so a constant torque costs one
    Python call per evaluation. Evaluation never raises: a division by zero
    gives inf, a domain error NaN, so that the time loop can stop with a
    message in the model's words instead of a traceback.
    """
    e = simplify(e)

    def _c(e):
        if isinstance(e, Num):
            v = e.value
            return lambda t: v
        if isinstance(e, Name):
            return lambda t: t
        if isinstance(e, Unary):
            f = _c(e.operand)
            return lambda t: -f(t)
        if isinstance(e, Binary):
            fa, fb = _c(e.left), _c(e.right)
            op = e.op
            if op == "+":
                return lambda t: fa(t) + fb(t)
            if op == "-":
                return lambda t: fa(t) - fb(t)
            if op == "*":
                return lambda t: fa(t) * fb(t)
            if op == "/":
                return lambda t: _div(fa(t), fb(t))
            if op == "min":
                return lambda t: min(fa(t), fb(t))
            if op == "max":
                return lambda t: max(fa(t), fb(t))
            if op in COMPARISONS:
                return lambda t: _compare(op, fa(t), fb(t))
            return lambda t: _pow(fa(t), fb(t))
        if isinstance(e, Cond):
            ft, fa, fb = _c(e.test), _c(e.then), _c(e.other)
            return lambda t: fa(t) if ft(t) != 0.0 else fb(t)
        if isinstance(e, TableCall):
            table, order, fx = e.table, e.order, _c(e.arg)
            return lambda t: table.value(fx(t), order)
        if isinstance(e, Call):
            fn, fx = _safe(FUNCTIONS[e.func]), _c(e.arg)
            return lambda t: fn(fx(t))
        raise TypeError(f"cannot compile {e!r}")

    return _c(e)


def kinked_tables(e: Expr) -> list:
    """[(call, its table's ``switches()``)] of the calls in e, of order 0, of
    tables whose slope jumps (``model.table.Table.switches`` is not None),
    outermost first."""
    out = []
    if isinstance(e, TableCall) and e.order == 0:
        kinks = e.table.switches()
        if kinks is not None:
            out.append((e, kinks))
    for c in children(e):
        out += kinked_tables(c)
    return out


def compile_state_function(e: Expr, variables: tuple) -> Callable[[float, "object"], float]:
    """Compile a substituted expression of t and the state variables
    ``variables`` (names) into f(t, x), x holding their values in order.
    Never raises (as :func:`compile_function`)."""
    e = simplify(e)
    index = {name: k for k, name in enumerate(variables)}

    def _c(e):
        if isinstance(e, Num):
            v = e.value
            return lambda t, x: v
        if isinstance(e, Name):
            if e.name in index:
                k = index[e.name]
                return lambda t, x: x[k]
            return lambda t, x: t
        if isinstance(e, Unary):
            f = _c(e.operand)
            return lambda t, x: -f(t, x)
        if isinstance(e, Binary):
            fa, fb = _c(e.left), _c(e.right)
            op = e.op
            if op == "+":
                return lambda t, x: fa(t, x) + fb(t, x)
            if op == "-":
                return lambda t, x: fa(t, x) - fb(t, x)
            if op == "*":
                return lambda t, x: fa(t, x) * fb(t, x)
            if op == "/":
                return lambda t, x: _div(fa(t, x), fb(t, x))
            if op == "min":
                return lambda t, x: min(fa(t, x), fb(t, x))
            if op == "max":
                return lambda t, x: max(fa(t, x), fb(t, x))
            if op in COMPARISONS:
                return lambda t, x: _compare(op, fa(t, x), fb(t, x))
            return lambda t, x: _pow(fa(t, x), fb(t, x))
        if isinstance(e, Cond):
            ft, fa, fb = _c(e.test), _c(e.then), _c(e.other)
            return lambda t, x: fa(t, x) if ft(t, x) != 0.0 else fb(t, x)
        if isinstance(e, TableCall):
            table, order, fx = e.table, e.order, _c(e.arg)
            return lambda t, x: table.value(fx(t, x), order)
        if isinstance(e, Call):
            fn, fx = _safe(FUNCTIONS[e.func]), _c(e.arg)
            return lambda t, x: fn(fx(t, x))
        raise TypeError(f"cannot compile {e!r}")

    return _c(e)


def postfix(e: Expr, var: str = "t", variables: dict | None = None, tables=None
            ) -> tuple[list[int], list[float], int]:
    """A substituted expression as a postfix program, for the compiled kernels
    (``kernels.programs._eval``): of time ``var`` and, with
    ``variables`` (name -> index in the model's table of state variables),
    of the state; ``tables`` maps a ``model.table.Table`` to its row in the
    model's tables (a program that calls one needs it).

    Returns
    -------
    code : list of int
        Opcodes (:data:`OPCODES`); ``const`` is followed by the index of its
        value in ``constants``.
    constants : list of float
    depth : int
        The evaluation stack the program needs.

    Raises
    ------
    TypeError
        A node that is not a number, the variable, or an operator or
        function of them (the expression was not substituted).
    """
    e = simplify(e)
    code, consts = [], []
    depth = [0, 0]          # current, largest

    def push(k):
        """Track the stack depth after k values are pushed (negative: popped)."""
        depth[0] += k
        depth[1] = max(depth[1], depth[0])

    def emit(e):
        """Append the postfix code of node e."""
        if isinstance(e, Num):
            code.extend((0, len(consts)))
            consts.append(float(e.value))
            push(1)
        elif isinstance(e, Name) and e.name == var:
            code.append(1)
            push(1)
        elif isinstance(e, Name) and variables and e.name in variables:
            code.extend((OPCODES.index("x"), int(variables[e.name])))
            push(1)
        elif isinstance(e, Unary):
            emit(e.operand)
            code.append(2)
        elif isinstance(e, Binary):
            emit(e.left)
            emit(e.right)
            code.append(OPCODES.index(e.op))
            push(-1)
        elif isinstance(e, Call):
            emit(e.arg)
            code.append(OPCODES.index(e.func))
        elif isinstance(e, TableCall) and tables is not None:
            emit(e.arg)
            code.extend((OPCODES.index("table"), int(tables(e.table)), int(e.order)))
        elif isinstance(e, Cond):        # both branches computed, one kept (a NaN of
            emit(e.test)                 # the other is discarded)
            emit(e.then)
            emit(e.other)
            code.append(OPCODES.index("if"))
            push(-2)
        else:
            raise TypeError(f"cannot compile {e!r}")

    emit(e)
    return code, consts, depth[1]
