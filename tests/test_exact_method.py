"""`method = "exact"` through the whole pipeline: user frames, auto's choice, refusals.

Bounds: exact vs dop853 at rtol 1e-13 agree to 1e-10 (the integrator's error, not exact's);
exact vs the independent axisymmetric closed form of tests/helpers.py to 1e-13.
"""

from __future__ import annotations

import numpy as np
import pytest

import rotlab
from rotlab.core import quaternion as quat
from rotlab.errors import InputError
from tests.conftest import CONFIGS
from tests.helpers import axisymmetric_free_body, same_rotation_error, scenario


def _free(method: str, body: dict, omega, q0):
    return rotlab.simulate(scenario(
        body=body, initial={"omega": list(omega), "quaternion": list(q0)},
        time={"end": 30.0, "sample_rate": 10}, solver={"method": method, "rtol": 1e-13, "atol": 1e-15},
    ))


def test_exact_asymmetric_in_a_rotated_body_frame_matches_dop853():
    s_q = quat.from_axis_angle([0.3, -1.0, 0.4], 1.1)
    S = quat.to_matrix(s_q)
    body = {"inertia_tensor": (S @ np.diag([1.0, 1.7, 2.3]) @ S.T).tolist()}
    omega, q0 = [0.4, -1.2, 0.9], quat.from_euler_313(0.2, 0.9, -0.4)
    exact, reference = _free("exact", body, omega, q0), _free("dop853", body, omega, q0)
    assert exact.stats.method == "exact" and exact.stats.steps == 0
    np.testing.assert_allclose(exact.omega, reference.omega, atol=1e-10)
    assert np.max(same_rotation_error(exact.quaternion, reference.quaternion)) < 1e-10
    assert exact.max_drift()["L_space"] < 1e-13 and exact.max_drift()["energy"] < 1e-14


def test_exact_axisymmetric_matches_independent_closed_form():
    omega, q0 = np.array([0.3, -0.2, 1.5]), quat.from_euler_313(0.4, 0.7, -0.2)
    traj = _free("exact", {"principal_moments": [2.0, 2.0, 3.0]}, omega, q0)
    q_ref, w_ref = axisymmetric_free_body(2.0, 3.0, omega, q0, traj.t)
    np.testing.assert_allclose(traj.omega, w_ref, atol=1e-13)
    assert np.max(same_rotation_error(traj.quaternion, q_ref)) < 1e-13


def test_auto_chooses_exact_where_it_is_cheapest_and_says_why():
    """euler.toml's body over 10⁴ s with 11 samples: stepping would take ~10⁴ steps, exact
    evaluates 11 samples."""
    scenario_ = rotlab.load(CONFIGS / "euler.toml")
    scenario_ = scenario_.model_copy(update={"time": scenario_.time.model_copy(update={"end": 1e4, "sample_rate": None, "samples": 11})})
    traj = rotlab.simulate(scenario_)
    assert traj.stats.method == "exact" and "least expected cost" in traj.stats.reason


def test_auto_uses_an_integrator_for_general_scenes():
    traj = rotlab.simulate(rotlab.load(CONFIGS / "general.toml", duration=0.5))
    assert traj.stats.method != "exact" and "non-conservative" in traj.stats.reason


def test_exact_refused_for_a_general_scene():
    with pytest.raises(InputError, match="no exact solution for a general scene"):
        rotlab.simulate(rotlab.load(CONFIGS / "general.toml", method="exact"))


@pytest.mark.parametrize("tilt", [0.0, 0.7])
def test_exact_lagrange_in_any_frame_matches_dop853(tilt):
    """A heavy symmetric top described in a rotated body frame (full tensor; symmetry axis along
    S e_x, not z) in a field pointing along an arbitrary direction: the exact solution, mapped to
    the canonical frame and back, agrees with dop853 at rtol 1e-13 (bound 1e-10)."""
    s_q = quat.from_axis_angle([0.2, 1.0, -0.3], 1.3)
    S = quat.to_matrix(s_q)
    moments = np.diag([4e-4, 1.1e-3, 1.1e-3])  # symmetric about body x
    body = {"inertia_tensor": (S @ moments @ S.T).tolist(), "mass": 0.5, "center_of_mass": (S @ [0.04, 0.0, 0.0]).tolist()}
    g = 9.81 * np.array([np.sin(tilt), 0.3, -np.cos(tilt)]) / np.linalg.norm([np.sin(tilt), 0.3, -np.cos(tilt)])
    common = dict(
        body=body,
        initial={"omega": (S @ [120.0, 0.5, -0.3]).tolist(), "euler_313": [0.3, 0.6, -0.2]},
        loads=[{"type": "gravity", "g": g.tolist()}],
        time={"end": 3.0, "sample_rate": 100},
    )
    exact = rotlab.simulate(scenario(**common, solver={"method": "exact"}))
    ref = rotlab.simulate(scenario(**common, solver={"method": "dop853", "rtol": 1e-13, "atol": 1e-15}))
    assert exact.scene.kind == "lagrange"
    assert np.max(np.abs(exact.omega - ref.omega)) / np.max(np.abs(ref.omega)) < 1e-10
    assert np.max(same_rotation_error(exact.quaternion, ref.quaternion)) < 1e-10
    drift = exact.max_drift()
    assert drift["energy"] < 1e-13 and drift["L_vertical"] < 1e-13 and drift["L_symmetry"] < 1e-13
