"""Study tables: one class that writes CSV and markdown and prints as text."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field

__all__ = ["Table", "fmt"]


def fmt(value) -> str:
    """A table cell: floats in 4 significant digits, NaN as a dash."""
    if isinstance(value, float):
        if math.isnan(value):
            return "-"
        return f"{value:.4g}" if 1e-3 <= abs(value) < 1e5 or value == 0 else f"{value:.3e}"
    return str(value)


@dataclass
class Table:
    """A titled table of a study.

    Attributes
    ----------
    name : str
        File stem (``convergence``, ``energy_dissipation``, ...).
    title : str
    columns : list of str
    rows : list of list
        Cells: str, int or float (full precision in CSV, 4 digits in markdown).
    notes : list of str
        Printed under the table (what is flagged, how a number was obtained).
    """

    name: str
    title: str
    columns: list
    rows: list = field(default_factory=list)
    notes: list = field(default_factory=list)

    def write_csv(self, path) -> None:
        """Write the full-precision table (``%.17g`` floats) with a header row."""
        with open(path, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(self.columns)
            for row in self.rows:
                w.writerow([f"{c:.17g}" if isinstance(c, float) else c for c in row])

    def markdown(self) -> str:
        """The table as a GitHub-flavoured markdown table with its title and notes."""
        lines = [f"**{self.title}**", "",
                 "| " + " | ".join(self.columns) + " |",
                 "|" + "|".join(" --- " for _ in self.columns) + "|"]
        lines += ["| " + " | ".join(fmt(c) for c in row) + " |" for row in self.rows]
        if self.notes:
            lines += [""] + [f"- {n}" for n in self.notes]
        return "\n".join(lines)

    def text(self) -> str:
        """Aligned plain text for the terminal."""
        cells = [list(self.columns)] + [[fmt(c) for c in row] for row in self.rows]
        widths = [max(len(r[i]) for r in cells) for i in range(len(self.columns))]
        out = [self.title, "  ".join(c.ljust(w) for c, w in zip(cells[0], widths)),
               "  ".join("-" * w for w in widths)]
        out += ["  ".join(c.rjust(w) if i else c.ljust(w) for i, (c, w) in
                          enumerate(zip(r, widths))) for r in cells[1:]]
        out += [f"  {n}" for n in self.notes]
        return "\n".join(out)


@dataclass
class Section:
    """The result of one study kind: tables, figures and a caption.

    Attributes
    ----------
    kind : str
    caption : str
        What the figures show (markdown).
    tables : list of Table
    figures : list of tuple (str, list of Panel, str)
        (file stem, panels, figure title).
    files : list of Path
        Written by :meth:`StudyResult.write`.
    """

    kind: str
    caption: str
    tables: list = field(default_factory=list)
    figures: list = field(default_factory=list)
    files: list = field(default_factory=list)
