"""Run a sweep's cases: local processes (default), a Dask cluster (``--dask``), or — when only
initial conditions vary and the method is ``rk4`` — one ensemble kernel call for all bodies.
When only initial conditions vary, the local workers run every case with one method chosen here
(``rotlab.sweep.shared_choice``) rather than each case's own.
Local workers take the cases in chunks (``chunk_size``): a worker validates its chunk's cases,
runs them one after the other and reports them together, the runs of one body and loads stacked
(``outcomes_of``).  A failing case is reported with its error; the others complete."""

from __future__ import annotations

import math
import os
import signal
import time
from collections.abc import Iterable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rotlab.config import models as cfg
from rotlab.config.loader import parse_scenario, read_toml
from rotlab.errors import InputError
from rotlab.parallel import TaskRun, WarmWorkers, run_tasks
from rotlab.sweep.cases import Case, SweepPlan, case_scenario, check_overlaps, check_path, expand
from rotlab.sweep.shared_choice import SharedChoice, initial_only, shared_choice
from rotlab.trajectory import Trajectory, stack_runs

COMPARISON_SAMPLES = 2000  # per case, in the comparison recording
CHUNK_CASES = 64  # at most this many cases in a local worker's task (``chunk_size``)
CHUNKS_PER_WORKER = 8  # ... and at least this many tasks per worker, for balance and a quick stop
# what a sweep worker imports before its first task (not the recording writer: a case writes no file)
WORKER_MODULES = ("rotlab.api", "rotlab.checks", "rotlab.sweep.runner")


@dataclass
class CaseOutcome:
    index: int
    values: dict[str, Any]
    status: str  # "pass" | "fail" | "error"
    method: str = ""
    steps: int = 0
    seconds: float = 0.0  # this case's wall time; NaN when cases ran together (ensemble kernel)
    drift: dict[str, float] = field(default_factory=dict)
    checks: list[dict] = field(default_factory=list)
    message: str = ""
    observables: dict[str, float] = field(default_factory=dict)  # see rotlab.sweep.observables
    t: np.ndarray | None = None  # decimated series for the comparison recording
    omega: np.ndarray | None = None
    energy_drift: np.ndarray | None = None


def plan(config: Path) -> SweepPlan:
    """Read the config, expand its [sweep] and validate the first case (a bad first case is a bad
    sweep; the others are validated where they run)."""
    raw = read_toml(config)
    base = parse_scenario(raw, source=str(config))
    if base.sweep is None:
        raise InputError(f"{config}", "no [sweep] section: add one (README, 'Scenario files', the [sweep] row) or use `rotlab run`")
    for path in base.sweep.parameters:
        check_path(base, path)
    check_overlaps(list(base.sweep.parameters))
    p = SweepPlan(base, expand(base.sweep), raw, str(config))
    first = case_scenario(raw, base, p.cases[0], p.source)
    if isinstance(first, InputError):
        raise first
    return p


def outcomes_of(runs: list[tuple[Case, Trajectory, float]]) -> list[CaseOutcome]:
    """The report of each (case, trajectory, its wall time): checks, observables, decimated series.
    Runs of one body and loads over the same sample times are reported together (their series
    stacked: ``rotlab.trajectory.stack_runs``); each run's ``seconds`` gets its share of that."""
    groups: dict[tuple, list[int]] = {}
    for k, (_, traj, _) in enumerate(runs):
        scene, n = traj.scene, traj.t.shape[0]
        # scenes of equal body and loads share these objects (``rotlab.scene.scene._rigid_part``)
        key = (id(scene.loads), id(scene.axes), n, float(traj.t[0]) if n else 0.0, float(traj.t[-1]) if n else 0.0)
        groups.setdefault(key, []).append(k)
    outcomes: list[CaseOutcome | None] = [None] * len(runs)
    for members in groups.values():
        started = time.perf_counter()
        group = _stacked_outcomes([runs[k] for k in members])
        share = (time.perf_counter() - started) / len(members)
        for k, outcome in zip(members, group):
            outcome.seconds += share
            outcomes[k] = outcome
    return outcomes


def _stacked_outcomes(runs: list[tuple[Case, Trajectory, float]]) -> list[CaseOutcome]:
    from rotlab.checks import checks_of
    from rotlab.sweep.observables import flip_axes, flips, observables

    stacked = stack_runs([traj for _, traj, _ in runs])
    given = [traj.scene.scenario.checks.flip_period for _, traj, _ in runs]
    period, reversals = flips(stacked, flip_axes(stacked, [None if spec is None else spec.axis for spec in given]))
    found = observables(stacked, period)
    drift = stacked.max_drift()
    energy = stacked.drifts["energy"]
    n = stacked.t.shape[0]
    shown = np.unique(np.r_[np.arange(0, n, max(1, math.ceil(n / COMPARISON_SAMPLES))), n - 1]) if n else np.zeros(0, dtype=int)
    t = stacked.t[shown]  # every k-th sample and the last: the comparison spans the whole run
    outcomes = []
    for b, (case, traj, seconds) in enumerate(runs):
        case_drift = {name: float(values[b]) for name, values in drift.items()}
        checks = checks_of(traj.scene, case_drift, (float(period[b]), int(reversals[b])), traj.stats.failure)
        failed = [c for c in checks if not c.passed]
        outcomes.append(CaseOutcome(
            index=case.index,
            values=case.values,
            status="fail" if failed else "pass",
            method=traj.stats.method,
            steps=traj.stats.steps,
            seconds=seconds,
            drift=case_drift,
            checks=[{"name": c.name, "passed": c.passed, "value": c.value, "limit": c.limit} for c in checks],
            message="; ".join(c.message for c in failed),
            observables={name: float(values[b]) for name, values in found.items()},
            t=t,
            omega=stacked.omega[b, shown],
            energy_drift=energy[b, shown],
        ))
    return outcomes


def run_sweep_cases(cases: list[Case], scenarios: list[cfg.Scenario | InputError], choice: SharedChoice | None = None) -> list[CaseOutcome]:
    """Cases one after the other, reported together (``outcomes_of``); never raises for a case:
    an invalid one or one whose run raised is an "error" outcome.  ``choice``: the method every case runs with (a sweep over initial states: ``shared_choice``),
    else each case's own."""
    from rotlab import api
    from rotlab.methods.registry import get_method
    from rotlab.scene.scene import build_scene

    outcomes: list[CaseOutcome | None] = [None] * len(cases)
    runs: list[tuple[int, Case, Trajectory, float]] = []
    plan: api.Plan | None = None
    for k, (case, scenario) in enumerate(zip(cases, scenarios)):
        if isinstance(scenario, InputError):
            outcomes[k] = CaseOutcome(case.index, case.values, "error", message=str(scenario))
            continue
        started = time.perf_counter()
        try:
            shared = choice is not None and case.index not in choice.own
            if shared and plan is None:  # the cases' sample times are the same: made once
                plan = (get_method(choice.method), choice.why, choice.settings, scenario.time.sample_times())
            # a failed case is reported by its checks
            traj = api.run_scene(build_scene(scenario), plan=plan) if shared else api.simulate(scenario, check=False)
        except Exception as exc:
            outcomes[k] = CaseOutcome(case.index, case.values, "error", seconds=time.perf_counter() - started,
                                      message=f"{type(exc).__name__}: {exc}")
            continue
        runs.append((k, case, traj, time.perf_counter() - started))
    for (k, *_), outcome in zip(runs, outcomes_of([run[1:] for run in runs])):
        outcomes[k] = outcome
    return outcomes


def run_sweep_case(case: Case, scenario: cfg.Scenario | InputError) -> CaseOutcome:
    """One case, never raising (importable by Dask workers)."""
    return run_sweep_cases([case], [scenario])[0]


def run_sweep_chunk(raw: dict[str, Any], base: cfg.Scenario, source: str, cases: list[Case],
                    choice: SharedChoice | None = None) -> list[CaseOutcome]:
    """A local worker's task: ``cases`` validated here (``case_scenario``) and run (``run_sweep_cases``)."""
    return run_sweep_cases(cases, [case_scenario(raw, base, case, source) for case in cases], choice)


def ensemble_eligible(p: SweepPlan) -> bool:
    """Only initial conditions vary, every case is valid, the method is fixed-step rk4, and no
    load is a compiled formula: numba's parallel loop cannot take the formulas' record nested in
    the kernels' model (a TypeError while compiling), so those sweeps run case by case."""
    if not _ensemble_shape(p.base.solver.method, p.base.sweep.parameters) or any(isinstance(s, InputError) for s in p.scenarios):
        return False
    from rotlab.scene.scene import build_scene

    return build_scene(p.scenarios[0]).loads.expressions is None


def _ensemble_shape(method: object, paths: Iterable[str]) -> bool:
    """rk4, and only initial conditions swept: what the ensemble kernel runs."""
    return method == "rk4" and initial_only(paths)


def run_ensemble(p: SweepPlan) -> list[CaseOutcome]:
    """All cases in one call of the parallel ensemble kernel."""
    from rotlab.core.ensemble import rk4_ensemble
    from rotlab.methods.base import Settings, Solution
    from rotlab.methods.registry import get_method
    from rotlab.methods.stepping import initial_state
    from rotlab.scene.scene import build_scene
    from rotlab.trajectory import RunStats, build_trajectory

    scenes = [build_scene(s) for s in p.scenarios]
    first = scenes[0]
    t = first.scenario.time.sample_times()
    s = first.scenario.solver
    settings = Settings.of(s)  # (rk4 has one order: solver.order plays no part)
    method = get_method("rk4")
    order = method.order(settings)
    substeps = max(1, math.ceil(float(t[1] - t[0]) / min(method.step(sc, t, settings, order) for sc in scenes) - 1e-9))
    y0 = np.array([initial_state(sc) for sc in scenes])
    out = np.empty((len(scenes), t.shape[0], 8))
    status = np.zeros(len(scenes), dtype=np.int64)
    valid = np.zeros(len(scenes), dtype=np.int64)
    rk4_ensemble(y0, t, out, substeps, s.max_steps, first.model, status, valid)
    seconds = float("nan")  # one kernel call for all bodies: no per-case wall time to report
    steps = (t.shape[0] - 1) * substeps
    runs = []
    for case, scene, k in zip(p.cases, scenes, range(len(scenes))):
        failure = None if status[k] == 0 else f"state became non-finite before t = {t[valid[k]]:.9g} s"
        solution = Solution(t=t, state=out[k], valid=int(valid[k]), steps=steps, failure=failure)
        stats = RunStats("rk4", "ensemble kernel: only initial conditions vary", steps, 0, 4 * steps, seconds, failure,
                         {"step": float(t[1] - t[0]) / substeps})
        runs.append((case, build_trajectory(scene, solution, stats), seconds))
    return outcomes_of(runs)


@dataclass
class SweepRun:
    outcomes: list[CaseOutcome]  # case order; a case that did not finish is an "error" saying why
    how: str  # how the cases were run
    stopped: int | None = None  # SIGINT / SIGTERM that stopped the sweep


def run_sweep(p: SweepPlan, jobs: int = 2, dask_address: str | None = None) -> tuple[list[CaseOutcome], str]:
    """(outcomes in case order, how they were run) — ``run_cases`` without the stop signal."""
    run = run_cases(p, jobs, dask_address)
    return run.outcomes, run.how


def start_workers(config: Path, jobs: int) -> AbstractContextManager[WarmWorkers | None]:
    """``jobs`` local sweep workers (at most one per core this process may use) started now, for
    ``run_cases`` to use (a ``with`` block: the ones it does not use are stopped at its end) —
    none when the file's sweep has the ensemble kernel's shape (it runs in this process) or the
    file cannot be read (``plan`` says why).  More workers than cores start when the cases are
    known, as before."""
    try:
        raw = read_toml(config)
    except InputError:
        return nullcontext()
    sweep, solver = raw.get("sweep"), raw.get("solver")
    method = solver.get("method") if isinstance(solver, dict) else None
    parameters = sweep.get("parameters") if isinstance(sweep, dict) else None
    if isinstance(parameters, dict) and _ensemble_shape(method, parameters):
        return nullcontext()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return WarmWorkers(run_sweep_chunk, min(jobs, cores), WORKER_MODULES)


def chunk_size(cases: int, workers: int) -> int:
    """Cases per local task: up to ``CHUNK_CASES``, and ``CHUNKS_PER_WORKER`` tasks per worker."""
    return max(1, min(CHUNK_CASES, cases // (workers * CHUNKS_PER_WORKER)))


def run_cases(p: SweepPlan, jobs: int = 2, dask_address: str | None = None, *, timeout: float | None = None,
              retries: int = 0, warm: WarmWorkers | None = None) -> SweepRun:
    """Every case: the ensemble kernel when eligible, else local worker processes or the Dask
    cluster at ``dask_address``.  Local workers take the cases in chunks (``chunk_size``),
    validate and run them and report them together; a chunk whose worker died is run again one
    case per task (with ``retries``: the chunk's attempt, which cannot name the case that was
    running, is not counted), so a case that kills its worker costs that case only.  With a per-case
    ``timeout``, one case per task from the start (its clock is the case's).  ``warm``: local
    workers started for ``run_sweep_chunk`` while the sweep was planned (``start_workers``)."""
    ensemble = dask_address is None and timeout is None and ensemble_eligible(p)
    if warm is not None and (ensemble or dask_address is not None):
        warm.release()  # the cases run elsewhere: the warm workers would only take the cores
    if ensemble:
        started = time.perf_counter()
        outcomes = run_ensemble(p)
        return SweepRun(outcomes, f"ensemble kernel (numba parallel over bodies; {time.perf_counter() - started:.3g} s for all cases)")
    if dask_address is not None:
        from rotlab.cluster import run_on_dask

        run = run_on_dask(run_sweep_cases, [([case], [scenario]) for case, scenario in zip(p.cases, p.scenarios)], dask_address,
                          retries=retries)
        outcomes, _ = collect_outcomes([[case] for case in p.cases], run)
        return SweepRun([outcomes[case.index] for case in p.cases], f"Dask cluster at {dask_address}", run.stopped)
    workers = max(1, min(jobs, len(p.cases)))
    size = 1 if timeout is not None else chunk_size(len(p.cases), workers)
    # only initial states vary: one method for all cases, chosen here for the most demanding (not with
    # a per-case --timeout: each case is then a run of its own, as `rotlab run` would make it)
    choice = shared_choice(p) if timeout is None and initial_only(p.base.sweep.parameters) else None
    chunks = [p.cases[i:i + size] for i in range(0, len(p.cases), size)]
    run = run_tasks(run_sweep_chunk, [(p.raw, p.base, p.source, chunk, choice) for chunk in chunks], jobs,
                    timeout=timeout, retries=retries if size == 1 else 0, preload=WORKER_MODULES, warm=warm)
    outcomes, again = collect_outcomes(chunks, run)
    stopped = run.stopped
    if size > 1 and again and stopped is None:  # a chunk's worker died: its cases one by one
        rerun = run_tasks(run_sweep_chunk, [(p.raw, p.base, p.source, [case], choice) for case in again], jobs,
                          retries=retries, preload=WORKER_MODULES)
        outcomes.update(collect_outcomes([[case] for case in again], rerun)[0])
        stopped = rerun.stopped
    how = f"{workers} local worker process{'es' if workers > 1 else ''}" + (f", {size} cases a task" if size > 1 else "")
    if choice is not None:
        how += f"; only initial states vary, one method for {'the' if choice.own else 'all'} cases: {choice.label}: {choice.why}"
    return SweepRun([outcomes[case.index] for case in p.cases], how, stopped)


def collect_outcomes(chunks: list[list[Case]], run: TaskRun) -> tuple[dict[int, CaseOutcome], list[Case]]:
    """(case index → outcome, the cases of tasks that failed): task k ran ``chunks[k]``.  A failed
    task (dead worker, timeout) or one that never finished (the run was stopped) gives each of
    its cases an "error" outcome that says so."""
    ended = {e.index: e for e in run.ends}
    name = signal.Signals(run.stopped).name if run.stopped else ""
    outcomes: dict[int, CaseOutcome] = {}
    failed: list[Case] = []
    for k, chunk in enumerate(chunks):
        end = ended.get(k)
        if end is not None and end.failure is None:
            outcomes.update((outcome.index, outcome) for outcome in end.result)
            continue
        if end is not None:
            failed += chunk
            errors = [CaseOutcome(case.index, case.values, "error", seconds=end.seconds, message=end.failure) for case in chunk]
        else:
            state = "stopped while running" if k in run.running else "not finished"
            errors = [CaseOutcome(case.index, case.values, "error", message=f"{state} (the sweep received {name})") for case in chunk]
        outcomes.update((outcome.index, outcome) for outcome in errors)
    return outcomes, failed
