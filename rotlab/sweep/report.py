"""Sweep outputs: the results table (``rotlab.sweep.results.Results``: results.csv as cases finish,
then results.csv and results.parquet whole, in case order) and the terminal table.  The recording
that compares the cases is written by ``rotlab.sweep.recording``."""

from __future__ import annotations

import csv
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rotlab.sweep.results import STATUSES, TERMINAL_ROWS, Results


WRITE_ROWS = 16_384  # rows made at a time for the final files (their memory, not the sweep's, bounds it)


def write_results(results: Results, outdir: Path) -> list[Path]:
    """results.csv and results.parquet of every case in case order, ``WRITE_ROWS`` rows at a time
    (a Parquet row group each), atomically; then the partial file written as the cases finished
    goes (it stays should this fail: a full disk)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    results.close()
    header, order = results.header, results.in_case_order()
    csv_path, parquet_path = outdir / "results.csv", outdir / "results.parquet"
    chunks = [order[start:start + WRITE_ROWS] for start in range(0, max(1, order.shape[0]), WRITE_ROWS)]

    def write_csv(tmp: Path) -> None:
        with tmp.open("w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(header)
            for rows in chunks:
                writer.writerows(results.table(rows))

    def column(name: str, rows: np.ndarray) -> pa.Array:
        values = results.values(name, rows)
        if isinstance(values, list):
            return pa.array([text or None for text in values], type=pa.string())
        return pa.array(values, mask=np.isnan(values)) if values.dtype.kind == "f" else pa.array(values)

    def write_parquet(tmp: Path) -> None:
        batches = (pa.record_batch([column(name, rows) for name in header], names=header) for rows in chunks)
        first = next(batches)
        with pq.ParquetWriter(tmp, first.schema) as writer:
            writer.write_batch(first)
            for batch in batches:
                writer.write_batch(batch)

    _atomically({csv_path: write_csv, parquet_path: write_parquet})
    pa.default_memory_pool().release_unused()  # (Arrow's allocator keeps freed memory for reuse)
    results.close(remove=True)
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


def terminal_table(results: Results, how: str) -> str:
    """The results table for the terminal, the failing cases, a count.  A sweep of more than
    ``TERMINAL_ROWS`` cases shows only the rows and messages of (at most ``TERMINAL_ROWS``) cases
    that did not pass: every case is in results.csv."""
    header, total = results.header, len(results)
    order = results.in_case_order()
    failing = order[results.status()[order] != 0]
    shown = order if total <= TERMINAL_ROWS else failing[:TERMINAL_ROWS]
    lines = [f"sweep: {total} cases, run by {how}"]
    if shown.shape[0]:
        table = results.table(shown)
        keep = [k for k, name in enumerate(header) if name not in ("message",)]
        widths = [max(len(str(header[k])), *(len(_fmt(row[k])) for row in table)) for k in keep]
        lines.append("  ".join(str(header[k]).rjust(w) for k, w in zip(keep, widths)))
        lines += ["  ".join(_fmt(row[k]).rjust(w) for k, w in zip(keep, widths)) for row in table]
    passing = total - failing.shape[0]
    if shown.shape[0] < total:
        lines.append(f"({passing:,} passing {'case' if passing == 1 else 'cases'} not shown: every case is in results.csv)")
    case, status = results.column("case"), results.status()
    lines += [f"case {case[k]}: {STATUSES[status[k]].upper()}: {results.messages.get(int(k), '')}" for k in failing[:TERMINAL_ROWS]]
    if failing.shape[0] > TERMINAL_ROWS:
        lines.append(f"(and {failing.shape[0] - TERMINAL_ROWS:,} more cases that did not pass: see results.csv)")
    lines.append(f"{passing} passed, {failing.shape[0]} failed")
    return "\n".join(lines)


def _fmt(value: object) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)
