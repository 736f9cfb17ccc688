"""Gyrostats: a body carrying rotors at constant relative spin, I ω̇ + ω × (I ω + h) = M
(Zhukovsky–Volterra), h = Σ J Ω â fixed in the body.

Held against an independent integration of the gyrostat's equations in the user's body frame
(SciPy's DOP853 at rtol 1e-13), its two Casimirs |I ω + h| and L_space = R (I ω + h) and its
energy ½ ω·I ω, and the closed form of the dual-spin body's linear stability."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import rotlab
from rotlab.config.loader import parse_scenario
from rotlab.errors import InputError
from tests.conftest import CONFIGS

# a body given by a full tensor (its principal axes are not the user's axes) and two rotors on skew axes
TENSOR = np.array([[2.0, 0.3, -0.1], [0.3, 3.0, 0.2], [-0.1, 0.2, 4.0]])
ROTORS = [{"axis": [1.0, 1.0, 0.0], "inertia": 0.01, "spin": 60.0}, {"name": "pitch", "axis": [0.0, 0.0, 2.0], "momentum": -0.4}]
H_USER = 0.6 * np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0) + np.array([0.0, 0.0, -0.4])
OMEGA0 = np.array([0.3, -0.7, 0.5])
Q0 = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])
END = 20.0


def _scenario(method: str, **solver):
    return parse_scenario({"body": {"inertia_tensor": TENSOR.tolist()}, "rotors": ROTORS,
                           "initial": {"omega": OMEGA0.tolist(), "quaternion": Q0.tolist()},
                           "time": {"end": END, "sample_rate": 20}, "solver": {"method": method, **solver}}, source="gyrostat")


def _reference(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ω, Λ) at ``t`` from the gyrostat's equations in the user's frame, independently of rotlab:
    I ω̇ = (I ω + h) × ω, Λ̇ = ½ Λ ∘ (0, ω)."""

    def f(_, y):
        w, q = y[:3], y[3:]
        dw = np.linalg.solve(TENSOR, np.cross(TENSOR @ w + H_USER, w))
        q0, q1, q2, q3 = q
        p, r, s = w
        dq = 0.5 * np.array([-q1 * p - q2 * r - q3 * s, q0 * p + q2 * s - q3 * r, q0 * r + q3 * p - q1 * s, q0 * s + q1 * r - q2 * p])
        return np.concatenate([dw, dq])

    sol = solve_ivp(f, (0.0, END), np.concatenate([OMEGA0, Q0]), method="DOP853", rtol=1e-13, atol=1e-15, t_eval=t)
    return sol.y[:3].T, sol.y[3:].T


def test_the_rotors_momentum_is_the_sum_of_each_rotors_j_omega_along_its_axis():
    scenario = _scenario("dop853")
    assert scenario.rotor_momentum() == pytest.approx(H_USER, abs=1e-15)
    traj = rotlab.simulate(scenario)
    assert traj.scene.kind == "gyrostat"
    assert traj.L_body[0] == pytest.approx(TENSOR @ OMEGA0 + H_USER, rel=1e-13)  # L = I ω + h, user's body frame
    assert traj.kinetic[0] == pytest.approx(0.5 * OMEGA0 @ TENSOR @ OMEGA0, rel=1e-14)  # T = ½ ω·I ω: the rotors' own spin is not in it


@pytest.mark.parametrize("method, solver, bound", [
    ("dop853", {"rtol": 1e-12, "atol": 1e-14}, 5e-11),  # measured: 3e-12 (Λ), 7.5e-12 (L_space)
    ("taylor", {"rtol": 1e-12, "atol": 1e-14}, 3e-12),  # measured: 1.3e-13
    ("rk4", {"step": 1e-3}, 3e-12),  # measured: 1.2e-13
    ("rkmk4", {"step": 1e-3}, 3e-12),
    ("splitting", {"step": 1e-3, "order": 8}, 3e-12),
])
def test_a_free_gyrostat_matches_an_independent_integration_and_keeps_its_casimirs(method, solver, bound):
    """ω and Λ in the user's frames within ``bound`` of the reference over 20 s (~2 turns of the
    body, both rotors' h comparable to I ω); |L|, L_space and T kept to ``bound`` relative."""
    traj = rotlab.simulate(_scenario(method, **solver))
    assert traj.stats.failure is None and traj.t[-1] == END
    omega, q = _reference(traj.t)
    assert np.max(np.abs(traj.omega - omega)) <= bound
    sign = np.sign(np.sum(traj.quaternion * q, axis=1))[:, None]  # Λ and −Λ are one attitude
    assert np.max(np.abs(traj.quaternion * sign - q)) <= bound
    drift = traj.max_drift()
    assert set(drift) == {"energy", "quaternion_norm", "L_norm", "L_space"}
    for name in ("energy", "L_norm", "L_space"):
        assert drift[name] <= bound, name
    L_space = traj.L_space
    assert np.max(np.linalg.norm(L_space - L_space[0], axis=1)) <= bound * np.linalg.norm(L_space[0])


@pytest.mark.parametrize("method", ["dmv", "exact"])
def test_methods_made_for_a_body_without_rotors_refuse_a_gyrostat_in_one_line(method):
    with pytest.raises(InputError) as refused:
        rotlab.simulate(_scenario(method))
    message = str(refused.value)
    assert "\n" not in message and ("rotors" in message or "gyrostat" in message)


@pytest.mark.parametrize("h", [0.0, 0.2, 0.39, 0.41, 0.5, 1.5, -0.5, -1.1])
def test_a_wheel_on_the_intermediate_axis_holds_it_as_the_closed_form_says(h):
    """Spin Ω about the intermediate axis y, h = h ŷ: λ² = −((B − C)Ω + h)((B − A)Ω + h)/(A C)
    (configs/gyrostat.toml's moments: held for h > (C − B)Ω = 0.4 N·m·s or h < −(B − A)Ω)."""
    A, B, C, spin = 2.0, 3.0, 4.0, 0.4
    result = rotlab.stability(CONFIGS / "gyrostat.toml",
                              overrides={"initial.omega": [0.0, spin, 0.0], "rotors": [{"axis": [0, 1, 0], "momentum": h}] if h else []})
    square = -((B - C) * spin + h) * ((B - A) * spin + h) / (A * C)
    if square > 0:
        assert result.verdict == "unstable" and result.growth_rate == pytest.approx(np.sqrt(square), rel=1e-12)
    else:
        assert result.verdict == "linearly stable"
        assert np.sort(np.abs(result.eigenvalues.imag))[1:] == pytest.approx([np.sqrt(-square)] * 2, rel=1e-12)


def test_splitting_keeps_a_gyrostats_casimirs_to_rounding():
    """The axis rotations turn L = I ω + h (not I ω) at the rates (L_i − h_i)/I_i: |L| and L_space
    are kept to rounding at any step (a coarse one here: 0.05 s, ~100 steps a turn)."""
    traj = rotlab.simulate(_scenario("splitting", step=0.05, order=4))
    drift = traj.max_drift()
    assert drift["L_norm"] <= 1e-14 and drift["L_space"] <= 1e-13 and drift["quaternion_norm"] <= 1e-14
    assert drift["energy"] <= 1e-8  # not kept exactly: bounded at the method's order (measured 6.5e-10)


def test_the_shipped_dual_spin_body_stays_on_its_axis_and_flips_without_its_wheel():
    held = rotlab.simulate(CONFIGS / "gyrostat.toml")
    assert np.min(held.omega[:, 1]) > 0.39 and held.max_drift()["L_norm"] <= 1e-12
    bare = rotlab.simulate(CONFIGS / "gyrostat.toml", overrides={"rotors": []})
    assert bare.scene.kind == "torque_free" and np.min(bare.omega[:, 1]) < -0.39  # the Dzhanibekov flip


def test_a_heavy_gyrostat_keeps_its_vertical_momentum():
    """A Lagrange top carrying a rotor on a skew axis: no closed form and no symmetry invariant,
    but gravity's torque is horizontal, so (R (I ω + h))·up is kept (taylor, to 1e-11)."""
    traj = rotlab.simulate(CONFIGS / "lagrange.toml", method="taylor", duration=2.0,
                           overrides={"rotors": [{"axis": [1.0, 0.0, 1.0], "momentum": 0.002}], "solver.rtol": 1e-12})
    assert traj.scene.kind == "gyrostat"
    drift = traj.max_drift()
    assert "L_symmetry" not in drift and drift["L_vertical"] <= 1e-11 and drift["energy"] <= 1e-11


@pytest.mark.parametrize("rotor, key", [
    ({"axis": [0, 0, 0], "momentum": 1.0}, "rotors[0].axis"),
    ({"axis": [1, 0, 0], "inertia": 0.1}, "rotors[0].spin"),
    ({"axis": [1, 0, 0], "momentum": 1.0, "spin": 3.0}, "rotors[0].spin"),
    ({"axis": [1, 0, 0], "inertia": 0.1, "spin": 1.0, "spin_rpm": 10.0}, "rotors[0].spin_rpm"),
    ({"axis": [1, 0, 0], "inertia": -0.1, "spin": 1.0}, "rotors[0].inertia"),
    ({"axis": [1, 0, 0], "momentum": 1.0, "mass": 3.0}, "rotors[0].mass"),
    ({"axis": [0, 1e-300, 0], "momentum": 1.0}, "rotors[0].axis"),  # (its norm underflows)
    ({"axis": [0, 1, 0], "inertia": 2.5, "spin": 1.0}, "rotors[0].inertia"),  # more than the body's B = 2 about y
    ({"axis": [1, 0, 0], "momentum": 1.0, "torque": "gamma[2]", "up": [0, 0, 0]}, "rotors[0].up"),
])
def test_a_bad_rotor_is_one_line_naming_its_key(cli, write, rotor, key):
    body = "\n".join(f"{k} = {v!r}".replace("'", '"') for k, v in rotor.items())
    path = write("bad.toml", f"[body]\nprincipal_moments = [1, 2, 3]\n[time]\nend = 1.0\n[[rotors]]\n{body}\n")
    result = cli("validate", str(path))
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and key in lines[0]


def test_spin_rpm_is_stored_in_rad_per_s():
    scenario = parse_scenario({"body": {"principal_moments": [1, 2, 3]}, "time": {"end": 1.0},
                               "rotors": [{"axis": [0, 0, 1], "inertia": 0.5, "spin_rpm": 60.0}]}, source="rpm")
    assert scenario.rotors[0].spin == pytest.approx(2.0 * np.pi, rel=1e-15)
    assert scenario.rotor_momentum() == pytest.approx([0.0, 0.0, np.pi], rel=1e-15)


def test_the_recording_draws_each_wheel_on_its_axis_and_the_report_lists_them(tmp_path):
    from rotlab.recording.reader import read_static, read_text

    path = rotlab.save(tmp_path / "g.rrd", rotlab.simulate(_scenario("dop853")))
    centers = np.asarray(read_static(path, "/world/body/rotors/wheels", "Cylinders3D:centers"), dtype=float)
    assert centers.shape == (2, 3)
    for center, rotor in zip(centers, ROTORS):
        axis = np.asarray(rotor["axis"], dtype=float) / np.linalg.norm(rotor["axis"])
        assert np.linalg.norm(np.cross(center, axis)) <= 1e-6 * np.linalg.norm(center) and center @ axis > 0  # on its axis, this side
    report = read_text(path, "/info")
    assert "- rotor 1: axis [1.0, 1.0, 0.0] (body frame), J = 0.01 kg·m², Ω = 60 rad/s (572.958 rpm)" in report
    assert "- rotor pitch: axis [0.0, 0.0, 2.0] (body frame), J Ω = -0.4 N·m·s" in report
    assert "rotors' momentum h: [ 0.424264  0.424264 -0.4     ] N·m·s" in report


# ---- driven rotors: J Ω̇ = u, the body feels −u â; their momenta are state columns ----------------

DRIVEN = {"name": "drive", "axis": [0.0, 1.0, 1.0], "inertia": 0.02, "spin": 5.0, "torque": "0.05*sin(2*t) - k*omega[1]",
          "constants": {"k": 0.01}}
DRIVEN_AXIS = np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0)


def _driven(method: str, **solver):
    return parse_scenario({"body": {"inertia_tensor": TENSOR.tolist()}, "rotors": [ROTORS[0], DRIVEN],
                           "initial": {"omega": OMEGA0.tolist(), "quaternion": Q0.tolist()},
                           "time": {"end": END, "sample_rate": 20}, "solver": {"method": method, **solver}}, source="driven")


def _driven_reference(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(ω, h_drive) at ``t`` from I ω̇ = (I ω + h) × ω − u â, ḣ_drive = u (user's frame), independently of rotlab."""
    constant = ROTORS[0]["inertia"] * ROTORS[0]["spin"] * np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)

    def f(time, y):
        w, h = y[:3], y[3]
        u = 0.05 * np.sin(2.0 * time) - 0.01 * w[1]
        total = constant + h * DRIVEN_AXIS
        return np.concatenate([np.linalg.solve(TENSOR, np.cross(TENSOR @ w + total, w) - u * DRIVEN_AXIS), [u]])

    sol = solve_ivp(f, (0.0, END), np.concatenate([OMEGA0, [0.02 * 5.0]]), method="DOP853", rtol=1e-13, atol=1e-15, t_eval=t)
    return sol.y[:3].T, sol.y[3]


@pytest.mark.parametrize("method, solver, bound", [
    ("dop853", {"rtol": 1e-12, "atol": 1e-14}, 5e-11),
    ("rk4", {"step": 1e-3}, 3e-12),
    ("rkmk4", {"step": 1e-3}, 3e-12),
])
def test_a_driven_rotor_matches_an_independent_integration_and_keeps_l(method, solver, bound):
    """ω and the rotor's momentum against the reference; |L| and L_space (the drive is internal)
    and T − W (W: the drive's work on the body) kept to ``bound``."""
    traj = rotlab.simulate(_driven(method, **solver))
    assert traj.stats.failure is None and traj._state.shape[1] == 9
    omega, h = _driven_reference(traj.t)
    assert np.max(np.abs(traj.omega - omega)) <= bound and np.max(np.abs(traj.rotor_momenta[:, 0] - h)) <= bound
    drift = traj.max_drift()
    assert set(drift) == {"energy", "quaternion_norm", "L_norm", "L_space"}
    assert max(drift["energy"], drift["L_norm"], drift["L_space"]) <= bound
    assert np.ptp(traj.rotor_momenta[:, 0]) > 0.05  # the drive moved it


@pytest.mark.parametrize("method", ["taylor", "splitting", "dmv", "exact"])
def test_methods_without_a_driven_rotors_state_refuse_it_in_one_line(method):
    with pytest.raises(InputError) as refused:
        rotlab.simulate(_driven(method))
    assert "\n" not in str(refused.value) and "rotor" in str(refused.value)


def test_the_shipped_wheel_slew_turns_the_body_90_degrees_and_stops_it_and_its_wheels():
    """configs/wheel_slew.toml: three wheels under a PD law, rest to rest, 90° about z in 60 s;
    the wheels give back what they took (L = I ω + h stays 0 in space)."""
    traj = rotlab.simulate(CONFIGS / "wheel_slew.toml")
    q = traj.quaternion[-1] * np.sign(traj.quaternion[-1, 0])
    assert q[1:3] == pytest.approx([0.0, 0.0], abs=1e-12)
    assert np.degrees(2.0 * np.arctan2(q[3], q[0])) == pytest.approx(90.0, abs=0.01)
    assert np.linalg.norm(traj.omega[-1]) < 1e-5 and np.max(np.abs(traj.rotor_momenta[-1])) < 1e-6
    assert np.max(np.abs(traj.rotor_momenta[:, 2])) > 0.01  # the z wheel took the slew's momentum
    assert np.max(np.linalg.norm(traj.L_space, axis=1)) < 1e-12
    assert np.max(np.abs(traj.kinetic - traj.work)) < 1e-10  # T − W = 0: the drives gave the body its energy


def test_a_drive_that_is_not_finite_stops_the_run_naming_the_rotor():
    from rotlab.errors import RunFailure

    scenario = parse_scenario({"body": {"principal_moments": [1, 2, 3]}, "initial": {"omega": [0.1, 0.2, 0.3]}, "time": {"end": 3.0},
                               "rotors": [{"axis": [0, 0, 1], "momentum": 0.0, "torque": "1/(t - 1)"}], "solver": {"method": "rk4"}},
                              source="pole")
    with pytest.raises(RunFailure) as stopped:
        rotlab.simulate(scenario)
    assert "rotors[0].torque = '1/(t - 1)' is not finite at t = 1 s" in str(stopped.value)
    kept = stopped.value.trajectory
    assert kept.t[-1] < 1.0 and np.all(np.isfinite(kept._state))


def test_a_driven_rotor_is_recorded_and_exported(tmp_path, cli):
    from rotlab.recording.reader import read_series

    path = write_rotor_recording(tmp_path)
    t, momenta = read_series(path, "/rotors/momentum")
    traj = rotlab.simulate(_driven("rk4", step=1e-3))
    assert np.array_equal(momenta[:, 0], traj.rotor_momenta[:, 0])  # every sample (the state's column)
    _, speeds = read_series(path, "/rotors/speed")
    assert speeds[:, 0] == pytest.approx(traj.rotor_momenta[:: len(traj.t) // len(t), 0][: len(t)] / 0.02 / (2.0 * np.pi / 60.0), rel=1e-6)  # rpm
    _, torques = read_series(path, "/rotors/torque")
    assert torques[:, 0] == pytest.approx(0.05 * np.sin(2.0 * t) - 0.01 * traj.omega[:: len(traj.t) // len(t), 1][: len(t)], abs=1e-12)
    result = cli("export", str(path), "-o", str(tmp_path / "run.csv"))
    assert result.exit_code == 0, result.output
    import pandas as pd

    table = pd.read_csv(tmp_path / "run.csv", comment="#")
    assert np.array_equal(table["rotor_momentum_drive"].to_numpy(), traj.rotor_momenta[:, 0])
    figure = cli("plot", str(path), "-o", str(tmp_path / "fig.png"), "--panels", "speed,torque")
    assert figure.exit_code == 0 and "speed, torque" in figure.output and (tmp_path / "fig.png").stat().st_size > 10_000


def write_rotor_recording(tmp_path):
    return rotlab.save(tmp_path / "driven.rrd", rotlab.simulate(_driven("rk4", step=1e-3)))


@pytest.mark.parametrize("rotor, key", [
    ({"axis": [1, 0, 0], "momentum": 1.0, "torque": "foo*t"}, "rotors[0].torque"),
    ({"axis": [1, 0, 0], "momentum": 1.0, "constants": {"k": 1.0}}, "rotors[0].constants"),
    ({"axis": [1, 0, 0], "momentum": 1.0, "torque": {"type": "pd_control", "kp": -1.0, "kd": 1.0}}, "rotors[0].torque"),
])
def test_a_bad_drive_is_one_line_naming_its_key(write, cli, rotor, key):
    import json

    body = "\n".join(f"{k} = {json.dumps(v) if not isinstance(v, dict) else '{ ' + ', '.join(f'{a} = {json.dumps(b)}' for a, b in v.items()) + ' }'}"
                     for k, v in rotor.items())
    path = write("bad.toml", f"[body]\nprincipal_moments = [1, 2, 3]\n[time]\nend = 1.0\n[[rotors]]\n{body}\n")
    result = cli("validate", str(path))
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and key in lines[0], result.output


def test_rotor_names_are_their_own(cli, write):
    path = write("dup.toml", "[body]\nprincipal_moments = [1, 2, 3]\n[time]\nend = 1.0\n"
                             "[[rotors]]\nname = \"a\"\naxis = [1, 0, 0]\nmomentum = 0.1\n"
                             "[[rotors]]\nname = \"2\"\naxis = [0, 1, 0]\nmomentum = 0.1\n")  # "2": the first one's place name
    result = cli("validate", str(path))
    assert result.exit_code == 0, result.output
    path = write("dup2.toml", path.read_text().replace('name = "2"', 'name = "a"'))
    result = cli("validate", str(path))
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and "rotors[1].name: rotor name 'a' is used twice" in lines[0]


def test_momentum_given_on_the_command_line_replaces_the_files_spin(cli):
    result = cli("validate", str(CONFIGS / "wheel_slew.toml"), "--set", "rotors[2].momentum=0.003")
    assert result.exit_code == 0, result.output
    assert "rotor z: axis [0.0, 0.0, 1.0] (body frame), J Ω = 0.003 N·m·s, J = 0.0002 kg·m²" in result.output


def test_a_drives_gamma_is_its_own_up_in_body_components():
    """u = gamma[0] with up = space x: the drive's torque is (Rᵀ x̂)_x, the body's x axis's space x."""
    base = {"body": {"principal_moments": [1, 2, 3]}, "initial": {"omega": [0.3, 0.2, 0.1]}, "time": {"end": 2.0},
            "solver": {"method": "rk4", "step": 1e-3}}
    scenario = parse_scenario({**base, "rotors": [{"axis": [0, 0, 1], "inertia": 0.01, "spin": 0.0, "torque": "0.01*gamma[0]",
                                                   "up": [1, 0, 0]}]}, source="up")
    traj = rotlab.simulate(scenario)
    from rotlab.core.quaternion import to_matrix

    expected = 0.01 * np.array([to_matrix(q)[0, 0] for q in traj.quaternion])  # (Rᵀ x̂)_x = R[0, 0]
    rates = np.gradient(traj.rotor_momenta[:, 0], traj.t)
    assert np.max(np.abs(rates[2:-2] - expected[2:-2])) < 1e-6


def test_speeds_are_recorded_for_the_driven_rotors_whose_inertia_is_given(tmp_path):
    from rotlab.recording.reader import read_series

    rotors = [DRIVEN, {**DRIVEN, "name": "bare", "inertia": None, "spin": None, "momentum": 0.1}]
    rotors[1] = {k: v for k, v in rotors[1].items() if v is not None}
    scenario = parse_scenario({"body": {"inertia_tensor": TENSOR.tolist()}, "rotors": rotors, "initial": {"omega": OMEGA0.tolist()},
                               "time": {"end": 1.0}, "solver": {"method": "rk4", "step": 1e-3}}, source="speeds")
    traj = rotlab.simulate(scenario)
    assert traj.rotor_speeds.shape == (len(traj.t), 2) and np.all(np.isnan(traj.rotor_speeds[:, 1]))
    path = rotlab.save(tmp_path / "s.rrd", traj)
    _, speeds = read_series(path, "/rotors/speed")
    _, momenta = read_series(path, "/rotors/momentum")
    assert speeds.shape[1] == 1 and momenta.shape[1] == 2


def test_a_total_momentum_of_zero_is_plotted_flat_not_as_its_rounding(tmp_path):
    """configs/wheel_slew.toml starts at rest: L = I ω + h stays 0 (1e-17 of rounding). Its plot's
    range is at least 2% of the body's own |I ω|, so the line is flat at 0."""
    from tests.test_blueprint_ranges import _ranges

    traj = rotlab.simulate(CONFIGS / "wheel_slew.toml")
    path = rotlab.save(tmp_path / "slew.rrd", traj)
    own = float(np.max(np.abs(traj.omega @ traj.inertia)))
    (low, high), *_ = _ranges(path, "L space (kg·m²/s)")
    assert own > 0.01 and high - low >= 0.02 * own and np.max(np.abs(traj.L_space)) < 1e-12
