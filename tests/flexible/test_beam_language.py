"""The flexible_beam declaration: what it builds and what it refuses."""

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import MbdModelError

BEAM = """model m
flexible_beam rod {{ {props} }}
joint pin: revolute(ground.origin, rod.start)
"""
GOOD = ("mass 0.9; length 0.6; E 200e9; area 5.74e-6; second_moment 2.765e-8; elements 4; "
        "frame chord; point M at 0.3")


def codes(props):
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(BEAM.format(props=props))
    return [(d.code, d.message) for d in err.value.diagnostics if d.is_error]


def test_beam_builds_coordinates_and_points():
    model = mbdsl.load_text(BEAM.format(props=GOOD))
    beam = model.bodies[0]
    assert (beam.length, beam.elements, beam.frame, beam.mass) == (0.6, 4, "chord", 0.9)
    assert model.n_coordinates == 3 + 3 * 4
    assert model.coordinate_names()[3:6] == ["rod.theta0", "rod.u1", "rod.v1"]
    assert model.velocity_names()[3] == "rod.theta0_t"
    assert beam.points == {"start": 0.0, "end": 0.6, "M": 0.3}
    assert model.joints[0].second.elastic_columns.size == 0      # start: removed by the frame


def test_density_gives_the_mass():
    props = GOOD.replace("mass 0.9", "density 7800")
    beam = mbdsl.load_text(BEAM.format(props=props)).bodies[0]
    assert beam.mass == pytest.approx(7800 * 5.74e-6 * 0.6)


def test_python_spec_matches_the_file():
    spec = mbdsl.BeamSpec.uniform("rod", length=0.6, E=200e9, area=5.74e-6,
                                  second_moment=2.765e-8, elements=4, mass=0.9, frame="chord",
                                  points={"M": 0.3})
    model = mbdsl.from_spec(mbdsl.ModelSpec("m", bodies=[spec]))
    ref = mbdsl.load_text(BEAM.format(props=GOOD)).bodies[0]
    got = model.bodies[0]
    assert (got.mass, got.length, got.E, got.elements, got.frame, got.points) == \
        (ref.mass, ref.length, ref.E, ref.elements, ref.frame, ref.points)


@pytest.mark.parametrize("props, code, words", [
    (GOOD.replace("length 0.6; ", ""), "E302", "no length"),
    (GOOD + "; density 7800", "E302", "exactly one of 'mass'"),
    (GOOD.replace("frame chord", "frame tangent"), "E304", "unknown frame"),
    (GOOD.replace("at 0.3", "at 0.7"), "E306", "not on the beam"),
    (GOOD.replace("elements 4", "elements 2.5"), "E301", "integer"),
    (GOOD.replace("E 200e9", "E -1"), "E303", "must be positive"),
    (GOOD + "; inertia 3", "E304", "unknown property 'inertia'"),
    (GOOD.replace("length 0.6", "length 1e308"), "E303", "floating-point range"),
])
def test_errors(props, code, words):
    found = codes(props)
    assert any(c == code and words in msg for c, msg in found), found


def test_elastic_columns_of_a_point_are_its_element():
    model = mbdsl.load_text(BEAM.format(props=GOOD))
    beam = model.bodies[0]
    ref = mbdsl.dsl.check.point_ref(beam, "M", "rod.M")
    # x = 0.3 is node 2 of 4 (element 2 starts there): u2, v2, theta2 and node 3's
    S_full = beam.mesh.shape(0.3)[0]
    np.testing.assert_array_equal(ref.elastic_columns,
                                  beam.elastic_offset + np.flatnonzero(np.any(S_full != 0, 0)))
    assert np.allclose(ref.elastic_shape @ np.ones(len(ref.elastic_columns)),
                       S_full @ np.ones(S_full.shape[1]))


def test_an_unloaded_beam_at_rest_starts_without_a_warning():
    """No load, no motion: the beam is quasi-static undeformed, and W403 (which
    said "elastic accelerations up to 0 remain") is not raised; a loaded one
    is started deflected, also without it."""
    text = """model hub_beam
body hub { mass 1; inertia 0.1 }
flexible_beam arm { mass 1.2; length 1; E 7e10; area 1e-4; second_moment 1e-9; elements 4
                    frame first_node; point a at start; point b at end }
joint O: revolute(ground.origin, hub.cm)
joint W: fixed(hub.cm, arm.a)
"""
    for extra, deflected in (("", False), ("gravity (0, -9.81)\ninitial hub.phi = 0\n", True)):
        model = mbdsl.load_text(text + extra)
        init = mbdsl.consistent_initial_state(mbdsl.assemble(model))
        assert not [w for w in init.warnings if w.code == "W403"]
        elastic = init.q[[i for b in model.flexible_bodies for i in b.elastic_columns()]]
        assert (np.max(np.abs(elastic)) > 1e-6) == deflected
