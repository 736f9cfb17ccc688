"""Property-based tests over random bodies and initial conditions (hypothesis).

Bounds (max over the run, relative):
  exact: energy and L_space invariant to 1e-12;  dop853 (rtol 1e-11): 1e-8;
  splitting (order 4, step from rtol 1e-9): energy 1e-7, |L| and L_space 1e-11 (exact rotations);
  frame covariance and load equivalences: 1e-9.
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rotlab
from rotlab.core import quaternion as quat
from tests.helpers import same_rotation_error, scenario

SETTINGS = settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])

unit = st.floats(-1.0, 1.0, allow_nan=False)


@st.composite
def bodies(draw):
    """Principal moments satisfying the triangle inequality, within a factor of 5."""
    a = draw(st.floats(0.2, 1.0))
    b = draw(st.floats(0.2, 1.0))
    c = draw(st.floats(max(abs(a - b), 0.2), min(a + b, 1.0)))
    return [a, b, c]


@st.composite
def vectors(draw, low=0.2, high=3.0):
    v = np.array([draw(unit), draw(unit), draw(unit)])
    if np.linalg.norm(v) < 1e-3:
        v = np.array([1.0, 0.0, 0.0])
    return (v / np.linalg.norm(v) * draw(st.floats(low, high))).tolist()


@st.composite
def orientations(draw):
    return quat.from_axis_angle(draw(vectors()), draw(st.floats(0.0, np.pi))).tolist()


@SETTINGS
@given(body=bodies(), omega=vectors(), q0=orientations())
def test_torque_free_invariants_per_method(body, omega, q0):
    common = {"body": {"principal_moments": body}, "initial": {"omega": omega, "quaternion": q0},
              "time": {"end": 20.0, "sample_rate": 5}}
    bounds = {"exact": (1e-12, 1e-12), "dop853": (1e-8, 1e-8), "taylor": (1e-8, 1e-8), "splitting": (1e-7, 1e-11)}
    for method, (energy_bound, momentum_bound) in bounds.items():
        solver = {"method": method, "rtol": 1e-11 if method in ("dop853", "taylor") else 1e-9}
        drift = rotlab.simulate(scenario(**common, solver=solver)).max_drift()
        assert drift["energy"] < energy_bound, (method, drift)
        assert drift["L_norm"] < momentum_bound and (method != "exact" or drift["L_space"] < momentum_bound), (method, drift)


@SETTINGS
@given(body=bodies(), omega=vectors(), q0=orientations(), turn=orientations(), g_dir=vectors(1.0, 1.0))
def test_rotating_the_whole_scene_rotates_the_result(body, omega, q0, turn, g_dir):
    """Space rotation S applied to the initial attitude, gravity and space-frame loads:
    Λ → S∘Λ, L_space → S L_space, body-frame ω unchanged."""
    s_q = np.array(turn)
    S = quat.to_matrix(s_q)
    g = 9.81 * np.array(g_dir)
    tau = np.array([0.01, -0.02, 0.015])

    def run(q_init, g_vec, tau_vec):
        return rotlab.simulate(scenario(
            body={"principal_moments": body, "mass": 1.0, "center_of_mass": [0.02, 0.01, 0.05],
                  "allow_triangle_violation": True},  # drawn bodies need not hold that mass (a property, not a body)
            initial={"omega": omega, "quaternion": list(q_init)},
            loads=[{"type": "gravity", "g": list(g_vec)}, {"type": "torque", "frame": "space", "value": list(tau_vec)}],
            time={"end": 3.0, "sample_rate": 10}, solver={"method": "dop853", "rtol": 1e-12, "atol": 1e-14}))

    base = run(q0, g, tau)
    turned = run(quat.multiply_array(s_q, np.array(q0)), S @ g, S @ tau)
    np.testing.assert_allclose(turned.omega, base.omega, atol=1e-9)
    np.testing.assert_allclose(turned.L_space, base.L_space @ S.T, atol=1e-9)
    expected_q = quat.multiply_array(np.broadcast_to(s_q, base.quaternion.shape), base.quaternion)
    assert np.max(same_rotation_error(turned.quaternion, expected_q)) < 1e-9


@SETTINGS
@given(body=bodies(), omega=vectors(), q0=orientations(), point=vectors(0.01, 0.2), force=vectors(0.1, 2.0))
def test_equivalent_loads_in_different_frames_give_the_same_motion(body, omega, q0, point, force):
    """(1) gravity on m at r_c ≡ a space-frame force m g at the body point r_c;
    (2) a body-frame force F at p ≡ a body-frame torque p × F."""
    common = {"initial": {"omega": omega, "quaternion": q0}, "time": {"end": 3.0, "sample_rate": 10},
              "solver": {"method": "dop853", "rtol": 1e-12, "atol": 1e-14}}
    g = np.array([0.0, 0.0, -9.81])
    gravity = rotlab.simulate(scenario(body={"principal_moments": body, "mass": 2.0, "center_of_mass": point,
                                             "allow_triangle_violation": True},  # a property, not a realisable body
                                       loads=[{"type": "gravity", "g": g.tolist()}], **common))
    space_force = rotlab.simulate(scenario(body={"principal_moments": body},
                                           loads=[{"type": "force", "frame": "space", "value": (2.0 * g).tolist(), "point": point}], **common))
    np.testing.assert_allclose(space_force.omega, gravity.omega, atol=1e-9)
    body_force = rotlab.simulate(scenario(body={"principal_moments": body},
                                          loads=[{"type": "force", "frame": "body", "value": force, "point": point}], **common))
    body_torque = rotlab.simulate(scenario(body={"principal_moments": body},
                                           loads=[{"type": "torque", "frame": "body", "value": np.cross(point, force).tolist()}], **common))
    np.testing.assert_allclose(body_force.omega, body_torque.omega, atol=1e-12)


@SETTINGS
@given(spin=st.floats(0.5, 20.0), torque=st.floats(-0.5, 0.5), a=st.floats(0.3, 1.0), ratio=st.floats(0.3, 2.0))
def test_body_and_space_torque_agree_when_the_axis_stays_put(spin, torque, a, ratio):
    """Axisymmetric body spinning about its symmetry axis, aligned with space z: a torque along
    z is the same load in the body and in the space frame."""
    c = ratio * a  # (a, a, c) is a real body for c ≤ 2a
    common = {"body": {"principal_moments": [a, a, c]}, "initial": {"omega": [0.0, 0.0, spin]},
              "time": {"end": 2.0, "sample_rate": 10}, "solver": {"method": "dop853", "rtol": 1e-12, "atol": 1e-14}}
    in_body = rotlab.simulate(scenario(**common, loads=[{"type": "torque", "frame": "body", "value": [0.0, 0.0, torque]}]))
    in_space = rotlab.simulate(scenario(**common, loads=[{"type": "torque", "frame": "space", "value": [0.0, 0.0, torque]}]))
    np.testing.assert_allclose(in_body.omega, in_space.omega, atol=1e-12)
    assert np.max(same_rotation_error(in_body.quaternion, in_space.quaternion)) < 1e-12
