"""Regenerate every figure and table under docs/studies on the current engine.

Each folder of docs/studies records in its ``index.md`` the commands that
wrote it (``- command: `...` `` lines) and the engine that computed it
(``- engine: mbdsl VERSION, ENGINES, kernels DIGEST``); this script runs
those commands again, folder by folder (and the scripts of ``AFTER`` that
draw into a study's folder), then draws the chart that reads the studies'
cost tables (``examples/cost_chart.py``). A sweep's table is
started afresh (a sweep skips the runs its table holds). The engine line of
every folder then names the current version and kernels, which
``tests/docs/test_studies_current.py`` checks.

Run from the checkout's root, on a quiet machine (the cost and
work-precision studies time their runs): about 12 minutes on 2 cores.

    python examples/regenerate_studies.py [FOLDER ...]
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ROOT / "docs" / "studies"
COMMAND = re.compile(r"^- command: `(.+)`$", re.M)
#: Scripts that draw into a study's folder after its study (which rewrites its index.md).
AFTER = {"double_pendulum_stiff": ["examples/alpha_effect.py"]}


def commands(folder: Path) -> list[list[str]]:
    """The commands a folder's ``index.md`` records, as argument lists, with
    ``mbdsl`` and ``python`` run by this interpreter."""
    out = []
    for text in COMMAND.findall((folder / "index.md").read_text(encoding="utf-8")):
        args = shlex.split(text)
        if args[0] == "mbdsl":
            args = [sys.executable, "-m", "mbdsl"] + args[1:]
        elif args[0] == "python":
            args = [sys.executable] + args[1:]
        out.append(args)
    return out


def folders(names) -> list[Path]:
    """The study folders (every folder with an ``index.md``, nested ones
    first: a study may write into its parent's folder), or those named."""
    found = sorted((p.parent for p in STUDIES.rglob("index.md")),
                   key=lambda p: (-len(p.parts), p))
    if names:
        found = [p for p in found if p.name in names or str(p.relative_to(STUDIES)) in names]
    return found


def main(argv: list[str]) -> int:
    for folder in folders(argv):
        for args in commands(folder):
            if "sweep" in args and "-o" in args:       # a fresh table, not a continued one
                Path(ROOT / args[args.index("-o") + 1]).unlink(missing_ok=True)
            started = time.perf_counter()
            print(f"{folder.relative_to(ROOT)}: {shlex.join(args[1:])}", flush=True)
            done = subprocess.run(args, cwd=ROOT)
            if done.returncode != 0:
                print(f"failed ({done.returncode}): {shlex.join(args)}", file=sys.stderr)
                return done.returncode
            print(f"  {time.perf_counter() - started:.0f} s", flush=True)
        for script in AFTER.get(folder.name, []):
            print(f"{folder.relative_to(ROOT)}: python {script}", flush=True)
            if subprocess.run([sys.executable, str(ROOT / script)], cwd=ROOT).returncode:
                return 1
    return subprocess.run([sys.executable, str(ROOT / "examples" / "cost_chart.py")],
                          cwd=ROOT).returncode


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
