"""Spatial models drawn in perspective (``mbdsl animate``): the camera's
projection against a pinhole written out by hand, rendered frames against the
bodies' projected positions, and the spatial ``shape`` lines."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

import mbdsl
from mbdsl.cli.main import main
from mbdsl.errors import MbdModelError
from mbdsl.graphics.plotting import animate_solution
from mbdsl.graphics.scene3d import Camera
from tests.conftest import MODELS


def test_the_camera_is_a_pinhole():
    """Eye at (0, -d, 0) looking at the origin, z up: (x, y, z) lands at
    f (x, z) / (y + d), and depth is y + d."""
    d, f = 4.0, 2.0
    cam = Camera(np.array([0.0, -d, 0.0]), np.zeros(3), np.array([0.0, 0.0, 1.0]), focal=f)
    p = np.array([[0.3, 0.5, -0.2], [-1.0, 2.0, 0.7]])
    expected = f * np.column_stack([p[:, 0], p[:, 2]]) / (p[:, 1:2] + d)
    np.testing.assert_allclose(cam.project(p), expected, rtol=1e-14)
    np.testing.assert_allclose(cam.depth(p), p[:, 1] + d, rtol=1e-14)


def test_a_rendered_frame_shows_each_body_at_its_projected_position(tmp_path):
    """The spatial double pendulum (no shapes: lines to its points): at the
    first frame each link's colour is at the pixel its centre of mass
    projects to, and halfway along the line to its lower point; at t = 1 s
    link2 has moved away from where it was."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "spatial_double_pendulum.mbd"), t_end=1.0)
    res = animate_solution(sol, tmp_path / "pendulum.gif", fps=10)
    assert res.frames == 11

    def frame(k):
        with Image.open(tmp_path / "pendulum.gif") as im:
            im.seek(k)
            return np.asarray(im.convert("RGB"), dtype=float)

    def pixel(img, world):
        px, py = res.axes.transData.transform(res.camera.project(world))
        return img[int(round(img.shape[0] - py)), int(round(px))]

    first, later = frame(0), frame(10)
    for body in ("link1", "link2"):
        colour = np.array(res.colors[body]) * 255
        r = np.array([sol.column(f"{body}.{c}")[0] for c in "xyz"])
        A = np.array([sol.column(f"{body}.A{i}{j}")[0] for j in "123" for i in "123"])
        lower = r + A.reshape(3, 3).T @ np.array([0.0, 0.0, -0.25])    # a quarter way down
        assert np.max(np.abs(pixel(first, r) - colour)) < 40, body
        assert np.max(np.abs(pixel(first, lower) - colour)) < 40, body
    r2 = np.array([sol.column(f"link2.{c}")[0] for c in "xyz"])
    assert np.max(np.abs(pixel(later, r2) - np.array(res.colors["link2"]) * 255)) > 60


def test_shapes_of_a_spatial_body_and_the_command(tmp_path):
    """The slider crank's cylinders and box: the box's eight corners are its
    centre +- half its sides; ``mbdsl animate`` writes the frames."""
    model = mbdsl.load(MODELS / "spatial_slider_crank.mbd")
    box = next(s for s in model.body("slider").shapes if s.kind == "box")
    np.testing.assert_allclose(np.ptp(box.points, axis=0), [0.05, 0.03, 0.03])
    assert len(box.points) == 8 and np.allclose(box.points.mean(axis=0), 0.0)
    rod = model.body("rod").shapes[0]
    assert rod.kind == "cylinder" and rod.radius == 0.005
    np.testing.assert_allclose(rod.points, [[-0.15, 0, 0], [0.15, 0, 0]])
    out = tmp_path / "run.h5"
    assert main(["simulate", str(MODELS / "spatial_slider_crank.mbd"), "--t-end", "0.2", "-q",
                 "-o", str(out)]) == 0
    gif = tmp_path / "crank.gif"
    assert main(["animate", str(out), "-o", str(gif), "-q"]) == 0
    with Image.open(gif) as im:
        assert im.n_frames == 6


@pytest.mark.parametrize("line, code", [
    ("shape cone(cm, 0.1)", "E205"),
    ("shape sphere(cm)", "E305"),
    ("shape sphere(cm, -0.1)", "E303"),
    ("shape box(cm, (0.1, 0, 0.1))", "E303"),
    ("shape cylinder(cm, Q, 0.01)", "E201"),
])
def test_a_wrong_spatial_shape_is_an_error_at_its_line(line, code):
    text = ("model t\nspace 3d\n"
            f"body b {{ mass 1; inertia (1, 1, 1); point P (0, 0, 1)\n  {line} }}\n")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(text)
    d = err.value.diagnostics[0]
    assert d.code == code and d.span.line == 4, (d.code, d.message)


def test_the_browser_view_draws_a_spatial_model_in_3d(tmp_path):
    """``mbdsl view`` of the spatial slider-crank: a 3D scene whose frames
    put each body's centre-of-mass marker at the run's x, y, z at the
    frame's time (frames on the rows), the crank's cylinder as two end
    circles of its radius about its axis, and the page written."""
    from mbdsl.graphics.viewer import figure
    sol = mbdsl.simulate(mbdsl.load(MODELS / "spatial_slider_crank.mbd"), h=1e-3, t_end=0.1)
    fig, info = figure(sol, max_frames=101)
    assert info["frames"] == 101
    np.testing.assert_allclose(info["times"], sol.t, atol=1e-12)
    styles = {d["trace"]: (d["style"], d["color"]) for d in info["traces"]}
    assert {s for s, _ in styles.values()} >= {"wire", "cm", "joint"}
    assert all(fig.data[i].type == "scatter3d" for i in styles)
    colors = {b.name: c for b, c in zip(sol.model.bodies, ("#1f77b4", "#ff7f0e", "#2ca02c"))}
    cm = [i for i, (s, _) in styles.items() if s == "cm"]
    moving = [d["trace"] for d in info["traces"]] + info["cursors"]
    for k in (0, 37, 100):
        frame = fig.frames[k].data
        for i in cm:
            data = frame[moving.index(i)]
            color = styles[i][1]
            names = [n for n, c in colors.items() if c == color]
            for (x, y, z), name in zip(zip(data.x, data.y, data.z), names):
                want = [sol.column(f"{name}.{c}")[k] for c in "xyz"]
                np.testing.assert_allclose([x, y, z], want, atol=1e-12)
    # the crank's cylinder: its end circles lie at its radius about its axis
    crank = next(b for b in sol.model.bodies if b.name == "crank")
    (shape,) = [s for s in crank.shapes if s.kind == "cylinder"]
    from mbdsl.graphics.scene3d import SpatialScene
    scene = SpatialScene(sol.model)
    wires = scene.wires(sol.q[50])
    i = next(j for j, it in enumerate(scene.items) if it.body == "crank" and it.kind == "cylinder")
    ends = scene.world(sol.q[50], crank.index, shape.points)
    axis = (ends[1] - ends[0]) / np.linalg.norm(ends[1] - ends[0])
    for circle, end in zip(wires[i][:2], ends):
        d = circle - end
        np.testing.assert_allclose(d @ axis, 0.0, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(d, axis=1), shape.radius, rtol=1e-12)
    h5 = tmp_path / "crank.h5"
    assert main(["simulate", str(MODELS / "spatial_slider_crank.mbd"), "--t-end", "0.1", "-q",
                 "-o", str(h5)]) == 0
    assert main(["view", str(h5), "-o", str(tmp_path / "crank.html")]) == 0
    text = (tmp_path / "crank.html").read_text()
    assert "scatter3d" in text and "window.mbdslViewer" in text
