"""Batch reports: a line per finished case, a terminal table, strict ``summary.json``, JUnit XML
(each check's value and bound as properties) and a Markdown summary (GitHub's step summary).

JSON is strict (RFC 8259): a number that is not finite (a drift of NaN after a blow-up, a flip
period that could not be measured) is written as ``null`` with the reason beside it
(``KEY_reason``); ``json.dumps(allow_nan=False)`` guarantees none slips through.
"""

from __future__ import annotations

import json
import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from rotlab.batch.runner import PASS, CaseResult
from rotlab.errors import RunFailure

STATUS_ORDER = ("pass", "fail", "error", "cancelled")


def _drift_text(r: CaseResult) -> str:
    if not r.worst_invariant:
        return ""
    value = "n/a" if r.worst_drift is None else f"{r.worst_drift:.1e}"
    return f"{r.worst_invariant} {value}"


def _checks_text(r: CaseResult) -> str:
    if not r.checks:
        return ""
    return f"{len(r.checks)} {'default' if r.default_checks else '[checks]'}"


def case_line(r: CaseResult) -> str:
    """One line for a finished case: ``PASS  euler.toml  (exact, 0 steps, 0.41 s, …)`` or
    ``FAIL  strict.toml: why`` — the scenario named once, the reason after a colon."""
    if r.status == PASS:
        details = [r.method, f"{r.steps:,} steps", f"{r.seconds:.2f} s"]
        if r.worst_invariant:
            details.append(f"worst drift {_drift_text(r)}")
        if r.default_checks:
            details.append(f"{len(r.checks)} default checks")
        return f"{r.status.upper():9} {r.scenario}  ({', '.join(details)})"
    return f"{r.status.upper():9} {r.scenario}: {r.message}"


def counts(results: list[CaseResult]) -> dict[str, int]:
    return {status: sum(r.status == status for r in results) for status in STATUS_ORDER}


def count_line(results: list[CaseResult]) -> str:
    c = counts(results)
    parts = [f"{c['pass']} passed", f"{c['fail']} failed"]
    if c["error"]:
        parts.append(f"{c['error']} error{'s' if c['error'] != 1 else ''}")
    if c["cancelled"]:
        parts.append(f"{c['cancelled']} cancelled")
    return ", ".join(parts)


def table(results: list[CaseResult]) -> str:
    header = f"{'scenario':32} {'method':9} {'steps':>10} {'wall s':>8} {'worst drift':>24} {'checks':>12} {'result':>9}"
    lines = [header, "-" * len(header)]
    for r in results:
        lines.append(f"{r.name[:32]:32} {r.method:9} {r.steps:>10,} {r.seconds:>8.2f} {_drift_text(r):>24} {_checks_text(r):>12} "
                     f"{r.status.upper():>9}")
    lines.extend(case_line(r) for r in results if r.status != PASS)
    defaults = [r for r in results if r.default_checks and r.checks]
    if defaults:
        lines.append("default checks (no [checks] in the scenario): every invariant's max relative drift ≤ the bound shown; "
                     f"e.g. {defaults[0].name}: {defaults[0].checks[0]['limit']} ({defaults[0].checks[0]['basis']})")
    lines.append(count_line(results))
    return "\n".join(lines)


def strict(value: Any) -> Any:
    """``value`` with every non-finite float replaced by None, and ``KEY_reason`` beside it."""
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for key, item in value.items():
            if isinstance(item, float) and not math.isfinite(item):
                out[key] = None
                out[f"{key}_reason"] = f"not a finite number ({item}): the run blew up or the figure could not be measured"
            else:
                out[key] = strict(item)
        return out
    if isinstance(value, list):
        return [None if isinstance(v, float) and not math.isfinite(v) else strict(v) for v in value]
    return value


def summary_doc(results: list[CaseResult], stopped: str | None = None) -> dict:
    c = counts(results)
    doc = {"passed": c["pass"], "failed": c["fail"], "errors": c["error"], "cancelled": c["cancelled"],
           "stopped_by": stopped, "cases": [r.as_dict() for r in results]}
    return strict(doc)


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise RunFailure(f"could not write {path}: {exc.strerror or exc}") from None


def write_summary(results: list[CaseResult], path: Path, stopped: str | None = None) -> None:
    _atomic_write(path, json.dumps(summary_doc(results, stopped), indent=2, allow_nan=False, ensure_ascii=False) + "\n")


def _number(value: Any) -> str:
    return "null" if value is None else f"{value:.17g}" if isinstance(value, float) else str(value)


def write_junit(results: list[CaseResult], path: Path) -> None:
    """One testcase per scenario; its properties give every check's value, bound and source."""
    c = counts(results)
    suite = ET.Element("testsuite", name="rotlab batch", tests=str(len(results)), failures=str(c["fail"]),
                       errors=str(c["error"]), skipped=str(c["cancelled"]), time=f"{sum(r.seconds for r in results):.3f}")
    for r in results:
        case = ET.SubElement(suite, "testcase", classname="rotlab.scenario", name=r.scenario, time=f"{r.seconds:.3f}")
        if r.checks:
            props = ET.SubElement(case, "properties")
            for check in strict(r.checks):
                for key in ("value", "bound", "source", "passed"):
                    ET.SubElement(props, "property", name=f"{check['name']}.{key}", value=_number(check[key]))
        if r.status == "fail":
            ET.SubElement(case, "failure", message=r.message).text = "\n".join(ch["message"] for ch in r.checks)
        elif r.status == "error":
            ET.SubElement(case, "error", message=r.message)
        elif r.status == "cancelled":
            ET.SubElement(case, "skipped", message=r.message)
        if r.output:
            ET.SubElement(case, "system-out").text = f"recording: {r.output}; method {r.method}; {r.steps} steps"
    _atomic_write(path, ET.tostring(suite, encoding="unicode", xml_declaration=True) + "\n")


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def markdown(results: list[CaseResult], stopped: str | None = None) -> str:
    """A Markdown report (for ``$GITHUB_STEP_SUMMARY``): the table, then why each case failed."""
    icon = {"pass": "✅", "fail": "❌", "error": "💥", "cancelled": "⏹️"}
    lines = ["## rotlab batch", "", f"**{count_line(results)}**" + (f" — stopped by {stopped}" if stopped else ""), "",
             "| | scenario | method | steps | wall s | worst drift | checks |", "|---|---|---|---:|---:|---|---|"]
    for r in results:
        lines.append(f"| {icon[r.status]} | `{_md_cell(r.scenario)}` | {r.method} | {r.steps:,} | {r.seconds:.2f} | "
                     f"{_drift_text(r)} | {_checks_text(r)} |")
    failed = [r for r in results if r.status != PASS]
    if failed:
        lines += ["", "### Not passed", ""]
        lines += [f"- **{r.status.upper()}** `{_md_cell(r.scenario)}`: {_md_cell(r.message)}" for r in failed]
    defaults = [r for r in results if r.default_checks and r.checks]
    if defaults:
        lines += ["", "### Default bounds applied (scenarios without `[checks]`)", ""]
        lines += [f"- `{_md_cell(r.scenario)}`: every invariant {r.checks[0]['limit']} — {_md_cell(r.checks[0]['basis'])}" for r in defaults]
    return "\n".join(lines) + "\n"


def write_markdown(results: list[CaseResult], path: Path, append: bool, stopped: str | None = None) -> None:
    """``append`` for ``$GITHUB_STEP_SUMMARY`` (steps add to it); otherwise replace ``path`` whole."""
    text = markdown(results, stopped)
    if not append:
        _atomic_write(path, text)
        return
    try:
        with path.open("a", encoding="utf-8") as f:
            f.write(text)
    except OSError as exc:
        raise RunFailure(f"could not write {path}: {exc.strerror or exc}") from None
