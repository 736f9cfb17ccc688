"""What the user sees: scene geometry in the recording, and a headless snapshot of the viewer."""

from __future__ import annotations

import glob
import os
import subprocess
import time
from pathlib import Path

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
def test_snapshot_renders_the_viewer(cli, tmp_path, euler, monkeypatch):
    from PIL import Image

    tag = f"{os.getpid()}-{time.monotonic_ns()}"
    monkeypatch.setenv("ROTLAB_SNAPSHOT_TEST", tag)  # the viewer inherits it: ours is told from another test's
    write_recording(euler, tmp_path / "e.rrd")
    result = cli("snapshot", "e.rrd", "-o", "shot.png", "--time", "2.5", "--size", "960x540")
    assert result.exit_code == 0, result.output
    image = Image.open(tmp_path / "shot.png")
    assert image.size[0] >= 960 and image.size[1] >= 540  # logical points; HiDPI may double
    pixels = np.asarray(image.convert("L"), dtype=float)
    assert pixels.std() > 10.0  # a drawn viewer, not a blank frame
    found = subprocess.run(["pgrep", "-f", "rerun.*--headless.*--screenshot|rerun_cli/rerun --headless"], capture_output=True, text=True)
    assert not [pid for pid in found.stdout.split() if _has_environment(pid, f"ROTLAB_SNAPSHOT_TEST={tag}")], \
        "the headless viewer outlived the snapshot"


def _has_environment(pid: str, entry: str) -> bool:
    """Process ``pid`` (still alive) has ``entry`` in its environment: a viewer this test started,
    even if it outlived its parent (another test's viewer, under pytest -n 2, has another tag)."""
    try:
        return entry.encode() in Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
    except OSError:
        return False


@pytest.mark.skipif(not _has_vulkan(), reason="no Vulkan driver: install mesa-vulkan-drivers libvulkan1 (CI does)")
@pytest.mark.parametrize("config, args", [
    ("general.toml", ["--set", "time.end=200"]),  # 40,001 samples
    ("lagrange.toml", ["--method", "taylor", "--duration", "100", "--set", "time.sample_rate=400"]),  # 40,001, gravity, stepping
    # the matrix: each scene kind, 10³ … 10⁶ samples, past the visual thinning (``output.visual_samples``, 10⁵)
    ("euler.toml", ["--method", "dmv", "--duration", "10", "--set", "time.sample_rate=100"]),  # 1,001, torque-free
    ("euler.toml", ["--method", "exact", "--duration", "1000", "--set", "time.sample_rate=1000"]),  # 1,000,001
    ("dzhanibekov.toml", ["--method", "rk4", "--duration", "500", "--set", "time.sample_rate=200"]),  # 100,001
    ("lagrange.toml", ["--method", "splitting", "--duration", "10", "--set", "time.sample_rate=100"]),  # 1,001, Lagrange top
    ("general.toml", ["--method", "rkmk4", "--duration", "500", "--set", "time.sample_rate=200"]),  # 100,001, every load kind
    ("detumbling.toml", ["--method", "dop853", "--duration", "1000", "--set", "time.sample_rate=100"]),  # 100,001, controller
    ("gyrostat.toml", ["--method", "splitting", "--duration", "1000", "--set", "time.sample_rate=100"]),  # 100,001, rotors
    ("wheel_slew.toml", ["--method", "rk4", "--duration", "60", "--set", "time.sample_rate=20"]),  # 1,201, driven rotors
])
def test_a_long_run_with_loads_opens_in_the_viewer(cli, tmp_path, config, args):
    """Every recording opens in the real viewer (headless, ``rotlab snapshot``), whatever its scene
    kind and length.  Rerun 0.41's viewer panicked on the first two files (exit 102, "transport
    error" from `snapshot`): a visual chunk with no sample where the loads are evaluated sent an
    empty load-arrow chunk, whose time range is the whole timeline.  The sink sends no empty chunk."""
    from PIL import Image

    result = cli("run", str(CONFIGS / config), "-o", "long.rrd", "-q", *args)
    assert result.exit_code == 0, result.stderr
    result = cli("snapshot", "long.rrd", "-o", "long.png", "--size", "960x540")
    assert result.exit_code == 0, result.stderr
    assert np.asarray(Image.open(tmp_path / "long.png").convert("L"), dtype=float).std() > 10.0


def test_snapshot_refuses_bad_input(cli, tmp_path, euler):
    write_recording(euler, tmp_path / "e.rrd")
    result = cli("snapshot", "e.rrd", "--time", "99")
    assert result.exit_code == 2 and "outside the recording's span" in result.stderr
    result = cli("snapshot", "e.rrd", "--size", "big")
    assert result.exit_code == 2 and "WIDTHxHEIGHT" in result.stderr
    result = cli("snapshot", "missing.rrd")
    assert result.exit_code == 2 and "no such recording" in result.stderr
    assert not list(tmp_path.glob("*.png"))


# --- #13: blueprints that show data, one colour language, labels that render ------------------

from rerun.chunk import RrdReader  # noqa: E402

from rotlab.recording import style  # noqa: E402
from rotlab.recording.reader import entity_paths, query_matches, view_queries  # noqa: E402

SHIPPED = ("euler", "lagrange", "dzhanibekov", "general")


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """Every shipped config (2 s of it) written as a recording: name → (trajectory, path)."""
    out = {}
    folder = tmp_path_factory.mktemp("shipped")
    for name in SHIPPED:
        traj = rotlab.simulate(rotlab.load(CONFIGS / f"{name}.toml", duration=2.0))
        out[name] = (traj, write_recording(traj, folder / f"{name}.rrd"))
    return out


def _assert_every_view_shows_data(path):
    entities = entity_paths(path)
    views = view_queries(path)
    assert views, f"{path}: no blueprint"
    for name, origin, query in views.values():
        assert query_matches(query, origin, entities), f"{path}: view {name!r} (origin {origin}, query {query}) shows nothing"


def test_query_matching_follows_rerun_rules():
    entities = {"/cases/0/omega", "/cases/1/omega", "/sweep"}
    assert query_matches(["/cases/*/omega"], "/cases", entities) == set()  # the old sweep blueprint's bug
    assert query_matches(["$origin/**"], "/cases", entities) == {"/cases/0/omega", "/cases/1/omega"}
    assert query_matches(["+ /cases/**", "- /cases/1/**"], "/", entities) == {"/cases/0/omega"}


def test_every_view_of_every_run_recording_shows_data(recordings):
    for _, path in recordings.values():
        _assert_every_view_shows_data(path)


def _static_component(path, entity, component):
    for chunk in RrdReader(str(path)).stream().filter(content=entity, is_static=True, components=component).to_chunks():
        batch = chunk.to_record_batch()
        return batch.column(batch.schema.get_field_index(component)).to_pylist()[-1]
    raise KeyError(f"no static {component} at {entity}")


def _rgb(packed: int) -> tuple[int, int, int]:
    return (packed >> 24) & 255, (packed >> 16) & 255, (packed >> 8) & 255


def test_components_are_red_green_blue_and_energies_distinct(recordings):
    for name, (_, path) in recordings.items():
        for entity in (layout.OMEGA, layout.L_SPACE):
            assert [_rgb(c) for c in _static_component(path, entity, "SeriesLines:colors")] == style.XYZ, (name, entity)
        axes = [_rgb(c) for c in _static_component(path, layout.BODY_AXES, "Arrows3D:colors")]
        assert axes == style.XYZ, name
    general = recordings["general"][1]
    if layout.LOAD_TORQUE_BODY in entity_paths(general):
        assert [_rgb(c) for c in _static_component(general, layout.LOAD_TORQUE_BODY, "SeriesLines:colors")] == style.XYZ
    energy = [_rgb(c) for c in _static_component(general, layout.ENERGY, "SeriesLines:colors")]
    names = _static_component(general, layout.ENERGY, "SeriesLines:names")
    assert names == ["T", "V", "T+V", "W", "T+V−W"]
    for i in range(len(energy)):  # five hues, pairwise far apart (RGB distance > 100 of 441)
        for j in range(i):
            assert np.linalg.norm(np.subtract(energy[i], energy[j])) > 100, (names[i], names[j])


def test_labels_are_short_symbols_the_font_draws(recordings):
    for name, (_, path) in recordings.items():
        for chunk in RrdReader(str(path)).stream().to_chunks():
            batch = chunk.to_record_batch()
            for column in batch.schema.names:
                if column.endswith(":labels"):
                    for row in batch.column(column).to_pylist():
                        for label in row or []:
                            style.label_3d(label)  # raises on a long label or a missing glyph
                if column.endswith(":names") or column.endswith("TextDocument:text") or column.endswith(":display_name"):
                    for row in batch.column(column).to_pylist():
                        for text in (row if isinstance(row, list) else [row]):
                            style.check_text(str(text).replace("\n", " ").replace("\t", " "))


def test_label_rules_refuse_what_the_viewer_cannot_show():
    with pytest.raises(ValueError, match="glyph"):
        style.check_text("plane ⊥ L")
    with pytest.raises(ValueError, match="longer"):
        style.label_3d("ω ×0.0009")
    assert style.label_3d("mg") == "mg"


def test_legends_sit_above_the_data(recordings):
    from rotlab.recording.writer import series

    for name, (traj, _) in recordings.items():
        all_series = series(traj)
        for plots in layout.plots(all_series, "rad", 0.0).values():
            for plot in plots:
                if not plot.legend or plot.y_range is None:
                    continue
                values = np.column_stack([v[0] for e, v in all_series.items() if e == plot.origin or e.startswith(plot.origin + "/")])
                finite = values[np.isfinite(values)]
                span = max(float(np.ptp(finite)), 1e-300)
                assert plot.y_range[1] >= finite.max() + 0.4 * span - 1e-12 * abs(finite.max()), (name, plot.name)


def test_euler_angles_in_degrees_for_a_degree_scenario(recordings):
    traj, path = recordings["lagrange"]  # euler_313_deg = [0, 25, 0]
    _, theta = read_series(path, layout.EULER_THETA)
    assert theta[0, 0] == pytest.approx(25.0, abs=1e-9)
    _, psi = read_series(path, layout.EULER_PSI)
    assert np.all(np.abs(psi) <= 180.0)
    _, rate = read_series(path, layout.EULER_SPIN_RATE)
    psi_dot = np.gradient(traj.euler_angles[:, 0], traj.t)  # φ̇ = r − ψ̇ cos θ, ψ̇ by differences
    expected = np.degrees(traj.omega[:, 2] - psi_dot * np.cos(traj.euler_angles[:, 1]))
    np.testing.assert_allclose(rate[2:-2, 0], expected[2:-2], rtol=2e-3)


def test_energy_ellipsoid_touches_the_invariable_plane_at_omega(euler):
    """At every sample the tip s·ω lies on the energy ellipsoid x·Ix = s²·2T (body frame) and the
    ellipsoid's normal there, I ω, is along L: the plane ⊥ L through s·ω is tangent to it."""
    from rotlab.recording.visuals import energy_ellipsoid

    views = _views(euler)
    s = views.omega_scale
    _, semi, _ = energy_ellipsoid(euler, s)
    tip = euler.omega * s  # principal = user's frame for this config
    np.testing.assert_allclose(np.sum((tip / semi) ** 2, axis=1), 1.0, rtol=1e-9)
    normal = tip * euler.scene.moments
    cosine = np.einsum("ij,ij->i", normal, euler.L_body) / np.linalg.norm(normal, axis=1) / np.linalg.norm(euler.L_body, axis=1)
    np.testing.assert_allclose(cosine, 1.0, atol=1e-12)


def test_load_power_integrates_to_the_work(recordings):
    """The loads' torque drawn in the recording, dotted with ω and integrated (trapezoid, 200
    samples/s), equals the work W the integrator accumulated: to 1e-3 of max |W|.  The run ends at
    t = 2 s where the space-frame pulse switches on: the last sample (right limit) is left out."""
    traj, path = recordings["general"]
    t, power = read_series(path, layout.LOAD_POWER)
    t, power = t[:-1], power[:-1, 0] * 1e-3  # drawn in mW (general.toml's power is ~0.1–0.7 W: ``visuals.plot_unit``)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    np.testing.assert_allclose(work, traj.work[:-1] - traj.work[0], atol=1e-3 * np.max(np.abs(traj.work)))
    _, body = read_series(path, layout.LOAD_TORQUE_BODY)
    _, space = read_series(path, layout.LOAD_TORQUE_SPACE)
    unit = traj.quaternion / np.linalg.norm(traj.quaternion, axis=1, keepdims=True)
    from rotlab.core import quaternion as quat

    np.testing.assert_allclose(quat.rotate_to_space_array(unit, body), space, atol=1e-12)


def test_each_load_has_an_arrow_at_its_point(recordings):
    traj, path = recordings["general"]
    _, origins = read_series(path, f"{layout.LOADS_3D}/mg/arrow", "Arrows3D:origins")
    from rotlab.core import quaternion as quat

    unit = traj.quaternion / np.linalg.norm(traj.quaternion, axis=1, keepdims=True)
    r_c = np.asarray(traj.scene.scenario.body.center_of_mass)
    expected = quat.rotate_to_space_array(unit, np.broadcast_to(r_c, (len(unit), 3)))
    np.testing.assert_allclose(origins.reshape(-1, 3), expected, atol=1e-6)  # float32 in Rerun
    for symbol in ("M1", "M2", "M3", "M4"):
        read_series(path, f"{layout.LOADS_3D}/{symbol}/arrow", "Arrows3D:vectors")


def test_trails_have_a_trailing_window_in_the_blueprint(recordings):
    _, path = recordings["euler"]
    names = set()
    for chunk in RrdReader(str(path)).stream(store=RrdReader(str(path)).blueprints()[0]).to_chunks():
        names.update(chunk.to_record_batch().schema.names)
    assert any("VisibleTimeRange" in n for n in names)
    read_series(path, layout.AXIS_TIP, "Points3D:positions")
    read_series(path, layout.HERPOLHODE_TRAIL, "Points3D:positions")


def test_labels_never_overlap_in_the_default_camera_view(recordings):
    """Every label drawn at a sample (axes, ω, L, g, loads), projected with the default camera the
    blueprint sets, keeps its box clear of every other: checked at every sample of every config."""
    from rotlab.recording import labels
    from rotlab.recording.writer import _views

    for name, (traj, path) in recordings.items():
        from rotlab.recording.visuals import reach

        eye, target = labels.camera(reach(traj, _views(traj)))
        reader = RrdReader(str(path))
        set_eye = [chunk.to_record_batch().column("EyeControls3D:position").to_pylist()[-1][0]
                   for chunk in reader.stream(store=reader.blueprints()[0]).to_chunks()
                   if "EyeControls3D:position" in chunk.to_record_batch().schema.names]
        np.testing.assert_allclose(set_eye, [eye], rtol=1e-6)  # the labels were laid out for the view's camera
        texts = _static_component(path, layout.LABELS_3D, "Points3D:labels")
        _, positions = read_series(path, layout.LABELS_3D, "Points3D:positions")
        positions = positions.reshape(len(traj.t), len(texts), 3)
        points = [positions[:, k] for k in range(len(texts))]
        omega = positions[:, texts.index("ω")]
        shown = 0
        for i in range(len(texts)):
            for j in range(i):
                a, b = labels.project(points[i], eye, target), labels.project(points[j], eye, target)
                both = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
                shown += int(both.sum())
                assert not np.any(labels.overlaps(a, b, texts[i], texts[j]) & both), (name, texts[i], texts[j])
        assert shown > 0, name
        assert np.mean(np.isfinite(omega[:, 0])) > 0.5, f"{name}: the ω label is hidden most of the time"


def test_animate_writes_a_gif_of_the_run(cli, tmp_path, recordings):
    """`rotlab animate`: one frame per speed/fps seconds of the recording, frames that change."""
    pytest.importorskip("matplotlib")
    from PIL import Image

    _, path = recordings["lagrange"]  # 2 s recorded
    result = cli("animate", str(path), "-o", "top.gif", "--fps", "5", "--speed", "0.5", "--size", "320x320")
    assert result.exit_code == 0, result.output
    gif = Image.open(tmp_path / "top.gif")
    assert gif.n_frames == 21 and gif.size == (320, 320)  # t = 0, 0.1, …, 2.0 s
    frames = []
    for k in (0, 10):
        gif.seek(k)
        frames.append(np.asarray(gif.convert("L"), dtype=float))
    assert np.abs(frames[0] - frames[1]).mean() > 0.1 and frames[1].std() > 5.0


def test_animate_refuses_bad_input(cli, tmp_path, recordings):
    _, path = recordings["euler"]
    result = cli("animate", str(path), "-o", "clip.avi")
    assert result.exit_code == 2 and ".gif or .mp4" in result.stderr
    result = cli("animate", str(path), "--speed", "1e-6")
    assert result.exit_code == 2 and "--speed" in result.stderr
    assert not list(tmp_path.glob("*.gif"))


def test_each_load_drawn_is_its_share_of_the_kernels_torque():
    """The recording draws each load's torque with the kernels' own compiled torque, the load
    alone in a model of the scene's type: forces, body-frame forces (follower torques), constant
    and harmonic torques in both frames with windows, a constant folded from w = 0, tables in both
    frames (knots and window edges sampled exactly, before, inside, after), damping.  The views
    add up to the torque of the whole scene; bound: 16 ulp of the largest torque (a sum of 12)."""
    import numba

    from rotlab.core.torques import torque_samples
    from rotlab.recording import loads_view
    from rotlab.scene.scene import build_scene

    loads = [
        {"type": "gravity", "g": [0.3, -1.0, -9.81]},
        {"type": "force", "frame": "space", "value": [0.5, 2.0, -1.0], "point": [0.1, -0.2, 0.05]},
        {"type": "force", "frame": "body", "value": [0.0, 1.5, 0.2], "point": [0.3, 0.0, -0.1], "window": {"on": 1.0, "off": 3.0}},
        {"type": "torque", "frame": "space", "value": [0.01, -0.02, 0.03], "window": {"on": 2.0, "off": 4.0}},
        {"type": "torque", "frame": "body", "value": [-0.01, 0.0, 0.02]},
        {"type": "harmonic_torque", "frame": "space", "offset": [0.001, 0.0, 0.0], "amplitude": [0.0, 0.02, -0.01],
         "angular_frequency": 3.0, "phase": 0.4, "window": {"on": 0.5, "off": 6.0}},
        {"type": "harmonic_torque", "frame": "body", "amplitude": [0.002, 0.001, 0.0], "angular_frequency": 7.0, "phase": -1.0},
        {"type": "harmonic_torque", "frame": "body", "amplitude": [0.0, 0.0, 0.004], "angular_frequency": 0.0, "phase": 0.7},
        {"type": "torque_table", "frame": "body", "times": [5.0, 6.0, 7.5], "values": [[0, 0, 0], [0.01, 0, -0.05], [0.02, 0.03, 0]]},
        {"type": "torque_table", "frame": "space", "times": [0.5, 2.5, 3.0, 8.0], "values": [[0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1], [0.1, 0.1, 0.1]],
         "window": {"on": 1.0, "off": 7.0}},
        {"type": "damping", "coefficient": 3e-3},
    ]
    scenario = rotlab.load(CONFIGS / "general.toml", overrides={"loads": loads})
    scene = build_scene(scenario)
    rng = np.random.default_rng(7)
    edges = [0.5, 1.0, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 7.0, 7.5, 8.0]
    t = np.concatenate([edges, np.nextafter(edges, -np.inf), rng.uniform(-1.0, 10.0, 500)])
    q = rng.standard_normal((t.shape[0], 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.standard_normal((t.shape[0], 3)) * 20.0
    views = loads_view.load_views(scene)
    assert len(views) == len(loads)
    whole = np.empty((t.shape[0], 3))
    torque_samples(t, q, w, scene.model, whole)  # the kernels' torque of all the loads together
    total = np.zeros_like(whole)
    for view in views:
        assert numba.typeof(view.model) == numba.typeof(scene.model)  # one compiled specialisation for every view
        drawn = loads_view.torques(scene, view, t, q, w)
        assert np.count_nonzero(np.any(drawn != 0.0, axis=1)) > 50, view.description  # the samples exercise the load
        total += drawn
    scale = np.max(np.abs(whole))
    assert np.max(np.abs(total - whole)) <= 16 * np.finfo(float).eps * scale


def test_arrows_past_the_first_chunks_longest_still_grow_but_stay_in_the_view():
    """``visuals.drawn``: linear up to the design length, then design·(1 + tanh(ln(ℓ/design))/2):
    continuous, increasing, below 1.5 × design, direction kept."""
    from rotlab.recording.visuals import drawn

    direction = np.array([0.36, 0.48, 0.8])
    magnitudes = np.array([0.0, 0.5, 1.0, 1.0 + 1e-12, 2.0, 10.0, 1e3, 1e12])
    arrows = drawn(magnitudes[:, None] * direction, 2.0, 2.0)  # design reached at magnitude 1
    lengths = np.linalg.norm(arrows, axis=1)
    assert lengths[:3] == pytest.approx([0.0, 1.0, 2.0], abs=1e-15)
    assert np.all(np.diff(lengths) > 0.0)
    assert lengths[3] == pytest.approx(2.0, rel=1e-11)  # continuous at the design length
    assert np.all(lengths <= 3.0 * (1.0 + 1e-15)) and lengths[-1] == pytest.approx(3.0, rel=1e-9)
    assert np.allclose(arrows[1:] / lengths[1:, None], direction, atol=1e-15)


def test_animate_hides_what_the_body_covers():
    """``animate.behind``: a point is hidden when the ray from it toward the camera crosses the
    solid ellipsoid — behind it or inside it — and shown in front of it or beside it."""
    from rotlab.core import quaternion as quat
    from rotlab.recording.animate import behind, toward_camera

    camera = toward_camera()
    axes = quat.to_matrix(quat.from_axis_angle(np.array([0.3, -0.5, 0.8]), 0.7))  # a turned ellipsoid
    half, centre = np.array([1.0, 0.5, 0.25]), np.array([0.2, -0.1, 0.3])
    side = np.cross(camera, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    points = np.array([centre - 3.0 * camera, centre + 3.0 * camera, centre, centre + 3.0 * side, centre - 3.0 * camera + 3.0 * side])
    assert behind(points, centre, axes, half, camera).tolist() == [True, False, True, False, False]
    assert camera == pytest.approx(np.array([np.cos(np.radians(22)) * np.cos(np.radians(-58)),
                                             np.cos(np.radians(22)) * np.sin(np.radians(-58)), np.sin(np.radians(22))]))


def test_small_load_plots_are_drawn_in_a_submultiple_named_in_the_title(tmp_path):
    """Rerun labels a plot of 1e-6 W '−0.000 001' and gives a 1e-5 N·m range one tick: the loads'
    torque and power plots are drawn in the SI submultiple that brings their value at the run's
    first sample (or the loads' own bound) to ≥ 1, named in the plot's title
    (``visuals.plot_unit``, ``visuals.load_units``).  detumbling.toml (B-dot: |M| ≤ ~1e-5 N·m,
    |P| ≤ ~1e-6 W) is drawn in µN·m and µW: the recorded series equal the torque computed from the
    run in N·m × 1e6, in both frames."""
    from rotlab.recording import visuals
    from rotlab.recording.reader import view_queries

    assert visuals.plot_unit(np.array([2e-5, -3e-5])) == (1e6, "µ")
    assert visuals.plot_unit(np.array([0.05, np.nan])) == (1e3, "m")
    assert visuals.plot_unit(np.array([1.0, -250.0])) == (1.0, "")
    assert visuals.plot_unit(np.zeros(3)) == (1.0, "") and visuals.plot_unit(np.array([np.inf])) == (1.0, "")
    assert visuals.plot_unit(np.array([1e-16])) == (1e12, "p")
    traj = rotlab.simulate(rotlab.load(CONFIGS / "detumbling.toml", duration=200.0))
    path = write_recording(traj, tmp_path / "d.rrd")
    names = {name for name, _, _ in view_queries(path).values()}
    assert {"M of loads, body frame (µN·m)", "M of loads, space frame (µN·m)", "Power of loads (µW)"} <= names, names
    raw = visuals.load_series(traj)
    for entity in (layout.LOAD_TORQUE_BODY, layout.LOAD_TORQUE_SPACE, layout.LOAD_POWER):
        _, drawn = read_series(path, entity)
        np.testing.assert_allclose(drawn, raw[entity][0] * 1e6, rtol=1e-12, atol=1e-12 * np.max(np.abs(drawn)))
        assert 1.0 <= np.max(np.abs(drawn)) < 1e3


RAMP = """
[[loads]]
type = "harmonic_torque"
frame = "body"
amplitude = [0.01, 0.0, 0.0]
angular_frequency = 1.0
phase = 1e-6
"""  # ~1e-8 N·m at t = 0, 0.01 N·m a second later: a first chunk of one sample saw nN·m


@pytest.mark.parametrize("config", ["general.toml", "detumbling.toml", "ramp"])
def test_the_load_plots_unit_does_not_depend_on_how_the_run_is_cut(config, tmp_path, monkeypatch):
    """A streamed run flushes what it has after 0.5 s, so its first chunk can be one sample (a
    cold numba cache, a busy machine): the unit is chosen from the run's first sample and the
    loads' own bound, never from a chunk.  Streamed in 1-sample chunks, the recording's titles and
    torque values equal the whole run's written at once (``rotlab.save``)."""
    from rotlab import api
    from rotlab.methods import stepping
    from rotlab.recording import stream as stream_module
    from rotlab.recording.reader import view_queries
    from rotlab.recording.sink import RecordingSink
    from rotlab.scene.scene import build_scene

    if config == "ramp":
        (tmp_path / "ramp.toml").write_text((CONFIGS / "euler.toml").read_text() + RAMP)
    scenario = rotlab.load(tmp_path / "ramp.toml" if config == "ramp" else CONFIGS / config, duration=2.0)
    monkeypatch.setattr(stepping, "WINDOW", 7)  # (both runs: an adaptive step ends at a window's last sample)
    whole = write_recording(rotlab.simulate(scenario), tmp_path / "whole.rrd")
    monkeypatch.setattr(stream_module, "FLUSH_ROWS", 1)
    _, _, streamed = api.record(build_scene(scenario), RecordingSink(tmp_path / "streamed.rrd"))
    titles = [sorted({name for name, origin, _ in view_queries(path).values() if origin.startswith("/loads/")}) for path in (whole, streamed)]
    assert titles[0] == titles[1] and len(titles[0]) == 3, titles
    if config == "ramp":
        assert titles[0] == ["M of loads, body frame (mN·m)", "M of loads, space frame (mN·m)", "Power of loads (mW)"]
    for entity in (layout.LOAD_TORQUE_BODY, layout.LOAD_POWER):
        np.testing.assert_array_equal(read_series(streamed, entity)[1], read_series(whole, entity)[1])
