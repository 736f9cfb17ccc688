"""Base of the fixed-step methods: a compiled kernel with the signature

    advance(y, times, out, i_start, substeps, max_steps, model, *extra) → (status, i, steps)

that steps ``substeps`` equal steps per sample interval (see ``rotlab.core.rk4``).  A method
module only names its kernel, the orders it offers, its cost and what it cannot do.

Step size: ``solver.step`` when given; otherwise the step that meets ``solver.rtol`` over the
whole span, from a probe: the method runs over a short span with steps h₀ and h₀/2, the
difference estimates the error e ≈ |y_{h₀} − y_{h₀/2}| / (2^p − 1) of the finer run, and with
error ∝ h^p · (elapsed time) the step for the run is
    h = (h₀/2) · (rtol / (e · span / probe span))^(1/p).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from rotlab.errors import InputError
from rotlab.methods import cost
from rotlab.methods.base import FIXED, LocalSolution, ProgressCallback, Settings, Solution
from rotlab.methods.stepping import CHUNK_STEPS, initial_state, run_chunks, state_failure_message
from rotlab.scene.scene import Scene

PROBE_RADIANS = 20.0  # probe span: about 20 rad of the scene's characteristic rotation
PROBE_STEPS = 40  # coarse steps in the probe


@dataclass(frozen=True)
class FixedStepMethod:
    name: str
    summary: str
    kernel: Callable
    order_of_accuracy: int  # p when the method has one order (else see ``orders``)
    evaluations_per_step: Callable[[Scene, int], int]  # force / right-hand-side evaluations per step
    requires: Callable[[Scene], str | None] = lambda scene: None  # why the scene is out of reach
    extra_args: Callable[[Scene, int], tuple] = lambda scene, order: ()
    orders: tuple[int, ...] = ()  # orders offered through ``solver.order`` (empty: just one)
    default_order: int | None = None
    step_limit: float = 2.0  # largest h·ω (rad per step) that is stable / meaningful
    auto_orders: tuple[int | None, ...] = ()  # the orders ``auto`` weighs (None: the one order); empty: never by cost
    auto_applies: Callable[[Scene], bool] = lambda scene: True  # where ``auto`` weighs it (besides ``requires``)
    auto_probe: bool = True  # auto lets it derive its step from its own probe (else: the cost model's a priori step)
    given_step_preference: int | None = None  # rank when auto is given solver.step (``rotlab.methods.base.Method``)
    stepping = FIXED
    adaptive = False
    ends_steps_at_switches = False

    def auto_estimates(self, scene: Scene, settings: Settings, work: cost.Work) -> list[cost.Estimate]:
        """Each order of ``auto_orders`` at the step that meets rtol (``cost.fixed_step_estimate``;
        the probe aims at rtol itself, amplified near a separatrix)."""
        if not self.auto_applies(scene):
            return []
        target = settings.rtol / work.amplification
        return [cost.fixed_step_estimate(self.name, k, self.order_of_accuracy if k is None else k, target, work, step_limit=self.step_limit,
                                         probe=self.auto_probe) for k in self.auto_orders if settings.order in (None, k)]

    def auto_settings(self, estimate: cost.Estimate, settings: Settings) -> Settings:
        """The estimate's order, at its a priori step or (``auto_probe``) the method's own probe's."""
        return replace(settings, step=None if self.auto_probe else estimate.step, order=estimate.order)

    def unsupported(self, scene: Scene) -> str | None:
        return self.requires(scene)

    def order(self, settings: Settings) -> int:
        if not self.orders:
            return self.order_of_accuracy
        order = self.default_order if settings.order is None else settings.order
        if order not in self.orders:
            raise InputError("solver.order", f"{self.name} offers orders {', '.join(map(str, self.orders))} (got {order})")
        return int(order)

    def step(self, scene: Scene, t: np.ndarray, settings: Settings, order: int) -> float:
        """``solver.step``, or the step that meets ``solver.rtol`` (see the module docstring)."""
        if settings.step is not None:
            rate = scene.rate_scale
            if settings.step * rate > self.step_limit:
                raise InputError(
                    "solver.step",
                    f"{settings.step:g} s is too large to be stable: h·ω = {settings.step * rate:.3g} rad exceeds "
                    f"{self.name}'s limit {self.step_limit:g}; use step ≤ {self.step_limit / rate:.3g} s, "
                    "or omit step to derive it from rtol",
                )
            self._check_windows(scene, settings.step)
            return settings.step
        h = self.step_for_tolerance(scene, t, settings.rtol, order)
        return min(h, scene.shortest_window / 4.0)

    def _check_windows(self, scene: Scene, step: float) -> None:
        window = scene.shortest_window
        if step > window / 2.0:
            raise InputError(
                "solver.step",
                f"{step:g} s is too long for a load that acts for only {window:g} s (a window or table segment): "
                f"it would be sampled too coarsely or missed; use step ≤ {window / 4.0:.3g} s or method = \"dop853\"",
            )

    def step_for_tolerance(self, scene: Scene, t: np.ndarray, rtol: float, order: int) -> float:
        span = float(t[-1] - t[0])
        rate = scene.rate_scale or 1.0 / span
        probe_span = min(span, PROBE_RADIANS / rate)
        h0 = probe_span / PROBE_STEPS
        coarse, fine = (self._probe(scene, t[0], probe_span, n, order) for n in (PROBE_STEPS, 2 * PROBE_STEPS))
        omega_scale = max(float(np.max(np.abs(fine[4:7]))), float(np.linalg.norm(scene.omega0)), rate * float(np.min(scene.moments)) / float(np.max(scene.moments)))
        difference = max(float(np.max(np.abs(coarse[0:4] - fine[0:4]))), float(np.max(np.abs(coarse[4:7] - fine[4:7]))) / omega_scale)
        error = difference / (2.0**order - 1.0)
        if not np.isfinite(error):
            return h0 / 8.0
        if error == 0.0:  # exact for this scene at the probe's resolution
            return h0
        h = 0.5 * h0 * (rtol / (error * span / probe_span)) ** (1.0 / order)
        return float(min(h, h0))

    def _probe(self, scene: Scene, t0: float, span: float, steps: int, order: int) -> np.ndarray:
        times = np.array([t0, t0 + span])
        y = initial_state(scene)
        out = np.empty((2, y.shape[0]))
        self.kernel(y, times, out, 1, steps, steps, scene.model, *self.kernel_args(scene, order))
        return y

    def kernel_args(self, scene: Scene, order: int) -> tuple:
        """The method's extra kernel arguments (after ``scene.model``), once per scene."""
        return scene.rigid.kernel_constants(self.name, order, lambda: tuple(self.extra_args(scene, order)))

    def sampling(self, scene: Scene, t: np.ndarray, settings: Settings, order: int) -> tuple[int, dict[str, object]]:
        """(steps per sample interval, the run's details) for ``scene`` over the sample times ``t``;
        an ``InputError`` when the run would need more than ``solver.max_steps`` (known before
        stepping, unless a terminal event may end the run sooner: the budget then stops it while
        it steps, as an adaptive method's)."""
        interval = float(t[1] - t[0])
        h = self.step(scene, t, settings, order)
        substeps = max(1, math.ceil(interval / h - 1e-9))
        needed = substeps * (t.shape[0] - 1)
        ends_early = any(event.terminal for event in scene.scenario.events)
        if needed > settings.max_steps and not ends_early:  # known before stepping: refuse rather than run into the budget
            raise InputError(
                "solver.max_steps",
                f"{self.name} needs {needed:.3g} steps of {interval / substeps:.3g} s for this span, beyond max_steps = "
                f"{settings.max_steps:,}: raise solver.max_steps, give a longer solver.step or looser rtol, or use method = \"auto\"",
            )
        return substeps, {"step": interval / substeps, "steps per sample": substeps, "order": order,
                          "step from": "solver.step" if settings.step is not None else f"rtol = {settings.rtol:g}"}

    def local_solution(self, scene: Scene, t: np.ndarray, settings: Settings) -> LocalSolution:
        """The run's ``substeps`` equal steps over [t0, t1] (``Method.local_solution``): over a
        whole sample interval, the run's own steps."""
        order = self.order(settings)
        substeps, _ = self.sampling(scene, t, settings, order)
        model, extra = scene.model, self.kernel_args(scene, order)
        out = np.empty((2, scene.state0.shape[0]))

        def advance(y0: np.ndarray, t0: float, t1: float) -> np.ndarray:
            y = y0.copy()
            self.kernel(y, np.array([t0, t1]), out, 1, substeps, substeps, model, *extra)
            return y

        return advance

    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        order = self.order(settings)
        substeps, details = self.sampling(scene, t, settings, order)
        y = initial_state(scene)
        model, extra = scene.model, self.kernel_args(scene, order)
        advance = _long_samples(self.kernel, y, substeps, (model, *extra)) if substeps > CHUNK_STEPS else (
            lambda times, out, i, budget: self.kernel(y, times, out, i, substeps, budget, model, *extra))
        solution = run_chunks(t, y, advance, settings.max_steps, progress, state_failure_message,
                              explain_fault=scene.explain_fault)
        solution.rhs_evaluations = self.evaluations_per_step(scene, order) * solution.steps
        solution.details = details
        return solution


def _long_samples(kernel: Callable, y: np.ndarray, substeps: int, args: tuple) -> Callable:
    """``advance`` for samples longer than a chunk of steps: each sample interval is cut into
    m = ⌈substeps / CHUNK_STEPS⌉ equal pieces of ⌈substeps / m⌉ steps, one piece per call, so
    Ctrl-C, the step budget and the wall-clock limit are honoured inside a sample."""
    pieces = math.ceil(substeps / CHUNK_STEPS)
    per_piece = math.ceil(substeps / pieces)
    scratch = np.empty((2, y.shape[0]))
    position = {"piece": 0}

    def advance(times: np.ndarray, out: np.ndarray, i: int, budget: int) -> tuple[int, int, int]:
        if per_piece > budget:  # not enough of the step budget left for a piece
            return 0, i, 0
        k = position["piece"]
        t0, t1 = float(times[i - 1]), float(times[i])
        scratch_times = np.array([t0 + k * (t1 - t0) / pieces, t1 if k == pieces - 1 else t0 + (k + 1) * (t1 - t0) / pieces])
        status, _, taken = kernel(y, scratch_times, scratch, 1, per_piece, per_piece, *args)
        if status != 0:
            return status, i, taken
        if k < pieces - 1:
            position["piece"] = k + 1
            return 0, i, taken
        position["piece"] = 0
        out[i] = y
        return 0, i + 1, taken

    return advance
