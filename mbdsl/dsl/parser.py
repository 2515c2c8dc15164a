"""Model text -> :class:`~mbdsl.dsl.spec.ModelSpec`: a model file parsed by
the grammar's parser (:mod:`.grammar`) and turned into specs
(:class:`~.transformer.ToSpec`). Syntax errors become
:class:`~mbdsl.errors.MbdSyntaxError` with a diagnostic that says, in words,
what was expected (``grammar.syntax_diagnostic``).
"""

from __future__ import annotations

from pathlib import Path

from lark.exceptions import UnexpectedInput, VisitError

from ..gcpause import paused
from ..errors import Diagnostic, MbdError, MbdSyntaxError
from .grammar import grammar_parser, parse_expression, syntax_diagnostic  # noqa: F401
from .spec import ModelSpec
from .transformer import ToSpec

__all__ = ["parse_text", "parse_file", "parse_expression", "grammar_parser"]

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
        diag = syntax_diagnostic(err, text, file)
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
