"""The models and kernel modules the kernel-against-oracle tests run on:
every shipped model and every valid test model, its system evaluating on
the compiled kernels or on their uncompiled copy."""

import warnings
from pathlib import Path

import pytest

import mbdsl
from mbdsl.integrators.engine import CompiledModel, _kernels

ROOT = Path(__file__).resolve().parents[2]
#: The planar models (the oracles here are planar; a spatial model's, ``space 3d``, are
#: in tests/spatial: finite differences and constants of motion).
FILES = sorted(p for p in [*ROOT.glob("models/*.mbd"), *ROOT.glob("tests/dsl/valid/*.mbd"),
                           *ROOT.glob("tests/flexible/*.mbd")]
               if "\nspace 3d" not in p.read_text())


def system_on(path, kernels):
    """The model's system, evaluating on the given kernel module."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return system_on_model(mbdsl.load(path), kernels)


def system_on_model(model, kernels):
    """A model's system, evaluating on the given kernel module."""
    system = mbdsl.assemble(model)
    cm = CompiledModel(system, kernels)
    system.kernel_model = lambda: cm
    return system


@pytest.fixture(scope="module", params=["compiled", "uncompiled"])
def kernels(request):
    """The compiled kernels, or their uncompiled copy."""
    return _kernels(uncompiled=request.param == "uncompiled")
