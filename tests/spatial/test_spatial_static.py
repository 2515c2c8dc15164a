"""``initial static`` in spatial models: the equilibrium Q = Phi_q^T lambda
with the frames' rows among the constraints, a given orientation held by
three rows (the small rotation's components, not its nine directors,
which the six frame rows would make redundant).

Oracles: a rod on a revolute under gravity and a rotational spring
(m g l cos theta = k theta, solved by brentq here); a body hung from a
spring at its centre of mass with its orientation given (z = -(L0 + m g /
k)); both then stay at rest."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

import mbdsl
from mbdsl.errors import AssemblyError

ROD = """model rod_static
space 3d
gravity (0, 0, -9.81)
body rod { mass 1; inertia (0.01, 0.03, 0.03); point O (-0.5, 0, 0) }
joint R: revolute(ground.origin, rod.O, ground.y, rod.y)
force spring: rotational_spring_damper(R, k = 10, c = 0.5, angle = 0)
initial static
simulate { method {method}; h 1e-3; t_end 1 }
"""

HUNG = """model hung
space 3d
gravity (0, 0, -9.81)
ground { point top (0, 0, 1) }
body box { mass 2; inertia (0.02, 0.03, 0.04) }
force spring: spring_damper(ground.top, box.cm, k = 400, c = 3, length = 0.5)
initial box.orientation = zyx(0.3, 0.2, -0.1)
initial static
simulate { method hht-si2; h 1e-3; t_end 1 }
"""


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "nstiff"])
def test_a_rod_on_a_torsion_spring_starts_at_its_equilibrium_and_stays(method):
    """theta about y (the rod's x turned towards -z): m g l cos theta = k
    theta with l = 0.5 m from the axis to the centre of mass."""
    theta = brentq(lambda x: 9.81 * 0.5 * np.cos(x) - 10.0 * x, 0.0, 1.0)
    sol = mbdsl.simulate(mbdsl.load_text(ROD.replace("{method}", method)))
    x_axis = np.array([sol.column(f"rod.A{i}1") for i in (1, 2, 3)])
    assert np.arctan2(-x_axis[2, 0], x_axis[0, 0]) == pytest.approx(theta, abs=1e-10)
    assert np.max(np.abs([sol.column(f"rod.w{c}") for c in "xyz"])) < 1e-8
    assert np.max(np.abs(x_axis - x_axis[:, :1])) < 1e-9


def test_a_body_hung_from_a_spring_keeps_its_given_orientation():
    """The centre of mass at z = 1 - (0.5 + m g / k); the orientation the
    initial line gives, held (three rows); at rest for 1 s."""
    from mbdsl.model.spatial import zyx
    sol = mbdsl.simulate(mbdsl.load_text(HUNG))
    assert sol.column("box.z")[0] == pytest.approx(1.0 - (0.5 + 2 * 9.81 / 400), abs=1e-10)
    assert abs(sol.column("box.x")[0]) < 1e-12 and abs(sol.column("box.y")[0]) < 1e-12
    A0 = np.array([[sol.column(f"box.A{i}{j}")[0] for j in (1, 2, 3)] for i in (1, 2, 3)])
    np.testing.assert_allclose(A0, zyx(0.3, 0.2, -0.1), atol=1e-12)
    assert np.max(np.abs(sol.column("box.vz"))) < 1e-9


def test_a_free_turn_has_no_static_equilibrium():
    """Without its orientation given, nothing holds the body's turn about
    its centre of mass: the equilibrium is not isolated, E507."""
    with pytest.raises(AssemblyError) as err:
        mbdsl.simulate(mbdsl.load_text(HUNG.replace(
            "initial box.orientation", "guess box.orientation")))
    assert err.value.diagnostics[0].code == "E507"


def test_bricards_static_equilibrium_with_its_redundant_row():
    """Bricard's linkage (one row redundant, 1 DOF by rank) under gravity: the
    static solve runs on the independent rows, and the equilibrium is one:
    the loop closed, and gravity does no work along the one motion the
    constraints allow (the null space of Phi_q, from scipy here)."""
    import dataclasses

    from scipy.linalg import null_space

    from mbdsl.assembly.initial import consistent_initial_state
    from mbdsl.assembly.system import assemble
    from ..conftest import MODELS
    model = dataclasses.replace(mbdsl.load(MODELS / "bricard.mbd"), static=True)
    system = assemble(model)
    init = consistent_initial_state(system, 0.0, redundant="accept")
    assert len(init.structure.dependent) == 1
    q = init.q
    assert np.max(np.abs(system.Phi(q, 0.0))) < 1e-12
    N = null_space(system.Phi_q(q, 0.0), rcond=1e-9)
    assert N.shape[1] == 1
    Q = system.Q(0.0, q, np.zeros(system.n))
    assert abs(float(N[:, 0] @ Q)) < 1e-10 * np.max(np.abs(Q))
    # the start was not one: gravity worked along the motion there
    start = consistent_initial_state(assemble(mbdsl.load(MODELS / "bricard.mbd")), 0.0,
                                     redundant="accept").q
    N0 = null_space(system.Phi_q(start, 0.0), rcond=1e-9)
    assert abs(float(N0[:, 0] @ system.Q(0.0, start, np.zeros(system.n)))) > 1e-3


def test_mbdsl_static_prints_bricards_equilibrium(capsys):
    """``mbdsl static`` on Bricard: the redundant row named (W405), the
    equilibrium printed, its reactions said to be one set of many."""
    from mbdsl.cli.main import main
    from ..conftest import MODELS
    assert main(["static", str(MODELS / "bricard.mbd")]) == 0
    out = capsys.readouterr()
    assert "W405" in out.out + out.err and "static equilibrium of model bricard" in out.out
    assert "one set of reactions of many" in out.out
