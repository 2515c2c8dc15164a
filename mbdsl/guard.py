"""A run that knows when it is wrong: checks of a finished run's own rows.

A run can complete every step and still be wrong: a step that resolves
nothing of a fast contact, a stick-slip switch that error control chases
down to round-off, a method whose numerical damping is not where the user
thought. Three signs of that are read from the stored rows, after the run,
on every run (they cost a pass over arrays the run has computed anyway):

* **W602, the energy balance.** ``energy.balance = E - E_0 - work +
  dissipated`` (:func:`mbdsl.io.derived.energy_flows`) is zero for the exact
  motion. Its largest magnitude is compared with the energy the run
  exchanged: the largest of the range of the kinetic energy, the range of
  the potential energy, the work put in and the energy dissipated (and, of
  a spatial body, the range of its energy of turning about one principal
  axis: a torque-free body's moves between its axes). Above
  :data:`ENERGY_LIMIT` of that (1 %) the run is flagged. The number: the
  shipped models at their own settings stay at or below 0.5 % (the PD servo
  arm, 0.46 %; the others 1e-6 .. 3e-4), so 1 % leaves a factor of two above
  the worst clean run while a run that is wrong by a visible amount is
  caught (a friction run that chased stick-slip to 1e-9 s steps: 40 %; a
  spinning beam whose Newton matrix lost a term: 44 %). An absolute floor
  (1e-9 of the largest energy, plus 1e-12 J) keeps a mechanism at rest, whose
  exchanged energy is round-off, from tripping it.
* **W603, a collapsed step size.** Error-controlled steps that fall more than
  :data:`COLLAPSE_LIMIT` (six orders of magnitude) below the run's median
  step, other than the steps that land on a contact event (whose length is
  where the event falls, not what the error needed). The shipped models'
  error-controlled runs stay within a factor of 52 of their median.
* **W604, reactions that alternate.** Constraint forces that jump by more
  than :data:`JUMP_FACTOR` (10) times their typical size (the median of
  |lambda| over the run) and back again at every step, for
  :data:`ALTERNATING_STEPS` or more steps in a row: the signature of an
  iteration that does not resolve the motion (a multiplier oscillating
  between branches), not of an impact, whose reaction rises and falls
  once.

Each check returns :class:`~mbdsl.errors.Diagnostic` warnings; the summary,
the result files' metadata and ``Solution.warnings`` carry them, and
``mbdsl simulate --strict`` turns them into a failed run (exit 3).
"""

from __future__ import annotations

import numpy as np

from .errors import Diagnostic

__all__ = ["run_checks", "energy_balance", "step_collapse", "alternating_reactions",
           "ENERGY_LIMIT", "COLLAPSE_LIMIT", "JUMP_FACTOR", "ALTERNATING_STEPS"]

#: Largest |energy.balance| accepted, as a fraction of the energy exchanged.
ENERGY_LIMIT = 0.01
#: Largest ratio of the median step to a step that is not an event's landing.
COLLAPSE_LIMIT = 1e6
#: A reaction's step-to-step change, in units of its typical size, that counts as a jump.
JUMP_FACTOR = 10.0
#: Consecutive alternating jumps that flag a run.
ALTERNATING_STEPS = 8


def run_checks(sol) -> list[Diagnostic]:
    """Every check of this module on a run's rows (a finalized Solution).

    Returns
    -------
    list of Diagnostic
        Warnings W602, W603, W604, in that order; empty for a clean run.
    """
    out = []
    for check in (energy_balance, step_collapse, alternating_reactions):
        d = check(sol)
        if d is not None:
            out.append(d)
    return out


def _turning_exchange(sol) -> float:
    """The largest range [J] of a spatial body's kinetic energy of turning
    about one principal axis, J_k w_k^2 / 2, from the extents of its
    ``BODY.wx``, ``wy``, ``wz`` columns: a torque-free body keeps its kinetic
    energy while it moves between the axes (Euler-Poinsot), energy a wrong
    gyroscopic term would misroute. 0 without spatial bodies."""
    out = 0.0
    for b in sol.model.bodies:
        if not hasattr(b, "velocity_fields") or getattr(b, "particle", False):
            continue
        for k, c in enumerate("xyz"):
            w = sol.extent(f"{b.name}.w{c}")
            top = max(w.min ** 2, w.max ** 2)
            low = 0.0 if w.min <= 0.0 <= w.max else min(w.min ** 2, w.max ** 2)
            out = max(out, 0.5 * float(b.inertia[k]) * (top - low))
    return out


def energy_balance(sol) -> Diagnostic | None:
    """W602 when the largest |energy.balance| exceeds :data:`ENERGY_LIMIT`
    of the energy exchanged (module notes), else None."""
    if sol.n_rows < 2:
        return None
    x = sol.extent          # a column's range and largest value (kept by a streamed run)
    ke, pe, total = x("energy.kinetic"), x("energy.potential"), x("energy.total")
    work, diss, bal = x("energy.work"), x("energy.dissipated"), x("energy.balance")
    with np.errstate(all="ignore"):
        exchanged = float(np.max([ke.max - ke.min, pe.max - pe.min, work.absmax,
                                  diss.absmax, _turning_exchange(sol)]))
        floor = 1e-9 * float(np.max([ke.absmax, pe.absmax, total.absmax])) + 1e-12
        k, worst = bal.at, bal.absmax
    if not np.isfinite(worst):
        worst = float("inf")
    if worst <= max(ENERGY_LIMIT * exchanged, floor):
        return None
    share = (f" = {100 * worst / exchanged:.3g} % of the {exchanged:.3g} J exchanged"
             if exchanged > 0 else "")
    return Diagnostic(
        "warning", "W602",
        f"energy balance off by {worst:.3g} J{share} (at t = {sol.t[k]:.6g} s): the motion "
        "does not match the forces that act on it; the run is not accurate there", None, "",
        hint="a step that does not resolve the fastest motion (a stiff contact, spring or "
             "beam), or a switch the steps chase: a smaller h or rtol, or another method; "
             "`mbdsl study convergence` shows whether the result has converged",
        notes=(f"the limit is {100 * ENERGY_LIMIT:g} % of the energy exchanged (the largest "
               "of the kinetic and potential energies' ranges, the work in and the energy "
               "dissipated)",))


def _landing_steps(sol) -> np.ndarray:
    """Which recorded steps (rows 1..) end on a contact or limit event."""
    t = sol.t[1:]
    landed = np.zeros(len(t), dtype=bool)
    for e in sol.events:
        landed |= np.abs(t - e[0]) <= 1e-9 * (1.0 + abs(e[0]))
    return landed


def step_collapse(sol) -> Diagnostic | None:
    """W603 when an error-controlled step falls more than
    :data:`COLLAPSE_LIMIT` below the run's median step (landings on events
    left out), else None."""
    if getattr(sol, "control", None) is None or len(sol.t) < 3:
        return None
    h = np.asarray(sol.stats["h"][1:], dtype=float)
    keep = ~_landing_steps(sol) & (h > 0)
    if not np.any(keep):
        return None
    median = float(np.median(h[keep]))
    k = int(np.flatnonzero(keep)[np.argmin(h[keep])])
    if h[k] * COLLAPSE_LIMIT >= median:
        return None
    return Diagnostic(
        "warning", "W603",
        f"the step size collapsed to {h[k]:.3g} s at t = {sol.t[k + 1]:.6g} s, "
        f"{median / h[k]:.2g} times below the run's median step {median:.3g} s: the error "
        "estimate was chasing something the steps cannot resolve", None, "",
        hint="a force that switches with the motion (friction at stick-slip, a contact) or "
             "a multiplier that oscillates: check the run around that time; a fixed step "
             "run compares")


def alternating_reactions(sol) -> Diagnostic | None:
    """W604 when a constraint force alternates by more than
    :data:`JUMP_FACTOR` times its typical size for :data:`ALTERNATING_STEPS`
    steps in a row, else None."""
    m, N = sol.system.m, sol.n_rows
    if not m or N < ALTERNATING_STEPS + 2:
        return None
    # the multipliers in blocks of columns of about 2^20 values: a long streamed
    # run's are read from its file a column at a time, a chain's 20 000 at once
    width = max(1, (1 << 20) // N)
    blocks = [(j0, min(m, j0 + width)) for j0 in range(0, m, width)]
    # (temporaries in place: a run of 10^6 steps has columns of 8 MB)
    with np.errstate(all="ignore"):
        typical = np.concatenate([np.median(np.abs(sol.multipliers(a, b)), axis=0,
                                            overwrite_input=True) for a, b in blocks])
        ref = np.maximum(typical, 1e-3 * float(np.max(typical)) + 1e-12)
    best, where = 0, None
    for a, b in blocks:
        with np.errstate(all="ignore"):
            z = np.diff(sol.multipliers(a, b), axis=0)
            z /= ref[a:b]
            down = np.signbit(z)        # (a jump is not zero, nor NaN)
            big = np.abs(z, out=z) > JUMP_FACTOR
        del z
        alternating = big[1:] & big[:-1] & (down[1:] != down[:-1])
        for jj in np.flatnonzero(np.count_nonzero(alternating, axis=0) >= ALTERNATING_STEPS):
            run = 0
            for i in np.flatnonzero(alternating[:, jj]):   # the longest run of consecutive rows
                run = run + 1 if run and i == last + 1 else 1
                last = i
                if run > best:
                    best, where = run, (i, a + jj)
    if best < ALTERNATING_STEPS:
        return None
    i, j = where
    i0 = i + 2 - best                        # the row where the alternation starts
    rows = sol.system.layout.rows
    name = f"{rows[j][0]}" + (f" (row {rows[j][1]})" if len(rows[j]) > 1 else "")
    span = sol.system.layout.span_of(rows[j][0])
    return Diagnostic(
        "warning", "W604",
        f"the reaction of '{name}' alternates step by step by more than "
        f"{JUMP_FACTOR:g} times its typical size ({typical[j]:.3g}) for {best + 1} steps "
        f"from t = {sol.t[i0]:.6g} s: the multipliers are not resolved there", span,
        "reaction alternates",
        hint="forces that read this reaction (friction) or the method's acceleration after a "
             "non-smooth event; a smaller h or another method compares")
