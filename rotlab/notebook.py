"""A run as a notebook shows it (``Trajectory._repr_html_``): a summary table (scene, method and
why, samples, steps, time, the invariants' drift, how the run ended) and small inline SVG plots
of ω (body frame) and the energies over time.  Plain HTML and SVG: nothing to install, and the
page renders the same anywhere (a notebook, a saved HTML export, a GitHub preview)."""

from __future__ import annotations

import html
from typing import Any

import numpy as np

PLOT_WIDTH, PLOT_HEIGHT, MARGIN = 360, 130, 34  # px
MAX_POINTS = 400  # per line: more than a 360 px plot can show
COLORS = ("#d62728", "#2ca02c", "#1f77b4", "#ff7f0e", "#9467bd")  # the recording's x, y, z order first


def trajectory_html(traj: Any) -> str:
    """The HTML of ``traj`` (a ``rotlab.trajectory.Trajectory``)."""
    stats, scene = traj.stats, traj.scene
    n = traj.t.shape[0]
    span = f"{traj.t[0]:g} – {traj.t[-1]:g} s" if n else "no samples"
    rows = [
        ("scene", f"{scene.kind.replace('_', '-')}: {scene.kind_reason}"),
        ("method", stats.method),
        ("samples", f"{n:,} over {span}"),
        ("steps", f"{stats.steps:,} ({stats.rejected_steps:,} rejected)"),
        ("time", f"{stats.seconds:.3g} s integrating" + (f" + {stats.compile_seconds:.3g} s loading or compiling kernels" if stats.compile_seconds else "")),
    ]
    rows += [(f"max drift, {name}", f"{value:.2e} (relative)") for name, value in traj.max_drift().items()]
    rows.append(("ended", "whole span" if traj.ok else f"stopped: {stats.failure}"))
    title = scene.scenario.title or "rotlab run"
    table = "".join(f"<tr><th style='text-align:left;padding-right:1em'>{html.escape(k)}</th><td style='text-align:left'>{html.escape(v)}</td></tr>"
                    for k, v in rows)
    why = f"<details><summary>why {html.escape(stats.method)}</summary><p>{html.escape(stats.reason)}</p></details>"
    plots = ""
    if n >= 2:
        energies = [("T", traj.kinetic)]
        if traj.potential is not None:
            energies += [("V", traj.potential), ("T+V", traj.total)]
        if traj.work is not None:
            energies += [("W", traj.work), ("T+V−W", traj.total - traj.work)]
        plots = (svg_plot(traj.t, [("p", traj.omega[:, 0]), ("q", traj.omega[:, 1]), ("r", traj.omega[:, 2])], "ω body (rad/s)")
                 + svg_plot(traj.t, energies, "energy (J)"))
    return (f"<div><strong>{html.escape(title)}</strong><table>{table}</table>{why}"
            f"<div style='display:flex;gap:1em;flex-wrap:wrap'>{plots}</div></div>")


def svg_plot(t: np.ndarray, lines: list[tuple[str, np.ndarray]], title: str) -> str:
    """A small line plot of ``lines`` (name, values) against ``t``: the value range on the left,
    the time span below, a legend on top; non-finite values break a line."""
    stride = max(1, t.shape[0] // MAX_POINTS)
    tt = t[::stride]
    finite = np.concatenate([v[::stride][np.isfinite(v[::stride])] for _, v in lines] or [np.zeros(0)])
    low, high = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    if high - low <= 1e-12 * max(abs(low), abs(high), 1e-300):
        low, high = low - 1.0, high + 1.0  # a constant: drawn flat in the middle
    t0, t1 = float(tt[0]), float(tt[-1]) if tt[-1] > tt[0] else float(tt[0]) + 1.0
    width, height = PLOT_WIDTH - MARGIN - 6, PLOT_HEIGHT - 2 * MARGIN // 2 - 20

    def x(values: np.ndarray) -> np.ndarray:
        return MARGIN + (values - t0) / (t1 - t0) * width

    def y(values: np.ndarray) -> np.ndarray:
        return 18 + (high - values) / (high - low) * height

    parts = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{PLOT_WIDTH}' height='{PLOT_HEIGHT}' style='font:10px sans-serif'>",
             f"<rect x='{MARGIN}' y='18' width='{width}' height='{height:.0f}' fill='none' stroke='#bbb'/>",
             f"<text x='{MARGIN}' y='11'>{html.escape(title)}</text>",
             f"<text x='2' y='24'>{high:.3g}</text><text x='2' y='{18 + height:.0f}'>{low:.3g}</text>",
             f"<text x='{MARGIN}' y='{PLOT_HEIGHT - 4}'>{t0:g} s</text>",
             f"<text x='{PLOT_WIDTH - 6}' y='{PLOT_HEIGHT - 4}' text-anchor='end'>{t1:g} s</text>"]
    for k, (name, values) in enumerate(lines):
        color = COLORS[k % len(COLORS)]
        parts.append(f"<text x='{PLOT_WIDTH - 6 - 42 * (len(lines) - 1 - k)}' y='11' text-anchor='end' fill='{color}'>{html.escape(name)}</text>")
        v = values[::stride]
        for segment in _finite_runs(v):
            points = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(x(tt[segment]), y(v[segment])))
            parts.append(f"<polyline fill='none' stroke='{color}' stroke-width='1.2' points='{points}'/>")
    parts.append("</svg>")
    return "".join(parts)


def _finite_runs(values: np.ndarray) -> list[slice]:
    """The slices of consecutive finite values (a line breaks where the run blew up)."""
    finite = np.isfinite(values)
    edges = np.flatnonzero(np.diff(np.r_[0, finite.astype(np.int8), 0]))
    return [slice(a, b) for a, b in zip(edges[::2], edges[1::2])]
