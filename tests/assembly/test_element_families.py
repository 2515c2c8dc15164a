"""The contract of every element family of ``mbdsl/kernels``: it declares its
fields in the packed model data, they round-trip through packing, and its
triplet counts bound the Newton-matrix entries it emits.

The emitters run uncompiled (the kernels' own code in the interpreter) on a
model that declares the family, at random coordinates, velocities and
multipliers: a count that is too small would let the compiled loop write past
its triplet arrays (``kernels.system.triplet_bound`` sums the counts).
"""

import importlib

import numpy as np
import pytest

import mbdsl
from mbdsl.integrators.engine import CompiledModel
from mbdsl.integrators.kernel_cache import UNCOMPILED_ROOT, uncompiled_kernels
from mbdsl.kernels import schema

from ..conftest import MODELS

VALID = MODELS.parent / "tests" / "dsl" / "valid"
#: family module -> a model that declares it
JOINTS = {"coincidence": VALID / "all_elements.mbd", "point_on_line": VALID / "all_elements.mbd",
          "linear_rows": VALID / "all_elements.mbd", "distance": VALID / "distance_elements.mbd",
          "couplers": VALID / "coupler_elements.mbd", "spatial": MODELS / "heavy_top.mbd",
          "spatial_angles": VALID / "spatial_drivers.mbd"}
LOADS = {"spring_damper": VALID / "all_elements.mbd", "torques": VALID / "all_elements.mbd",
         "point_forces": VALID / "follower_elements.mbd", "state_loads": VALID / "all_elements.mbd",
         "friction": VALID / "friction_elements.mbd",
         "contact": MODELS / "bouncing_ball.mbd",
         "spatial_springs": MODELS / "spatial_spring_pendulum.mbd",
         "spatial_loads": VALID / "spatial_loads.mbd",
         "spatial_rotational": VALID / "spatial_drivers.mbd"}
OTHERS = ("programs", "geometry", "beams.ffr", "beams.elastic_points")


def _module(name, uncompiled=False):
    prefix = UNCOMPILED_ROOT + ".kernels." if uncompiled else "mbdsl.kernels."
    if uncompiled:
        uncompiled_kernels()
    return importlib.import_module(prefix + name)


def test_every_field_belongs_to_one_family():
    owners = {}
    for name in ([f"joints.{j}" for j in JOINTS] + [f"loads.{m}" for m in LOADS]
                 + list(OTHERS) + ["schema"]):
        for field in _module(name).FIELDS:
            assert field not in owners, (field, owners.get(field), name)
            owners[field] = name
    assert set(owners) == {name for name, _, _ in schema.MODEL_SCHEMA}


@pytest.mark.parametrize("path", sorted({*JOINTS.values(), *LOADS.values(),
                                         VALID / "flexible_joints.mbd"}), ids=lambda p: p.stem)
def test_packing_round_trips(path):
    """unpack then pack gives the same two arrays, field by field."""
    cm = CompiledModel(mbdsl.assemble(mbdsl.load(path)))
    fields = schema.unpack(cm.ints, cm.floats)
    ints, floats = schema.pack(fields)
    assert np.array_equal(ints, cm.ints) and np.array_equal(floats, cm.floats)
    again = schema.unpack(ints, floats)
    for name, _, _ in schema.MODEL_SCHEMA:
        assert np.array_equal(again[name], fields[name]), name


@pytest.mark.parametrize("path", sorted({*JOINTS.values(), *LOADS.values(),
                                         VALID / "flexible_joints.mbd"}), ids=lambda p: p.stem)
def test_the_compiled_kernels_and_their_uncompiled_copy_get_the_same_model_data(path):
    """The families pack the same arrays for both: a family's packing that
    compares with a class of the package (the point forces' zero derivatives,
    ``Num``) must see the package's class from the copy too. Before, the copy
    packed 28 more derivative programs for ``follower_elements``, each
    evaluating a constant zero."""
    from mbdsl.assembly.packing import PackedModel
    system = mbdsl.assemble(mbdsl.load(path))
    compiled = PackedModel(system, importlib.import_module("mbdsl.kernels.api"))
    copy = PackedModel(system, uncompiled_kernels())
    assert copy.uncompiled and not compiled.uncompiled
    assert np.array_equal(compiled.ints, copy.ints)
    assert np.array_equal(compiled.floats, copy.floats)


def test_the_load_families_hold_every_load_kind_once():
    """Each load kind of the language is packed by exactly one family of
    ``kernels/loads`` (``LOADS``), and every family packs and says its
    derivatives' pattern."""
    from mbdsl.kernels.system import LOAD_FAMILIES
    kinds = [k for family in LOAD_FAMILIES for k in family.LOADS]
    assert len(kinds) == len(set(kinds))
    assert all(callable(f.pack) and callable(f.pattern) for f in LOAD_FAMILIES)
    assert {m.split(".")[-1] for m in LOADS} == {f.__name__.split(".")[-1] for f in LOAD_FAMILIES}
    found = set()
    for path in [*VALID.glob("*.mbd"), *MODELS.glob("*.mbd")]:
        found |= {f.kind for f in mbdsl.load(path).loads}
    assert found == set(kinds)


def test_a_load_kind_no_family_holds_is_refused_by_name():
    from dataclasses import replace
    from types import SimpleNamespace
    model = mbdsl.load(VALID / "all_elements.mbd")
    gear = SimpleNamespace(kind="gear", name="G1", functions=())
    system = mbdsl.assemble(replace(model, forces=model.forces + (gear,)))
    with pytest.raises(ValueError, match="'G1' \\(gear\\).*LOADS"):
        system.kernel_model()


def _state(path, seed):
    system = mbdsl.assemble(mbdsl.load(path))
    cm = CompiledModel(system, kernels=uncompiled_kernels())
    rng = np.random.default_rng(seed)
    n = system.n
    qx, vx = np.zeros(n + 3), np.zeros(n + 3)
    qx[:n], vx[:n] = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    lam = rng.uniform(-1, 1, max(system.m, 1))
    size = cm.bound
    return system, cm, qx, vx, lam, (np.empty(size, np.int64), np.empty(size, np.int64),
                                      np.empty(size))


@pytest.mark.parametrize("family", sorted(JOINTS))
def test_a_joint_emits_at_most_its_triplet_counts(family):
    module = _module(f"joints.{family}", uncompiled=True)
    system, cm, qx, vx, lam, (R, C, V) = _state(JOINTS[family], 1)
    I, Fl, n = cm.ints, cm.floats, system.n
    k = int(I[3 * schema.MODEL_FIELDS.index(module.FIELDS[0]) + 1])
    assert k > 0
    counts = {
        "PHIQ": module.emit_phiq(I, Fl, n, qx, R, C, V, 0, 0, 0, 1.0, False),
        "G": module.emit_G(I, Fl, n, qx, vx, R, C, V, 0, 0, 0, 1.0)
        if hasattr(module, "emit_G") else 0,
        "HESS": module.emit_hess(I, Fl, n, qx, lam, R, C, V, 0, 0, 0, 1.0)
        if hasattr(module, "emit_hess") else 0,
    }
    assert counts["PHIQ"] > 0
    for what, count in counts.items():
        bound = getattr(module, f"{what}_TRIPLETS") * k
        if what == "HESS" and hasattr(module, "hess_triplets"):   # counted from the data
            bound += module.hess_triplets(I)
        assert count <= bound, (what, count, k)


@pytest.mark.parametrize("family", sorted(LOADS))
def test_a_load_emits_at_most_its_triplet_count(family):
    """Q_q and Q_v of one load family (one force block) against FORCE_TRIPLETS;
    friction's Q_lambda block is counted apart (12 per joint)."""
    module = _module(f"loads.{family}", uncompiled=True)
    system, cm, qx, vx, lam, (R, C, V) = _state(LOADS[family], 2)
    I, Fl, n = cm.ints, cm.floats, system.n
    t = 0.3
    field = module.FIELDS[0]
    k = int(I[3 * schema.MODEL_FIELDS.index(field) + 1])
    if family == "state_loads":         # per load and per partial derivative
        k += int(I[3 * schema.MODEL_FIELDS.index("sdv") + 1])
    assert k > 0
    if family in ("spring_damper", "spatial_springs", "spatial_rotational"):
        p = module.emit_force(I, Fl, n, qx, vx, R, C, V, 0, 0, 0, 1.0, 1.0)
    elif family == "torques":
        p = module.emit_force(I, Fl, n, R, C, V, 0, 0, 0, 1.0, 1.0)
    elif family == "point_forces":      # and the derivatives of the forces of the state
        p = module.emit_force(I, Fl, t, n, qx, vx, R, C, V, 0, 0, 0, 1.0, 1.0)
        assert 0 < p <= module.FORCE_TRIPLETS * k + module.triplets(I), (p, k)
        return
    elif family == "state_loads":
        p = module.emit_force(I, Fl, t, n, qx, vx, R, C, V, 0, 0, 0, 1.0, 1.0)
    elif family == "friction":
        p = module._emit_friction(I, Fl, n, qx, vx, lam, R, C, V, 0, 0, 0, 1.0, 1.0)
    elif family == "spatial_loads":
        p = module.emit_force(I, Fl, t, qx, R, C, V, 0, 0, 0, 1.0)
    else:
        kimp = schema.MODEL_FIELDS.index("kimp")
        Fl = Fl.copy()
        o = int(I[3 * kimp])
        Fl[o:o + k] = 1.0                       # closed gaps at an impact speed of 1 m/s
        qx[:2] = 0.0, 0.04                      # the ball (radius 0.05 m) 1 cm into the floor
        p = module._emit_contacts(I, Fl, n, qx, vx, R, C, V, 0, 0, 0, 1.0, 1.0)
        assert 0 < p <= module.triplets(I), (p, k)      # counted per gap (planar, spatial)
        return
    assert 0 < p <= module.FORCE_TRIPLETS * k, (p, k)
