"""The scene matrix (``matrix.py``): every element kind with every method,
fixed and error-controlled steps, on both engines; right or honestly
refused. CI runs a slice touching every scene and every method; the full
matrix is ``-m slow``."""

import pytest

from .matrix import (KINDS, METHODS, SCENES, all_cases, ci_slice, engines_agree, run_case)


def _check(scene, method, mode):
    # the compiled run as a user's (Newton's extrapolated start) against the
    # invariants, and with the numpy engine's start against the numpy engine
    a = run_case(scene, method, mode, "compiled")
    same = run_case(scene, method, mode, "compiled", start="last")
    b = run_case(scene, method, mode, "numpy")
    problems = a.problems + same.problems + b.problems + engines_agree(same, b, mode)
    assert not problems, (problems, a.detail[-2000:], b.detail[-2000:])


def test_the_scenes_cover_every_element_kind():
    text = "\n".join(s.read_text() for s in SCENES)
    assert [k for k in KINDS if k not in text] == []


def test_the_slice_covers_every_method_and_scene():
    cases = ci_slice()
    assert {m for _, m, _ in cases} == set(METHODS)
    assert {s for s, _, _ in cases} == set(SCENES)


@pytest.mark.parametrize("scene, method, mode", ci_slice(),
                         ids=lambda x: getattr(x, "stem", x))
def test_slice(scene, method, mode):
    _check(scene, method, mode)


@pytest.mark.slow
@pytest.mark.parametrize("scene, method, mode", all_cases(),
                         ids=lambda x: getattr(x, "stem", x))
def test_full_matrix(scene, method, mode):
    _check(scene, method, mode)
