"""What the user sees: scene geometry in the recording, and a headless snapshot of the viewer."""

from __future__ import annotations

import glob
import subprocess

import numpy as np
import pytest

import rotlab
from rotlab.recording import layout
from rotlab.recording.reader import read_series
from rotlab.recording.writer import _views, write_recording
from tests.conftest import CONFIGS


@pytest.fixture(scope="module")
def euler():
    return rotlab.simulate(rotlab.load(CONFIGS / "euler.toml", duration=5.0))


def test_poinsot_construction_lies_on_its_surfaces(euler):
    """Herpolhode on the invariable plane (distance s·2T/|L| along L̂), polhode on the inertia
    ellipsoid x·Ix = s²·2T (body frame): to 1e-9 relative."""
    views = _views(euler)
    geo, s = views.geometry, views.omega_scale
    plane = geo.invariable_plane
    offsets = (geo.herpolhode - plane.center) @ plane.normal
    assert np.max(np.abs(offsets)) < 1e-9 * np.linalg.norm(plane.center)
    inertia_form = np.einsum("ij,j,ij->i", geo.polhode, euler.scene.moments, geo.polhode)
    np.testing.assert_allclose(inertia_form, s**2 * 2 * euler.kinetic[0], rtol=1e-9)
    assert geo.field_up is None


def test_axis_tip_on_sphere_and_field_for_the_top():
    traj = rotlab.simulate(rotlab.load(CONFIGS / "lagrange.toml", duration=1.0))
    views = _views(traj)
    radii = np.linalg.norm(views.geometry.axis_tips, axis=1)
    np.testing.assert_allclose(radii, radii[0], rtol=1e-9)
    assert views.geometry.axis_label == "symmetry axis tip"
    np.testing.assert_allclose(views.geometry.field_up, [0.0, 0.0, 1.0])
    assert views.geometry.invariable_plane is None


def test_log_drift_series_and_no_needless_series(euler, tmp_path):
    path = write_recording(euler, tmp_path / "e.rrd")
    _, log_drift = read_series(path, f"{layout.INVARIANTS_LOG}/energy")
    drift = euler.invariants["energy"]
    expected = np.log10(np.maximum(np.abs(drift), 1e-17))
    np.testing.assert_array_equal(log_drift[:, 0], expected)
    for absent in (layout.EULER_ANGLES,):
        with pytest.raises(KeyError):
            read_series(path, absent)


def _has_vulkan() -> bool:
    return bool(glob.glob("/usr/share/vulkan/icd.d/*.json"))


@pytest.mark.skipif(not _has_vulkan(), reason="no Vulkan driver: install mesa-vulkan-drivers libvulkan1 (CI does)")
def test_snapshot_renders_the_viewer(cli, tmp_path, euler):
    from PIL import Image

    write_recording(euler, tmp_path / "e.rrd")
    result = cli("snapshot", "e.rrd", "-o", "shot.png", "--time", "2.5", "--size", "960x540")
    assert result.exit_code == 0, result.output
    image = Image.open(tmp_path / "shot.png")
    assert image.size[0] >= 960 and image.size[1] >= 540  # logical points; HiDPI may double
    pixels = np.asarray(image.convert("L"), dtype=float)
    assert pixels.std() > 10.0  # a drawn viewer, not a blank frame
    leftover = subprocess.run(["pgrep", "-f", "rerun.*--headless.*--screenshot|rerun_cli/rerun --headless"], capture_output=True, text=True)
    assert not leftover.stdout.strip(), "the headless viewer outlived the snapshot"


def test_snapshot_refuses_bad_input(cli, tmp_path, euler):
    write_recording(euler, tmp_path / "e.rrd")
    result = cli("snapshot", "e.rrd", "--time", "99")
    assert result.exit_code == 2 and "outside the recording's span" in result.stderr
    result = cli("snapshot", "e.rrd", "--size", "big")
    assert result.exit_code == 2 and "WIDTHxHEIGHT" in result.stderr
    result = cli("snapshot", "missing.rrd")
    assert result.exit_code == 2 and "no such recording" in result.stderr
    assert not list(tmp_path.glob("*.png"))
