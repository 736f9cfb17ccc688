"""``rotlab export``: a recording's samples as the table ``Trajectory.to_dataframe`` gives —
every column equal to the run's (bit for bit in a principal body frame, to 1e-14 through a
tensor's axes), units in the CSV's first line and the Parquet metadata; refusals in one line."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import rotlab
from tests.conftest import CONFIGS


@pytest.mark.parametrize("config, exact", [("lagrange.toml", True), ("general.toml", False)])
def test_the_exported_table_is_the_runs_dataframe(cli, tmp_path, config, exact):
    result = cli("run", str(CONFIGS / config), "--duration", "1", "-q", "-o", "r.rrd")
    assert result.exit_code == 0, result.output
    expected = rotlab.simulate(CONFIGS / config, duration=1.0).to_dataframe()
    for suffix in (".csv", ".parquet"):
        out = cli("export", "r.rrd", "-o", f"r{suffix}")
        assert out.exit_code == 0 and f"{len(expected):,} rows × {expected.shape[1]} columns" in out.stdout, out.output
    table = pd.read_csv(tmp_path / "r.csv", comment="#")
    parquet = pd.read_parquet(tmp_path / "r.parquet")
    assert list(table.columns) == list(expected.columns) == list(parquet.columns)
    for frame in (table, parquet):
        if exact:
            np.testing.assert_array_equal(frame.to_numpy(), expected.to_numpy())
        else:  # the state back to the principal frame and out again
            np.testing.assert_allclose(frame.to_numpy(), expected.to_numpy(), rtol=1e-13, atol=1e-15)
    units = json.loads(__import__("pyarrow.parquet", fromlist=["x"]).read_schema(tmp_path / "r.parquet").metadata[b"units"])
    assert units == expected.attrs["units"]
    first = (tmp_path / "r.csv").read_text(encoding="utf-8").splitlines()[0]
    assert first.startswith("# units: t s; q0 1 (body → space, scalar first);") and "omega_x_body rad/s" in first


def test_refusals_are_one_line(cli, tmp_path):
    traj = rotlab.simulate(CONFIGS / "euler.toml", duration=0.2, torque=lambda t, q, w: (0.0, 0.0, 0.01))
    rotlab.save(tmp_path / "py.rrd", traj)
    for args, words in ((["py.rrd", "-o", "x.csv"], "had a Python torque function"),
                        (["py.rrd", "-o", "x.xlsx"], "give a name ending in .csv or .parquet"),
                        (["none.rrd", "-o", "x.csv"], "no such recording")):
        result = cli("export", *args)
        assert result.exit_code == 2 and words in result.stderr and result.stderr.count("\n") == 1, result.output
    assert not list(tmp_path.glob("x.*"))
