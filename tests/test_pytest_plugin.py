"""The pytest plugin (entry point pytest11): `pytest DIR` runs each scenario with [checks] as a test."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from tests.conftest import VALID_BODY, VALID_TIME

pytest_plugins = ["pytester"]

MOTION = "[initial]\nomega = [1, 0.1, 0]\n"


@pytest.fixture
def scenarios(pytester):
    folder = pytester.mkdir("suite")
    (folder / "good.toml").write_text(VALID_BODY + MOTION + VALID_TIME + "[checks]\nmax_drift = { energy = 1e-6 }\n")
    (folder / "strict.toml").write_text(VALID_BODY + MOTION + VALID_TIME
                                        + '[solver]\nmethod = "rk4"\nstep = 0.05\n[checks]\nmax_drift = { energy = 1e-15 }\n')
    (folder / "broken.toml").write_text(VALID_BODY + "[time]\nend = -1\n[checks]\nmax_drift = { energy = 1e-6 }\n")
    (folder / "plain.toml").write_text(VALID_BODY + MOTION + VALID_TIME)  # no [checks]: not a test
    (folder / "notes.toml").write_text("[project]\nname = \"x\"\n")  # not a scenario: ignored
    return folder


def test_scenarios_with_checks_are_test_items(pytester, scenarios):
    result = pytester.runpytest_subprocess("suite", "-p", "no:randomly", "--junitxml=report.xml")
    result.assert_outcomes(passed=1, failed=2)
    result.stdout.fnmatch_lines(["ERROR     suite/broken.toml: time.end: end (-1 s) must be after start (0 s)",
                                 "FAIL      suite/strict.toml: max |energy drift| = * > 1e-15"])
    cases = {c.get("name"): c for c in ET.parse(pytester.path / "report.xml").getroot().iter("testcase")}
    assert set(cases) == {"good", "strict", "broken"}
    props = {p.get("name"): p.get("value") for p in cases["good"].iter("property")}
    assert float(props["max_drift.energy.bound"]) == 1e-6 and 0 <= float(props["max_drift.energy.value"]) <= 1e-6


def test_selection_and_opt_in(pytester, scenarios):
    """-k selects scenarios; a plain `pytest` elsewhere collects none unless --rotlab-scenarios."""
    (pytester.path / "test_nothing.py").write_text("def test_one():\n    assert True\n")

    def collected(*args: str) -> list[str]:
        result = pytester.runpytest("--collect-only", "-q", *args)  # collection only: nothing runs in-process
        return sorted(line for line in result.outlines if "::" in line)

    assert collected("suite", "-k", "good") == ["suite/good.toml::good"]
    assert collected() == ["test_nothing.py::test_one"]  # installing rotlab changes nothing elsewhere
    assert collected("--rotlab-scenarios") == ["suite/broken.toml::broken", "suite/good.toml::good",
                                               "suite/strict.toml::strict", "test_nothing.py::test_one"]
