"""A run in the browser: one self-contained HTML file (``mbdsl view``).

The page holds the mechanism animated (the drawing of :mod:`mbdsl.graphics.scene`:
bodies with their shapes, beams deformed, springs, rods and joints; of a spatial
model, :mod:`mbdsl.graphics.scene3d`'s, as wireframes in a 3D scene the reader
turns and zooms), a time
slider with play and pause at three speeds, and time plots beside it (the
standard panels, or the columns asked for) that zoom, pan and show values
on hover, each with a cursor at the slider's time and the run's events as
dotted lines. Above them the run's summary and its warnings. plotly writes
the figure, its script embedded (``include_plotlyjs=True``): the file opens
offline, without a server. plotly is imported here only.

The frames are downsampled (at most ``max_frames``, evenly in time, the
state interpolated linearly between rows as the GIF animation does), the
time plots are not: they draw every row. The mechanism is drawn with a few
traces whatever the number of bodies (one per colour and kind, the parts
separated by gaps), so that a chain of hundreds of links plays smoothly.

The page exposes what it shows for scripts and tests as
``window.mbdslViewer``: ``frames`` (their number), ``times`` [s] and
``traces`` (the mechanism traces' indices in the figure and what each
draws); the figure is the element with id ``mechanism``.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from .scene import Scene
from .scene3d import SpatialScene

__all__ = ["write_html", "figure", "MAX_FRAMES"]

#: Frames of the animation at most (downsampled in time).
MAX_FRAMES = 200
#: Points of a drawn circle.
_CIRCLE = 24


def _rgba(color: str, alpha: float) -> str:
    r, g, b = (int(color[i:i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha})"


def _joined(parts, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """x, y of polylines (k, 2) joined with NaN gaps (closed: back to the start)."""
    xs, ys = [], []
    for w in parts:
        if closed:
            w = np.vstack([w, w[:1]])
        xs += [w[:, 0], [np.nan]]
        ys += [w[:, 1], [np.nan]]
    if not xs:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(xs)[:-1], np.concatenate(ys)[:-1]


class _Grouped:
    """A scene's items grouped into plotly traces, one per way of drawing
    (``style_of`` an item's kind) and colour: ``groups`` (style, colour) ->
    item indices, ``keys`` their order."""

    def __init__(self, scene, style_of):
        self.scene = scene
        self.groups = {}
        for i, item in enumerate(scene.items):
            self.groups.setdefault((style_of(item.kind), item.color), []).append(i)
        self.keys = list(self.groups)

    def _name(self, key) -> str:
        """A trace's hover name: the bodies it draws (four at most), or its style."""
        names = sorted({self.scene.items[i].body for i in self.groups[key]
                        if self.scene.items[i].body})
        return ", ".join(names[:4]) + (" ..." if len(names) > 4 else "") or key[0]


class _Drawing(_Grouped):
    """The scene's items grouped into plotly traces (one per colour and way
    of drawing), and their x, y at a state."""

    #: whether plotly redraws the figure at each frame (its 3D scenes need it)
    redraw = False
    STYLES = {"polygon": "fill", "circle": "fill", "line": "line", "beam": "beam",
              "point": "point", "spring": "spring", "rod": "rod", "joint": "joint"}

    def __init__(self, scene: Scene):
        super().__init__(scene, self.STYLES.__getitem__)

    def traces(self):
        """The traces' static attributes (plotly dicts), in :attr:`keys` order."""
        out = []
        for style, color in self.keys:
            base = {"type": "scatter", "xaxis": "x", "yaxis": "y", "showlegend": False,
                    "hoverinfo": "name", "name": self._name((style, color))}
            if style == "fill":
                base.update(mode="lines", fill="toself", fillcolor=_rgba(color, 0.35),
                            line={"color": color, "width": 2})
            elif style in ("line", "beam"):
                base.update(mode="lines", line={"color": color, "width": 5 if style == "line"
                                                else 4})
            elif style == "point":
                base.update(mode="markers", marker={"color": color, "size": 10})
            elif style in ("spring", "rod"):
                base.update(mode="lines", line={"color": "#000000" if style == "spring"
                                                else "#333333",
                                                "width": 1 if style == "spring" else 2})
            else:
                base.update(mode="markers", marker={"color": "#ffffff", "size": 9,
                                                    "line": {"color": "#000000", "width": 1.5}})
            out.append(base)
        return out

    def xy(self, q):
        """Per trace (x, y) at q (n,): the parts joined with gaps."""
        coords = self.scene.coordinates(q)
        out = []
        for style, color in self.keys:
            parts = []
            for i in self.groups[(style, color)]:
                w, item = coords[i], self.scene.items[i]
                if item.kind == "circle":
                    a = np.linspace(0.0, 2 * np.pi, _CIRCLE, endpoint=False)
                    w = w[0] + item.radius * np.column_stack([np.cos(a), np.sin(a)])
                parts.append(w)
            if style in ("point", "joint"):
                pts = np.vstack(parts)
                out.append((pts[:, 0], pts[:, 1]))
            else:
                out.append(_joined(parts, closed=style == "fill"))
        return out

    def frame_traces(self, go, q) -> list:
        """The moving traces' data at q (n,), for a frame."""
        return [go.Scatter(x=x, y=y) for x, y in self.xy(q)]

    def add_to(self, fig, go, q0, qs) -> list:
        """The mechanism's panel (row 1, column 1) at q0, framed to hold every
        frame of qs; returns its moving traces' indices."""
        lo, hi = self.scene.frame_extent(qs)
        mech = _add_mechanism(fig, go, self.scene, self, q0)
        fig.update_xaxes(range=[lo[0], hi[0]], row=1, col=1, showgrid=False, zeroline=False)
        fig.update_yaxes(range=[lo[1], hi[1]], row=1, col=1, scaleanchor="x", scaleratio=1,
                         showgrid=False, zeroline=False)
        return mech


class _Drawing3D(_Grouped):
    """A spatial model's items (``SpatialScene``) grouped into plotly 3D traces
    (one per colour and way of drawing: the bodies' wireframes, the centres of
    mass, springs, joints), their x, y, z at a state; a perspective scene
    looking from above and beside the motion, as ``mbdsl animate`` does,
    that the reader turns and zooms."""

    redraw = True

    def __init__(self, scene: SpatialScene):
        super().__init__(scene, lambda kind: kind if kind in ("cm", "spring", "joint")
                         else "wire")

    def traces(self):
        """The traces' static attributes (plotly dicts), in :attr:`keys` order."""
        out = []
        for style, color in self.keys:
            base = {"showlegend": False, "hoverinfo": "name", "name": self._name((style, color))}
            if style == "wire":
                base.update(mode="lines", line={"color": color, "width": 5})
            elif style == "cm":
                base.update(mode="markers", marker={"color": color, "size": 5})
            elif style == "spring":
                base.update(mode="lines", line={"color": "#000000", "width": 2})
            else:
                base.update(mode="markers", marker={"color": "#000000", "size": 4,
                                                    "symbol": "circle-open"})
            out.append(base)
        return out

    def xyz(self, q):
        """Per trace (x, y, z) at q (n,): the polylines joined with gaps."""
        wires = self.scene.wires(q)
        out = []
        for key in self.keys:
            parts = [w for i in self.groups[key] for w in wires[i]]
            joined = np.vstack([np.vstack([w, np.full((1, 3), np.nan)]) for w in parts])[:-1]
            out.append((joined[:, 0], joined[:, 1], joined[:, 2]))
        return out

    def frame_traces(self, go, q) -> list:
        """The moving traces' data at q (n,), for a frame."""
        return [go.Scatter3d(x=x, y=y, z=z) for x, y, z in self.xyz(q)]

    def add_to(self, fig, go, q0, qs) -> list:
        """The 3D scene (row 1, column 1) at q0: a floor grid and the
        ground's points (static), the bodies' traces; its axes fixed to hold
        every frame of qs, equal in scale. Returns the moving traces."""
        sc = self.scene
        pts = [sc.ground_points()] + [w for q in qs[:: max(1, len(qs) // 50)]
                                      for ws in sc.wires(q) for w in ws]
        pts = np.vstack(pts)
        cam = sc.camera(qs)
        for seg in sc.floor(pts, cam.up):
            fig.add_trace(go.Scatter3d(x=seg[:, 0], y=seg[:, 1], z=seg[:, 2], mode="lines",
                                       showlegend=False, hoverinfo="skip",
                                       line={"color": "#cccccc", "width": 1}), row=1, col=1)
        ground = sc.ground_points()
        if len(ground):
            fig.add_trace(go.Scatter3d(x=ground[:, 0], y=ground[:, 1], z=ground[:, 2],
                                       mode="markers", showlegend=False, name="ground",
                                       marker={"symbol": "x", "size": 4, "color": "#777777"}),
                          row=1, col=1)
        first = len(fig.data)
        for base, (x, y, z) in zip(self.traces(), self.xyz(q0)):
            fig.add_trace(go.Scatter3d(x=x, y=y, z=z, **base), row=1, col=1)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        half = 0.55 * max(float(np.max(hi - lo)), 0.1)
        mid = 0.5 * (lo + hi)
        eye = (cam.eye - mid) / half
        axis = {"showbackground": False, "zeroline": False}
        fig.update_scenes(
            xaxis={**axis, "range": [mid[0] - half, mid[0] + half], "title": "x [m]"},
            yaxis={**axis, "range": [mid[1] - half, mid[1] + half], "title": "y [m]"},
            zaxis={**axis, "range": [mid[2] - half, mid[2] + half], "title": "z [m]"},
            aspectmode="cube", camera={"eye": dict(zip("xyz", eye.tolist())),
                                       "up": dict(zip("xyz", cam.up.tolist()))})
        return list(range(first, len(fig.data)))


def _panels(sol, columns, bodies):
    """[(title, [columns], log scale)] of the time plots."""
    if columns:
        missing = [c for c in columns if c not in set(sol.columns)]
        for c in missing:
            sol.column(c)               # the KeyError with the closest names
        return [(c, [c], False) for c in columns]
    from .plotting import standard_columns
    panels, _ = standard_columns(sol.model, bodies)
    out = [(f"{title} {unit}", names, False) for title, (unit, names) in panels.items()
           if names]
    if sol.system.m:
        out.append(("constraint violation", ["constraint.position", "constraint.velocity"],
                    True))
    if getattr(sol, "control", None) is not None or len(np.unique(sol.stats["h"][1:])) > 1:
        out.append(("step size [s]", ["step.h"], True))
    return out


def write_html(solution, path, columns=None, bodies=None, max_frames: int = MAX_FRAMES,
               deform_scale: float = 1.0) -> Path:
    """Write a run as one self-contained interactive HTML page (module notes).

    Parameters
    ----------
    solution : Solution
        A finished run, or one read back from a result file.
    path : str or Path
        The ``.html`` file.
    columns : list of str, optional
        The time plots, one column each; default: the standard panels
        (positions, angles, velocities, angular velocities of the first
        four bodies, energies, constraint violation, the step size of an
        error-controlled run).
    bodies : list of str, optional
        The bodies of the standard panels.
    max_frames : int
        Frames of the animation at most.
    deform_scale : float
        Magnification of the beams' elastic displacements in the drawing.

    Returns
    -------
    Path

    Raises
    ------
    KeyError
        An unknown column or body, with the closest names.
    ValueError
        max_frames < 2, a negative deformation scale, a run without rows.
    OSError
        The file cannot be written.
    """
    sol = solution
    fig, info = figure(sol, columns, bodies, max_frames, deform_scale)
    # auto_play: plotly starts a figure's frames on load unless told not to;
    # the page opens at the run's start and plays when the reader asks
    embedded = fig.to_html(include_plotlyjs=True, full_html=False, div_id="mechanism",
                           config={"responsive": True, "displaylogo": False}, auto_play=False)
    warnings = "".join(f"<li>{html.escape(w.code)}: {html.escape(w.message)}</li>"
                       for w in sol.warnings)
    page = _PAGE.format(title=html.escape(f"{sol.model.name}: {sol.method_name}"),
                        summary=html.escape(sol.summary()),
                        warnings=f"<ul class='warn'>{warnings}</ul>" if warnings else "",
                        figure=embedded, info=json.dumps(info))
    path = Path(path)
    path.write_text(page, encoding="utf-8")
    return path


def figure(solution, columns=None, bodies=None, max_frames: int = MAX_FRAMES,
           deform_scale: float = 1.0) -> tuple:
    """The page's plotly figure and what it shows (:func:`write_html`, whose
    parameters and errors these are).

    Returns
    -------
    (plotly Figure, dict)
        The figure, its frames at ``times``, and ``{"frames", "times",
        "traces", "cursors"}``: the number of frames, their times [s], the
        mechanism's moving traces (``{"trace", "style", "color"}``: their
        index in the figure, how they draw and their colour) and the time
        plots' cursors' indices.
    """
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots
    from .plotting import _interpolated
    sol = solution
    if max_frames < 2:
        raise ValueError(f"the animation needs at least 2 frames, got {max_frames}")
    if len(sol.t) == 0:
        raise ValueError("the run has no rows to show")
    panels = _panels(sol, columns, bodies)
    t = np.asarray(sol.t, float)
    n_frames = int(min(max_frames, max(len(t), 2)))
    times = np.linspace(t[0], t[-1], n_frames)
    qs = _interpolated(t, sol.q, times) if len(t) > 1 else np.repeat(sol.q[:1], n_frames, 0)
    spatial = getattr(sol.model, "space", 2) == 3
    drawing = (_Drawing3D(SpatialScene(sol.model)) if spatial
               else _Drawing(Scene(sol.model, deform_scale)))
    rows = max(len(panels), 1)
    first = {"rowspan": rows, **({"type": "scene"} if spatial else {})}
    fig = make_subplots(rows=rows, cols=2, column_widths=[0.5, 0.5],
                        specs=[[first, {}]] + [[None, {}] for _ in range(rows - 1)],
                        shared_xaxes=False, vertical_spacing=0.04 if rows > 4 else 0.08,
                        subplot_titles=[""] + [p[0] for p in panels])
    mech = drawing.add_to(fig, go, qs[0], qs)
    cursors, bounds = _add_time_plots(fig, go, sol, panels, t, times)
    fig.update_xaxes(title_text="t [s]", row=rows, col=2)
    _add_frames(fig, go, drawing, qs, times, bounds, mech + cursors, rows)
    described = [{"trace": i, "style": s, "color": c}
                 for i, (s, c) in zip(mech, drawing.keys)]
    return fig, {"frames": n_frames, "times": times.tolist(), "traces": described,
                 "cursors": cursors}



def _add_mechanism(fig, go, scene, drawing, q0) -> list:
    """The mechanism's panel at q0: the ground's marks and guides (static),
    then its bodies' traces; returns the indices of those (the frames move
    them)."""
    marks, guides = scene.ground()
    if marks:
        m = np.array(marks)
        fig.add_trace(go.Scatter(x=m[:, 0], y=m[:, 1], mode="markers", showlegend=False,
                                 hoverinfo="skip", marker={"symbol": "triangle-up", "size": 12,
                                                           "color": "#777777"}), row=1, col=1)
    for g in guides:
        fig.add_trace(go.Scatter(x=g[:, 0], y=g[:, 1], mode="lines", showlegend=False,
                                 hoverinfo="skip", line={"dash": "dash", "color": "#888888",
                                                         "width": 1}), row=1, col=1)
    first = len(fig.data)
    for base, (x, y) in zip(drawing.traces(), drawing.xy(q0)):
        base = dict(base)
        base.pop("xaxis")
        base.pop("yaxis")
        fig.add_trace(go.Scatter(x=x, y=y, **{k: v for k, v in base.items() if k != "type"}),
                      row=1, col=1)
    mech = list(range(first, len(fig.data)))
    return mech


def _add_time_plots(fig, go, sol, panels, t, times) -> tuple:
    """The time plots, every row, events as dotted lines and a cursor at the
    first frame's time in each; returns (the cursors' trace indices, each
    panel's (y0, y1))."""
    units = sol.column_units()
    cursors, bounds = [], []
    for r, (title, names, log) in enumerate(panels, start=1):
        lows, highs = [], []
        for name in names:
            y = np.asarray(sol.column(name), float)
            if log:
                y = np.where(y > 0, y, np.nan)
            label = f"{name} [{units[name]}]" if units.get(name) else name
            fig.add_trace(go.Scatter(x=t, y=y, mode="lines", name=label, showlegend=False,
                                     hovertemplate=f"{label}: %{{y:.6g}}<br>t = %{{x:.6g}} s"
                                     "<extra></extra>", line={"width": 1.5}),
                          row=r, col=2)
            finite = y[np.isfinite(y)]
            if len(finite):
                lows.append(finite.min())
                highs.append(finite.max())
        y0 = min(lows) if lows else 0.0
        y1 = max(highs) if highs else 1.0
        if y1 == y0:
            y0, y1 = y0 - 1.0, y1 + 1.0
        bounds.append((y0, y1))
        for te, name, kind, _ in sol.events:          # events as dotted lines
            fig.add_trace(go.Scatter(x=[te, te], y=[y0, y1], mode="lines", showlegend=False,
                                     hovertemplate=f"{html.escape(str(name))} {kind} "
                                     f"at t = {te:.6g} s<extra></extra>",
                                     line={"dash": "dot", "color": "#999999", "width": 1}),
                          row=r, col=2)
        fig.add_trace(go.Scatter(x=[times[0], times[0]], y=[y0, y1], mode="lines",
                                 showlegend=False, hoverinfo="skip",
                                 line={"color": "#d62728", "width": 1.5}), row=r, col=2)
        cursors.append(len(fig.data) - 1)
        if log:
            fig.update_yaxes(type="log", row=r, col=2)
    return cursors, bounds


def _add_frames(fig, go, drawing, qs, times, bounds, moving, rows) -> None:
    """One frame per time of ``times`` (the mechanism at ``qs`` and the
    cursors), the play buttons and the time slider."""
    n_frames = len(times)
    frames = []
    for k in range(n_frames):
        data = drawing.frame_traces(go, qs[k])
        data += [go.Scatter(x=[times[k], times[k]], y=list(b)) for b in bounds]
        frames.append(go.Frame(name=f"f{k}", data=data, traces=moving))
    fig.frames = frames
    span = float(times[-1] - times[0])
    step_ms = 1000.0 * span / max(n_frames - 1, 1)

    def play(speed):
        """The play button at ``speed`` times real time (frames >= 16 ms apart)."""
        return {"label": f"play x{speed:g}", "method": "animate",
                "args": [None, {"frame": {"duration": max(step_ms / speed, 16.0),
                                          "redraw": drawing.redraw},
                                "transition": {"duration": 0}, "fromcurrent": True,
                                "mode": "immediate"}]}
    fig.update_layout(
        height=max(600, 170 * rows), margin={"l": 50, "r": 20, "t": 40, "b": 40},
        template="plotly_white", hovermode="closest",
        updatemenus=[{"type": "buttons", "direction": "left", "x": 0.0, "y": -0.02,
                      "xanchor": "left", "yanchor": "top", "showactive": False,
                      "buttons": [play(1.0), play(0.25), play(4.0),
                                  {"label": "pause", "method": "animate",
                                   "args": [[None], {"frame": {"duration": 0, "redraw": False},
                                                     "mode": "immediate",
                                                     "transition": {"duration": 0}}]}]}],
        sliders=[{"active": 0, "x": 0.0, "len": 0.5, "y": -0.08, "xanchor": "left",
                  "yanchor": "top", "currentvalue": {"prefix": "t = ", "suffix": " s"},
                  "steps": [{"label": f"{times[k]:.4g}", "method": "animate",
                             "args": [[f"f{k}"], {"mode": "immediate",
                                                  "frame": {"duration": 0,
                                                            "redraw": drawing.redraw},
                                                  "transition": {"duration": 0}}]}
                            for k in range(n_frames)]}])


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>body {{ font-family: sans-serif; margin: 1em; }}
details pre {{ font-size: 12px; }} .warn {{ color: #a33; }}</style></head>
<body>
<script>
// plotly.js rejects an animation's promise, with no reason, when the next one
// interrupts it (a click on the slider animates on mousedown and again on
// mouseup; plotly/plotly.js#2438: intentional): not an error of this page.
window.addEventListener("unhandledrejection", function (e) {{
  if (e.reason === undefined) {{ e.preventDefault(); }}
}});
</script>
<h2>{title}</h2>
<details><summary>summary of the run</summary><pre>{summary}</pre></details>
{warnings}
{figure}
<script>window.mbdslViewer = {info};</script>
</body></html>
"""
