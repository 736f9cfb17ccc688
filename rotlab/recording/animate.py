"""``rotlab animate``: a GIF or MP4 of the body, read back from a run recording.

Each frame shows what the 3D view shows, in the same colours (``style``): the equivalent
ellipsoid turned by Λ(t) (``/body/quaternion``, float64), the body axes x, y, z, the ω and L
arrows (``/world/omega``, ``/world/L``: already scaled, space frame), each load's arrow
(``/world/loads/<symbol>/arrow``) and the tip of the reference axis (symmetry axis, else spin axis) with a trailing
trace over the same window as the viewer's (``visuals.trail_window``).  Frame k shows the
recording at t₀ + k · speed / fps (nearest sample).  Rendered with matplotlib's Agg backend
(optional dependency: ``pip install 'rotlab[plots]'``); GIF through Pillow, MP4 through ffmpeg.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rotlab.core import quaternion as quat
from rotlab.errors import InputError, RunFailure
from rotlab.recording import layout, style, visuals
from rotlab.recording.plot import pyplot
from rotlab.recording.reader import entity_paths, read_series, read_static, read_text

MAX_FRAMES = 3000
MESH = (18, 10)  # ellipsoid mesh: longitude × latitude lines


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


def animate(recording: Path, output: Path, fps: float = 20.0, speed: float = 1.0, size: tuple[int, int] = (640, 640)) -> Path:
    """Write the animation; returns ``output``."""
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
    reach = scene["reach"]
    draw = _frame_drawer(ax, scene, t, q, reach)
    tmp = output.with_name(f".{output.stem}.{os.getpid()}.tmp{suffix}")
    writer = animation.PillowWriter(fps=fps) if suffix == ".gif" else animation.FFMpegWriter(fps=fps, bitrate=2400)
    try:
        with writer.saving(fig, str(tmp), dpi=100):
            for when in times:
                draw(float(when))
                writer.grab_frame(facecolor="#101010")
        os.replace(tmp, output)
    finally:
        tmp.unlink(missing_ok=True)
        plt.close(fig)
    return output


def _read_scene(path: Path, t: np.ndarray) -> dict:
    """Everything the frames need, read from the recording."""
    half, center, xyzw = _ellipsoid(path)
    axes_length = float(np.max(np.abs(np.asarray(read_static(path, layout.BODY_AXES, "Arrows3D:vectors"), dtype=float))))
    _, omega = read_series(path, layout.OMEGA)
    entities = entity_paths(path)
    arrows = {}
    for entity, color in ((layout.OMEGA_ARROW, style.OMEGA), (layout.L_ARROW, style.L)):
        t_a, v = read_series(path, entity, "Arrows3D:vectors")
        arrows[entity] = (t_a, np.zeros((len(t_a), 3)), v.reshape(-1, 3), color)
    for entity in sorted(e for e in entities if e.startswith(layout.LOADS_3D + "/") and e.endswith("/arrow")):
        t_a, v = read_series(path, entity, "Arrows3D:vectors")
        _, o = read_series(path, entity, "Arrows3D:origins")
        arrows[entity] = (t_a, o.reshape(-1, 3), v.reshape(-1, 3), style.LOAD)
    t_tip, tips = read_series(path, layout.AXIS_TIP, "Points3D:positions")
    lengths = [np.nanmax(np.linalg.norm(o + v, axis=1), initial=0.0) for _, o, v, _ in arrows.values()]
    return {
        "half": half, "center": center, "orientation": np.roll(xyzw, 1), "axes_length": axes_length,
        "arrows": arrows, "tips": (t_tip, tips.reshape(-1, 3)), "window": visuals.trail_window(t, omega),
        "reach": max([axes_length, float(np.linalg.norm(center) + half.max()), *lengths]),
    }


def _frame_drawer(ax, scene: dict, t: np.ndarray, q: np.ndarray, reach: float):
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, MESH[0]), np.linspace(0, np.pi, MESH[1]))
    unit_sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)], axis=-1)
    shape_rot = quat.to_matrix(scene["orientation"])
    body_points = unit_sphere * scene["half"] @ shape_rot.T + scene["center"]  # body frame
    body_color = np.array(style.BODY) / 255

    def rgb(c):
        return np.array(c[:3]) / 255

    def draw(when: float) -> None:
        ax.cla()
        ax.set_axis_off()
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-reach, reach)
        ax.set_zlim(-reach, reach)
        ax.set_box_aspect((1, 1, 1), zoom=1.5)
        ax.view_init(elev=22, azim=-58)
        unit = _at(np.array([when]), t, q)[0]
        unit = unit / np.linalg.norm(unit)
        rot = quat.to_matrix(unit)
        pts = body_points @ rot.T
        ax.plot_surface(pts[..., 0], pts[..., 1], pts[..., 2], color=body_color, linewidth=0, shade=True, alpha=0.9)
        for k, color in enumerate(style.XYZ):
            end = rot[:, k] * scene["axes_length"]
            ax.plot([0, end[0]], [0, end[1]], [0, end[2]], color=rgb(color), linewidth=2)
        for t_a, origins, vectors, color in scene["arrows"].values():
            o, vec = _at(np.array([when]), t_a, origins)[0], _at(np.array([when]), t_a, vectors)[0]
            if np.all(np.isfinite(vec)) and np.linalg.norm(vec) > 0:
                ax.quiver(*o, *vec, color=rgb(color), linewidth=2, arrow_length_ratio=0.12)
        t_tip, tips = scene["tips"]
        recent = (t_tip <= when) & (t_tip >= when - scene["window"])
        trace = tips[recent]
        if len(trace):
            ax.plot(trace[:, 0], trace[:, 1], trace[:, 2], color=rgb(style.AXIS_TRACE), linewidth=1.2)
        ax.text2D(0.03, 0.95, f"t = {when:.2f} s", transform=ax.transAxes, color="white", fontsize=11)

    return draw
