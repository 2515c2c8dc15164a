"""The grammar's parser (Lark, LALR over ``mbd.lark``), the translation of its
syntax errors into words, and the reading of one expression.

The grammar is ``mbd.lark`` beside this file, loaded with
``Lark.open_from_package`` so that it is found in an installed package too.
Syntax errors become :class:`~mbdsl.errors.MbdSyntaxError` with a diagnostic
that says, in words, what was expected (:func:`syntax_diagnostic`). An
expression's text becomes an :class:`~.expressions.Expr` by
:func:`parse_expression` and :class:`ToExpression`, which the model's
transformer (:class:`~.transformer.ToSpec`) extends. Nothing here imports the
model's specs: they read expressions from text through :func:`as_expr`.
"""

from __future__ import annotations

import re
from functools import lru_cache

from lark import Lark, Token, Transformer, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken
from lark.lexer import PatternStr

from ..errors import Diagnostic, MbdSyntaxError, Span
from . import units
from .error_examples import EXAMPLES
from .expressions import (Binary, Call, Cond, Dotted, Expr, IndexedName, Name, Num, Unary,
                          Vec)

__all__ = ["grammar_parser", "syntax_diagnostic", "parse_expression", "as_expr", "ToExpression"]

#: a QUANTITY token split into the number and the unit as written
_QUANTITY = re.compile(r"((?:\d+(?:\.\d+)?|\.\d+)(?:[eE][+-]?\d+)?)[ \t]*(\S+)")

_WORDS = {"NAME": "a name", "NUMBER": "a number", "METHOD": "a method name",
          "COMPARE": "a comparison (<, >, <=, >=)",
          "$END": "the end of the file"}


@lru_cache(maxsize=1)
def grammar_parser() -> Lark:
    """The LALR parser of ``mbd.lark`` (built once per process).

    The grammar analysis (about 0.1 s, a fifth of the start-up) is cached
    by lark in the temporary directory (``cache=True``: keyed by the
    grammar's and the options' hash and lark's version, rebuilt when they
    change; a missing or unwritable cache only costs the analysis).
    """
    return Lark.open_from_package("mbdsl.dsl", "mbd.lark", ("",), parser="lalr",
                                  lexer="contextual", propagate_positions=True,
                                  start=["start", "expression"], maybe_placeholders=False,
                                  cache=True)


def _describe(terminals: set[str]) -> str:
    by_name = {t.name: t for t in grammar_parser().terminals}
    words = []
    for name in terminals:
        if name in _WORDS:
            words.append(_WORDS[name])
        elif name in by_name and isinstance(by_name[name].pattern, PatternStr):
            words.append(f"'{by_name[name].pattern.value}'")
        else:
            words.append(name.lower())
    words = sorted(set(words), key=lambda w: (not w.startswith("a "), w))
    if len(words) > 8:
        words = words[:8] + ["..."]
    return ", ".join(words[:-1]) + (" or " if len(words) > 1 else "") + words[-1]


def _token_text(tok) -> str:
    if tok is None or getattr(tok, "type", None) == "$END":
        return "the end of the file"
    return f"'{tok}'"


@lru_cache(maxsize=1)
def _example_states() -> dict:
    """(LALR state id, offending token type) -> (code, message, hint) for the catalogue.

    Lark's own ``match_examples`` compares whole parser states, including the
    depth of the stack, so an example only matches when as many statements
    precede it; the state id and token type are what identify the mistake.
    """
    p = grammar_parser()
    table = {}
    for label, snippets in EXAMPLES.items():
        for text in snippets:
            try:
                p.parse(text, start="start")
            except UnexpectedToken as ut:
                table.setdefault((ut.state.position, ut.token.type), label)
            except UnexpectedInput:
                pass
    return table


def _match_example(err) -> tuple | None:
    if not isinstance(err, UnexpectedToken) or err.state is None:
        return None
    return _example_states().get((err.state.position, err.token.type))


_STATEMENT_KEYWORDS = {"PARAMETER", "GRAVITY", "GROUND", "BODY", "JOINT", "FORCE", "DRIVER",
                       "INITIAL", "GUESS", "SIMULATE", "STATE", "TABLE", "OUTPUT", "PARTICLE",
                       "FOR"}


def _open_block_note(text: str) -> str | None:
    """Where a ``{`` of the text is left unclosed (the last such line), or None."""
    opened = []
    for i, line in enumerate(text.splitlines(), 1):
        code = line.split("#", 1)[0]
        for ch in code:
            if ch == "{":
                opened.append(i)
            elif ch == "}" and opened:
                opened.pop()
    if opened:
        return f"the block opened at line {opened[-1]} is not closed"
    return None


def syntax_diagnostic(err: UnexpectedInput, text: str, file: str) -> Diagnostic:
    """The E1xx diagnostic of a syntax error, in words.

    Parameters
    ----------
    err : lark.exceptions.UnexpectedInput
        Lark's error (an unexpected character, token or end of input).
    text : str
        The text that was parsed.
    file : str
        Its file name, for the diagnostic's span.

    Returns
    -------
    Diagnostic
        A known mistake's own code and hint (``error_examples.EXAMPLES``), else
        what was expected at the error's line and column (and a note on a
        block left open).
    """
    lines = text.splitlines() or [""]
    matched = _match_example(err)
    if isinstance(err, UnexpectedCharacters):
        ch = text[err.pos_in_stream] if err.pos_in_stream < len(text) else ""
        span = Span(file, err.line, err.column, err.line, err.column + 1)
        expected = _describe(set(err.allowed or ()))
        return Diagnostic("error", "E101", f"unexpected character {ch!r}", span,
                          "not allowed here", hint=f"expected {expected}")
    tok = getattr(err, "token", None)
    at_end = isinstance(err, UnexpectedEOF) or (tok is not None and tok.type == "$END")
    if at_end:
        last = len(lines)
        col = len(lines[-1]) + 1
        span = Span(file, last, max(col, 1), last, max(col, 1) + 1)
        note = _open_block_note(text)
        return Diagnostic("error", "E103", "unexpected end of file", span,
                          "the file ends here",
                          notes=(note,) if note else (),
                          hint=f"expected {_describe(set(err.expected))}")
    span = Span(file, tok.line, tok.column, tok.end_line or tok.line,
                tok.end_column or tok.column + len(str(tok)))
    expected = _describe(set(err.accepts if getattr(err, "accepts", None) else err.expected))
    accepted = set(getattr(err, "accepts", None) or err.expected)
    if "RBRACE" in accepted and tok.type in _STATEMENT_KEYWORDS:
        note = _open_block_note(text[: getattr(tok, "start_pos", len(text))])
        return Diagnostic("error", "E108", f"a block is not closed before '{tok}'", span,
                          "a new declaration starts here", notes=(note,) if note else (),
                          hint="add '}' at the end of the block")
    if matched is not None:
        code, message, hint = matched
        return Diagnostic("error", code, message, span, f"unexpected {_token_text(tok)}",
                          hint=hint)
    return Diagnostic("error", "E102", f"expected {expected}, found {_token_text(tok)}",
                      span, "unexpected here",
                      hint=f"expected {expected}")


def parse_expression(text: str):
    """Parse a single expression, e.g. ``"m1*L1^2/12"`` or ``"crank.O"``.

    Raises
    ------
    MbdSyntaxError
    """
    try:
        tree = grammar_parser().parse(text, start="expression")
    except UnexpectedInput as err:
        diag = syntax_diagnostic(err, text, "<expression>")
        raise MbdSyntaxError(f"in expression {text!r}: {diag.message}", [diag]) from None
    return ToExpression("<expression>", text).transform(tree)


def as_expr(value) -> Expr:
    """Turn a number, an expression string or an Expr into an Expr.

    Used by the Python API so that model objects can be built with plain
    numbers (``mass=3.0``) or text (``inertia="m1*L1^2/12"``).

    Raises
    ------
    MbdSyntaxError
        If a string is not a valid expression.
    TypeError
        A value that is neither (a boolean, say).
    """
    if isinstance(value, (Num, Name, Dotted, Unary, Binary, Call, Cond, IndexedName)):
        return value
    if isinstance(value, bool):
        raise TypeError("a boolean is not an expression")
    if isinstance(value, (int, float)):
        return Num(float(value))
    if isinstance(value, str):
        return parse_expression(value)
    raise TypeError(f"cannot make an expression from {type(value).__name__}")


def dotted_chain(first, attrs, span):
    """``first.a.b.c`` -> Dotted(Dotted(Dotted(first, a), b), c)."""
    out = first
    for a in attrs:
        out = Dotted(out, a, span)
    return out


class ToExpression(Transformer):
    """Build expressions (:mod:`.expressions`) from a Lark tree of an
    ``expression`` of ``mbd.lark``; the model's transformer
    (:class:`~.transformer.ToSpec`) extends it with the declarations.

    Parameters
    ----------
    file : str
        File name recorded in every :class:`~mbdsl.errors.Span`.
    source : str
        The text.
    """

    def __init__(self, file: str, source: str):
        super().__init__()
        self.file, self.source = file, source

    def _span(self, meta) -> Span | None:
        if getattr(meta, "empty", True):
            return None
        return Span(self.file, meta.line, meta.column, meta.end_line, meta.end_column)

    def _tspan(self, tok: Token) -> Span:
        return Span(self.file, tok.line, tok.column, tok.end_line, tok.end_column)

    def _name(self, x):
        return x if isinstance(x, IndexedName) else str(x)

    def _nspan(self, x):
        return x.span if isinstance(x, IndexedName) else self._tspan(x)

    # -- 3. expressions --------------------------------------------------------
    def expression(self, children):
        """A lone expression (parse_expression's entry point)."""
        return children[0]

    @v_args(meta=True)
    def vec(self, meta, children):
        """``(x, y)`` or ``(x, y, z)`` -> Vec."""
        z = children[2] if len(children) == 3 else None
        return Vec(children[0], children[1], self._span(meta), z)

    def _bin(op):
        @v_args(meta=True)
        def method(self, meta, children):
            """``a op b`` -> Binary."""
            return Binary(op, children[0], children[1], self._span(meta))
        return method

    add, sub, mul, div, pow = _bin("+"), _bin("-"), _bin("*"), _bin("/"), _bin("^")
    del _bin

    @v_args(meta=True)
    def compare(self, meta, children):
        """``a < b`` (``>``, ``<=``, ``>=``) -> Binary worth 1 or 0."""
        left, op, right = children
        return Binary(str(op), left, right, self._span(meta))

    @v_args(meta=True)
    def neg(self, meta, children):
        """``-x`` -> Unary."""
        return Unary("-", children[0], self._span(meta))

    @v_args(meta=True)
    def pos(self, meta, children):
        """``+x`` -> x."""
        return children[0]

    @v_args(meta=True)
    def number(self, meta, children):
        """NUMBER -> Num."""
        return Num(float(children[0]), self._tspan(children[0]))

    @v_args(meta=True)
    def quantity(self, meta, children):
        """QUANTITY (``15 cm``) -> Num in SI, keeping the number and unit as written."""
        tok = children[0]
        number, unit = _QUANTITY.match(str(tok)).groups()
        try:
            value = units.to_si(number, unit)
        except units.UnitError as err:
            diag = Diagnostic("error", "E307", str(err), self._tspan(tok), "unknown unit",
                              hint="units are SI symbols and their multiples, joined by * and /")
            raise MbdSyntaxError(diag.message, [diag]) from None
        return Num(value, self._tspan(tok), unit=unit, written=number)

    @v_args(meta=True)
    def name(self, meta, children):
        """NAME -> Name."""
        return Name(str(children[0]), self._tspan(children[0]))

    @v_args(meta=True)
    def dotted(self, meta, children):
        """``a.b`` or ``a[i].b`` -> Dotted."""
        return Dotted(self._name(children[0]), str(children[1]), self._span(meta))

    @v_args(meta=True)
    def dotted_indexed(self, meta, children):
        """``ground.P[i]``: an indexed point -> Dotted with an IndexedName attr."""
        attr = IndexedName(str(children[1]), children[2], self._tspan(children[1]))
        return Dotted(self._name(children[0]), attr, self._span(meta))

    @v_args(meta=True)
    def dotted2(self, meta, children):
        """``arm.T.x`` (a point's field, or ``reaction.O.fx``; ``lambda.O.0``, a
        multiplier row) -> Dotted of a Dotted."""
        inner = Dotted(self._name(children[0]), str(children[1]), self._span(meta))
        return Dotted(inner, str(children[2]), self._span(meta))

    @v_args(meta=True)
    def dotted_long(self, meta, children):
        """``upper.b.B.x`` (a point's field of a body of a component instance)
        -> Dotted chain, nested to the left."""
        return dotted_chain(self._name(children[0]), [str(c) for c in children[1:]],
                            self._span(meta))

    @v_args(meta=True)
    def dotted_indexed_long(self, meta, children):
        """``right.s[2].b.y`` (a body of an instance in a component's array)
        -> Dotted chain with an IndexedName part."""
        first, name, index, *rest = children
        part = IndexedName(str(name), index, self._tspan(name))
        return dotted_chain(self._name(first), [part] + [str(c) for c in rest], self._span(meta))

    @v_args(meta=True)
    def indexed(self, meta, children):
        """``link[i]`` in an expression (a reference) -> IndexedName."""
        return IndexedName(str(children[0]), children[1], self._span(meta))

    @v_args(meta=True)
    def call(self, meta, children):
        """``f(x)`` -> Call; ``min(a, b)``, ``max(a, b)`` -> Binary;
        ``clip(x, lo, hi)`` -> max(lo, min(x, hi)). A wrong number of
        arguments is kept as a Call that the checks report (E203)."""
        name, args = str(children[0]), children[1:]
        span = self._tspan(children[0])
        if name in ("min", "max") and len(args) == 2:
            return Binary(name, args[0], args[1], span)
        if name == "clip" and len(args) == 3:
            return Binary("max", args[1], Binary("min", args[0], args[2], span), span)
        if name == "zyx" and len(args) == 3:        # an orientation: initial b.orientation
            return Call(name, Vec(args[0], args[1], span, args[2]), span)
        if name == "axis_angle" and len(args) == 4:  # an orientation: axis x, y, z, angle
            return Call(name, Vec(Vec(args[0], args[1], span, args[2]), args[3], span), span)
        if name == "if" and len(args) == 3:
            return Cond(args[0], args[1], args[2], span)
        if len(args) != 1:
            return Call(f"{name}/{len(args)}", args[0], span)
        return Call(name, args[0], span)
