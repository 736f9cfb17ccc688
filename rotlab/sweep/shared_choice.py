"""One method for every case of a sweep over initial states.

When a sweep varies only ``initial.*`` keys, its cases share the body, the loads, the time grid
and the solver settings: ``auto`` then makes one choice for all of them, in the main process,
instead of a fresh one per case in the workers (~45 µs a case, more than a short case's
integration).  The choice is the one for the most demanding case — the fastest spin, and the
largest error floor and amplification near the separatrix (``rotlab.methods.choose.
ensemble_choice``) — so that every case is expected to meet rtol with it, whatever the number of
workers or the order in which they take the cases.  An explicit method runs as requested.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from rotlab.config.paths import parse_key_path
from rotlab.methods.base import Settings
from rotlab.rows import row_dot
from rotlab.sweep.cases import SweepPlan, case_scenario

OMEGA = "initial.omega"


@dataclass(frozen=True)
class SharedChoice:
    """What every case of the sweep runs with (sent to the workers)."""

    method: str
    why: str
    settings: Settings


def initial_only(paths: Iterable[str]) -> bool:
    """Every swept key is an initial condition."""
    return all(path.startswith("initial.") for path in paths)


def shared_choice(p: SweepPlan) -> SharedChoice:
    """The method, reason and settings for all cases of ``p`` (a sweep over initial states).
    Loading a stepping method's kernel in a new process is shared among all the cases, whatever
    the number of workers: the choice, and so every case's result, does not depend on ``-j``."""
    from rotlab.methods.choose import ensemble_choice
    from rotlab.scene.scene import build_scene

    scene = build_scene(p.base)  # the body and loads of every case
    omegas, fastest = case_omegas(p, scene.axes)
    if fastest is not None:  # auto's view of the exact solution's cost depends on ω₀ too: the fastest case's
        scenario = case_scenario(p.raw, p.base, p.cases[fastest], p.source)
        scene = scene if isinstance(scenario, Exception) else build_scene(scenario)
    solver = p.base.solver
    method, why, settings = ensemble_choice(scene, solver.method, Settings.of(solver), p.base.time.sample_times(), omegas,
                                            len(p.cases))
    return SharedChoice(method.name, why, settings)


def case_omegas(p: SweepPlan, axes: np.ndarray) -> tuple[np.ndarray, int | None]:
    """(each distinct initial ω of the cases, principal frame, as rows; the position in
    ``p.cases`` of the case with the fastest spin, None when ω is not swept).  A case whose ω is
    not three finite numbers is left out (its worker reports the error)."""
    base = list(p.base.initial.omega)
    swept = [(path, parse_key_path(path, path)[2:]) for path in p.base.sweep.parameters if path == OMEGA or path.startswith(OMEGA + "[")]
    if not swept:
        return np.array([base]) @ axes, None
    rows, positions = [], []
    for position, case in enumerate(p.cases):
        omega = base.copy()
        try:
            for path, index in swept:  # initial.omega = [x, y, z] or initial.omega[k] = x
                if index:
                    omega[index[0]] = float(case.values[path])
                else:
                    omega = [float(x) for x in case.values[path]]
        except (TypeError, ValueError, IndexError):
            continue
        if len(omega) == 3 and all(math.isfinite(x) for x in omega):
            rows.append(omega)
            positions.append(position)
    if not rows:
        return np.empty((0, 3)), None
    user = np.array(rows)
    fastest = positions[int(np.argmax(row_dot(user, user)))]
    return np.unique(user, axis=0) @ axes, fastest
