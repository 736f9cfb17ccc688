"""One method for the cases of a sweep over initial states.

When a sweep varies only ``initial.*`` keys, its cases share the body, the loads, the time grid
and the solver settings: ``auto`` then makes one choice for all of them, in the main process,
instead of a fresh one per case in the workers (a choice can cost more than a short case's
integration).  It is the choice for the most demanding case — the fastest spin, and the largest
error floor and amplification near the separatrix (``rotlab.methods.choose.worst_work``) — so
that every case is expected to meet rtol with it, whatever the number of workers.  A case on or
near a separatrix, where no stepping method meets rtol (only an exact solution does), would make
that choice absurd for all the others: such a case makes its own choice instead, and so does every
case when no method is expected to meet rtol.  An explicit method runs as requested.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rotlab.config.paths import parse_key_path
from rotlab.errors import InputError
from rotlab.methods.base import Settings
from rotlab.rows import row_dot
from rotlab.sweep.cases import SweepPlan, case_scenario


@dataclass(frozen=True)
class SharedChoice:
    """What the cases of a sweep run with (sent to the workers): ``method`` and ``settings``,
    why, and the cases (indices) that make their own choice instead."""

    method: str
    why: str
    settings: Settings
    own: frozenset[int] = frozenset()

    @property
    def label(self) -> str:
        """The method and the settings it runs with, to the last digit: what reproduces a case alone."""
        s = self.settings
        parts = [f"order {s.order}" if s.order is not None else "", f"step {s.step!r} s" if s.step is not None else "",
                 f"rtol {s.rtol!r}, atol {s.atol!r}" if s.step is None else ""]
        return f"{self.method} ({', '.join(p for p in parts if p)})"


def shared_choice(p: SweepPlan) -> SharedChoice | None:
    """The method and settings for the cases of ``p`` (a sweep over initial states), or None when
    each case is to choose its own (no method is expected to meet rtol for the most demanding,
    or the choice is an input error, which each case then reports)."""
    from rotlab.methods.choose import ACCURACY_FACTOR, choose_method, ensemble_choice, worst_work
    from rotlab.scene.scene import build_scene

    scene = build_scene(p.base)  # the body and loads of every case
    t = p.base.time.sample_times()
    solver = p.base.solver
    settings = Settings.of(solver)
    try:
        if solver.method != "auto" or settings.step is not None:  # nothing to choose by cost
            method, why, chosen_settings = choose_method(scene, solver.method, settings, t)
            return SharedChoice(method.name, why, chosen_settings)
        omegas, positions = case_omegas(p, scene.axes)
        if not len(omegas):
            return None
        distinct, inverse = np.unique(omegas, axis=0, return_inverse=True)
        work, within_distinct = worst_work(scene, t, distinct, floor_limit=ACCURACY_FACTOR * settings.rtol)
        if work is None:
            return None
        within = within_distinct[inverse.reshape(-1)]
        speeds = np.sqrt(row_dot(omegas, omegas))
        fastest = positions[int(np.argmax(np.where(within, speeds, -1.0)))]
        scenario = case_scenario(p.raw, p.base, p.cases[fastest], p.source)  # auto's view of exact's cost depends on ω₀ too
        chosen = ensemble_choice(scene if isinstance(scenario, InputError) else build_scene(scenario), settings, t, work)
    except InputError:
        return None
    if chosen is None:
        return None
    method, why, chosen_settings = chosen
    own = frozenset(p.cases[positions[k]].index for k in np.flatnonzero(~within).tolist())
    why += (f"; chosen once for {len(p.cases) - len(own)} cases, for the most demanding: the fastest spin |ω₀| = "
            f"{float(np.max(speeds[within])):.3g} rad/s" + (f", a stepping-error amplification up to ×{work.amplification:.3g}"
                                                          if work.amplification > 1.01 else ""))
    if own:
        why += f"; {len(own)} case{'s' if len(own) > 1 else ''} near a separatrix, where no stepping method meets rtol, choose their own"
    return SharedChoice(method.name, why, chosen_settings, own)


def case_omegas(p: SweepPlan, axes: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """(the initial ω of each case, principal frame, as rows; each row's position in
    ``p.cases``).  A case whose ω is not three finite numbers is left out (its worker reports
    the error).  ω is swept whole or by components, never both (``sweep.cases.check_overlaps``)."""
    base = [float(x) for x in p.base.initial.omega]
    parts = {path: parse_key_path(path, path) for path in p.base.sweep.parameters}
    swept = {path: part[2:] for path, part in parts.items() if part[:2] == ["initial", "omega"]}  # → [] or [k]
    if not swept:
        return np.repeat(np.array([base]) @ axes, len(p.cases), axis=0), list(range(len(p.cases)))
    rows, positions = [], []
    for position, case in enumerate(p.cases):
        omega = base.copy()
        try:
            for path, value in case.values.items():
                index = swept.get(path)
                if index is None:
                    continue
                if len(index) > 1:
                    raise IndexError(path)
                if index:  # initial.omega[k] = x
                    omega[index[0]] = float(value)
                else:  # initial.omega = [x, y, z]
                    omega = [float(x) for x in value]
        except (TypeError, ValueError, IndexError):
            continue
        if len(omega) == 3 and all(math.isfinite(x) for x in omega):
            rows.append(omega)
            positions.append(position)
    return (np.array(rows) @ axes if rows else np.empty((0, 3))), positions
