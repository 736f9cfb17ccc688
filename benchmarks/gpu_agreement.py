"""The GPU's ensemble against the CPU's, case by case, on shipped scenes (``run_block`` on both
devices, the GPU's own cross-check off): where they agree bit for bit, and where not, how far and
from which sample.

    python benchmarks/gpu_agreement.py [--cases 64] [--scale 1.0] [--only dop853 ...]
    NUMBA_ENABLE_CUDASIM=1 python benchmarks/gpu_agreement.py --cases 3 --scale 0.02   # without a GPU

Needs the whole of rotlab (its configuration reads the scenes), unlike ``bench_gpu.py``.  Each run:
``--cases`` cases of a shipped config with ω₀ dispersed by 0.05 rad/s (deg/s where the config gives it in degrees; seed 7), ended at its end
time × ``--scale``, every case's samples kept (every sample of cases 0 and 1 compared in full).
Columns: the fields of ``BlockResult`` that differ (events' columns included; none: bit for bit), the largest relative
difference of the last valid states (``cross_check.relative_difference``), the first sample at
which case 0's states differ.
"""

from __future__ import annotations

import argparse
import copy
import time
from pathlib import Path

import numpy as np

from rotlab.config.loader import parse_scenario, read_toml
from rotlab.ensemble.block import run_block
from rotlab.ensemble.cross_check import relative_difference
from rotlab.methods.base import Settings
from rotlab.methods.registry import get_method
from rotlab.scene.scene import build_scene

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
GRAVITY_AND = ("gravity",)
# the flip's events: ω_y through 0 downward, where the spin's direction is recorded (a library function, atan2), and |Λ₀| through ½
FLIP_EVENTS = [{"name": "flip", "when": "omega[1]", "direction": "falling", "record": ["atan2(omega[0], omega[2])"]},
               {"name": "half", "when": "q[0]*q[0] - 0.5"}]
# (config, end s, method, solver changes, the load types kept: None for all[, events])
RUNS = [("sweep_flip.toml", 20.0, "dop853", {}, None), ("lagrange.toml", 2.0, "dop853", {}, None),
        ("gyrostat.toml", 4.0, "dop853", {}, None), ("general.toml", 2.0, "dop853", {}, None),
        ("general.toml", 10.0, "dop853", {}, None), ("general.toml", 10.0, "dop853", {}, GRAVITY_AND),
        ("general.toml", 10.0, "dop853", {}, GRAVITY_AND + ("damping",)), ("general.toml", 10.0, "dop853", {}, GRAVITY_AND + ("torque",)),
        ("general.toml", 10.0, "dop853", {}, GRAVITY_AND + ("torque_table",)),
        ("sweep_flip.toml", 20.0, "rk4", {"step": 1e-3}, None), ("sweep_flip.toml", 20.0, "dmv", {"step": 5e-3, "order": 8}, None),
        ("lagrange.toml", 2.0, "rk4", {"step": 1e-4}, None), ("general.toml", 10.0, "rk4", {"step": 1e-3}, None),
        ("general.toml", 10.0, "rkmk4", {"step": 1e-3}, None), ("gyrostat.toml", 4.0, "rk4", {"step": 1e-2}, None),
        ("detumbling.toml", 600.0, "dop853", {}, None), ("detumbling.toml", 600.0, "rk4", {"step": 0.05}, None),  # a formula load
        ("sweep_flip.toml", 20.0, "dop853", {}, None, FLIP_EVENTS), ("sweep_flip.toml", 20.0, "rk4", {"step": 1e-3}, None, FLIP_EVENTS)]
FIELDS = ("status", "valid", "steps", "rejected", "evaluations", "last", "flip_period", "reversals", "max_nutation_deg")


def scenes_of(config: str, end: float, method: str, changes: dict, loads: tuple[str, ...] | None, cases: int, events: list | None = None) -> list:
    raw = read_toml(CONFIGS / config)
    raw.pop("sweep", None)
    if events is not None:
        raw["events"] = events
    raw["time"]["end"] = end
    if loads is not None:
        raw["loads"] = [load for load in raw.get("loads", []) if load["type"] in loads]
    raw["solver"] = {**{k: v for k, v in raw.get("solver", {}).items() if k in ("rtol", "atol")}, "method": method, **changes}
    rng = np.random.default_rng(7)
    scenes = []
    for _ in range(cases):
        case = copy.deepcopy(raw)
        key = "omega" if "omega" in raw["initial"] else "omega_deg"
        case["initial"][key] = [float(w + 0.05 * rng.normal()) for w in raw["initial"][key]]
        scenes.append(build_scene(parse_scenario(case, source=config)))
    return scenes


def last_states_apart(gpu: np.ndarray, cpu: np.ndarray) -> float:
    """The cross-check's relative difference of the last states, over all cases, relative to the
    largest finite component of the CPU's."""
    finite = np.abs(cpu[np.isfinite(cpu)])
    return relative_difference(gpu, cpu, float(np.max(finite, initial=0.0)))


def compare(config: str, end: float, method: str, changes: dict, loads, cases: int, events: list | None = None) -> None:
    started = time.perf_counter()
    scenes = scenes_of(config, end, method, changes, loads, cases, events)
    t = scenes[0].scenario.time.sample_times()
    args = (scenes, get_method(method), Settings.of(scenes[0].scenario.solver), t, list(range(min(2, cases))), 1, [None] * cases)
    cpu, gpu = run_block(*args), run_block(*args, device="cuda", cross_check=False)
    differ = [f for f in FIELDS if not np.array_equal(getattr(cpu, f), getattr(gpu, f), equal_nan=True)]
    differ += [f"{k} drift" for k in cpu.max_drift if not np.array_equal(cpu.max_drift[k], gpu.max_drift[k], equal_nan=True)]
    differ += [k for k in cpu.events if not np.array_equal(cpu.events[k], gpu.events[k], equal_nan=True)]
    kept_cpu, kept_gpu = cpu.kept[0][1], gpu.kept[0][1]
    rows = min(kept_cpu.shape[0], kept_gpu.shape[0])
    apart = np.flatnonzero(np.any(kept_cpu[:rows] != kept_gpu[:rows], axis=1))
    first = f"{apart[0]} (t = {t[apart[0]]:.6g} s)" if apart.size else ("—" if kept_cpu.shape == kept_gpu.shape else "lengths differ")
    loads_kept = ("all" if loads is None else ", ".join(loads)) + (f"; events {', '.join(e['name'] for e in events)}" if events else "")
    print(f"| {config} | {end:g} | {loads_kept} | {method} | {cases} | {t.shape[0]:,} | {', '.join(differ) or 'none'} | "
          f"{last_states_apart(gpu.last, cpu.last):.1e} | {first} | {time.perf_counter() - started:.0f} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=64)
    parser.add_argument("--scale", type=float, default=1.0, help="of each run's end time")
    parser.add_argument("--only", nargs="+", default=None, help="methods to run")
    args = parser.parse_args()
    print("| config | end s | loads | method | cases | samples | fields that differ | last states, max rel. diff | "
          "case 0's first differing sample | s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for config, end, method, changes, loads, *events in RUNS:
        if args.only is None or method in args.only:
            compare(config, end * args.scale, method, changes, loads, args.cases, *events)


if __name__ == "__main__":
    main()
