"""The scene matrix: small scenes that combine two or three of the language's
elements, each run with every method, fixed and error-controlled steps, on
the compiled and the numpy engines.

A run must end in one of three ways:

* completed, its own guard silent (``Solution.warnings`` has no W602-W604),
  and the two engines agreeing (:func:`engines_agree`);
* completed with a coded warning that the run's numbers justify (W602 is
  checked against the energy balance recomputed here);
* stopped with a coded error (``MbdError``, or a failed run with E6xx).

Never a traceback, never a guard condition met without its warning.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import mbdsl
from mbdsl.errors import MbdError

SCENES = sorted((Path(__file__).resolve().parent / "scenes").glob("*.mbd"))
METHODS = ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
           "genalpha-si2"]
MODES = {"fixed": None, "error-controlled": 1e-5}
ENGINES = ("compiled", "numpy")

#: Engines agree on q(T) to this, relative to 1 + |q|, on fixed steps (the
#: same formulas in two implementations: round-off, grown over the run).
AGREE_FIXED = 1e-7
#: ... and with error control (the estimate's round-off may choose another
#: step somewhere, each within the tolerance).
AGREE_CONTROLLED = 1e-3

#: The element kinds of the language: each must appear in some scene.
KINDS = ("revolute", "prismatic", "point_on_line", "fixed", "distance", "particle",
         "flexible_beam", "modes", "spring_damper", "rotational_spring_damper", "torque(",
         "force(", "joint_torque", "joint_force", "friction", "contact(", "circle =",
         "line =", "limit", "driver", ".angle =", ".distance =", ".phi =", "if(", "min(",
         "max(", "gear(", "rack(", "coupler(", "rope(", "cable(", "frame = body", "table ", "state ",
         "component ", "import ")


@dataclass
class Outcome:
    """What one run did: kind ("completed", "refused", "traceback"), the
    codes it reported, the Solution (completed runs), and the problems the
    invariants found (empty: the run is fine)."""

    kind: str
    codes: list = field(default_factory=list)
    solution: object = None
    problems: list = field(default_factory=list)
    detail: str = ""


def energy_ratio(sol) -> float:
    """max |energy.balance| over the energy exchanged, recomputed from the
    columns as ``mbdsl.guard`` defines it (its floor included: 0 below it)."""
    c = sol.column
    ke, pe, total = c("energy.kinetic"), c("energy.potential"), c("energy.total")
    work, diss, bal = c("energy.work"), c("energy.dissipated"), c("energy.balance")
    exchanged = max(np.ptp(ke), np.ptp(pe), np.max(np.abs(work)), np.max(np.abs(diss)))
    floor = 1e-9 * np.max(np.abs(np.concatenate([ke, pe, total]))) + 1e-12
    worst = float(np.max(np.abs(bal)))
    if worst <= floor:
        return 0.0
    return worst / exchanged if exchanged > 0 else float("inf")


def run_case(scene: Path, method: str, mode: str, engine: str,
             start: str = "extrapolated") -> Outcome:
    """One run of the matrix, classified and checked against its invariants;
    ``start``: Newton's start in the compiled loop (``NewtonOptions.start``;
    the numpy engine's Newton starts from the last state's values)."""
    from mbdsl.integrators import NewtonOptions
    try:
        model = mbdsl.load(scene)
        sol = mbdsl.simulate(model, method=method, rtol=MODES[mode], engine=engine,
                             on_failure="return", newton=NewtonOptions(start=start))
    except MbdError as exc:
        return Outcome("refused", [d.code for d in exc.diagnostics], detail=str(exc))
    except Exception as exc:                      # noqa: BLE001 - the invariant under test
        import traceback
        return Outcome("traceback", detail=traceback.format_exc(),
                       problems=[f"traceback: {type(exc).__name__}: {exc}"])
    codes = [w.code for w in sol.warnings]
    if sol.status == "failed":
        codes = [d.code for d in sol.diagnostics] + codes
        out = Outcome("refused", codes, sol, detail=sol.message)
        if not any(c.startswith("E6") for c in codes):
            out.problems.append(f"failed without an E6xx code: {sol.message}")
        return out
    out = Outcome("completed", codes, sol)
    ratio = energy_ratio(sol)
    if ratio > 0.01 and "W602" not in codes:
        out.problems.append(f"energy balance off by {ratio:.3g} of the energy exchanged "
                            "without W602")
    if not np.all(np.isfinite(sol.q)):
        out.problems.append("non-finite coordinates in a completed run")
    return out


def engines_agree(a: Outcome, b: Outcome, mode: str) -> list[str]:
    """Problems between the compiled (a) and numpy (b) runs of one case:
    both must end the same way; clean completed runs must agree on q(T).
    The compiled run compared starts Newton where the numpy engine does
    (the last state's values): from the extrapolated start each step's
    solution moves within Newton's tolerance, which a contact's events
    amplify (2e-4 relative on the pin in its hole, hht-i3, fixed steps)."""
    if a.kind != b.kind:
        # one engine refusing where the other completes is a finding, unless
        # the completing one flags itself (the case is at the edge of what
        # the step can do)
        done = a if a.kind == "completed" else b
        if done.kind == "completed" and not done.codes:
            return [f"engines end differently: compiled {a.kind} {a.codes}, numpy {b.kind} "
                    f"{b.codes}"]
        return []
    if a.kind != "completed" or a.codes or b.codes:
        return []
    qa, qb = a.solution.q[-1], b.solution.q[-1]
    tol = AGREE_FIXED if mode == "fixed" else AGREE_CONTROLLED
    diff = float(np.max(np.abs(qa - qb) / (1.0 + np.abs(qb))))
    if diff > tol:
        return [f"engines differ on q(T) by {diff:.3g} (relative), more than {tol:g}"]
    return []


def all_cases():
    """(scene, method, mode) of the whole matrix (engines paired per case)."""
    return [(s, m, mode) for s in SCENES for m in METHODS for mode in MODES]


def ci_slice():
    """A deterministic slice: every scene, each with two methods taken round
    robin (so every method runs on at least two scenes), fixed steps for the
    first and error control for the second."""
    out = []
    k = 0
    for s in SCENES:
        for mode in MODES:
            out.append((s, METHODS[k % len(METHODS)], mode))
            k += 1
    return out
