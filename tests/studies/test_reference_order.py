"""The order a study expects of a method (``studies.method_order``) is the
method's own on the study's model (``Method.order``)."""

import mbdsl
from mbdsl.studies import method_order

from ..conftest import MODELS


def test_expected_order_follows_the_model():
    rigid = mbdsl.assemble(mbdsl.load(MODELS / "slider_crank.mbd"))
    flexible = mbdsl.assemble(mbdsl.load(MODELS / "flexible_slider_crank.mbd"))
    friction = mbdsl.assemble(mbdsl.load(MODELS / "incline_friction.mbd"))
    # stored coefficients include HHT's derived beta and gamma: ignored
    hht = {"alpha": -0.05, "beta": 0.275625, "gamma": 0.55}
    assert method_order("hht-i3", hht, rigid) == 2
    # HHT-I3's order 1 on flexible beams is asymptotic: at the paper's steps it fits 2.01
    assert method_order("hht-i3", hht, flexible) == 2
    assert method_order("hht-si2", hht, flexible) == 2
    assert method_order("hht-add", {"alpha": -0.05}, friction) == 1
    assert method_order("hht-add", {"alpha": -0.05}, rigid) == 2
    assert method_order("newmark", {"gamma": 0.6, "beta": 0.3025}) == 1
    assert method_order("newmark", {"gamma": 0.5, "beta": 0.25}) == 2
