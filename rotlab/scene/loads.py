"""Loads compiled to flat arrays for the kernels (principal body frame).

Torque on the body, body components (R = R(Λ) body → space):

* constant space-frame force F at body point p:  M = p × (Rᵀ F)          (conservative,
  potential V = −F · (R p); gravity is F = m g at p = r_c)
* torque terms: M(t) = offset + amplitude · sin(w t + phase) inside [on, off), in the body frame
  or, for space-frame terms, M = Rᵀ M(t)                                    (work W)
* tables: piecewise-linear M(t) through (t_k, M_k), zero outside [t_0, t_n) ∩ [on, off)  (work W)
* damping: M = −k ω                                                         (work W)

Work of the non-conservative loads: Ẇ = M_nc · ω, so that T + V − W is invariant.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rotlab.config import models as cfg

BODY, SPACE = 0.0, 1.0

# torque term columns
T_FRAME, T_ON, T_OFF, T_OFFSET, T_AMP, T_W, T_PHASE = 0, 1, 2, slice(3, 6), slice(6, 9), 9, 10
# table columns
TB_FRAME, TB_ON, TB_OFF, TB_FIRST, TB_STOP = 0, 1, 2, 3, 4


class LoadArrays(NamedTuple):
    """Everything the right-hand side needs about loads; passed to numba kernels as a tuple."""

    forces: np.ndarray  # (n, 6): [p (body, m), F (space, N)]
    terms: np.ndarray  # (n, 11): [frame, on, off, offset(3), amplitude(3), w, phase]
    tables: np.ndarray  # (n, 5): [frame, on, off, first row, stop row] into table_t / table_v
    table_t: np.ndarray  # (m,)
    table_v: np.ndarray  # (m, 3)
    damping: float  # k, N·m·s

    def for_kernel(self) -> LoadArrays:
        """The same loads with absent groups as None, so kernels compile without them."""
        forces = self.forces if len(self.forces) else None
        if has_nonconservative(self):
            return self._replace(forces=forces)
        return LoadArrays(forces, None, None, None, None, None)


def compile_loads(scenario: cfg.Scenario, axes: np.ndarray) -> LoadArrays:
    """Turn the scenario's loads into arrays; body-frame vectors are rotated by Pᵀ = ``axes.T``
    into the principal frame (space-frame vectors are unchanged)."""
    to_principal = axes.T
    forces: list[np.ndarray] = []
    terms: list[np.ndarray] = []
    tables: list[list[float]] = []
    table_t: list[float] = []
    table_v: list[np.ndarray] = []
    damping = 0.0

    def body_vector(v: tuple[float, float, float]) -> np.ndarray:
        return to_principal @ np.asarray(v, dtype=float)

    def frame_vector(frame: str, v: tuple[float, float, float]) -> np.ndarray:
        return body_vector(v) if frame == "body" else np.asarray(v, dtype=float)

    def window(w: cfg.Window | None) -> tuple[float, float]:
        return (-np.inf, np.inf) if w is None else (w.on, w.off)

    for load in scenario.loads:
        if isinstance(load, cfg.Gravity):
            mass = scenario.body.mass or 0.0
            forces.append(np.concatenate([body_vector(scenario.body.center_of_mass), mass * np.asarray(load.g)]))
        elif isinstance(load, cfg.Force) and load.frame == "space":
            forces.append(np.concatenate([body_vector(load.point), np.asarray(load.value, dtype=float)]))
        elif isinstance(load, cfg.Force):  # body-frame force: a constant follower torque p × F
            moment = np.cross(body_vector(load.point), body_vector(load.value))
            terms.append(_term(BODY, (-np.inf, np.inf), moment, np.zeros(3), 0.0, 0.0))
        elif isinstance(load, cfg.Torque):
            frame = BODY if load.frame == "body" else SPACE
            terms.append(_term(frame, window(load.window), frame_vector(load.frame, load.value), np.zeros(3), 0.0, 0.0))
        elif isinstance(load, cfg.HarmonicTorque):
            frame = BODY if load.frame == "body" else SPACE
            offset = frame_vector(load.frame, load.offset)
            amplitude = frame_vector(load.frame, load.amplitude)
            if load.angular_frequency == 0.0:  # a constant: fold into the offset
                offset, amplitude = offset + amplitude * np.sin(load.phase), np.zeros(3)
            terms.append(_term(frame, window(load.window), offset, amplitude, load.angular_frequency, load.phase))
        elif isinstance(load, cfg.TorqueTable):
            frame = BODY if load.frame == "body" else SPACE
            first = len(table_t)
            table_t.extend(load.times)
            table_v.extend(frame_vector(load.frame, v) for v in load.values)
            tables.append([frame, *window(load.window), first, len(table_t)])
        elif isinstance(load, cfg.Damping):
            damping += load.coefficient
    return LoadArrays(
        forces=np.array(forces, dtype=float).reshape(-1, 6),
        terms=np.array(terms, dtype=float).reshape(-1, 11),
        tables=np.array(tables, dtype=float).reshape(-1, 5),
        table_t=np.array(table_t, dtype=float),
        table_v=np.array(table_v, dtype=float).reshape(-1, 3),
        damping=float(damping),
    )


def _term(frame: float, window: tuple[float, float], offset: np.ndarray, amplitude: np.ndarray, w: float, phase: float) -> np.ndarray:
    return np.array([frame, window[0], window[1], *offset, *amplitude, w, phase], dtype=float)


def breakpoints(loads: LoadArrays) -> np.ndarray:
    """Sorted times where a load switches or kinks (window edges, table knots): an adaptive
    method ends its steps there instead of stepping over a short pulse."""
    times = [loads.terms[:, 1:3].ravel(), loads.tables[:, 1:3].ravel(), loads.table_t]
    all_times = np.concatenate(times) if any(len(x) for x in times) else np.zeros(0)
    return np.unique(all_times[np.isfinite(all_times)])


def shortest_window(loads: LoadArrays) -> float:
    """The shortest time a windowed load or a table segment acts (inf when none)."""
    spans = [loads.terms[:, 2] - loads.terms[:, 1], loads.tables[:, 2] - loads.tables[:, 1]]
    if len(loads.table_t) > 1:
        knots = np.diff(loads.table_t)
        spans.append(knots[knots > 0])  # segments within tables (consecutive tables concatenate)
    values = np.concatenate(spans) if spans else np.zeros(0)
    return float(np.min(values)) if values.size else float("inf")


def active_forces(loads: LoadArrays) -> np.ndarray:
    """Rows of ``loads.forces`` that can exert a torque (non-zero arm and force)."""
    f = loads.forces
    return f[(np.linalg.norm(f[:, :3], axis=1) > 0.0) & (np.linalg.norm(f[:, 3:], axis=1) > 0.0)]


def has_nonconservative(loads: LoadArrays) -> bool:
    """True when some load does work that no potential accounts for."""
    terms_active = bool(np.any(loads.terms[:, 3:9] != 0.0))
    tables_active = bool(np.any(loads.table_v != 0.0))
    return terms_active or tables_active or loads.damping > 0.0


def torque_scale(loads: LoadArrays) -> float:
    """A rough upper bound of |M| (N·m) at unit ω, for choosing time scales."""
    f = loads.forces
    scale = float(np.sum(np.linalg.norm(f[:, :3], axis=1) * np.linalg.norm(f[:, 3:], axis=1)))
    scale += float(np.sum(np.linalg.norm(loads.terms[:, 3:6], axis=1) + np.linalg.norm(loads.terms[:, 6:9], axis=1)))
    if loads.table_v.size:
        scale += float(np.max(np.linalg.norm(loads.table_v, axis=1)))
    return scale
