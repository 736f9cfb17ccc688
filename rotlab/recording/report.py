"""The run report (Markdown): scenario, method and why, statistics, invariant drift."""

from __future__ import annotations

import numpy as np

from rotlab.trajectory import Trajectory


def run_report(traj: Trajectory) -> str:
    scene, stats = traj.scene, traj.stats
    scenario = scene.scenario
    lines = [f"# {scenario.title or 'rotlab run'}", ""]
    if scenario.description:
        lines += [scenario.description, ""]
    lines += [
        f"- scene: **{scene.kind.replace('_', '-')}** — {scene.kind_reason}",
        f"- principal moments: {np.array2string(scene.moments, precision=6)} kg·m²",
        f"- method: **{stats.method}** — {stats.reason}",
        f"- samples: {traj.t.shape[0]:,} from {traj.t[0] if len(traj.t) else 0:g} s to {traj.t[-1] if len(traj.t) else 0:g} s",
        f"- steps: {stats.steps:,} accepted, {stats.rejected_steps:,} rejected; {stats.rhs_evaluations:,} evaluations of f",
        f"- integration wall time: {stats.seconds:.4g} s",
    ]
    for key, value in stats.details.items():
        lines.append(f"- {key}: {value:.6g}" if isinstance(value, float) else f"- {key}: {value}")
    lines += ["", "| invariant | max relative drift |", "|---|---|"]
    lines += [f"| {name} | {drift:.3e} |" for name, drift in traj.max_drift().items()]
    if stats.failure:
        lines += ["", f"**Run stopped:** {stats.failure}"]
    return "\n".join(lines) + "\n"
