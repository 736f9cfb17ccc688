"""``rotlab animate``: a GIF or MP4 of the body, read back from a run recording.

Each frame shows what the 3D view shows, in the same colours (``style``): the equivalent
ellipsoid turned by Λ(t) (``/body/quaternion``, float64), the body axes x, y, z, the ω and L
arrows (``/world/omega``, ``/world/L``: already scaled, space frame), each load's arrow
(``/world/loads/<symbol>/arrow``) and the tip of the reference axis (symmetry axis, else spin axis) with a trailing
trace over the same window as the viewer's (``visuals.trail_window``).  Frame k shows the
recording at t₀ + k · speed / fps (nearest sample).  Each arrow carries its symbol at its tip (x, y,
z, ω, L, the loads' M1, F1 …), a legend names the colours, and the body is opaque: every line is
drawn piece by piece in front of it or behind it (``behind``: a ray test against the ellipsoid),
since matplotlib sorts whole artists, not pixels.  The camera frames everything any frame draws
(``_content_box``).  A progress bar counts the frames.  Rendered with matplotlib's Agg backend
(optional dependency: ``pip install 'rotlab[plots]'``); GIF through Pillow, MP4 through ffmpeg.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rotlab.core import quaternion as quat
from rotlab.errors import InputError, RunFailure
from rotlab.progress import StreamProgress
from rotlab.recording import layout, style, visuals
from rotlab.recording.plot import pyplot
from rotlab.recording.reader import entity_paths, read_series, read_static, read_text

MAX_FRAMES = 3000
MESH = (36, 18)  # ellipsoid mesh: longitude × latitude lines (fine enough that its faces sort front to back)


def _ellipsoid(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(half sizes, centre, xyzw) of the body's equivalent ellipsoid: as drawn, or for a body given
    by its geometry (drawn as its shapes) from the recorded scenario (``shapes.equivalent_ellipsoid``)."""
    try:
        return tuple(np.asarray(read_static(path, layout.BODY_SHAPE, f"Ellipsoids3D:{c}")[0], dtype=float)  # type: ignore[return-value]
                     for c in ("half_sizes", "centers", "quaternions"))
    except KeyError:
        import json

        from rotlab.config.models import Body
        from rotlab.recording.shapes import equivalent_ellipsoid

        shape = equivalent_ellipsoid(Body.model_validate(json.loads(read_text(path, layout.SCENARIO))["scenario"]["body"]))
        return shape.half_sizes, shape.center, np.r_[shape.orientation[1:], shape.orientation[0]]


def _at(t_frames: np.ndarray, t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The sample nearest (at or before) each frame time."""
    return values[np.clip(np.searchsorted(t, t_frames, side="right") - 1, 0, len(t) - 1)]


def frame_times(start: float, end: float, fps: float, speed: float) -> np.ndarray:
    """t₀ + k · speed / fps for k = 0, 1, … up to the recording's end."""
    count = int(np.floor((end - start) * fps / speed + 1e-9)) + 1
    if count > MAX_FRAMES:
        raise InputError("--speed", f"{count:,} frames at {fps:g} fps: more than {MAX_FRAMES:,}; raise --speed "
                                    f"(e.g. {speed * count / MAX_FRAMES:.3g}) or lower --fps")
    return start + np.arange(count) * speed / fps


def animate(recording: Path, output: Path, fps: float = 20.0, speed: float = 1.0, size: tuple[int, int] = (640, 640),
            progress=None) -> Path:
    """Write the animation; returns ``output``.  ``progress.written(frames done, frames)`` after each
    frame (default: a bar on stderr, ``rotlab.progress.StreamProgress``)."""
    suffix = output.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise InputError("--output", f"'{output.name}': give a name ending in .gif or .mp4")
    if not (0 < fps <= 60):
        raise InputError("--fps", f"{fps:g} is outside (0, 60]")
    if not (0 < speed < float("inf")):
        raise InputError("--speed", f"must be a positive factor (got {speed:g})")
    if not recording.is_file():
        raise InputError(str(recording), "no such recording")
    plt = pyplot("rotlab animate")
    from matplotlib import animation

    if suffix == ".mp4" and not animation.writers.is_available("ffmpeg"):
        raise RunFailure("an .mp4 needs ffmpeg on PATH (Debian: apt-get install ffmpeg); or write a .gif")
    from rotlab.recording.writer import check_output_path

    check_output_path(output)
    try:
        t, q = read_series(recording, layout.QUATERNION)
    except Exception:
        raise InputError(str(recording), "not a rotlab run recording (no /body/quaternion series)") from None
    scene = _read_scene(recording, t)
    times = frame_times(float(t[0]), float(t[-1]), fps, speed)
    fig = plt.figure(figsize=(size[0] / 100, size[1] / 100), dpi=100, facecolor="#101010")
    ax = fig.add_axes((0, 0, 1, 1), projection="3d", facecolor="#101010")
    draw = _frame_drawer(ax, scene, t, q, scene["box"])
    _legend(fig, scene)
    tmp = output.with_name(f".{output.stem}.{os.getpid()}.tmp{suffix}")
    writer = animation.PillowWriter(fps=fps) if suffix == ".gif" else animation.FFMpegWriter(fps=fps, bitrate=2400)
    shown = progress if progress is not None else StreamProgress(f"animate {output.name}", unit="frames")
    try:
        with writer.saving(fig, str(tmp), dpi=100):
            for k, when in enumerate(times):
                draw(float(when))
                writer.grab_frame(facecolor="#101010")
                shown.written(k + 1, len(times))
        os.replace(tmp, output)
    finally:
        if progress is None:
            shown.close()
        tmp.unlink(missing_ok=True)
        plt.close(fig)
    return output


def _read_scene(path: Path, t: np.ndarray) -> dict:
    """Everything the frames need, read from the recording."""
    half, center, xyzw = _ellipsoid(path)
    axes_length = float(np.max(np.abs(np.asarray(read_static(path, layout.BODY_AXES, "Arrows3D:vectors"), dtype=float))))
    _, omega = read_series(path, layout.OMEGA)
    entities = entity_paths(path)
    arrows = {}  # symbol → (times, origins, vectors, colour)
    for entity, symbol, color in ((layout.OMEGA_ARROW, "ω", style.OMEGA), (layout.L_ARROW, "L", style.L)):
        t_a, v = read_series(path, entity, "Arrows3D:vectors")
        arrows[symbol] = (t_a, np.zeros((len(t_a), 3)), v.reshape(-1, 3), color)
    for entity in sorted(e for e in entities if e.startswith(layout.LOADS_3D + "/") and e.endswith("/arrow")):
        t_a, v = read_series(path, entity, "Arrows3D:vectors")
        _, o = read_series(path, entity, "Arrows3D:origins")
        arrows[entity.split("/")[-2]] = (t_a, o.reshape(-1, 3), v.reshape(-1, 3), style.LOAD)
    t_tip, tips = read_series(path, layout.AXIS_TIP, "Points3D:positions")
    scene = {"half": half, "center": center, "orientation": np.roll(xyzw, 1), "axes_length": axes_length,
             "arrows": arrows, "tips": (t_tip, tips.reshape(-1, 3)), "window": visuals.trail_window(t, omega)}
    return {**scene, "box": _content_box(scene)}


def _content_box(scene: dict) -> tuple[np.ndarray, float]:
    """(centre, half width) of a cube holding everything any frame draws: the body and its axes in
    every attitude (a ball about the fixed point), the arrows with their labels, the trace."""
    body = max(scene["axes_length"] * visuals.LABEL_BEYOND, float(np.linalg.norm(scene["center"]) + scene["half"].max()))
    points = [np.array([[-body] * 3, [body] * 3]), scene["tips"][1]]
    for _, origins, vectors, _ in scene["arrows"].values():
        points += [origins, origins + visuals.LABEL_BEYOND * vectors]
    everything = np.concatenate([p[np.all(np.isfinite(p), axis=1)] for p in points])
    low, high = everything.min(axis=0), everything.max(axis=0)
    return 0.5 * (low + high), 0.5 * float(np.max(high - low))


ELEVATION, AZIMUTH = 22.0, -58.0  # degrees: the camera (matplotlib's view_init)
POINTS_PER_LINE = 48  # a line is cut into this many pieces, each drawn in front of the body or behind it


def toward_camera(elevation: float = ELEVATION, azimuth: float = AZIMUTH) -> np.ndarray:
    """The unit vector from the scene toward matplotlib's camera at (elevation, azimuth) degrees."""
    e, a = np.radians(elevation), np.radians(azimuth)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def behind(points: np.ndarray, center: np.ndarray, axes: np.ndarray, half: np.ndarray, camera: np.ndarray) -> np.ndarray:
    """(n,) True where the ray from a point toward the camera passes through the solid ellipsoid
    (centre ``center``, columns of ``axes`` its axes, semi-axes ``half``; space frame): that point
    is hidden by the body.  In the ellipsoid's frame scaled to the unit sphere, p + s d meets it
    for some s > 0 when |p + s d|² = 1 has a positive root."""
    p = (points - center) @ axes / half
    d = (camera @ axes) / half
    a, b, c = d @ d, 2.0 * p @ d, np.einsum("ij,ij->i", p, p) - 1.0
    disc = b * b - 4.0 * a * c
    root = (-b + np.sqrt(np.maximum(disc, 0.0))) / (2.0 * a)  # the farther crossing
    return (disc > 0.0) & (root > 0.0)


def _frame_drawer(ax, scene: dict, t: np.ndarray, q: np.ndarray, box: tuple[np.ndarray, float]):
    """draw(when): the frame at time ``when`` within ``box`` (centre, half width), from the camera
    (``ELEVATION``, ``AZIMUTH``): the body opaque, every line and label in front of it or behind
    it piece by piece (``behind``), each arrow labelled with its symbol at its tip."""
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, MESH[0]), np.linspace(0, np.pi, MESH[1]))
    unit_sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
    shape_rot = quat.to_matrix(scene["orientation"])
    body_points = unit_sphere * scene["half"] @ shape_rot.T + scene["center"]  # body frame
    body_color = np.array(style.BODY) / 255
    camera = toward_camera()
    middle, width = box

    def rgb(c):
        return np.array(c[:3]) / 255

    def line(points: np.ndarray, color, covered, width: float = 2.0) -> None:
        """``points`` (a polyline, space frame), each piece in front of the body or behind it
        (``covered``: the frame's ``behind`` test)."""
        hidden = covered(points)
        cuts = np.flatnonzero(np.diff(hidden.astype(int))) + 1
        for piece in np.split(np.arange(len(points)), cuts):
            ends = np.arange(max(piece[0] - 1, 0), piece[-1] + 1)  # (joined to the previous piece)
            segment = points[ends]
            ax.plot(segment[:, 0], segment[:, 1], segment[:, 2], color=color, linewidth=width, zorder=0 if hidden[piece[0]] else 3)

    def arrow(origin: np.ndarray, vector: np.ndarray, color, label: str, covered, width: float = 2.0) -> None:
        """A shaft, a head, and ``label`` just beyond the tip."""
        tip = origin + vector
        line(origin + np.linspace(0.0, 0.88, POINTS_PER_LINE)[:, None] * vector, color, covered, width)
        front = not covered(tip[None, :])[0]
        ax.quiver(*(origin + 0.86 * vector), *(0.14 * vector), color=color, linewidth=width, arrow_length_ratio=1.0, zorder=3 if front else 0)
        ax.text(*tip, f"  {label}", color=color, fontsize=10, ha="left", va="bottom", zorder=4 if front else 0)  # beside the tip: off parallel shafts

    def draw(when: float) -> None:
        ax.cla()
        ax.set_axis_off()
        ax.computed_zorder = False  # drawn in zorder: behind the body, the body, in front of it
        for set_limits, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), middle):
            set_limits(c - width, c + width)
        ax.set_box_aspect((1, 1, 1), zoom=1.25)
        ax.view_init(elev=ELEVATION, azim=AZIMUTH)
        unit = _at(np.array([when]), t, q)[0]
        unit = unit / np.linalg.norm(unit)
        rot = quat.to_matrix(unit)
        centre, body_axes = rot @ scene["center"], rot @ shape_rot  # the body's ellipsoid in space, this frame

        def covered(points: np.ndarray) -> np.ndarray:
            return behind(points, centre, body_axes, scene["half"], camera)

        pts = body_points @ rot.T
        ax.plot_surface(pts[..., 0], pts[..., 1], pts[..., 2], color=body_color, linewidth=0, shade=True, alpha=1.0, zorder=1)
        for symbol, (t_a, origins, vectors, color) in scene["arrows"].items():  # (before the shorter body axes: ω ∥ L ∥ z stay apart)
            o, vec = _at(np.array([when]), t_a, origins)[0], _at(np.array([when]), t_a, vectors)[0]
            if np.all(np.isfinite(vec)) and np.all(np.isfinite(o)) and np.linalg.norm(vec) > 0:
                arrow(o, vec, rgb(color), symbol, covered)
        for k, (color, name) in enumerate(zip(style.XYZ, "xyz")):
            arrow(np.zeros(3), rot[:, k] * scene["axes_length"], rgb(color), name, covered, width=1.6)
        t_tip, tips = scene["tips"]
        recent = (t_tip <= when) & (t_tip >= when - scene["window"])
        if np.count_nonzero(recent) > 1:
            line(tips[recent], rgb(style.AXIS_TRACE), covered, width=1.2)
        ax.text2D(0.03, 0.95, f"t = {when:.2f} s", transform=ax.transAxes, color="white", fontsize=11)

    return draw


def _legend(fig, scene: dict) -> None:
    """What each colour is, in a corner outside the body's way."""
    from matplotlib.lines import Line2D

    def handle(color, name):
        return Line2D([0], [0], color=np.array(color[:3]) / 255, linewidth=2, label=name)

    handles = [handle(style.OMEGA, "ω angular velocity"), handle(style.L, "L angular momentum")]
    if any(symbol not in ("ω", "L") for symbol in scene["arrows"]):
        handles.append(handle(style.LOAD, "loads (F: force, M: torque)"))
    handles += [handle(style.AXIS_TRACE, "reference axis tip, recent"), handle(style.X_RED, "body axes x, y, z")]
    legend = fig.legend(handles=handles, loc="lower left", fontsize=8, frameon=False, labelcolor="white", handlelength=1.5)
    legend.set_zorder(5)
