"""Starting in static equilibrium (``initial static``, ``mbdsl static``).

Oracles: the moment balance of the swing arm about its pin, solved as a
scalar equation by bisection (scipy's brentq); a run started there that
does not move; a pendulum held by an ``initial`` line.
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import mbdsl
from mbdsl.cli.main import main

from ..conftest import MODELS

SUSPENSION = MODELS / "suspension.mbd"


def moment_about_pin(phi, L=0.4, m=30.0, k=8000.0, l0=0.45, S=(0.3, 0.35), g=9.81):
    """Gravity plus spring moment about O on the arm at angle phi [N m]."""
    tx, ty = L * math.cos(phi), L * math.sin(phi)
    dx, dy = S[0] - tx, S[1] - ty
    length = math.hypot(dx, dy)
    fx, fy = k * (length - l0) * dx / length, k * (length - l0) * dy / length
    return -m * g * 0.5 * L * math.cos(phi) + (tx * fy - ty * fx)


def test_equilibrium_is_the_moment_balance():
    system = mbdsl.assemble(mbdsl.load(SUSPENSION))
    init = mbdsl.consistent_initial_state(system)
    phi = brentq(moment_about_pin, -1.0, 0.5, xtol=1e-15)
    assert init.q[2] == pytest.approx(phi, abs=1e-12)
    assert np.max(np.abs(init.v)) == 0.0 and np.max(np.abs(init.a)) < 1e-10


@pytest.mark.parametrize("method", ["hht-i3", "nstiff-si2"])
def test_preloaded_suspension_started_static_stays_at_rest(method):
    """No damping: any error in the equilibrium would show as an oscillation."""
    sol = mbdsl.simulate(mbdsl.load(SUSPENSION), method=method, h=1e-3, t_end=1.0)
    assert sol.completed
    assert np.max(np.abs(sol.q - sol.q[0])) < 1e-9
    # the same model without 'initial static' starts at phi = 0 and swings
    text = SUSPENSION.read_text().replace("initial static\n", "")
    swinging = mbdsl.simulate(mbdsl.load_text(text), method=method, h=1e-3, t_end=1.0)
    assert np.max(np.abs(swinging.q - swinging.q[0])) > 1e-2


def test_initial_lines_hold_their_coordinates():
    """A pendulum held at 30 degrees from the vertical: the held angle is kept,
    the free coordinates (the centre of mass) follow from the joint."""
    text = (MODELS / "pendulum.mbd").read_text() + "initial static\n"
    system = mbdsl.assemble(mbdsl.load_text(text))
    init = mbdsl.consistent_initial_state(system)
    assert init.q[2] == pytest.approx(-math.pi / 2 + math.pi / 6, abs=1e-15)
    assert init.q[0] == pytest.approx(0.5 * math.cos(init.q[2]), abs=1e-12)


def test_no_equilibrium_is_reported():
    model = mbdsl.load_text("model falling\ngravity (0, -9.81)\nbody b { mass 1; inertia 1 }\n"
                            "initial static\n", "falling.mbd")
    with pytest.raises(mbdsl.AssemblyError) as info:
        mbdsl.consistent_initial_state(mbdsl.assemble(model))
    d = info.value.diagnostics[0]
    assert d.code == "E507" and d.span is not None and d.span.line == 4


def test_static_command_prints_the_equilibrium(capsys):
    assert main(["static", str(SUSPENSION)]) == 0
    out = capsys.readouterr().out
    phi = brentq(moment_about_pin, -1.0, 0.5, xtol=1e-15)
    line = next(x for x in out.splitlines() if x.strip().startswith("arm.phi"))
    assert float(line.split()[1]) == pytest.approx(phi, abs=1e-8)
    assert "reaction.O.fy" in out
