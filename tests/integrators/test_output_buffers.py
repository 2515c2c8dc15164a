"""The time loop's output buffers: CHUNK rows, or fewer for a model whose
rows would not fit in memory (a chain of 1e5 links asked for 24 GB and the
machine's out-of-memory killer ended the run); a run through small buffers
is the same run."""

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators import loop

from ..conftest import MODELS


def test_a_large_model_keeps_fewer_rows_within_the_budget():
    """Models up to thousands of coordinates keep CHUNK rows; 3e5
    coordinates keep what fits in OUTPUT_BYTES; never none."""
    assert loop.buffer_rows(3000, 2000) == loop.CHUNK
    n, m = 300_000, 200_000
    rows = loop.buffer_rows(n, m)
    assert 1 <= rows < loop.CHUNK
    assert rows * 8 * (3 * n + 2 * m + 8) <= loop.OUTPUT_BYTES
    assert loop.buffer_rows(10 ** 9, 0) == 1


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("rtol", [None, 1e-6])
def test_a_run_through_small_buffers_is_the_same_run(monkeypatch, engine, rtol):
    """The slider crank over 0.5 s (500 rows) with buffers of 7 rows: every
    row is there, at the same times, with the same states (to the Newton
    tolerance: each call of the stepper starts a new Newton matrix)."""
    model = mbdsl.load(MODELS / "slider_crank.mbd")
    ref = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=0.5, rtol=rtol, engine=engine)
    system = ref.system
    monkeypatch.setattr(loop, "OUTPUT_BYTES", 8 * (3 * system.n + 2 * system.m + 8) * 7)
    small = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=0.5, rtol=rtol, engine=engine)
    assert small.completed and small.n_rows == ref.n_rows > 100
    np.testing.assert_allclose(small.t, ref.t, rtol=0, atol=1e-9)   # error control: the
    # same steps, their sizes from estimates that differ in round-off
    np.testing.assert_allclose(small.q, ref.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(small.v, ref.v, rtol=0, atol=1e-7)
