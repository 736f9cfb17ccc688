"""``auto``'s cost model: the expected wall time and error of each method on a scene, a priori
(no probe runs, no kernel calls: a few dozen float operations per candidate).

Cost (seconds) = per_call + per_step(method, scene) · steps + per_sample · samples, with the
constants measured once by ``benchmarks/fit_cost_model.py`` (``CONSTANTS``, pasted from its output).

Steps, over a span T of a scene with rate scale Ω (``Scene.rate_scale``) and n samples:

* fixed-step method of order p: the error of a run is err ≈ C (hΩ)^p ΩT (C measured from each
  method's own tolerance probe on the bench problems, the largest kept), so the step that meets a
  target ε is hΩ = min(x_max, (ε / (C ΩT))^(1/p)), and the run takes ⌈interval / h⌉ steps per
  sample interval (at least one);
* ``taylor`` at order N and local tolerance ε: Jorba–Zou's step is h ≈ ρ (ε/M)^(1/(N−1)) e^(−0.7/(N−1))
  for a radius of convergence ρ, i.e. hΩ = R exp(−(ln(1/ε) + 0.7)/(N − 1)); R = 4.4 is the median
  over the bench problems (0.38–1.12 rad per step at order 13, rtol 1e-10: R within ×0.6–×1.8).
  One more step per load breakpoint;
* ``dop853`` at local tolerance ε: its step controller keeps hΩ ≈ R₈ ε^(1/8) (R₈ from the median
  rotation per step over the bench problems at rtol 1e-10), 12 evaluations a step; its global
  error is up to G ε, G the largest ratio of error to rtol measured on the bench problems of the
  scene's load kind (large where the motion amplifies errors: general.toml), so ``auto`` runs it
  at ε = rtol / (G · amplification), at least ``DOP853_MIN_TOLERANCE``;
* ``exact``: no steps, a set-up and a cost per sample, and no numba kernel.

A formula load adds to every step a cost proportional to its programs' rows r (operations,
leaves and auxiliary series, ``formula_rows``): r · c per step of a method that evaluates the
formula (``rk4``: 4 calls a step, ``dop853``: 12), and r · (a + b N²) per ``taylor`` step, which
forms each row's Taylor series to order N by interpreting the programs.

The costs are steady-state costs: loading a kernel from numba's cache, paid once per process,
is not part of them, so that a choice does not depend on what the process ran before.

Near the separatrix of a free asymmetric body every stepping method loses accuracy: an error δ
in the modulus m moves the flip period 4K(m)/λ by δK ≈ δ / (2 m₁) (m₁ = 1 − m), so the flips
drift in time by ~δ ΩT / (m₁ K) radians over the run.  With κ = ΩT / (m₁ K(m)):
* rounding (δ ~ u per step) gives a floor ≈ F u κ, F = 8 (dzhanibekov.toml: m₁ = 1.4e-6,
  κ = 2.6e7, best stepping error 7.7e-10);
* a method's own error is amplified by 1 + γ κ, γ = 2.5e-5 (taylor on dzhanibekov.toml and
  sweep_flip.toml: 280–2600× its tolerance; on the bench's other free bodies κ ≤ 110: ×1.003).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

CONSTANTS = {  # printed by python benchmarks/fit_cost_model.py
    "exact_asymmetric": {"per_call": 0.00109, "per_sample": 9.28e-07},
    "exact_axisymmetric": {"per_call": 0.000473, "per_sample": 4.06e-07},
    "exact_lagrange": {"per_call": 0.0024, "per_sample": 1.71e-06},
    "dmv": {"per_call": 6.9e-06, "per_step_a": 5.06e-08, "per_step_b": 1.19e-08, "per_sample": 4.71e-08},
    "splitting-2": {"free": 5.64e-08, "forces": 9.35e-08, "per_call": 6.4e-06, "per_sample": 2.94e-08},
    "splitting-4": {"free": 2.82e-07, "forces": 4.47e-07, "per_call": 6.42e-06, "per_sample": 3.14e-08},
    "splitting-6": {"free": 8.86e-07, "forces": 8.02e-07, "per_call": 6.73e-06, "per_sample": 1.86e-08},
    "splitting-8": {"free": 9.56e-07, "forces": 1.53e-06, "per_call": 7.05e-06, "per_sample": 2.91e-08},
    "rk4": {"free": 4.09e-08, "forces": 9.06e-08, "loads": 2.61e-07, "per_call": 6.18e-06, "per_sample": 6.72e-09},
    "taylor": {"free": {"a": 1.71e-07, "b": 1.55e-09}, "forces": {"a": 2.12e-07, "b": 2.21e-09}, "loads": {"a": 3.4e-07, "b": 5.22e-09},
               "per_sample": 3.37e-08, "per_call": 8.78e-06},
    # dop853, formula_row, dop853_* (2026-11-28, --only dop853 formulas --repeats 9; dop853-accuracy; load average 1.2-1.4):
    "dop853": {"free": 5.29e-07, "forces": 6.6e-07, "loads": 2.39e-06, "per_call": 2.72e-05, "per_sample": 3.83e-08},
    "formula_row": {"rk4": 2.35e-10, "dop853": 7.95e-10, "taylor": {"a": 1.78e-08, "b": 8.24e-10}},
    "dop853_radians_per_step": 0.398,  # median over the bench problems at rtol 1e-10 (range 0.0213-0.917)
    "dop853_error_ratio": {"free": 7.28, "forces": 7.83e+04, "loads": 3.03e+03},
    "error_constants": {"dmv-8": 8.4e-06, "dmv-10": 2.53e-07, "dmv-12": 7.36e-09, "splitting-2": 0.0152, "splitting-4": 0.000738,
                        "splitting-6": 5.58e-05, "splitting-8": 3.76e-08, "rk4": 0.00252},
    "taylor_radians_per_step": 0.614,  # median over the bench problems at order 13, rtol 1e-10 (range 0.381–1.12)
    "taylor_order": 13,
}

PROBE_PYTHON = 2.5e-5  # s: a tolerance probe's Python work around its 120 steps
UNIT_ROUNDOFF = 2.0**-53
SEPARATRIX_FACTOR = 8.0  # F of the error floor (module docstring)
EXACT_ERROR = 1e-13  # the exact solutions' error bound in the tests (vs mpmath, 40 digits): ≤ 1e-12 near the separatrix, 1e-15-ish elsewhere
MAX_ROTATION_PER_STEP = 0.5  # rad: the fixed-step probe's own cap (h ≤ probe span / 40 = 20 rad / 40)
TAYLOR_EXTRA_ORDERS = 3  # taylor orders tried: Jorba–Zou's N₀ to N₀ + 3 (above, the bench's errors grow: docs/benchmarks.md)
DOP853_MIN_TOLERANCE = 1e-14  # below, its error stops falling with the tolerance (magnetic_dipole over 6,000 s:
                              # 8.2e-11 at 1e-14, 3.5e-11 at 3e-15 and 1e-15; gravity_gradient 8.4e-12, 7.9e-12, 1.4e-11)
AMPLIFICATION = 2.5e-5  # γ of the error amplification 1 + γ κ near the separatrix (module docstring)


def _taylor_radius() -> float:
    """R of hΩ = R exp(−(ln(1/ε) + 0.7)/(N − 1)), from the measured rotation per step at order 13, rtol 1e-10."""
    n = CONSTANTS["taylor_order"]
    return CONSTANTS["taylor_radians_per_step"] * math.exp((math.log(1e10) + 0.7) / (n - 1))


TAYLOR_RADIUS = _taylor_radius()


class Estimate(NamedTuple):
    """One candidate: registry name, expected seconds and max error, and what it runs with
    (``order``, ``step`` None: the method derives it; ``rtol`` for taylor; ``probe``: the run
    takes the step of its own tolerance probe, of which ``step`` is the a priori estimate)."""

    method: str
    seconds: float
    error: float
    order: int | None = None
    step: float | None = None
    rtol: float | None = None
    probe: bool = False

    @property
    def label(self) -> str:
        name = self.method if self.order is None or self.method == "taylor" else f"{self.method}-{self.order}"
        if self.method == "taylor":
            return f"taylor order {self.order}"
        if self.rtol is not None:
            return f"{name} (its rtol {self.rtol:.2g})"
        if self.step is None:
            return name
        return f"{name} (its probe's step, a priori h ≈ {self.step:.3g} s)" if self.probe else f"{name} (h = {self.step:.3g} s)"


@dataclass(frozen=True)
class Work:
    """What the cost depends on: span T (s), samples n, rate scale Ω (rad/s), breakpoints, load kind
    ("free" | "forces" | "loads"), the stepping methods' error floor and the size of the formula
    loads; ``radians`` ΩT and the
    sample ``interval`` T/(n − 1) follow (computed once: every estimate reads them)."""

    span: float
    samples: int
    rate: float
    breakpoints: int
    loads: str
    floor: float
    amplification: float = 1.0  # how much a stepping method's error exceeds its tolerance (separatrix)
    formula_rows: int = 0  # rows of the formula loads' programs (module docstring)
    radians: float = field(init=False)
    interval: float = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "radians", self.rate * self.span)
        object.__setattr__(self, "interval", self.span / max(self.samples - 1, 1))


def exact_estimate(kind: str, work: Work) -> Estimate:
    """``kind``: "asymmetric", "axisymmetric" or "lagrange"."""
    c = CONSTANTS[f"exact_{kind}"]
    return Estimate("exact", c["per_call"] + c["per_sample"] * work.samples, EXACT_ERROR)


def fixed_step_estimate(name: str, order: int | None, p: int, target: float, work: Work, step_limit: float = 2.0,
                        probe: bool = False) -> Estimate:
    """A fixed-step method of order p run at the step that meets ``target``; ``step`` in the result
    is that step fitted to the sample interval (an integer number of steps per interval).
    ``probe``: the method will derive its step from its own tolerance probe (two runs of 40 and 80
    steps, and ``PROBE_PYTHON`` of Python around them), which the estimate then includes."""
    label = name if order is None else f"{name}-{order}"
    constant = CONSTANTS["error_constants"][label]
    radians, rotation = work.radians, work.interval * work.rate  # over the run, and per sample interval
    x = min(MAX_ROTATION_PER_STEP, step_limit, (target / (constant * max(radians, 1e-300))) ** (1.0 / p))
    per_interval = max(1, math.ceil(rotation / x - 1e-9))
    steps = per_interval * max(work.samples - 1, 1)
    if name == "dmv":
        c = CONSTANTS["dmv"]
        x_run = max(min(rotation / per_interval, 0.9), 1e-12)
        per_step = c["per_step_a"] + c["per_step_b"] / -math.log(x_run)
    else:
        c = CONSTANTS[label]
        per_step = c.get(work.loads, c.get("forces", 0.0)) + CONSTANTS["formula_row"].get(label, 0.0) * work.formula_rows
    seconds = c["per_call"] + per_step * steps + c["per_sample"] * work.samples
    if probe:
        seconds += 2.0 * c["per_call"] + 120.0 * per_step + PROBE_PYTHON
    error = max(constant * x**p * radians * work.amplification, work.floor)
    return Estimate(name, seconds, error, order, work.interval / per_interval, probe=probe)


def taylor_seconds(order: int, tolerance: float, work: Work) -> float:
    """Expected seconds of ``taylor`` at ``order`` and local tolerance ``tolerance`` (module docstring)."""
    c = CONSTANTS["taylor"]
    x = TAYLOR_RADIUS * math.exp(-(math.log(1.0 / tolerance) + 0.7) / (order - 1))
    steps = work.radians / x + work.breakpoints + 1
    row = CONSTANTS["formula_row"]["taylor"]
    per_row = row["a"] + row["b"] * order * order
    per_step = c[work.loads]["a"] + c[work.loads]["b"] * order * order + per_row * work.formula_rows
    return c["per_call"] + per_step * steps + c["per_sample"] * work.samples


def taylor_estimate(order: int | None, tolerance: float, work: Work) -> Estimate:
    """``taylor`` at local tolerance ``tolerance`` and ``order`` (None: the cheapest of Jorba–Zou's
    order N₀ to N₀ + ``TAYLOR_EXTRA_ORDERS``).  Expected error: the tolerance times the
    amplification (the Jorba–Zou step keeps the bench's errors at 0.01–20× the tolerance)."""
    if order is None:
        first = max(4, math.ceil(-0.5 * math.log(tolerance)) + 1)
        seconds, order = min((taylor_seconds(n, tolerance, work), n) for n in range(first, first + TAYLOR_EXTRA_ORDERS + 1))
    else:
        seconds = taylor_seconds(order, tolerance, work)
    error = max(tolerance * work.amplification, work.floor)
    return Estimate("taylor", seconds, error, order, None, tolerance)


def dop853_estimate(rtol: float, work: Work) -> Estimate:
    """``dop853`` run at the local tolerance ε = rtol / (G · amplification) that is expected to meet
    rtol (module docstring), at least ``DOP853_MIN_TOLERANCE``."""
    c = CONSTANTS["dop853"]
    ratio = CONSTANTS["dop853_error_ratio"][work.loads] * work.amplification
    tolerance = max(rtol / ratio, DOP853_MIN_TOLERANCE)
    x = CONSTANTS["dop853_radians_per_step"] * (tolerance / 1e-10) ** 0.125
    steps = work.radians / x + work.breakpoints + 1
    per_step = c[work.loads] + CONSTANTS["formula_row"]["dop853"] * work.formula_rows
    seconds = c["per_call"] + per_step * steps + c["per_sample"] * work.samples
    return Estimate("dop853", seconds, max(tolerance * ratio, work.floor), None, None, tolerance)


def separatrix(moments: Sequence[float], omega: Sequence[float], span: float, rate: float) -> tuple[float, float]:
    """(error floor, error amplification) of time stepping on a free asymmetric body (module
    docstring); (0, 1) when symmetric."""
    a, b, c = sorted(moments)
    if not a < b < c:
        return 0.0, 1.0
    i = sorted(range(3), key=lambda k: moments[k])
    w = [omega[k] for k in i]
    two_t = a * w[0] ** 2 + b * w[1] ** 2 + c * w[2] ** 2
    if two_t <= 0.0:
        return 0.0, 1.0
    d = ((a * w[0]) ** 2 + (b * w[1]) ** 2 + (c * w[2]) ** 2) / two_t  # L² / 2T, in [A, C]
    if d >= b:
        m1 = (c - a) * (d - b) / ((c - b) * max(d - a, 1e-300))
    else:
        m1 = (c - a) * (b - d) / ((b - a) * max(c - d, 1e-300))
    m1 = min(max(m1, 1e-300), 1.0)
    k = math.pi / (2.0 * _agm(1.0, math.sqrt(m1)))  # K(m), m = 1 − m₁
    kappa = rate * span / (m1 * k)
    return SEPARATRIX_FACTOR * UNIT_ROUNDOFF * kappa, 1.0 + AMPLIFICATION * kappa


def _agm(x: float, y: float) -> float:
    for _ in range(60):
        if abs(x - y) <= 1e-15 * x:
            break
        x, y = 0.5 * (x + y), math.sqrt(x * y)
    return x
