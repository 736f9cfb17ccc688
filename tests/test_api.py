"""The Python API in numpy/scipy habits: overrides validated like the file, a compact repr,
failures raised with the valid part attached, save() and to_dataframe(), and the README's
example run as written."""

from __future__ import annotations

import re

import numpy as np
import pytest

import rotlab
from rotlab.errors import InputError, RunFailure
from rotlab.recording import layout
from rotlab.recording.reader import read_series
from tests.conftest import CONFIGS, ROOT


def test_simulate_takes_duration_method_and_validated_overrides():
    traj = rotlab.simulate(CONFIGS / "euler.toml", method="dop853", duration=0.5, overrides={"initial.omega[1]": 0.25})
    assert traj.t[-1] == pytest.approx(traj.t[0] + 0.5) and traj.stats.method == "dop853"
    assert traj.omega[0, 1] == 0.25
    with pytest.raises(InputError, match=r"body\.mass.*> 0"):
        rotlab.simulate(CONFIGS / "lagrange.toml", overrides={"body.mass": -1.0})
    with pytest.raises(InputError, match="did you mean 'omega'"):
        rotlab.simulate(CONFIGS / "lagrange.toml", overrides={"initial.omegaa": [0, 0, 1]})


def test_overrides_apply_to_scenario_objects_too():
    scenario = rotlab.load(CONFIGS / "lagrange.toml")
    traj = rotlab.simulate(scenario, duration=0.2, overrides={"initial.omega[2]": 40.0})
    assert traj.omega[0, 2] == 40.0 and traj.t[-1] == pytest.approx(0.2)


def test_model_copy_validates_the_change():
    scenario = rotlab.load(CONFIGS / "lagrange.toml")
    with pytest.raises(InputError, match="mass"):
        scenario.body.model_copy(update={"mass": -1.0})
    edited = scenario.model_copy(update={"solver": scenario.solver.model_copy(update={"method": "rk4"})})
    assert edited.solver.method == "rk4" and edited.body == scenario.body


def test_repr_is_one_compact_line():
    traj = rotlab.simulate(CONFIGS / "euler.toml", method="exact", duration=0.5)  # auto's choice depends on what this process ran before
    text = repr(traj)
    assert "\n" not in text and len(text) < 300 and text.startswith("<Trajectory torque-free scene, 51 samples")
    assert "method exact" in text and text.endswith("; ok>")


def test_a_failed_run_raises_with_the_valid_part_or_returns_it_on_request():
    overrides = {"solver.method": "dop853", "solver.max_steps": 10}
    with pytest.raises(RunFailure, match="step budget") as stop:
        rotlab.simulate(CONFIGS / "euler.toml", overrides=overrides)
    partial = stop.value.trajectory
    assert not partial.ok and 1 < partial.t.shape[0] < 2001 and np.all(np.isfinite(partial.omega))
    returned = rotlab.simulate(CONFIGS / "euler.toml", overrides=overrides, check=False)
    assert not returned.ok and "step budget" in returned.stats.failure
    assert np.array_equal(returned.omega, partial.omega)


def test_save_writes_the_same_recording_as_the_cli(tmp_path):
    traj = rotlab.simulate(CONFIGS / "lagrange.toml", duration=0.5)
    path = rotlab.save(tmp_path / "top.rrd", traj)
    t, omega = read_series(path, layout.OMEGA)
    assert np.max(np.abs(t - traj.t)) <= 1e-9 and np.array_equal(omega, traj.omega)  # ns time axis, float64 ω


def test_to_dataframe_names_columns_with_frames_and_units():
    pytest.importorskip("pandas")
    traj = rotlab.simulate(CONFIGS / "general.toml", duration=0.5)
    df = traj.to_dataframe()
    assert len(df) == traj.t.shape[0]
    assert np.array_equal(df["omega_y_body"].to_numpy(), traj.omega[:, 1])
    assert np.array_equal(df["L_z_space"].to_numpy(), traj.L_space[:, 2])
    assert {"potential", "total", "work", "drift_energy"} <= set(df.columns)
    units = df.attrs["units"]
    assert units["t"] == "s" and units["omega_x_body"] == "rad/s" and units["L_x_space"] == "kg·m²/s" and units["work"] == "J"


def test_public_names():
    for name in ("simulate", "load", "parse_scenario", "Scenario", "Trajectory", "InputError", "RunFailure", "Interrupted", "stability", "Stability"):
        assert getattr(rotlab, name) is not None
    with pytest.raises(AttributeError):
        rotlab.nonexistent  # noqa: B018


def test_readme_python_example_runs_as_written(tmp_path, monkeypatch, capsys):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"<!-- ci:python -->\n```python\n(.*?)```", readme, re.S)
    assert len(blocks) >= 2, "README lacks the ci:python examples"
    monkeypatch.chdir(tmp_path)
    for block in blocks:  # each as written, in its own namespace
        exec(compile(block.replace('"configs/', f'"{CONFIGS}/'), "README.md", "exec"), {})
    printed = capsys.readouterr().out
    assert "unstable 0.809039" in printed  # the stability example
    assert "<Trajectory lagrange scene" in printed and "rad/s" in printed and "stopped: step budget" in printed
    assert (tmp_path / "top.rrd").exists()


def test_editing_a_series_in_place_changes_no_other_series():
    """The series are computed on first use from the integrated state, which the trajectory keeps
    to itself: zeroing ω or Λ, or L, in place leaves the energies, drifts and Euler angles as a
    fresh run has them (found by review: the kinetic energy followed an edited ω)."""
    fresh = rotlab.simulate(CONFIGS / "general.toml", duration=0.5, overrides={"output.euler_angles": True})
    for config in ("lagrange.toml", "general.toml"):  # principal axes given / an inertia tensor
        reference = rotlab.simulate(CONFIGS / config, duration=0.5, overrides={"output.euler_angles": True})
        edited = rotlab.simulate(CONFIGS / config, duration=0.5, overrides={"output.euler_angles": True})
        edited.omega[:] = 0.0
        edited.quaternion[:] = 2.0
        edited.L_body[:] = 0.0
        assert np.array_equal(edited.kinetic, reference.kinetic) and np.array_equal(edited.L_space, reference.L_space)
        assert np.array_equal(edited.euler_angles, reference.euler_angles)
        edited.L_space[:] = 0.0
        assert edited.max_drift() == reference.max_drift()
    assert np.array_equal(fresh.omega, rotlab.simulate(CONFIGS / "general.toml", duration=0.5).omega)


def test_the_packages_lazy_names_are_looked_up_once():
    """``rotlab.simulate`` and the other lazy names import their module on first use and are
    plain attributes from then on (a loop over ``rotlab.simulate`` paid an import look-up a call)."""
    import rotlab.api

    assert rotlab.simulate is rotlab.api.simulate and rotlab.load is rotlab.api.load
    assert vars(rotlab)["simulate"] is rotlab.api.simulate
