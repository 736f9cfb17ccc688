"""Base of the fixed-step methods: a compiled kernel with the signature

    advance(y, times, out, i_start, substeps, max_steps, euler, loads, *extra) → (status, i, steps)

that steps ``substeps`` equal steps per sample interval (see ``rotlab.core.rk4``).  A method
module only names its kernel, its cost and what it cannot do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from rotlab.core.dynamics import euler_coefficients
from rotlab.methods.base import ProgressCallback, Settings, Solution
from rotlab.methods.stepping import initial_state, nonfinite_message, run_chunks
from rotlab.scene.scene import Scene

DEFAULT_STEPS_PER_RADIAN = 100  # default step: 0.01 / (characteristic rate)


@dataclass(frozen=True)
class FixedStepMethod:
    name: str
    summary: str
    kernel: Callable
    evaluations_per_step: int
    requires: Callable[[Scene], str | None] = lambda scene: None  # why the scene is out of reach
    extra_args: Callable[[Scene, Settings], tuple] = lambda scene, settings: ()

    def unsupported(self, scene: Scene) -> str | None:
        return self.requires(scene)

    def step(self, scene: Scene, t: np.ndarray, settings: Settings) -> float:
        """``solver.step``, or min(sample interval, 0.01 / rate) from the scene's rate scale."""
        interval = float(t[1] - t[0])
        if settings.step is not None:
            return settings.step
        rate = scene.rate_scale
        return interval if rate == 0.0 else min(interval, 1.0 / (DEFAULT_STEPS_PER_RADIAN * rate))

    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        interval = float(t[1] - t[0])
        substeps = max(1, math.ceil(interval / self.step(scene, t, settings) - 1e-9))
        out = np.empty((t.shape[0], 8))
        y = initial_state(scene.q0, scene.omega0)
        out[0] = y
        euler = euler_coefficients(scene.moments)
        loads = scene.loads.for_kernel()
        extra = self.extra_args(scene, settings)

        def advance(i: int, budget: int) -> tuple[int, int, int]:
            return self.kernel(y, t, out, i, substeps, max(budget, substeps), euler, loads, *extra)

        solution = run_chunks(t, out, advance, settings.max_steps, progress, lambda status, i: nonfinite_message(t, i, out))
        solution.rhs_evaluations = self.evaluations_per_step * solution.steps
        solution.details = {"step": interval / substeps, "steps per sample": substeps}
        return solution
