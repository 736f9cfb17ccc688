"""The recording, read back with Rerun's own reader, equals what was simulated."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rotlab
from rotlab.recording import layout
from rotlab.recording.reader import read_series, read_text
from rotlab.recording.writer import write_recording
from tests.conftest import CONFIGS


@pytest.fixture(scope="module")
def lagrange(tmp_path_factory):
    sc = rotlab.load(CONFIGS / "lagrange.toml", method="rk4", duration=2.0)
    traj = rotlab.simulate(sc)
    path = tmp_path_factory.mktemp("rec") / "lagrange.rrd"
    write_recording(traj, path, chunk_rows=1000)  # several chunks
    return traj, path


def test_time_series_round_trip_exactly(lagrange):
    traj, path = lagrange
    t, q = read_series(path, layout.QUATERNION)
    np.testing.assert_array_equal(np.round(t * 1e9), np.round(traj.t * 1e9))  # ns, no truncation
    np.testing.assert_array_equal(q, traj.quaternion)  # full float64
    np.testing.assert_array_equal(read_series(path, layout.OMEGA)[1], traj.omega)
    np.testing.assert_array_equal(read_series(path, layout.L_SPACE)[1], traj.L_space)
    energy = read_series(path, layout.ENERGY)[1]
    np.testing.assert_array_equal(energy, np.column_stack([traj.kinetic, traj.potential, traj.total]))
    for name, drift in traj.invariants.items():
        np.testing.assert_array_equal(read_series(path, f"{layout.INVARIANTS}/{name}")[1][:, 0], drift)
    np.testing.assert_array_equal(read_series(path, layout.EULER_ANGLES)[1], traj.euler_angles)


def test_pose_transform_is_the_quaternion_in_xyzw(lagrange):
    traj, path = lagrange
    _, xyzw = read_series(path, layout.BODY, "Transform3D:quaternion")
    xyzw = xyzw.reshape(-1, 4)
    unit = traj.quaternion / np.linalg.norm(traj.quaternion, axis=1, keepdims=True)
    np.testing.assert_allclose(xyzw, np.roll(unit, -1, axis=1), atol=1e-7)  # float32 in Rerun


def test_arrows_are_space_frame_L(lagrange):
    traj, path = lagrange
    _, arrows = read_series(path, layout.L_ARROW, "Arrows3D:vectors")
    arrows = arrows.reshape(-1, 3)
    scale = np.linalg.norm(arrows[0]) / np.linalg.norm(traj.L_space[0])
    np.testing.assert_allclose(arrows, traj.L_space * scale, rtol=1e-6, atol=1e-9)


def test_report_names_method_and_drift(lagrange):
    _, path = lagrange
    text = read_text(path, layout.INFO)
    assert "rk4" in text and "L_symmetry" in text and "lagrange" in text


def test_torque_free_scene_records_no_potential(tmp_path):
    traj = rotlab.simulate(rotlab.load(CONFIGS / "euler.toml", duration=1.0))
    path = write_recording(traj, tmp_path / "e.rrd")
    assert read_series(path, layout.ENERGY)[1].shape[1] == 1  # kinetic only
    with pytest.raises(KeyError):
        read_series(path, layout.EULER_ANGLES)


def test_rerun_verify_accepts_every_shipped_config(tmp_path):
    rerun = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    for config in sorted(CONFIGS.glob("*.toml")):
        traj = rotlab.simulate(rotlab.load(config, duration=0.5))
        path = write_recording(traj, tmp_path / f"{config.stem}.rrd")
        done = subprocess.run([rerun, "rrd", "verify", str(path)], capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
    assert not list(tmp_path.glob(".*.tmp"))


def test_failed_write_leaves_nothing_and_keeps_existing_file(tmp_path, monkeypatch):
    traj = rotlab.simulate(rotlab.load(CONFIGS / "euler.toml", duration=0.2))
    target = tmp_path / "keep.rrd"
    target.write_bytes(b"previous recording")
    from rotlab.recording import writer

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(writer, "_write_full_rate", boom)
    from rotlab.errors import RunFailure

    with pytest.raises(RunFailure, match="could not write the recording.*disk full"):
        write_recording(traj, target)
    assert target.read_bytes() == b"previous recording"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.rrd"]
