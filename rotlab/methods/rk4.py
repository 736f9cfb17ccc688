"""``rk4``: classical fixed-step Runge–Kutta 4 — the seeds' baseline, compiled, no renormalisation.

Step: ``solver.step``; default min(sample interval, 0.01 / rate) with the scene's characteristic
rate (see ``Scene.rate_scale``).  Steps are shortened so that samples fall on steps exactly.
"""

from __future__ import annotations

import math

import numpy as np

from rotlab.core.dynamics import euler_coefficients
from rotlab.core import rk4 as kernel
from rotlab.methods.base import ProgressCallback, Settings, Solution
from rotlab.methods.stepping import initial_state, nonfinite_message, run_chunks
from rotlab.scene.scene import Scene


class RK4:
    name = "rk4"
    summary = "classical Runge–Kutta 4, fixed step"

    def unsupported(self, scene: Scene) -> str | None:
        return None

    def step(self, scene: Scene, t: np.ndarray, settings: Settings) -> float:
        interval = float(t[1] - t[0])
        if settings.step is not None:
            return settings.step
        rate = scene.rate_scale
        return interval if rate == 0.0 else min(interval, 0.01 / rate)

    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        interval = float(t[1] - t[0])
        substeps = max(1, math.ceil(interval / self.step(scene, t, settings) - 1e-9))
        out = np.empty((t.shape[0], 8))
        y = initial_state(scene.q0, scene.omega0)
        out[0] = y
        euler = euler_coefficients(scene.moments)
        loads = scene.loads.for_kernel()

        def advance(i: int, budget: int) -> tuple[int, int, int]:
            return kernel.rk4_advance(y, t, out, i, substeps, max(budget, substeps), euler, loads)

        solution = run_chunks(t, out, advance, settings.max_steps, progress, lambda status, i: nonfinite_message(t, i, out))
        solution.rhs_evaluations = 4 * solution.steps
        solution.details = {"step": interval / substeps, "steps per sample": substeps}
        return solution


METHOD = RK4()
