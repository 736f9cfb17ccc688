"""A run's events in the recording (``rotlab.events``): each event's occurrences as markers on
a plot of its own (the ``record`` values, else the occurrence number, at each time), and an
event that records two or more values as its Poincaré section, a point cloud of
(record[0], record[1]) accumulated over the run (``layout.EVENTS``, ``layout.SECTIONS``)."""

from __future__ import annotations

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from rotlab.core import quaternion as quat
from rotlab.events import EventLog
from rotlab.recording import layout, style

MARKER_SIZE = 4.0
MARGIN = 0.08  # around a section's points, of their span
MARKER_RADIUS_3D = rr.components.Radius.ui_points(4.0)
SECTION_RADIUS = rr.components.Radius.ui_points(2.5)


def log_events(rec: rr.RecordingStream, events: dict[str, EventLog], axis: np.ndarray, reach: float) -> None:
    """Write every event's markers and, where it has one, its section; in the 3D view, where
    the reference axis's tip (``axis``, user's body frame, at distance ``reach``) was at each
    occurrence (``layout.EVENTS_3D``)."""
    for k, (name, log) in enumerate(events.items()):
        if not log.count:
            continue
        path = f"{layout.EVENTS}/{name}"
        values, names = _marked(log)
        colors = [style.HUES[(k + j) % len(style.HUES)] for j in range(len(names))]  # the first: the event's own
        rec.log(path, rr.SeriesPoints(names=[style.drawable(n) for n in names], marker_sizes=[MARKER_SIZE] * len(names), colors=colors),
                static=True)
        ns = np.round(log.t * 1e9).astype(np.int64).astype("timedelta64[ns]")  # as the run's timeline (writer._nanoseconds)
        rec.send_columns(path, [rr.TimeColumn(layout.TIMELINE, duration=ns)], rr.Scalars.columns(scalars=values))
        if len(log.record) >= 2:
            rec.log(f"{layout.SECTIONS}/{name}", rr.Points2D(log.values[:, :2], radii=SECTION_RADIUS, colors=style.SECTION), static=True)
        unit_q = log.quaternion / np.linalg.norm(log.quaternion, axis=1, keepdims=True)
        tips = quat.rotate_to_space_array(unit_q, np.broadcast_to(reach * axis, (log.count, 3)))
        rec.log(f"{layout.EVENTS_3D}/{name}", rr.Points3D(tips, radii=MARKER_RADIUS_3D, colors=style.HUES[k % len(style.HUES)]),
                static=True)


def event_views(events: dict[str, EventLog], span: tuple[float, float] | None) -> list[rrb.View]:
    """The views of the events: one plot each, and the section of each event that has one."""
    views: list[rrb.View] = []
    for name, log in events.items():
        views.append(rrb.TimeSeriesView(origin=f"{layout.EVENTS}/{name}", name=style.drawable(f"event {name}: {log.count:,} occurrences"),
                                        axis_x=layout.whole_span(span), plot_legend=rrb.PlotLegend(corner="RightTop", visible=True)))
        if len(log.record) >= 2 and log.count:
            views.append(rrb.Spatial2DView(origin=f"{layout.SECTIONS}/{name}", visual_bounds=_bounds(log.values[:, :2]),
                                           name=style.drawable(f"section {name}: {log.record[1]} (down) vs {log.record[0]} (right)")))
    return views


def _bounds(points: np.ndarray) -> rrb.VisualBounds2D:
    """The section's points with a margin of ``MARGIN`` of their span on every side (of a tenth
    of their magnitude where they do not spread: a periodic motion returns to one point)."""
    low, high = points.min(axis=0), points.max(axis=0)
    pad = MARGIN * np.maximum(high - low, np.maximum(0.1 * np.maximum(np.abs(low), np.abs(high)), 1e-12))
    return rrb.VisualBounds2D(x_range=[low[0] - pad[0], high[0] + pad[0]], y_range=[low[1] - pad[1], high[1] + pad[1]])


def _marked(log: EventLog) -> tuple[np.ndarray, list[str]]:
    """The values marked at each occurrence and their names: the ``record`` formulas, or the
    occurrence number when there are none."""
    if log.record:
        return log.values, list(log.record)
    return np.arange(1, log.count + 1, dtype=float)[:, None], ["occurrence"]
