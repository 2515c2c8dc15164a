"""The studies' measures of error: a quantity's error at the end against the
reference (with the reference's own error), its largest error over a run's
samples, and the order fitted to errors over step sizes.
"""

from __future__ import annotations

import numpy as np

from .reference import StudyReference
from .runs import RunData

__all__ = ["quantity_error", "sampled_error", "fitted_order"]


def quantity_error(model, run: RunData, ref: StudyReference, quantity: str) -> tuple[float, float]:
    """(|x(T) - x_ref(T)|, estimated reference error) of one quantity.

    ``positions``/``velocities``: the max over the coordinates/velocities.
    """
    if quantity == "positions":
        return float(np.max(np.abs(run.q_end - ref.q_end))), float(np.max(ref.error_q))
    if quantity == "velocities":
        return float(np.max(np.abs(run.v_end - ref.v_end))), float(np.max(ref.error_v))
    if quantity.startswith("lambda."):
        i = ref.lam_names.index(quantity)
        return abs(float(run.lam_end[i] - ref.lam_end[i])), float(ref.error_lam[i])
    coords = model.coordinate_names()
    if quantity in coords:
        i = coords.index(quantity)
        return abs(float(run.q_end[i] - ref.q_end[i])), float(ref.error_q[i])
    i = model.velocity_names().index(quantity)
    return abs(float(run.v_end[i] - ref.v_end[i])), float(ref.error_v[i])


def sampled_error(model, run: RunData, ref: StudyReference, quantity: str) -> float:
    """The largest |x(t) - x_ref(t)| of one quantity over a run's samples
    (``RunSpec.samples``; ``positions``/``velocities``: over every coordinate
    or velocity too); NaN without samples, or for a multiplier."""
    if run.t_samples is None or quantity.startswith("lambda."):
        return float("nan")
    q_ref, v_ref = ref.state(run.t_samples)
    if quantity == "positions":
        return float(np.max(np.abs(run.q_samples - q_ref)))
    if quantity == "velocities":
        return float(np.max(np.abs(run.v_samples - v_ref)))
    coords = model.coordinate_names()
    if quantity in coords:
        i = coords.index(quantity)
        return float(np.max(np.abs(run.q_samples[:, i] - q_ref[:, i])))
    i = model.velocity_names().index(quantity)
    return float(np.max(np.abs(run.v_samples[:, i] - v_ref[:, i])))


def fitted_order(hs, errors) -> float:
    """Least-squares slope of log(error) against log(h); NaN with fewer than two points."""
    hs, errors = np.asarray(hs, dtype=float), np.asarray(errors, dtype=float)
    ok = np.isfinite(errors) & (errors > 0)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(hs[ok]), np.log(errors[ok]), 1)[0])
