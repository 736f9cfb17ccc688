"""``dop853``: adaptive Dormand–Prince 8(5,3) with dense output, sampled exactly at the output
times (``solver.rtol``, ``solver.atol``)."""

from __future__ import annotations

import numpy as np

from rotlab.methods.base import ADAPTIVE, LocalSolution, ProgressCallback, Settings, Solution
from rotlab.methods.cost import Estimate, Work, dop853_estimate
from rotlab.methods.stepping import adaptive_failure_message, initial_state, run_chunks
from rotlab.scene.scene import Scene


class DOP853:
    name = "dop853"
    summary = "adaptive Dormand–Prince 8(5,3) with dense output"
    stepping = ADAPTIVE
    adaptive = True  # steps chosen from rtol/atol, not a fixed step
    orders: tuple[int, ...] = ()
    order_of_accuracy = 8
    given_step_preference = None
    ends_steps_at_switches = False

    def evaluations_per_step(self, scene: Scene, order: int | None) -> int:
        return 12  # 12 stages, the 13th is the next step's first (FSAL); dense output adds 3 per sampled step

    def unsupported(self, scene: Scene) -> str | None:
        return None

    def auto_estimates(self, scene: Scene, settings: Settings, work: Work) -> list[Estimate]:
        """At the local tolerance expected to meet rtol (``cost.dop853_estimate``).  None where a
        load switches (abs, sign, min or max) with no breakpoint: its steps cross the kink and
        its error is erratic in the tolerance (detumbling.toml: 100 to 3e5 × rtol over rtol
        1e-13 … 1e-10, against taylor's 1–23, whose steps end at the switches); none for a Python
        torque or a driven rotor, whose cost and smoothness no model covers (auto then runs it
        for its error control, ``rotlab.methods.choose``); none with ``solver.order`` (it has one)."""
        if scene.has_switches or scene.loads.drives is not None or settings.order is not None:
            return []
        return [dop853_estimate(settings.rtol, work)]

    def auto_settings(self, estimate: Estimate, settings: Settings) -> Settings:
        """The estimate's local tolerance (atol scaled alike)."""
        return settings.at_tolerance(estimate.rtol, None)

    def local_solution(self, scene: Scene, t: np.ndarray, settings: Settings) -> LocalSolution:
        """Its steps from (t0, y) at the run's tolerances, ending at t1 (``Method.local_solution``)."""
        from rotlab.core import dop853 as kernel

        model, counters, grid, out = scene.model, np.zeros(3, dtype=np.int64), np.empty(2), np.empty((2, scene.state0.shape[0]))

        def advance(y0: np.ndarray, t0: float, t1: float) -> np.ndarray:
            y = y0.copy()
            kernel.dop853_local(y, t0, t1, grid, out, settings.rtol, settings.atol, settings.max_steps, model, counters)
            return y

        return advance

    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        from rotlab.core import dop853 as kernel  # (imported when it runs, not when auto weighs it)

        y = initial_state(scene)
        model = scene.model
        counters = np.zeros(3, dtype=np.int64)
        clock = {"t": float(t[0]), "h": 0.0}

        def advance(times: np.ndarray, out: np.ndarray, i: int, budget: int) -> tuple[int, int, int]:
            before = int(counters[0] + counters[1])
            status, i, clock["t"], clock["h"] = kernel.dop853_advance(
                y, clock["t"], clock["h"], times, out, i, float(times[-1]), settings.rtol, settings.atol, budget, model, counters
            )
            return status, i, int(counters[0] + counters[1]) - before

        def describe(status: int, times: np.ndarray, out: np.ndarray, i: int) -> str:
            return adaptive_failure_message(status, clock["t"], times, out, i)

        solution = run_chunks(t, y, advance, settings.max_steps, progress, describe, lambda: clock["t"], explain_fault=scene.explain_fault)
        solution.steps = int(counters[0])
        solution.rejected_steps = int(counters[1])
        solution.rhs_evaluations = int(counters[2])
        solution.details = {"rtol": settings.rtol, "atol": settings.atol}
        return solution


METHOD = DOP853()
