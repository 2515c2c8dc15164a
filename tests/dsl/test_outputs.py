"""Sensors: ``output NAME = expr`` lines become ``output.NAME`` columns.

Oracles: the point kinematics written out by hand from the body columns
(r + A(phi) s and its rate), the joint angle as phi2 - phi1, and the
columns the output reads.
"""

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import MbdModelError
from mbdsl.io.csvfile import read_csv_metadata

from ..conftest import MODELS

ARM = (MODELS / "servo_arm.mbd").read_text() + """
output tip_x = link2.T.x
output tip_vy = link2.T.vy
output err = A2*sin(2*t) - E.angle
output pin = sqrt(reaction.O.fx^2 + reaction.O.fy^2)
output net = energy.total - energy.work
"""


def test_outputs_are_the_quantities_they_name(tmp_path):
    from mbdsl.cli.main import main
    path = tmp_path / "arm.mbd"
    path.write_text(ARM)
    out = tmp_path / "arm.csv"
    assert main(["simulate", str(path), "--t-end", "1", "-q", "-o", str(out)]) == 0
    meta, names, v = read_csv_metadata(out)
    c = lambda name: v[:, names.index(name)]      # noqa: E731
    L, t = 0.5, v[:, 0]
    phi1, phi2 = c("link1.phi"), c("link2.phi")
    tip_x = 0.5 * L * np.cos(phi1) * 2 + L * np.cos(phi2)           # the chain from the pin
    np.testing.assert_allclose(c("output.tip_x"), tip_x, atol=1e-12)
    np.testing.assert_allclose(c("output.tip_vy"), c("link2.vy") + 0.5 * L * np.cos(phi2)
                               * c("link2.omega"), atol=1e-12)
    np.testing.assert_array_equal(c("output.err"), 0.4 * np.sin(2 * t) - (phi2 - phi1))
    np.testing.assert_allclose(c("output.pin"), np.hypot(c("reaction.O.fx"), c("reaction.O.fy")))
    np.testing.assert_allclose(c("output.net"), c("energy.total") - c("energy.work"))
    # read back, and plotted by name
    back = mbdsl.load_solution(out)
    np.testing.assert_array_equal(back.column("output.tip_x"), c("output.tip_x"))
    assert main(["plot", str(out), "--y", "output.tip_x,output.err",
                 "-o", str(tmp_path / "tip.png")]) == 0


@pytest.mark.parametrize("line, code, text", [
    ("output a = link2.Q.x", "E201", "body 'link2' has no point 'Q'"),
    ("output a = link2.T.z", "E304", "a point's field is x, y, vx or vy"),
    ("output a = reaction.X.fx", "E201", "a reaction is reaction.<joint>.fx|fy|torque"),
    ("output a = energy.totl", "E304", "did you mean 'total'?"),
    ("output a = link9.x", "E201", "unknown body or joint 'link9'"),
    ("output a = O.distance", "E304", "revolute joint's angle or rate"),
    ("output a = 1\noutput a = 2", "E202", "declared twice"),
])
def test_output_mistakes_are_reported_at_their_place(line, code, text):
    with pytest.raises(MbdModelError) as info:
        mbdsl.load_text((MODELS / "servo_arm.mbd").read_text() + line + "\n", "arm.mbd")
    d = [d for d in info.value.diagnostics if d.code == code]
    assert d and d[0].span is not None, [str(x) for x in info.value.diagnostics]
    assert any(text in (x.message + " " + (x.hint or "")) for x in d)


def test_a_point_with_a_field_where_a_point_is_expected():
    """``crank.A.y`` parses (an output reads it) but is no point: E305 at its place."""
    text = (MODELS / "slider_crank.mbd").read_text().replace(
        "spring_damper(ground.origin, rod.B", "spring_damper(ground.origin.x, rod.B")
    with pytest.raises(MbdModelError) as info:
        mbdsl.load_text(text, "sc.mbd")
    d = info.value.diagnostics[0]
    assert d.code == "E305" and "expected a point like 'body.point'" in d.message
    assert d.span is not None and d.span.line == text.splitlines().index(
        next(x for x in text.splitlines() if "ground.origin.x" in x)) + 1
