"""Cost of state-dependent loads: a built-in load vs the same load written as an expression
(generated code compiled once per formula set, ``rotlab.scene.formulas``; Taylor mode interpreted)
or as a Python ``torque=`` function (``rotlab.scene.user_torque``; taylor refuses it), and the
built-in kinds that compile to expressions, per step of rk4, dop853 and taylor; and what a NEW
formula, or a Python function, costs on a warm cache.

    python benchmarks/bench_loads.py [--repeats 5]

Integration time only (every kernel called once first); medians of repeats, all rows in one run.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from rotlab.config import parse_scenario
from rotlab.methods.base import Settings
from rotlab.methods.registry import get_method
from rotlab.scene.scene import build_scene

BODY = {"principal_moments": [2.0, 3.0, 4.0]}
LOADS = {
    "damping (built-in)": [{"type": "damping", "coefficient": 0.1}],
    "damping as expression": [{"type": "expression", "frame": "body", "constants": {"k": 0.1},
                               "torque": ["-k*omega[0]", "-k*omega[1]", "-k*omega[2]"]}],
    "quadratic_drag": [{"type": "quadratic_drag", "coefficient": 0.1}],
    "pd_control, saturated": [{"type": "pd_control", "target": [0.0, 0.0, 0.0, 1.0], "kp": 1.0, "kd": 1.0, "max_torque": 0.5}],
    "gravity_gradient": [{"type": "gravity_gradient", "orbit_rate": 1.0}],
    "magnetic_dipole": [{"type": "magnetic_dipole", "dipole": [0.1, -0.05, 0.2], "altitude": 500e3, "inclination_deg": 51.6}],
    "bdot_detumbling": [{"type": "bdot_detumbling", "gain": 2.0e5, "max_dipole": 0.2, "altitude": 500e3, "inclination_deg": 51.6}],
}
SETTINGS = {"rk4": Settings(step=1e-3, max_steps=10**12), "dop853": Settings(rtol=1e-10, atol=1e-12), "taylor": Settings(rtol=1e-10, atol=1e-12)}


def scene_of(loads, torque=None):
    return build_scene(parse_scenario({"body": BODY, "initial": {"omega": [0.5, -1.0, 0.8]}, "loads": loads,
                                       "time": {"end": 20.0, "samples": 201}}), torque=torque)


def damping_function(t, q, omega):
    """The damping row's load as a user's Python function."""
    return -0.1 * omega[0], -0.1 * omega[1], -0.1 * omega[2]


def ns_per_step(scene, name: str, repeats: int) -> tuple[float, int]:
    method = get_method(name)
    t = scene.scenario.time.sample_times()
    settings = SETTINGS[name]
    method.solve(scene, t, settings, None)  # compile or load from the cache
    times, steps = [], 0
    for _ in range(repeats):
        started = time.perf_counter()
        sol = method.solve(scene, t, settings, None)
        times.append(time.perf_counter() - started)
        steps = sol.steps + sol.rejected_steps
    return float(np.median(times)) / steps * 1e9, steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print(f"{'load':26} " + " ".join(f"{m + ' ns/step':>16} {'steps':>8}" for m in SETTINGS))
    base = {}
    for label, loads in LOADS.items():
        scene = scene_of(loads)
        cells = []
        for name in SETTINGS:
            ns, steps = ns_per_step(scene, name, args.repeats)
            base.setdefault(name, ns)
            cells.append(f"{ns:10.0f} ({ns / base[name]:3.1f}x) {steps:8,}")
        print(f"{label:26} " + " ".join(cells))
    started = time.perf_counter()
    scene = scene_of([], torque=damping_function)
    built = time.perf_counter() - started
    cells = []
    for name in ("rk4", "dop853"):
        ns, steps = ns_per_step(scene, name, args.repeats)
        cells.append(f"{ns:10.0f} ({ns / base[name]:3.1f}x) {steps:8,}")
    print(f"{'damping as Python torque=':26} " + " ".join(cells) + f" {'(refused)':>16}")
    started = time.perf_counter()
    scene_of([], torque=damping_function)
    print(f"Python torque: compiled in {built:.2f} s; the same function again: {time.perf_counter() - started:.4f} s")
    # a formula never seen before (an empty formula cache): its cfunc is compiled (then cached on
    # disk); the kernels are not.  The same formula with other constants reuses the function.
    os.environ["ROTLAB_CACHE"] = tempfile.mkdtemp(prefix="rotlab-bench-")
    formula = {"type": "expression", "frame": "space", "torque": ["c*sin(t)*gamma[0]", "tanh(omega[1])", "0.25*q[2]"]}
    started = time.perf_counter()
    fresh = scene_of([{**formula, "constants": {"c": 1.5}}])
    fresh.model
    print(f"new formula: its compiled function built in {time.perf_counter() - started:.2f} s")
    started = time.perf_counter()
    scene_of([{**formula, "constants": {"c": 1.7}}]).model  # (a number written in the text is part of the operations: only c changes)
    print(f"the same formula, other constants: its function reused in {time.perf_counter() - started:.3f} s")
    for name in SETTINGS:
        t = fresh.scenario.time.sample_times()
        started = time.perf_counter()
        get_method(name).solve(fresh, t, SETTINGS[name], None)
        print(f"new formula, first solve, {name}: {time.perf_counter() - started:.3f} s (kernels not recompiled)")

if __name__ == "__main__":
    main()
