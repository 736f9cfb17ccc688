"""Accuracy checks of a run: the scenario's ``[checks]`` (invariant drift bounds, an expected flip
period) or, for a scenario without ``[checks]``, default bounds on every invariant of its scene.

Default bound on the max relative drift of each invariant of the scene (``rotlab batch``):

    bound = DEFAULT_RTOL_FACTOR · rtol + ROUNDOFF_FACTOR · ε · n          (stepping methods)
    bound = EXACT_BOUND + ROUNDOFF_FACTOR · ε · n                         (``exact``: no rtol)

with ``rtol = solver.rtol`` (the accuracy every method is asked for: adaptive methods control
their local error with it, fixed-step methods derive their step from it), ε the double precision
unit roundoff and n = max(steps, samples) (rounding errors accumulate at most linearly).  On the
shipped configs the largest drift of any method stays within about ten times its rtol: the
factor 100 leaves a further decade of margin and still fails a run whose step is far too coarse
for its tolerance (rk4 at step 1e-2 on the 150 rad/s top misses its bound by orders of
magnitude).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from rotlab.trajectory import Trajectory

AXES = {"x": 0, "y": 1, "z": 2}
DEFAULT_RTOL_FACTOR = 100.0
ROUNDOFF_FACTOR = 10.0
EXACT_BOUND = 1e-12
EPS = float(np.finfo(float).eps)
MIN_REVERSALS = 3  # sign changes needed to measure a flip period

SCENARIO, DEFAULT = "[checks]", "default"


@dataclass(frozen=True)
class CheckResult:
    name: str  # e.g. "max_drift.energy", "flip_period", "run"
    passed: bool
    value: float | None  # the measured figure; None when it could not be measured (see ``message``)
    limit: str  # what it was held to, in words
    message: str
    bound: float | None = None  # the numeric bound, where there is one
    source: str = SCENARIO  # SCENARIO (the file's [checks]) or DEFAULT (see ``default_bound``)
    basis: str = ""  # how a default bound was derived

    def as_dict(self) -> dict:
        """Strict-JSON form: non-finite numbers become null with the reason in ``message``."""
        doc = asdict(self)
        for key in ("value", "bound"):
            if doc[key] is not None and not math.isfinite(doc[key]):
                doc[key] = None
        if doc["value"] is None:
            doc["value_reason"] = self.message
        return doc


def has_checks(traj: Trajectory) -> bool:
    checks = traj.scene.scenario.checks
    return bool(checks.max_drift) or checks.flip_period is not None


def evaluate_checks(traj: Trajectory, defaults: bool = False) -> list[CheckResult]:
    """The scenario's checks; with ``defaults``, a scenario without ``[checks]`` gets a drift
    bound on every invariant of its scene (module docstring).  A stopped run always fails."""
    spec = traj.scene.scenario.checks.flip_period
    flip = None if spec is None else flip_period(traj.t, traj.omega[:, AXES[spec.axis]])
    default = default_bound(traj) if defaults and not has_checks(traj) else None
    return checks_of(traj.scene, traj.max_drift(), flip, traj.stats.failure, default)


def checks_of(scene, drift: dict[str, float], flip: tuple[float, int] | None, failure: str | None,
              default: tuple[float, str] | None = None) -> list[CheckResult]:
    """The checks of a run of ``scene`` from what was measured: the max drift of each invariant,
    the flip period and reversals of the ``[checks] flip_period`` axis (``flip_period``), the
    run's failure; ``default``: (bound, basis) held by every invariant (``default_bound``)."""
    checks = scene.scenario.checks
    results = []
    if default is not None:
        bound, basis = default
        results += [_drift_check(name, value, bound, DEFAULT, basis) for name, value in drift.items()]
    for name, bound in checks.max_drift.items():
        if name not in drift:
            results.append(CheckResult(f"max_drift.{name}", False, None, f"≤ {bound:g}",
                                       f"{name} is not an invariant of this {scene.kind} scene (it has {', '.join(drift)})", bound))
            continue
        results.append(_drift_check(name, drift[name], bound, SCENARIO, ""))
    if checks.flip_period is not None:
        results.append(_flip_check(checks.flip_period, *flip))
    if failure:
        results.append(CheckResult("run", False, None, "completes", failure))
    return results


def default_bound(traj: Trajectory) -> tuple[float, str]:
    """(bound on every invariant's max relative drift, how it was derived) — module docstring."""
    n = max(traj.stats.steps, traj.t.shape[0])
    roundoff = ROUNDOFF_FACTOR * EPS * n
    if traj.stats.method == "exact":
        return EXACT_BOUND + roundoff, f"exact method: {EXACT_BOUND:g} + {ROUNDOFF_FACTOR:g}·ε·{n:,} (roundoff)"
    rtol = traj.scene.scenario.solver.rtol
    return (DEFAULT_RTOL_FACTOR * rtol + roundoff,
            f"{DEFAULT_RTOL_FACTOR:g} × solver.rtol ({rtol:g}) + {ROUNDOFF_FACTOR:g}·ε·{n:,} (roundoff)")


def _drift_check(name: str, value: float, bound: float, source: str, basis: str) -> CheckResult:
    ok = bool(value <= bound)  # False for NaN
    if not math.isfinite(value):
        message = f"max |{name} drift| is {value} (the run blew up): not ≤ {bound:.3g}"
    else:
        message = f"max |{name} drift| = {value:.3e} {'≤' if ok else '>'} {bound:.3g}"
    return CheckResult(f"max_drift.{name}", ok, value, f"≤ {bound:.3g}", message, bound, source, basis)


def flip_times(t: np.ndarray, component: np.ndarray) -> np.ndarray:
    """Times where ``component`` changes sign, by linear interpolation between samples."""
    return _crossing(t, component, np.nonzero(_sign_changes(component))[0])


def _sign_changes(c: np.ndarray) -> np.ndarray:
    """(..., N − 1): c changes sign between samples k and k + 1."""
    s = np.sign(c)
    return s[..., :-1] * s[..., 1:] < 0


def _crossing(t: np.ndarray, c: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Where c (..., N) crosses zero between samples k and k + 1 (k indexes its last axis), by
    linear interpolation: t_k − c_k (t_{k+1} − t_k) / (c_{k+1} − c_k)."""
    ck, cn = np.take_along_axis(c, k, -1), np.take_along_axis(c, k + 1, -1)
    return t[k] - ck * (t[k + 1] - t[k]) / (cn - ck)


def flip_period(t: np.ndarray, component: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(period, reversals) of the sign changes of ``component`` (..., N) along its last axis, at
    times ``t`` (N,): twice their mean spacing, (last − first)/(reversals − 1), the crossings placed
    as in ``flip_times``; NaN with fewer than ``MIN_REVERSALS``.  One run or B stacked: (B,) each."""
    c = np.asarray(component, dtype=float)
    if c.shape[-1] < 2:
        return np.full(c.shape[:-1], math.nan)[()], np.zeros(c.shape[:-1], dtype=np.int64)[()]
    changes = _sign_changes(c)
    reversals = np.count_nonzero(changes, axis=-1)
    first = np.argmax(changes, axis=-1)[..., None]
    last = changes.shape[-1] - 1 - np.argmax(changes[..., ::-1], axis=-1)[..., None]
    with np.errstate(divide="ignore", invalid="ignore"):  # no reversal: first = last = 0, maybe 0/0
        period = period_of(_crossing(t, c, first)[..., 0], _crossing(t, c, last)[..., 0], reversals)
    return period[()], reversals[()]


def period_of(first: np.ndarray, last: np.ndarray, reversals: np.ndarray) -> np.ndarray:
    """The flip period from the first and last reversal times and the count: twice their mean
    spacing, 2 (last − first)/(reversals − 1); NaN with fewer than ``MIN_REVERSALS`` (also used by
    the ensemble, which folds the crossings as the samples come: ``rotlab.ensemble.observe``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        period = 2.0 * (last - first) / np.maximum(reversals - 1, 1)
    return np.where(reversals >= MIN_REVERSALS, period, math.nan)


def _flip_check(spec, period: float, reversals: int) -> CheckResult:
    limit = f"{spec.expected:g} s ± {100 * spec.rtol:g}%"
    if reversals < MIN_REVERSALS:
        return CheckResult("flip_period", False, None, limit,
                           f"ω_{spec.axis} reversed {reversals} times: need ≥ {MIN_REVERSALS} to measure a period (lengthen time.end)",
                           spec.expected)
    period = float(period)
    ok = abs(period - spec.expected) <= spec.rtol * spec.expected
    return CheckResult("flip_period", ok, period, limit, f"flip period {period:.6g} s {'within' if ok else 'outside'} {limit}", spec.expected)
