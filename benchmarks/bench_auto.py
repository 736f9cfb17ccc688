"""``auto`` through the public API, each case in a fresh process, against rotlab's own ``dop853``
(which runs at the speed of a compiled C++ DOP853 per evaluation: docs/benchmarks.md) at equal
max error ≤ 1e-10, on the bench's free body (GNI) and heavy top.

    python benchmarks/bench_auto.py [--repeats 20] [--target 1e-10]

For each problem and each of ``auto`` and ``dop853``, the loosest rtol of a ladder (1e-8 … 1e-14)
whose run has max state error ≤ ``--target`` against the reference (GNI: the exact solution;
heavy top: dop853 at rtol 1e-15, atol 1e-17; the metric of ``rotlab.bench.problems.state_error``)
is timed in a new process: ``rotlab.simulate(scenario)`` once (the first call: kernel loads
included) and then ``--repeats`` times (minimum and median).  The ratio is dop853's minimum over
auto's, both from the same run of this script.  ``auto``'s choice is printed with its figures.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

CHILD = r"""
import json, sys, time
import rotlab
from rotlab.config import parse_scenario
data, method, rtol, repeats = json.loads(sys.argv[1]), sys.argv[2], float(sys.argv[3]), int(sys.argv[4])
data = {**data, "solver": {"method": method, "rtol": rtol, "atol": rtol * 1e-2}}
scenario = parse_scenario(data, source="bench")
started = time.perf_counter()
traj = rotlab.simulate(scenario)
first = time.perf_counter() - started
times = []
for _ in range(repeats):
    started = time.perf_counter()
    rotlab.simulate(scenario)
    times.append(time.perf_counter() - started)
times = sorted(times) or [first]
print(json.dumps({"first": first, "min": times[0], "median": times[len(times) // 2], "method": traj.stats.method,
                  "reason": traj.stats.reason, "state": traj._state[:, :7].tolist()}))
"""

LADDER = (1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14)


def _child(data: dict, method: str, rtol: float, repeats: int) -> dict:
    done = subprocess.run([sys.executable, "-c", CHILD, json.dumps(data), method, repr(rtol), str(repeats)],
                          capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    import numpy as np

    from rotlab.bench.problems import get_problems, reference_solution, state_error
    from rotlab.scene.scene import build_scene

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--target", type=float, default=1e-10)
    args = parser.parse_args()
    print("| problem | method | rtol | max error | runs | first call (ms) | min (ms) | median (ms) | dop853 min / auto min |")
    print("|---|---|---:|---:|---|---:|---:|---:|---:|")
    for problem in get_problems(["gni", "heavy-top"]):
        scenario = problem.scenario()
        scene = build_scene(scenario)
        t = scenario.time.sample_times()
        if problem.reference == "none":
            from rotlab.methods.base import Settings
            from rotlab.methods.registry import get_method

            ref = get_method("dop853").solve(scene, t, Settings(rtol=1e-15, atol=1e-17, max_steps=10**10), None).state[:, :7]
        else:
            ref = reference_solution(problem, scene, t).state
        best = {}
        for method in ("auto", "dop853"):
            for rtol in LADDER:
                probe = _child(problem.data, method, rtol, 0)
                error = state_error(np.array(probe["state"]), ref)[0]
                if error <= args.target:
                    best[method] = (rtol, error, _child(problem.data, method, rtol, args.repeats))
                    break
        for method, (rtol, error, timing) in best.items():
            ratio = best["dop853"][2]["min"] / timing["min"] if method == "auto" and "dop853" in best else None
            runs = timing["method"] + ("" if method == "dop853" else f" ({timing['reason'].split(':')[1].split(',')[0].strip()})")
            print(f"| {problem.name} | {method} | {rtol:.0e} | {error:.2g} | {runs} | {timing['first'] * 1e3:.1f} | {timing['min'] * 1e3:.3f} | "
                  f"{timing['median'] * 1e3:.3f} | {'' if ratio is None else f'{ratio:.2f}×'} |", flush=True)


if __name__ == "__main__":
    main()
