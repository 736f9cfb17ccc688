"""The observables an ensemble reduces as a case runs (``rotlab.ensemble.observe``): ns a sample
on the CPU, the CPU's blocked pass (``_fold_blocks``: a block of rows copied into columns, the
per-sample values in passes that LLVM vectorises) against the GPU's loop over samples
(``_fold_samples``, run here on the CPU), side by side, on shipped scenes.

    python benchmarks/bench_observables.py [--repeats 15] [--samples 40001]

Each scene is run by dop853 over as long as gives ``--samples`` samples; the rows are folded whole,
ten times per round, the two ways alternating; the table gives the medians of the rounds (ns a
sample), the median of the rounds' own ratios, and whether the two folds agree bit for bit.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import rotlab
from rotlab.config.loader import load_scenario
from rotlab.ensemble import observe as ob
from rotlab.ensemble.block import case_inputs, shared_inputs
from rotlab.scene.scene import build_scene

SCENES = ("dzhanibekov", "gyrostat", "lagrange", "general")  # free body; rotors' h; a force, every invariant; several loads
CALLS = 10  # folds of the whole run per timing


def opening() -> tuple:
    """The folds' state before a case's first sample (``observe_rows`` with ``first``)."""
    return (0.0, math.nan, math.nan, 1.0, 0.0, 0.0) + (0.0,) * len(ob.INVARIANTS)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--samples", type=int, default=40001)
    args = parser.parse_args()
    print(f"{'scene':14s} {'samples':>8s} {'forces':>6s} {'blocks ns':>10s} {'samples ns':>11s} {'ratio':>6s}  bit for bit")
    for name in SCENES:
        scenario = load_scenario(f"configs/{name}.toml")
        rate = (scenario.time.sample_count - 1) / (scenario.time.end - scenario.time.start)
        scenario = load_scenario(f"configs/{name}.toml", duration=(args.samples - 1) / rate)
        scene = build_scene(scenario)
        rows = np.ascontiguousarray(rotlab.simulate(scenario, method="dop853", check=False)._state[:, :8])
        times = scenario.time.sample_times()
        shared, applies, forces = shared_inputs(scene)
        k = ob.constants_of(case_inputs([scene], [None])[0], shared, applies)
        n = rows.shape[0]
        folds = {fold: fold(times, rows, 0, n, True, k, forces, opening()) for fold in (ob._fold_blocks, ob._fold_samples)}
        same = np.array_equal(np.array(folds[ob._fold_blocks]), np.array(folds[ob._fold_samples]), equal_nan=True)
        timings: dict = {fold: [] for fold in folds}
        for _ in range(args.repeats):
            for fold in folds:
                started = time.perf_counter()
                for _ in range(CALLS):
                    fold(times, rows, 0, n, True, k, forces, opening())
                timings[fold].append((time.perf_counter() - started) / CALLS / n * 1e9)
        blocks, samples = np.array(timings[ob._fold_blocks]), np.array(timings[ob._fold_samples])
        print(f"{name:14s} {n:8d} {forces.shape[0]:6d} {np.median(blocks):10.2f} {np.median(samples):11.2f} "
              f"{np.median(blocks / samples):6.3f}  {'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
