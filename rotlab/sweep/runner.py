"""Run a sweep's cases: local processes (default), a Dask cluster (``--dask``), or — when only
initial conditions vary and the method is ``rk4`` — one ensemble kernel call for all bodies.
A failing case is reported with its error; the others complete."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rotlab.config import models as cfg
from rotlab.config.loader import parse_scenario, read_toml
from rotlab.errors import InputError
from rotlab.parallel import process_pool
from rotlab.sweep.cases import Case, apply, expand

COMPARISON_SAMPLES = 2000  # per case, in the comparison recording
DASK_CONNECT_TIMEOUT = "15s"


@dataclass
class CaseOutcome:
    index: int
    values: dict[str, Any]
    status: str  # "pass" | "fail" | "error"
    method: str = ""
    steps: int = 0
    seconds: float = 0.0
    drift: dict[str, float] = field(default_factory=dict)
    checks: list[dict] = field(default_factory=list)
    message: str = ""
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
        raise InputError(f"{config}", "no [sweep] section: add one (see README, 'Sweeps') or use `rotlab run`")
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
        t=traj.t[::stride],
        omega=traj.omega[::stride],
        energy_drift=traj.invariants["energy"][::stride],
    )


def run_sweep_case(case: Case, scenario: cfg.Scenario | InputError) -> CaseOutcome:
    """One case, never raising (importable by Dask workers)."""
    from rotlab import api

    if isinstance(scenario, InputError):
        return CaseOutcome(case.index, case.values, "error", message=str(scenario))
    started = time.perf_counter()
    try:
        traj = api.simulate(scenario)
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
    from rotlab.core.dynamics import euler_coefficients
    from rotlab.core.ensemble import rk4_ensemble
    from rotlab.methods.base import Settings, Solution
    from rotlab.methods.registry import get_method
    from rotlab.methods.stepping import initial_state
    from rotlab.scene.loads import breakpoints
    from rotlab.scene.scene import build_scene
    from rotlab.trajectory import RunStats, build_trajectory

    started = time.perf_counter()
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
    rk4_ensemble(y0, t, out, substeps, s.max_steps, euler_coefficients(first.moments), first.loads.for_kernel(),
                 breakpoints(first.loads), status, valid)
    seconds = (time.perf_counter() - started) / len(scenes)
    steps = (t.shape[0] - 1) * substeps
    outcomes = []
    for case, scene, k in zip(p.cases, scenes, range(len(scenes))):
        failure = None if status[k] == 0 else f"state became non-finite before t = {t[valid[k]]:.9g} s"
        solution = Solution(t=t, state=out[k], valid=int(valid[k]), steps=steps, failure=failure)
        stats = RunStats("rk4", "ensemble kernel: only initial conditions vary", steps, 0, 4 * steps, seconds, failure,
                         {"step": float(t[1] - t[0]) / substeps})
        outcomes.append(outcome_of(case, build_trajectory(scene, solution, stats), seconds))
    return outcomes


def run_sweep(p: SweepPlan, jobs: int = 2, dask_address: str | None = None) -> tuple[list[CaseOutcome], str]:
    """(outcomes in case order, how they were run)."""
    if dask_address is None and ensemble_eligible(p):
        return run_ensemble(p), "ensemble kernel (numba parallel over bodies)"
    if dask_address is not None:
        return _run_dask(p, dask_address), f"Dask cluster at {dask_address}"
    if jobs <= 1 or len(p.cases) == 1:
        return [run_sweep_case(c, s) for c, s in zip(p.cases, p.scenarios)], "one process"
    with process_pool(jobs) as pool:
        return list(pool.map(run_sweep_case, p.cases, p.scenarios, chunksize=max(1, len(p.cases) // (8 * jobs)))), f"{jobs} local processes"


def _run_dask(p: SweepPlan, address: str) -> list[CaseOutcome]:
    try:
        from dask.distributed import Client
    except ImportError:
        raise InputError("--dask", "Dask is not installed: pip install 'rotlab[dask]'") from None
    try:
        client = Client(address, timeout=DASK_CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as exc:
        raise InputError("--dask", f"cannot reach a Dask scheduler at {address}: {exc}") from None
    with client:
        futures = client.map(run_sweep_case, p.cases, p.scenarios, pure=False)
        return client.gather(futures)
