"""Batch reports: a terminal table, ``summary.json`` and JUnit XML for CI systems."""

from __future__ import annotations

import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path

from rotlab.batch.runner import CaseResult


def table(results: list[CaseResult]) -> str:
    header = f"{'scenario':32} {'method':8} {'steps':>10} {'wall s':>8} {'worst drift':>24} {'result':>6}"
    lines = [header, "-" * len(header)]
    for r in results:
        drift = f"{r.worst_invariant} {r.worst_drift:.1e}" if r.worst_invariant else ""
        lines.append(f"{Path(r.scenario).name[:32]:32} {r.method:8} {r.steps:>10,} {r.seconds:>8.2f} {drift:>24} {r.status.upper():>6}")
    for r in results:
        if r.status != "pass":
            lines.append(f"{r.status.upper()} {r.scenario}: {r.message}")
    passed = sum(r.status == "pass" for r in results)
    lines.append(f"{passed} passed, {len(results) - passed} failed")
    return "\n".join(lines)


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def write_summary(results: list[CaseResult], path: Path) -> None:
    passed = sum(r.status == "pass" for r in results)
    doc = {"passed": passed, "failed": len(results) - passed, "cases": [r.as_dict() for r in results]}
    _atomic_write(path, json.dumps(doc, indent=2, allow_nan=True) + "\n")


def write_junit(results: list[CaseResult], path: Path) -> None:
    suite = ET.Element(
        "testsuite",
        name="rotlab batch",
        tests=str(len(results)),
        failures=str(sum(r.status == "fail" for r in results)),
        errors=str(sum(r.status == "error" for r in results)),
        time=f"{sum(r.seconds for r in results):.3f}",
    )
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="rotlab.scenario", name=r.scenario, time=f"{r.seconds:.3f}")
        if r.status == "fail":
            ET.SubElement(case, "failure", message=r.message).text = json.dumps(r.checks, indent=1)
        elif r.status == "error":
            ET.SubElement(case, "error", message=r.message)
        if r.output:
            ET.SubElement(case, "system-out").text = f"recording: {r.output}; method {r.method}; {r.steps} steps"
    _atomic_write(path, ET.tostring(ET.ElementTree(suite).getroot(), encoding="unicode", xml_declaration=True) + "\n")
