"""Run a sweep's cases: local processes (default), a Dask cluster (``--dask``), or — when only
initial conditions vary and the method is ``rk4`` — one ensemble kernel call for all bodies.
A failing case is reported with its error; the others complete."""

from __future__ import annotations

import math
import signal
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rotlab.config import models as cfg
from rotlab.config.loader import parse_scenario, read_toml
from rotlab.errors import InputError
from rotlab.parallel import TaskRun, run_tasks
from rotlab.sweep.cases import Case, apply, check_path, expand

COMPARISON_SAMPLES = 2000  # per case, in the comparison recording


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


@dataclass
class SweepPlan:
    base: cfg.Scenario
    cases: list[Case]
    scenarios: list[cfg.Scenario | InputError]


def plan(config: Path) -> SweepPlan:
    """Read the config, expand its [sweep], validate every case (a bad case is kept as its error;
    a bad first case is a bad sweep)."""
    raw = read_toml(config)
    base = parse_scenario(raw, source=str(config))
    if base.sweep is None:
        raise InputError(f"{config}", "no [sweep] section: add one (README, 'Scenario files', the [sweep] row) or use `rotlab run`")
    for path in base.sweep.parameters:
        check_path(base, path)
    cases = expand(base.sweep)
    scenarios: list[cfg.Scenario | InputError] = []
    for case in cases:
        try:
            scenarios.append(parse_scenario(apply(raw, base, case.values), source=f"{config} case {case.index}"))
        except InputError as exc:
            if case.index == 0:
                raise
            scenarios.append(exc)
    return SweepPlan(base, cases, scenarios)


def outcome_of(case: Case, traj, seconds: float) -> CaseOutcome:
    from rotlab.checks import evaluate_checks
    from rotlab.sweep.observables import case_observables

    checks = evaluate_checks(traj)
    failed = [c for c in checks if not c.passed]
    stride = max(1, math.ceil(traj.t.shape[0] / COMPARISON_SAMPLES))
    return CaseOutcome(
        index=case.index,
        values=case.values,
        status="fail" if failed else "pass",
        method=traj.stats.method,
        steps=traj.stats.steps,
        seconds=seconds,
        drift=traj.max_drift(),
        checks=[{"name": c.name, "passed": c.passed, "value": c.value, "limit": c.limit} for c in checks],
        message="; ".join(c.message for c in failed),
        observables=case_observables(traj),
        t=traj.t[::stride],
        omega=traj.omega[::stride],
        energy_drift=traj.invariants["energy"][::stride],
    )


def run_sweep_case(case: Case, scenario: cfg.Scenario | InputError, expected_runs: int = 0) -> CaseOutcome:
    """One case, never raising (importable by Dask workers).  ``expected_runs``: the cases this
    worker process is expected to run (``auto`` shares a kernel's loading among them)."""
    from rotlab import api
    from rotlab.methods.choose import expect_runs

    if expected_runs:
        expect_runs(expected_runs)
    if isinstance(scenario, InputError):
        return CaseOutcome(case.index, case.values, "error", message=str(scenario))
    started = time.perf_counter()
    try:
        traj = api.simulate(scenario, check=False)  # a failed case is reported by outcome_of
    except Exception as exc:
        return CaseOutcome(case.index, case.values, "error", seconds=time.perf_counter() - started, message=f"{type(exc).__name__}: {exc}")
    return outcome_of(case, traj, time.perf_counter() - started)


def ensemble_eligible(p: SweepPlan) -> bool:
    """Only initial conditions vary, every case is valid, and the method is fixed-step rk4."""
    return (
        p.base.solver.method == "rk4"
        and all(key.startswith("initial.") for key in p.base.sweep.parameters)
        and not any(isinstance(s, InputError) for s in p.scenarios)
    )


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
    settings = Settings(step=s.step, rtol=s.rtol, atol=s.atol, max_steps=s.max_steps)
    method = get_method("rk4")
    order = method.order(settings)
    substeps = max(1, math.ceil(float(t[1] - t[0]) / min(method.step(sc, t, settings, order) for sc in scenes) - 1e-9))
    y0 = np.array([initial_state(sc.q0, sc.omega0) for sc in scenes])
    out = np.empty((len(scenes), t.shape[0], 8))
    status = np.zeros(len(scenes), dtype=np.int64)
    valid = np.zeros(len(scenes), dtype=np.int64)
    rk4_ensemble(y0, t, out, substeps, s.max_steps, first.model, status, valid)
    seconds = float("nan")  # one kernel call for all bodies: no per-case wall time to report
    steps = (t.shape[0] - 1) * substeps
    outcomes = []
    for case, scene, k in zip(p.cases, scenes, range(len(scenes))):
        failure = None if status[k] == 0 else f"state became non-finite before t = {t[valid[k]]:.9g} s"
        solution = Solution(t=t, state=out[k], valid=int(valid[k]), steps=steps, failure=failure)
        stats = RunStats("rk4", "ensemble kernel: only initial conditions vary", steps, 0, 4 * steps, seconds, failure,
                         {"step": float(t[1] - t[0]) / substeps})
        outcomes.append(outcome_of(case, build_trajectory(scene, solution, stats), seconds))
    return outcomes


@dataclass
class SweepRun:
    outcomes: list[CaseOutcome]  # case order; a case that did not finish is an "error" saying why
    how: str  # how the cases were run
    stopped: int | None = None  # SIGINT / SIGTERM that stopped the sweep


def run_sweep(p: SweepPlan, jobs: int = 2, dask_address: str | None = None) -> tuple[list[CaseOutcome], str]:
    """(outcomes in case order, how they were run) — ``run_cases`` without the stop signal."""
    run = run_cases(p, jobs, dask_address)
    return run.outcomes, run.how


def run_cases(p: SweepPlan, jobs: int = 2, dask_address: str | None = None, *, timeout: float | None = None,
              retries: int = 0) -> SweepRun:
    """Every case: the ensemble kernel when eligible, else local worker processes (a dead worker
    or a case over ``timeout`` s costs that case only) or the Dask cluster at ``dask_address``."""
    if dask_address is None and timeout is None and ensemble_eligible(p):
        started = time.perf_counter()
        outcomes = run_ensemble(p)
        return SweepRun(outcomes, f"ensemble kernel (numba parallel over bodies; {time.perf_counter() - started:.3g} s for all cases)")
    tasks = list(zip(p.cases, p.scenarios))
    if dask_address is not None:
        from rotlab.cluster import run_on_dask

        run, how = run_on_dask(run_sweep_case, tasks, dask_address, retries=retries), f"Dask cluster at {dask_address}"
    else:
        workers = max(1, min(jobs, len(tasks)))
        # each worker runs about this many cases: auto shares a kernel's loading among them; not with a
        # per-case --timeout, whose clock the first case's kernel load would run out on every new worker
        per_worker = -(-len(tasks) // workers) if timeout is None else 0
        run = run_tasks(run_sweep_case, [(*task, per_worker) for task in tasks], jobs, timeout=timeout, retries=retries)
        how = f"{workers} local worker process{'es' if workers > 1 else ''}"
    return SweepRun(collect_outcomes(p, run), how, run.stopped)


def collect_outcomes(p: SweepPlan, run: TaskRun) -> list[CaseOutcome]:
    """Outcomes in case order: a task's failure (dead worker, timeout) or a case that never
    finished (the sweep was stopped) becomes an "error" outcome that says so."""
    ended = {e.index: e for e in run.ends}
    name = signal.Signals(run.stopped).name if run.stopped else ""
    outcomes = []
    for i, case in enumerate(p.cases):
        end = ended.get(i)
        if end is not None and end.failure is None:
            outcomes.append(end.result)
        elif end is not None:
            outcomes.append(CaseOutcome(case.index, case.values, "error", seconds=end.seconds, message=end.failure))
        else:
            state = "stopped while running" if i in run.running else "not finished"
            outcomes.append(CaseOutcome(case.index, case.values, "error", message=f"{state} (the sweep received {name})"))
    return outcomes
