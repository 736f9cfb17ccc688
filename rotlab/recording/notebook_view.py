"""``rotlab.show(traj)``: the Rerun viewer inside a Jupyter notebook, showing the run as
``rotlab run``'s recording does — the same writer, series and layout — through Rerun's notebook
widget (``rerun.notebook.Viewer``; optional dependency: ``pip install 'rotlab[notebook]'``).
The data goes to an in-memory recording stream that only the widget reads: nothing is written
to disk."""

from __future__ import annotations

import uuid

import rerun as rr
import rerun.blueprint as rrb

from rotlab.trajectory import Trajectory


class _WidgetSink:
    """What ``RecordingWriter`` needs of a sink (``rec``, the layout, checks), for a notebook
    widget's stream: no file to verify, no viewer to wait for."""

    def __init__(self, rec: rr.RecordingStream) -> None:
        self.rec = rec
        self.blueprint: rrb.Blueprint | None = None

    def open(self, blueprint: rrb.Blueprint) -> None:
        self.blueprint = blueprint

    def update_blueprint(self, blueprint: rrb.Blueprint) -> None:
        self.blueprint = blueprint

    def check(self) -> None:
        return None

    def drain(self) -> None:
        return None

    watched = False  # the widget gets the recording whole


def show(traj: Trajectory, width: int | None = None, height: int | None = None):
    """A ``rerun.notebook.Viewer`` of ``traj`` (the cell's output when it is the last expression)."""
    try:
        from rerun.notebook import HAS_NOTEBOOK, Viewer
    except ImportError:
        HAS_NOTEBOOK = False
    if not HAS_NOTEBOOK:
        raise ImportError("rotlab.show() needs Rerun's notebook widget: pip install 'rotlab[notebook]' (rerun-notebook 0.41)")
    from rotlab.recording.writer import RecordingWriter

    rec = rr.RecordingStream("rotlab", recording_id=str(uuid.uuid4()))
    rec.set_log_time_enabled(False)
    sink = _WidgetSink(rec)
    writer = RecordingWriter(sink, stride=1)  # type: ignore[arg-type]
    writer.write(traj, 0)
    writer.finish(traj.summary(), traj)
    return Viewer(recording=rec, blueprint=sink.blueprint, width=width, height=height)
