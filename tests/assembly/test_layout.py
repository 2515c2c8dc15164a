"""The layout of q and of the constraint rows, made from arrays (one pass
over the bodies' kinds, the rows' counts), against a plain per-body and
per-row reading of the same model: the columns of each body, the names of
q, v and a, the rows of each element, the mass diagonal and gravity's Q, and
the failure reports' lookups (the worst element, its span, a joint's first
row). The models mix every kind of body: rigid bodies, planar particles,
flexible beams, first-order states, spatial bodies and particles (their
frames' rows), couplers and drivers."""

import numpy as np
import pytest

import mbdsl

from ..conftest import MODELS, ROOT

VALID = ROOT / "tests" / "dsl" / "valid"
MIXED = [VALID / "follower_elements.mbd", VALID / "state_elements.mbd",
         VALID / "coupler_elements.mbd", VALID / "all_elements.mbd",
         MODELS / "car_axis.mbd", MODELS / "spatial_arm.mbd", MODELS / "pendulum_chain.mbd"]


def _columns(model):
    """Each body's (x, y, phi) columns, read body by body: three each, two
    for a particle (its phi the ground's n + 2), a spatial body its twelve's
    first three."""
    n, off, table, spatial = model.n_coordinates, 0, [], {}
    for i, b in enumerate(model.bodies):
        width = len(b.coordinate_fields) if hasattr(b, "coordinate_fields") else 3
        if getattr(b, "space", 2) == 3:
            spatial[i] = (off, width)
            table.append((off, off + 1, off + 2))
        elif b.particle:
            width = 2
            table.append((off, off + 1, n + 2))
        else:
            table.append((off, off + 1, off + 2))
        off += width
    return np.array(table).reshape(-1, 3), spatial, off


def _names(model, fields, beam_suffix, state_name):
    out = []
    for b in model.bodies:
        if getattr(b, "space", 2) == 3:
            own = {"x": b.coordinate_fields, "vx": b.velocity_fields,
                   "ax": b.acceleration_fields}[fields[0]]
        else:
            own = fields[:2] if getattr(b, "particle", False) else fields
        out += [f"{b.name}.{c}" for c in own]
    for b in model.bodies:
        if hasattr(b, "n_elastic"):
            out += [f"{b.name}.{c}{beam_suffix}" for c in b.mesh.names]
    return out + [state_name(s) for s in model.states]


@pytest.mark.parametrize("path", MIXED, ids=lambda p: p.stem)
def test_the_columns_and_names_are_those_of_each_body_in_turn(path):
    model = mbdsl.load(path, {"N": 7} if path.stem == "pendulum_chain" else None)
    cmap = model.coordinate_map
    table, spatial, n_reference = _columns(model)
    np.testing.assert_array_equal(cmap.table, table)
    assert cmap.n_reference == n_reference
    assert cmap.spatial == {i: c for i, (c, _) in spatial.items()}
    assert cmap.spatial_width == {i: w for i, (_, w) in spatial.items()}
    assert cmap.elastic == {b.index: b.elastic_offset for b in model.bodies
                            if hasattr(b, "n_elastic")}
    lay = mbdsl.assemble(model).layout
    assert lay.coordinates == _names(model, ("x", "y", "phi"), "",
                                     lambda s: f"state.{s.name}.integral")
    assert lay.velocities == _names(model, ("vx", "vy", "omega"), "_t",
                                    lambda s: f"state.{s.name}")
    assert lay.accelerations == _names(model, ("ax", "ay", "alpha"), "_tt",
                                       lambda s: f"state.{s.name}.rate")
    assert len(lay.coordinates) == model.n_coordinates


def test_the_names_of_a_model_of_every_planar_kind_are_spelled_out():
    """A rigid body, a particle and a beam (its elastic coordinates after all
    bodies'), written out by hand."""
    model = mbdsl.load(VALID / "follower_elements.mbd")
    names = model.coordinate_names()
    assert names[:8] == ["arm.x", "arm.y", "arm.phi", "slider.x", "slider.y", "slider.phi",
                         "bob.x", "bob.y"]
    assert names[8:11] == ["rod.x", "rod.y", "rod.phi"]
    assert model.velocity_names()[6:8] == ["bob.vx", "bob.vy"]
    assert model.acceleration_names()[:3] == ["arm.ax", "arm.ay", "arm.alpha"]


@pytest.mark.parametrize("path", MIXED, ids=lambda p: p.stem)
def test_the_rows_of_each_element_are_its_own_in_row_order(path):
    model = mbdsl.load(path, {"N": 7} if path.stem == "pendulum_chain" else None)
    system = mbdsl.assemble(model)
    lay = system.layout
    rows, element_rows, row_element, first = [], {}, [], {}
    for k, e in enumerate(model.constraint_elements):   # joints, drivers, couplers, frames
        first[e.name] = len(rows)
        element_rows[e.name] = list(range(len(rows), len(rows) + e.rows))
        rows += [(e.name, i) for i in range(e.rows)]
        row_element += [k] * e.rows
    assert len(rows) == system.m == model.n_constraints
    assert list(lay.rows) == rows
    assert [lay.rows[i] for i in range(len(rows))] == rows
    assert lay.rows[-1] == rows[-1] if rows else True
    assert dict(lay.element_rows) == element_rows
    np.testing.assert_array_equal(lay.row_element, row_element)
    assert lay.n_elements == len(model.constraint_elements)
    frames = [r for f in model.frames for r in element_rows[f.name]]
    np.testing.assert_array_equal(lay.frame_rows, frames)
    assert dict(system.joint_rows) == {j.name: first[j.name] for j in model.joints}
    assert lay.multiplier_names() == [f"lambda.{a}.{b}" for a, b in rows]
    for e in model.constraint_elements:
        assert lay.span_of(e.name) is e.span
    assert lay.span_of("no such element") is None
    with pytest.raises(KeyError):
        system.joint_rows[model.drivers[0].name if model.drivers else "no such joint"]


@pytest.mark.parametrize("path", MIXED, ids=lambda p: p.stem)
def test_the_mass_diagonal_and_gravity_are_each_bodys(path):
    model = mbdsl.load(path, {"N": 7} if path.stem == "pendulum_chain" else None)
    system = mbdsl.assemble(model)
    table, spatial, _ = _columns(model)
    n, mass, Qg = system.n, np.zeros(system.n), np.zeros(system.n)
    g = model.gravity
    for i, b in enumerate(model.bodies):
        if i in spatial:
            c, w = spatial[i]
            mass[c:c + w] = b.mass_diagonal
        elif hasattr(b, "n_elastic"):
            continue                              # the beams' blocks: ``ffr``
        else:
            mass[table[i, :2]] = b.mass
            if table[i, 2] < n:
                mass[table[i, 2]] = b.inertia
        if g is not None and not hasattr(b, "n_elastic"):
            Qg[table[i, :len(g)]] = b.mass * g
    mass[model.coordinate_map.state_offset:] = 1.0          # a state's integral: unit mass
    rigid = system._rigid_cols
    np.testing.assert_array_equal(system.mass_diag[rigid], mass[rigid])
    if g is None or not np.any(g != 0.0):
        assert system.gravity_force is None
    else:
        np.testing.assert_array_equal(system.gravity_force, Qg)


def test_the_worst_element_is_the_first_of_the_largest_and_passes_over_non_finite():
    """Rows of the chain N = 4: four joints of two rows, then nothing else."""
    model = mbdsl.load(MODELS / "pendulum_chain.mbd", {"N": 4})
    lay = mbdsl.assemble(model).layout
    names = [j.name for j in model.joints]
    r = np.array([0.1, -0.2, 0.05, 0.0, -0.7, 0.3, 0.7, 0.0])
    assert lay.worst_element(r) == (names[2], 0.7)        # |-0.7| first of the two 0.7s
    r[4] = np.nan                                         # the third joint passed over
    assert lay.worst_element(r) == (names[3], 0.7)
    assert lay.worst_element(np.full(8, np.nan)) == ("", -1.0)
    assert lay.element_of_row(5) == names[2]
    np.testing.assert_array_equal(lay.element_mask({names[1], names[3]}),
                                  [0, 0, 1, 1, 0, 0, 1, 1])
