"""Each run's model data: a copy of the system's packed model (packed once),
equal to packing the system again, and its own: what a run's events write
into it (contact impact speeds, springs' held directions) reaches neither
the template nor another run."""

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators import make_method
from mbdsl.integrators.engine import CompiledModel, _kernels, prepare_compiled, recipe_monomials
from mbdsl.integrators.newton import NewtonOptions

from .kernel_models import ROOT


@pytest.mark.parametrize("name", ["slider_crank_clearance", "andrews", "double_pendulum"])
def test_a_runs_model_data_are_a_fresh_packing_of_its_own(name):
    system = mbdsl.assemble(mbdsl.load(ROOT / "models" / f"{name}.mbd"))
    init = mbdsl.consistent_initial_state(system)
    method = make_method("hht-i3")
    first, _, _ = prepare_compiled(system, method, NewtonOptions(), init.q)
    second, _, _ = prepare_compiled(system, method, NewtonOptions(), init.q)
    packed = CompiledModel(system, _kernels())
    for cm in (first, second):
        assert np.array_equal(cm.ints, packed.ints) and np.array_equal(cm.floats, packed.floats)
    assert not np.shares_memory(first.floats, second.floats)
    for cm in (first, second):                   # the views sit where the kernels read them
        fields = cm.K.unpack(cm.ints, cm.floats)
        assert cm.impact_speed.__array_interface__ == fields["kimp"].__array_interface__
        if cm.spring_held is not None:
            held = fields["spar"][:, 3:5]
            assert cm.spring_held.__array_interface__ == held.__array_interface__
    if first.impact_speed.size:
        first.impact_speed[:] = 7.0
        assert not np.any(second.impact_speed == 7.0)
        assert np.shares_memory(first.impact_speed, first.floats)
    if first.spring_held is not None:
        first.spring_held[:] = 3.0
        assert not np.any(second.spring_held == 3.0)


def test_the_recipe_monomials_follow_the_methods_parameters():
    """Kept per parameter set: another alpha, another recipe; the same one,
    equal arrays that a caller may change without touching the kept one."""
    a, b = recipe_monomials(make_method("hht-i3", alpha=-0.05)), recipe_monomials(
        make_method("hht-i3", alpha=-0.3))
    assert not np.array_equal(a, b)
    a[:] = 0.0
    assert np.array_equal(recipe_monomials(make_method("hht-i3", alpha=-0.3)), b)
    assert np.any(recipe_monomials(make_method("hht-i3", alpha=-0.05)) != 0.0)
