"""`rotlab batch`: parallel runs, checks, summary.json and junit.xml; failures don't stop it."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import rotlab
from rotlab.checks import evaluate_checks, flip_times
from tests.conftest import CONFIGS, VALID_BODY, VALID_TIME


def test_flip_times_interpolate_zero_crossings():
    t = np.linspace(0.0, 10.0, 1001)
    crossings = flip_times(t, np.sin(t))
    np.testing.assert_allclose(crossings, [np.pi, 2 * np.pi, 3 * np.pi], atol=2e-5)


def test_dzhanibekov_flip_period_matches_elliptic_value():
    """The shipped config's check: measured period within 1e-6 of 4K(m)/λ."""
    traj = rotlab.simulate(CONFIGS / "dzhanibekov.toml")
    (flip,) = [c for c in evaluate_checks(traj) if c.name == "flip_period"]
    assert flip.passed, flip.message
    assert flip.value == pytest.approx(6.0821358755, rel=1e-6)


def test_batch_reports_pass_fail_and_error_and_keeps_going(cli, write, tmp_path):
    write("good.toml", VALID_BODY + "[initial]\nomega = [1, 0.1, 0]\n" + VALID_TIME + "[checks]\nmax_drift = { energy = 1e-6 }\n")
    write("strict.toml", VALID_BODY + "[initial]\nomega = [1, 0.1, 0]\n" + VALID_TIME
          + '[solver]\nmethod = "rk4"\nstep = 0.05\n[checks]\nmax_drift = { energy = 1e-15 }\n')
    write("broken.toml", VALID_BODY + "[time]\nend = -1\n")
    result = cli("batch", str(tmp_path), "-o", str(tmp_path / "out"), "-j", "2")
    assert result.exit_code == 1
    out = result.stdout
    assert "strict.toml" in out and "energy drift" in out and "1e-15" in out  # names scenario and figure
    assert "broken.toml" in out and "time.end" in out
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    status = {c["scenario"].split("/")[-1]: c["status"] for c in summary["cases"]}
    assert status == {"broken.toml": "error", "good.toml": "pass", "strict.toml": "fail"}
    suite = ET.parse(tmp_path / "out" / "junit.xml").getroot()
    assert suite.get("tests") == "3" and suite.get("failures") == "1" and suite.get("errors") == "1"
    assert (tmp_path / "out" / "good.rrd").exists() and not (tmp_path / "out" / "broken.rrd").exists()


def test_batch_of_shipped_configs_passes(cli, tmp_path):
    result = cli("batch", str(CONFIGS), "-o", str(tmp_path / "out"), "-j", "1")
    assert result.exit_code == 0, result.stdout
    assert len(list((tmp_path / "out").glob("*.rrd"))) == len(list(CONFIGS.glob("*.toml")))


def test_check_of_a_missing_invariant_fails_clearly(write):
    path = write("t.toml", VALID_BODY + "[initial]\nomega = [1, 0.1, 0]\n" + VALID_TIME + "[checks]\nmax_drift = { L_symmetry = 1e-9 }\n")
    traj = rotlab.simulate(path)
    (check,) = evaluate_checks(traj)
    assert not check.passed and "not an invariant" in check.message


def test_batch_without_configs_is_bad_input(cli, tmp_path):
    (tmp_path / "empty").mkdir()
    result = cli("batch", str(tmp_path / "empty"))
    assert result.exit_code == 2 and "no scenario files" in result.stderr
