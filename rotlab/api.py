"""Python API for notebooks and scripts — the same objects the CLI uses.

    >>> import rotlab
    >>> traj = rotlab.simulate("configs/lagrange.toml")
    >>> traj.t, traj.quaternion, traj.omega, traj.L_space, traj.total
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from rotlab.config import load_scenario
from rotlab.config.models import Scenario
from rotlab.methods.base import ProgressCallback, Settings
from rotlab.methods.choose import choose_method
from rotlab.scene.scene import Scene, build_scene
from rotlab.trajectory import RunStats, Trajectory, build_trajectory


def load(path: str | Path, *, method: str | None = None, duration: float | None = None) -> Scenario:
    """Read and validate a scenario file; ``method`` and ``duration`` (s) override the file."""
    overrides: dict[tuple[str, ...], Any] = {}
    if method is not None:
        overrides[("solver", "method")] = method
    if duration is not None:
        start = load_scenario(path).time.start
        overrides[("time", "end")] = start + duration
    return load_scenario(path, overrides)


def simulate(scenario: Scenario | str | Path, *, method: str | None = None, progress: ProgressCallback | None = None) -> Trajectory:
    """Run a scenario (object or file path) and return its ``Trajectory`` (user's frames)."""
    if not isinstance(scenario, Scenario):
        scenario = load(scenario, method=method)
    elif method is not None:
        scenario = scenario.model_copy(update={"solver": scenario.solver.model_copy(update={"method": method})})
    scene = build_scene(scenario)
    return run_scene(scene, progress=progress)


def run_scene(scene: Scene, progress: ProgressCallback | None = None) -> Trajectory:
    scenario = scene.scenario
    s = scenario.solver
    t = scenario.time.sample_times()
    settings = Settings(step=s.step, rtol=s.rtol, atol=s.atol, max_steps=s.max_steps, order=s.order)
    chosen, reason, settings = choose_method(scene, s.method, settings, t)
    started = time.perf_counter()
    solution = chosen.solve(scene, t, settings, progress)
    seconds = time.perf_counter() - started
    stats = RunStats(
        method=chosen.name,
        reason=reason,
        steps=solution.steps,
        rejected_steps=solution.rejected_steps,
        rhs_evaluations=solution.rhs_evaluations,
        seconds=seconds,
        failure=solution.failure,
        interrupted=solution.interrupted,
        details=solution.details,
    )
    return build_trajectory(scene, solution, stats, euler_angles=scenario.output.euler_angles)
