"""Geometric integrators (splitting, dmv, rkmk4; rk4 for comparison): cost per step and accuracy.

    python benchmarks/bench_geometric.py [--repeats 5] [--steps 1000000]

1. ns per step on a free asymmetric body (kernel time only, compiled beforehand; median and
   min of repeats — on a shared machine the min is the better estimate of the cost; 1000 samples
   of ``steps/1000`` steps each).  Target: < 100 ns for 2nd-order methods.
2. Max error (|ω − ω_ref|, |Λ − Λ_ref| over 101 samples) against dop853 at rtol 1e-13 on the GNI
   free body: I = (2, 1, 2/3) (breaks the triangle inequality: a test problem), m0 = L0 =
   (cos 1.1, 0, sin 1.1), t ∈ [0, 100] (Hairer, Lubich & Wanner, "Geometric Numerical
   Integration", §VII.5), at a few step sizes; with the cost of the run and the energy drift.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import rotlab
from rotlab.config import parse_scenario
from rotlab.core.dmv import ORDERS, dmv_advance, modified_coefficients
from rotlab.core.rk4 import rk4_advance
from rotlab.core.rkmk4 import rkmk4_advance
from rotlab.core.splitting import splitting_advance
from rotlab.methods.stepping import initial_state
from rotlab.scene.scene import build_scene

GNI_MOMENTS = [2.0, 1.0, 2.0 / 3.0]


def gni_scenario(method: str, **solver) -> dict:
    m0 = np.array([np.cos(1.1), 0.0, np.sin(1.1)])
    return {
        "body": {"principal_moments": GNI_MOMENTS, "allow_triangle_violation": True},
        "initial": {"omega": (m0 / np.array(GNI_MOMENTS)).tolist()},
        "time": {"end": 100.0, "samples": 101},
        "solver": {"method": method, **solver},
    }


def kernels(scene):
    coefficients = modified_coefficients(scene.moments)
    rows = [("rk4", None, rk4_advance, ())]
    rows += [("splitting", p, splitting_advance, (p,)) for p in (2, 4, 6, 8)]
    rows += [("dmv", p, dmv_advance, (p, coefficients)) for p in ORDERS]
    rows += [("rkmk4", None, rkmk4_advance, ())]
    return rows


def ns_per_step(scene, kernel, extra, steps: int, repeats: int) -> tuple[float, float]:
    model = scene.model
    t = np.linspace(0.0, steps * 1e-3, 1001)  # h = 1e-3
    out = np.empty((t.size, 8))
    substeps = steps // 1000

    def run():
        y = initial_state(scene)
        kernel(y, t, out, 1, substeps, 10 * steps, model, *extra)

    run()  # compile (or load from the cache)
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        run()
        times.append(time.perf_counter() - started)
    scale = 1e9 / (substeps * 1000)
    return float(np.median(times)) * scale, float(np.min(times)) * scale


def errors(method: str, order: int | None, step: float, reference) -> tuple[float, float, float]:
    traj = rotlab.simulate(parse_scenario(gni_scenario(method, step=step, order=order)))
    dq = np.minimum(np.linalg.norm(traj.quaternion - reference.quaternion, axis=1), np.linalg.norm(traj.quaternion + reference.quaternion, axis=1))
    err = max(float(np.max(np.abs(traj.omega - reference.omega))), float(np.max(dq)))
    return err, float(np.max(np.abs(traj.invariants["energy"]))), float(np.max(np.abs(traj.invariants["quaternion_norm"])))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--steps", type=int, default=1_000_000)
    args = parser.parse_args()

    free = build_scene(
        parse_scenario({"body": {"principal_moments": [1.0, 1.6, 2.2]}, "initial": {"omega": [1.0, 0.5, 1.5]}, "time": {"end": 1.0}})
    )
    print(f"Cost per step, free asymmetric body, {args.steps:,} steps, median of {args.repeats} (kernel only)")
    print(f"{'method':10} {'order':>5} {'ns/step':>9} {'(min)':>9} {'target':>9}")
    for name, order, kernel, extra in kernels(free):
        median, best = ns_per_step(free, kernel, extra, args.steps, args.repeats)
        p = 4 if order is None else order
        target = "< 100" if p == 2 else ""
        print(f"{name:10} {p:>5} {median:9.1f} {best:9.1f} {target:>9}")

    reference = rotlab.simulate(parse_scenario(gni_scenario("dop853", rtol=1e-13, atol=1e-15)))
    print()
    print("GNI free body I = (2, 1, 2/3), m0 = (cos 1.1, 0, sin 1.1), t ≤ 100: max error vs dop853 (rtol 1e-13)")
    print(f"{'method':10} {'order':>5} {'h':>8} {'max error':>11} {'|ΔH|/H':>10} {'||Λ|-1|':>10}")
    for name, order in [("rk4", None), *[("splitting", p) for p in (2, 4, 6, 8)], *[("dmv", p) for p in ORDERS], ("rkmk4", None)]:
        for step in (0.2, 0.1, 0.05, 0.025, 0.0125):
            err, energy, norm = errors(name, order, step, reference)
            print(f"{name:10} {4 if order is None else order:>5} {step:8.4f} {err:11.3e} {energy:10.2e} {norm:10.2e}")
    print("(errors of ~3e-13 to 1e-12 are the reference's own: dop853 at rtol 1e-13 over t = 100)")


if __name__ == "__main__":
    main()
