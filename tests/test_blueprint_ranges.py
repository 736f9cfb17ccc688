"""A streamed run's plot ranges come from the whole run, not from its first chunk (the layout is
sent again, as the default, when the run ends: a torque peak late in the run stays on the plot)."""

from __future__ import annotations

import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from rotlab.recording import layout
from rotlab.recording.reader import read_series
from tests.conftest import CONFIGS


def _ranges(path, view_name: str) -> list[tuple[float, float]]:
    """The y range of the view named ``view_name`` in every blueprint of the file."""
    reader = RrdReader(str(path))
    out = []
    for store in reader.blueprints():
        names, ranges = {}, {}
        for chunk in reader.stream(store=store).to_chunks():
            batch, entity = chunk.to_record_batch(), str(chunk.entity_path)
            if "ViewBlueprint:display_name" in batch.schema.names:
                names[entity] = batch.column("ViewBlueprint:display_name").to_pylist()[-1][0]
            if "ScalarAxis:range" in batch.schema.names:
                ranges[entity.rsplit("/ScalarAxis", 1)[0]] = batch.column("ScalarAxis:range").to_pylist()[-1][0]
        out += [tuple(ranges[view]) for view, name in names.items() if name == view_name and view in ranges]
    return out


def test_plot_ranges_cover_the_whole_streamed_run(cli, tmp_path):
    # 200,001 samples: several chunks; general.toml's largest torque comes after the first one
    result = cli("run", str(CONFIGS / "general.toml"), "-q", "-o", "g.rrd", "--set", "time.sample_rate=20000")
    assert result.exit_code == 0, result.output
    _, torque = read_series(tmp_path / "g.rrd", layout.LOAD_TORQUE_BODY)
    low, high = float(np.min(torque)), float(np.max(torque))
    ranges = _ranges(tmp_path / "g.rrd", "M of loads, body frame (mN·m)")  # general.toml: |M| < 1 N·m at t = 0 and in its loads' own bound
    assert ranges, "no y range for the body-frame torque plot"
    assert any(lo <= low and hi >= high for lo, hi in ranges), (low, high, ranges)


def test_the_final_layout_of_a_top_keeps_its_nutation_plots(cli, tmp_path, monkeypatch):
    """The layout is sent again when the run ends, built from the run's thinned samples; those
    carried no Euler angles, so a heavy top's final layout lost its θ, ψ and spin-rate plots."""
    from rotlab.recording import writer

    built = []
    original = writer.run_blueprint

    def recording(traj, views, events=None):
        built.append(set(views.series))
        return original(traj, views, events)

    monkeypatch.setattr(writer, "run_blueprint", recording)
    result = cli("run", str(CONFIGS / "lagrange.toml"), "-q", "-o", "l.rrd", "--set", "time.sample_rate=4000")  # 40,001 samples: thinned
    assert result.exit_code == 0, result.output
    assert len(built) == 2  # the first chunk's layout, then the whole run's
    assert all({layout.EULER_THETA, layout.EULER_PSI, layout.EULER_SPIN_RATE} <= series for series in built)


def test_the_plots_show_the_whole_run_and_the_band_of_a_fast_motion(cli, tmp_path):
    """A long run's plots opened centred on the time cursor, half empty, the start off-screen: the
    time axis of every plot now spans the run (start to end); and a motion faster than a pixel
    (a top's nutation over 100 s) is drawn as the band it sweeps (min-max per pixel), not as its
    mean, which was a flat line."""
    result = cli("run", str(CONFIGS / "lagrange.toml"), "-q", "-o", "l.rrd", "--duration", "100", "--set", "time.sample_rate=50")
    assert result.exit_code == 0, result.output
    reader = RrdReader(str(tmp_path / "l.rrd"))
    spans = []
    for store in reader.blueprints():
        for chunk in reader.stream(store=store).to_chunks():
            batch = chunk.to_record_batch()
            if "TimeAxis:view_range" in batch.schema.names:
                spans.append(batch.column("TimeAxis:view_range").to_pylist()[-1])
    # absolute, 0 to 100 s (ns), and the margin that keeps the last tick's label whole; and the
    # "Motion, recent" tab's plots: the 4 s before the cursor (200 samples: longer than 12 turns, 0.5 s)
    whole, recent = [{"start": 0, "end": round(100e9 * (1 + layout.TIME_MARGIN))}], [{"start": -4_000_000_000, "end": 0}]
    assert spans and all(span in (whole, recent) for span in spans) and whole in spans and recent in spans, spans[:2]
    policies = []
    for chunk in reader.stream().filter(content="/euler/theta", is_static=True).to_chunks():
        batch = chunk.to_record_batch()
        if "SeriesLines:aggregation_policy" in batch.schema.names:
            policies += batch.column("SeriesLines:aggregation_policy").to_pylist()
    minmax = rr.components.AggregationPolicy.MinMax.value
    assert policies and all(p == [minmax] for p in policies), policies


def test_a_long_run_has_its_recent_motion_beside_the_whole_run_and_a_short_one_not(cli, tmp_path):
    """``visuals.recent_window``: 12 periods of the fastest motion, at least 200 samples, shown
    only under a quarter of the run."""
    from rotlab.recording import visuals

    def view_names(path) -> set[str]:
        reader = RrdReader(str(path))
        return {batch.column("ViewBlueprint:display_name").to_pylist()[-1][0] for store in reader.blueprints()
                for batch in (chunk.to_record_batch() for chunk in reader.stream(store=store).to_chunks())
                if "ViewBlueprint:display_name" in batch.schema.names}

    assert cli("run", str(CONFIGS / "lagrange.toml"), "-q", "-o", "long.rrd", "--duration", "100").exit_code == 0
    assert cli("run", str(CONFIGS / "lagrange.toml"), "-q", "-o", "short.rrd", "--duration", "2").exit_code == 0
    assert "θ nutation (deg), last 2 s" in view_names(tmp_path / "long.rrd")
    assert not any(", last " in name for name in view_names(tmp_path / "short.rrd"))
    t = np.linspace(0.0, 1000.0, 100_001)
    omega = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])  # one turn in 2π s
    assert visuals.recent_window(t, omega) == pytest.approx(12 * 2 * np.pi, rel=1e-9)
    assert visuals.recent_window(t[:10_001], omega[:10_001]) is None  # 100 s: 75 s would be most of it


def test_a_longer_legend_gets_more_room_above_the_data():
    """The legend sits in the plot's top corner: the range leaves 5% below the data and, above
    it, 5% without a legend, 45% of the data span for up to 3 legend lines and 22% more for each
    further line (general.toml's 5 energies: T, V, T+V, W, T+V−W covered the top of T+V−W)."""
    values = np.array([[0.0, 1.0], [2.0, 3.0]])  # data from 0 to 3
    assert layout.plot_range(values, 0) == pytest.approx((-0.15, 3.15))
    assert layout.plot_range(values, 2) == pytest.approx((-0.15, 3.0 + 0.45 * 3))
    assert layout.plot_range(values, 3) == pytest.approx((-0.15, 3.0 + 0.45 * 3))
    assert layout.plot_range(values, 5) == pytest.approx((-0.15, 3.0 + 0.89 * 3))
    assert layout.plot_range(np.array([np.nan]), 3) is None
