"""`rotlab stress --quick` passes, and a failing check fails the command."""

from __future__ import annotations

from rotlab.stress import suite


def test_quick_stress_suite_passes(cli):
    result = cli("stress", "--quick")
    assert result.exit_code == 0, result.stdout
    assert "FAIL" not in result.stdout and "checks passed" in result.stdout


def test_a_failing_check_fails_the_suite(cli, monkeypatch):
    broken = suite.Check("broken", lambda quick: suite.Outcome("broken", False, "x", "y"))
    crashing = suite.Check("crash", lambda quick: 1 / 0)
    monkeypatch.setattr(suite, "CHECKS", [broken, crashing])
    result = cli("stress", "--quick")
    assert result.exit_code == 1
    assert result.stdout.count("FAIL") == 2 and "ZeroDivisionError" in result.stdout
