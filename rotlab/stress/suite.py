"""The stress suite.  Each check runs a hard scene and returns a figure held to a stated bound.

Checks marked ``quick`` form the ``--quick`` subset, each at its reduced size (``run(True)``): a
short pass that leaves out the suite's slowest checks.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.special import ellipk

import rotlab
from rotlab.checks import flip_times
from rotlab.config import parse_scenario
from rotlab.errors import InputError


ROUNDING = 1e-12  # drift below this is rounding, whose random walk may grow as √n


@dataclass(frozen=True)
class Outcome:
    name: str
    passed: bool
    figure: str  # what was measured
    bound: str  # what it is held to
    seconds: float = 0.0


@dataclass(frozen=True)
class Check:
    name: str
    run: Callable[[bool], Outcome]  # run(quick) → outcome
    quick: bool = True


def _scene(**sections) -> rotlab.simulate:
    data = {"time": {"end": 1.0}}
    data.update(sections)
    return rotlab.simulate(parse_scenario(data))


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(b))), 1e-300))


def _q_error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.minimum(np.linalg.norm(a - b, axis=1), np.linalg.norm(a + b, axis=1))))


def long_run(method: str, order: int | None, bound: float, stages: int = 1) -> Callable[[bool], Outcome]:
    """10⁷ fixed steps (10⁶ quick) of an asymmetric free body: max |energy drift| over the run,
    sampled every 100 steps, and no growth between the halves of the run.  The bound is the
    method's truncation bound or the rounding random walk 10·√(stages·steps)·ε, the larger."""

    def run(quick: bool) -> Outcome:
        steps = 10**6 if quick else 10**7
        h = 1e-3
        traj = _scene(body={"principal_moments": [1.0, 1.7, 2.3]}, initial={"omega": [0.4, 2.0, 0.3]},
                      time={"end": steps * h, "samples": steps // 100 + 1},
                      solver={"method": method, "step": h, **({"order": order} if order else {})})
        drift = np.abs(traj.invariants["energy"])
        first, second = float(np.max(drift[: len(drift) // 2])), float(np.max(drift[len(drift) // 2:]))
        limit = max(bound, 10.0 * np.sqrt(stages * steps) * np.finfo(float).eps)
        ok = max(first, second) <= limit and second <= 1.5 * first + ROUNDING  # below ROUNDING: a random walk
        return Outcome(f"{steps:.0e} steps, {method}{order or ''}: energy drift", ok,
                       f"max {max(first, second):.2e} (halves {first:.2e}, {second:.2e})", f"≤ {limit:.1e}, no growth")

    return run


def flip_period(quick: bool) -> Outcome:
    """Intermediate-axis flip: measured period of ω_y reversals vs 4K(m)/λ (Jacobi)."""
    moments, w0 = np.array([1e-4, 2e-4, 2.8e-4]), np.array([0.01, 10.0, 0.01])
    A, B, C = moments
    t2, l2 = float(moments @ w0**2), float(np.sum((moments * w0) ** 2))
    lam = np.sqrt((C - B) * (l2 - t2 * A) / (A * B * C))
    m = (B - A) * (t2 * C - l2) / ((C - B) * (l2 - t2 * A))
    expected = 4.0 * ellipk(m) / lam
    worst = 0.0
    for method in ("exact", "dop853"):
        traj = _scene(body={"principal_moments": moments.tolist()}, initial={"omega": w0.tolist()},
                      time={"end": 40.0, "sample_rate": 1000}, solver={"method": method, "rtol": 1e-12, "atol": 1e-14})
        crossings = flip_times(traj.t, traj.omega[:, 1])
        worst = max(worst, abs(2.0 * np.mean(np.diff(crossings)) - expected) / expected)
    return Outcome("Dzhanibekov flip period vs 4K(m)/λ", worst < 1e-7, f"relative error {worst:.1e} (exact, dop853)", "< 1e-7")


def near_separatrix(quick: bool) -> Outcome:
    """Start 1e-8 from the separatrix (moments 1, 2, 3): exact vs dop853 at rtol 1e-13 over
    40 s; the gap is the integrator's error amplified near the separatrix."""
    c = 1.0
    a = np.sqrt(3.0) * c * (1.0 + 1e-8)  # A a²(B − A) = C c²(C − B) on the separatrix
    runs = {m: _scene(body={"principal_moments": [1.0, 2.0, 3.0]}, initial={"omega": [a, 1e-3, c]},
                      time={"end": 40.0, "sample_rate": 10}, solver={"method": m, "rtol": 1e-13, "atol": 1e-15})
            for m in ("exact", "dop853")}
    gap = _rel(runs["exact"].omega, runs["dop853"].omega)
    drift = max(runs["exact"].max_drift().values())
    ok = gap < 1e-6 and drift < 1e-13
    return Outcome("start 1e-8 from the separatrix", ok, f"exact vs dop853 {gap:.1e}; exact invariants {drift:.1e}",
                   "< 1e-6; < 1e-13")


def nearly_spherical(quick: bool) -> Outcome:
    """Moments equal within 1e-9: exact and dop853 agree, nothing divides by the difference."""
    moments = [1.0, 1.0 + 1e-9, 1.0 + 2e-9]
    runs = {m: _scene(body={"principal_moments": moments}, initial={"omega": [0.3, -0.5, 0.8]},
                      time={"end": 100.0, "sample_rate": 10}, solver={"method": m, "rtol": 1e-13, "atol": 1e-15})
            for m in ("exact", "dop853")}
    gap = max(_rel(runs["exact"].omega, runs["dop853"].omega), _q_error(runs["exact"].quaternion, runs["dop853"].quaternion))
    return Outcome("nearly spherical body (ΔI/I = 1e-9)", gap < 1e-10, f"exact vs dop853 {gap:.1e}", "< 1e-10")


def flat_plate(quick: bool) -> Outcome:
    """The flat-plate limit A + B = C is a real body (accepted) and integrates normally."""
    runs = {m: _scene(body={"principal_moments": [1.0, 2.0, 3.0]}, initial={"omega": [0.5, 0.7, 1.1]},
                      time={"end": 50.0, "sample_rate": 10}, solver={"method": m, "rtol": 1e-13, "atol": 1e-15})
            for m in ("exact", "dop853")}
    gap = _rel(runs["exact"].omega, runs["dop853"].omega)
    return Outcome("flat plate A + B = C", gap < 1e-10, f"exact vs dop853 {gap:.1e}", "< 1e-10")


def fast_gyroscope(quick: bool) -> Outcome:
    """Spin 10³ rad/s, slow precession: exact vs dop853 and taylor (rtol 1e-13); the mean precession rate
    vs the gyroscopic limit mgl/(C r), which itself is off by about A·mgl/(C r)² ≈ 9e-4."""
    A, C, m, l, g, r = 1.1e-3, 5e-4, 0.5, 0.04, 9.81, 1000.0
    runs = {method: _scene(body={"principal_moments": [A, A, C], "mass": m, "center_of_mass": [0.0, 0.0, l]},
                           initial={"omega": [0.0, 0.0, r], "euler_313_deg": [0.0, 30.0, 0.0]},
                           loads=[{"type": "gravity", "g": [0.0, 0.0, -g]}], time={"end": 2.0, "sample_rate": 2000},
                           solver={"method": method, "rtol": 1e-13, "atol": 1e-15}, output={"euler_angles": True})
            for method in ("exact", "dop853", "taylor")}
    exact = runs["exact"]
    gaps = {m: max(_rel(exact.omega, runs[m].omega), _q_error(exact.quaternion, runs[m].quaternion)) for m in ("dop853", "taylor")}
    gap = max(gaps.values())
    rate = float(np.polyfit(exact.t, exact.euler_angles[:, 0], 1)[0])
    expected = m * g * l / (C * r)
    error = abs(rate - expected) / expected
    ok = gap < 1e-9 and error < 2e-3
    return Outcome("fast gyroscope (r = 10³ rad/s)", ok,
                   f"exact vs dop853 {gaps['dop853']:.1e}, vs taylor {gaps['taylor']:.1e}; precession {rate:.6f} vs mgl/(Cr) {expected:.6f} rad/s ({error:.1e})",
                   "< 1e-9; < 2e-3")


def sleeping_and_poles(quick: bool) -> Outcome:
    """A sleeping top stays up (θ = 0 exactly, angles finite); a body tumbling about x takes
    body z through θ = 0 and π: Euler angles finite, θ continuous, Λ unaffected (|Λ| − 1).
    Both run ``exact`` (named: ``auto`` may step, whose |Λ| − 1 is the integrator's, not the angles')."""
    top = _scene(body={"principal_moments": [1.1e-3, 1.1e-3, 5e-4], "mass": 0.5, "center_of_mass": [0.0, 0.0, 0.04]},
                 initial={"omega": [0.0, 0.0, 200.0]}, loads=[{"type": "gravity"}],
                 time={"end": 2.0, "sample_rate": 500}, output={"euler_angles": True}, solver={"method": "exact"})
    tumble = _scene(body={"principal_moments": [1.0, 2.0, 2.5]}, initial={"omega": [3.0, 0.0, 0.0]},
                    time={"end": 10.0, "sample_rate": 1000}, output={"euler_angles": True}, solver={"method": "exact"})
    theta = tumble.euler_angles[:, 1]
    finite = bool(np.all(np.isfinite(top.euler_angles)) and np.all(np.isfinite(tumble.euler_angles)))
    through = bool(np.min(theta) < 1e-2 and np.max(theta) > np.pi - 1e-2)
    jump = float(np.max(np.abs(np.diff(theta))))
    sleeping = float(np.max(top.euler_angles[:, 1]))
    norm = max(float(np.max(np.abs(top.invariants["quaternion_norm"]))), float(np.max(np.abs(tumble.invariants["quaternion_norm"]))))
    ok = finite and through and jump < 0.01 and sleeping < 1e-12 and norm < 1e-12
    return Outcome("sleeping top; θ through 0 and π", ok,
                   f"finite {finite}, θ range [{np.min(theta):.1e}, {np.max(theta):.4f}], max Δθ/sample {jump:.1e}, "
                   f"sleeping θ {sleeping:.1e}, |Λ|−1 {norm:.1e}", "finite; Δθ < 0.01; θ_sleep < 1e-12")


def inertia_scaling(quick: bool) -> Outcome:
    """Moments × 1e−9 and × 1e9 (no load): ω(t) and Λ(t) unchanged."""
    worst = 0.0
    for method in ("exact", "dop853", "taylor", "rk4", "splitting"):
        runs = [_scene(body={"principal_moments": [s, 2.0 * s, 2.5 * s]}, initial={"omega": [0.3, 1.0, 0.2]},
                       time={"end": 10.0, "sample_rate": 10}, solver={"method": method, "step": 1e-3})
                for s in (1.0, 1e-9, 1e9)]
        for other in runs[1:]:
            worst = max(worst, _rel(other.omega, runs[0].omega), _q_error(other.quaternion, runs[0].quaternion))
    return Outcome("inertia × 1e−9 and × 1e9", worst < 1e-12, f"max change {worst:.1e} (exact, dop853, taylor, rk4, splitting)", "< 1e-12")


def unstable_steps(quick: bool) -> Outcome:
    """A fixed step beyond the stability limit is refused with a message; dop853 adapts."""
    scene = {"body": {"principal_moments": [1.0, 2.0, 2.5]}, "initial": {"omega": [0.1, 50.0, 0.1]},
             "time": {"end": 1.0, "sample_rate": 10}}
    refused = ""
    try:
        rotlab.simulate(parse_scenario({**scene, "solver": {"method": "rk4", "step": 0.1}}))
    except InputError as exc:
        refused = str(exc)
    adapted = rotlab.simulate(parse_scenario({**scene, "solver": {"method": "dop853"}}), check=False)
    drift = max(adapted.max_drift().values())
    ok = "too large to be stable" in refused and adapted.stats.failure is None and drift < 1e-8
    return Outcome("rk4 at h·ω = 5: refused; dop853 adapts", ok,
                   f"refused: {'yes' if refused else 'NO'}; dop853 drift {drift:.1e}", "refused; < 1e-8")


CHECKS: list[Check] = [
    Check("long-splitting", long_run("splitting", 2, 1e-6)),
    Check("long-splitting8", long_run("splitting", 8, 1e-12, stages=17), quick=False),
    Check("long-dmv", long_run("dmv", None, 1e-6)),
    Check("flip-period", flip_period),
    Check("separatrix", near_separatrix),
    Check("near-sphere", nearly_spherical),
    Check("flat-plate", flat_plate),
    Check("fast-gyroscope", fast_gyroscope),
    Check("poles", sleeping_and_poles),
    Check("scaling", inertia_scaling),
    Check("unstable-step", unstable_steps),
]


def run_suite(quick: bool, report: Callable[[Outcome], None] | None = None) -> list[Outcome]:
    outcomes = []
    for check in CHECKS:
        if quick and not check.quick:
            continue
        started = time.perf_counter()
        try:
            outcome = check.run(quick)
        except Exception as exc:  # a crashing check is a failed check, with its reason
            outcome = Outcome(check.name, False, f"{type(exc).__name__}: {exc}", "runs")
        outcome = Outcome(outcome.name, outcome.passed, outcome.figure, outcome.bound, time.perf_counter() - started)
        outcomes.append(outcome)
        if report is not None:
            report(outcome)
    return outcomes
