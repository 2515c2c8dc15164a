"""Every figure and table under docs/studies was computed by the current
engine: each folder with a figure has an ``index.md`` whose engine line
(``- engine: mbdsl VERSION, ENGINES, kernels DIGEST``, written by the study
or script that drew it) names this version of mbdsl, the compiled engine,
and the kernels of this checkout (``kernels.cache.source_digest``). A change
of the numba code, or of the version, fails here until the figures are
regenerated: ``python examples/regenerate_studies.py``."""

import re
from pathlib import Path

import mbdsl
from mbdsl.kernels.cache import source_digest

STUDIES = Path(__file__).resolve().parents[2] / "docs" / "studies"
LINE = re.compile(r"^- engine: mbdsl (\S+), (.+), kernels ([0-9a-f]{16})$", re.M)


def test_every_study_figure_records_the_current_engine():
    folders = sorted({p.parent for p in STUDIES.rglob("*.png")} - {STUDIES})
    assert len(folders) >= 7
    stale = {}
    for folder in folders:
        index = folder / "index.md"
        found = LINE.findall(index.read_text(encoding="utf-8")) if index.exists() else []
        if len(found) != 1:
            stale[folder.name] = "no engine line"
            continue
        version, engines, digest = found[0]
        if (version, engines, digest) != (mbdsl.__version__, "compiled", source_digest()[:16]):
            stale[folder.name] = found[0]
    assert stale == {}, (f"regenerate with python examples/regenerate_studies.py: {stale} "
                         f"(current: mbdsl {mbdsl.__version__}, compiled, kernels "
                         f"{source_digest()[:16]})")


def test_the_cost_chart_reads_studies_that_are_checked():
    """The chart of every model's cost (docs/studies/cost_all_models) draws the
    cost tables of study folders the test above checks (their CSV is written
    beside the markdown the repository keeps), and every run of those tables
    was compiled."""
    for folder in ("slider_crank", "flexible_slider_crank", "andrews", "double_pendulum_stiff"):
        rows = [line.split("|")[1:-1] for line in
                (STUDIES / folder / "cost.md").read_text(encoding="utf-8").splitlines()
                if line.startswith("| ") and not line.startswith(("| method", "| ---"))]
        engines = {cells[1].strip().split("/")[0] for cells in rows}
        assert len(rows) == 8 and engines == {"compiled"}, (folder, engines)
        assert (STUDIES / folder / "index.md").exists()
