"""Every load kind is declared once (``rotlab.scene.load_kinds``) and reaches every method.

A kind left out of the declarations would compile to nothing: the scene would run torque-free and
say nothing.  Here each kind of the config's union runs through every method of the catalog: a
method that takes the scene must move ω as dop853 at rtol 1e-12 does (bound 1e-6 of |ω|, the
methods at rtol 1e-9; the load must move ω by more than 1e-3 of |ω| over the run, so a dropped
load fails), and one that does not take it refuses in one line that names it.
"""

from __future__ import annotations

import numpy as np
import pytest

import rotlab
from rotlab.config import models as cfg
from rotlab.errors import InputError
from rotlab.methods.registry import METHODS
from rotlab.scene import load_kinds
from rotlab.scene.scene import build_scene
from tests.helpers import scenario

BODY = {"principal_moments": [1.0, 1.5, 2.0], "mass": 2.0, "center_of_mass": [0.05, 0.1, 0.3], "allow_triangle_violation": True}
INITIAL = {"omega": [1.0, 0.5, 6.0], "euler_313": [0.0, 0.5, 0.0]}
EXAMPLES = {  # one load of each kind, strong enough to move ω over the run
    "gravity": {"type": "gravity"},
    "torque": {"type": "torque", "frame": "space", "value": [0.3, -0.2, 0.5], "window": {"on": 0.1, "off": 0.35}},
    "force": {"type": "force", "frame": "body", "value": [0.0, 3.0, -2.0], "point": [0.2, 0.0, 0.3]},
    "harmonic_torque": {"type": "harmonic_torque", "frame": "body", "amplitude": [0.4, 0.2, 0.0], "angular_frequency": 3.0, "phase": 0.2},
    "torque_table": {"type": "torque_table", "frame": "space", "times": [0.0, 0.2, 0.4], "values": [[0, 0, 0], [0.5, 0.2, 0], [0, 0, 0.3]]},
    "damping": {"type": "damping", "coefficient": 0.2},
    "expression": {"type": "expression", "frame": "body", "torque": ["-0.3*omega[0]", "0.4*sin(3*t)", "0.5*gamma[0]"]},
    "pd_control": {"type": "pd_control", "kp": 2.0, "kd": 0.3},  # target: the attitude halfway (``_example``)
    "gravity_gradient": {"type": "gravity_gradient", "orbit_rate": 2.0},
    "quadratic_drag": {"type": "quadratic_drag", "coefficient": 0.05},
    # Earth's field is ~3e-5 T: a field of 1 T (the model's B₀) and strong torquers move ω within the short run
    "magnetic_dipole": {"type": "magnetic_dipole", "dipole": [0.5, -0.3, 0.4], "field": 1.0, "altitude": 1e6, "inclination_deg": 60.0},
    "bdot_detumbling": {"type": "bdot_detumbling", "gain": 2.0, "max_dipole": 0.6, "field": 1.0, "altitude": 1e6},
}
TIME = {"end": 0.5, "samples": 11}


def _scenario(load: dict | None, method: str, rtol: float = 1e-9):
    return scenario(body=BODY, initial=INITIAL, loads=[] if load is None else [load], time=TIME,
                    solver={"method": method, "rtol": rtol, "atol": rtol * 1e-2})


def test_every_config_load_kind_has_one_declaration_and_an_example():
    assert set(load_kinds.KINDS) == set(cfg.LOAD_KINDS)
    assert set(EXAMPLES) == set(cfg.LOAD_MODELS)


def test_a_config_load_kind_without_a_declaration_is_an_error_at_import(monkeypatch):
    class Thruster(cfg.Torque):
        pass

    monkeypatch.setattr(cfg, "LOAD_KINDS", (*cfg.LOAD_KINDS, Thruster))
    with pytest.raises(TypeError, match="no LoadKind for Thruster"):
        load_kinds._check_complete()


def _example(kind: str) -> dict:
    """EXAMPLES[kind]; pd_control's target is the free body's attitude at mid-run, so that the
    sign of δ₀ does not switch during the run (a fixed step would cross the switch at low order)."""
    if kind != "pd_control":
        return EXAMPLES[kind]
    free = rotlab.simulate(_scenario(None, "exact"))
    return {**EXAMPLES[kind], "target": free.quaternion[free.t.shape[0] // 2].tolist()}


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
def test_every_load_kind_runs_in_every_method_that_takes_it(kind):
    load = _example(kind)
    reference = rotlab.simulate(_scenario(load, "dop853", 1e-12))
    free = rotlab.simulate(_scenario(None, "dop853", 1e-12))
    scale = float(np.max(np.linalg.norm(reference.omega, axis=1)))
    assert np.max(np.abs(reference.omega - free.omega)) > 1e-3 * scale  # the load acts
    ran = []
    for method in METHODS:
        sc = _scenario(load, method)
        try:
            traj = rotlab.simulate(sc)
        except InputError as refusal:
            assert "\n" not in str(refusal) and f"'{method}' cannot run this scene" in str(refusal)
            continue
        assert np.max(np.abs(traj.omega - reference.omega)) <= 1e-6 * scale, method
        ran.append(method)
    assert {"dop853", "rk4", "rkmk4"} <= set(ran)  # the general-purpose methods take every kind


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
def test_every_load_kind_is_drawn_with_the_kernels_torque(kind):
    """The recording's view of the load is the kernels' torque of the load (not zero: not dropped)."""
    from rotlab.core.torques import torque_samples
    from rotlab.recording import loads_view

    scene = build_scene(_scenario(_example(kind), "dop853"))
    (view,) = loads_view.load_views(scene)
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 0.5, 50)
    q = rng.standard_normal((50, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.standard_normal((50, 3))
    drawn = loads_view.torques(scene, view, t, q, w)
    whole = np.empty_like(drawn)
    torque_samples(t, q, w, scene.model, whole)
    np.testing.assert_array_equal(drawn, whole)
    assert np.count_nonzero(np.any(drawn != 0.0, axis=1)) > 5


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
def test_every_load_kinds_work_is_counted(kind):
    """H = T + V − W stays at H₀ (dop853 at rtol 1e-12: bound 1e-8 of the energy scale) with each
    kind alone; where the kind does work, T + V moves by more than 1e-3 of that scale, so a work
    rate the kernels dropped (W ≡ 0: the compiled right-hand side skips it for scenes without a
    load that does work, ``torques.WORKLESS_FIELDS``) breaks the bound by far."""
    traj = rotlab.simulate(_scenario(_example(kind), "dop853", 1e-12))
    potential0 = traj.potential[0] if traj.potential is not None else 0.0
    scale = max(abs(traj.total[0]), traj.kinetic[0] + abs(potential0))  # (invariants' energy scale; W₀ = 0)
    assert np.max(np.abs(traj.invariants["energy"])) <= 1e-8
    moved = np.max(np.abs(traj.total - traj.total[0])) / scale
    if traj.work is None:  # conservative: a potential, or no torque's work at all
        assert kind in ("gravity", "gravity_gradient") or moved <= 1e-8, kind
    else:
        assert moved > 1e-3 and np.max(np.abs(traj.work)) > 1e-3 * scale, kind
