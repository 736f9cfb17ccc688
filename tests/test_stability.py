"""Linear stability (``rotlab.linear_stability``) against the closed forms: the free body's permanent
rotations (the intermediate axis grows at Ω√((I₂−I₁)(I₃−I₂)/(I₁I₃)), the others oscillate at
Ω√((I_k−I_i)(I_k−I_j)/(I_iI_j))), the sleeping top (unstable iff C²ω₃² < 4 A m g l, growing at
√(4 A m g l − C²ω₃²)/(2A)), and a simulated perturbation growing at the predicted rate."""

from __future__ import annotations

import numpy as np
import pytest

import rotlab
from rotlab.errors import InputError
from tests.conftest import CONFIGS

MOMENTS = (0.01, 0.016, 0.022)  # configs/euler.toml
TOP = {"A": 1.1e-3, "C": 5.0e-4, "mgl": 0.5 * 9.81 * 0.04}  # configs/lagrange.toml


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("spin", [0.5, 3.0, -7.0])
def test_a_permanent_rotation_of_the_free_body_matches_the_closed_form(axis, spin):
    omega = [0.0, 0.0, 0.0]
    omega[axis] = spin
    result = rotlab.stability(CONFIGS / "euler.toml", overrides={"initial.omega": omega})
    k, i, j = axis, (axis + 1) % 3, (axis + 2) % 3
    ik, ii, ij = MOMENTS[k], MOMENTS[i], MOMENTS[j]
    product = (ik - ii) * (ik - ij) / (ii * ij)  # > 0: oscillation at |Ω|√product; < 0: growth at |Ω|√−product
    rate = abs(spin) * np.sqrt(abs(product))
    if product < 0:
        assert axis == 1 and result.verdict == "unstable"
        assert result.growth_rate == pytest.approx(rate, rel=1e-12)
        assert np.sort(result.eigenvalues.real) == pytest.approx([-rate, 0.0, rate], rel=1e-12, abs=1e-12 * rate)
    else:
        assert result.verdict == "linearly stable" and result.growth_rate == 0.0
        assert np.sort(np.abs(result.eigenvalues.imag)) == pytest.approx([0.0, rate, rate], rel=1e-12, abs=1e-12 * rate)
        assert np.max(np.abs(result.eigenvalues.real)) <= 1e-12 * rate


@pytest.mark.parametrize("spin", [150.0, 60.0, 42.0, 41.0, 30.0, 10.0])
def test_a_sleeping_top_is_stable_exactly_when_its_spin_beats_gravity(spin):
    A, C, mgl = TOP["A"], TOP["C"], TOP["mgl"]
    result = rotlab.stability(CONFIGS / "lagrange.toml", overrides={"initial.omega": [0.0, 0.0, spin], "initial.euler_313_deg": [0, 0, 0]})
    discriminant = C**2 * spin**2 - 4.0 * A * mgl  # threshold ≈ 41.6 rad/s
    if discriminant > 0:
        assert result.verdict == "linearly stable"
    else:
        assert result.verdict == "unstable"
        assert result.growth_rate == pytest.approx(np.sqrt(-discriminant) / (2.0 * A), rel=1e-9)
    assert result.jacobian.shape == (6, 6) and "γ" in result.space


def test_the_intermediate_axis_perturbation_grows_at_the_predicted_rate():
    """A 1e-9 rad/s wobble about the intermediate axis, simulated (exact solution): log|ω₁| grows
    with slope λ to 1e-3 while the wobble is small."""
    spin = 2.0
    predicted = rotlab.stability(CONFIGS / "euler.toml", overrides={"initial.omega": [0.0, spin, 0.0]}).growth_rate
    traj = rotlab.simulate(CONFIGS / "euler.toml", method="taylor", duration=12.0,
                           overrides={"initial.omega": [1e-9, spin, 1e-9], "solver.rtol": 1e-13, "solver.atol": 1e-16})
    late = (traj.t > 4.0) & (traj.t < 12.0)  # past the start-up transient, before the wobble is large (|ω₁| < 1e-4)
    assert np.max(np.abs(traj.omega[late, 0])) < 1e-4
    slope = np.polyfit(traj.t[late], np.log(np.abs(traj.omega[late, 0])), 1)[0]
    assert slope == pytest.approx(predicted, rel=1e-3)


def test_a_state_that_is_not_an_equilibrium_or_loads_out_of_reach_are_refused(cli):
    with pytest.raises(InputError, match="^initial: not an equilibrium"):
        rotlab.stability(CONFIGS / "lagrange.toml")  # released 25° from the vertical
    with pytest.raises(InputError, match="^loads: stability analyses a torque-free body or one in a uniform field"):
        rotlab.stability(CONFIGS / "general.toml")
    done = cli("stability", str(CONFIGS / "euler.toml"), "--set", "initial.omega=[0, 2, 0]")
    assert done.exit_code == 0 and "verdict: unstable" in done.stdout and "growth rate: 0.809039835 1/s" in done.stdout
    refused = cli("stability", str(CONFIGS / "euler.toml"), "--set", "initial.omega=[1, 2, 0]")
    assert refused.exit_code == 2 and len(refused.stderr.strip().splitlines()) == 1 and "Traceback" not in refused.stderr


def _precessing(theta_deg: float, spin: float, fast: bool) -> tuple[list[float], float]:
    """ω (body) of a steady precession of the lagrange.toml top at tilt θ with spin ω₃: ψ̇ a root
    of A ψ̇² cos θ − C ω₃ ψ̇ + m g l = 0 (slow or fast); Euler angles (0, θ, 0) put γ = (0, sin θ, cos θ)."""
    A, C, mgl = TOP["A"], TOP["C"], TOP["mgl"]
    theta = np.radians(theta_deg)
    slow_root, fast_root = sorted(np.roots([A * np.cos(theta), -C * spin, mgl]).real)
    rate = fast_root if fast else slow_root
    return [0.0, rate * np.sin(theta), spin], rate


@pytest.mark.parametrize("theta_deg, spin, fast", [(25.0, 150.0, False), (25.0, 150.0, True), (60.0, 80.0, False), (120.0, 200.0, False)])
def test_a_steady_precession_nutates_at_the_effective_potentials_curvature(theta_deg, spin, fast):
    """Eigenvalues ±i√(U''(θ₀)/A), U'' from mpmath at 30 digits (U of the module docstring)."""
    import mpmath

    A, C, mgl = TOP["A"], TOP["C"], TOP["mgl"]
    omega, rate = _precessing(theta_deg, spin, fast)
    result = rotlab.stability(CONFIGS / "lagrange.toml", overrides={"initial.omega": omega, "initial.euler_313_deg": [0, theta_deg, 0]})
    mpmath.mp.dps = 30
    theta0 = mpmath.radians(theta_deg)
    p_psi = A * rate * mpmath.sin(theta0) ** 2 + C * spin * mpmath.cos(theta0)  # L·γ
    U = lambda th: (p_psi - C * spin * mpmath.cos(th)) ** 2 / (2 * A * mpmath.sin(th) ** 2) + mgl * mpmath.cos(th)  # noqa: E731
    assert abs(mpmath.diff(U, theta0)) < 1e-9 * mgl  # the reference agrees this is a steady precession
    frequency = float(mpmath.sqrt(mpmath.diff(U, theta0, 2) / A))
    assert result.verdict == "linearly stable" and "steady precession" in result.space
    assert np.sort(result.eigenvalues.imag) == pytest.approx([-frequency, frequency], rel=1e-7)


def test_a_nudged_steady_precession_nutates_at_the_predicted_frequency():
    """θ nudged by 1e-4 rad from a slow steady precession, simulated: θ(t) oscillates at the
    predicted frequency (mean spacing of its extrema over 20 cycles) to 1e-3."""
    omega, _ = _precessing(25.0, 150.0, fast=False)
    frequency = np.max(rotlab.stability(CONFIGS / "lagrange.toml", overrides={
        "initial.omega": omega, "initial.euler_313_deg": [0, 25.0, 0]}).eigenvalues.imag)
    traj = rotlab.simulate(CONFIGS / "lagrange.toml", method="dop853", duration=2.0, overrides={
        "initial.omega": omega, "initial.euler_313_deg": [0, 25.0 + np.degrees(1e-4), 0], "time.sample_rate": 5000,
        "solver.rtol": 1e-12, "solver.atol": 1e-14})
    theta = traj.euler_angles[:, 1]
    turning = np.flatnonzero(np.diff(np.sign(np.diff(theta))) != 0) + 1  # maxima and minima of θ
    period = 2.0 * np.mean(np.diff(traj.t[turning]))
    assert 2 * np.pi / period == pytest.approx(frequency, rel=1e-3)
