"""Lark construction and syntax-error translation (the only place that imports lark).

The grammar is ``mbd.lark`` beside this file, loaded with
``Lark.open_from_package`` so that it is found in an installed package too.
Syntax errors become :class:`~mbdsl.errors.MbdSyntaxError` with a diagnostic
that says, in words, what was expected.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from lark import Lark
from lark.exceptions import (UnexpectedCharacters, UnexpectedEOF, UnexpectedInput,
                             UnexpectedToken, VisitError)

from lark.lexer import PatternStr

from ..gcpause import paused
from ..errors import Diagnostic, MbdError, MbdSyntaxError, Span
from .error_examples import EXAMPLES
from .spec import ModelSpec
from .transformer import ToSpec

__all__ = ["parse_text", "parse_file", "parse_expression", "grammar_parser"]

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
                       "INITIAL", "GUESS", "SIMULATE"}


def _open_block_note(text: str) -> str | None:
    depth, opened = 0, []
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


def _syntax_diagnostic(err: UnexpectedInput, text: str, file: str) -> Diagnostic:
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


@paused
def parse_text(text: str, file: str = "<string>") -> ModelSpec:
    """Parse model text into a :class:`ModelSpec` (no semantic checks).

    Parameters
    ----------
    text : str
        The model source.
    file : str
        File name used in diagnostics.

    Returns
    -------
    ModelSpec

    Raises
    ------
    MbdSyntaxError
        With one diagnostic (code E1xx) for the first syntax error.
    """
    try:
        tree = grammar_parser().parse(text, start="start")
    except UnexpectedInput as err:
        diag = _syntax_diagnostic(err, text, file)
        raise MbdSyntaxError(diag.message, [diag]) from None
    try:
        return ToSpec(file, text).transform(tree)
    except VisitError as err:  # a value the spec refuses, e.g. a malformed vector
        orig = err.orig_exc
        if isinstance(orig, MbdError):
            raise orig from None
        raise


def parse_file(path: str | Path) -> ModelSpec:
    """Read and parse a model file.

    Raises
    ------
    MbdSyntaxError
        For syntax errors, or E100 if the file cannot be read or decoded.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        diag = Diagnostic("error", "E100", f"cannot read model file '{path}': {exc}",
                          hint="check the path and that the file is UTF-8 text")
        raise MbdSyntaxError(diag.message, [diag]) from None
    return parse_text(text, str(path))


def parse_expression(text: str):
    """Parse a single expression, e.g. ``"m1*L1^2/12"`` or ``"crank.O"``.

    Raises
    ------
    MbdSyntaxError
    """
    try:
        tree = grammar_parser().parse(text, start="expression")
    except UnexpectedInput as err:
        diag = _syntax_diagnostic(err, text, "<expression>")
        raise MbdSyntaxError(f"in expression {text!r}: {diag.message}", [diag]) from None
    return ToSpec("<expression>", text).transform(tree)
