"""Euler's equations, Poisson's kinematics and frames pinned against exact results.

Bounds: dop853 at rtol = 1e-12 reproduces the axisymmetric closed form to 1e-9 (ω relative,
Λ absolute) over 20 s (~30 spin periods); rk4 at h = 1e-3 s to 1e-7.
"""

from __future__ import annotations

import numpy as np
import pytest

import rotlab
from rotlab.core import quaternion as quat
from tests.helpers import axisymmetric_free_body, same_rotation_error, scenario

A, C = 2.0, 3.0
OMEGA0 = np.array([0.3, -0.2, 1.5])


def _free_axisymmetric(method: str, **body):
    q0 = quat.from_euler_313(0.4, 0.7, -0.2)
    sc = scenario(
        body={"principal_moments": [A, A, C], **body},
        initial={"omega": OMEGA0.tolist(), "quaternion": q0.tolist()},
        time={"end": 20.0, "sample_rate": 10},
        solver={"method": method, "rtol": 1e-12, "atol": 1e-14, "step": 1e-3},
    )
    return rotlab.simulate(sc), q0


@pytest.mark.parametrize("method, bound", [("dop853", 1e-9), ("rk4", 1e-7)])
def test_axisymmetric_free_body_matches_closed_form(method, bound):
    traj, q0 = _free_axisymmetric(method)
    q_exact, w_exact = axisymmetric_free_body(A, C, OMEGA0, q0, traj.t)
    assert np.max(np.abs(traj.omega - w_exact)) / np.linalg.norm(OMEGA0) < bound
    assert np.max(same_rotation_error(traj.quaternion, q_exact)) < bound


def test_omega_precesses_about_symmetry_axis_at_body_rate():
    """ω_⊥ turns about body axis 3 at Ω = (C − A)/A · r: the phase of p + iq advances by Ω t."""
    traj, _ = _free_axisymmetric("dop853")
    phase = np.unwrap(np.angle(traj.omega[:, 0] + 1j * traj.omega[:, 1]))
    rate = np.polyfit(traj.t, phase, 1)[0]
    assert rate == pytest.approx((C - A) / A * OMEGA0[2], rel=1e-10)


def test_angular_momentum_fixed_in_space_when_torque_free():
    traj, _ = _free_axisymmetric("dop853")
    drift = np.linalg.norm(traj.L_space - traj.L_space[0], axis=1) / np.linalg.norm(traj.L_space[0])
    assert np.max(drift) < 1e-10
    assert np.allclose(traj.L_body, traj.omega * [A, A, C], rtol=0, atol=1e-15)


def test_full_tensor_in_rotated_body_frame_reports_in_user_frames():
    """The same physical body described in a rotated body frame U (r_U = S r_P):
    I_U = S diag Sᵀ, ω_U = S ω_P, Λ_U = Λ_P ∘ Λ(S)⁻¹.  Every reported vector must follow."""
    s_q = quat.from_axis_angle([1.0, 2.0, -0.5], 0.9)
    S = quat.to_matrix(s_q)
    tensor = S @ np.diag([1.0, 1.6, 2.2]) @ S.T
    q_p0 = quat.from_axis_angle([0.2, 0.1, 1.0], 0.3)
    w_p0 = np.array([0.5, 1.0, -0.7])
    common = {"time": {"end": 5.0, "sample_rate": 20}, "solver": {"method": "dop853", "rtol": 1e-12, "atol": 1e-14}}
    principal = rotlab.simulate(
        scenario(body={"principal_moments": [1.0, 1.6, 2.2]}, initial={"omega": w_p0.tolist(), "quaternion": q_p0.tolist()}, **common)
    )
    q_u0 = quat.multiply_array(q_p0, quat.conjugate_array(s_q))
    user = rotlab.simulate(
        scenario(body={"inertia_tensor": tensor.tolist()}, initial={"omega": (S @ w_p0).tolist(), "quaternion": q_u0.tolist()}, **common)
    )
    assert np.allclose(user.omega, principal.omega @ S.T, atol=1e-9)
    assert np.allclose(user.L_body, principal.L_body @ S.T, atol=1e-9)
    assert np.allclose(user.L_space, principal.L_space, atol=1e-9)  # space frame is the same
    expected_q = quat.multiply_array(principal.quaternion, quat.conjugate_array(s_q))
    assert np.max(same_rotation_error(user.quaternion, expected_q)) < 1e-9
    # and a body point fixed in the body frame U maps to the same space point
    point_u = np.array([0.3, -0.1, 0.2])
    r_user = quat.rotate_to_space_array(user.quaternion, point_u)
    r_princ = quat.rotate_to_space_array(principal.quaternion, S.T @ point_u)
    assert np.allclose(r_user, r_princ, atol=1e-9)


def test_constant_space_torque_changes_L_space_linearly():
    """dL_space/dt = M_space for a torque fixed in space, whatever the body does."""
    m_space = np.array([0.02, -0.01, 0.03])
    traj = rotlab.simulate(
        scenario(
            body={"principal_moments": [1.0, 1.5, 2.0]},
            initial={"omega": [0.4, 1.1, -0.3], "euler_313": [0.3, 1.0, 0.2]},
            loads=[{"type": "torque", "frame": "space", "value": m_space.tolist()}],
            time={"end": 10.0, "sample_rate": 10},
            solver={"method": "dop853", "rtol": 1e-12, "atol": 1e-14},
        )
    )
    expected = traj.L_space[0] + traj.t[:, None] * m_space
    assert np.max(np.abs(traj.L_space - expected)) < 1e-10


def test_body_torque_along_symmetry_axis_spins_up_linearly():
    """A = B, M = (0, 0, M3) in the body frame: C ṙ = M3 exactly, p² + q² constant."""
    traj = rotlab.simulate(
        scenario(
            body={"principal_moments": [1.0, 1.0, 2.0]},
            initial={"omega": [0.3, 0.4, 1.0]},
            loads=[{"type": "torque", "frame": "body", "value": [0.0, 0.0, 0.5]}],
            time={"end": 4.0, "sample_rate": 10},
            solver={"method": "rk4", "step": 1e-3},
        )
    )
    assert np.allclose(traj.omega[:, 2], 1.0 + 0.25 * traj.t, atol=1e-12)
    assert np.allclose(np.hypot(traj.omega[:, 0], traj.omega[:, 1]), 0.5, atol=1e-12)


def test_gravity_torque_and_potential_in_the_right_frames():
    """Top with its axis tilted by θ about space x: V = m g l cos θ, initial torque
    M_body = r_c × (m Rᵀ g) points along the line of nodes (body x here), magnitude m g l sin θ."""
    theta, m, g, l = 0.6, 2.0, 9.81, 0.1
    traj = rotlab.simulate(
        scenario(
            body={"principal_moments": [0.05, 0.05, 0.02], "mass": m, "center_of_mass": [0.0, 0.0, l]},
            initial={"omega": [0.0, 0.0, 0.0], "euler_313": [0.0, theta, 0.0]},
            loads=[{"type": "gravity", "g": [0.0, 0.0, -g]}],
            time={"end": 1e-3, "samples": 2},
            solver={"method": "dop853", "rtol": 1e-13, "atol": 1e-15},
        )
    )
    assert traj.potential[0] == pytest.approx(m * g * l * np.cos(theta), rel=1e-14)
    # starting at rest, ω(dt) ≈ M/A dt: the body swings about +x (θ grows: the top falls)
    dt = traj.t[1]
    expected_px = m * g * l * np.sin(theta) / 0.05 * dt
    assert traj.omega[1, 0] == pytest.approx(expected_px, rel=1e-3)
    assert abs(traj.omega[1, 1]) < 1e-12


def test_euler_angles_continuous_and_consistent():
    """Recorded (ψ, θ, φ) rebuild Λ (up to sign) and ψ, φ are unwrapped: no jumps of 2π."""
    from tests.conftest import CONFIGS

    traj = rotlab.simulate(rotlab.load(CONFIGS / "lagrange.toml", duration=1.0))
    angles = traj.euler_angles
    rebuilt = np.array([quat.from_euler_313(*a) for a in angles])
    unit = traj.quaternion / np.linalg.norm(traj.quaternion, axis=1, keepdims=True)
    assert np.max(same_rotation_error(rebuilt, unit)) < 1e-9
    assert np.max(np.abs(np.diff(angles[:, 2]))) < 1.0  # spin 150 rad/s at 200 Hz: 0.75 rad per sample
    assert angles[-1, 2] - angles[0, 2] > 100.0  # φ accumulates, not wrapped


def test_euler_313_is_the_product_of_the_three_turns():
    """Λ(ψ, θ, φ) = Λ_z(ψ) ∘ Λ_x(θ) ∘ Λ_z(φ) (closed form, 1e-15 against the product), and the
    body's z axis ends at (sin θ sin ψ, −sin θ cos ψ, cos θ) in space."""
    z, x = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
    for psi, theta, phi in np.random.default_rng(3).uniform(-7.0, 7.0, size=(200, 3)):
        product = quat.multiply_array(quat.multiply_array(quat.from_axis_angle(z, psi), quat.from_axis_angle(x, theta)),
                                      quat.from_axis_angle(z, phi))
        q = quat.from_euler_313(psi, theta, phi)
        assert np.max(np.abs(q - product)) < 1e-15
        axis = quat.rotate_to_space_array(q, z)
        assert np.allclose(axis, [np.sin(theta) * np.sin(psi), -np.sin(theta) * np.cos(psi), np.cos(theta)], atol=1e-15)
