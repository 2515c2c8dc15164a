"""Fig. 16 of the paper for mbdsl: the cost per step of every method,
normalised to HHT-I3, on the four models of the paper on one chart.

Reads docs/studies/<model>/cost.csv (written by ``mbdsl study cost`` or
``study all``; every method on the same engine, timed after a warm-up run)
and writes docs/studies/cost_all_models.{png,svg}.

Run: python examples/cost_chart.py
"""

from __future__ import annotations

import csv
from pathlib import Path

from mbdsl.graphics.plotting import Panel, Series, write_figure

ROOT = Path(__file__).resolve().parents[1] / "docs" / "studies"
MODELS = [("slider_crank", "rigid slider crank"), ("flexible_slider_crank", "flexible slider crank"),
          ("andrews", "Andrews' mechanism"), ("double_pendulum_stiff", "stiff double pendulum")]


def main() -> int:
    panel = Panel("time per step relative to HHT-I3 (Fig. 16)",
                  "method", "time per step / HHT-I3's")
    for folder, label in MODELS:
        with open(ROOT / folder / "cost.csv") as f:
            rows = list(csv.DictReader(f))
        engine = rows[0]["engine"].split("/")[0]
        panel.series.append(Series(f"{label} ({engine})", [r["method"] for r in rows],
                                   [float(r["relative to hht-i3"]) for r in rows], kind="bar"))
    panel.yscale = "log"
    for path in write_figure([panel], ROOT / "cost_all_models", columns=1):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
