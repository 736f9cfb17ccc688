"""The run report (Markdown): scenario, method and why, statistics, invariant drift."""

from __future__ import annotations

import numpy as np

from rotlab import geometry_inertia
from rotlab.recording import portrait_view
from rotlab.trajectory import RunSummary


SCENE_KEY = {  # what each drawn thing is (the 3D view's labels are short symbols)
    "x y z": "body axes, red / green / blue (the same colours as the x, y, z and p, q, r series in every plot)",
    "ω": "angular velocity, space frame (orange)",
    "L": "angular momentum, space frame (violet)",
    "cyan trace": "tip of the reference axis (the symmetry axis, else the spin axis: the principal axis nearest L at the start): bright over the last few periods, the whole path dimmed",
    "g": "direction of the uniform field (grey)",
    "F1, M1, mg": "applied loads (magenta): a force at its point of application, a torque at the fixed point, space frame",
    "orange traces": "torque-free: herpolhode on the invariable plane (space) and polhode (body), tips of s·ω",
    "orange wireframe": "torque-free: the energy ellipsoid ω·Iω = 2T (scaled by s), fixed in the body; it rolls on the invariable plane, touching it at the tip of s·ω",
    "green discs": "gyrostat: its rotors on their shafts, fixed in the body; L includes their momentum h",
    "coloured dots": "events: where the reference axis's tip was at each occurrence, in the colour of the event's first series in the Events tab",
}


def run_report(run: RunSummary, scales: dict[str, tuple[float, str]] | None = None) -> str:
    """The report; ``scales``: arrow symbol → (length per unit, unit) as drawn in the 3D view."""
    scene, stats = run.scene, run.stats
    scenario = scene.scenario
    lines = [f"# {scenario.title or 'rotlab run'}", ""]
    if scenario.description:
        lines += [scenario.description, ""]
    lines += [
        f"- scene: **{scene.kind.replace('_', '-')}** — {scene.kind_reason}",
        f"- principal moments: {np.array2string(scene.moments, precision=6)} kg·m²",
        *geometry_inertia.describe(scenario.body),
        *scenario.rotor_lines(),
        f"- method: **{stats.method}** — {stats.reason}",
        f"- samples: {run.samples:,} from {run.start:g} s to {run.end:g} s",
        f"- steps: {stats.steps:,} accepted, {stats.rejected_steps:,} rejected; {stats.rhs_evaluations:,} evaluations of f",
        f"- integration wall time: {stats.seconds:.4g} s",
    ]
    for key, value in stats.details.items():
        lines.append(f"- {key}: {value:.6g}" if isinstance(value, float) else f"- {key}: {value}")
    if run.events:
        lines += ["", "| event | occurrences | first (s) | mean interval (s) |", "|---|---|---|---|"]
        lines += [f"| {name} | {log.count:,} | {log.t[0]:.12g} | " + (f"{float(log.intervals().mean()):.12g} |" if log.count > 1 else "– |")
                  if log.count else f"| {name} | 0 | – | – |" for name, log in run.events.items()]
    lines += ["", "| invariant | max relative drift |", "|---|---|"]
    lines += [f"| {name} | {drift:.3e} |" for name, drift in run.max_drift().items()]
    if stats.failure:
        lines += ["", f"**Run stopped:** {stats.failure}"]
    lines += portrait_view.top_report(scene)
    if scales:
        lines += ["", "## The 3D view", "", "| symbol | what |", "|---|---|"]
        lines += [f"| {symbol} | {what} |" for symbol, what in SCENE_KEY.items()]
        if portrait_view.has_polhodes(scene):
            lines.append(f"| Phase portrait tab | {portrait_view.POLHODE_NOTE} |")
        lines += ["", "Arrow scales: " + "; ".join(f"{symbol}: {value:.3g} {unit}" for symbol, (value, unit) in scales.items())
                  + ". Linear up to the longest arrow of the run's first chunk (length a₀), beyond it a₀(1 + tanh(ln(a/a₀))/2), at most 1.5 a₀: "
                  "a vector that grows later stays in the view; the plots give its magnitude."]
    return "\n".join(lines) + "\n"

