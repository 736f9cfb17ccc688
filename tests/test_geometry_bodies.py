"""Bodies given by their geometry (``rotlab.geometry_inertia``, ``[body] shape / parts / pivot``):
each shape's inertia against its textbook formula and the parallel-axis theorem (a box about its
corner, a cylinder about an end), composites against independent sums (two half boxes are one
box; a Monte Carlo integral of ∫(|r|²𝟙 − r rᵀ) dm), the run of a geometry equal to the run of
the tensor it gives, and one-line errors for what does not describe a body."""

from __future__ import annotations

import numpy as np
import pytest

import rotlab
from rotlab.errors import InputError

BODY = {"initial": {"omega": [0.0, 0.5, 3.0]}, "loads": [{"type": "gravity", "g": [0.0, 0.0, -9.81]}], "time": {"end": 2.0}}


def body(**fields) -> rotlab.Scenario:
    return rotlab.parse_scenario({"body": fields, **BODY})


def test_a_box_about_its_corner():
    a, b, c, m = 0.3, 0.2, 0.1, 2.0
    tensor = body(shape={"box": [a, b, c]}, mass=m, pivot=[a / 2, b / 2, c / 2]).body.tensor()
    expected = m * np.array([[(b * b + c * c) / 3, -a * b / 4, -a * c / 4],
                             [-a * b / 4, (a * a + c * c) / 3, -b * c / 4],
                             [-a * c / 4, -b * c / 4, (a * a + b * b) / 3]])
    np.testing.assert_allclose(tensor, expected, rtol=1e-14)


def test_a_cylinder_about_an_end_a_sphere_and_a_disc():
    r, length, m = 0.05, 0.4, 3.0
    end = body(shape={"cylinder": {"radius": r, "length": length}}, mass=m, pivot=[0.0, 0.0, -length / 2]).body
    np.testing.assert_allclose(end.tensor(), np.diag([m * r * r / 4 + m * length**2 / 3] * 2 + [m * r * r / 2]), rtol=1e-14)
    assert end.centre() == pytest.approx((0.0, 0.0, length / 2))
    np.testing.assert_allclose(body(shape={"sphere": r}, mass=m).body.tensor(), 0.4 * m * r * r * np.eye(3), rtol=1e-15)
    np.testing.assert_allclose(body(shape={"disc": {"radius": r}}, mass=m).body.tensor(), m * r * r * np.diag([0.25, 0.25, 0.5]),
                               rtol=1e-15, atol=0.0)


def test_composites_against_independent_sums():
    a, b, c, m = 0.3, 0.2, 0.1, 2.0
    pivot = [0.15, -0.1, 0.02]
    whole = body(shape={"box": [a, b, c]}, mass=m, pivot=pivot).body
    halves = body(parts=[{"shape": {"box": [a / 2, b, c]}, "mass": m / 2, "center": [-a / 4, 0.0, 0.0]},
                         {"shape": {"box": [a / 2, b, c]}, "mass": m / 2, "center": [a / 4, 0.0, 0.0]}], pivot=pivot).body
    np.testing.assert_allclose(halves.tensor(), whole.tensor(), rtol=1e-14, atol=1e-17)
    assert halves.total_mass() == m and halves.centre() == pytest.approx(whole.centre(), abs=1e-16)
    rng = np.random.default_rng(3)  # Monte Carlo: 10⁶ points of the box, about the pivot
    r = (rng.random((1_000_000, 3)) - 0.5) * [a, b, c] - pivot
    integral = m * (np.mean(np.sum(r * r, axis=1)) * np.eye(3) - r.T @ r / r.shape[0])
    np.testing.assert_allclose(whole.tensor(), integral, rtol=0, atol=3e-3 * np.max(np.abs(integral)))
    dumbbell = body(parts=[{"shape": {"point": True}, "mass": 1.0, "center": [0.0, 0.0, 0.5]},
                           {"shape": {"point": True}, "mass": 1.0, "center": [0.0, 0.0, -0.5]},
                           {"shape": {"rod": 1.0}, "mass": 0.6}, {"shape": {"sphere": 0.05}, "mass": 0.2}]).body
    across = 2 * 0.25 + 0.6 / 12 + 0.4 * 0.2 * 0.05**2  # points m d², the rod m L²/12, the sphere 2/5 m r²
    np.testing.assert_allclose(dumbbell.tensor(), np.diag([across, across, 0.4 * 0.2 * 0.05**2]), rtol=1e-14)


def test_a_geometry_runs_as_the_tensor_it_gives():
    geometry = body(shape={"box": [0.3, 0.2, 0.1]}, mass=2.0, pivot=[0.15, 0.1, 0.05])
    tensor = body(inertia_tensor=geometry.body.tensor().tolist(), mass=2.0, center_of_mass=list(geometry.body.centre()))
    a, b = rotlab.simulate(geometry, method="dop853"), rotlab.simulate(tensor, method="dop853")
    assert np.array_equal(a.omega, b.omega) and np.array_equal(a.quaternion, b.quaternion)
    np.testing.assert_array_equal(a.inertia, geometry.body.tensor())
    np.testing.assert_array_equal(a.center_of_mass, [-0.15, -0.1, -0.05])
    assert max(a.max_drift().values()) < 1e-9


@pytest.mark.parametrize("fields, key, words", [
    ({"shape": {"box": [0.3, 0.2, 0.1]}}, "body.mass", "a shape needs its mass"),
    ({"parts": [{"shape": {"sphere": 0.1}, "mass": 1.0}], "mass": 1.0}, "body.mass", "the parts carry their masses"),
    ({"shape": {"sphere": 0.1}, "mass": 1.0, "center_of_mass": [0, 0, 0.1]}, "body.center_of_mass", "computed from the shape"),
    ({"principal_moments": [1, 2, 2], "pivot": [0, 0, 1]}, "body.pivot", "pivot places the fixed point"),
    ({"shape": {"rod": 1.0}, "mass": 1.0}, "body.shape", "no inertia about an axis"),
    ({"shape": {"cube": 1.0}, "mass": 1.0}, "body.shape", "must be one of { box = [a, b, c] }"),
    ({"shape": {"box": [1, 1, -1]}, "mass": 1.0}, "body.shape.box[2]", "must be > 0"),
    ({"principal_moments": [1, 2, 2], "shape": {"sphere": 1.0}, "mass": 1.0}, "body.shape", "give exactly one of"),
])
def test_bad_geometry_is_one_line_naming_the_key(fields, key, words):
    with pytest.raises(InputError) as caught:
        body(**fields)
    text = str(caught.value)
    assert key in text and words in text and "\n" not in text, text


def test_validate_shows_what_was_computed(cli, write):
    write("box.toml", '[body]\nshape = { box = [0.3, 0.2, 0.1] }\nmass = 2.0\npivot = [0.15, 0.1, 0.05]\n[time]\nend = 1.0\n')
    result = cli("validate", "box.toml")
    assert result.exit_code == 0, result.output
    assert "body from its shape: mass 2 kg, centre of mass [-0.15, -0.1 , -0.05] m from the fixed point" in result.stdout
    assert "0.033333, -0.03" in result.stdout


def test_the_recording_draws_the_body_as_its_shape(tmp_path, cli):
    from rotlab.recording.reader import read_static

    traj = rotlab.simulate(body(shape={"box": [0.3, 0.2, 0.1]}, mass=2.0, pivot=[0.15, 0.1, 0.05]))
    rotlab.save(tmp_path / "box.rrd", traj)
    np.testing.assert_allclose(read_static(tmp_path / "box.rrd", "/world/body/shape/box", "Boxes3D:half_sizes"), [[0.15, 0.1, 0.05]])
    np.testing.assert_allclose(read_static(tmp_path / "box.rrd", "/world/body/shape/box", "Boxes3D:centers"), [[-0.15, -0.1, -0.05]])
    with pytest.raises(KeyError):  # no equivalent ellipsoid drawn over it
        read_static(tmp_path / "box.rrd", "/world/body/shape", "Ellipsoids3D:half_sizes")
    result = cli("animate", str(tmp_path / "box.rrd"), "-o", "box.gif", "--fps", "2", "--speed", "4")  # its ellipsoid from /scenario
    assert result.exit_code == 0 and (tmp_path / "box.gif").stat().st_size > 0, result.output
