"""Run many scenarios in worker processes (or on a Dask cluster); a failing case, a dead worker or
a case over its time limit never stops the others, and each case is reported as it finishes."""

from __future__ import annotations

import math
import signal
import time
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Iterable

from rotlab.errors import InputError
from rotlab.parallel import TaskEnd, run_tasks

PASS, FAIL, ERROR, CANCELLED = "pass", "fail", "error", "cancelled"


@dataclass
class CaseResult:
    scenario: str  # config path as given
    output: str | None  # the recording written (NAME.partial.rrd when the run stopped early)
    status: str  # PASS | FAIL (a check failed) | ERROR (bad input, crash, dead worker, timeout) | CANCELLED
    method: str = ""
    steps: int = 0
    seconds: float = 0.0  # wall time of the whole case
    worst_invariant: str = ""
    worst_drift: float | None = None
    checks: list[dict] = field(default_factory=list)  # CheckResult.as_dict() of every check applied
    default_checks: bool = False  # the scenario has no [checks]: default bounds were applied
    message: str = ""  # why it did not pass (never repeats the scenario's path)
    attempts: int = 1

    def as_dict(self) -> dict:
        return asdict(self)

    @property
    def name(self) -> str:
        return Path(self.scenario).name


def collect_configs(paths: Iterable[Path]) -> list[Path]:
    """Files as given; directories contribute their *.toml files (sorted, not recursive)."""
    found: list[Path] = []
    for path in paths:
        if path.is_dir():
            found.extend(sorted(path.glob("*.toml")))
        elif path.exists():
            found.append(path)
        else:
            raise InputError(str(path), "no such file or directory")
    if not found:
        raise InputError(" ".join(map(str, paths)), "no scenario files (*.toml) found")
    return found


def output_names(configs: list[Path]) -> list[str]:
    """Recording names, unique even when two configs share a name in different folders."""
    names = [c.stem for c in configs]
    return [f"{c.parent.name}_{c.stem}" if names.count(c.stem) > 1 else c.stem for c in configs]


def error_text(exc: InputError, config: Path) -> str:
    """The error without the config's path in front (the report names the scenario once)."""
    where = exc.where
    for prefix in (str(config), config.name):
        if where == prefix:
            return exc.message
        if where.startswith(prefix + ": "):
            return f"{where[len(prefix) + 2:]}: {exc.message}"
    return str(exc)


def run_case(config: Path, output: Path) -> CaseResult:
    """Run one scenario, write its recording (``NAME.partial.rrd`` if the run stopped early, so a
    good ``NAME.rrd`` is never replaced by a failed run), evaluate its checks.  Never raises."""
    from rotlab import api
    from rotlab.checks import DEFAULT, evaluate_checks, has_checks
    from rotlab.errors import RunFailure
    from rotlab.recording.writer import partial_path, write_recording

    started = time.perf_counter()

    def error(message: str) -> CaseResult:
        return CaseResult(str(config), None, ERROR, seconds=time.perf_counter() - started, message=message)

    try:
        traj = api.simulate(api.load(config), check=False)  # a stopped run is reported by its checks
        target = partial_path(output) if traj.stats.failure else output
        write_recording(traj, target)
    except InputError as exc:
        return error(error_text(exc, config))
    except RunFailure as exc:  # the recording could not be written
        return error(str(exc))
    except Exception as exc:  # a crash in one case is reported, the batch goes on
        last = traceback.extract_tb(exc.__traceback__)[-1]
        return error(f"{type(exc).__name__}: {exc} (at {Path(last.filename).name}:{last.lineno})")
    checks = evaluate_checks(traj, defaults=True)
    drift = traj.max_drift()
    worst = max(drift, key=lambda k: math.inf if math.isnan(drift[k]) else drift[k]) if drift else ""  # NaN: the worst
    failed = [c for c in checks if not c.passed]
    message = "; ".join(c.message for c in failed)
    defaulted = [c for c in failed if c.source == DEFAULT]
    if defaulted:
        message += f" (default bound: {defaulted[0].basis})"
    return CaseResult(
        scenario=str(config),
        output=str(target),
        status=FAIL if failed else PASS,
        method=traj.stats.method,
        steps=traj.stats.steps,
        seconds=time.perf_counter() - started,
        worst_invariant=worst,
        worst_drift=drift.get(worst),
        checks=[c.as_dict() for c in checks],
        default_checks=not has_checks(traj),
        message=message,
    )


def remove_temporaries(output: Path, pid: int) -> list[Path]:
    """Delete what a killed worker ``pid`` left half-written beside ``output`` (the recording
    writer's ``.NAME.PID.*`` temporaries: it renames them only when complete)."""
    found = [p for stem in (output.name, partial_path_name(output)) for p in output.parent.glob(f".{stem}.{pid}.*")]
    for path in found:
        path.unlink(missing_ok=True)
    return found


def partial_path_name(output: Path) -> str:
    from rotlab.recording.writer import partial_path

    return partial_path(output).name


@dataclass
class BatchRun:
    results: list[CaseResult]  # input order; cases never started are CANCELLED
    stopped: int | None = None  # SIGINT / SIGTERM that stopped the batch

    @property
    def exit_code(self) -> int:
        if self.stopped is not None:
            return 128 + self.stopped
        return 0 if all(r.status == PASS for r in self.results) else 1


def run_batch(configs: list[Path], outdir: Path, jobs: int, *, timeout: float | None = None, retries: int = 0,
              dask_address: str | None = None, on_result: Callable[[CaseResult], None] | None = None) -> BatchRun:
    """Run every config (``jobs`` worker processes, or the Dask cluster at ``dask_address``);
    ``on_result`` sees each case as it finishes."""
    outputs = [outdir / f"{name}.rrd" for name in output_names(configs)]
    tasks = [(c, o) for c, o in zip(configs, outputs)]
    results: dict[int, CaseResult] = {}

    def ended(end: TaskEnd) -> None:
        if end.failure is None:
            result = end.result
        else:
            result = CaseResult(str(configs[end.index]), None, ERROR, seconds=end.seconds, message=end.failure)
            if end.pid is not None:
                remove_temporaries(outputs[end.index], end.pid)
        result.attempts = end.attempts
        results[end.index] = result
        if on_result is not None:
            on_result(result)

    if dask_address is not None:
        from rotlab.cluster import run_on_dask

        run = run_on_dask(run_case, tasks, dask_address, retries=retries, on_end=ended)
    else:
        run = run_tasks(run_case, tasks, jobs, timeout=timeout, retries=retries, on_end=ended)
    for index, pid in run.running.items():
        remove_temporaries(outputs[index], pid)
    name = signal.Signals(run.stopped).name if run.stopped else ""
    why = {i: f"stopped while running (the batch received {name})" for i in run.running}
    ordered = [results.get(i) or CaseResult(str(c), None, CANCELLED, message=why.get(i, f"not finished (the batch received {name})"))
               for i, c in enumerate(configs)]
    return BatchRun(ordered, run.stopped)
