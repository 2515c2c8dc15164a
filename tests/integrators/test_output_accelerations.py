"""The acceleration columns are the motion's q'' for every method.

HHT-ADD carries a = M^-1 Q (the applied forces' share; the constraint
forces' is in its psi multipliers): written as the acceleration columns, a
pendulum's angular acceleration read 0. Its output writes, like its
multipliers, the index-1 values at each row's (q, v) (Haug, sec. 6.3). The
oracle: the index-1 system solved row by row by its dense matrix
(``AssembledSystem.index1_state``), a path that shares no code with the
output's (the equations of motion solved for a given lambda).
"""

from pathlib import Path

import numpy as np
import pytest

import mbdsl

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("model, output", [
    ("models/double_pendulum.mbd", {}),
    ("models/slider_crank.mbd", {"output_dt": 0.0125}),        # rows between steps
    ("models/bouncing_ball.mbd", {}),                          # contact states
    ("models/incline_friction.mbd", {}),                       # Q reads lambda
    ("models/flexible_slider_crank.mbd", {}),                  # M(q)
])
def test_hht_add_writes_the_motions_accelerations(model, output, engine):
    path = ROOT / model
    m = mbdsl.load(path)
    sol = mbdsl.simulate(m, method="hht-add", t_end=0.05, engine=engine,
                         **({"h": 1e-3} if "flexible" not in model else {"h": 1e-4}), **output)
    assert sol.completed
    system = sol.system
    rows = range(0, len(sol.t), max(1, len(sol.t) // 7))
    for i in rows:
        if system.contact_state is not None:
            group = system.contact_state
            kept = group.impact_speed.copy()
            group.impact_speed[:] = group.speeds_at(sol.t[i:i + 1], group.log)[0]
        try:
            a, lam = system.index1_state(sol.t[i], sol.q[i], sol.v[i])
        finally:
            if system.contact_state is not None:
                group.impact_speed[:] = kept
        scale = 1.0 + np.abs(a).max()
        assert np.abs(sol.a[i] - a).max() < 1e-8 * scale, (i, sol.a[i], a)
        assert np.abs(sol.lam[i] - lam).max(initial=0.0) < 1e-8 * (1.0 + np.abs(lam).max(initial=0.0))
    # and they are the motion's: the same run's velocities differentiated
    v = sol.v
    dv = np.gradient(v, sol.t, axis=0)[2:-2]
    assert np.abs(dv - sol.a[2:-2]).max() < 0.05 * (1.0 + np.abs(sol.a).max())
