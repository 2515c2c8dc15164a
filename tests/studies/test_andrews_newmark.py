"""NEWMARK (gamma = 0.6) is first order on Andrews' mechanism once its
steps are in the asymptotic range: the error of body 5's angle at T changes
sign near h = 1e-5 s, so only below a few 1e-6 s does it halve with h
(docs/studies.md, Andrews)."""

import math

import mbdsl

from ..conftest import MODELS


def test_newmark_angle_converges_at_order_one_on_andrews():
    """The observed order from three runs at h, h/2, h/4 (no reference
    needed): p = log2((y_h - y_h/2) / (y_h/2 - y_h/4)), 1 for a first-order
    method, 2 for a second-order one."""
    model = mbdsl.load(MODELS / "andrews.mbd")
    T = 0.03
    y = []
    for h in (6.25e-7, 3.125e-7, 1.5625e-7):
        sol = mbdsl.simulate(model, method="newmark", h=h, t_end=T, output_every=1000)
        assert sol.t[-1] == T
        y.append(sol.column("body5.phi")[-1])
    p = math.log2((y[0] - y[1]) / (y[1] - y[2]))
    assert abs(p - 1.0) < 0.15          # measured 0.934 (the study over 2.5e-6 .. 7.8e-8 s: 0.937)
