"""Accuracy checks of a run (a scenario's ``[checks]``): invariant drift bounds and an expected
flip period."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rotlab.trajectory import Trajectory

AXES = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class CheckResult:
    name: str  # e.g. "max_drift.energy", "flip_period"
    passed: bool
    value: float  # the measured figure
    limit: str  # what it was held to
    message: str


def evaluate_checks(traj: Trajectory) -> list[CheckResult]:
    checks = traj.scene.scenario.checks
    results = []
    drift = traj.max_drift()
    for name, bound in checks.max_drift.items():
        if name not in drift:
            results.append(CheckResult(f"max_drift.{name}", False, float("nan"), f"≤ {bound:g}",
                                       f"{name} is not an invariant of this {traj.scene.kind} scene (it has {', '.join(drift)})"))
            continue
        value = drift[name]
        ok = bool(value <= bound)
        results.append(CheckResult(f"max_drift.{name}", ok, value, f"≤ {bound:g}", f"max |{name} drift| = {value:.3e} {'≤' if ok else '>'} {bound:g}"))
    if checks.flip_period is not None:
        results.append(_flip_period(traj, checks.flip_period))
    if traj.stats.failure:
        results.append(CheckResult("run", False, float("nan"), "completes", traj.stats.failure))
    return results


def flip_times(t: np.ndarray, component: np.ndarray) -> np.ndarray:
    """Times where ``component`` changes sign, by linear interpolation between samples."""
    s = np.sign(component)
    k = np.nonzero(s[:-1] * s[1:] < 0)[0]
    return t[k] - component[k] * (t[k + 1] - t[k]) / (component[k + 1] - component[k])


def _flip_period(traj: Trajectory, spec) -> CheckResult:
    crossings = flip_times(traj.t, traj.omega[:, AXES[spec.axis]])
    limit = f"{spec.expected:g} s ± {100 * spec.rtol:g}%"
    if crossings.size < 3:
        return CheckResult("flip_period", False, float("nan"), limit,
                           f"ω_{spec.axis} reversed {crossings.size} times: need ≥ 3 to measure a period (lengthen time.end)")
    period = 2.0 * float(np.mean(np.diff(crossings)))
    ok = abs(period - spec.expected) <= spec.rtol * spec.expected
    return CheckResult("flip_period", ok, period, limit, f"flip period {period:.6g} s {'within' if ok else 'outside'} {limit}")
