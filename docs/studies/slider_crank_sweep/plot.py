"""The figure of docs/studies.md, "Parameter sweeps", from the sweep's table:

    mbdsl sweep models/slider_crank.mbd --set k=20:400:39 --set c=0,5,20 --t-end 2 \
        --columns crank.phi,energy.total -o docs/studies/slider_crank_sweep/sweep.h5
    python docs/studies/slider_crank_sweep/plot.py
"""

from pathlib import Path

import matplotlib
import numpy as np

from mbdsl.io.hdf5 import read_sweep
from mbdsl.studies.study import engine_line

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

here = Path(__file__).parent
t = read_sweep(here / "sweep.h5")
fig, axes = plt.subplots(1, 2, figsize=(9, 3.5), layout="constrained")
for c in sorted(set(t["c"])):
    sel = t["c"] == c
    order = np.argsort(t["k"][sel])
    k = t["k"][sel][order]
    axes[0].plot(k, t["crank.phi.final"][sel][order], "o-", ms=3, label=f"c = {c:g} N s/m")
    axes[1].plot(k, t["crank.phi.max"][sel][order] - t["crank.phi.min"][sel][order], "o-",
                 ms=3, label=f"c = {c:g} N s/m")
axes[0].set(xlabel="spring stiffness k [N/m]", ylabel="crank angle at t = 2 s [rad]")
axes[1].set(xlabel="spring stiffness k [N/m]", ylabel="range of the crank angle [rad]")
axes[0].legend(fontsize=8)
for ax in axes:
    ax.grid(alpha=0.3)
fig.savefig(here / "sweep.png", dpi=110)
(here / "index.md").write_text(
    "# A sweep of the slider crank's spring\n\n"
    "- command: `mbdsl sweep models/slider_crank.mbd --set k=20:400:39 --set c=0,5,20 --t-end 2 "
    "--columns crank.phi,energy.total -o docs/studies/slider_crank_sweep/sweep.h5`\n"
    "- command: `python docs/studies/slider_crank_sweep/plot.py`\n"
    f"- {engine_line(t['engine'])}\n\n"
    "![the slider crank's spring stiffness swept](sweep.png)\n", encoding="utf-8")
