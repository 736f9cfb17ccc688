"""The phase portraits (``rotlab.phase_portrait``, ``rotlab.recording.portrait_view``) against the
integrals they come from: every polhode lies on |L| = L₀ and on its energy ellipsoid, the
separatrices pass through the unstable axis; a Lagrange top's turning points are the roots of its
cubic (mpmath), its nutation period 4AK(m)/√(2Ak(u₃ − u₁)) is the time between the run's turning
points and its mean precession rate the run's, to 1e-9; both recorded."""

from __future__ import annotations

import numpy as np
import pytest

import rotlab
from rotlab.phase_portrait import lagrange_top, polhodes
from rotlab.recording import layout
from rotlab.recording.reader import read_series, read_text
from rotlab.scene.scene import build_scene
from tests.conftest import CONFIGS
from tests.test_events import lagrange_turning_points

# the symmetry axis (body z) in space from Λ (scalar first): its horizontal components give ψ = atan2(x, −y)
AXIS_X, AXIS_Y = "2*(q[1]*q[3] + q[0]*q[2])", "2*(q[2]*q[3] - q[0]*q[1])"
TURN = {"name": "top", "when": "gamma[0]*omega[1] - gamma[1]*omega[0]", "direction": "falling", "record": [AXIS_X, AXIS_Y]}


@pytest.mark.parametrize("moments", [(1.0, 2.0, 3.0), (2.8e-4, 1e-4, 2e-4), (5.0, 0.5, 1.0)])
def test_every_polhode_lies_on_the_momentum_sphere_and_its_energy_ellipsoid(moments):
    moments = np.array(moments)
    curves, separatrices = polhodes(moments, 2.5)
    assert len(curves) == 16 and len(separatrices) == 2
    for curve in curves + separatrices:
        assert np.allclose(np.linalg.norm(curve, axis=1), 2.5, rtol=1e-12, atol=0)
        h = np.sum(curve**2 / moments, axis=1)
        assert np.ptp(h) <= 1e-12 * h.mean()  # one energy along each
    middle = int(np.argsort(moments)[1])
    for curve in separatrices:  # through ±L₀ e_mid, at the intermediate moment's energy
        assert np.allclose(np.sum(curve**2 / moments, axis=1), 2.5**2 / moments[middle], rtol=1e-12)
        assert np.min(np.abs(np.abs(curve[:, middle]) - 2.5)) <= 1e-9
    assert polhodes(np.array([1.0, 1.0, 2.0]), 1.0) == ([], [])  # a symmetric body: no separatrix, none drawn


def test_the_top_turns_nutates_and_precesses_as_its_integrals_say():
    """Turning points against mpmath's cubic roots (≤ 1e-12); the nutation period against the times
    between the exact run's θ-minimum events, the mean precession against ψ's advance between the
    first and the last of them (≤ 1e-9 relative; measured ≤ 2e-12)."""
    top = lagrange_top(build_scene(rotlab.load(CONFIGS / "lagrange.toml")))
    assert np.allclose(np.cos(top.turning_points()), lagrange_turning_points(), rtol=0, atol=1e-12)
    traj = rotlab.simulate(CONFIGS / "lagrange.toml", method="exact", overrides={"events": [TURN]})
    turns = traj.events["top"]
    assert turns.count >= 90
    period = top.nutation_period()
    assert np.max(np.abs(turns.intervals() - period)) <= 1e-9 * period
    psi = np.unwrap(np.arctan2(turns.values[:, 0], -turns.values[:, 1]))
    rate = (psi[-1] - psi[0]) / (turns.t[-1] - turns.t[0])
    assert rate == pytest.approx(top.mean_precession_rate(), rel=1e-9)
    # the fast top's approximations are near, not equal: at ω₃ = 150 rad/s C ω₃/A is 7.7 % high, m g l/(C ω₃) 3.5 % low
    assert 1.0 < top.fast_nutation_frequency * period / (2 * np.pi) < 1.1 and 0.95 < top.fast_precession_rate / rate < 1.0


def test_the_recordings_carry_the_portraits(tmp_path):
    free = rotlab.simulate(CONFIGS / "dzhanibekov.toml")
    rotlab.save(tmp_path / "free.rrd", free)
    t, L = read_series(tmp_path / "free.rrd", layout.PORTRAIT_NOW, "Points3D:positions")
    assert t.shape[0] == free.t.shape[0] and np.allclose(L.reshape(-1, 3), free.L_body, rtol=1e-6, atol=1e-12)  # float32 positions
    assert "Phase portrait tab" in read_text(tmp_path / "free.rrd", layout.INFO)
    top = rotlab.simulate(CONFIGS / "lagrange.toml", duration=2.0)
    rotlab.save(tmp_path / "top.rrd", top)
    _, potential = read_series(tmp_path / "top.rrd", layout.TOP_POTENTIAL)
    u, level = potential[:, 0], potential[:, 1]
    assert np.all(u <= level * (1 + 1e-9)) and np.max(u) >= level[0] * (1 - 1e-6)  # U(θ) ≤ E′, touching at the turning points
    _, turning = read_series(tmp_path / "top.rrd", layout.EULER_THETA_TURNING)
    assert np.allclose(turning[0], np.degrees(lagrange_top(top.scene).turning_points()))
    report = read_text(tmp_path / "top.rrd", layout.INFO)
    assert "turning points θ₁, θ₂ | 27.0751°, 25°" in report and "mean precession rate" in report


def test_the_portraits_closed_forms_match_scipys_to_rounding():
    """``complete_elliptic_k`` (the AGM) against SciPy's ``ellipk`` for m in [0, 1 − 1e-15]
    (≤ 1e-15 relative), and the mean precession (the periodic trapezoidal rule) against SciPy's
    adaptive ``quad`` at epsrel 1e-13 on four tops, slow to fast (≤ 1e-14 relative)."""
    from scipy.integrate import quad
    from scipy.special import ellipk

    from rotlab.phase_portrait import complete_elliptic_k

    ms = np.concatenate([np.linspace(0.0, 0.99, 200), 1.0 - np.logspace(-2, -15, 50)])
    assert max(abs(complete_elliptic_k(m) / ellipk(m) - 1.0) for m in ms) <= 1e-15
    for omega in ([0.5, 0.0, 150.0], [3.0, 1.0, 40.0], [0.1, 0.2, 10.0], [2.0, 0.0, 5.0]):
        top = lagrange_top(build_scene(rotlab.load(CONFIGS / "lagrange.toml", overrides={"initial.omega": omega})))
        u1, u2, u3 = top.cubic_roots()
        b, a = top.c_moment * top.spin, top.a_moment

        def rate(s: float) -> float:
            u = u1 + (u2 - u1) * np.sin(s) ** 2
            return (top.p_psi - b * u) / (1.0 - u * u) * 2.0 / np.sqrt(2.0 * a * top.k * (u3 - u))

        reference = 2.0 * quad(rate, 0.0, 0.5 * np.pi, epsabs=0.0, epsrel=1e-13, limit=200)[0] / top.nutation_period()
        assert top.mean_precession_rate() == pytest.approx(reference, rel=1e-14, abs=0.0), omega
