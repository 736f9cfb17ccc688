"""Cold start: what compiling every method's numba kernels costs, from an empty numba cache.

    python benchmarks/bench_cold.py            # all kernels in one process
    python benchmarks/bench_cold.py --fresh    # cold `rotlab run` of each case in its own process

One child process with an empty ``NUMBA_CACHE_DIR`` runs every method on every shipped config it
supports (0.5 s of simulated time, then written as a recording, so the writer's kernels count
too) and prints, per run, the compile / cache-load time the run reports (numba's compiler lock,
``rotlab.methods.compile_time``) and the total.  Issue 12's target: all methods' kernels together
≤ 30 s.  A method compiles one specialisation per set of load groups, so a config with other
load groups compiles again; a second pass over the same runs shows what loading them costs.

``--fresh``: each case as a user meets it, ``rotlab run CONFIG --method M -q`` in a new process
with its own empty ``NUMBA_CACHE_DIR`` (whole-process wall time, ``--repeats`` runs each, cases
interleaved).  A process re-uses numba's typing of an inlined function for the same types, so
these differ from the single-process figures.  ``PYTHONPATH`` selects the code measured.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

CHILD = r"""
import sys, tempfile, time
from pathlib import Path
import rotlab
try:
    from rotlab.method_names import METHODS
except ImportError:  # code before the method catalog (PYTHONPATH=an older checkout)
    from rotlab.methods.names import METHOD_MODULES as METHODS
from rotlab.methods.registry import get_method
from rotlab.scene.scene import build_scene

configs = Path(rotlab.__file__).parent / "configs"
started = time.perf_counter()
total = 0.0
out = Path(tempfile.mkdtemp())
for name in ("euler.toml", "dzhanibekov.toml", "lagrange.toml", "general.toml", "sweep_flip.toml"):
    for method in METHODS:
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


HERE = os.path.dirname(os.path.abspath(__file__))
CONFIGS = os.path.join(os.path.dirname(HERE), "configs")
FRESH_CASES = (  # (config, method or None for the config's own): every shipped config, then other kernels
    (os.path.join(CONFIGS, "euler.toml"), None),
    (os.path.join(CONFIGS, "dzhanibekov.toml"), None),
    (os.path.join(CONFIGS, "lagrange.toml"), None),
    (os.path.join(CONFIGS, "general.toml"), None),
    (os.path.join(CONFIGS, "sweep_flip.toml"), None),
    (os.path.join(CONFIGS, "general.toml"), "dop853"),
    (os.path.join(HERE, "scenes", "pd_drag.toml"), None),
    (os.path.join(HERE, "scenes", "pd_drag.toml"), "rk4"),
)


def fresh(repeats: int) -> None:
    """Each case's cold ``rotlab run`` in a new process with an empty numba cache."""
    walls: dict[int, list[float]] = {k: [] for k in range(len(FRESH_CASES))}
    with tempfile.TemporaryDirectory() as work:
        for _ in range(repeats):
            for k, (config, method) in enumerate(FRESH_CASES):
                with tempfile.TemporaryDirectory(dir=work) as cache:
                    command = [sys.executable, "-m", "rotlab", "run", config, "-o", os.path.join(cache, "run.rrd"), "-q"]
                    command += ["--method", method] if method else []
                    began = time.perf_counter()
                    # cwd outside the checkout: ``-m`` puts the cwd first on sys.path, ahead of PYTHONPATH
                    subprocess.run(command, env={**os.environ, "NUMBA_CACHE_DIR": cache}, cwd=work, check=True, stdout=subprocess.DEVNULL)
                    walls[k].append(time.perf_counter() - began)
    print(f"== cold `rotlab run` in a fresh process, empty numba cache (median of {repeats}; each run)")
    for k, (config, method) in enumerate(FRESH_CASES):
        runs = ", ".join(f"{w:.1f}" for w in walls[k])
        print(f"   {os.path.basename(config):18s} {method or 'auto':8s} {statistics.median(walls[k]):6.1f} s   ({runs})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fresh", action="store_true", help="each case cold in its own process")
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    if args.fresh:
        fresh(args.repeats)
        return
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        for label in ("empty numba cache (compiling)", "filled cache (loading)"):
            print(f"== every method on every shipped config it supports, {label}")
            began = time.perf_counter()
            subprocess.run([sys.executable, "-c", CHILD], env=env, cwd=cache, check=True)
            print(f"   child process wall {time.perf_counter() - began:.1f} s\n", flush=True)


if __name__ == "__main__":
    main()
