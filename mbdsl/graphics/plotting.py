"""Figures and animations of a Solution (matplotlib): the only module that imports it.

Figures are built on :class:`matplotlib.figure.Figure` with the Agg canvas,
never pyplot, so plotting works headless, in threads and in workers, and
leaves no global figure state behind. The file format follows the extension
(PNG, SVG, PDF; GIF through Pillow, MP4 through ffmpeg).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


__all__ = ["plot_solution", "animate_solution", "PANELS", "AnimationResult",
           "Series", "Panel", "write_figure"]

#: Titles of the standard panels of :func:`plot_solution`, in order.
PANELS = ("position", "angle", "velocity", "angular velocity", "energy",
          "constraint violation", "Newton iterations per step", "step size")

#: Bodies drawn in the standard panels (the first ones; a chain of 1000 would be unreadable).
MAX_BODIES = 4


def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _lines(ax, t, sol, names):
    """One line a column on ``ax``; a note in an empty panel (an angle panel
    of a model whose bodies are all particles)."""
    if not names:
        ax.text(0.5, 0.5, "none: particles do not turn", transform=ax.transAxes,
                ha="center", va="center", fontsize=8, color="0.4")
    for name in names:
        ax.plot(t, sol.column(name), label=name, lw=1.2)
    if 0 < len(names) <= 8:
        ax.legend(fontsize=7, loc="best")


def standard_columns(model, bodies=None) -> tuple[dict, str]:
    """The columns of the first five standard panels (:data:`PANELS`) and
    what the body panels' titles add ("(first 4 of 40 bodies; ...)").

    Parameters
    ----------
    model : Model
    bodies : list of str, optional
        The bodies shown (default: the first :data:`MAX_BODIES`).

    Returns
    -------
    panels : dict of str -> (str, list of str)
        Panel title -> (its unit in brackets, its columns).
    shown : str

    Raises
    ------
    KeyError
        An unknown body, with the closest names.
    """
    by_name = {b.name: b for b in model.bodies}
    if bodies:
        for name in bodies:
            if name not in by_name:
                import difflib
                close = difflib.get_close_matches(name, list(by_name), n=3)
                raise KeyError(f"no body '{name}'" + (f"; did you mean {', '.join(close)}?"
                               if close else f"; the bodies are {', '.join(by_name)}"))
        chosen = [by_name[n] for n in bodies]
        shown = "" if len(chosen) == len(by_name) else \
            f" ({len(chosen)} of {len(by_name)} bodies)"
    else:
        chosen = list(model.bodies[:MAX_BODIES])
        shown = "" if len(model.bodies) <= MAX_BODIES else \
            f" (first {MAX_BODIES} of {len(model.bodies)} bodies; choose with --bodies)"
    turning = [b for b in chosen if not getattr(b, "particle", False)]
    if getattr(model, "space", 2) == 3:       # spatial bodies: orientation by Euler parameters,
        return {                              # angular velocity in body axes
            "position": ("[m]", [f"{b.name}.{c}" for b in chosen for c in "xyz"]),
            "angle": ("(Euler parameters)", [f"{b.name}.e{k}" for b in turning for k in range(4)]),
            "velocity": ("[m/s]", [f"{b.name}.v{c}" for b in chosen for c in "xyz"]),
            "angular velocity": ("[rad/s]", [f"{b.name}.w{c}" for b in turning for c in "xyz"]),
            "energy": ("[J]", ["energy.kinetic", "energy.potential", "energy.total"]),
            "first-order states": ("", []),
        }, shown
    return {
        "position": ("[m]", [f"{b.name}.{c}" for b in chosen for c in ("x", "y")]),
        # a particle (a point mass) has no angle: no line in the angle panels
        "angle": ("[rad]", [f"{b.name}.phi" for b in turning]),
        "velocity": ("[m/s]", [f"{b.name}.{c}" for b in chosen for c in ("vx", "vy")]),
        "angular velocity": ("[rad/s]", [f"{b.name}.omega" for b in turning]),
        "energy": ("[J]", ["energy.kinetic", "energy.potential", "energy.total"]),
        # a model's first-order states (controllers, filters), in their own units
        "first-order states": ("", [f"state.{s.name}" for s in getattr(model, "states", ())]),
    }, shown


def plot_solution(solution, y=None, x: str = "t", path=None, bodies=None) -> Figure:
    """Time histories of a run as one figure.

    Parameters
    ----------
    solution : Solution
    y : list of str, optional
        Column names (see ``Solution.columns``), one panel each. Default: the
        standard panels :data:`PANELS`: positions [m], angles [rad],
        velocities [m/s], angular velocities [rad/s] of the first
        :data:`MAX_BODIES` bodies, kinetic/potential/total energy [J], max
        |Phi| and max |Phi_q v + Phi_t| on a log scale, Newton iterations per
        step, the step size [s], and the first-order states if the model
        has any.
    x : str
        The abscissa column; ``t`` by default, any column for a phase plot.
    path : str or Path, optional
        Save the figure there; format by extension (``.png``, ``.svg``, ``.pdf``).
    bodies : list of str, optional
        The bodies of the standard panels (default: the first
        :data:`MAX_BODIES`; the panel titles say so when some are left out).

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    KeyError
        An unknown column or body, with the closest names.
    """
    sol = solution
    xs = sol.column(x)
    col_units = sol.column_units()

    def label(name):
        """``crank.phi [rad]``: the column with its SI unit, when it has one."""
        return f"{name} [{col_units[name]}]" if col_units.get(name) else name
    xlabel = label(x)
    if y:
        fig = _figure(8.0, 1.0 + 2.0 * len(y))
        axes = fig.subplots(len(y), 1, sharex=True, squeeze=False)[:, 0]
        for ax, name in zip(axes, y):
            ax.plot(xs, sol.column(name), lw=1.2)
            ax.set_ylabel(label(name))
            ax.grid(alpha=0.3)
        axes[-1].set_xlabel(xlabel)
    else:
        panels, shown = standard_columns(sol.model, bodies)
        titles = PANELS + (("first-order states",) if panels["first-order states"][1] else ())
        rows = (len(titles) + 1) // 2
        fig = _figure(11.0, 2.5 * rows)
        axes = fig.subplots(rows, 2, sharex=True).ravel()
        if len(axes) > len(titles):         # an odd count: the last slot stays empty
            axes[-1].set_visible(False)
            axes[-3].xaxis.set_tick_params(labelbottom=True)
            axes[-3].set_xlabel(xlabel)
        for ax, title in zip(axes, titles):
            ax.set_title(title + (shown if title in ("position", "angle", "velocity",
                                                      "angular velocity") else ""), fontsize=9)
            ax.grid(alpha=0.3)
            if title in panels:
                unit, names = panels[title]
                _lines(ax, xs, sol, names)
                ax.set_ylabel(f"{title} {unit}".rstrip())
            elif title == "constraint violation":
                for name, label in (("constraint.position", "max |Phi| [m]"),
                                    ("constraint.velocity", "max |Phi_q v + Phi_t| [m/s]")):
                    val = sol.column(name)
                    ax.plot(xs, np.where(val > 0, val, np.nan), label=label, lw=1.2)
                ax.set_yscale("log")
                ax.set_ylabel("constraint violation")
                ax.legend(fontsize=7, loc="best")
            elif title == "Newton iterations per step":
                # row i's counts belong to the step (t_{i-1}, t_i]: one stair per step
                if len(xs) > 1:
                    ax.stairs(sol.stats["iterations"][1:], xs, lw=1.0, baseline=None)
                ax.set_ylabel("iterations")
            else:
                h = sol.stats["h"][1:]
                if len(xs) > 1:
                    ax.stairs(h, xs, lw=1.0, baseline=None)
                    _step_size_axis(ax, h)
                ax.set_ylabel("h [s]")
        for ax in axes[-2:]:
            ax.set_xlabel(xlabel)
    fig.suptitle(f"{sol.model.name}: {sol.method_name}, h = {sol.h:g} s ({sol.status})",
                 fontsize=10)
    if path is not None:
        fig.savefig(path)
    return fig


def plot_mode_damping(found, methods, h: float, path=None) -> Figure:
    """What each method does to a mode of frequency omega at step h, with the
    model's modes marked: spectral radius, numerical damping ratio and
    relative period error against omega h (``integrators.spectral``).

    Parameters
    ----------
    found : mbdsl.modes.Modes
    methods : list of Method
    h : float
        Step size [s].
    path : str or Path, optional
        Where to save the figure (format by extension).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from ..integrators.spectral import spectrum
    W = np.logspace(-3, 3, 400)
    fig = _figure(7.5, 8.0)
    axes = fig.subplots(3, 1, sharex=True)
    for method in methods:
        sp = [spectrum(method.amplification(w), w) for w in W]
        label = method.describe()
        axes[0].plot(W, [s.rho for s in sp], lw=1.2, label=label)
        axes[1].plot(W, [s.damping_ratio for s in sp], lw=1.2, label=label)
        per = np.array([s.period_error for s in sp])
        axes[2].plot(W, np.where(per > 0, per, np.nan), lw=1.2, label=label)
    marks = [(mo.omega * h, i) for i, mo in enumerate(found.modes, 1)
             if mo.stable and 1e-3 <= mo.omega * h <= 1e3]
    for ax in axes:
        ax.set_xscale("log")
        ax.grid(alpha=0.3)
        for w, i in marks:
            ax.axvline(w, color="0.5", lw=0.8, ls=":")
    for w, i in marks:
        axes[0].annotate(f"{i}", (w, 1.0), textcoords="offset points", xytext=(2, 2),
                         fontsize=7, color="0.3")
    axes[0].set_ylabel("spectral radius rho")
    axes[1].set_ylabel("damping ratio xi_bar")
    axes[2].set_ylabel("period error (longer)")
    axes[2].set_yscale("log")
    axes[2].set_xlabel(f"omega h (h = {h:g} s); dotted: the model's modes")
    axes[0].legend(fontsize=7, loc="lower left")
    fig.suptitle(f"{found.model_name}: what each method does to a mode at h = {h:g} s",
                 fontsize=10)
    if path is not None:
        fig.savefig(path)
    return fig


def _step_size_axis(ax, h) -> None:
    """A log axis of step sizes whose ticks are the halvings (factors of 2) with
    their values as labels, padded by half a halving: a constant h shows as one
    labelled line, not a decade of identical "10^-3" labels."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator
    h = np.asarray(h, dtype=float)
    h = h[np.isfinite(h) & (h > 0)]
    if not len(h):
        return
    lo, hi = float(h.min()), float(h.max())
    ax.set_yscale("log")                       # halvings show as equal steps
    ax.set_ylim(lo / 2**0.5, hi * 2**0.5)
    k = int(np.ceil(np.log2(hi / lo) + 1e-9))
    ticks = hi / 2.0 ** np.arange(0, k + 1)
    if len(ticks) > 6:                         # at most six labels
        ticks = ticks[:: int(np.ceil(len(ticks) / 6))]
    ax.yaxis.set_major_locator(FixedLocator(ticks))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.3g}"))
    ax.yaxis.set_minor_locator(NullLocator())


def _readable_log_ticks(ax) -> None:
    """Log axes whose tick labels do not overlap: over a decade or more only the
    powers of ten are labelled; within less than a decade (no or one power of
    ten inside, where matplotlib labels every minor tick) the minor ticks are
    1, 2 and 5 times a power of ten, labelled with their values."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    for axis, lim in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        if axis.get_scale() != "log" or not min(lim) > 0:
            continue
        if max(lim) / min(lim) >= 10.0:
            axis.set_minor_formatter(NullFormatter())
        else:
            axis.set_minor_locator(LogLocator(base=10.0, subs=(2.0, 5.0)))
            axis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:.2g}"))


# -- animation ---------------------------------------------------------------------------

@dataclass
class AnimationResult:
    """What :func:`animate_solution` wrote.

    Attributes
    ----------
    path : Path
    frames : int
    times : ndarray, shape (frames,) [s]
        Simulated time of each frame.
    figure : matplotlib.figure.Figure
        With its axes at the first frame's limits, for mapping data to pixels.
    colors : dict of str -> tuple
        RGB (0..1) of each body, by name.
    camera : Camera or None
        A spatial model's perspective (:class:`mbdsl.graphics.scene3d.Camera`):
        ``camera.project`` gives the screen coordinates the axes map to pixels.
    """

    path: Path
    frames: int
    times: np.ndarray
    figure: Figure
    colors: dict = field(default_factory=dict)
    camera: object = None

    @property
    def axes(self):
        """The drawing's axes."""
        return self.figure.axes[0]


def _interpolated(t, values, times):
    """values (N, n) at stored t -> (len(times), n), linear in time."""
    idx = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2)
    w = np.clip((times - t[idx]) / np.maximum(t[idx + 1] - t[idx], 1e-300), 0.0, 1.0)
    return values[idx] * (1 - w)[:, None] + values[idx + 1] * w[:, None]


def animate_solution(solution, path, fps: float = 25.0, speed: float = 1.0,
                     size=(6.0, 4.5), dpi: int = 100,
                     deform_scale: float = 1.0) -> AnimationResult:
    """Draw the mechanism's motion to a GIF (Pillow) or MP4 (ffmpeg).

    A spatial model (``space 3d``) is drawn in perspective
    (:class:`mbdsl.graphics.scene3d.SpatialScene`): its bodies' shapes
    (lines, spheres, cylinders, boxes) or lines from their centres of mass to
    their points, a dot at each centre of mass, in the painter's order.

    Rigid bodies are drawn with their ``shape`` lines (lines, circles,
    polygons in the body frame), or without them as the outline through
    their points (:func:`mbdsl.graphics.scene.body_outline`); flexible beams as their deformed
    centre line (:func:`mbdsl.graphics.scene.beam_world`, the elastic displacement times
    ``deform_scale``); joints as circles, spring-dampers as zig-zags, ground
    attachment points hatched (a prismatic or point-on-line joint on the
    ground also shows its guide), and the simulated time as a label.

    Parameters
    ----------
    solution : Solution
    path : str or Path
        ``.gif`` or ``.mp4``.
    fps : float
        Frames per second of the file.
    speed : float
        Simulated seconds per second of video (2 = twice as fast).
    size : (float, float) [inch], dpi : int
        Frame size: ``size * dpi`` pixels.
    deform_scale : float
        Magnification of the beams' elastic displacements (1: true size).

    Returns
    -------
    AnimationResult
        frames = floor((t_last - t_first) fps / speed) + 1.

    Raises
    ------
    ValueError
        An unsupported extension, a non-positive fps or speed, or MP4 without
        ffmpeg (saying to install it or write a GIF).
    """
    from matplotlib import animation
    path = Path(path)
    ext = path.suffix.lower()
    if fps <= 0 or speed <= 0:
        raise ValueError(f"fps and speed must be positive (got fps={fps}, speed={speed})")
    if not (deform_scale >= 0 and np.isfinite(deform_scale)):
        raise ValueError(f"the deformation scale must be zero or positive, got {deform_scale}")
    writer = _movie_writer(animation, path, ext, fps)

    from .scene import Scene
    sol, model = solution, solution.model
    t = sol.t
    n_frames = int(np.floor((t[-1] - t[0]) * fps / speed + 1e-9)) + 1
    times = t[0] + np.arange(n_frames) * speed / fps
    qs = _interpolated(t, sol.q, times) if len(t) > 1 else np.repeat(sol.q[:1], n_frames, 0)
    if getattr(model, "space", 2) == 3:
        return _animate_spatial(model, path, writer, animation, times, qs, size, dpi)
    scene = Scene(model, deform_scale)
    lo, hi = scene.frame_extent(qs)
    scale = scene.scale
    r_joint = 0.015 * scale

    fig = _figure(*size)
    fig.set_dpi(dpi)
    fig.set_layout_engine(None)
    ax = fig.add_axes((0.02, 0.02, 0.96, 0.96))
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xticks([])
    ax.set_yticks([])

    artists, colors = _mechanism_artists(ax, scene, r_joint)
    label = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=10)

    def draw(k):
        """Move every artist to frame k."""
        for item, art, w in zip(scene.items, artists, scene.coordinates(qs[k])):
            if item.kind in ("circle", "joint"):
                art.center = tuple(w[0])
            elif item.kind == "polygon":
                art.set_xy(w)
            else:
                art.set_data(w[:, 0], w[:, 1])
        label.set_text(f"t = {times[k]:.3f} s")
        return []

    anim = animation.FuncAnimation(fig, draw, frames=n_frames, blit=False, repeat=False)
    anim.save(str(path), writer=writer, dpi=dpi)
    draw(0)
    fig.canvas.draw()              # final limits (equal aspect) for data -> pixel maps
    return AnimationResult(path=path, frames=n_frames, times=times, figure=fig, colors=colors)



def _animate_spatial(model, path, writer, animation, times, qs, size, dpi) -> AnimationResult:
    """The spatial model's frames qs (N, n) at ``times`` through a
    perspective camera (:meth:`SpatialScene.camera`), written by ``writer``;
    the result's axes map screen coordinates (``camera.project``) to pixels."""
    from matplotlib.patches import Circle, Polygon

    from .scene3d import BOX_FACES, SpatialScene
    scene = SpatialScene(model)
    cam = scene.camera(qs)
    fig = _figure(*size)
    fig.set_dpi(dpi)
    fig.set_layout_engine(None)
    ax = fig.add_axes((0.02, 0.02, 0.96, 0.96))
    pts = [scene.ground_points()] + [c for q in qs[:: max(1, len(qs) // 50)]
                                     for c in scene.coordinates(q)]
    xy = cam.project(np.vstack(pts))
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = 0.08 * max(float(np.max(hi - lo)), 1e-9)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xticks([])
    ax.set_yticks([])
    for line in scene.floor(np.vstack(pts), cam.up):            # the floor's grid, beneath all
        g = cam.project(line)
        ax.plot(g[:, 0], g[:, 1], lw=0.5, color="0.85", zorder=-1e6)
    ground = cam.project(scene.ground_points())
    ax.plot(ground[:, 0], ground[:, 1], "x", ms=9, mew=2, color="0.45", zorder=0)
    rgb = {name: _rgb(h) for name, h in scene.colors.items()}
    artists = []
    for item in scene.items:
        col = rgb.get(item.body, (0.0, 0.0, 0.0))
        if item.kind == "box":
            artists.append([ax.add_patch(Polygon(np.zeros((4, 2)), closed=True, lw=1.0,
                                                 facecolor=(*col, 0.3), edgecolor=col))
                            for _ in BOX_FACES])
        elif item.kind in ("sphere", "cylinder"):
            patch = Circle((0, 0), 1.0) if item.kind == "sphere" else Polygon(np.zeros((4, 2)))
            patch.set(facecolor=(*col, 0.45), edgecolor=col, lw=1.5)
            artists.append([ax.add_patch(patch)])
        elif item.kind == "cm":
            artists.append(ax.plot([], [], "o", ms=7, color=col, mec="k", mew=0.8))
        elif item.kind == "joint":
            artists.append(ax.plot([], [], "o", ms=6, color="white", mec="k", mew=1.0))
        else:
            artists.append(ax.plot([], [], lw=1.0 if item.kind == "spring" else 3.0,
                                   color=col, solid_capstyle="round"))
    label = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=10)

    def draw(k):
        """Move every artist to frame k, farther ones beneath nearer ones."""
        for item, arts, w in zip(scene.items, artists, scene.coordinates(qs[k])):
            p, depth = cam.project(w), cam.depth(w)
            on_top = 1000.0 if item.kind in ("cm", "joint") else 0.0
            for a in arts:
                a.set_zorder(on_top - float(np.mean(depth)))
            if item.kind == "box":
                for a, face in zip(arts, BOX_FACES):
                    a.set_xy(p[list(face)])
                    a.set_zorder(-float(np.mean(depth[list(face)])))
            elif item.kind == "sphere":
                arts[0].center, arts[0].radius = tuple(p[0]), cam.focal * item.radius / depth[0]
            elif item.kind == "cylinder":
                d = p[1] - p[0]
                n = np.array([-d[1], d[0]]) / max(np.linalg.norm(d), 1e-12)
                ra, rb = cam.focal * item.radius / depth
                arts[0].set_xy([p[0] + ra * n, p[1] + rb * n, p[1] - rb * n, p[0] - ra * n])
            else:
                arts[0].set_data(p[:, 0], p[:, 1])
        label.set_text(f"t = {times[k]:.3f} s")
        return []

    anim = animation.FuncAnimation(fig, draw, frames=len(times), blit=False, repeat=False)
    anim.save(str(path), writer=writer, dpi=dpi)
    draw(0)
    fig.canvas.draw()
    return AnimationResult(path=path, frames=len(times), times=times, figure=fig, colors=rgb,
                           camera=cam)


def _movie_writer(animation, path, ext, fps):
    """matplotlib's writer of a ``.gif`` (Pillow) or ``.mp4`` (ffmpeg) at
    ``fps`` frames per second; ValueError for another format or without ffmpeg."""
    if ext == ".gif":
        return animation.PillowWriter(fps=fps)
    if ext == ".mp4":
        if not animation.writers.is_available("ffmpeg"):
            raise ValueError("writing MP4 needs ffmpeg, which is not installed here; "
                             "install ffmpeg or write a GIF (-o motion.gif)")
        return animation.FFMpegWriter(fps=fps)
    raise ValueError(f"cannot write an animation as '{ext or path.name}': use .gif or .mp4")


def _rgb(h):
    """``#rrggbb`` as an RGB tuple in [0, 1]."""
    return tuple(int(h[i:i + 2], 16) / 255 for i in (1, 3, 5))


def _mechanism_artists(ax, scene, r_joint) -> tuple:
    """The ground (a hatched block under every ground attachment, the guides
    of sliders on the ground) and one artist per item of ``scene``, in its
    order; returns (the artists, the bodies' colours as RGB)."""
    from matplotlib.patches import Circle, Polygon, Rectangle
    marks, guides = scene.ground()
    for g in marks:
        ax.add_patch(Rectangle((g[0] - 2 * r_joint, g[1] - 3.5 * r_joint), 4 * r_joint,
                               2.2 * r_joint, hatch="////", fill=False, lw=0.8,
                               edgecolor="0.3", zorder=0))
    for ends in guides:
        ax.plot(ends[:, 0], ends[:, 1], ls="--", lw=0.8, color="0.5", zorder=0)

    colors = {name: _rgb(h) for name, h in scene.colors.items()}
    artists = []
    for item in scene.items:
        col = _rgb(item.color)
        if item.kind == "circle":
            artists.append(ax.add_patch(Circle((0, 0), item.radius, lw=2.0,
                                               facecolor=(*col, 0.35), edgecolor=col)))
        elif item.kind == "polygon":
            artists.append(ax.add_patch(Polygon(np.zeros((3, 2)), closed=True, lw=2.0,
                                                facecolor=(*col, 0.35), edgecolor=col)))
        elif item.kind in ("line", "beam"):
            artists.append(ax.plot([], [], lw=4.0 if item.kind == "line" else 3.0, color=col,
                                   solid_capstyle="round")[0])
        elif item.kind == "point":
            artists.append(ax.plot([], [], "o", ms=8, color=col)[0])
        elif item.kind in ("spring", "rod"):
            artists.append(ax.plot([], [], lw=1.0 if item.kind == "spring" else 1.5,
                                   color="k" if item.kind == "spring" else "0.2")[0])
        else:
            artists.append(ax.add_patch(Circle((0, 0), r_joint, fill=True, facecolor="white",
                                               edgecolor="k", lw=1.2, zorder=5)))
    return artists, colors


@dataclass
class Series:
    """One plotted series of a study figure.

    Attributes
    ----------
    label : str
    x, y : ndarray, shape (N,)
    kind : {"line", "scatter", "bar"}
        ``line``: lines with markers at the points; ``scatter``: markers only
        (one per step); ``bar``: bars at positions 0..N-1 labelled ``x``
        (several bar series of a panel are grouped side by side).
    """

    label: str
    x: np.ndarray
    y: np.ndarray
    kind: str = "line"


@dataclass
class Panel:
    """One axes of a study figure.

    Attributes
    ----------
    title, xlabel, ylabel : str
    series : list of Series
    xscale, yscale : {"linear", "log"}
    equal : bool
        Equal aspect (x against y components of one vector).
    """

    title: str
    xlabel: str
    ylabel: str
    series: list = field(default_factory=list)
    xscale: str = "linear"
    yscale: str = "linear"
    equal: bool = False


def write_figure(panels, stem, title: str = "", columns: int | None = None) -> list[Path]:
    """Draw panels into one figure and save it as PNG and SVG.

    Parameters
    ----------
    panels : list of Panel
    stem : str or Path
        File name without suffix; ``stem.png`` and ``stem.svg`` are written.
    title : str
        Figure title.
    columns : int, optional
        Panels per row; default up to 3.

    Returns
    -------
    list of Path
        The files written. In the SVG, the artists of series j of panel k
        have the id ``series-k-j`` (bars ``series-k-j-i``).
    """
    n = len(panels)
    cols = columns or min(n, 3)
    rows = -(-n // cols)
    fig = _figure(4.6 * cols, 3.6 * rows)
    if title:
        fig.suptitle(title)
    for k, panel in enumerate(panels):
        ax = fig.add_subplot(rows, cols, k + 1)
        # the scales first: setting a scale resets the axis' locator and formatter,
        # which would replace a bar chart's method names by the numbers 0..N-1
        ax.set_xscale(panel.xscale)
        ax.set_yscale(panel.yscale)
        n_bars = sum(s.kind == "bar" for s in panel.series)
        width = 0.8 / max(n_bars, 1)
        b = 0
        for j, s in enumerate(panel.series):
            x, y = np.asarray(s.x), np.asarray(s.y, dtype=float)
            # every drawn artist of a series carries the id "series-<panel>-<series>[-<bar>]",
            # so the SVG says how many series each panel shows
            gid = f"series-{k}-{j}"
            if s.kind == "bar":
                # several bar series in one panel are grouped side by side at each label
                pos = np.arange(len(y)) + (b - (n_bars - 1) / 2) * width
                bars = ax.bar(pos, y, width=width if n_bars > 1 else 0.8, label=s.label)
                if b == 0:
                    ax.set_xticks(np.arange(len(y)), [str(v) for v in x])
                b += 1
                for i, bar in enumerate(bars):
                    bar.set_gid(f"{gid}-{i}")
                ax.tick_params(axis="x", labelrotation=30, labelsize=8)
            elif s.kind == "scatter":
                ax.plot(x, y, ".", ms=2, label=s.label, gid=gid)
            else:
                # markers show the steps of a convergence line; on a time history of
                # thousands of steps they would hide the curve
                ax.plot(x, y, "o-" if len(x) <= 60 else "-", ms=3, lw=1.2, label=s.label,
                        gid=gid)
        ax.set_title(panel.title, fontsize=10)
        ax.set_xlabel(panel.xlabel)
        ax.set_ylabel(panel.ylabel)
        if panel.equal:
            ax.set_aspect("equal", adjustable="box")
            ax.ticklabel_format(style="sci", scilimits=(-2, 3))
        ax.grid(True, which="both", alpha=0.3)
        _readable_log_ticks(ax)
        if len(panel.series) > 1:
            ax.legend(fontsize=7, loc="best")
    stem = Path(stem)
    paths = [stem.with_suffix(".png"), stem.with_suffix(".svg")]
    for p in paths:
        fig.savefig(p, dpi=110)
    return paths
