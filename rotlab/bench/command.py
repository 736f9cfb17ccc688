"""``rotlab bench``: the benchmark suite as a typer command.  Nothing heavy is imported at module
level (``rotlab --help`` must not import numpy): every import is inside ``bench``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer

SECTIONS = ("wp", "throughput", "overhead", "runs", "drift")


def bench(
    quick: Annotated[bool, typer.Option("--quick", help="A subset that runs in under two minutes.")] = False,
    json_path: Annotated[Optional[Path], typer.Option("--json", help="Write every record as a JSON list to PATH.")] = None,
    plots: Annotated[Optional[Path], typer.Option("--plots", help="Write work-precision PNGs to DIR (needs matplotlib).")] = None,
    repeats: Annotated[Optional[int], typer.Option("--repeats", min=1, help="Repeats per timing (median); default 5, 3 with --quick.")] = None,
    problem: Annotated[Optional[list[str]], typer.Option("--problem", "-p", help="Only these problems (repeat the option); default all.")] = None,
    only: Annotated[Optional[str], typer.Option("--only", help=f"Comma-separated sections: {', '.join(SECTIONS)} (default all).")] = None,
    details: Annotated[bool, typer.Option("--details", help="Also print every run as it is timed, each problem's work-precision table and the full speed-up tables.")] = False,
) -> None:
    """Benchmark rotlab against scipy solve_ivp and the seeds' RK4: work-precision on the test
    problems (with `auto` as its own row, and the lead over rotlab's dop853), throughput, the
    per-call overhead of rotlab.simulate, `rotlab run` cold/warm wall time against the import of
    its dependencies, long-run energy error.  A headline table comes first; ``--details`` prints
    the rest."""
    import time

    from rotlab.bench import report, runner
    from rotlab.bench.problems import get_problems

    sections = SECTIONS if not only else tuple(s.strip() for s in only.split(","))
    unknown = [s for s in sections if s not in SECTIONS]
    if unknown:
        typer.echo(f"rotlab: error: --only: unknown section(s) {', '.join(unknown)}: choose from {', '.join(SECTIONS)}", err=True)
        raise typer.Exit(2)
    try:
        problems = get_problems(problem, quick=quick) if "wp" in sections else []
    except KeyError as exc:
        typer.echo(f"rotlab: error: --problem: {exc.args[0]}", err=True)
        raise typer.Exit(2)
    if plots is not None:
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            typer.echo("rotlab: error: --plots needs matplotlib, which is not a rotlab dependency: pip install matplotlib (or pip install 'rotlab[plots]')", err=True)
            raise typer.Exit(2)

    options = runner.Options.make(quick, repeats, log=(lambda line: typer.echo(line, err=True)) if details else (lambda line: None))
    started = time.perf_counter()
    typer.echo(f"rotlab bench ({'quick' if quick else 'full'}, repeats {options.repeats}); 1-min load average at start: {_load()}")
    records: list[runner.Record] = []
    extra: list[dict] = []
    titles = {}
    detail_tables: list[str] = []
    if problems:
        runner.warm_up_peers()
    for p in problems:
        began = time.perf_counter()
        recs, ref = runner.run_problem(p, options)
        records.extend(recs)
        titles[p.name] = p.title
        detail_tables.append(report.work_precision_table(recs, p.name, p.title, ref.how + (f"; check vs {ref.check_how}: {ref.check:.2g}" if ref.check is not None else "")))
        if not details:
            typer.echo(f"   {p.name}: {len(recs)} runs timed in {time.perf_counter() - began:.1f} s", err=True)
    if records:
        ratio_rows = {threshold: runner.ratios(records, threshold) for threshold in (runner.THRESHOLD, 1e-8)}
        lead_rows = runner.leads(records)
        extra.extend(row for rows in ratio_rows.values() for row in rows)
        extra.extend(lead_rows)
        typer.echo(report.headline_table(ratio_rows[runner.THRESHOLD], lead_rows))
        typer.echo("")
        typer.echo(report.lead_table(lead_rows))
        typer.echo("")
        if details:
            for table in [*detail_tables, *(report.ratio_table(rows) for rows in ratio_rows.values())]:
                typer.echo(table)
                typer.echo("")
    if "throughput" in sections:
        rows = runner.kernel_throughput(options)
        recording = runner.recording_throughput(options)
        extra.extend(rows)
        extra.append(recording)
        typer.echo(report.throughput_table(rows, recording))
        typer.echo("")
    if "overhead" in sections:
        rows = runner.call_overhead(options)
        extra.extend(rows)
        typer.echo(report.overhead_table(rows))
        typer.echo("")
    if "runs" in sections:
        rows = runner.run_timing(options)
        extra.extend(rows)
        typer.echo(report.run_timing_table(rows))
        typer.echo("")
    if "drift" in sections:
        rows = runner.energy_windows(options)
        extra.extend(rows)
        typer.echo(report.energy_table(rows))
        typer.echo("")
    if json_path is not None:
        report.write_json(json_path, records, extra)
        typer.echo(f"wrote {json_path}")
    if plots is not None and records:
        for path in report.write_plots(plots, records, titles):
            typer.echo(f"wrote {path}")
    typer.echo(f"bench finished in {time.perf_counter() - started:.1f} s ({'quick' if quick else 'full'}, repeats {options.repeats}); "
               f"1-min load average at the end: {_load()}")


def _load() -> str:
    import os

    try:
        return f"{os.getloadavg()[0]:.2f}"
    except (AttributeError, OSError):
        return "n/a"
