"""Units where people think in them: ω in rev/min or deg/s, rotations and a controller's target
in degrees — stored converted, so a run is the same however it was written — and one-line hints
where a valid value looks like a unit slip (``rotlab.config.hints``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rotlab
from rotlab.core import quaternion as quat
from rotlab.errors import InputError
from tests.conftest import CONFIGS

BASE = {"body": {"principal_moments": [1.0, 2.0, 3.0]}, "time": {"end": 1.0}}


def scenario(**initial) -> rotlab.Scenario:
    return rotlab.parse_scenario({**BASE, "initial": initial})


def test_rpm_degrees_per_second_and_degrees_are_stored_in_si():
    assert scenario(omega_rpm=[0.0, 60.0, 30.0]).initial.omega == pytest.approx((0.0, 2 * math.pi, math.pi), rel=1e-15)
    assert scenario(omega_deg=[180.0, 0.0, -90.0]).initial.omega == pytest.approx((math.pi, 0.0, -math.pi / 2), rel=1e-15)
    assert scenario(axis_angle_deg=[0.0, 90.0, 0.0]).initial.axis_angle == pytest.approx((0.0, math.pi / 2, 0.0), rel=1e-15)
    a = rotlab.simulate(scenario(omega_rpm=[0.0, 60.0, 30.0], axis_angle_deg=[0.0, 90.0, 0.0]), method="dop853")
    b = rotlab.simulate(scenario(omega=[0.0, 2 * math.pi, math.pi], axis_angle=[0.0, math.pi / 2, 0.0]), method="dop853")
    assert np.array_equal(a.omega, b.omega) and np.array_equal(a.quaternion, b.quaternion)
    assert "omega_rpm" not in a.scene.scenario.model_dump(mode="json", exclude_unset=True)["initial"]  # one value, in SI


def test_a_controllers_target_in_degrees():
    load = {"type": "pd_control", "kp": 0.5, "kd": 1.0}
    for given, expected in (({"target_euler_313_deg": [90.0, 30.0, 0.0]}, quat.from_euler_313(math.pi / 2, math.pi / 6, 0.0)),
                            ({"target_axis_angle_deg": [0.0, 0.0, 90.0]}, quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), math.pi / 2))):
        target = rotlab.parse_scenario({**BASE, "loads": [{**load, **given}]}).loads[0].target
        np.testing.assert_allclose(target, expected, rtol=0, atol=1e-16)


@pytest.mark.parametrize("initial, key, words", [
    ({"omega": [1.0, 0.0, 0.0], "omega_rpm": [1.0, 0.0, 0.0]}, "initial.omega_rpm", "give omega or omega_rpm, not both"),
    ({"omega_deg": [1.0, "x", 0.0]}, "initial.omega_deg[1]", "must be a number"),
    ({"axis_angle_deg": [1.0, 2.0]}, "initial.axis_angle_deg", "three numbers"),
    ({"axis_angle_deg": [1.0, 0.0, 0.0], "euler_313": [0.0, 0.1, 0.0]}, "initial", "give only one orientation"),
])
def test_conflicts_and_bad_values_are_one_line(initial, key, words):
    with pytest.raises(InputError) as caught:
        scenario(**initial)
    assert key in str(caught.value) and words in str(caught.value) and "\n" not in str(caught.value)


def test_set_in_other_units_replaces_the_files_value(cli):
    result = cli("run", str(CONFIGS / "lagrange.toml"), "--duration", "0.05", "-q", "-o", "t.rrd",
                 "--set", "initial.omega_rpm=[0, 0, 1200]", "--set", "initial.quaternion=[1, 0, 0, 0]")
    assert result.exit_code == 0, result.output  # the file's omega and euler_313_deg give way



def test_set_sample_rate_replaces_the_files_samples(cli):
    """configs/detumbling.toml gives samples = 6001: a --set of sample_rate replaces it (and back)."""
    result = cli("validate", str(CONFIGS / "detumbling.toml"), "--set", "time.sample_rate=2")
    assert result.exit_code == 0 and "ok (12,001 samples" in result.output, result.output
    result = cli("validate", str(CONFIGS / "lagrange.toml"), "--set", "time.samples=11")
    assert result.exit_code == 0 and "ok (11 samples" in result.output, result.output

def test_hints_for_values_that_look_like_unit_slips(cli):
    result = cli("validate", str(CONFIGS / "euler.toml"), "--set", "initial.euler_313=[15, 0, 0]", "--set", "initial.omega=[0, 0, 20000]")
    assert result.exit_code == 0
    lines = result.stderr.splitlines()
    assert any("initial.euler_313 = [15.0, 0.0, 0.0] rad is more than a turn: did you mean euler_313_deg" in line for line in lines)
    assert any("|ω₀| = 2e+04 rad/s = 1.91e+05 rpm" in line and "omega_rpm: rev/min" in line for line in lines)
    heavy = cli("validate", str(CONFIGS / "lagrange.toml"), "--set", "body.mass=500", "--set", "body.center_of_mass=[0, 0, 0.0001]")
    assert "density ~1.26e+10 kg/m³" in heavy.stderr and heavy.exit_code == 0
    low = cli("validate", str(CONFIGS / "detumbling.toml"), "--set", "loads[0].altitude=500")
    assert "loads[0].altitude = 500 m: an orbit is at least ~150 km up" in low.stderr
    quiet = cli("validate", str(CONFIGS))
    assert quiet.exit_code == 0 and "hint" not in quiet.stderr  # none for the shipped scenarios
