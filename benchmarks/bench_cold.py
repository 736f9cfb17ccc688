"""Cold start: what compiling every method's numba kernels costs, from an empty numba cache.

    python benchmarks/bench_cold.py

One child process with an empty ``NUMBA_CACHE_DIR`` runs every method on every shipped config it
supports (0.5 s of simulated time, then written as a recording, so the writer's kernels count
too) and prints, per run, the compile / cache-load time the run reports (numba's compiler lock,
``rotlab.methods.compile_time``) and the total.  Issue 12's target: all methods' kernels together
≤ 30 s.  A method compiles one specialisation per set of load groups, so a config with other
load groups compiles again; a second pass over the same runs shows what loading them costs.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

CHILD = r"""
import sys, tempfile, time
from pathlib import Path
import rotlab
from rotlab.methods.names import METHOD_MODULES
from rotlab.methods.registry import get_method
from rotlab.scene.scene import build_scene

configs = Path(rotlab.__file__).parent / "configs"
started = time.perf_counter()
total = 0.0
out = Path(tempfile.mkdtemp())
for name in ("euler.toml", "dzhanibekov.toml", "lagrange.toml", "general.toml", "sweep_flip.toml"):
    for method in METHOD_MODULES:
        scenario = rotlab.load(configs / name, method=method, duration=0.5)
        if get_method(method).unsupported(build_scene(scenario)) is not None:
            continue
        began = time.perf_counter()
        traj = rotlab.simulate(scenario)
        rotlab.save(out / "run.rrd", traj)
        wall = time.perf_counter() - began
        total += traj.stats.compile_seconds
        print(f"   {name:18s} {method:10s} compile/load {traj.stats.compile_seconds:7.2f} s   wall {wall:6.2f} s", flush=True)
print(f"   all runs: compile/load {total:.1f} s, process {time.perf_counter() - started:.1f} s", flush=True)
"""


def main() -> None:
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for label in ("empty numba cache (compiling)", "filled cache (loading)"):
            print(f"== every method on every shipped config it supports, {label}")
            began = time.perf_counter()
            subprocess.run([sys.executable, "-c", CHILD], env=env, check=True)
            print(f"   child process wall {time.perf_counter() - began:.1f} s\n", flush=True)


if __name__ == "__main__":
    main()
