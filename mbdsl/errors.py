"""Errors and diagnostics of mbdsl.

Every problem a user can cause is reported as a :class:`Diagnostic`: a stable
code (E1xx syntax, E2xx names, E3xx values, E4xx structure and DOF, E5xx
initial conditions, E6xx simulation; Wxxx warnings), the file, line and
column, the source line as written with a caret run under the offending
token, and a hint. Diagnostics travel inside the exception tree rooted at
:class:`MbdError`; the CLI renders them and exits non-zero, never with a
traceback.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = [
    "Span",
    "ViaSpan",
    "Diagnostic",
    "MbdError",
    "MbdSyntaxError",
    "MbdModelError",
    "AssemblyError",
    "ConvergenceError",
    "render",
]


@dataclass(frozen=True)
class Span:
    """A region of a model file.

    Parameters
    ----------
    file : str
        Path of the model file (``"<string>"`` for text without a file).
    line, column : int
        1-based position of the first character.
    end_line, end_column : int
        1-based position one past the last character (Lark's convention).
    """

    file: str
    line: int
    column: int
    end_line: int
    end_column: int


@dataclass(frozen=True)
class ViaSpan(Span):
    """A span in a component's definition, reached through instances.

    Parameters
    ----------
    via : tuple of (Span, str)
        The instances' statements that led here, outermost first, each with
        a label (``"in 'upper', an instance of Link"``); :func:`render` shows
        them after the definition's place.
    """

    via: tuple = ()


@dataclass(frozen=True)
class Diagnostic:
    """One finding about a model, with where it is and what to do.

    Parameters
    ----------
    severity : {"error", "warning"}
    code : str
        Stable code, e.g. ``"E201"``; ``docs/errors.md`` lists them all.
    message : str
        One sentence in the model's words.
    span : Span or None
        Where; None for problems that have no place in the file (e.g. a
        ``--set`` override on the command line).
    label : str
        Short text printed beside the caret run.
    hint : str
        What to do about it.
    notes : tuple of str
        Further facts.
    secondary : tuple of (Span, str)
        Other places that matter, e.g. "first declared here".
    """

    severity: str
    code: str
    message: str
    span: Span | None = None
    label: str = ""
    hint: str = ""
    notes: tuple[str, ...] = ()
    secondary: tuple[tuple[Span, str], ...] = ()

    @property
    def is_error(self) -> bool:
        """True for errors, False for warnings."""
        return self.severity == "error"


class MbdError(Exception):
    """Base class of every error mbdsl raises on purpose."""

    def __init__(self, message: str, diagnostics: list[Diagnostic] | None = None):
        super().__init__(message)
        self.diagnostics: list[Diagnostic] = list(diagnostics or [])


class MbdSyntaxError(MbdError):
    """The model text does not follow the grammar (codes E1xx)."""


class MbdModelError(MbdError):
    """The model parses but does not make sense (names, values, DOF, ...)."""


class AssemblyError(MbdError):
    """No consistent initial configuration or velocity could be found (E5xx),
    or the assembled configuration shows redundant joints (E401).

    Attributes
    ----------
    structure : StructureReport or None
        DOF by count and by rank, when the configuration could be analysed.
    """

    def __init__(self, message: str, diagnostics=None, structure=None):
        super().__init__(message, diagnostics)
        self.structure = structure


class ConvergenceError(MbdError):
    """The time integration could not go on (E6xx).

    Attributes
    ----------
    solution : mbdsl.Solution or None
        Every accepted step up to the failure.
    """

    def __init__(self, message: str, diagnostics=None, solution=None):
        super().__init__(message, diagnostics)
        self.solution = solution


def _line_of(source: str | None, line: int) -> str | None:
    if source is None:
        return None
    lines = source.splitlines()
    if 1 <= line <= len(lines):
        return lines[line - 1].expandtabs(4)
    if line == len(lines) + 1:
        return ""
    return None


def render(diag: Diagnostic, sources: dict[str, str] | None = None) -> str:
    """Render a diagnostic as text, rustc-style.

    Parameters
    ----------
    diag : Diagnostic
    sources : dict mapping file name to its text, optional
        Used to print the offending source line with a caret run.

    Returns
    -------
    str
        Several lines, without a trailing newline.
    """
    sources = sources or {}
    out = [f"{diag.severity}[{diag.code}]: {diag.message}"]

    def _excerpt(span: Span, label: str) -> None:
        out.append(f"  --> {span.file}:{span.line}:{span.column}")
        text = _line_of(sources.get(span.file), span.line)
        if text is None:
            if label:
                out.append(f"   = {label}")
            return
        width = len(str(span.line))
        pad = " " * width
        out.append(f" {pad} |")
        out.append(f" {span.line} | {text}")
        start = max(span.column - 1, 0)
        if span.end_line == span.line and span.end_column > span.column:
            n = span.end_column - span.column
        else:
            n = max(len(text) - start, 1)
        out.append(f" {pad} | {' ' * start}{'^' * n} {label}".rstrip())

    if diag.span is not None:
        _excerpt(diag.span, diag.label)
        for span, label in reversed(getattr(diag.span, "via", ())):
            _excerpt(span, label)
    for span, label in diag.secondary:
        _excerpt(span, label)
    for note in diag.notes:
        out.append(f"   = note: {note}")
    if diag.hint:
        out.append(f"   = hint: {diag.hint}")
    return "\n".join(out)
