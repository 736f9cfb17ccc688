"""Core throughput: compiled RK4/DOP853 steps and recording rows per second.

    python benchmarks/bench_core.py [--repeats 7]

Integration time only (compile time measured separately, on the first call); medians of repeats,
all rows measured in one run so that ratios are comparable on a shared machine.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import rotlab
from rotlab.core import dop853, rk4
from rotlab.methods.stepping import initial_state
from rotlab.recording.writer import write_recording
from rotlab.scene.scene import build_scene

ROOT = Path(__file__).resolve().parents[1]


def median_seconds(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        fn()
        times.append(time.perf_counter() - started)
    return float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()

    scene = build_scene(rotlab.load(ROOT / "configs" / "lagrange.toml"))
    model = scene.model
    rows = []

    # RK4: 10^6 steps of the Lagrange top (1000 samples × 1000 steps)
    n_steps = 1_000_000
    t = np.linspace(0.0, 10.0, 1001)
    out = np.empty((t.size, 8))

    def rk4_run():
        y = initial_state(scene)
        rk4.rk4_advance(y, t, out, 1, 1000, n_steps, model)

    started = time.perf_counter()
    rk4_run()
    first = time.perf_counter() - started
    sec = median_seconds(rk4_run, args.repeats)
    rows.append(("rk4, Lagrange top", f"{n_steps:,} steps", sec, f"{sec / n_steps * 1e9:.0f} ns/step", first - sec, "< 0.1 s"))

    # DOP853: Lagrange top, rtol 1e-10, 10 s
    counters = np.zeros(3, dtype=np.int64)

    def dop_run():
        y = initial_state(scene)
        counters[:] = 0
        dop853.dop853_advance(y, 0.0, 0.0, t, out, 1, 10.0, 1e-10, 1e-12, 10**9, model, counters)

    started = time.perf_counter()
    dop_run()
    first = time.perf_counter() - started
    sec = median_seconds(dop_run, args.repeats)
    steps = int(counters[0] + counters[1])
    rows.append(("dop853 rtol 1e-10, Lagrange top", f"{steps:,} steps", sec, f"{sec / steps * 1e9:.0f} ns/step", first - sec, ""))

    # Recording: 10^5 samples of the full layout
    sc = rotlab.load(ROOT / "configs" / "lagrange.toml", method="rk4")
    sc = sc.model_copy(update={"time": sc.time.model_copy(update={"end": 100.0, "sample_rate": 1000.0, "samples": None})})
    traj = rotlab.simulate(sc)
    n = traj.t.shape[0]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.rrd"
        write_recording(traj, path)
        sec = median_seconds(lambda: write_recording(traj, path), max(3, args.repeats // 2))
        size = path.stat().st_size
    rows.append(("write recording (full layout)", f"{n:,} samples", sec, f"{n / sec / 1e6:.2f} M rows/s, {size / n:.0f} B/sample", 0.0, "< 1 s"))

    print(f"{'benchmark':34} {'work':>18} {'median s':>10} {'rate':>34} {'compile s':>10} {'target':>8}")
    for name, work, sec, rate, compile_s, target in rows:
        print(f"{name:34} {work:>18} {sec:10.4f} {rate:>34} {compile_s:10.2f} {target:>8}")


if __name__ == "__main__":
    main()
