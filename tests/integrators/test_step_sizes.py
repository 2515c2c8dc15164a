"""The time loop's step-size policy (``loop.StepSizes``), which it follows
whichever stepper takes the steps: the sizes it gives, derived by hand."""

import pytest

from mbdsl.integrators.loop import JUMP, StepSizes


def test_a_failed_step_is_halved_down_to_the_smallest_then_the_run_ends():
    s = StepSizes(h=0.01, h_min=0.01 / 2 ** 3, grow_after=4, augmented=False, adaptive=False)
    sizes, step = [], 0.01
    while (step := s.failed(0.0, step, 1.0)) is not None:
        sizes.append(step)
    assert sizes == [0.005, 0.0025, 0.00125]          # three halvings, then none left


def test_fixed_steps_grow_back_after_grow_after_steps_at_a_reduced_size():
    s = StepSizes(h=0.01, h_min=1e-6, grow_after=4, augmented=False, adaptive=False)
    h = s.failed(0.0, s.failed(0.0, 0.01, 1.0), 1.0)    # 0.0025
    assert s.steps_before_growth(h) == 4
    h = s.grown(h, 3)
    assert h == 0.0025 and s.steps_before_growth(h) == 1
    h = s.grown(h)
    assert h == 0.005 and s.steps_before_growth(h) == 4
    h = s.grown(h, 4)
    assert h == 0.01 and s.steps_before_growth(h) == 0     # at h: no limit
    assert s.grown(h, 100) == 0.01                          # never above h


def test_error_control_grows_its_own_steps():
    s = StepSizes(h=0.01, h_min=1e-9, grow_after=4, augmented=False, adaptive=True)
    h = s.failed(0.0, 0.01, 1.0)
    assert h == 0.005 and s.grown(h, 10) == 0.005 and s.steps_before_growth(h) == 0


def test_the_augmented_formulation_first_jumps_then_halves_the_step_that_failed():
    s = StepSizes(h=0.01, h_min=1e-6, grow_after=4, augmented=True, adaptive=False)
    assert s.failed(0.0, 0.01, 1.0) == pytest.approx(JUMP * 0.01)
    assert s.steps_before_growth(JUMP * 0.01) == 1          # the jump is one step
    assert s.failed(0.0, JUMP * 0.01, 1.0) == 0.005         # it failed too: half the first
    assert s.jumped is None
    # a jump that lands: the next step is the size before it
    assert s.failed(0.5, 0.005, 1.0) == pytest.approx(JUMP * 0.005)
    assert s.landed(JUMP * 0.005) == 0.005 and s.jumped is None
    # no jump past the end of the run: halved at once
    assert s.failed(0.995, 0.005, 1.0) == 0.0025
