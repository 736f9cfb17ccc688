"""Run many scenarios in parallel processes; a failing case never stops the others."""

from __future__ import annotations

import time
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Iterable

from rotlab.errors import InputError
from rotlab.parallel import process_pool


@dataclass
class CaseResult:
    scenario: str  # config path as given
    output: str | None
    status: str  # "pass" | "fail" (a check failed) | "error" (bad input or crash)
    method: str = ""
    steps: int = 0
    seconds: float = 0.0  # wall time of the whole case
    worst_invariant: str = ""
    worst_drift: float = 0.0
    checks: list[dict] = field(default_factory=list)
    message: str = ""

    def as_dict(self) -> dict:
        return asdict(self)


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


def run_case(config: Path, output: Path) -> CaseResult:
    """Run one scenario, write its recording, evaluate its checks. Never raises."""
    from rotlab import api
    from rotlab.checks import evaluate_checks
    from rotlab.recording.writer import write_recording

    started = time.perf_counter()
    try:
        traj = api.simulate(api.load(config))
        write_recording(traj, output)
    except InputError as exc:
        return CaseResult(str(config), None, "error", seconds=time.perf_counter() - started, message=str(exc))
    except Exception as exc:  # a crash in one case is reported, the batch goes on
        last = traceback.extract_tb(exc.__traceback__)[-1]
        return CaseResult(str(config), None, "error", seconds=time.perf_counter() - started,
                          message=f"{type(exc).__name__}: {exc} (at {Path(last.filename).name}:{last.lineno})")
    checks = evaluate_checks(traj)
    drift = traj.max_drift()
    worst = max(drift, key=drift.get) if drift else ""
    failed = [c for c in checks if not c.passed]
    return CaseResult(
        scenario=str(config),
        output=str(output),
        status="fail" if failed else "pass",
        method=traj.stats.method,
        steps=traj.stats.steps,
        seconds=time.perf_counter() - started,
        worst_invariant=worst,
        worst_drift=drift.get(worst, 0.0),
        checks=[{"name": c.name, "passed": c.passed, "value": c.value, "limit": c.limit, "message": c.message} for c in checks],
        message="; ".join(c.message for c in failed),
    )


def run_batch(configs: list[Path], outdir: Path, jobs: int) -> list[CaseResult]:
    """Run every config (``jobs`` processes; 1 = in this process); results in input order."""
    outdir.mkdir(parents=True, exist_ok=True)
    outputs = [outdir / f"{name}.rrd" for name in output_names(configs)]
    if jobs <= 1 or len(configs) == 1:
        return [run_case(c, o) for c, o in zip(configs, outputs)]
    with process_pool(jobs) as pool:
        return list(pool.map(run_case, configs, outputs))
