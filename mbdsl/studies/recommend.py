"""The recommend study: the step (or the tolerance) each method needs for an
accuracy, from the convergence runs' fitted error constants, checked by a run
at that step, and the model's modes at the step recommended.
"""

from __future__ import annotations

import math

import numpy as np

from .measures import quantity_error
from .reference import method_order
from .runs import RunSpec
from .tables import Section, Table


#: The h a recommendation extrapolates to is this fraction of the one the fitted order
#: predicts (then rounded down to the sweep's largest h halved a whole number of
#: times), so that an error a little above the asymptotic line still meets the target.
RECOMMEND_SAFETY = 0.8
#: A recommendation extrapolates at most this factor below the smallest swept h (a
#: verifying run costs up to that factor times the sweep's longest run).
RECOMMEND_REACH = 32.0


def recommend_h(hs, errors, tol, order, h_max):
    """(h, predicted error, basis) for a target error tol from one method's sweep.

    ``measured``: the largest swept h whose error is at most tol. Otherwise
    ``extrapolated``: from the smallest swept h along the method's order,
    h = RECOMMEND_SAFETY * h_s (tol / e_s)^(1/order), rounded down to h_max /
    2^k. ``not reached``: no usable point (every run failed).
    """
    pts = sorted((h, e) for h, e in zip(hs, errors) if np.isfinite(e) and e > 0)
    ok = [(h, e) for h, e in pts if e <= tol]
    if ok:
        return max(ok)[0], dict(ok)[max(ok)[0]], "measured"
    if not pts:
        return float("nan"), float("nan"), "not reached"
    h_s, e_s = pts[0]
    h = RECOMMEND_SAFETY * h_s * (tol / e_s) ** (1.0 / order)
    k = int(np.ceil(np.log2(h_max / h)))
    h = h_max / 2.0**k
    return h, e_s * (h / h_s) ** order, "extrapolated"


def _recommend(o, runs, ref, model, source=None, system=None, **_):
    """For each target error, the cheapest method and the h or the tolerance it needs.

    Candidates come from the sweep over h (``recommend_h``) and from
    error-controlled runs at rtol = atol = the target (``_tolerance_option``);
    an extrapolated one is run at its h or tolerance and kept only if it
    meets the target (with h halved, or the tolerance quartered, up to
    twice): below the swept step sizes an index-3 method meets the floor its
    Newton tolerance and round-off set (HHT-I3 on the slider crank: 1e-7 m at
    h = 7.6e-6 s, worse than at 3.1e-5 s), which no order extrapolates.
    """
    q = o.quantities[0]
    table = Table("recommend", f"Cheapest method for a target error in {q} at T = {o.t_end:g} s "
                  f"(time of the time loop, median of {o.repeat} after a warm-up run; measured "
                  "in the sweep, or extrapolated along the method's order and verified by a "
                  "run; fixed steps of h, or error-controlled steps at rtol = atol = tol)",
                  ["target", "method", "h [s]", "tol", "error", "basis", "time [s]", "engine",
                   "runner-up", "runner-up time [s]"])
    nan = float("nan")
    for tol in o.tols:
        options = _candidates(o, runs, ref, model, system, tol)
        options.sort()
        chosen = _chosen(o, options, ref, model, source, tol)
        chosen.sort()
        if not chosen:
            table.rows.append([tol, "none", nan, nan, nan,
                               "not reached: no method met it at the step sizes tried "
                               f"(down to {min(o.hs) / RECOMMEND_REACH:.3g} s)", nan, "", "",
                               nan])
            continue
        best, second = chosen[0], (chosen[1] if len(chosen) > 1 else None)
        table.rows.append([tol, best[1], best[2], best[6], best[3], best[4], best[0], best[5],
                           second[1] if second else "", second[0] if second else nan])
    caption = ("Which method, for what accuracy, at what cost: for each target error the "
               "method that needs the least time on this model, the step size or the "
               "tolerance it needs, and the runner-up. A step size below the swept ones is "
               "extrapolated along the method's order, a tolerance in proportion to the error "
               "(docs/methods.md), and then run to verify it.")
    tables = [table]
    spectrum_table = _recommend_modes(table, model, system)
    if spectrum_table is not None:
        tables.append(spectrum_table)
        at_h = _modes_at_model_step(model, system, o.methods)
        if at_h is not None:
            tables.append(at_h)
        caption += (" The second table reads each recommendation against the model's modes "
                    "(mbdsl modes, at the initial state): the fastest mode the step follows "
                    "(period error at most 1 %), the first it does not, and how many steps the "
                    "method takes to remove 99 % of that mode's energy; the third does the "
                    "same for the model's own step and every method.")
    return Section("recommend", caption, tables, [])



def _candidates(o, runs, ref, model, system, tol) -> list:
    """Each method's ways to meet ``tol``: [time, method, h, error, basis,
    engine, tolerance] from the sweep over h (``recommend_h``) and from an
    error-controlled run (``_tolerance_option``)."""
    q = o.quantities[0]
    nan = float("nan")
    options = []        # [time, method, h, error, basis, engine, tolerance]
    for m in o.methods:
        hs = [h for h in o.hs if runs[(m, h, ())].completed]
        if hs:
            errs = [quantity_error(model, runs[(m, h, ())], ref, q)[0] for h in hs]
            order = method_order(m, runs[(m, hs[0], ())].coefficients, system)
            h, err, basis = recommend_h(hs, errs, tol, order, max(o.hs))
            if np.isfinite(h):
                run = runs[(m, h if basis == "measured" else min(hs), ())]
                per_step = run.time / max(run.stats.get("steps", 0), 1)
                options.append([per_step * o.t_end / h, m, h, err, basis, run.engine, nan])
        option = _tolerance_option(runs.get((m, o.hs[0], (), _probe_tol(tol))), model, ref,
                                   q, tol)
        if option is not None:
            options.append(option)
    return options


def _chosen(o, options, ref, model, source, tol) -> list:
    """The two cheapest of ``options`` (sorted by time) from different
    methods, an extrapolated one kept only once a run at its h or tolerance
    meets ``tol`` (h halved, or the tolerance quartered, up to twice)."""
    from .runs import execute_run
    q = o.quantities[0]
    chosen = []
    for opt in options:
        if len(chosen) == 2:
            break
        if any(opt[1] == c[1] for c in chosen):
            continue                      # the runner-up is another method
        if opt[4].startswith("measured") or source is None:
            chosen.append(opt)
            continue
        for _ in range(3):                 # verify an extrapolated step size by a run
            controlled = np.isfinite(opt[6])
            if not controlled and opt[2] < min(o.hs) / RECOMMEND_REACH:
                break
            if controlled and opt[6] < _probe_tol(tol) / RECOMMEND_REACH ** 2:
                break                      # (steps follow tol^(-1/2))
            data = execute_run(source, RunSpec(opt[1], o.hs[0] if controlled else opt[2],
                                               o.t_end, (), 1,
                                               tol=opt[6] if controlled else None))
            err = quantity_error(model, data, ref, q)[0] if data.completed else np.inf
            if err <= tol:
                opt[0], opt[3] = data.time, err
                opt[4] = opt[4].replace("extrapolated", "extrapolated, verified")
                chosen.append(opt)
                break
            if controlled:
                opt[6] /= 4.0
            else:
                opt[2] /= 2.0
    return chosen


#: The tightest tolerance a recommendation probes with error control: an error
#: per unit step of 1e-10 already takes some 1e6 steps on the slider crank.
RECOMMEND_TIGHTEST_PROBE = 1e-10


def _probe_tol(target):
    """The rtol = atol of the error-controlled probe run for a target error."""
    return max(target, RECOMMEND_TIGHTEST_PROBE)


def _tolerance_option(run, model, ref, q, target):
    """A recommendation with error control from the run at rtol = atol = target:
    [time, method, nan, error, basis, engine, tolerance], or None. Measured
    when it meets the target; otherwise the tolerance RECOMMEND_SAFETY target
    (target / error), the error being proportional to the tolerance, and the
    time scaled by the steps' tol^(-1/2) (docs/methods.md)."""
    if run is None or not run.completed:
        return None
    err = quantity_error(model, run, ref, q)[0]
    if not (np.isfinite(err) and err > 0):
        return None
    if err <= target:
        return [run.time, run.spec.method, float("nan"), err, "measured, error control",
                run.engine, target]
    tol = RECOMMEND_SAFETY * target * target / err
    return [run.time * math.sqrt(target / tol), run.spec.method, float("nan"), target,
            "extrapolated, error control", run.engine, tol]


def _modes_at_model_step(model, system, methods, most: int = 8):
    """The modes the model's own step does not follow, and the steps each
    method takes to remove 99 % of each one's energy: a Table, or None."""
    from ..errors import MbdError
    from ..integrators import make_method, settings_coefficients
    from ..integrators.spectral import spectrum
    from ..modes import DENSE_LIMIT, describe_followed, followed, modes
    h = model.settings.get("h")
    if not h:
        return None
    try:
        found = modes(system, k=None if system.n <= DENSE_LIMIT else 20)
    except (MbdError, np.linalg.LinAlgError, ValueError):
        return None
    made = [make_method(m, **settings_coefficients(model.settings, m)) for m in methods]
    fast, above = followed(found, made[0], float(h))
    out = Table("recommend_model_step", f"The modes the model's step h = {h:g} s does not "
                "follow, and the steps each method takes to remove 99 % of their energy",
                ["mode", "f [Hz]", "omega h", "the mode of"] + [m.name for m in made])
    for i, mo, _ in above[:most]:
        row = [i, mo.frequency, mo.omega * h, found.mode_of(mo)]
        for m in made:
            row.append(spectrum(m.amplification(mo.omega * h), mo.omega * h).steps_to_damp)
        out.rows.append(row)
    out.notes.append(describe_followed(found, made[0], float(h)))
    if above:
        i, mo, _ = above[0]
        out.notes.append(f"to follow mode {i} ({mo.frequency:.4g} Hz, {found.mode_of(mo)}), "
                         f"the mode that limits h, a step below {0.3 / mo.omega:.2g} s "
                         "(omega h = 0.3, period error about 1 %)")
    return out


def _recommend_modes(table, model, system):
    """The recommendations read against the spectrum (``mbdsl.modes``): a Table,
    or None without a system or when the modes cannot be found."""
    from ..errors import MbdError
    from ..integrators import make_method, settings_coefficients
    from ..modes import DENSE_LIMIT, describe_followed, followed, modes
    if system is None or not table.rows:
        return None
    try:
        found = modes(system, k=None if system.n <= DENSE_LIMIT else 20)
    except (MbdError, np.linalg.LinAlgError, ValueError):
        return None
    out = Table("recommend_modes", "The recommended steps and the model's modes",
                ["target", "method", "h [s]", "followed up to [Hz]", "fastest followed",
                 "first not followed [Hz]", "its omega h", "steps to remove 99 %",
                 "the mode of"])
    for row in table.rows:
        tol, name, h = row[0], row[1], row[2]
        if name == "none" or not np.isfinite(h):
            continue
        method = make_method(name, **settings_coefficients(model.settings, name))
        fast, above = followed(found, method, h)
        first = above[0] if above else None
        out.rows.append([
            tol, name, h, fast[1].frequency if fast else float("nan"),
            f"mode {fast[0]}" if fast else "none",
            first[1].frequency if first else float("nan"),
            first[2].omega_h if first else float("nan"),
            first[2].steps_to_damp if first else float("nan"),
            found.mode_of(first[1]) if first else ""])
        out.notes.append(f"target {tol:g}, {name}: " + describe_followed(found, method, h))
    return out

