"""``rotlab.show(traj)``: the run in Rerun's notebook widget, written by the recording's own writer
(the widget queues what it is sent until a notebook front end connects: the test reads that queue,
a detail of rerun-notebook 0.41), and a one-line ImportError without the optional package."""

from __future__ import annotations

import time

import pytest

import rotlab
from tests.conftest import CONFIGS


def test_show_gives_the_notebook_viewer_the_whole_run(tmp_path):
    notebook = pytest.importorskip("rerun.notebook")
    if not notebook.HAS_NOTEBOOK:
        pytest.skip("rerun-notebook is not installed (pip install 'rotlab[notebook]')")
    traj = rotlab.simulate(CONFIGS / "lagrange.toml", duration=0.5)
    viewer = rotlab.show(traj, width=800, height=500)
    assert isinstance(viewer, notebook.Viewer)
    deadline = time.monotonic() + 10.0
    queued = 0
    while time.monotonic() < deadline:  # Rerun's sink flushes on its own thread
        queued = sum(len(buffers[0]) for _, buffers in viewer._viewer._event_queue if buffers)
        if queued > 0.5 * rotlab.save(tmp_path / "run.rrd", traj).stat().st_size:
            break
        time.sleep(0.2)
    assert queued > 0.5 * (tmp_path / "run.rrd").stat().st_size  # the run's data, not just a layout


def test_show_without_the_notebook_package_says_how_to_get_it(monkeypatch):
    notebook = pytest.importorskip("rerun.notebook")
    monkeypatch.setattr(notebook, "HAS_NOTEBOOK", False)
    traj = rotlab.simulate(CONFIGS / "euler.toml", duration=0.1)
    with pytest.raises(ImportError, match=r"pip install 'rotlab\[notebook\]'"):
        rotlab.show(traj)
