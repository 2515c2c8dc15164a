"""The rotations' memo of the time loop's iterate (``kernels.geometry._cos_sin``):
every answer is the one ``math`` gives for the angle in qx now, whatever was
remembered; an extended q of the usual n + 3 entries is read, never written."""

import math

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators.engine import CompiledModel, _kernels
from mbdsl.kernels.geometry import MEMO, _cos_sin

from .kernel_models import ROOT


@pytest.fixture(scope="module")
def model_ints():
    system = mbdsl.assemble(mbdsl.load(ROOT / "models" / "double_pendulum.mbd"))
    return CompiledModel(system, _kernels()).ints, system.n


def _bits(x):
    return np.float64(x).tobytes()


def test_without_a_memo_qx_is_only_read(model_ints):
    I, n = model_ints
    qx = np.linspace(-2.0, 2.0, n + 3)
    before = qx.copy()
    for col in range(n + 3):
        c, s = _cos_sin(I, qx, col)
        assert (_bits(c), _bits(s)) == (_bits(math.cos(qx[col])), _bits(math.sin(qx[col])))
    assert np.array_equal(qx, before)


def test_the_memo_answers_for_the_angle_qx_holds_now(model_ints):
    I, n = model_ints
    base = n + 3
    qx = np.zeros((MEMO + 1) * base)
    qx[base:] = np.nan
    col = 2
    for angle in (0.3, 0.3, 1e-300, 0.0, -0.0, 0.0, -2.5, np.pi, 0.3):
        qx[col] = angle
        c, s = _cos_sin(I, qx, col)
        assert (_bits(c), _bits(s)) == (_bits(math.cos(angle)), _bits(math.sin(angle))), angle
        k = base + MEMO * col
        assert _bits(qx[k]) == _bits(angle)              # remembered, the sign of zero too
    qx[col] = np.inf                                     # no angle: NaN, as from math
    assert np.isnan(_cos_sin(I, qx, col)).all()
    # a memo written by hand with a wrong value for another angle is not used
    qx[col] = 1.0
    k = base + MEMO * col
    qx[k:k + 3] = (0.5, 123.0, 456.0)
    assert _cos_sin(I, qx, col) == (math.cos(1.0), math.sin(1.0))
    # the memo of one column leaves the others alone
    others = np.delete(np.arange(base, (MEMO + 1) * base), np.arange(k - base, k - base + MEMO))
    assert np.isnan(qx[others]).all()
