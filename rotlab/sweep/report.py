"""Sweep outputs: a results table (CSV and Parquet), a terminal table, and one recording that
compares the cases (ω body components and energy drift of each case on one timeline)."""

from __future__ import annotations

import csv
import os
import uuid
from pathlib import Path

import numpy as np

from rotlab.recording.layout import TIMELINE
from rotlab.sweep.runner import CaseOutcome

MAX_COMPARED = 50


def rows(outcomes: list[CaseOutcome]) -> tuple[list[str], list[list[object]]]:
    """Column names and rows: case, one column per parameter (vectors spread out), results."""
    params: list[str] = []
    for o in outcomes:
        for key, value in o.values.items():
            names = [f"{key}[{i}]" for i in range(len(value))] if isinstance(value, list) else [key]
            params += [n for n in names if n not in params]
    invariants: list[str] = []
    for o in outcomes:
        invariants += [n for n in o.drift if n not in invariants]
    header = ["case", *params, "status", "method", "steps", "seconds", *[f"max_drift_{n}" for n in invariants], "message"]
    table = []
    for o in outcomes:
        flat: dict[str, object] = {}
        for key, value in o.values.items():
            if isinstance(value, list):
                flat.update({f"{key}[{i}]": v for i, v in enumerate(value)})
            else:
                flat[key] = value
        table.append([o.index, *[flat.get(p, "") for p in params], o.status, o.method, o.steps, round(o.seconds, 6),
                      *[o.drift.get(n, "") for n in invariants], o.message])
    return header, table


def write_results(outcomes: list[CaseOutcome], outdir: Path) -> list[Path]:
    """results.csv and results.parquet (atomically)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    header, table = rows(outcomes)
    csv_path, parquet_path = outdir / "results.csv", outdir / "results.parquet"
    tmp = csv_path.with_name(f".{csv_path.name}.{os.getpid()}.tmp")
    with tmp.open("w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows(table)
    os.replace(tmp, csv_path)
    columns = {name: [row[k] if row[k] != "" else None for row in table] for k, name in enumerate(header)}
    tmp = parquet_path.with_name(f".{parquet_path.name}.{os.getpid()}.tmp")
    pq.write_table(pa.table(columns), tmp)
    os.replace(tmp, parquet_path)
    return [csv_path, parquet_path]


def terminal_table(outcomes: list[CaseOutcome], how: str) -> str:
    header, table = rows(outcomes)
    keep = [k for k, name in enumerate(header) if name not in ("message",)]
    widths = [max(len(str(header[k])), *(len(_fmt(r[k])) for r in table)) for k in keep]
    lines = [f"sweep: {len(outcomes)} cases, run by {how}", "  ".join(str(header[k]).rjust(w) for k, w in zip(keep, widths))]
    lines += ["  ".join(_fmt(r[k]).rjust(w) for k, w in zip(keep, widths)) for r in table]
    lines += [f"case {o.index}: {o.status.upper()}: {o.message}" for o in outcomes if o.status != "pass"]
    passed = sum(o.status == "pass" for o in outcomes)
    lines.append(f"{passed} passed, {len(outcomes) - passed} failed")
    return "\n".join(lines)


def _fmt(value: object) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def write_comparison(outcomes: list[CaseOutcome], path: Path, title: str) -> Path:
    """One recording: /cases/<k>/omega and /cases/<k>/energy_drift for up to 50 cases."""
    import rerun as rr
    import rerun.blueprint as rrb

    from rotlab.recording.writer import check_output_path

    check_output_path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    shown = [o for o in outcomes if o.t is not None][:MAX_COMPARED]
    blueprint = rrb.Blueprint(
        rrb.Vertical(
            rrb.TimeSeriesView(origin="/cases", contents="/cases/*/omega", name="ω body frame per case (rad/s)"),
            rrb.TimeSeriesView(origin="/cases", contents="/cases/*/energy_drift", name="energy drift per case (relative)"),
            rrb.TextDocumentView(origin="/sweep", name="Sweep"),
            row_shares=[3, 2, 1],
        )
    )
    try:
        rec = rr.RecordingStream("rotlab-sweep", recording_id=uuid.uuid4())
        rec.save(tmp, default_blueprint=blueprint)
        header, table = rows(outcomes)
        md = [f"# {title or 'sweep'}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        md += ["| " + " | ".join(_fmt(v) for v in r) + " |" for r in table]
        rec.log("/sweep", rr.TextDocument("\n".join(md), media_type="text/markdown"), static=True)
        for o in shown:
            index = [rr.TimeColumn(TIMELINE, duration=np.round(o.t * 1e9).astype(np.int64).astype("timedelta64[ns]"))]
            rec.log(f"/cases/{o.index}/omega", rr.SeriesLines(names=[f"case {o.index} p", f"case {o.index} q", f"case {o.index} r"]), static=True)
            rec.log(f"/cases/{o.index}/energy_drift", rr.SeriesLines(names=[f"case {o.index}"]), static=True)
            rec.send_columns(f"/cases/{o.index}/omega", index, rr.Scalars.columns(scalars=o.omega))
            rec.send_columns(f"/cases/{o.index}/energy_drift", index, rr.Scalars.columns(scalars=o.energy_drift[:, None]))
        rec.flush()
        rec.disconnect()
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path
