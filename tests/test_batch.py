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


def _strict_json(path):
    def reject(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(path.read_text(encoding="utf-8"), parse_constant=reject)


def test_default_checks_fail_a_step_far_too_coarse_for_rtol(cli, write, tmp_path):
    """No [checks]: every invariant gets 100·rtol + roundoff.  rk4 at step 1e-2 on the shipped
    150 rad/s top drifts 3.7e-2 in |Λ| (bound 1e-8): FAIL, and the report names the bounds."""
    text = (CONFIGS / "lagrange.toml").read_text(encoding="utf-8")
    assert "[checks]" not in text
    write("top.toml", text.replace('method = "auto"', 'method = "rk4"\nstep = 1e-2'))
    write("fine.toml", text)
    result = cli("batch", "top.toml", "fine.toml", "-o", "out", "-j", "1")
    assert result.exit_code == 1
    summary = _strict_json(tmp_path / "out" / "summary.json")
    top, fine = summary["cases"]
    assert top["status"] == "fail" and fine["status"] == "pass"
    assert top["default_checks"] and {c["source"] for c in top["checks"]} == {"default"}
    (q,) = [c for c in top["checks"] if c["name"] == "max_drift.quaternion_norm"]
    assert q["value"] == pytest.approx(3.73e-2, rel=0.01) and q["bound"] == pytest.approx(1e-8, rel=1e-3) and not q["passed"]
    assert {c["name"] for c in fine["checks"]} == {f"max_drift.{n}" for n in ("energy", "quaternion_norm", "L_vertical", "L_symmetry")}
    assert "top.toml: max |energy drift| = " in result.stdout and "default bound: 100 × solver.rtol (1e-10)" in result.stdout


def test_strict_json_null_with_a_reason(cli, write, tmp_path):
    """A flip period that cannot be measured is null with its reason, never NaN."""
    write("noflip.toml", VALID_BODY + "[initial]\nomega = [0.1, 0, 3]\n" + VALID_TIME
          + '[checks]\nflip_period = { expected = 1.0, axis = "y" }\n')
    cli("batch", "noflip.toml", "-o", "out", "-j", "1")
    text = (tmp_path / "out" / "summary.json").read_text(encoding="utf-8")
    assert "NaN" not in text and "Infinity" not in text
    (check,) = _strict_json(tmp_path / "out" / "summary.json")["cases"][0]["checks"]
    assert check["value"] is None and "need ≥ 3 to measure a period" in check["value_reason"]


def test_strict_replaces_every_non_finite_number():
    from rotlab.batch.reports import strict

    doc = strict({"a": float("nan"), "b": [1.0, float("inf")], "c": {"d": -float("inf"), "e": 2}})
    assert doc["a"] is None and "not a finite number (nan)" in doc["a_reason"]
    assert doc["b"] == [1.0, None] and doc["c"]["d"] is None and doc["c"]["e"] == 2
    json.dumps(doc, allow_nan=False)


def test_stopped_run_writes_partial_and_keeps_a_good_recording(cli, write, tmp_path):
    """A run that stops (step budget) goes to NAME.partial.rrd; the good NAME.rrd stays as it was."""
    good = VALID_BODY + "[initial]\nomega = [1, 0.1, 0]\n" + VALID_TIME
    write("case.toml", good)
    assert cli("batch", "case.toml", "-o", "out", "-j", "1").exit_code == 0
    before = (tmp_path / "out" / "case.rrd").read_bytes()
    write("case.toml", good + '[solver]\nmethod = "dop853"\nmax_steps = 2\n')
    result = cli("batch", "case.toml", "-o", "out", "-j", "1")
    assert result.exit_code == 1 and "step budget" in result.stdout
    assert (tmp_path / "out" / "case.rrd").read_bytes() == before
    assert (tmp_path / "out" / "case.partial.rrd").stat().st_size > 0
    (case,) = _strict_json(tmp_path / "out" / "summary.json")["cases"]
    assert case["output"].endswith("case.partial.rrd") and case["status"] == "fail"


def test_error_line_names_the_scenario_once(cli, write):
    write("bad1.toml", VALID_BODY + "[time]\nend = -1\n")
    result = cli("batch", "bad1.toml", "-o", "out", "-j", "1")
    (line,) = {line for line in result.stdout.splitlines() if line.startswith("ERROR")}
    assert line.split()[:2] == ["ERROR", "bad1.toml:"] and line.count("bad1.toml") == 1 and "time.end" in line


def test_junit_properties_and_markdown_summaries(cli, write, tmp_path, monkeypatch):
    write("good.toml", VALID_BODY + "[initial]\nomega = [1, 0.1, 0]\n" + VALID_TIME + "[checks]\nmax_drift = { energy = 1e-6 }\n")
    write("plain.toml", VALID_BODY + "[initial]\nomega = [1, 0.1, 0]\n" + VALID_TIME)
    step_summary = tmp_path / "step_summary.md"
    step_summary.write_text("earlier step\n", encoding="utf-8")
    monkeypatch.setenv("GITHUB_STEP_SUMMARY", str(step_summary))
    result = cli("batch", "good.toml", "plain.toml", "-o", "out", "-j", "1", "--markdown", "report.md")
    assert result.exit_code == 0, result.stdout
    suite = ET.parse(tmp_path / "out" / "junit.xml").getroot()
    good = suite.find("testcase[@name='good.toml']")
    props = {p.get("name"): p.get("value") for p in good.iter("property")}
    assert props["max_drift.energy.source"] == "[checks]" and float(props["max_drift.energy.bound"]) == 1e-6
    assert 0.0 <= float(props["max_drift.energy.value"]) <= 1e-6
    plain = {p.get("name"): p.get("value") for p in suite.find("testcase[@name='plain.toml']").iter("property")}
    assert plain["max_drift.quaternion_norm.source"] == "default" and float(plain["max_drift.quaternion_norm.bound"]) > 0
    report = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert "| ✅ | `good.toml` |" in report and "Default bounds applied" in report and "`plain.toml`" in report
    assert step_summary.read_text(encoding="utf-8") == "earlier step\n" + report  # appended, as GitHub expects


def test_batch_on_a_dask_cluster(cli, write, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    write("good.toml", VALID_BODY + "[initial]\nomega = [1, 0.1, 0]\n" + VALID_TIME)
    write("broken.toml", VALID_BODY + "[time]\nend = -1\n")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        result = cli("batch", "good.toml", "broken.toml", "-o", "out", "--dask", cluster.scheduler_address)
    assert result.exit_code == 1
    status = {c["scenario"]: c["status"] for c in _strict_json(tmp_path / "out" / "summary.json")["cases"]}
    assert status == {"good.toml": "pass", "broken.toml": "error"}
    assert (tmp_path / "out" / "good.rrd").is_file()


def test_timeout_with_dask_is_bad_input(cli, write):
    write("good.toml", VALID_BODY + VALID_TIME)
    result = cli("batch", "good.toml", "--dask", "tcp://127.0.0.1:9", "--timeout", "5")
    assert result.exit_code == 2 and "--timeout" in result.stderr and "Dask" in result.stderr


def test_temporaries_of_a_killed_worker_are_removed(tmp_path):
    """What a worker killed mid-write leaves (the writer's .NAME.PID.*.tmp) is deleted; other files stay."""
    from rotlab.batch.runner import remove_temporaries

    output = tmp_path / "case.rrd"
    mine = [tmp_path / ".case.rrd.4242.ab12cd34.tmp", tmp_path / ".case.partial.rrd.4242.ff00ff00.tmp"]
    others = [tmp_path / ".case.rrd.4243.ab12cd34.tmp", tmp_path / "case.rrd", tmp_path / ".other.rrd.4242.00.tmp"]
    for path in mine + others:
        path.write_bytes(b"x")
    assert sorted(remove_temporaries(output, 4242)) == sorted(mine)
    assert all(p.exists() for p in others) and not any(p.exists() for p in mine)
