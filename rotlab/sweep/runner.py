"""Run a sweep's cases: local processes (default), a Dask cluster (``--dask``), or — when only
initial conditions vary and the method has an ensemble kernel (every fixed-step method, dop853, taylor)
— blocks of cases through the ensemble kernels in this process (``rotlab.ensemble``), each
case's observables reduced as it runs.
When only initial conditions vary, the local workers run every case with one method chosen here
(``rotlab.sweep.shared_choice``) rather than each case's own.
Local workers take the cases in chunks (``chunk_size``): a worker validates its chunk's cases,
runs them one after the other and reports them together, the runs of one body and loads stacked
(``outcomes_of``).  A failing case is reported with its error; the others complete.
Every way hands the outcomes to ``on_outcomes`` as cases finish (the CLI's ``Results``: results.csv
grows as they do); only the ``compared`` cases (``compared_cases``) carry their decimated series.
"""

from __future__ import annotations

import math
import os
import signal
import time
from collections.abc import Callable, Iterable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rotlab.config import models as cfg
from rotlab.config.loader import parse_scenario, read_toml
from rotlab.errors import InputError, RunFailure
from rotlab.parallel import TaskEnd, TaskRun, WarmWorkers, run_tasks, signals_noted
from rotlab.sweep.cases import Case, SweepPlan, case_scenario, check_parameters, expand, initial_only
from rotlab.sweep.shared_choice import SharedChoice, shared_choice
from rotlab.trajectory import Trajectory, stack_runs

COMPARISON_SAMPLES = 2000  # per case, in the comparison recording
COMPARED_CASES = 50  # cases with series in the comparison recording, spread evenly over the sweep
BLOCK_CASES = 4096  # at most this many cases per ensemble kernel call (their outcomes are then reported and dropped) ...
FIRST_BLOCK = 64  # ... the first call this many, the next ones as many as take ~BLOCK_SECONDS (``block_size``)
BLOCK_SECONDS = 1.0
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
    observables: dict[str, float] = field(default_factory=dict)  # see rotlab.observables
    t: np.ndarray | None = None  # decimated series for the comparison recording
    omega: np.ndarray | None = None
    energy_drift: np.ndarray | None = None


def plan(config: Path) -> SweepPlan:
    """Read the config, expand its [sweep] and validate the first case (a bad first case is a bad
    sweep; the others are validated where they run)."""
    raw = read_toml(config)
    return plan_of(raw, parse_scenario(raw, source=str(config)), str(config))


def plan_of(raw: dict[str, Any], base: cfg.Scenario, source: str) -> SweepPlan:
    """``plan`` of a document already read (``raw``) and validated (``base``)."""
    if base.sweep is None:
        raise InputError(source, "no [sweep] section: add one (README, 'Scenario files', the [sweep] row) or use `rotlab run`")
    check_parameters(base, source)
    p = SweepPlan(base, expand(base.sweep), raw, source)
    first = case_scenario(raw, base, p.cases[0], p.source)
    if isinstance(first, InputError):
        raise first
    return p


def compared_cases(count: int, asked: Iterable[int] = ()) -> frozenset[int]:
    """The cases whose series the comparison recording shows: ``COMPARED_CASES`` spread evenly
    over the ``count`` cases (all of them when fewer), and the ``asked`` ones."""
    spread = np.unique(np.linspace(0, count - 1, min(count, COMPARED_CASES)).round().astype(np.int64)) if count else []
    return frozenset([*map(int, spread), *asked])


def outcomes_of(runs: list[tuple[Case, Trajectory, float]], compared: frozenset[int] | None = None) -> list[CaseOutcome]:
    """The report of each (case, trajectory, its wall time): checks, observables, and for the cases
    in ``compared`` (None: every case) the decimated series.
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
        group = _stacked_outcomes([runs[k] for k in members], compared)
        share = (time.perf_counter() - started) / len(members)
        for k, outcome in zip(members, group):
            outcome.seconds += share
            outcomes[k] = outcome
    return outcomes


def _stacked_outcomes(runs: list[tuple[Case, Trajectory, float]], compared: frozenset[int] | None) -> list[CaseOutcome]:
    from rotlab.events import observables as event_observables
    from rotlab.observables import flip_axes, flips, observables

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
        outcome = case_outcome(case, traj.scene, traj.stats.method, traj.stats.steps, seconds, traj.stats.failure,
                               {name: float(values[b]) for name, values in drift.items()}, float(period[b]), int(reversals[b]),
                               {**{name: float(values[b]) for name, values in found.items()}, **event_observables(traj.events)})
        if compared is None or case.index in compared:
            outcome.t, outcome.omega, outcome.energy_drift = t, stacked.omega[b, shown], energy[b, shown]
        outcomes.append(outcome)
    return outcomes


def case_outcome(case: Case, scene, method: str, steps: int, seconds: float, failure: str | None, drift: dict[str, float],
                 period: float, reversals: int, observables: dict[str, float]) -> CaseOutcome:
    """A case's outcome from what its run measured: its checks (``rotlab.checks.checks_of``) decide its status."""
    from rotlab.checks import checks_of

    checks = checks_of(scene, drift, (period, reversals), failure)
    failed = [c for c in checks if not c.passed]
    return CaseOutcome(
        index=case.index,
        values=case.values,
        status="fail" if failed else "pass",
        method=method,
        steps=steps,
        seconds=seconds,
        drift=drift,
        checks=[{"name": c.name, "passed": c.passed, "value": c.value, "limit": c.limit} for c in checks],
        message="; ".join(c.message for c in failed),
        observables=observables,
    )


def case_error(exc: Exception) -> str:
    """A case's error as its results row words it: rotlab's own errors in their words (a key and
    its fix); anything else with its type, since it is not one rotlab foresaw."""
    return str(exc) if isinstance(exc, (InputError, RunFailure)) else f"{type(exc).__name__}: {exc}"


def run_sweep_cases(cases: list[Case], scenarios: list[cfg.Scenario | InputError], choice: SharedChoice | None = None,
                    compared: frozenset[int] | None = None) -> list[CaseOutcome]:
    """Cases one after the other, reported together (``outcomes_of``); never raises for a case:
    an invalid one or one whose run raised is an "error" outcome.  ``choice``: the method every case runs with (a sweep over initial states: ``shared_choice``),
    else each case's own.  ``compared``: the cases that keep their series (None: all)."""
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
        shared = choice is not None and case.index not in choice.own
        try:
            if shared and plan is None:  # the cases' sample times are the same: made once
                plan = (get_method(choice.method), choice.why, choice.settings, scenario.time.sample_times())
            # a failed case is reported by its checks
            traj = api.run_scene(build_scene(scenario), plan=plan) if shared else api.simulate(scenario, check=False)
        except Exception as exc:
            method = choice.method if shared else (scenario.solver.method if scenario.solver.method != "auto" else "")  # (auto's own: not chosen)
            outcomes[k] = CaseOutcome(case.index, case.values, "error", method=method, seconds=time.perf_counter() - started,
                                      message=case_error(exc))
            continue
        runs.append((k, case, traj, time.perf_counter() - started))
    for (k, *_), outcome in zip(runs, outcomes_of([run[1:] for run in runs], compared)):
        outcomes[k] = outcome
    return outcomes


def run_sweep_case(case: Case, scenario: cfg.Scenario | InputError) -> CaseOutcome:
    """One case, never raising (importable by Dask workers)."""
    return run_sweep_cases([case], [scenario])[0]


def run_sweep_chunk(raw: dict[str, Any], base: cfg.Scenario, source: str, cases: list[Case],
                    choice: SharedChoice | None = None, compared: frozenset[int] | None = None) -> list[CaseOutcome]:
    """A local worker's task: ``cases`` validated here (``case_scenario``) and run (``run_sweep_cases``)."""
    return run_sweep_cases(cases, [case_scenario(raw, base, case, source) for case in cases], choice, compared)


@dataclass(frozen=True)
class EnsemblePlan:
    """How a sweep over initial states runs in the ensemble kernels: the method (its name: a plan
    travels to Dask workers), its settings, why, and the device ("cpu" or "cuda")."""

    method_name: str
    settings: Any
    why: str
    device: str = "cpu"

    @property
    def method(self) -> Any:
        from rotlab.methods.registry import get_method

        return get_method(self.method_name)


def ensemble_plan(p: SweepPlan) -> EnsemblePlan | None:
    """The ensemble plan of ``p``, or None when its cases run one by one (``ensemble_plan_or_why``)."""
    plan = ensemble_plan_or_why(p)
    return plan if isinstance(plan, EnsemblePlan) else None


def ensemble_plan_or_why(p: SweepPlan, device: str = "cpu") -> EnsemblePlan | str:
    """The ensemble plan of ``p`` on ``device``, or why its cases run one by one: something other
    than initial conditions varies, the method (as asked, or ``auto``'s one choice for all cases:
    ``shared_choice``) has no ensemble kernel (on a GPU: ``GPU_METHODS``), some cases choose their
    own, the first case is invalid, or the loads cannot run in a parallel kernel
    (``rotlab.ensemble.block.unsupported_scene``)."""
    if not initial_only(p.base.sweep.parameters):
        return "only initial conditions may vary (the cases share one body, loads and method)"
    from rotlab.ensemble.block import GPU_METHODS, has_ensemble_kernel, unsupported_on_gpu, unsupported_scene
    from rotlab.methods.base import Settings
    from rotlab.methods.choose import crossing_note
    from rotlab.methods.registry import get_method
    from rotlab.scene.scene import build_scene

    first = case_scenario(p.raw, p.base, p.cases[0], p.source)
    if isinstance(first, InputError):
        return f"case 0 is invalid: {first}"
    scene = build_scene(first)
    solver = p.base.solver
    if solver.method == "auto":
        choice = shared_choice(p)
        if choice is None or choice.own:
            return "auto chooses a method for each case: give solver.method"
        method, settings, why = get_method(choice.method), choice.settings, f"one method for all cases: {choice.label}: {choice.why}"
        if device == "cuda" and unsupported_on_gpu(method) is not None:
            return f"auto chose {choice.label}, which has no GPU kernel: give solver.method, one of {', '.join(GPU_METHODS)}"
    else:
        method, settings = get_method(solver.method), Settings.of(solver)
        why = "as the file asks" + crossing_note(scene, method)
    refusal = (unsupported_on_gpu(method) if device == "cuda" else None) \
        or (None if has_ensemble_kernel(method) else f"method {method.name!r} has no ensemble kernel") or unsupported_scene(scene) \
        or method.unsupported(scene)
    if refusal is not None:
        return refusal
    return EnsemblePlan(method.name, settings, why, device)


def device_plan(p: SweepPlan, device: str | None, option: str, dask_address: str | None = None,
                timeout: float | None = None) -> EnsemblePlan | None:
    """``device`` (given as ``option``; None: the file's ``[sweep] device``): None for "cpu"; for
    "cuda", the sweep's ensemble plan on the GPU; else an ``InputError`` naming the option or key
    that asked and why: not cpu or cuda, with --dask or --timeout, cases the ensemble kernels do
    not take, no usable GPU (never a silent CPU run)."""
    from rotlab.ensemble.block import gpu_unavailable

    where = option if device is not None else "sweep.device"
    device = device if device is not None else p.base.sweep.device

    if device not in ("cpu", "cuda"):
        raise InputError(where, f"must be cpu or cuda (got {device!r})")
    if device == "cpu":
        return None
    if dask_address is not None:
        raise InputError(where, "cuda runs on this machine's GPU: not with --dask")
    if timeout is not None:
        raise InputError(where, "cuda runs the cases together in one kernel: not with --timeout")
    plan = ensemble_plan_or_why(p, "cuda")
    if isinstance(plan, str):
        raise InputError(where, f"the GPU runs the ensemble kernels only, and this sweep cannot use them: {plan}")
    why = gpu_unavailable()
    if why is not None:
        raise InputError(where, why)
    return plan


def block_size(size: int, seconds: float) -> int:
    """The next ensemble block: as many cases as the last block's pace fits in ``BLOCK_SECONDS``
    (results.csv grows, and a stop signal is heard, about once a second — but for a first block
    whose kernels compile: numba's compiler is not interrupted), within
    [``FIRST_BLOCK``, ``BLOCK_CASES``].  Blocks change no case's numbers, only when they are reported."""
    return int(min(BLOCK_CASES, max(FIRST_BLOCK, size * BLOCK_SECONDS / max(seconds, 1e-3))))


def run_ensemble_chunk(raw: dict[str, Any], base: cfg.Scenario, source: str, cases: list[Case], plan: EnsemblePlan,
                       compared: frozenset[int] | None, timing: dict[str, float] | None = None) -> list[CaseOutcome]:
    """One ensemble kernel call for ``cases`` (validated here: an invalid case is an "error"
    outcome); importable by Dask workers, each task a block of cases.  ``timing["checked"]``
    receives the seconds a GPU call spent checking cases on the CPU (not the device's pace)."""
    from rotlab.ensemble.block import run_block
    from rotlab.ensemble.cross_check import GpuDisagreement, message
    from rotlab.methods.base import Solution
    from rotlab.scene.scene import build_scene
    from rotlab.trajectory import RunStats, build_trajectory

    outcomes: dict[int, CaseOutcome] = {}
    runnable: list[tuple[Case, Any]] = []
    for case in cases:
        try:
            scenario = case_scenario(raw, base, case, source)
            if isinstance(scenario, InputError):
                outcomes[case.index] = CaseOutcome(case.index, case.values, "error", message=str(scenario))
            else:
                runnable.append((case, build_scene(scenario)))
        except Exception as exc:  # (one case's, as ``run_sweep_cases`` reports it: not the whole block's)
            outcomes[case.index] = CaseOutcome(case.index, case.values, "error", message=case_error(exc))
    if runnable:
        scenes = [scene for _, scene in runnable]
        t = scenes[0].scenario.time.sample_times()
        stride = max(1, math.ceil(t.shape[0] / COMPARISON_SAMPLES))
        keep = [k for k, (case, _) in enumerate(runnable) if compared is None or case.index in compared]
        given = [None if s.scenario.checks.flip_period is None else s.scenario.checks.flip_period.axis for s in scenes]
        try:
            block = run_block(scenes, plan.method, plan.settings, t, keep, stride, given, device=plan.device)
        except GpuDisagreement as exc:  # (named by the sweep's case number)
            raise RunFailure(message(f"case {runnable[exc.position][0].index}", exc.what, exc.library)) from None
        if isinstance(block, InputError):
            raise block
        if timing is not None:
            timing["checked"] = block.checked_seconds
        name = plan.method.name
        for k, (case, scene) in enumerate(runnable):
            failure = block.failure[k]
            if block.valid[k] == 0:  # refused before stepping (a step it cannot take)
                outcomes[case.index] = CaseOutcome(case.index, case.values, "error", method=name, message=failure or "")
                continue
            drift = {n: float(v[k]) for n, v in block.max_drift.items()}
            observables = {"flip_period_s": float(block.flip_period[k]), "max_nutation_deg": float(block.max_nutation_deg[k]),
                           **{column: float(values[k]) for column, values in block.events.items()}}
            outcome = case_outcome(case, scene, name, int(block.steps[k]), math.nan, failure, drift, float(block.flip_period[k]),
                                   int(block.reversals[k]), observables)
            if k in block.kept:
                kept_t, rows = block.kept[k]
                stats = RunStats(name, plan.why, int(block.steps[k]), int(block.rejected[k]), int(block.evaluations[k]), math.nan,
                                 failure, block.details[k])
                traj = build_trajectory(scene, Solution(t=kept_t, state=rows, valid=rows.shape[0]), stats)
                outcome.t, outcome.omega, outcome.energy_drift = traj.t, traj.omega, traj.invariants["energy"]
            outcomes[case.index] = outcome
    return [outcomes[case.index] for case in cases]


@dataclass
class SweepRun:
    outcomes: list[CaseOutcome]  # case order, when no ``on_outcomes`` took them; a case that did not finish is an "error" saying why
    how: str  # how the cases were run
    stopped: int | None = None  # SIGINT / SIGTERM that stopped the sweep


def run_sweep(p: SweepPlan, jobs: int = 2, dask_address: str | None = None) -> tuple[list[CaseOutcome], str]:
    """(outcomes in case order, how they were run) — ``run_cases`` without the stop signal."""
    run = run_cases(p, jobs, dask_address)
    return run.outcomes, run.how


def start_workers(config: Path, jobs: int) -> AbstractContextManager[WarmWorkers | None]:
    """``jobs`` local sweep workers (at most one per core this process may use) started now, for
    ``run_cases`` to use (a ``with`` block: the ones it does not use are stopped at its end) —
    none when the file asks for a method with an ensemble kernel and sweeps only initial
    conditions (its cases run in this process), or the file cannot be read (``plan`` says why).
    More workers than cores start when the cases are known, as before."""
    try:
        raw = read_toml(config)
    except InputError:
        return nullcontext()
    sweep, solver = raw.get("sweep"), raw.get("solver")
    method = solver.get("method") if isinstance(solver, dict) else None
    parameters = sweep.get("parameters") if isinstance(sweep, dict) else None
    if isinstance(parameters, dict) and initial_only(parameters) and isinstance(method, str) and method != "auto":
        from rotlab.ensemble.block import has_ensemble_kernel
        from rotlab.methods.registry import all_methods

        if any(m.name == method and has_ensemble_kernel(m) for m in all_methods()):
            return nullcontext()
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return WarmWorkers(run_sweep_chunk, min(jobs, cores), WORKER_MODULES)


def chunk_size(cases: int, workers: int) -> int:
    """Cases per local task: up to ``CHUNK_CASES``, and ``CHUNKS_PER_WORKER`` tasks per worker."""
    return max(1, min(CHUNK_CASES, cases // (workers * CHUNKS_PER_WORKER)))


def run_cases(p: SweepPlan, jobs: int = 2, dask_address: str | None = None, *, timeout: float | None = None,
              retries: int = 0, warm: WarmWorkers | None = None, on_outcomes: Callable[[list[CaseOutcome]], None] | None = None,
              compared: frozenset[int] | None = None, ensemble: EnsemblePlan | None = None, device: str | None = None) -> SweepRun:
    """Every case: the ensemble kernels when ``ensemble_plan`` allows (on ``jobs`` threads), else local worker processes
    or the Dask cluster at ``dask_address``.  Local workers take the cases in chunks
    (``chunk_size``), validate and run them and report them together; a chunk whose worker died is
    run again one case per task (with ``retries``: the chunk's attempt, which cannot name the case
    that was running, is not counted), so a case that kills its worker costs that case only.  With
    a per-case ``timeout``, one case per task from the start (its clock is the case's).  ``warm``:
    local workers started for ``run_sweep_chunk`` while the sweep was planned (``start_workers``).
    ``on_outcomes``: given the outcomes as cases finish (else they are returned, in case order);
    ``compared``: the cases that keep their series (default: ``compared_cases`` when the outcomes
    go to ``on_outcomes``, else every case); ``ensemble``: the ensemble plan decided already
    (``device_plan``), else ``ensemble_plan``'s; ``device``: "cpu" or "cuda" (default: the file's
    ``[sweep] device``; "cuda" runs as ``device_plan`` says, or raises its ``InputError``)."""
    if ensemble is None:
        ensemble = device_plan(p, device, "device", dask_address, timeout)
    if compared is None and on_outcomes is not None:
        compared = compared_cases(len(p.cases))
    collected: list[CaseOutcome] = []
    deliver = on_outcomes or collected.extend
    plan = ensemble if ensemble is not None else ensemble_plan(p) if timeout is None else None
    if warm is not None and (plan is not None or dask_address is not None):
        warm.release()  # the cases run elsewhere: the warm workers would only take the cores
    if plan is not None and dask_address is None:
        import numba

        started, done, size = time.perf_counter(), 0, FIRST_BLOCK
        threads = numba.get_num_threads()
        numba.set_num_threads(max(1, min(jobs, numba.config.NUMBA_NUM_THREADS)))  # -j: the kernels' threads
        with signals_noted() as signals:  # a stop signal ends the sweep between blocks (a block is not cut short)
            try:
                while done < len(p.cases) and signals.signum is None:
                    block_started, timing = time.perf_counter(), {}
                    block = p.cases[done:done + size]
                    deliver(run_ensemble_chunk(p.raw, p.base, p.source, block, plan, compared, timing))
                    done += len(block)
                    size = block_size(size, time.perf_counter() - block_started - timing.get("checked", 0.0))  # (the pace of the kernels)
            finally:
                used = numba.get_num_threads()
                numba.set_num_threads(threads)
        stopped = signals.signum
        if stopped is not None:
            note = f"not finished (the sweep received {signal.Signals(stopped).name})"
            deliver([CaseOutcome(case.index, case.values, "error", message=note) for case in p.cases[done:]])
        spread = ("one thread per case on the GPU, up to 4 cases a call run again on the CPU to check it" if plan.device == "cuda"
                  else f"{used} thread{'s' if used > 1 else ''} over cases")
        how = (f"ensemble kernels ({plan.method_name}, {spread}, {FIRST_BLOCK}–{BLOCK_CASES} cases a call, "
               f"{time.perf_counter() - started:.3g} s for all cases; {plan.why})")
        return SweepRun(sorted(collected, key=lambda o: o.index), how, stopped)
    if dask_address is not None:
        from rotlab.cluster import run_on_dask

        size = BLOCK_CASES if plan is not None else CHUNK_CASES
        chunks = [p.cases[i:i + size] for i in range(0, len(p.cases), size)]
        if plan is not None:  # each task a block of cases through the ensemble kernels
            run = run_on_dask(run_ensemble_chunk, [(p.raw, p.base, p.source, chunk, plan, compared) for chunk in chunks],
                              dask_address, retries=retries)
        else:
            run = run_on_dask(run_sweep_chunk, [(p.raw, p.base, p.source, chunk, None, compared) for chunk in chunks],
                              dask_address, retries=retries)
        outcomes, _ = collect_outcomes(chunks, run)
        deliver([outcomes[case.index] for case in p.cases])
        how = f"Dask cluster at {dask_address}" + (f", ensemble kernels ({plan.method_name}), {size} cases a task" if plan else "")
        return SweepRun(sorted(collected, key=lambda o: o.index), how, run.stopped)
    workers = max(1, min(jobs, len(p.cases)))
    size = 1 if timeout is not None else chunk_size(len(p.cases), workers)
    # only initial states vary: one method for all cases, chosen here for the most demanding (not with
    # a per-case --timeout: each case is then a run of its own, as `rotlab run` would make it)
    choice = shared_choice(p) if timeout is None and initial_only(p.base.sweep.parameters) else None
    chunks = [p.cases[i:i + size] for i in range(0, len(p.cases), size)]

    def finished(end: TaskEnd) -> None:  # a chunk's outcomes as soon as it ends; its payload is then dropped
        if end.failure is None:
            deliver(end.result)
            end.result = _DELIVERED

    run = run_tasks(run_sweep_chunk, [(p.raw, p.base, p.source, chunk, choice, compared) for chunk in chunks], jobs,
                    timeout=timeout, retries=retries if size == 1 else 0, preload=WORKER_MODULES, warm=warm, on_end=finished)
    outcomes, again = collect_outcomes(chunks, run)
    stopped = run.stopped
    if size > 1 and again and stopped is None:  # a chunk's worker died: its cases one by one
        rerun = run_tasks(run_sweep_chunk, [(p.raw, p.base, p.source, [case], choice, compared) for case in again], jobs,
                          retries=retries, preload=WORKER_MODULES, on_end=finished)
        outcomes.update(collect_outcomes([[case] for case in again], rerun)[0])
        stopped = rerun.stopped
    deliver(sorted(outcomes.values(), key=lambda o: o.index))
    how = f"{workers} local worker process{'es' if workers > 1 else ''}" + (f", {size} cases a task" if size > 1 else "")
    if choice is not None:
        how += f"; only initial states vary, one method for {'the' if choice.own else 'all'} cases: {choice.label}: {choice.why}"
    return SweepRun(sorted(collected, key=lambda o: o.index), how, stopped)


_DELIVERED = object()  # a task's result once its outcomes were delivered


def collect_outcomes(chunks: list[list[Case]], run: TaskRun) -> tuple[dict[int, CaseOutcome], list[Case]]:
    """(case index → outcome, the cases of tasks that failed): task k ran ``chunks[k]`` (the outcomes
    of a task already delivered as it ended are not among them).  A failed
    task (dead worker, timeout) or one that never finished (the run was stopped) gives each of
    its cases an "error" outcome that says so."""
    ended = {e.index: e for e in run.ends}
    name = signal.Signals(run.stopped).name if run.stopped else ""
    outcomes: dict[int, CaseOutcome] = {}
    failed: list[Case] = []
    for k, chunk in enumerate(chunks):
        end = ended.get(k)
        if end is not None and end.failure is None:
            if end.result is not _DELIVERED:
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
