"""``rotlab plot``: report figures read back from a recording — the viewer's panels with their
units, the events and Poincaré sections, a chosen span, PDF/SVG/PNG written whole; bad input is a
one-line error and no file."""

from __future__ import annotations

import numpy as np
import pytest

import rotlab
from rotlab.recording.plot import MAX_POINTS, envelope
from tests.conftest import CONFIGS


@pytest.fixture(scope="module")
def top_rrd(tmp_path_factory):
    path = tmp_path_factory.mktemp("plot") / "top.rrd"
    rotlab.save(path, rotlab.simulate(CONFIGS / "lagrange.toml", duration=2.0))
    return path


@pytest.mark.parametrize("suffix, magic", [(".png", b"\x89PNG"), (".pdf", b"%PDF"), (".svg", b"<?xml")])
def test_every_panel_of_a_top_in_each_format(cli, top_rrd, tmp_path, suffix, magic):
    result = cli("plot", str(top_rrd), "-o", f"fig{suffix}")
    assert result.exit_code == 0, result.output
    assert result.stdout.strip() == f"wrote fig{suffix}: omega, L_space, theta, psi, spin_rate, potential, energy, invariants_log10"
    assert (tmp_path / f"fig{suffix}").read_bytes()[:len(magic)] == magic
    assert not list(tmp_path.glob(".fig*"))  # no temporary left


def test_chosen_panels_span_and_sections(cli, tmp_path):
    cli("run", str(CONFIGS / "chaotic_top.toml"), "--set", "time.end=100", "-q", "-o", "c.rrd")
    result = cli("plot", "c.rrd", "-o", "s.svg", "--panels", "omega,section_section", "--from", "20", "--to", "80")
    assert result.exit_code == 0, result.output
    svg = (tmp_path / "s.svg").read_text()
    assert "ω body (rad/s)" in svg and "omega[0]" in svg and "Poincaré section section" in svg
    section = rotlab.simulate(CONFIGS / "chaotic_top.toml", overrides={"time.end": 100.0}).events["section"]
    inside = int(np.sum((section.t >= 20) & (section.t <= 80)))
    assert f"{inside} points" in svg
    events = cli("plot", "c.rrd", "-o", "e.svg", "--panels", "event_section", "--from", "20", "--to", "80")
    assert events.exit_code == 0 and f"omega[0] ({inside:,} in the span)" in (tmp_path / "e.svg").read_text()


@pytest.mark.parametrize("args, key, words", [
    (["-o", "fig.jpg"], "--output", "give a name ending in .pdf, .svg, .png"),
    (["--panels", "omega,spin"], "--panels", "no panel 'spin' in this recording: choose from omega, L_space, theta"),
    (["--from", "5"], "--from", "outside the recording's span [0, 2] s"),
    (["--from", "1", "--to", "0.5"], "--to", "must be after --from"),
    (["--size", "big"], "--size", "WIDTHxHEIGHT"),
])
def test_bad_input_is_one_line_and_writes_nothing(cli, top_rrd, tmp_path, args, key, words):
    result = cli("plot", str(top_rrd), *(args if "-o" in args else ["-o", "fig.png", *args]))
    assert result.exit_code == 2 and key in result.stderr and words in result.stderr, result.output
    assert result.stderr.count("\n") == 1 and not list(tmp_path.glob("fig*"))


def test_a_file_that_is_not_a_recording_is_refused(cli, tmp_path):
    (tmp_path / "x.rrd").write_bytes(b"not a recording")
    result = cli("plot", "x.rrd", "-o", "f.png")
    assert result.exit_code == 2 and "not a complete rotlab run recording" in result.stderr and "Warning" not in result.stderr


def test_a_long_series_is_drawn_as_its_envelope():
    t = np.linspace(0.0, 100.0, 1_000_001)
    y = np.sin(2 * np.pi * 37.3 * t) * (1 + 0.1 * np.sin(t)) + np.random.default_rng(1).normal(0, 1e-3, t.size)
    te, ye = envelope(t, y)
    assert te.size <= MAX_POINTS and np.all(np.diff(te) >= 0)
    assert ye.max() == y.max() and ye.min() == y.min()  # every bucket's extremes are kept: the band stays
    short = y[:100]
    assert envelope(t[:100], short)[1] is short  # a short one as it is


def test_several_runs_are_overlaid(cli, top_rrd, tmp_path):
    rotlab.save(tmp_path / "rk4.rrd", rotlab.simulate(CONFIGS / "lagrange.toml", method="rk4", duration=2.0, overrides={"solver.step": 2e-3}))
    result = cli("plot", str(top_rrd), "rk4.rrd", "-o", "cmp.svg", "--panels", "theta,invariants_log10", "--to", "1")
    assert result.exit_code == 0, result.output
    svg = (tmp_path / "cmp.svg").read_text()
    assert "Comparison: top, rk4" in svg and "top: θ" in svg and "rk4: θ" in svg and "rk4: T+V−W" in svg


def test_overlaid_runs_are_drawn_in_the_first_runs_unit(cli, tmp_path, monkeypatch):
    """Each run's load plots have their own SI prefix (``visuals.plot_unit``): overlaid, a run in
    µN·m is drawn in the first run's mN·m (× 1e-3), not as its numbers; units that no prefix
    relates (deg and rad) are refused in one line."""
    from rotlab.errors import InputError
    from rotlab.recording import plot as plot_module
    from rotlab.recording.plot import Panel, _Run, _unit_factor

    run = _Run(tmp_path / "b.rrd", "b", [], set(), 0.0, 1.0)
    milli = Panel("torque_body", "M of loads, body frame (mN·m)", "/loads/torque_body")
    assert _unit_factor(milli, Panel("torque_body", "M of loads, body frame (µN·m)", "/loads/torque_body"), run) == 1e-3
    assert _unit_factor(milli, Panel("torque_body", "M of loads, body frame (N·m)", "/loads/torque_body"), run) == 1e3
    assert _unit_factor(milli, milli, run) == 1.0
    assert _unit_factor(Panel("power", "Power of loads (W)", "/loads/power"), Panel("power", "Power of loads (nW)", "/loads/power"), run) == 1e-9
    with pytest.raises(InputError, match="deg.*rad|rad.*deg"):
        _unit_factor(Panel("theta", "θ nutation (deg)", "/euler/theta"), Panel("theta", "θ nutation (rad)", "/euler/theta"), run)

    rotlab.save(tmp_path / "general.rrd", rotlab.simulate(CONFIGS / "general.toml", duration=1.0))
    rotlab.save(tmp_path / "detumbling.rrd", rotlab.simulate(CONFIGS / "detumbling.toml", duration=1.0))
    drawn = []
    original = plot_module._series
    monkeypatch.setattr(plot_module, "_series", lambda ax, run, panel, span, style, factor=1.0: (drawn.append((run.label, factor)),
                                                                                                  original(ax, run, panel, span, style, factor)))
    result = cli("plot", "general.rrd", "detumbling.rrd", "-o", "both.svg", "--panels", "torque_body")
    assert result.exit_code == 0, result.output
    assert drawn == [("general", 1.0), ("detumbling", 1e-3)]  # mN·m and µN·m


def test_a_run_stopped_at_its_first_sample_is_refused_naming_the_file(cli, tmp_path):
    """A load not finite at t = 0 keeps one sample (``X.partial.rrd``): nothing to draw over
    time, said of that file (it blamed a --to that was not given)."""
    (tmp_path / "nan0.toml").write_text('''
[body]
principal_moments = [0.010, 0.016, 0.022]
[initial]
omega = [1.0, 0.5, 3.0]
[time]
end = 1.0
[[loads]]
type = "expression"
frame = "body"
torque = ["0", "0", "sqrt(-1-t)"]
''')
    run = cli("run", "nan0.toml", "-o", "nan0.rrd", "-q")
    assert run.exit_code == 1 and "the 1 valid sample is in nan0.partial.rrd" in run.stderr, run.output
    result = cli("plot", "nan0.partial.rrd", "-o", "f.png")
    assert result.exit_code == 2 and result.stderr.count("\n") == 1 and not (tmp_path / "f.png").exists(), result.output
    assert "nan0.partial.rrd: it holds the sample at t = 0 s only" in result.stderr and "--to" not in result.stderr
