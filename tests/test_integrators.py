"""Integrator accuracy, orders and failure handling, against exact results.

Bounds stated per test.  No renormalisation: |Λ| − 1 is measured, not hidden.
"""

from __future__ import annotations

import numpy as np
import pytest

import rotlab
from rotlab.core import quaternion as quat
from tests.conftest import CONFIGS
from tests.helpers import axisymmetric_free_body, same_rotation_error, scenario


def _free(method: str, **solver):
    q0 = quat.from_axis_angle([1.0, 1.0, 0.0], 0.5)
    w0 = np.array([0.2, 0.5, 2.0])
    sc = scenario(
        body={"principal_moments": [1.0, 1.0, 1.8]},
        initial={"omega": w0.tolist(), "quaternion": q0.tolist()},
        time={"end": 10.0, "sample_rate": 10},
        solver={"method": method, **solver},
    )
    traj = rotlab.simulate(sc)
    q_exact, w_exact = axisymmetric_free_body(1.0, 1.8, w0, q0, traj.t)
    return traj, max(np.max(np.abs(traj.omega - w_exact)), np.max(same_rotation_error(traj.quaternion, q_exact)))


def test_rk4_is_fourth_order():
    errors = [_free("rk4", step=h)[1] for h in (0.02, 0.01)]
    assert 14.0 < errors[0] / errors[1] < 18.0  # 2⁴ = 16


@pytest.mark.parametrize("rtol, bound", [(1e-8, 1e-6), (1e-10, 1e-8), (1e-12, 1e-10)])
def test_dop853_error_follows_tolerance(rtol, bound):
    traj, error = _free("dop853", rtol=rtol, atol=rtol * 1e-2)
    assert error < bound


def test_dop853_last_stage_is_the_solution_and_its_fsal_slope():
    """The kernel takes y₁ = y₀ + h Σ b_j k_j from its 12th stage (one call site of the
    right-hand side fewer to compile): that needs row 12 of A to be b exactly, and c₁₂ = 1."""
    from scipy.integrate._ivp import dop853_coefficients as table

    from rotlab.core import dop853

    assert np.array_equal(dop853._A[dop853._STAGES, : dop853._STAGES], table.B)
    assert not dop853._A[dop853._STAGES, dop853._STAGES :].any() and dop853._C[dop853._STAGES] == 1.0


def test_euler_config_invariants_at_default_tolerance():
    """Issue 2 'done when': configs/euler.toml, dop853 defaults: drift of T and L_space < 1e-10."""
    traj = rotlab.simulate(CONFIGS / "euler.toml", method="dop853")
    drift = traj.max_drift()
    assert drift["energy"] < 1e-10 and drift["L_space"] < 1e-10 and drift["L_norm"] < 1e-10


def test_quaternion_norm_drift_is_reported_not_hidden():
    traj, _ = _free("rk4", step=0.05)
    norm_drift = traj.invariants["quaternion_norm"]
    assert np.allclose(norm_drift, np.linalg.norm(traj.quaternion, axis=1) - 1.0)
    assert np.max(np.abs(norm_drift)) > 1e-12  # RK4 does not preserve |Λ|: we see it


def test_work_balances_energy_with_every_nonconservative_load():
    """general.toml (gravity + windowed space torque + body table + harmonic + damping):
    T + V − W stays constant to 1e-8 relative with dop853 at rtol 1e-10, while T + V itself
    changes by orders of magnitude more."""
    traj = rotlab.simulate(CONFIGS / "general.toml", method="dop853")
    assert traj.work is not None and traj.potential is not None
    assert np.max(np.abs(traj.invariants["energy"])) < 1e-8
    assert np.ptp(traj.total) / abs(traj.total[0]) > 1e-3


def test_damping_dissipates_exactly():
    """Spherical body, M = −kω: ω(t) = ω₀ e^{−kt/I}, W = −½ I |ω₀|² (1 − e^{−2kt/I})."""
    k, inertia = 0.3, 2.0
    sc = scenario(
        body={"principal_moments": [inertia] * 3},
        initial={"omega": [1.0, -2.0, 0.5]},
        loads=[{"type": "damping", "coefficient": k}],
        time={"end": 5.0, "sample_rate": 4},
        solver={"method": "dop853", "rtol": 1e-12, "atol": 1e-14},
    )
    traj = rotlab.simulate(sc)
    decay = np.exp(-k * traj.t / inertia)
    np.testing.assert_allclose(traj.omega, np.outer(decay, [1.0, -2.0, 0.5]), rtol=1e-10)
    np.testing.assert_allclose(traj.work, -0.5 * inertia * 5.25 * (1 - decay**2), rtol=1e-10, atol=1e-14)


def test_harmonic_and_table_torques_integrate_exactly():
    """Spherical body, body-frame torques along one axis: I ω̇ = M(t) integrates in closed form.
    M = 0.2 sin(3t + 0.5) + 0.1 inside [1, 3); table ramp 0 → 0.4 over [0, 2) then back to 0 at 4."""
    sc = scenario(
        body={"principal_moments": [1.0, 1.0, 1.0]},
        loads=[
            {"type": "harmonic_torque", "frame": "body", "amplitude": [0, 0, 0.2], "angular_frequency": 3.0, "phase": 0.5,
             "offset": [0, 0, 0.1], "window": {"on": 1.0, "off": 3.0}},
            {"type": "torque_table", "frame": "body", "times": [0.0, 2.0, 4.0], "values": [[0, 0, 0], [0.4, 0, 0], [0, 0, 0]]},
        ],
        time={"end": 5.0, "samples": 6},
        solver={"method": "dop853", "rtol": 1e-12, "atol": 1e-14},
    )
    traj = rotlab.simulate(sc)
    harmonic_total = 0.1 * 2.0 - 0.2 / 3.0 * (np.cos(3 * 3.0 + 0.5) - np.cos(3 * 1.0 + 0.5))
    assert traj.omega[-1, 2] == pytest.approx(harmonic_total, abs=1e-9)
    assert traj.omega[-1, 0] == pytest.approx(0.4 * 4.0 / 2.0, abs=1e-9)  # area under the triangle


def test_blow_up_stops_with_a_message_and_keeps_valid_samples(cli, write, tmp_path):
    path = write(
        "boom.toml",
        "[body]\nprincipal_moments = [1, 1, 1]\n[initial]\nomega = [0, 0, 1]\n"
        '[[loads]]\ntype = "torque_table"\nframe = "body"\ntimes = [0.5, 0.6]\nvalues = [[1e30, 1e30, 0], [1e30, 1e30, 0]]\n'
        "[time]\nend = 1.0\nsample_rate = 100\n[solver]\nmethod = \"dop853\"\n",
    )
    result = cli("run", str(path), "-o", "boom.rrd")
    assert result.exit_code == 1
    message = result.stderr.strip().splitlines()
    assert len(message) == 1 and "t = 0.5" in message[0]
    assert "non-finite" in message[0] or "step size fell below" in message[0]
    from rotlab.recording import layout
    from rotlab.recording.reader import read_series

    assert "boom.partial.rrd" in message[0] and not (tmp_path / "boom.rrd").exists()
    t, w = read_series(tmp_path / "boom.partial.rrd", layout.OMEGA)
    assert t[-1] == pytest.approx(0.5) and np.all(np.isfinite(w))


_COLLAPSING = (  # rk4 at h·|ω| = 2.79 (under its stability limit 2.8): |Λ| shrinks by |R(1.395i)| ≈ 0.96 a step
    "[body]\nprincipal_moments = [0.010, 0.016, 0.022]\n[initial]\nomega = [0.0, 0.0, 279.0]\n"
    "[time]\nend = 100.0\nsample_rate = 10\n[solver]\nmethod = \"rk4\"\nstep = 0.01\n"
)


@pytest.mark.parametrize("exponent", [0, -153, -154, -160, -400, 150, 154, 155, 160])
@pytest.mark.parametrize("broken", [None, 4, 7])
def test_a_state_with_a_lost_attitude_is_refused_by_one_rule(exponent, broken):
    """``state_status`` (the kernels') and ``valid_rows`` (NumPy's) agree: a state is stored only
    when it is finite and |Λ|² is a normal double, |Λ| between ~1.49e-154 and ~1.34e154."""
    from rotlab.core.kernel_status import ATTITUDE_LOST, NONFINITE, OK, state_status, valid_rows

    y = np.array([0.6, 0.0, 0.8, 0.0, 1.0, 2.0, 3.0, 0.5])
    y[:4] *= 10.0**exponent
    if broken is not None:
        y[broken] = np.nan
    expected = NONFINITE if broken is not None else (OK if -153 <= exponent <= 154 else ATTITUDE_LOST)
    assert state_status(y) == expected
    assert valid_rows(y[None, :])[0] == (expected == OK)


def test_a_collapsing_quaternion_stops_the_run_and_the_sweep_alike(cli, write, tmp_path):
    """rk4 drives |Λ| below ~1.5e-154 near t = 88 s: the run stops there (exit 1, one line that
    says the attitude is lost), keeping only samples whose Λ can be normalised; the same case in
    a sweep fails with the same words at the same sample (it ran to t = 100 s with exit 0 and NaN
    attitudes before)."""
    path = write("collapse.toml", _COLLAPSING)
    result = cli("run", str(path), "-o", "collapse.rrd")
    assert result.exit_code == 1
    line, = result.stderr.strip().splitlines()
    assert "the attitude is lost between t = 87.8 s and t = 87.9 s" in line and "take a smaller solver.step" in line
    from rotlab.recording import layout
    from rotlab.recording.reader import read_series

    t, q = read_series(tmp_path / "collapse.partial.rrd", layout.QUATERNION)
    norms = np.linalg.norm(q, axis=1)
    assert t.shape[0] == 879 and np.all(norms >= 1.49e-154) and norms[-1] < 1e-153
    write("sweep.toml", _COLLAPSING + '[sweep]\n[sweep.parameters]\n"initial.omega[2]" = [27.9, 279.0]\n')
    swept = cli("sweep", "sweep.toml", "-o", "swept")
    assert swept.exit_code == 1
    import csv

    rows = list(csv.DictReader((tmp_path / "swept" / "results.csv").open()))
    assert [r["status"] for r in rows] == ["pass", "fail"]
    assert rows[1]["message"] in line and int(rows[1]["steps"]) == 8790


def test_adaptive_steps_never_jump_over_a_short_pulse():
    """A 0.01 s torque pulse in a 10 s quiet run: its impulse M·Δt = 0.02 N·m·s must land in
    full (steps end at the window edges), to 1e-12."""
    sc = scenario(
        body={"principal_moments": [1.0, 1.0, 1.0]},
        loads=[{"type": "torque", "frame": "body", "value": [0.0, 0.0, 2.0], "window": {"on": 6.123, "off": 6.133}}],
        time={"end": 10.0, "samples": 3},
        solver={"method": "dop853"},
    )
    traj = rotlab.simulate(sc)
    assert traj.omega[-1, 2] == pytest.approx(0.02, abs=1e-12)


def test_fixed_step_longer_than_a_pulse_is_refused():
    from rotlab.errors import InputError

    sc = scenario(
        body={"principal_moments": [1.0, 1.0, 1.0]},
        loads=[{"type": "torque", "frame": "body", "value": [0.0, 0.0, 2.0], "window": {"on": 6.0, "off": 6.01}}],
        time={"end": 10.0, "samples": 11},
        solver={"method": "rk4", "step": 0.1},
    )
    with pytest.raises(InputError, match="acts for only 0.01 s"):
        rotlab.simulate(sc)


def _windowed(method: str, **solver):
    """An asymmetric body with a space-frame torque switched on and off between step points."""
    return rotlab.simulate(scenario(
        body={"principal_moments": [1.0, 1.5, 2.0]},
        initial={"omega": [0.3, 1.0, -0.4]},
        loads=[{"type": "torque", "frame": "space", "value": [0.2, -0.1, 0.3], "window": {"on": 2.03, "off": 4.07}},
               {"type": "torque_table", "frame": "body", "times": [1.01, 2.51, 3.33], "values": [[0, 0, 0], [0.1, 0.2, 0], [0, 0, 0]]}],
        time={"end": 6.0, "sample_rate": 10},
        solver={"method": method, **solver},
    ))


def test_rk4_keeps_fourth_order_across_load_switches():
    """Steps are split at window edges and table knots (left limit before, right limit after):
    halving h divides the error by ≈ 16, not 2 (bound: ratio 13–19)."""
    ref = _windowed("dop853", rtol=1e-13, atol=1e-15)
    errors = [np.max(np.abs(_windowed("rk4", step=h).omega - ref.omega)) for h in (0.02, 0.01)]
    assert 13.0 < errors[0] / errors[1] < 19.0, errors


def test_rkmk4_keeps_fourth_order_across_load_switches():
    """The same scene and bound as for rk4: RKMK4 splits its steps at the breakpoints too."""
    ref = _windowed("dop853", rtol=1e-13, atol=1e-15)
    errors = [np.max(np.abs(_windowed("rkmk4", step=h).omega - ref.omega)) for h in (0.02, 0.01)]
    assert 13.0 < errors[0] / errors[1] < 19.0, errors
