"""What a case of a sweep costs, and where it goes: a sweep of short free-body cases (201 samples
over 10 s, method = "auto", rtol 1e-10; ω₀ drawn per case), run end to end by `rotlab sweep` in
a child process, beside the parts of one case measured in this process:

* solve: ``Method.solve`` of the case's scene with the method and settings the sweep runs it with
  (the integration);
* validate: the case's scenario from the file's document and its values (``case_scenario``,
  done by the worker that runs it);
* simulate: ``rotlab.simulate(scenario)`` (scene, auto's choice, solve, trajectory);
* report: the sweep's per-case report (checks, observables, decimated series), made for a
  worker's chunk of cases at once (``outcomes_of``), per case;
* worker: a worker's whole task for a chunk of new cases (validate, run, report:
  ``run_sweep_chunk``), per case, with the sweep's one method (``shared_choice``: only initial
  states vary) when the code measured has it, and the time that choice takes in the main
  process, per case;
* ensemble: a block of 1,024 new cases validated, run through the ensemble kernels and reported
  (``run_ensemble_chunk``: what `rotlab sweep` does here when the one method has an ensemble
  kernel), per case;
* round trip: a worker's task that does nothing, handed over and answered (IPC);
* sweep: the whole `rotlab sweep` wall time (start-up, validation, workers, results files and
  the comparison recording included) divided by the number of cases; with psutil installed,
  its peak resident memory and that of its largest worker (sampled every 50 ms).

    python benchmarks/bench_sweep.py [--cases 2000] [--jobs 1 2]
"""

from __future__ import annotations

import argparse
import operator
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CONFIG = """title = "free-body sweep (bench_sweep.py)"
[body]
principal_moments = [1.0, 2.0, 3.0]
[initial]
omega = [0.3, 1.0, 0.2]
[time]
end = 10.0
samples = 201
[solver]
method = "auto"
rtol = 1e-10
[sweep]
seed = 1
samples = {cases}
[sweep.parameters]
"initial.omega[0]" = {{ uniform = [0.1, 0.5] }}
"initial.omega[2]" = {{ uniform = [-0.3, 0.3] }}
"""


def _median_us(fn, items) -> float:
    times = []
    for item in items:
        started = time.perf_counter()
        fn(item)
        times.append(time.perf_counter() - started)
    return statistics.median(times) * 1e6


def _run_sampling_memory(command: list[str], cwd: str) -> tuple[float, float] | None:
    """Run ``command`` in ``cwd`` (outside the checkout: ``-m`` puts the cwd first on sys.path,
    ahead of PYTHONPATH); with psutil, its peak resident memory and its workers' largest, in MB,
    sampled every 50 ms (None without psutil)."""
    try:
        import psutil
    except ImportError:
        subprocess.run(command, cwd=cwd, check=True, capture_output=True)
        return None
    child = subprocess.Popen(command, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    process, main_peak, worker_peak = psutil.Process(child.pid), 0, 0
    while child.poll() is None:
        try:
            main_peak = max(main_peak, process.memory_info().rss)
            worker_peak = max([worker_peak, *(c.memory_info().rss for c in process.children(recursive=True))])
        except psutil.Error:  # a worker that just left
            pass
        time.sleep(0.05)
    if child.returncode:
        raise subprocess.CalledProcessError(child.returncode, command, stderr=child.stderr.read())
    return main_peak / 2**20, worker_peak / 2**20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cases", type=int, default=2000)
    parser.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()

    import rotlab
    from rotlab.api import _plan
    from rotlab.heap import keep_heap
    from rotlab.methods.registry import get_method
    from rotlab.parallel import run_tasks
    from rotlab.scene.scene import build_scene
    from rotlab.sweep.cases import case_scenario
    from rotlab.sweep.runner import CHUNK_CASES, ensemble_plan, outcomes_of, plan, run_ensemble_chunk, run_sweep_chunk

    try:
        from rotlab.sweep.shared_choice import shared_choice
    except ImportError:  # earlier code: each case chooses its own method
        shared_choice = None

    with tempfile.TemporaryDirectory() as tmp:
        config = Path(tmp) / "free_sweep.toml"
        config.write_text(CONFIG.format(cases=args.cases), encoding="utf-8")
        sweep = {}
        peaks = {}
        for jobs in args.jobs:
            started = time.perf_counter()
            command = [sys.executable, "-m", "rotlab", "sweep", str(config), "-o", str(Path(tmp) / f"out{jobs}"), "-j", str(jobs)]
            peaks[jobs] = _run_sampling_memory(command, tmp)
            sweep[jobs] = (time.perf_counter() - started) / args.cases * 1e6

        p = plan(config)
        keep_heap()  # as a worker does (rotlab.heap)
        for scenario in p.scenarios[-20:]:
            rotlab.simulate(scenario)  # kernels loaded
        chosen_at = time.perf_counter()
        shared = None if shared_choice is None else shared_choice(p)  # None: each case chooses its own
        choice = () if shared is None else (shared,)
        choosing = (time.perf_counter() - chosen_at) / len(p.cases) * 1e6
        third = min(len(p.scenarios), 1500) // 3  # three sets of cases, none seen before by auto's cache
        planned = []
        for scenario in p.scenarios[:third]:
            scene = build_scene(scenario)
            if choice:  # what the sweep integrates: the one method for all cases
                chosen, settings, t = get_method(choice[0].method), choice[0].settings, scenario.time.sample_times()
            else:
                chosen, _, settings, t = _plan(scene)
            planned.append((chosen, scene, t, settings))
        methods = sorted({chosen.name for chosen, *_ in planned})
        solve = _median_us(lambda item: item[0].solve(item[1], item[2], item[3], None), planned)
        simulate = _median_us(lambda scenario: rotlab.simulate(scenario), p.scenarios[third:2 * third])
        validate = _median_us(lambda case: case_scenario(p.raw, p.base, case, p.source), p.cases[:third])
        runs = [(case, rotlab.simulate(scenario), 0.0) for case, scenario in zip(p.cases[2 * third:3 * third], p.scenarios[2 * third:3 * third])]
        chunks = [runs[k:k + CHUNK_CASES] for k in range(0, len(runs), CHUNK_CASES)]
        report = _median_us(outcomes_of, chunks) / CHUNK_CASES
        fresh = p.cases[3 * third:] or p.cases  # cases auto's cache has not seen (when there are enough)
        tasks = [fresh[k:k + CHUNK_CASES] for k in range(0, min(len(fresh), 20 * CHUNK_CASES), CHUNK_CASES)]
        worker = _median_us(lambda cases: run_sweep_chunk(p.raw, p.base, p.source, cases, *choice), tasks) / CHUNK_CASES
        in_kernels = ensemble_plan(p)
        blocks = [fresh[k:k + 1024] for k in range(0, min(len(fresh), 5 * 1024), 1024)]
        if in_kernels is not None:
            run_ensemble_chunk(p.raw, p.base, p.source, blocks[0][:64], in_kernels, frozenset())  # kernels loaded
        ensemble = (None if in_kernels is None else
                    _median_us(lambda cases: run_ensemble_chunk(p.raw, p.base, p.source, cases, in_kernels, frozenset()), blocks) / 1024)
        stamps: list[float] = []
        begun = time.perf_counter()
        run_tasks(operator.pos, [(1,)] * 2000, 1, preload=(), on_end=lambda end: stamps.append(time.perf_counter() - begun))
        tail = stamps[len(stamps) // 4:]
        round_trip = (tail[-1] - tail[0]) / (len(tail) - 1) * 1e6

    print(f"== a sweep of {args.cases:,} free-body cases (201 samples, auto at rtol 1e-10: {', '.join(methods)}), µs per case")
    print(f"   {'part':44s} {'µs':>8s}   {'× solve':>8s}")
    rows = [("solve (Method.solve, the integration)", solve), ("validate (the case's scenario, in its worker)", validate),
            ("simulate (scene, choice, solve, trajectory)", simulate),
            (f"report ({CHUNK_CASES} cases at once), per case", report),
            (f"worker's task ({CHUNK_CASES} cases), per case", worker),
            ("the sweep's one choice (main process), per case", choosing),
            *([("ensemble block (1,024 cases), per case", ensemble)] if ensemble is not None else []),
            ("round trip of an empty task (1 worker)", round_trip)]
    rows += [(f"rotlab sweep -j {jobs}, wall / cases", us) for jobs, us in sweep.items()]
    for name, us in rows:
        print(f"   {name:44s} {us:8.0f}   {us / solve:8.1f}")
    for jobs, peak in peaks.items():
        if peak is not None:
            print(f"   rotlab sweep -j {jobs}: peak resident memory {peak[0]:.0f} MB, of a worker {peak[1]:.0f} MB")


if __name__ == "__main__":
    main()
