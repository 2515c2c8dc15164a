"""The language's expressions as postfix programs, evaluated in the kernels.

Functions of time and of the state (``dsl.expressions.postfix``), with the
non-raising semantics of ``compile_function``: a division by zero gives
+-inf (0/0 NaN), a domain error NaN, so that a bad value stops the run with
a message, not a crash. The state variables a program reads are evaluated
first into XVAL (:func:`_state_values`).

(``dsl.expressions.postfix``), with the same non-raising semantics as
``compile_function``: a division by zero gives +-inf (0/0 NaN), a domain
error NaN, so that a bad value stops the run with a message, not a crash.
"""

from __future__ import annotations

import math

from mbdsl.dsl.expressions import OPCODES

from .geometry import _line
from .schema import (CODE, CONSTS, GEO, PROG, STACK, SWP, TBD, TBL, VAR, VARC, XVAL, _f, _i,
                     _inline, _jit, _put, _rows)

_OPCODES = ("const", "t", "neg", "+", "-", "*", "/", "^", "sin", "cos", "tan", "asin", "acos",
            "atan", "sinh", "cosh", "tanh", "sqrt", "exp", "log", "abs", "sign", "x", "min",
            "max", "<", ">", "<=", ">=", "if", "table")


#: Opcodes (``dsl.expressions.OPCODES``, checked at import): literals, as the field indices.
(OP_CONST, OP_T, OP_NEG, OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_POW,
 OP_SIN, OP_COS, OP_TAN, OP_ASIN, OP_ACOS, OP_ATAN, OP_SINH, OP_COSH, OP_TANH,
 OP_SQRT, OP_EXP, OP_LOG, OP_ABS, OP_SIGN, OP_X, OP_MIN, OP_MAX,
 OP_LT, OP_GT, OP_LE, OP_GE, OP_IF, OP_TABLE) = range(31)
if _OPCODES != OPCODES:     # pragma: no cover (a developer's error, caught by any test)
    raise ImportError("programs.py's opcodes differ from dsl.expressions.OPCODES")

#: Its fields in ``schema.MODEL_SCHEMA``: the programs, their stack, the state variables,
#: the tables, the kinks of tables of the state located as events.
FIELDS = ("code", "consts", "prog", "stack", "var", "varc", "xval", "tbl", "tbd", "swp")


@_jit
def _eval(I, Fl, p, t):
    """The value at time t [s] of program p (row of field PROG); a program of
    the state reads the variables' values from XVAL (``_state_values``)."""
    base, sp = I[3 * STACK], 0              # the stack is the float field STACK
    k, end = _i(I, PROG, p, 0), _i(I, PROG, p, 1)
    while k < end:
        op = _i(I, CODE, k, 0)
        k += 1
        if op == OP_CONST:
            Fl[base + sp] = _f(I, Fl, CONSTS, _i(I, CODE, k, 0), 0)
            k += 1
            sp += 1
        elif op == OP_T:
            Fl[base + sp] = t
            sp += 1
        elif op == OP_NEG:
            Fl[base + sp - 1] = -Fl[base + sp - 1]
        elif op == OP_X:
            Fl[base + sp] = Fl[I[3 * XVAL] + _i(I, CODE, k, 0)]
            k += 1
            sp += 1
        elif op == OP_MIN or op == OP_MAX:
            a, b = Fl[base + sp - 2], Fl[base + sp - 1]
            sp -= 1
            Fl[base + sp - 1] = min(a, b) if op == OP_MIN else max(a, b)
        elif op >= OP_LT and op <= OP_GE:    # comparisons: 1.0 or 0.0
            a, b = Fl[base + sp - 2], Fl[base + sp - 1]
            sp -= 1
            if op == OP_LT:
                c = a < b
            elif op == OP_GT:
                c = a > b
            elif op == OP_LE:
                c = a <= b
            else:
                c = a >= b
            Fl[base + sp - 1] = 1.0 if c else 0.0
        elif op == OP_IF:                    # test, then, other -> the chosen one
            test, a, b = Fl[base + sp - 3], Fl[base + sp - 2], Fl[base + sp - 1]
            sp -= 2
            Fl[base + sp - 1] = a if test != 0.0 else b
        elif op <= OP_POW:
            a, b = Fl[base + sp - 2], Fl[base + sp - 1]
            sp -= 1
            if op == OP_ADD:
                x = a + b
            elif op == OP_SUB:
                x = a - b
            elif op == OP_MUL:
                x = a * b
            elif op == OP_DIV:
                if b != 0.0:
                    x = a / b
                elif a != 0.0:
                    x = math.copysign(math.inf, a)
                else:
                    x = math.nan
            else:
                x = _pow(a, b)
            Fl[base + sp - 1] = x
        elif op == OP_TABLE:                 # a table's row and derivative order follow
            Fl[base + sp - 1] = _table(I, Fl, _i(I, CODE, k, 0), _i(I, CODE, k + 1, 0),
                                       Fl[base + sp - 1])
            k += 2
        else:
            Fl[base + sp - 1] = _call(op, Fl[base + sp - 1])
    return Fl[base]


@_inline
def _cubic(Fl, c, s, order):
    """The order-th derivative at s of the cubic whose coefficients (highest
    power first) start at Fl[c]."""
    c0, c1, c2, c3 = Fl[c], Fl[c + 1], Fl[c + 2], Fl[c + 3]
    if order == 0:
        return ((c0 * s + c1) * s + c2) * s + c3
    if order == 1:
        return (3.0 * c0 * s + 2.0 * c1) * s + c2
    if order == 2:
        return 6.0 * c0 * s + 2.0 * c1
    return 6.0 * c0 if order == 3 else 0.0


@_jit
def _table(I, Fl, row, order, u):
    """The order-th derivative at u of table ``row`` (fields TBL: offset into
    TBD, intervals k, extrapolation 0 hold, 1 linear, 2 error; TBD: the k + 1
    breakpoints, then 4 coefficients per interval), as
    ``model.table.Table.value``: the interval by bisection, NaN outside the
    points for ``error``."""
    k, mode = _i(I, TBL, row, 1), _i(I, TBL, row, 2)
    base = I[3 * TBD] + _i(I, TBL, row, 0)
    coefs = base + k + 1
    x0, xn = Fl[base], Fl[base + k]
    if not u == u:
        return math.nan
    if u < x0 or u > xn:
        if mode == 2:
            return math.nan
        i, s = (0, 0.0) if u < x0 else (k - 1, xn - Fl[base + k - 1])
        y = _cubic(Fl, coefs + 4 * i, s, 0)
        if mode == 0:
            return y if order == 0 else 0.0
        slope = _cubic(Fl, coefs + 4 * i, s, 1)
        if order == 0:
            return y + slope * (u - (x0 if u < x0 else xn))
        return slope if order == 1 else 0.0
    lo, hi = 0, k                            # x[lo] <= u, and u < x[hi] or hi = k
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if Fl[base + mid] <= u:
            lo = mid
        else:
            hi = mid
    return _cubic(Fl, coefs + 4 * lo, u - Fl[base + lo], order)


@_jit
def _pow(a, b):
    """a ** b as ``expressions._pow``: inf on overflow or 0 ** negative, NaN
    for a negative base with a fractional exponent."""
    if a == 0.0 and b < 0.0:
        return math.inf
    if a < 0.0 and b != math.floor(b):
        return math.nan
    return math.pow(a, b)


@_jit
def _call(op, x):
    """The function of opcode op at x; NaN outside its domain."""
    if op == OP_SIN:
        return math.sin(x)
    if op == OP_COS:
        return math.cos(x)
    if op == OP_TAN:
        return math.tan(x)
    if op == OP_ASIN:
        return math.asin(x) if abs(x) <= 1.0 else math.nan
    if op == OP_ACOS:
        return math.acos(x) if abs(x) <= 1.0 else math.nan
    if op == OP_ATAN:
        return math.atan(x)
    if op == OP_SINH:
        return math.sinh(x)
    if op == OP_COSH:
        return math.cosh(x)
    if op == OP_TANH:
        return math.tanh(x)
    if op == OP_SQRT:
        return math.sqrt(x) if x >= 0.0 else math.nan
    if op == OP_EXP:
        return math.exp(x)
    if op == OP_LOG:
        return math.log(x) if x > 0.0 else math.nan
    if op == OP_SIGN:
        return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)
    return abs(x)


@_jit
def _state_values(I, Fl, qx, vx, grad, H):
    """The state variables' values into XVAL: sum of coef q[col] (level 0) or
    coef v[col] (level 1) over their two (column, coef) entries, or a sliding
    line's distance s (level 0) or speed grad s . v (level 1); grad (6,), H
    (6, 6) scratch."""
    base = I[3 * XVAL]
    for k in range(_rows(I, VAR)):
        g = _i(I, VAR, k, 3)
        if g >= 0:
            s = _line(I, Fl, qx, g, grad, H)
            if _i(I, VAR, k, 0) == 0:
                Fl[base + k] = s
            else:
                acc = 0.0
                for j in range(6):
                    acc += grad[j] * vx[_i(I, GEO, g, j)]
                Fl[base + k] = acc
            continue
        c1, c2 = _i(I, VAR, k, 1), _i(I, VAR, k, 2)
        a1, a2 = _f(I, Fl, VARC, k, 0), _f(I, Fl, VARC, k, 1)
        if _i(I, VAR, k, 0) == 0:
            Fl[base + k] = a1 * qx[c1] + a2 * qx[c2]
        else:
            Fl[base + k] = a1 * vx[c1] + a2 * vx[c2]


@_jit
def switch_branches(I, Fl, t, qx, vx, grad, H, out):
    """The branch of each kink switch (field SWP: the program of a table's
    argument u, the row of the table of its kinks) at time t [s] and (q, v)
    extended (n + 3,): how many kinks lie at or below u
    (``model.elements.StateSwitch.interval``), -1 where u is not a number;
    into out (k,) int64. A step across which a branch changes crosses a
    kink: an event. grad (6,), H (6, 6): scratch."""
    _state_values(I, Fl, qx, vx, grad, H)
    for s in range(_rows(I, SWP)):
        u = _eval(I, Fl, _i(I, SWP, s, 0), t)
        row = _i(I, SWP, s, 1)
        base = I[3 * TBD] + _i(I, TBL, row, 0)
        c = 0
        if not u == u:
            c = -1
        else:
            for j in range(_i(I, TBL, row, 1) + 1):
                if Fl[base + j] <= u:
                    c += 1
        out[s] = c


@_inline
def emit_variable(I, Fl, n, vx, R, C, V, p, r0, c0, cq, cv, row, w, gk, kv, grad, H):
    """-w gk (cq dx_k/dq + cv dx_k/dv) in row r0 + row at column offset c0:
    the derivative of a load's entry w tau(x) through its state variable k
    with dtau/dx_k = gk (a linear one: its two (column, coefficient) terms at
    level 0 (q) or 1 (v); a sliding distance: grad s; a sliding speed
    grad s . v: H v (q) and grad s (v); ``grad``, ``H``: the line's, from
    ``geometry._line`` at the caller); returns p."""
    gv = _i(I, VAR, kv, 3)
    if gv < 0:                     # linear in q (level 0) or v (level 1)
        c = cq if _i(I, VAR, kv, 0) == 0 else cv
        if c == 0.0:
            return p
        for j in range(2):
            col = _i(I, VAR, kv, 1 + j)
            if col < n and _f(I, Fl, VARC, kv, j) != 0.0:
                p = _put(R, C, V, p, r0 + row, c0 + col, -c * w * gk * _f(I, Fl, VARC, kv, j))
        return p
    for j in range(6):             # a sliding distance (grad s) or speed
        col = _i(I, GEO, gv, j)
        if col >= n:
            continue
        if _i(I, VAR, kv, 0) == 0:
            dq, dv = grad[j], 0.0
        else:                      # d(grad s . v)/dq = H v, d/dv = grad s
            dq = 0.0
            for m2 in range(6):
                dq += H[j, m2] * vx[_i(I, GEO, gv, m2)]
            dv = grad[j]
        val = cq * dq + cv * dv
        if val != 0.0:
            p = _put(R, C, V, p, r0 + row, c0 + col, -w * gk * val)
    return p
