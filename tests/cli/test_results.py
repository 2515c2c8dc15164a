"""Results people can look at: plots, animation, HDF5/CSV round trips, progress bar."""

import io

import numpy as np
import pytest
from PIL import Image

import mbdsl
from mbdsl.cli.main import main
from mbdsl.graphics.plotting import PANELS, animate_solution, plot_solution
from mbdsl.graphics.scene import body_outline
from mbdsl.progress import ProgressBar

from ..conftest import MODELS


@pytest.fixture(scope="module")
def crank_run():
    """Slider crank, HHT-SI2 (so the file also holds mu), 0.5 s."""
    return mbdsl.simulate(mbdsl.load(MODELS / "slider_crank.mbd"), method="hht-si2", t_end=0.5)


# -- plots ---------------------------------------------------------------------------------

def test_simulate_plot_writes_the_standard_panels_beside_the_output(tmp_path):
    out = tmp_path / "run.csv"
    assert main(["simulate", str(MODELS / "slider_crank.mbd"), "--t-end", "0.3", "-q",
                 "-o", str(out), "--plot"]) == 0
    png = tmp_path / "run.png"
    with Image.open(png) as im:
        assert im.format == "PNG" and im.size[0] > 500 and im.size[1] > 500
    # the same figure from the file: every named panel, with its labels
    fig = plot_solution(mbdsl.load_solution(out))
    axes = fig.axes
    assert [ax.get_title() for ax in axes] == list(PANELS)
    labels = {ax.get_title(): ax.get_ylabel() for ax in axes}
    assert labels["position"] == "position [m]" and labels["angle"] == "angle [rad]"
    assert labels["energy"] == "energy [J]" and labels["step size"] == "h [s]"
    assert axes[PANELS.index("constraint violation")].get_yscale() == "log"
    assert all(ax.get_xlabel() == "t [s]" for ax in axes[-2:])
    energy = axes[PANELS.index("energy")]
    assert [ln.get_label() for ln in energy.get_lines()] == [
        "energy.kinetic", "energy.potential", "energy.total"]
    # the plotted total energy is the solution's, not a recomputation that could differ
    sol = mbdsl.load_solution(out)
    np.testing.assert_array_equal(energy.get_lines()[2].get_ydata(), sol.column("energy.total"))


def test_plot_chosen_columns_and_a_phase_plot(tmp_path, crank_run):
    path = tmp_path / "run.h5"
    mbdsl.write_solution(crank_run, path)
    fig_path = tmp_path / "phase.svg"
    assert main(["plot", str(path), "--x", "crank.phi", "--y", "crank.omega,rod.omega",
                 "-o", str(fig_path)]) == 0
    assert fig_path.read_text().lstrip().startswith("<?xml")
    fig = plot_solution(crank_run, y=["crank.omega", "rod.omega"], x="crank.phi")
    assert [ax.get_ylabel() for ax in fig.axes] == ["crank.omega [rad/s]", "rod.omega [rad/s]"]
    assert fig.axes[-1].get_xlabel() == "crank.phi [rad]"
    line = fig.axes[0].get_lines()[0]
    np.testing.assert_array_equal(line.get_xdata(), crank_run.column("crank.phi"))


def test_plot_unknown_column_is_a_message(tmp_path, crank_run, capsys):
    path = tmp_path / "run.csv"
    mbdsl.write_solution(crank_run, path)
    assert main(["plot", str(path), "--y", "crank.omegaa"]) == 1
    err = capsys.readouterr().err
    assert "no column 'crank.omegaa'" in err and "crank.omega" in err and "Traceback" not in err


# -- animation -----------------------------------------------------------------------------

def test_animate_writes_every_frame_with_the_crank_pointing_down(tmp_path):
    gif = tmp_path / "sc.gif"
    assert main(["animate", str(MODELS / "slider_crank.mbd"), "-o", str(gif),
                 "--t-end", "1", "-q"]) == 0
    with Image.open(gif) as im:
        assert im.n_frames == 26                  # 1 s at 25 frames per second, both ends
    # the same drawing through the API, for the data -> pixel map of the axes
    sol = mbdsl.simulate(mbdsl.load(MODELS / "slider_crank.mbd"), t_end=1.0)
    res = animate_solution(sol, tmp_path / "api.gif")
    assert res.frames == 26 and res.times[-1] == pytest.approx(1.0)
    crank = np.array(res.colors["crank"]) * 255
    with Image.open(tmp_path / "api.gif") as im:
        im.seek(0)
        rgb = np.asarray(im.convert("RGB"), dtype=float)
    height = rgb.shape[0]

    def colour_at(x, y):
        px, py = res.axes.transData.transform((x, y))
        return rgb[int(round(height - py)), int(round(px))]

    # crank O at the origin, A at (0, -0.3): crank-coloured below the pivot, not above
    for y in (-0.08, -0.15, -0.22):
        assert np.max(np.abs(colour_at(0.0, y) - crank)) < 40
        assert np.max(np.abs(colour_at(0.0, -y) - crank)) > 100
    # a later frame has moved: the crank swings toward the spring
    with Image.open(tmp_path / "api.gif") as im:
        im.seek(12)
        later = np.asarray(im.convert("RGB"), dtype=float)
    px, py = res.axes.transData.transform((0.0, -0.22))
    assert np.max(np.abs(later[int(round(height - py)), int(round(px))] - crank)) > 100


def test_animation_from_a_result_file_and_bad_extensions(tmp_path, crank_run, capsys):
    path = tmp_path / "run.h5"
    mbdsl.write_solution(crank_run, path)
    gif = tmp_path / "fast.gif"
    assert main(["animate", str(path), "-o", str(gif), "--fps", "10", "--speed", "2", "-q"]) == 0
    with Image.open(gif) as im:
        assert im.n_frames == 3                   # 0.5 s at 2x, 10 fps: t = 0, 0.2, 0.4
    assert main(["animate", str(path), "-o", str(tmp_path / "x.avi"), "-q"]) == 1
    assert "use .gif or .mp4" in capsys.readouterr().err


def test_mp4_without_ffmpeg_says_so(tmp_path, crank_run):
    from matplotlib import animation
    if animation.writers.is_available("ffmpeg"):
        pytest.skip("ffmpeg is installed here")
    with pytest.raises(ValueError, match="needs ffmpeg"):
        animate_solution(crank_run, tmp_path / "x.mp4")


@pytest.mark.parametrize("points,kind,n", [
    ([], "dot", 1), ([(0.2, 0.0)], "segment", 2), ([(-1, 0), (1, 0)], "segment", 2),
    ([(-1, 0), (0, 0), (2, 0)], "segment", 2),
    ([(0, 0), (1, 0), (1, 1), (0, 1), (0.5, 0.5)], "polygon", 4)])
def test_body_outline(points, kind, n):
    k, verts = body_outline(np.array(points, float).reshape(-1, 2))
    assert k == kind and len(verts) == n


# -- files: HDF5 and CSV round trips ---------------------------------------------------------

def _same(a, b, rtol):
    names_a, values_a = a.table()
    names_b, values_b = b.table()
    assert names_a == names_b
    if rtol == 0:
        np.testing.assert_array_equal(values_a, values_b)
    else:
        np.testing.assert_allclose(values_a, values_b, rtol=rtol, atol=0)
    for k in a.STAT_NAMES:
        np.testing.assert_array_equal(a.stats[k], b.stats[k])
    assert a.stats_total == b.stats_total
    assert (a.method_name, a.method_parameters, a.h, a.t_end, a.status) == \
        (b.method_name, b.method_parameters, b.h, b.t_end, b.status)


def test_hdf5_round_trip_is_bit_for_bit(tmp_path, crank_run):
    import h5py
    path = tmp_path / "run.h5"
    assert main(["simulate", str(MODELS / "slider_crank.mbd"), "--method", "hht-si2",
                 "--t-end", "0.5", "-q", "-o", str(path)]) == 0
    with h5py.File(path) as f:
        assert {"t", "q", "v", "a", "lambda", "extras", "energies", "constraints",
                "reactions", "newton", "model_source"} <= set(f)
        assert list(f["q"].attrs["columns"][:3]) == ["crank.x", "crank.y", "crank.phi"]
        assert f.attrs["method"] == "hht-si2" and float(f.attrs["method.alpha"]) == -0.05
        assert f["model_source"][()].decode() == (MODELS / "slider_crank.mbd").read_text()
        assert len(f.attrs["model_sha256"]) == 64 and f.attrs["mbdsl_version"] == mbdsl.__version__
    # in memory -> file -> memory: every array equal bit for bit
    path2 = tmp_path / "api.h5"
    mbdsl.write_solution(crank_run, path2)
    back = mbdsl.load_solution(path2)
    _same(crank_run, back, rtol=0)
    for x in ("t", "q", "v", "a", "lam"):
        assert np.array_equal(getattr(crank_run, x), getattr(back, x))
    assert np.array_equal(crank_run.extras["mu"], back.extras["mu"])


def test_csv_round_trip(tmp_path, crank_run):
    path = tmp_path / "run.csv"
    mbdsl.write_solution(crank_run, path)
    back = mbdsl.load_solution(path)
    _same(crank_run, back, rtol=1e-15)
    np.testing.assert_allclose(back.a, crank_run.a, rtol=1e-15, atol=0)
    np.testing.assert_allclose(back.extras["mu"], crank_run.extras["mu"], rtol=1e-15, atol=0)


def test_loaded_model_is_rebuilt_with_the_run_parameters(tmp_path):
    model = mbdsl.load(MODELS / "pendulum_chain.mbd", overrides={"N": 3})
    sol = mbdsl.simulate(model, t_end=0.01)
    path = tmp_path / "chain.h5"
    mbdsl.write_solution(sol, path)
    back = mbdsl.load_solution(path)
    assert len(back.model.bodies) == 3 and back.model.parameters["N"] == 3
    np.testing.assert_array_equal(back.column("link[3].omega"), sol.column("link[3].omega"))


def test_not_a_result_file(tmp_path, capsys):
    bad = tmp_path / "x.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="not a result file|no model source"):
        mbdsl.load_solution(bad)
    assert main(["plot", str(bad)]) == 1
    assert "cannot read" in capsys.readouterr().err


def test_to_dataframe(crank_run):
    pd = pytest.importorskip("pandas")
    df = crank_run.to_dataframe()
    assert isinstance(df, pd.DataFrame) and df.index.name == "t"
    np.testing.assert_array_equal(df["crank.omega"].to_numpy(), crank_run.column("crank.omega"))
    assert len(df) == len(crank_run.t) and len(df.columns) == len(crank_run.columns) - 1
    assert df.attrs["units"]["crank.omega"] == "rad/s" and df.attrs["units"]["energy.total"] == "J"
    assert df.attrs["method"] == crank_run.method_name and df.attrs["rows"] == "steps"


@pytest.mark.parametrize("suffix", [".csv", ".h5"])
def test_tables_of_a_run_read_back(tmp_path, suffix):
    """A bouncing ball with rows every 10 ms written and read back: the
    numbers, units, events and totals survive in the Solution, its DataFrame
    and its xarray Dataset (bodies stacked on a dimension: a particle has no
    angle, so the ball stays in columns; the slider crank's two bodies stack)."""
    xr = pytest.importorskip("xarray")
    pytest.importorskip("pandas")
    import json
    sol = mbdsl.simulate(mbdsl.load(MODELS / "bouncing_ball.mbd"), output_dt=1e-2)
    path = tmp_path / f"ball{suffix}"
    mbdsl.write_solution(sol, path)
    back = mbdsl.load_solution(path)
    assert back.dense and back.events == sol.events and back.stats_total == sol.stats_total
    np.testing.assert_array_equal(back.column("ball.y"), sol.column("ball.y"))
    np.testing.assert_allclose(back.column("energy.balance"), sol.column("energy.balance"),
                               rtol=1e-12, atol=1e-15)
    ds = back.to_xarray()
    assert isinstance(ds, xr.Dataset) and "body" not in ds.dims
    np.testing.assert_array_equal(ds["ball.y"].values, sol.column("ball.y"))
    np.testing.assert_array_equal(ds["t"].values, sol.t)
    assert ds["ball.vy"].attrs["units"] == "m/s" and ds["energy.total"].attrs["units"] == "J"
    assert json.loads(ds.attrs["events"]) == [list(e) for e in sol.events]
    df = back.to_dataframe()
    assert df.attrs["units"] == sol.column_units() and df.attrs["rows"] == "at requested times"
    crank = mbdsl.simulate(mbdsl.load(MODELS / "slider_crank.mbd"), t_end=0.05)
    ds = crank.to_xarray()
    assert list(ds["body"].values) == ["crank", "rod"] and ds["omega"].dims == ("t", "body")
    np.testing.assert_array_equal(ds["omega"].sel(body="rod").values, crank.column("rod.omega"))
    assert ds["phi"].attrs["units"] == "rad"


# -- progress ------------------------------------------------------------------------------

def test_progress_bar_shows_time_step_and_iterations():
    buf = io.StringIO()
    model = mbdsl.load(MODELS / "slider_crank.mbd")
    with ProgressBar(0.0, 0.2, enabled=True, delay=0.0, refresh=0.0, file=buf) as bar:
        mbdsl.simulate(model, t_end=0.2, progress=bar)
    text = buf.getvalue()
    assert "simulated" in text and "h 1.00e-03 s" in text and "it/step" in text
    assert "0.2/0.2 s" in text


def test_progress_bar_is_off_when_not_a_terminal():
    buf = io.StringIO()                     # isatty() is False
    with ProgressBar(0.0, 1.0, delay=0.0, file=buf) as bar:
        bar(0.5, 1e-3, 4)
    assert buf.getvalue() == ""


def test_standard_plot_step_size_bodies_and_log_ticks():
    # the step-size panel: one stair per step over (t_{i-1}, t_i], no drop at t_end,
    # distinct labels (the halvings); the bodies shown can be chosen and the panel
    # titles say how many are shown
    from matplotlib.figure import Figure

    from mbdsl.graphics.plotting import _readable_log_ticks, plot_solution
    model = mbdsl.load(MODELS / "pendulum_chain.mbd", overrides={"N": 6})
    sol = mbdsl.simulate(model, method="hht-i3", h=1e-3, t_end=0.05)
    fig = plot_solution(sol)
    ax = next(a for a in fig.axes if a.get_ylabel() == "h [s]")
    stairs = ax.patches[0]
    values, edges = stairs.get_data()[:2]
    assert np.allclose(values, 1e-3) and edges[0] == 0.0 and edges[-1] == pytest.approx(0.05)
    labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
    assert labels and len(labels) == len(set(labels))
    titles = [a.get_title() for a in fig.axes]
    assert "position (first 4 of 6 bodies; choose with --bodies)" in titles
    fig = plot_solution(sol, bodies=["link[5]", "link[6]"])
    angle = next(a for a in fig.axes if a.get_title().startswith("angle"))
    assert angle.get_title() == "angle (2 of 6 bodies)"
    assert [line.get_label() for line in angle.get_lines()] == ["link[5].phi", "link[6].phi"]
    with pytest.raises(KeyError, match="did you mean link"):
        plot_solution(sol, bodies=["lnk"])
    # log axes of study figures: within less than a decade matplotlib labels every
    # minor tick (2e-2, 3e-2, ..., 9e-2: overlapping); only 2 and 5 times 10^k remain
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    fig = Figure()
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.loglog([0.012, 0.09], [1e-8, 1e-3])
    _readable_log_ticks(ax)
    fig.canvas.draw()
    minor = [t.get_text() for t in ax.xaxis.get_minorticklabels() if t.get_text()]
    assert 1 <= len(minor) <= 3 and len(set(minor)) == len(minor), minor
    assert all(not t.get_text() for t in ax.yaxis.get_minorticklabels())   # 5 decades


SHAPED = """model shaped   # a pendulum drawn with shapes: a rod and a disc at its tip
gravity (0, -9.81)
body p { mass 1; inertia 0.02; point O (-0.4, 0); point T (0.4, 0)
         shape line(O, T); shape circle(T, 0.12); shape polygon(O, (-0.3, 0.1), (-0.3, -0.1)) }
joint O: revolute(ground.origin, p.O)
initial p.phi = -pi/2
initial p.omega = 0
"""


def test_shapes_are_drawn_where_the_body_is(tmp_path):
    """Hanging straight down at t = 0: the disc (radius 0.12 m) is centred at
    (0, -0.8); a point of the disc off the rod is body-coloured, the same
    offset on the other side of the pivot is not (the points' outline would
    have drawn only the rod)."""
    sol = mbdsl.simulate(mbdsl.load_text(SHAPED), t_end=0.04, h=1e-3)
    assert [s.kind for s in sol.model.bodies[0].shapes] == ["line", "circle", "polygon"]
    res = animate_solution(sol, tmp_path / "s.gif")
    col = np.array(res.colors["p"]) * 255
    with Image.open(tmp_path / "s.gif") as im:
        rgb = np.asarray(im.convert("RGB"), dtype=float)
    height = rgb.shape[0]

    def colour_at(x, y):
        px, py = res.axes.transData.transform((x, y))
        return rgb[int(round(height - py)), int(round(px))]
    inside = colour_at(0.08, -0.8)                  # in the disc, 8 cm right of the rod
    outside = colour_at(0.08, -0.6)                 # 8 cm right of the rod, above the disc
    assert np.max(np.abs(inside - outside)) > 30
    white = np.array([255.0, 255.0, 255.0])
    assert np.max(np.abs(outside - white)) < 10    # background there
    assert np.max(np.abs(inside - white)) > 30     # the disc's fill (body colour, 35 %)


@pytest.mark.parametrize("line,code", [
    ("shape line(O)", "E305"), ("shape circle(T, -1)", "E303"), ("shape circle(T)", "E305"),
    ("shape star(O, T)", "E205"), ("shape line(O, X)", "E201"), ("shape polygon(O, T)", "E305"),
    ("shape line(O, T, width = 2)", "E304")])
def test_shape_misuse_is_reported(line, code):
    from mbdsl.errors import MbdModelError
    text = SHAPED.replace("shape line(O, T); shape circle(T, 0.12); "
                          "shape polygon(O, (-0.3, 0.1), (-0.3, -0.1))", line)
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(text)
    assert code in [d.code for d in err.value.diagnostics]


def test_beams_are_drawn_deformed_by_the_deform_scale(tmp_path):
    """beam_world: r + A(phi) ((x, 0) + s S(x) q_f); at a node S q_f is that
    node's (u, v)."""
    from mbdsl.graphics.scene import beam_world
    model = mbdsl.load(MODELS / "flexible_slider_crank.mbd")
    beam = next(b for b in model.bodies if isinstance(b, mbdsl.model.elements.FlexibleBeam))
    q = np.zeros(model.n_coordinates)
    cmap = model.coordinate_map
    q[cmap(beam.index)[0]] = (0.1, 0.2, 0.5)
    names = beam.mesh.names
    end = beam.elements // 2                        # a middle node (a chord frame pins v at the end)
    arc = end * beam.length / beam.elements
    cols = beam.elastic_columns()
    q[cols[names.index(f"u{end}")]] = 0.003
    q[cols[names.index(f"v{end}")]] = 0.01
    c, s = np.cos(0.5), np.sin(0.5)
    for scale in (1.0, 50.0):
        local = np.array([arc + scale * 0.003, scale * 0.01])
        expect = np.array([0.1, 0.2]) + np.array([c * local[0] - s * local[1],
                                                  s * local[0] + c * local[1]])
        np.testing.assert_allclose(beam_world(q, beam, [arc], scale, cmap=cmap)[0], expect,
                                   atol=1e-14)
    np.testing.assert_allclose(beam_world(q, beam, [0.0], 50.0, cmap=cmap)[0], (0.1, 0.2),
                               atol=1e-14)
    sol = mbdsl.simulate(model, t_end=0.01)
    gif = tmp_path / "beam.gif"
    assert main(["animate", str(MODELS / "flexible_slider_crank.mbd"), "-o", str(gif),
                 "--t-end", "0.08", "--deform-scale", "100", "-q"]) == 0
    with Image.open(gif) as im:
        assert im.n_frames == 3
    with pytest.raises(ValueError, match="deformation scale"):
        animate_solution(sol, tmp_path / "x.gif", deform_scale=-1)


def test_amending_the_last_row_changes_it_alone():
    """Solution.amend_last (a compiled segment ending on a switch, the
    restart past it): the last row's t, a, lambda and mu, nothing else."""
    from mbdsl.io.solution import Solution
    model = mbdsl.load(MODELS / "slider_crank.mbd")
    sol = mbdsl.simulate(model, method="hht-si2", h=1e-3, t_end=0.01)
    before = sol.rows(0, sol.n_rows)
    a, lam, mu = (np.arange(before[k].shape[1], dtype=float) for k in ("a", "lam", "mu"))
    sol.amend_last(t=0.0105, a=a, lam=lam, extras={"mu": mu, "not stored": lam})
    after = sol.rows(0, sol.n_rows)
    assert after["t"][-1] == 0.0105
    assert np.array_equal(after["t"][:-1], before["t"][:-1])
    assert np.array_equal(after["q"], before["q"]) and np.array_equal(after["v"], before["v"])
    for key, value in (("a", a), ("lam", lam), ("mu", mu)):
        assert np.array_equal(after[key][-1], value)
        assert np.array_equal(after[key][:-1], before[key][:-1])
    with pytest.raises(IndexError, match="no row"):
        method = mbdsl.integrators.make_method("hht-si2")
        Solution(sol.system, method, sol.h, sol.t_end, None).amend_last(t=0.0)


# -- long runs: rows streamed to HDF5 leave memory -----------------------------------------

def test_extents_merged_chunk_by_chunk_equal_the_whole_columns():
    """The summary and the energy guard of a streamed run read Extents merged
    over its chunks: equal to the Extent of the whole column, NaN included
    (the first NaN is the largest, as numpy.argmax finds it), ties at the first."""
    from mbdsl.io.rows import Extent
    rng = np.random.default_rng(3)
    for trial in range(50):
        x = rng.normal(size=rng.integers(1, 60))
        if trial % 5 == 1:
            x[rng.integers(len(x), size=2)] = np.nan
        if trial % 5 == 2:
            x[:] = np.round(x)            # ties of |x|
        cuts = np.sort(rng.choice(np.arange(1, len(x)), size=min(len(x) - 1, 4), replace=False)) \
            if len(x) > 1 else []
        edges = [0, *cuts, len(x)]
        merged = None
        for i0, i1 in zip(edges[:-1], edges[1:]):
            part = Extent.of(x[i0:i1], i0)
            merged = part if merged is None else merged.merge(part)
        whole = Extent.of(x)
        assert merged.at == whole.at == int(np.argmax(np.abs(x)))
        np.testing.assert_array_equal(np.array(merged[:5]), np.array(whole[:5]))


class _Watching:
    """An HdfStream whose appends record how many rows the Solution holds."""

    def __init__(self, path):
        from mbdsl.io.hdf5 import HdfStream
        self.stream = HdfStream(path, interval=0.0)
        self.stream.PENDING_ROWS, self.stream.PART_ROWS = 50, 37   # many parts and chunks
        self.held = []

    def __getattr__(self, name):
        return getattr(self.stream, name)

    def on_rows(self, sol, start, stop):
        self.stream.on_rows(sol, start, stop)
        self.held.append((sol.n_rows, sol.n_rows - sol._rows.released))


@pytest.mark.parametrize("model, options", [
    ("double_pendulum.mbd", dict(h=1e-4, t_end=1.0)),
    ("bouncing_ball.mbd", dict(rtol=1e-6)),                              # events, error control
    ("bouncing_ball.mbd", dict(rtol=1e-6, output_dt=5e-4)),              # rows at requested times
    ("incline_friction.mbd", dict(method="nstiff-si2", h=2e-4)),         # the extras mu
    ("flexible_slider_crank.mbd", dict(method="hht-add", h=2e-5, t_end=0.1)),  # beams, psi1
])
def test_a_run_streamed_to_hdf5_lets_its_rows_go_and_reads_them_back(
        tmp_path, monkeypatch, model, options):
    """Written to HDF5 as it runs, a run holds a few blocks of rows at a time
    (the loop's block of CHUNK rows and the stream's pending rows), not the
    run; at the end its Solution reads the rows from the file: every column,
    the summary (timings aside) and the warnings equal those of the same run
    held in memory, bit for bit, and so does the file read back."""
    import re
    from mbdsl.integrators import loop
    monkeypatch.setattr(loop, "FLUSH_ROWS", 1)      # the writer at every return of the kernel
    m = mbdsl.load(MODELS / model)
    held = mbdsl.simulate(m, **options)
    watch = _Watching(tmp_path / "run.h5")
    streamed = mbdsl.simulate(m, observers=[watch], **options)
    assert streamed._file_rows is not None and streamed._rows.released == 0
    n = held.n_rows
    most = max(h for _, h in watch.held)
    assert streamed.n_rows == n and most <= 2 * loop.CHUNK + watch.stream.PENDING_ROWS < n
    for c in held.columns:
        np.testing.assert_array_equal(streamed.column(c), held.column(c), err_msg=c)
    def timeless(s):
        return re.sub(r"wall time.*|[0-9.]+ us/step", "", s)
    assert timeless(streamed.summary()) == timeless(held.summary())
    assert [w.message for w in streamed.warnings] == [w.message for w in held.warnings]
    back = mbdsl.load_solution(tmp_path / "run.h5")
    for c in ("t", *held.system.layout.coordinates, "energy.balance"):
        np.testing.assert_array_equal(back.column(c), held.column(c), err_msg=c)
    np.testing.assert_array_equal(streamed.q, held.q)      # whole arrays, read when asked
    assert back.events == held.events


@pytest.mark.slow
def test_a_million_steps_to_hdf5_stay_below_300_mb(tmp_path):
    """10^6 steps of the double pendulum (h = 1e-5 s, 10 s), every step a row
    of the HDF5 file (336 MB of rows): the whole command's peak resident
    memory stays below 300 MB (measured in the process itself, the compiled
    kernels loaded: about 240 MB of that before the first step)."""
    import subprocess
    import sys
    code = ("import sys; from mbdsl.cli.main import main; "
            "rc = main(sys.argv[1:]); "
            "print(' '.join(l.split()[0] + l.split()[1] for l in open('/proc/self/status') "
            "if l.startswith(('VmHWM', 'RssFile', 'RssAnon')))); sys.exit(rc)")
    out = tmp_path / "run.h5"
    proc = subprocess.run([sys.executable, "-c", code, "simulate",
                           str(MODELS / "double_pendulum.mbd"), "--h", "1e-5", "--t-end", "10",
                           "--engine", "compiled", "-o", str(out)],
                          capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stderr
    assert "wrote" in proc.stdout and "(1000001 rows" in proc.stdout
    status = dict(item.split(":") for item in proc.stdout.strip().splitlines()[-1].split())
    peak_mb, file_mb, anon_mb = (int(status[k]) / 1024 for k in ("VmHWM", "RssFile", "RssAnon"))
    assert peak_mb < 300, f"peak resident memory {peak_mb:.0f} MB (file {file_mb:.0f} MB, " \
        f"anonymous {anon_mb:.0f} MB at the end)"
    sol = mbdsl.load_solution(out)
    assert len(sol.t) == 1000001 and sol.t[-1] == pytest.approx(10.0)


# -- some columns only (--columns) ---------------------------------------------------------

def test_column_patterns_take_brackets_literally():
    """``link[3].*`` is link 3's columns (the brackets are part of the name,
    not a shell character class); ``?`` one character; "t" always first."""
    from mbdsl.io.metadata import select_columns
    names = ["t", "link[1].x", "link[3].x", "link[3].phi", "link[33].x", "energy.total"]
    assert select_columns(names, ["link[3].*"]) == ["t", "link[3].x", "link[3].phi"]
    assert select_columns(names, ["link[?].x", "energy.*"]) == \
        ["t", "link[1].x", "link[3].x", "energy.total"]
    with pytest.raises(ValueError, match="did you mean energy.total"):
        select_columns(names, ["energi.total"])


@pytest.mark.parametrize("suffix", [".csv", ".h5"])
def test_a_file_of_some_columns_holds_them_exactly(tmp_path, suffix):
    """``simulate --columns``: the file holds t and the matching columns,
    equal to the same run's full file bit for bit; read back, those columns
    are the result's and any other is a KeyError that says why; the units
    metadata lists those alone."""
    import json
    full, part = tmp_path / f"full{suffix}", tmp_path / f"part{suffix}"
    model = str(MODELS / "slider_crank.mbd")
    assert main(["simulate", model, "--t-end", "0.2", "-q", "-o", str(full)]) == 0
    assert main(["simulate", model, "--t-end", "0.2", "-q", "-o", str(part),
                 "--columns", "crank.*, lambda.O.*,energy.total,step.h"]) == 0
    a, b = mbdsl.load_solution(full), mbdsl.load_solution(part)
    chosen = {"lambda.O.0", "lambda.O.1", "energy.total", "step.h"}
    want = [c for c in a.columns if c == "t" or c.startswith("crank.") or c in chosen]
    assert len(want) == 1 + 9 + 4
    assert b.columns == want
    for c in want:
        np.testing.assert_array_equal(b.column(c), a.column(c), err_msg=c)
    with pytest.raises(KeyError, match="some columns only"):
        b.column("slider.x")
    if suffix == ".csv":
        from mbdsl.io.csvfile import read_csv_metadata
        meta, names, _ = read_csv_metadata(part)
        assert names == want
    else:
        import h5py
        with h5py.File(part, "r") as f:
            meta = dict(f.attrs)
            assert f["q"].shape == (201, 3) and f["reactions"].shape == (201, 0)
    assert json.loads(meta["columns"]) == want
    assert set(json.loads(meta["units"])) == set(want)
    # plotted: a panel per column it holds; not drawn: the mechanism needs every coordinate
    assert main(["plot", str(part), "-o", str(tmp_path / "part.png")]) == 0
    assert main(["animate", str(part), "-o", str(tmp_path / "part.gif")]) == 1


def test_a_column_pattern_that_matches_nothing_is_refused_before_the_run(tmp_path, capsys):
    """A misspelt pattern: exit 1 before any step, with the closest names, no
    file left behind; the same for the table on standard output."""
    out = tmp_path / "run.h5"
    model = str(MODELS / "slider_crank.mbd")
    assert main(["simulate", model, "-q", "-o", str(out), "--columns", "crank.phi,rodd.*"]) == 1
    err = capsys.readouterr().err
    assert "'rodd.*' matches no column" in err and "did you mean" in err
    assert not out.exists()
    assert main(["simulate", model, "-q", "-o", "-", "--columns", "crnk.phi"]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and "did you mean crank.phi" in captured.err
    assert main(["simulate", model, "--t-end", "0.01", "-q", "-o", "-",
                 "--columns", "crank.phi"]) == 0
    rows = [r for r in capsys.readouterr().out.splitlines() if not r.startswith("#")]
    assert rows[0] == "t,crank.phi" and len(rows) == 12
