"""The invariants rotlab reports: one row per invariant — its name, the label a recording shows,
when a scene has it, and its relative drift.  Config checks, scenes, trajectories and the
recording all read this table (this module needs only numpy).

    T = ½ ω·Iω,  L = Iω + h (body; h: a gyrostat's rotors) and R L (space),  V = −Σ F·(R p),
    W = ∫ M_nc·ω dt,  H = T + V − W.
Scale: |L₀| for momenta, max(|H₀|, T₀ + |V₀|) for energy; absolute when the scale is zero.
    energy            (H − H₀)/scale                     every scene
    quaternion_norm   |Λ| − 1                            every scene
    L_norm            (|L| − |L₀|)/|L₀|                  no load exerts a torque (a free gyrostat too)
    L_space           |L_space − L_space₀| / |L₀|        no load exerts a torque
    L_vertical        (L_space − L_space₀)·up / |L₀|     parallel forces, no work (up = −F̂)
    L_symmetry        (L − L₀)·e_sym / |L₀|              Lagrange top
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rotlab.rows import row_norm


@dataclass(frozen=True)
class Series:
    """What a drift is computed from (principal frame, valid samples only), and the values at the
    run's first sample it is measured from (a streamed run's chunks all share them).  Shapes are
    those of one run; B runs stacked add a leading axis to every array ((B, N, 3), (B, 1), …)."""

    q: np.ndarray  # (N, 4) Λ as integrated
    L_body: np.ndarray  # (N, 3)
    L_space: np.ndarray  # (N, 3)
    energy: np.ndarray  # (N,) H = T + V − W
    energy0: np.ndarray  # H₀, (1,)
    L_body0: np.ndarray  # (1, 3)
    L_space0: np.ndarray  # (1, 3)
    energy_scale: np.ndarray  # (1,)
    L_scale: np.ndarray  # |L₀|, (1,)
    field_direction: np.ndarray | None
    symmetry_axis: np.ndarray | None


@dataclass(frozen=True)
class Invariant:
    name: str
    label: str  # as a recording's legend shows it (short: the formulas are in the module docstring)
    applies: Callable[[Any], bool]  # scene → does this scene conserve it
    drift: Callable[[Series], np.ndarray]
    full_rate: bool = True  # a recording keeps it at every sample (else at the visual series' rate)


def _relative(x: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """x / scale, or x itself where the scale is zero (a body at rest)."""
    return np.divide(x, scale, out=x.copy(), where=scale > 0.0)


TABLE: tuple[Invariant, ...] = (
    Invariant("energy", "T+V−W", lambda scene: True,
              lambda s: _relative(s.energy - s.energy0, s.energy_scale)),
    Invariant("quaternion_norm", "|Λ|−1", lambda scene: True,
              lambda s: row_norm(s.q) - 1.0, full_rate=False),  # a function of Λ alone, which is kept
    Invariant("L_norm", "|L|", lambda scene: scene.free_of_loads,
              lambda s: _relative(row_norm(s.L_body) - s.L_scale, s.L_scale)),
    Invariant("L_space", "L space", lambda scene: scene.free_of_loads,
              lambda s: _relative(row_norm(s.L_space - s.L_space0), s.L_scale)),
    Invariant("L_vertical", "L·up", lambda scene: scene.field_direction is not None,
              lambda s: _relative(np.einsum("...j,j->...", s.L_space - s.L_space0, s.field_direction), s.L_scale)),
    Invariant("L_symmetry", "L·e", lambda scene: scene.symmetry_axis is not None,
              lambda s: _relative(np.einsum("...j,j->...", s.L_body - s.L_body0, s.symmetry_axis), s.L_scale)),
)

NAMES: tuple[str, ...] = tuple(row.name for row in TABLE)
LABELS: dict[str, str] = {row.name: row.label for row in TABLE}
# Written with the visual series, not at every sample: |Λ| − 1 is a function of the recorded
# float64 Λ alone (no physics), so its full-rate copy adds ~16 B a sample and no information;
# its maximum over every sample is still reported and checked.
THINNED: frozenset[str] = frozenset(row.name for row in TABLE if not row.full_rate)


def names_for(scene: Any) -> tuple[str, ...]:
    """The invariants of ``scene`` (in table order)."""
    return tuple(row.name for row in TABLE if row.applies(scene))


def drifts(names: tuple[str, ...], series: Series) -> dict[str, np.ndarray]:
    """Relative drift of each named invariant along ``series`` (empty arrays for no samples)."""
    if not series.q.shape[-2]:
        return {name: np.zeros(series.q.shape[:-1]) for name in names}
    rows = {row.name: row for row in TABLE}
    return {name: rows[name].drift(series) for name in names}
