"""Write a ``Trajectory`` to a Rerun ``.rrd`` file: columns sent in chunks (``send_columns``,
never one ``log`` per sample), to a temporary file renamed only when complete."""

from __future__ import annotations

import os
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr

from rotlab.core import quaternion as quat
from rotlab.core.quaternion import rotate_to_space_array
from rotlab.errors import InputError, RunFailure
from rotlab.recording import layout
from rotlab.recording.geometry import Geometry, decimate, scene_geometry
from rotlab.recording.report import run_report
from rotlab.recording.shapes import Ellipsoid, equivalent_ellipsoid
from rotlab.trajectory import Trajectory

CHUNK_ROWS = 4096
LOG_FLOOR = 1e-17  # log10 of a zero drift is drawn at −17 (below double precision)
AXIS_COLORS = [(230, 60, 60), (60, 200, 60), (70, 110, 240)]


def check_output_path(path: Path) -> None:
    """Fail early (before a long run) when the output cannot be written: a file is actually
    created and removed beside it (permission bits say little when running as root)."""
    where = f"output {path}"
    if path.exists() and path.is_dir():
        raise InputError(where, "is a directory: give a file name ending in .rrd")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(where, f"directory {parent} does not exist: create it or choose another path")
    probe = parent / f".{path.name}.{os.getpid()}.probe"
    try:
        probe.touch(exist_ok=False)
        probe.unlink()
    except OSError as exc:
        raise InputError(where, f"cannot write in {parent} ({exc.strerror}): choose another path with -o") from None


def partial_path(path: Path) -> Path:
    """Where the valid part of an incomplete run goes: ``name.partial.rrd`` beside ``path``."""
    return path.with_name(f"{path.stem}.partial{path.suffix or '.rrd'}")


def write_recording(traj: Trajectory, path: str | Path, chunk_rows: int = CHUNK_ROWS) -> Path:
    """Write ``traj`` to ``path`` atomically; returns the path."""
    path = Path(path)
    check_output_path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        with np.errstate(over="ignore", invalid="ignore"):  # display-only float32 casts of a run that blew up
            views = _views(traj)
            rec = rr.RecordingStream("rotlab", recording_id=uuid.uuid4())
            bp = layout.blueprint(list(traj.invariants), traj.euler_angles is not None, energy_range(views.series))
            rec.save(tmp, default_blueprint=bp)
            _write_static(rec, traj, views)
            _write_series(rec, traj, views, chunk_rows)
        rec.flush()
        rec.disconnect()
        os.replace(tmp, path)
    except (OSError, RuntimeError) as exc:  # disk full, file system gone: nothing half-written stays
        tmp.unlink(missing_ok=True)
        raise RunFailure(f"could not write the recording {path}: {exc}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def energy_range(all_series: dict[str, tuple[np.ndarray, list[str]]], min_span: float = 0.02) -> tuple[float, float] | None:
    """The energy plot's y range: the data, widened to at least ``min_span`` of the energy scale."""
    values = all_series[layout.ENERGY][0]
    finite = values[np.isfinite(values)]
    if not finite.size:
        return None
    low, high = float(finite.min()), float(finite.max())
    span = max(high - low, min_span * max(abs(low), abs(high), 1e-300))
    middle = 0.5 * (low + high)
    return middle - 0.55 * span, middle + 0.55 * span


def series(traj: Trajectory) -> dict[str, tuple[np.ndarray, list[str]]]:
    """Every time series of the layout: entity → ((N, k) float64 values, k series names)."""
    q = traj.quaternion
    out: dict[str, tuple[np.ndarray, list[str]]] = {
        layout.QUATERNION: (q, ["q0", "q1", "q2", "q3"]),
        layout.OMEGA: (traj.omega, ["p = ω_x (rad/s)", "q = ω_y (rad/s)", "r = ω_z (rad/s)"]),
        layout.L_SPACE: (traj.L_space, ["L_X space (kg·m²/s)", "L_Y space (kg·m²/s)", "L_Z space (kg·m²/s)"]),
    }
    energy, names = [traj.kinetic], ["kinetic T (J)"]
    if traj.potential is not None:
        energy += [traj.potential, traj.total]
        names += ["potential V (J)", "total T + V (J)"]
    if traj.work is not None:
        energy.append(traj.work)
        names.append("work W of non-conservative loads (J)")
    out[layout.ENERGY] = (np.column_stack(energy), names)
    for name, drift in traj.invariants.items():
        out[f"{layout.INVARIANTS}/{name}"] = (drift[:, None], [INVARIANT_LABELS.get(name, name)])
        with np.errstate(divide="ignore"):
            magnitude = np.log10(np.maximum(np.abs(drift), LOG_FLOOR))
        out[f"{layout.INVARIANTS_LOG}/{name}"] = (magnitude[:, None], [f"log10 |{INVARIANT_LABELS.get(name, name)}|"])
    if traj.euler_angles is not None:
        out[layout.EULER_ANGLES] = (traj.euler_angles, ["ψ precession (rad)", "θ nutation (rad)", "φ spin (rad)"])
    return out


INVARIANT_LABELS = {
    "energy": "(H − H₀)/scale, H = T + V − W",
    "quaternion_norm": "|Λ| − 1",
    "L_norm": "(|L| − |L₀|)/|L₀|",
    "L_space": "|L − L₀|/|L₀| (space frame)",
    "L_vertical": "ΔL·up/|L₀| (space frame)",
    "L_symmetry": "ΔL·e_sym/|L₀| (body frame)",
}


@dataclass(frozen=True)
class _Views:
    """What the static and temporal parts share: computed once per recording."""

    shape: Ellipsoid
    unit_q: np.ndarray  # (N, 4) normalised, for display
    omega_space: np.ndarray  # (N, 3)
    omega_scale: float  # arrow length per rad/s
    L_scale: float  # arrow length per kg·m²/s
    geometry: Geometry
    series: dict[str, tuple[np.ndarray, list[str]]]  # every time series: see ``series``


def _views(traj: Trajectory) -> _Views:
    shape = equivalent_ellipsoid(traj.scene.scenario.body)
    unit_q = traj.quaternion / np.linalg.norm(traj.quaternion, axis=1, keepdims=True)
    omega_space = rotate_to_space_array(unit_q, traj.omega)
    omega_scale = _arrow_scale(omega_space, shape.size)
    geometry = scene_geometry(traj, unit_q, omega_space, omega_scale, reach=1.3 * shape.size)
    return _Views(shape, unit_q, omega_space, omega_scale, _arrow_scale(traj.L_space, shape.size), geometry, series(traj))


def _write_static(rec: rr.RecordingStream, traj: Trajectory, views: _Views) -> None:
    shape, size, geo = views.shape, views.shape.size, views.geometry
    rec.log(
        layout.BODY_SHAPE,
        rr.Ellipsoids3D(
            half_sizes=[shape.half_sizes],
            centers=[shape.center],
            quaternions=[rr.Quaternion(xyzw=_xyzw(shape.orientation))],
            colors=[(200, 170, 90)],
            fill_mode="solid",
        ),
        static=True,
    )
    rec.log(
        layout.BODY_AXES,
        rr.Arrows3D(vectors=np.eye(3) * 1.3 * size, colors=AXIS_COLORS, labels=["x body", "y body", "z body"]),
        static=True,
    )
    r_c = np.asarray(traj.scene.scenario.body.center_of_mass, dtype=float)
    if np.any(r_c != 0.0):
        rec.log(layout.BODY_ARM, rr.LineStrips3D([[np.zeros(3), r_c]], colors=[(40, 40, 40)], labels=["r_c"]), static=True)
    rec.log(layout.AXIS_PATH, rr.LineStrips3D([decimate(geo.axis_tips)], colors=[(120, 190, 255)], radii=[0.004 * size]), static=True)
    rec.log(layout.AXIS_TIP, rr.Points3D.from_fields(colors=[(120, 190, 255)], radii=[0.02 * size], labels=[geo.axis_label]), static=True)
    if geo.field_up is not None:
        rec.log(layout.FIELD, rr.Arrows3D(vectors=[-geo.field_up * 0.8 * size], origins=[geo.field_up * 1.6 * size],
                                          colors=[(150, 150, 150)], labels=["g (field)"]), static=True)
    if geo.invariable_plane is not None:
        plane = geo.invariable_plane
        rec.log(layout.INVARIABLE_PLANE, rr.Boxes3D(
            half_sizes=[[plane.half_size, plane.half_size, 1e-3 * plane.half_size]], centers=[plane.center],
            quaternions=[rr.Quaternion(xyzw=_xyzw(quat.between([0.0, 0.0, 1.0], plane.normal)))],
            colors=[(90, 90, 140, 90)], fill_mode="solid", labels=["invariable plane (normal to L)"]), static=True)
        rec.log(layout.HERPOLHODE, rr.LineStrips3D([geo.herpolhode], colors=[(240, 150, 30)], radii=[0.003 * size],
                                                   labels=["herpolhode"]), static=True)
        rec.log(layout.BODY_POLHODE, rr.LineStrips3D([geo.polhode], colors=[(255, 210, 120)], radii=[0.003 * size],
                                                     labels=["polhode"]), static=True)
    for entity, (_, names) in views.series.items():
        rec.log(entity, rr.SeriesLines(names=names), static=True)
    for entity, scale, label, color in ((layout.OMEGA_ARROW, views.omega_scale, "ω", (240, 150, 30)),
                                        (layout.L_ARROW, views.L_scale, "L", (150, 60, 220))):
        rec.log(entity, rr.Arrows3D.from_fields(labels=[f"{label} ×{scale:.3g}"], colors=[color]), static=True)
    rec.log(layout.INFO, rr.TextDocument(run_report(traj), media_type="text/markdown"), static=True)


def _write_series(rec: rr.RecordingStream, traj: Trajectory, views: _Views, chunk_rows: int) -> None:
    n = traj.t.shape[0]
    ns = np.round(traj.t * 1e9).astype(np.int64).astype("timedelta64[ns]")
    vectors = {
        layout.OMEGA_ARROW: views.omega_space * views.omega_scale,
        layout.L_ARROW: traj.L_space * views.L_scale,
    }
    for start in range(0, n, chunk_rows):
        rows = slice(start, min(start + chunk_rows, n))
        index = [rr.TimeColumn(layout.TIMELINE, duration=ns[rows])]
        rec.send_columns(layout.BODY, index, rr.Transform3D.columns(quaternion=_xyzw(views.unit_q[rows])))
        rec.send_columns(layout.AXIS_TIP, index, rr.Points3D.columns(positions=views.geometry.axis_tips[rows]))
        for entity, values in vectors.items():
            rec.send_columns(entity, index, rr.Arrows3D.columns(vectors=values[rows]))
        for entity, (values, _) in views.series.items():
            rec.send_columns(entity, index, rr.Scalars.columns(scalars=values[rows]))


def _arrow_scale(vectors: np.ndarray, size: float) -> float:
    """Factor that makes the longest finite arrow 1.5 body sizes long."""
    with np.errstate(over="ignore"):
        lengths = np.linalg.norm(vectors, axis=1)
    finite = lengths[np.isfinite(lengths)]
    longest = float(finite.max()) if finite.size else 0.0
    return 1.5 * size / longest if longest > 0.0 else 1.0


def _xyzw(q: np.ndarray) -> np.ndarray:
    """Rerun's quaternion order (x, y, z, w) from scalar-first (w, x, y, z)."""
    return np.roll(q, -1, axis=-1)
