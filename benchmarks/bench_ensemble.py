"""Ensemble throughput: every method with an ensemble kernel, many cases of one scene per call
(``rotlab.ensemble``, observables reduced as each case runs), on 1 and 2 threads, against the same
cases each solved alone (``Method.solve``, the single run's integration, without its report).

    python benchmarks/bench_ensemble.py [--cases 128] [--repeats 7] [--problems NAME]

Problems: the free body of configs/sweep_flip.toml (20 s at 200 samples/s, ω₀ dispersed as the
sweep disperses it), the heavy top of configs/lagrange.toml (10 s), and the free body with two
formula loads (``FORMULAS``: compiled expressions in the body and space frames), each case from
a perturbed ω₀.
Fixed-step methods at a given step (rk4, splitting, rkmk4: h = 1e-3 s on the free body, 1e-4 s on the
top; dmv at order 8, h = 5e-3 s), dop853 and taylor at the file's rtol.  Columns: per-case solve time alone
(median of the first 16 cases), the ensemble's per-case time on 1 and 2 threads (median of
``--repeats`` calls), their ratio to the solve alone, the 2-thread speed-up, body-steps/s and
cases/s on 2 threads.  States are bit-identical to the solve alone (tests/test_ensemble.py).
"""

from __future__ import annotations

import argparse
import copy
import time
from pathlib import Path

import numba
import numpy as np

from rotlab.config.loader import parse_scenario, read_toml
from rotlab.ensemble.block import run_block
from rotlab.methods.base import Settings
from rotlab.methods.registry import get_method
from rotlab.scene.scene import build_scene

ALONE = 16  # cases solved alone in each round
CONFIGS = Path(__file__).resolve().parents[1] / "configs"
FORMULAS = [{"type": "expression", "frame": "body", "constants": {"k": 2e-5},  # a damping in the body, a decaying push fixed in space
             "torque": ["-k*omega[0]", "-k*omega[1]*(1 + 0.5*sin(t))", "-k*omega[2]"]},
            {"type": "expression", "frame": "space", "torque": ["0", "1e-5*exp(-t)", "0"]}]
PROBLEMS = {  # name → (file, changes, spread of ω₀ (rad/s), per method: solver settings, sections added to the file)
    "free body (sweep_flip)": ("sweep_flip.toml", {}, 0.05, {
        "rk4": {"step": 1e-3}, "splitting": {"step": 1e-3}, "rkmk4": {"step": 1e-3}, "dmv": {"step": 5e-3, "order": 8},
        "dop853": {}, "taylor": {}}, {}),
    "heavy top (lagrange, 10 s)": ("lagrange.toml", {"end": 10.0}, 0.5, {
        "rk4": {"step": 1e-4}, "splitting": {"step": 1e-4}, "rkmk4": {"step": 1e-4}, "dop853": {}, "taylor": {}}, {}),
    "free body + 2 formula loads": ("sweep_flip.toml", {}, 0.05, {"rk4": {"step": 1e-3}, "dop853": {}, "taylor": {}}, {"loads": FORMULAS}),
}


def scenes_of(name: str, method: str, cases: int) -> list:
    file, changes, spread, settings, sections = PROBLEMS[name]
    raw = {**read_toml(CONFIGS / file), **sections}
    raw.pop("sweep", None)
    raw.pop("checks", None)
    raw["time"].update(changes)
    raw["solver"] = {"method": method, **{k: v for k, v in raw.get("solver", {}).items() if k in ("rtol", "atol")},
                     **settings[method]}
    rng = np.random.default_rng(1)
    scenes = []
    for _ in range(cases):
        case = copy.deepcopy(raw)
        case["initial"]["omega"] = [float(w + spread * rng.uniform(-1.0, 1.0)) for w in raw["initial"]["omega"]]
        scenes.append(build_scene(parse_scenario(case, source=file)))
    return scenes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=128)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--problems", default="", help="only the problems whose name contains this")
    args = parser.parse_args()
    threads = numba.get_num_threads()
    print(f"{args.cases} cases per ensemble call; numba threads available: {threads}")
    header = (f"{'problem':28} {'method':10} {'alone ms/case':>13} {'ens 1 thr':>10} {'ens 2 thr':>10} {'1 thr/alone':>11} "
              f"{'2 thr speed-up':>14} {'M body-steps/s':>14} {'cases/s':>9}")
    print(header)
    print("-" * len(header))
    for name, (_, _, _, methods, _) in PROBLEMS.items():
        if args.problems not in name:
            continue
        for method_name in methods:
            scenes = scenes_of(name, method_name, args.cases)
            method = get_method(method_name)
            settings = Settings.of(scenes[0].scenario.solver)
            t = scenes[0].scenario.time.sample_times()
            results = {}

            def alone() -> float:
                """Per-case seconds of the first ``ALONE`` cases (or fewer), each solved alone."""
                started = time.perf_counter()
                for scene in scenes[:ALONE]:
                    method.solve(scene, t, settings, None)
                return (time.perf_counter() - started) / len(scenes[:ALONE])

            def ensemble(n: int) -> float:
                """Per-case seconds of one ensemble call on ``n`` threads."""
                numba.set_num_threads(n)
                started = time.perf_counter()
                results["block"] = run_block(scenes, method, settings, t, [], 1, [None] * len(scenes))
                return (time.perf_counter() - started) / len(scenes)

            two_threads = min(2, threads)
            alone(), ensemble(1), ensemble(two_threads)  # (compiled, or loaded from the cache, before the timing)
            rounds = np.array([(alone(), ensemble(1), ensemble(two_threads)) for _ in range(args.repeats)])  # side by side
            numba.set_num_threads(threads)
            per_case_alone, one, two = np.median(rounds, axis=0)
            versus_alone = float(np.median(rounds[:, 1] / rounds[:, 0]))
            speed_up = float(np.median(rounds[:, 1] / rounds[:, 2]))
            steps = int(np.sum(results["block"].steps))
            print(f"{name:28} {method_name:10} {1e3 * per_case_alone:13.3f} {1e3 * one:10.3f} {1e3 * two:10.3f} "
                  f"{versus_alone:11.2f} {speed_up:14.2f} "
                  f"{steps / (two * len(scenes)) / 1e6:14.1f} {1.0 / two:9.0f}")


if __name__ == "__main__":
    main()
