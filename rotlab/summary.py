"""The short run summary printed by ``rotlab run``."""

from __future__ import annotations

from pathlib import Path

from rotlab.trajectory import RunSummary


def summary_lines(run: RunSummary, config: Path, output: Path | None, wall: float, writing: float = 0.0,
                  live: str | None = None) -> list[str]:
    """``writing``: seconds spent converting and sending samples (streamed runs interleave it with
    the integration, whose own time is ``run.stats.seconds``); ``live``: where the run was streamed."""
    scene, stats = run.scene, run.stats
    span = f"{run.start:g}–{run.end:g} s" if run.samples else "nothing"
    drift = " | ".join(f"{name} {value:.1e}" for name, value in run.max_drift().items())
    lines = [
        f"{config.name}: {scene.kind.replace('_', '-')} scene — {scene.kind_reason}",
        f"  method   {stats.method} ({stats.reason})",
        f"  run      {run.samples:,} samples over {span}; {stats.steps:,} steps ({stats.rejected_steps:,} rejected); "
        f"integration {stats.seconds:.3g} s{_compiling(stats.compile_seconds)}, " + (f"writing {writing:.3g} s, " if writing else "") + f"total {wall:.3g} s",
        f"  drift    {drift}  (max relative, over the run)",
    ]
    lines += event_lines(run)
    if "ended by" in stats.details:
        lines.append(f"  ended    by {stats.details['ended by']}")
    if output is not None:
        size = output.stat().st_size if output.exists() else 0
        lines.append(f"  wrote    {output} ({size / 1e6:.2f} MB) — open with: rerun {output}")
    if live:
        lines.append(f"  live     {live}")
    return lines


def event_lines(run: RunSummary) -> list[str]:
    """One line per event: how many occurrences, the first time and the mean interval."""
    lines = []
    for name, log in run.events.items():
        first = f", first at t = {log.t[0]:.12g} s" if log.count else ""
        mean = f", mean interval {float(log.intervals().mean()):.12g} s" if log.count > 1 else ""
        lines.append(f"  event    {name}: {log.count:,} occurrence{'s' if log.count != 1 else ''}{first}{mean}")
    return lines


def _compiling(seconds: float) -> str:
    """The numba compile / cache-load time of the run, when there was any."""
    return f" (+ {seconds:.3g} s compiling or loading numba kernels)" if seconds >= 5e-4 else ""
