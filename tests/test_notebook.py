"""A run shows itself in a notebook (``Trajectory._repr_html_``): the summary table and inline
SVG plots, the text escaped, a failed run saying why."""

from __future__ import annotations

import re
from xml.etree import ElementTree

import numpy as np

import rotlab
from tests.conftest import CONFIGS
from tests.helpers import scenario


def test_a_run_shows_its_summary_and_plots():
    traj = rotlab.simulate(CONFIGS / "general.toml", duration=2.0)
    page = traj._repr_html_()
    assert traj.stats.method in page and f"{traj.t.shape[0]:,} over" in page and "whole span" in page
    for name in traj.max_drift():
        assert f"max drift, {name}" in page
    svgs = re.findall(r"<svg.*?</svg>", page, flags=re.S)
    assert len(svgs) == 2
    for svg in svgs:
        ElementTree.fromstring(svg)  # well-formed
    omega, energy = svgs
    assert omega.count("<polyline") == 3 and energy.count("<polyline") == 5  # p q r; T V T+V W T+V−W
    # the ω plot's range labels are the data's range
    assert f">{traj.omega.max():.3g}<" in omega and f">{traj.omega.min():.3g}<" in omega


def test_a_failed_run_says_why_escaped_and_breaks_its_lines():
    sc = scenario(body={"principal_moments": [1.0, 2.0, 3.0]}, initial={"omega": [0.1, 0.2, 0.3]},
                  loads=[{"type": "expression", "frame": "body", "torque": ["1/(0.5 - t)", "0", "0"]}],
                  time={"end": 1.0, "samples": 101}, solver={"method": "rk4", "step": 1e-3})
    traj = rotlab.simulate(sc, check=False)
    assert not traj.ok
    page = traj._repr_html_()
    assert "stopped: " in page and "loads[0].torque[0] = &#x27;1/(0.5 - t)&#x27;" in page
    assert "<script" not in page and page.count("<svg") == 2
    assert np.all(np.isfinite(traj.omega[: traj.t.shape[0]]))


def test_a_run_stopped_at_its_first_sample_has_a_table_and_no_plot():
    sc = scenario(body={"principal_moments": [1.0, 2.0, 3.0]}, initial={"omega": [0.1, 0.2, 0.3]},
                  loads=[{"type": "expression", "frame": "body", "torque": ["1/t", "0", "0"]}],
                  time={"end": 1.0, "samples": 11}, solver={"method": "rk4", "step": 1e-2})
    traj = rotlab.simulate(sc, check=False)
    assert traj.t.shape[0] == 1
    page = traj._repr_html_()
    assert "<table>" in page and "<svg" not in page and "stopped: " in page
