"""A scatter plot drawn with Rerun's 2D primitives: y against x with axes and tick labels.

Rerun's time-series views plot against the active timeline only, so an observable against a
swept parameter is drawn in a 2D view: the data is mapped into a box of ``WIDTH`` × ``HEIGHT``
units (2D y grows downwards), with axis lines and tick labels as labelled points.  A positive
x spanning ≥ ``LOG_SPAN`` (ratio) is drawn on a log10 scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rotlab.recording.style import Color, check_text

WIDTH, HEIGHT = 1.6, 1.0
LOG_SPAN = 20.0
TICKS = 4
AXIS_COLOR: Color = (150, 150, 150)


@dataclass(frozen=True)
class Scatter:
    """What to log: points, axis strips, tick anchors and their labels (plot units)."""

    points: np.ndarray  # (n, 2)
    colors: list[Color]
    axes: list[np.ndarray]  # line strips
    tick_positions: np.ndarray  # (m, 2)
    tick_labels: list[str]
    bounds: tuple[tuple[float, float], tuple[float, float]]  # (x_range, y_range) incl. margins


def use_log(x: np.ndarray) -> bool:
    finite = x[np.isfinite(x)]
    return bool(finite.size and np.all(finite > 0.0) and finite.max() / finite.min() >= LOG_SPAN)


def _ticks(low: float, high: float, log: bool) -> tuple[np.ndarray, list[str]]:
    if log:
        decades = np.arange(math.floor(math.log10(low)), math.ceil(math.log10(high)) + 1)
        values = 10.0 ** decades
        values = values[(values >= low * (1 - 1e-9)) & (values <= high * (1 + 1e-9))]
        if values.size < 2:
            values = np.array([low, high])
        return values, [f"{v:.3g}" for v in values]
    values = np.linspace(low, high, TICKS)
    return values, tick_labels(values)


def tick_labels(values: np.ndarray) -> list[str]:
    """The shortest %g labels that tell equally spaced ticks apart (at most 9 digits)."""
    for digits in range(3, 10):
        labels = [f"{v:.{digits}g}" for v in values]
        if len(set(labels)) == len(labels):
            return labels
    return labels


def scatter(x: np.ndarray, y: np.ndarray, colors: list[Color]) -> Scatter | None:
    """The scatter of the finite (x, y) pairs; None when fewer than one."""
    keep = np.isfinite(x) & np.isfinite(y)
    if not np.any(keep):
        return None
    log = use_log(x)
    xs = np.log10(x[keep]) if log else x[keep]
    ys = y[keep]
    x_low, x_high = float(np.min(x[keep])), float(np.max(x[keep]))
    y_low, y_high = float(np.min(ys)), float(np.max(ys))
    if y_high - y_low <= 1e-12 * max(abs(y_high), 1e-300):
        y_low, y_high = y_low - max(abs(y_low), 1.0) * 0.1, y_high + max(abs(y_high), 1.0) * 0.1
    if x_high == x_low:
        x_low, x_high = (x_low / 2, x_low * 2) if log else (x_low - 1.0, x_high + 1.0)
    fx_low, fx_high = (math.log10(x_low), math.log10(x_high)) if log else (x_low, x_high)

    def to_plot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        px = 0.05 * WIDTH + 0.9 * WIDTH * (u - fx_low) / (fx_high - fx_low)
        py = HEIGHT - (0.05 * HEIGHT + 0.9 * HEIGHT * (v - y_low) / (y_high - y_low))
        return np.column_stack([px, py])

    points = to_plot(xs, ys)
    x_ticks, x_labels = _ticks(x_low, x_high, log)
    y_ticks, y_labels = _ticks(y_low, y_high, False)
    x_anchor = to_plot(np.log10(x_ticks) if log else x_ticks, np.full(len(x_ticks), y_low))
    y_anchor = to_plot(np.full(len(y_ticks), fx_low), y_ticks)
    tick_positions = np.vstack([x_anchor + [0.0, 0.07 * HEIGHT], y_anchor - [0.03 * WIDTH + 0.012 * max(len(s) for s in y_labels), 0.0]])
    labels = [check_text(s) for s in (*x_labels, *y_labels)]
    box = [np.array([[0.0, 0.0], [0.0, HEIGHT], [WIDTH, HEIGHT]])]
    kept_colors = [c for c, k in zip(colors, keep) if k]
    return Scatter(points, kept_colors, box, tick_positions, labels, ((-0.3 * WIDTH, 1.05 * WIDTH), (-0.08 * HEIGHT, 1.2 * HEIGHT)))
