"""Sweep outputs: a results table (CSV and Parquet) and a terminal table.  One row per case:
its parameters, status, method, steps, wall time (``seconds``: this case's own run and its share
of the report made for its worker's chunk of cases; empty when the cases ran together in the
ensemble kernel), the observables of ``rotlab.sweep.observables`` and the max drift of each
invariant.  The recording that compares the cases is written by
``rotlab.sweep.recording``."""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Callable
from pathlib import Path

from rotlab.sweep.runner import CaseOutcome


Table = tuple[list[str], list[list[object]]]  # the results table: header, rows
TERMINAL_ROWS = 50  # a larger sweep's terminal table shows only the cases that did not pass


def rows(outcomes: list[CaseOutcome]) -> Table:
    """Column names and rows: case, one column per parameter (vectors spread out), results."""
    params: list[str] = []
    for o in outcomes:
        for key, value in o.values.items():
            names = [f"{key}[{i}]" for i in range(len(value))] if isinstance(value, list) else [key]
            params += [n for n in names if n not in params]
    invariants: list[str] = []
    observables: list[str] = []
    for o in outcomes:
        invariants += [n for n in o.drift if n not in invariants]
        observables += [n for n in o.observables if n not in observables]
    header = ["case", *params, "status", "method", "steps", "seconds", *observables,
              *[f"max_drift_{n}" for n in invariants], "message"]
    table = []
    for o in outcomes:
        flat: dict[str, object] = {}
        for key, value in o.values.items():
            if isinstance(value, list):
                flat.update({f"{key}[{i}]": v for i, v in enumerate(value)})
            else:
                flat[key] = value
        table.append([o.index, *[flat.get(p, "") for p in params], o.status, o.method, o.steps, _number(o.seconds, 6),
                      *[_number(o.observables.get(n, math.nan), 9) for n in observables],
                      *[o.drift.get(n, "") for n in invariants], o.message])
    return header, table


def _number(value: float, digits: int) -> float | str:
    """A table cell: the value rounded to ``digits`` decimals, or empty when undefined (NaN)."""
    return "" if not math.isfinite(value) else round(float(value), digits)


def write_results(results: Table, outdir: Path) -> list[Path]:
    """results.csv and results.parquet of the results table (``rows``), atomically."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    header, table = results
    csv_path, parquet_path = outdir / "results.csv", outdir / "results.parquet"

    def write_csv(tmp: Path) -> None:
        with tmp.open("w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(header)
            writer.writerows(table)

    columns = {name: [row[k] if row[k] != "" else None for row in table] for k, name in enumerate(header)}
    _atomically({csv_path: write_csv, parquet_path: lambda tmp: pq.write_table(pa.table(columns), tmp)})
    return [csv_path, parquet_path]


def _atomically(writers: dict[Path, Callable[[Path], None]]) -> None:
    """Each ``write`` to a temporary file beside its path, then every file renamed into place:
    on any failure (a full disk) the temporary files go and the old files stay as they were."""
    temporary = {path: path.with_name(f".{path.name}.{os.getpid()}.tmp") for path in writers}
    try:
        for path, write in writers.items():
            write(temporary[path])
    except BaseException:
        for tmp in temporary.values():
            tmp.unlink(missing_ok=True)
        raise
    for path, tmp in temporary.items():
        os.replace(tmp, path)


def terminal_table(outcomes: list[CaseOutcome], how: str, results: Table) -> str:
    """The results table (``rows(outcomes)``) for the terminal, the failing cases, a count.  A
    sweep of more than ``TERMINAL_ROWS`` cases shows only the rows and messages of (at most
    ``TERMINAL_ROWS``) cases that did not pass: every case is in results.csv."""
    header, table = results
    failing = [k for k, o in enumerate(outcomes) if o.status != "pass"]
    shown = range(len(table)) if len(table) <= TERMINAL_ROWS else failing[:TERMINAL_ROWS]
    lines = [f"sweep: {len(outcomes)} cases, run by {how}"]
    if shown:
        keep = [k for k, name in enumerate(header) if name not in ("message",)]
        widths = [max(len(str(header[k])), *(len(_fmt(table[i][k])) for i in shown)) for k in keep]
        lines.append("  ".join(str(header[k]).rjust(w) for k, w in zip(keep, widths)))
        lines += ["  ".join(_fmt(table[i][k]).rjust(w) for k, w in zip(keep, widths)) for i in shown]
    passing = len(outcomes) - len(failing)
    if len(shown) < len(table):
        lines.append(f"({passing:,} passing {'case' if passing == 1 else 'cases'} not shown: every case is in results.csv)")
    lines += [f"case {outcomes[k].index}: {outcomes[k].status.upper()}: {outcomes[k].message}" for k in failing[:TERMINAL_ROWS]]
    if len(failing) > TERMINAL_ROWS:
        lines.append(f"(and {len(failing) - TERMINAL_ROWS:,} more cases that did not pass: see results.csv)")
    lines.append(f"{passing} passed, {len(failing)} failed")
    return "\n".join(lines)


def _fmt(value: object) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)
