"""docs/library.md: every part of mbdsl's library has an example, and each
example's result matches the closed form or the flat model its text quotes."""

import re
from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.dsl.parser import parse_file

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "library.md").read_text()
EXAMPLES = {re.search(r"^model (\w+)", text, re.M).group(1): text
            for text in re.findall(r"```mbd\n(.*?)```", DOC, re.S)}
G = 9.81


def _run(name, tmp_path, **kw):
    path = tmp_path / f"{name}.mbd"
    path.write_text(EXAMPLES[name])
    model = mbdsl.load(path)
    return model, mbdsl.simulate(model, **kw)


def test_every_part_of_the_library_has_an_example():
    lib = parse_file(ROOT / "mbdsl" / "library" / "parts.mbd")
    used = set(re.findall(r"parts\.(\w+)", " ".join(EXAMPLES.values())))
    assert {c.name for c in lib.components} == used
    for comp in lib.components:
        assert f"### {comp.name}" in DOC and f"| `{comp.name}` |" in DOC


def test_link_pendulum_reaches_the_bottom_at_sqrt_3g_over_L(tmp_path):
    _, s = _run("link_pendulum", tmp_path)
    w = np.abs(s.column("arm.b.omega")).max()
    assert w == pytest.approx(np.sqrt(3 * G / 0.5), rel=1e-4)


def test_block_slides_down_the_incline_as_g_sin30_t2_over_2(tmp_path):
    _, s = _run("block_incline", tmp_path)
    x, y = s.column("blk.b.x")[-1], s.column("blk.b.y")[-1]
    assert np.hypot(x, y) == pytest.approx(G * 0.5 * 0.5 ** 2 / 2, rel=1e-6)
    assert y < 0 < x


def test_wheel_pinned_at_its_rim_reaches_sqrt_4g_over_3r(tmp_path):
    _, s = _run("wheel_pendulum", tmp_path)
    w = np.abs(s.column("w.b.omega")).max()
    assert w == pytest.approx(np.sqrt(4 * G / (3 * 0.1)), rel=1e-4)


def test_strut_hangs_at_its_static_deflection(tmp_path):
    _, s = _run("strut_load", tmp_path)
    length = s.column("output.s.length")
    assert length[0] == pytest.approx(0.3 + (5 + 0.1) * G / 1000, abs=1e-9)
    assert np.ptp(length) < 1e-9          # started at rest in equilibrium, it stays
    # the output is the mounts' distance
    def point(body, u):
        x, y, phi = (s.column(f"s.{body}.{c}")[0] for c in ("x", "y", "phi"))
        return np.array([x + np.cos(phi) * u, y + np.sin(phi) * u])
    a, b = point("cyl", -0.3 / 4), point("piston", 0.3 / 4)
    assert np.hypot(*(b - a)) == pytest.approx(length[0], abs=1e-12)
    assert b[1] < a[1]                    # hanging below its mount


def test_motor_spins_up_as_its_torque_speed_line_says(tmp_path):
    _, s = _run("motor_spinup", tmp_path)
    t, w = s.t, s.column("mot.rotor.omega")
    exact = 10 * (1 - np.exp(-5 * t / (0.01 * 10)))
    assert np.abs(w - exact).max() < 1e-5
    power = s.column("output.mot.power")
    assert power[-1] == pytest.approx(5 * (1 - w[-1] / 10) * w[-1], rel=1e-12)


def test_fourbar_part_follows_the_flat_motor_fourbar(tmp_path):
    _, s = _run("fourbar_motor", tmp_path)
    flat = mbdsl.simulate(mbdsl.load(ROOT / "models" / "motor_fourbar.mbd"), t_end=1.0)
    for a, b in (("fb.crank.b.phi", "crank.phi"), ("fb.rocker.b.phi", "rocker.phi"),
                 ("fb.coupler.b.omega", "coupler.omega")):
        assert np.abs(s.column(a) - flat.column(b)).max() < 1e-9, a


def test_slider_crank_part_keeps_its_geometry_and_its_energy(tmp_path):
    _, s = _run("slider_crank_part", tmp_path)
    phi = s.column("sc.crank.b.phi")
    x = 0.1 + 0.3 * np.cos(phi) + np.sqrt(0.6 ** 2 - (0.3 * np.sin(phi)) ** 2)
    assert np.abs(s.column("sc.slider.b.x") - x).max() < 1e-9
    assert np.abs(s.column("sc.slider.b.y") - 0.2).max() < 1e-12
    e = s.column("energy.total")
    assert np.ptp(phi) > 1.0                     # it moves
    assert np.abs(e - e[0]).max() < 1e-4 * np.ptp(s.column("energy.kinetic"))
