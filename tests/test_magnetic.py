"""Magnetic loads (``rotlab.scene.geomagnetic``, load kinds ``magnetic_dipole`` and
``bdot_detumbling``): the dipole field against its closed form (|B| = B₀(R/r)³ on the magnetic
equator, twice that over a pole), the compiled torque m × B against NumPy's at every sample (body
frame, through the user's axes), the B-dot law never adding energy, and the shipped detumbling
run decaying."""

from __future__ import annotations

import numpy as np
import pytest

import rotlab
from rotlab.core import quaternion as quat
from rotlab.recording.loads_view import load_views, principal_state, torques
from rotlab.scene import geomagnetic
from tests.conftest import CONFIGS

ORBIT = {"altitude": 700e3, "inclination_deg": 63.0, "tilt_deg": 11.5}


def test_the_dipole_field_on_the_equator_and_over_a_pole():
    b = geomagnetic.field_strength(500e3)
    assert b == pytest.approx(3.12e-5 * (6371.2 / 6871.2) ** 3, rel=1e-15)
    t = np.linspace(0.0, 6000.0, 41)
    equatorial = geomagnetic.field_in_space(t, 500e3, inclination_deg=0.0, tilt_deg=0.0)
    np.testing.assert_allclose(np.linalg.norm(equatorial, axis=1), b, rtol=1e-14)
    np.testing.assert_allclose(equatorial / b, np.tile([0.0, 0.0, 1.0], (41, 1)), atol=1e-15)  # pointing north
    quarter = np.pi / 2 / geomagnetic.orbit_rate(500e3)
    polar = geomagnetic.field_in_space(np.array([quarter]), 500e3, inclination_deg=90.0, tilt_deg=0.0)[0]
    np.testing.assert_allclose(polar, [0.0, 0.0, -2.0 * b], atol=1e-12 * b)  # over the north pole: down, twice as strong


@pytest.mark.parametrize("body", [{"principal_moments": [0.05, 0.06, 0.04]},
                                  {"inertia_tensor": [[0.05, 0.004, 0.0], [0.004, 0.06, -0.002], [0.0, -0.002, 0.04]]}])
def test_the_compiled_torque_is_m_cross_b_in_the_body_frame(body):
    load = {"type": "magnetic_dipole", "dipole": [0.2, -0.1, 0.3], **ORBIT}
    traj = rotlab.simulate(rotlab.parse_scenario({"body": body, "initial": {"omega": [0.1, -0.2, 0.15], "euler_313_deg": [10, 50, 30]},
                                                  "loads": [load], "time": {"end": 3000.0, "sample_rate": 0.1}}))
    scene = traj.scene
    (view,) = load_views(scene)
    q_p, w_p = principal_state(scene, traj.quaternion, traj.omega)
    compiled = torques(scene, view, traj.t, q_p, w_p) @ scene.axes.T  # principal → the user's body frame
    b_body = quat.rotate_to_body_array(traj.quaternion / np.linalg.norm(traj.quaternion, axis=1, keepdims=True),
                                       geomagnetic.field_in_space(traj.t, **ORBIT))
    expected = np.cross(np.array(load["dipole"]), b_body)
    np.testing.assert_allclose(compiled, expected, rtol=0, atol=1e-10 * np.max(np.abs(expected)))  # measured 5e-12: rounding


def test_bdot_only_takes_energy_out_and_detumbles():
    """M·ω = −m·(ω × B) ≤ 0 with m = sat(k ω × B): T never rises (to rounding) on the shipped run,
    and |ω| falls from 7.3 to below 0.1 deg/s in one orbit."""
    traj = rotlab.simulate(CONFIGS / "detumbling.toml")
    assert np.all(np.diff(traj.kinetic) <= 1e-12 * traj.kinetic[0])
    rate = np.degrees(np.linalg.norm(traj.omega, axis=1))
    assert rate[0] == pytest.approx(np.sqrt(5.0**2 + 4.0**2 + 3.5**2), rel=1e-12) and rate[-1] < 0.1
    assert traj.work[-1] == pytest.approx(traj.kinetic[-1] - traj.kinetic[0], rel=1e-6)  # what the torquers took out
