"""What an event costs a run, side by side in one process, for each method (``rotlab.events``):
the same run without events; with an event that never occurs (``omega[1] + 1000``: only the
check of every sample); with the flip (``omega[1]`` falling: the check and the location of each
occurrence by Brent's method on the method's own local solution); with a Poincaré section (the
flip recording two values).

    python benchmarks/bench_events.py [--repeats 7] [--end 200] [--cases 128] [--lyapunov-only]

Problem: configs/dzhanibekov.toml over ``--end`` seconds at 200 samples/s (40,001 samples and 33
falling flips at 200 s).  Columns: the plain run (median of ``--repeats`` runs, interleaved with
the others), its time per step (per sample for ``exact``), samples per step, the check's cost
(never − plain) per sample and as a fraction of the plain run, the location's cost per occurrence
((flip − never) / occurrences), and the section's whole overhead.  The target (issue 35): an event
on a formula ≤ 15 % of a plain step.

Then the same events in the ensemble kernels (``rotlab.ensemble``: found inside the kernel as each
case's samples are made): ``--cases`` cases of configs/sweep_flip.toml (20 s, 4,001 samples, ω₀
dispersed by ±0.05 rad/s) in one call on every thread numba has, without events, with ``never``
and with the flip; per-case time (median of ``--repeats`` calls, interleaved) and the overheads.

Then what a Lyapunov exponent costs (``rotlab.lyapunov``: two local solutions of the method per
sample interval) against the plain run of the same scenario, configs/chaotic_top.toml (600 s, 50
samples/s) and configs/lagrange.toml (10 s, 200 samples/s), medians of ``--repeats``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import rotlab
from rotlab.api import run_scene
from rotlab.scene.scene import build_scene

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
NEVER = {"name": "never", "when": "omega[1] + 1000"}
FLIP = {"name": "flip", "when": "omega[1]", "direction": "falling"}
SECTION = {"name": "section", "when": "omega[1]", "direction": "falling", "record": ["omega[0]", "omega[2]"]}
METHODS = {"rk4": {"solver.step": 1e-3}, "splitting": {"solver.step": 1e-3}, "dmv": {}, "rkmk4": {"solver.step": 1e-3},
           "dop853": {}, "taylor": {}, "exact": {}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--end", type=float, default=200.0)
    parser.add_argument("--cases", type=int, default=128)
    parser.add_argument("--lyapunov-only", action="store_true", help="only the last table: what a Lyapunov exponent costs")
    args = parser.parse_args()
    if args.lyapunov_only:
        lyapunov_cost(max(3, args.repeats // 2))
        return
    print(f"dzhanibekov.toml, {args.end:g} s at 200 samples/s; median of {args.repeats} runs each, interleaved\n")
    print("| method | steps | plain run (ms) | per step (ns) | samples per step | check per sample (ns) | check / plain run "
          "| location per occurrence (µs) | + section, whole |")
    print("|---|---|---|---|---|---|---|---|---|")
    for method, settings in METHODS.items():
        scenes = {}
        for label, events in (("plain", []), ("never", [NEVER]), ("flip", [FLIP]), ("section", [SECTION])):
            scenario = rotlab.load(CONFIGS / "dzhanibekov.toml", method=method,
                                   overrides={**settings, "time.end": args.end, "events": events})
            scenes[label] = build_scene(scenario)
            run_scene(scenes[label])  # compile / load the kernels and the formulas
        seconds: dict[str, list[float]] = {label: [] for label in scenes}
        for _ in range(args.repeats):
            for label, scene in scenes.items():
                started = time.perf_counter()
                traj = run_scene(scene)
                seconds[label].append(time.perf_counter() - started)
                if label == "flip":
                    count = traj.events["flip"].count
                if label == "plain":
                    steps, samples = traj.stats.steps or traj.t.shape[0], traj.t.shape[0]
        plain, never, flip, section = (float(np.median(seconds[k])) for k in ("plain", "never", "flip", "section"))
        print(f"| {method} | {steps:,} | {plain * 1e3:.2f} | {plain / steps * 1e9:.0f} | {samples / steps:.2g} | {(never - plain) / samples * 1e9:.0f} "
              f"| {100 * (never - plain) / plain:+.1f} % | {(flip - never) / count * 1e6:.0f} | {100 * (section - plain) / plain:+.1f} % |")
    print()
    check_alone(max(9, args.repeats))
    ensemble_cost(args.cases, args.repeats)
    lyapunov_cost(max(3, args.repeats // 2))


def check_alone(repeats: int) -> None:
    """The check by itself (``EventWatch.rows`` on the 40,001 samples of a run, no stepping): a
    formula of ω only (Λ, γ and L not formed) and one that reads γ."""
    from rotlab.events import EventWatch, compile_events

    for when in ("omega[1] + 1000", "gamma[2] + 1000"):
        scene = build_scene(rotlab.load(CONFIGS / "dzhanibekov.toml", overrides={"time.end": 200.0,
                                                                                  "events": [{"name": "never", "when": when}]}))
        traj = run_scene(scene)
        states, t = np.ascontiguousarray(traj._state), traj.t
        compiled = compile_events(scene)
        seconds = []
        for _ in range(repeats):
            watch = EventWatch(compiled, lambda: None)
            started = time.perf_counter()
            watch.rows(0, t, states)
            seconds.append(time.perf_counter() - started)
        print(f"check alone, when = \"{when}\": {np.median(seconds) / t.shape[0] * 1e9:.1f} ns a sample (median of {repeats})")


def ensemble_cost(cases: int, repeats: int) -> None:
    import numba

    from rotlab.ensemble.block import run_block
    from rotlab.methods.base import Settings
    from rotlab.methods.registry import get_method

    print(f"ensemble kernels: {cases} cases of sweep_flip.toml a call, {numba.get_num_threads()} threads; median of {repeats} calls each, "
          "interleaved\n")
    print("| method | plain (ms/case) | + never | + flip | flips a case | location per occurrence (µs, thread time) |")
    print("|---|---|---|---|---|---|")
    rng = np.random.default_rng(1)
    spread = rng.uniform(-0.05, 0.05, size=(cases, 3))
    for method, settings in (("rk4", {"solver.step": 1e-3}), ("dop853", {})):
        blocks = {}
        for label, events in (("plain", []), ("never", [NEVER]), ("flip", [FLIP])):
            scenes = [build_scene(rotlab.load(CONFIGS / "sweep_flip.toml", method=method, overrides={
                **settings, "events": events, "initial.omega": [float(w) for w in np.array([0.01, 10.0, 0.01]) + dw]})) for dw in spread]
            t, m = scenes[0].scenario.time.sample_times(), get_method(method)
            run = (lambda scenes=scenes, t=t, m=m: run_block(scenes, m, Settings.of(scenes[0].scenario.solver), t, [], 1, [None] * cases))
            run()  # compile / load the kernels
            blocks[label] = run
        seconds: dict[str, list[float]] = {label: [] for label in blocks}
        for _ in range(repeats):
            for label, run in blocks.items():
                started = time.perf_counter()
                result = run()
                seconds[label].append(time.perf_counter() - started)
                if label == "flip":
                    flips = float(np.mean(result.events["event_flip_count"]))
        plain, never, flip = (float(np.median(seconds[k])) / cases for k in ("plain", "never", "flip"))
        print(f"| {method} | {plain * 1e3:.3f} | {100 * (never - plain) / plain:+.1f} % | {100 * (flip - plain) / plain:+.1f} % | {flips:.1f} "
              f"| {(flip - never) / flips * numba.get_num_threads() * 1e6:.0f} |")
    print()


def lyapunov_cost(repeats: int) -> None:
    print("\n| scenario | method | samples | plain run (ms) | lyapunov (ms) | ratio | per sample interval (µs) |")
    print("|---|---|---|---|---|---|---|")
    for name in ("chaotic_top", "lagrange"):
        scenario = rotlab.load(CONFIGS / f"{name}.toml")
        scene = build_scene(scenario)
        traj = run_scene(scene)
        rotlab.lyapunov(scenario, duration=1.0)
        plain, measured = [], []
        for _ in range(repeats):
            started = time.perf_counter()
            run_scene(scene)
            plain.append(time.perf_counter() - started)
            started = time.perf_counter()
            rotlab.lyapunov(scenario)
            measured.append(time.perf_counter() - started)
        a, b, n = float(np.median(plain)), float(np.median(measured)), traj.t.shape[0]
        print(f"| {name} | {traj.stats.method} | {n:,} | {a * 1e3:.1f} | {b * 1e3:.1f} | {b / a:.1f} | {b / (n - 1) * 1e6:.1f} |")


if __name__ == "__main__":
    main()
