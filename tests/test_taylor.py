"""The Taylor series method: its coefficients, its accuracy against exact solutions and
references, every load kind and frame, breakpoints, work, order control.  Bounds stated per test."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rotlab
from rotlab.core import taylor
from rotlab.core.dynamics import rhs
from rotlab.errors import InputError
from rotlab.methods.base import Settings
from rotlab.methods.registry import get_method
from rotlab.methods.catalog.taylor import kernel_constants
from rotlab.scene.scene import build_scene
from tests.conftest import CONFIGS
from tests.helpers import axisymmetric_free_body, same_rotation_error, scenario

EVERY_LOAD = [
    {"type": "gravity", "g": [0.3, -0.2, -9.81]},
    {"type": "force", "frame": "space", "point": [0.1, -0.2, 0.05], "value": [1.0, 0.5, -0.3]},
    {"type": "force", "frame": "body", "point": [0.0, 0.1, 0.0], "value": [0.2, 0.0, 0.1]},
    {"type": "torque", "frame": "space", "value": [0.05, -0.02, 0.1]},
    {"type": "torque", "frame": "body", "value": [0.01, 0.03, -0.02], "window": {"on": 0.3, "off": 1.1}},
    {"type": "harmonic_torque", "frame": "space", "offset": [0.01, 0.0, 0.02], "amplitude": [0.05, -0.04, 0.03],
     "angular_frequency": 4.0, "phase": 0.3},
    {"type": "harmonic_torque", "frame": "body", "amplitude": [0.02, 0.01, -0.05], "angular_frequency": 7.0, "phase": -1.0},
    {"type": "torque_table", "frame": "space", "times": [0.2, 0.9, 1.6], "values": [[0.0, 0.1, 0.0], [0.1, -0.1, 0.05], [0.0, 0.0, 0.0]]},
    {"type": "torque_table", "frame": "body", "times": [0.5, 1.0, 1.5], "values": [[0.0, 0.0, 0.1], [0.05, 0.0, -0.1], [0.0, 0.0, 0.0]]},
    {"type": "damping", "coefficient": 0.01},
]


def _scene(loads=EVERY_LOAD, end=2.0, **solver):
    return build_scene(scenario(
        body={"inertia_tensor": [[0.3, 0.01, 0.0], [0.01, 0.25, 0.02], [0.0, 0.02, 0.2]], "mass": 1.5, "center_of_mass": [0.02, 0.01, 0.1]},
        initial={"omega": [0.8, -0.5, 6.0], "axis_angle": [0.4, 0.2, -0.1]},
        loads=loads, time={"end": end, "sample_rate": 50}, solver=solver,
    ))


def _config(name: str, **solver):
    """configs/<name>.toml with solver settings replaced."""
    sc = rotlab.load(CONFIGS / f"{name}.toml")
    return sc.model_copy(update={"solver": sc.solver.model_copy(update=solver)})


def _series_at(scene, t0: float, y: np.ndarray, order: int) -> np.ndarray:
    """The Taylor coefficients X[0..order] of the state at (t0, y), as the kernel computes them."""
    return taylor.coefficients(t0, y, order, scene.model, *kernel_constants(scene))


def _f(scene, t0: float, y: np.ndarray) -> np.ndarray:
    dy = np.empty(8)
    rhs(t0, y, dy, scene.model)
    return dy


# a lone constant force and only body-frame loads besides: the kernel's γ = Rᵀ F path
GAMMA_LOADS = [
    {"type": "gravity", "g": [0.3, -0.2, -9.81]},
    {"type": "harmonic_torque", "frame": "body", "amplitude": [0.02, 0.01, -0.05], "angular_frequency": 7.0, "phase": -1.0},
    {"type": "damping", "coefficient": 0.01},
]


@pytest.mark.parametrize("loads, gamma", [(EVERY_LOAD, False), (GAMMA_LOADS, True), (GAMMA_LOADS[:1], True)],
                         ids=["products", "gamma-with-body-loads", "gamma-gravity-only"])
def test_first_two_coefficients_are_the_right_hand_side_and_its_derivative(loads, gamma):
    """X[1] = f(t, y) to 1e-14 relative (every load kind and frame active at t = 0.7; and a lone
    force, through γ = Rᵀ F), and 2 X[2] = df/dt along the flow = (f(t+δ, y+δf) − f(t−δ, y−δf)) / 2δ
    to 1e-6 relative (central difference, δ = 1e-5: truncation ~δ² |f'''|)."""
    scene = _scene(loads)
    assert (kernel_constants(scene)[2] is not None) is gamma
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = rng.normal(size=4)
        y = np.concatenate([q / np.linalg.norm(q), rng.normal(size=3) * 3.0, [0.0]])
        t0 = 0.7
        X = _series_at(scene, t0, y, 6)
        f = _f(scene, t0, y)
        np.testing.assert_allclose(X[1], f, rtol=1e-14, atol=1e-14 * np.max(np.abs(f)))
        d = 1e-5
        derivative = (_f(scene, t0 + d, y + d * f) - _f(scene, t0 - d, y - d * f)) / (2 * d)
        np.testing.assert_allclose(2.0 * X[2], derivative, rtol=1e-6, atol=1e-6 * np.max(np.abs(derivative)))


@pytest.mark.parametrize("rtol, bound", [(1e-8, 1e-7), (1e-10, 1e-9), (1e-12, 1e-11), (1e-14, 1e-13)])
def test_error_follows_tolerance_on_the_free_axisymmetric_body(rtol, bound):
    """Against the closed form (tests.helpers), ω and Λ over 10 s: error < 10 rtol."""
    q0 = np.array([0.9, 0.3, -0.2, 0.1])
    q0 /= np.linalg.norm(q0)
    w0 = np.array([0.2, 0.5, 2.0])
    traj = rotlab.simulate(scenario(body={"principal_moments": [1.0, 1.0, 1.8]}, initial={"omega": w0.tolist(), "quaternion": q0.tolist()},
                                    time={"end": 10.0, "sample_rate": 10}, solver={"method": "taylor", "rtol": rtol, "atol": rtol * 1e-2}))
    q_exact, w_exact = axisymmetric_free_body(1.0, 1.8, w0, q0, traj.t)
    error = max(np.max(np.abs(traj.omega - w_exact)), np.max(same_rotation_error(traj.quaternion, q_exact)))
    assert error < bound


def test_lagrange_top_matches_the_exact_solution():
    """configs/lagrange.toml (150 rad/s spin, 10 s, 2001 samples) at rtol 1e-12: within 1e-9 of
    the elliptic-function solution in ω (relative to max |ω|) and Λ (measured 1.4e-11)."""
    exact = rotlab.simulate(CONFIGS / "lagrange.toml", method="exact")
    run = rotlab.simulate(_config("lagrange", method="taylor", rtol=1e-12, atol=1e-14))
    scale = np.max(np.linalg.norm(exact.omega, axis=1))
    assert np.max(np.abs(run.omega - exact.omega)) / scale < 1e-9
    assert np.max(same_rotation_error(run.quaternion, exact.quaternion)) < 1e-9


def test_every_load_kind_and_frame_matches_dop853():
    """Tensor inertia, two forces, body and space torques (constant, windowed, harmonic, tables)
    and damping: taylor at rtol 1e-13 and dop853 at rtol 1e-13 agree to 1e-10 in Λ, ω/max|ω| and W."""
    scene = _scene()
    t = np.linspace(0.0, 2.0, 101)
    a = get_method("taylor").solve(scene, t, Settings(rtol=1e-13, atol=1e-15), None)
    b = get_method("dop853").solve(scene, t, Settings(rtol=1e-13, atol=1e-15), None)
    assert a.failure is None and b.failure is None
    scale = np.max(np.abs(b.state[:, 4:7]))
    assert np.max(same_rotation_error(a.state[:, :4], b.state[:, :4])) < 1e-10
    assert np.max(np.abs(a.state[:, 4:7] - b.state[:, 4:7])) / scale < 1e-10
    assert np.max(np.abs(a.state[:, 7] - b.state[:, 7])) < 1e-10 * max(1.0, np.max(np.abs(b.state[:, 7])))
    assert np.max(np.abs(b.state[:, 7])) > 1e-3  # the loads do real work


def test_work_balances_energy_on_general_toml():
    """T + V − W constant to 1e-9 relative at rtol 1e-11 (dop853's bound at 1e-10 is 1e-8)."""
    traj = rotlab.simulate(_config("general", method="taylor", rtol=1e-11, atol=1e-13))
    assert np.max(np.abs(traj.invariants["energy"])) < 1e-9
    assert np.ptp(traj.total) / abs(traj.total[0]) > 1e-3


def test_short_pulse_is_not_stepped_over():
    """A sphere (I = 2) with a 1 ms body-frame pulse M = (0, 0, 0.4) at t = 3.2: ω₃ jumps by
    M·Δt/I = 2e-4 exactly (no gyroscopic term for a sphere; the body axes keep M's direction
    along ω), to 1e-14 — steps end at the window's edges."""
    traj = rotlab.simulate(scenario(body={"principal_moments": [2.0, 2.0, 2.0]}, initial={"omega": [0.0, 0.0, 1.0]},
                                    loads=[{"type": "torque", "frame": "body", "value": [0.0, 0.0, 0.4], "window": {"on": 3.2, "off": 3.201}}],
                                    time={"end": 10.0, "sample_rate": 1}, solver={"method": "taylor", "rtol": 1e-12}))
    assert traj.stats.failure is None
    assert abs(traj.omega[-1, 2] - (1.0 + 0.4 * 1e-3 / 2.0)) < 1e-14
    assert abs(traj.omega[3, 2] - 1.0) < 1e-15  # before the pulse (t = 3)


def test_order_follows_rtol_unless_given():
    scene = _scene(loads=[])
    t = np.linspace(0.0, 1.0, 11)
    method = get_method("taylor")
    assert method.solve(scene, t, Settings(rtol=1e-10), None).details["order"] == taylor.default_order(1e-10) == 13
    assert method.solve(scene, t, Settings(rtol=1e-10, order=20), None).details["order"] == 20
    with pytest.raises(InputError, match="solver.order"):
        method.solve(scene, t, Settings(order=2), None)


def test_non_finite_state_stops_with_the_valid_samples(monkeypatch):
    """A diverging torque (table values of 1e300) makes the state non-finite: the run stops,
    says where, and keeps the samples before it.  (Scenario files refuse magnitudes above 1e30;
    the kernel's own guard is tested beneath that range check.)"""
    from rotlab.config import models

    monkeypatch.setattr(models, "MAX_MAGNITUDE", math.inf)
    scene = _scene(loads=[{"type": "torque_table", "frame": "body", "times": [0.5, 0.6], "values": [[1e300, 1e300, 1e300], [1e300, 1e300, 1e300]]}])
    t = np.linspace(0.0, 2.0, 101)
    solution = get_method("taylor").solve(scene, t, Settings(rtol=1e-10), None)
    assert solution.failure is not None and "non-finite" in solution.failure
    assert 20 <= solution.valid <= 31
    assert np.all(np.isfinite(solution.state[: solution.valid]))
