"""What the pictures cost: `rotlab snapshot` (small and large recording), `rotlab animate` (a
10 s clip at 20 fps) and writing a recording with the visual layer.

    python benchmarks/bench_visuals.py [--repeats 3]

Medians of repeats, wall time of the installed CLI (what a user waits for); needs a Vulkan driver
for the snapshots and matplotlib for the animation.  Writing: seconds and bytes per sample.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import rotlab
from rotlab.recording.writer import write_recording

ROOT = Path(__file__).resolve().parents[1]
CLI = str(Path(sys.executable).with_name("rotlab"))


def median_wall(args: list[str], repeats: int, cwd: Path) -> float:
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        subprocess.run([CLI, *args], cwd=cwd, check=True, capture_output=True)
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def recording(folder: Path, name: str, sample_rate: float) -> tuple[Path, int, float]:
    """(path, samples, median write seconds over 3) of a shipped config at ``sample_rate``."""
    scenario = rotlab.load(ROOT / "configs" / f"{name}.toml")
    scenario = scenario.model_copy(update={"time": scenario.time.model_copy(update={"sample_rate": sample_rate})})
    traj = rotlab.simulate(scenario)
    path = folder / f"{name}_{int(sample_rate)}.rrd"
    write_recording(traj, path)  # compile and warm up
    times = []
    for _ in range(3):
        started = time.perf_counter()
        write_recording(traj, path)
        times.append(time.perf_counter() - started)
    return path, traj.t.shape[0], statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = []
        for name, rate in (("general", 200), ("general", 10_000), ("lagrange", 10_000)):
            path, n, seconds = recording(folder, name, rate)
            rows.append((f"write {name}, {n:,} samples", seconds, f"{os.path.getsize(path) / n:.0f} B/sample"))
        small, large = folder / "general_200.rrd", folder / "lagrange_10000.rrd"
        for label, path in (("snapshot, 2,001 samples", small), ("snapshot, 100,001 samples", large)):
            wall = median_wall(["snapshot", str(path), "-o", "shot.png", "--size", "1280x720"], args.repeats, folder)
            rows.append((label, wall, "1280x720"))
        wall = median_wall(["animate", str(small), "-o", "clip.gif", "--fps", "20", "--speed", "1"], args.repeats, folder)
        rows.append(("animate 10 s clip, 20 fps (201 frames)", wall, "640x640 GIF"))
    print(f"{'what':44} {'median s':>9}  note")
    for label, seconds, note in rows:
        print(f"{label:44} {seconds:9.2f}  {note}")


if __name__ == "__main__":
    main()
