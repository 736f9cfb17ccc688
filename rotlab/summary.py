"""The short run summary printed by ``rotlab run``."""

from __future__ import annotations

from pathlib import Path

from rotlab.trajectory import Trajectory


def summary_lines(traj: Trajectory, config: Path, output: Path, wall: float) -> list[str]:
    scene, stats = traj.scene, traj.stats
    n = traj.t.shape[0]
    span = f"{traj.t[0]:g}–{traj.t[-1]:g} s" if n else "nothing"
    drift = " | ".join(f"{name} {value:.1e}" for name, value in traj.max_drift().items())
    size = output.stat().st_size if output.exists() else 0
    return [
        f"{config.name}: {scene.kind.replace('_', '-')} scene — {scene.kind_reason}",
        f"  method   {stats.method} ({stats.reason})",
        f"  run      {n:,} samples over {span}; {stats.steps:,} steps ({stats.rejected_steps:,} rejected); "
        f"integration {stats.seconds:.3g} s, total {wall:.3g} s",
        f"  drift    {drift}  (max relative, over the run)",
        f"  wrote    {output} ({size / 1e6:.2f} MB) — open with: rerun {output}",
    ]
