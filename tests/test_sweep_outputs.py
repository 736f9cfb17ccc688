"""What a sweep reports: per-case observables in results.csv/parquet, a comparison recording
whose every view shows data, and `rotlab snapshot` of that recording."""

from __future__ import annotations

import csv
import glob

import numpy as np
import pyarrow.parquet as pq
import pytest

from rotlab.recording.reader import entity_paths, query_matches, view_queries
from tests.conftest import CONFIGS

FLIP_PERIOD = 6.0821358755  # Jacobi's solution for configs/dzhanibekov.toml (see its [checks])

FLIP_SWEEP = "\n".join(  # the shipped scene without its flip check (case 1 flips at another period)
    line for line in (CONFIGS / "dzhanibekov.toml").read_text(encoding="utf-8").splitlines() if not line.startswith("flip_period")
) + """
[sweep]
[sweep.parameters]
"initial.omega[0]" = [0.01, 0.1]
"""

ENSEMBLE_SWEEP = """
[body]
principal_moments = [1.0e-4, 2.0e-4, 2.8e-4]
[initial]
omega = [0.01, 10.0, 0.01]
[time]
end = 8.0
sample_rate = 50
[solver]
method = "rk4"
step = 2e-3
[sweep]
seed = 1
samples = 2
[sweep.parameters]
"initial.omega[0]" = [0.001, 0.1]
"initial.omega[2]" = { uniform = [-0.05, 0.05] }
"""


def _views_show_data(path):
    entities = entity_paths(path)
    for name, origin, query in view_queries(path).values():
        assert query_matches(query, origin, entities), f"view {name!r} shows nothing"


def test_flip_period_per_case_matches_jacobi(cli, write, tmp_path):
    """Case 0 is the shipped Dzhanibekov scene: its flip period in results.csv equals the value
    from Jacobi's elliptic functions to 1e-6; the larger wobble flips sooner."""
    result = cli("sweep", str(write("flip.toml", FLIP_SWEEP)), "-o", "out", "-j", "1")
    assert result.exit_code == 0, result.output
    with open(tmp_path / "out" / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert float(rows[0]["flip_period_s"]) == pytest.approx(FLIP_PERIOD, rel=1e-6)
    assert float(rows[1]["flip_period_s"]) < float(rows[0]["flip_period_s"])
    assert 175.0 < float(rows[0]["max_nutation_deg"]) <= 180.0  # the spin axis turns over
    assert all(float(r["seconds"]) > 0 for r in rows)  # one process: each case timed alone
    table = pq.read_table(tmp_path / "out" / "results.parquet").to_pydict()
    assert table["flip_period_s"][0] == pytest.approx(FLIP_PERIOD, rel=1e-6)
    _views_show_data(tmp_path / "out" / "flip_sweep.rrd")


def test_ensemble_sweep_recording_shows_every_case_and_no_fake_timings(cli, write, tmp_path):
    result = cli("sweep", str(write("ens.toml", ENSEMBLE_SWEEP)), "-o", "out")
    assert result.exit_code == 0, result.output
    assert "ensemble kernel" in result.stdout and "s for all cases" in result.stdout
    with open(tmp_path / "out" / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["seconds"] for r in rows} == {""}  # cases ran together: no per-case wall time
    path = tmp_path / "out" / "ens_sweep.rrd"
    _views_show_data(path)
    entities = entity_paths(path)
    for k in range(4):
        assert f"/compare/omega_y/case_{k}" in entities
    assert any(e.startswith("/results/initial_omega_0/flip_period_s") for e in entities)


@pytest.mark.skipif(not glob.glob("/usr/share/vulkan/icd.d/*.json"), reason="no Vulkan driver: install mesa-vulkan-drivers libvulkan1")
def test_snapshot_renders_a_sweep_recording(cli, write, tmp_path):
    from PIL import Image

    assert cli("sweep", str(write("ens.toml", ENSEMBLE_SWEEP)), "-o", "out").exit_code == 0
    result = cli("snapshot", "out/ens_sweep.rrd", "-o", "sweep.png", "--size", "960x540")
    assert result.exit_code == 0, result.output
    pixels = np.asarray(Image.open(tmp_path / "sweep.png").convert("L"), dtype=float)
    assert pixels.std() > 10.0


def test_the_comparison_recording_spans_every_cases_whole_run(cli, write, tmp_path):
    """The comparison keeps every k-th sample of a long case (at most ~2,000) and its last: it
    ended one stride early (8 s at 500 Hz: 7.994 s), so `snapshot --time 8` was refused."""
    from rotlab.recording.reader import read_series

    text = ENSEMBLE_SWEEP.replace("sample_rate = 50", "sample_rate = 500")
    assert cli("sweep", str(write("long.toml", text)), "-o", "out").exit_code == 0
    for k in range(4):
        t, omega = read_series(tmp_path / "out" / "long_sweep.rrd", f"/compare/omega_y/case_{k}")
        assert t[0] == 0.0 and t[-1] == pytest.approx(8.0, abs=1e-9) and 1000 <= t.shape[0] <= 2001
        assert np.all(np.diff(t) > 0) and np.all(np.isfinite(omega))
