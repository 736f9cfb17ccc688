"""Ensemble throughput: body-steps per second of the parallel RK4 ensemble kernel on the free
body, against the single-body kernel in a loop (same work, one run).

    python benchmarks/bench_ensemble.py [--bodies 2000] [--steps 2000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from rotlab.config import parse_scenario
from rotlab.core.ensemble import rk4_ensemble
from rotlab.core.rk4 import rk4_advance
from rotlab.scene.scene import build_scene


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--bodies", type=int, default=2000)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()

    scene = build_scene(parse_scenario({"body": {"principal_moments": [1.0, 2.0, 2.5]}, "time": {"end": 1.0}}))
    model = scene.model
    rng = np.random.default_rng(0)
    y0 = np.zeros((args.bodies, 8))
    y0[:, 0] = 1.0
    y0[:, 4:7] = rng.normal(size=(args.bodies, 3))
    samples = 11
    times = np.linspace(0.0, 1.0, samples)
    substeps = args.steps // (samples - 1)
    out = np.empty((args.bodies, samples, 8))
    status = np.zeros(args.bodies, dtype=np.int64)
    valid = np.zeros(args.bodies, dtype=np.int64)
    body_steps = args.bodies * substeps * (samples - 1)

    def ensemble():
        rk4_ensemble(y0, times, out, substeps, 10**12, model, status, valid)

    def serial():
        for b in range(args.bodies):
            y = y0[b].copy()
            rk4_advance(y, times, out[b], 1, substeps, 10**12, model)

    rows = []
    for name, fn in (("rk4 ensemble (prange)", ensemble), ("rk4 single-body kernel, Python loop", serial)):
        fn()
        times_s = []
        for _ in range(args.repeats):
            started = time.perf_counter()
            fn()
            times_s.append(time.perf_counter() - started)
        rows.append((name, float(np.median(times_s))))
    print(f"free body, {args.bodies:,} bodies × {substeps * (samples - 1):,} steps = {body_steps:,} body-steps; "
          f"numba threads: {numba.get_num_threads()}")
    print(f"{'kernel':40} {'median s':>10} {'M body-steps/s':>16}")
    for name, sec in rows:
        print(f"{name:40} {sec:10.4f} {body_steps / sec / 1e6:16.1f}")
    print(f"ensemble speed-up over the serial loop: {rows[1][1] / rows[0][1]:.2f}x   (target ≥ 20 M body-steps/s)")


if __name__ == "__main__":
    main()
