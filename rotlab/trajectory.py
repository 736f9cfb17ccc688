"""What a run produces, in the user's frames, with every diagnostic of the scene.

    T = ½ ω·Iω,  L = Iω (body) and R L (space),  V = −Σ F·(R p)  (constant space-frame forces,
    gravity included),  W = ∫ M_nc·ω dt,  and the invariant H = T + V − W.
Relative drift of each invariant (scale: |L₀| for momenta, max(|H₀|, T₀ + |V₀|) for energy;
absolute when the scale is zero):
    energy            (H − H₀)/scale
    quaternion_norm   |Λ| − 1
    L_norm            (|L| − |L₀|)/|L₀|                 torque-free
    L_space           |L_space − L_space₀| / |L₀|        torque-free
    L_vertical        (L_space − L_space₀)·up / |L₀|     parallel forces (up = −F̂)
    L_symmetry        (L − L₀)·e_sym / |L₀|              Lagrange top
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rotlab.core import quaternion as quat
from rotlab.methods.base import Solution
from rotlab.scene.scene import Scene


@dataclass
class RunStats:
    method: str
    reason: str
    steps: int
    rejected_steps: int
    rhs_evaluations: int
    seconds: float
    failure: str | None = None
    interrupted: bool = False
    details: dict[str, object] = field(default_factory=dict)


@dataclass
class Trajectory:
    """Time series of a run.  Vectors: ``omega``, ``L_body`` body frame; ``L_space`` space frame;
    ``quaternion`` body → space, scalar first (as integrated: |Λ| − 1 is in ``invariants``)."""

    scene: Scene
    stats: RunStats
    t: np.ndarray  # (N,) s
    quaternion: np.ndarray  # (N, 4)
    omega: np.ndarray  # (N, 3) rad/s, body
    L_body: np.ndarray  # (N, 3) kg·m²/s, body
    L_space: np.ndarray  # (N, 3) kg·m²/s, space
    kinetic: np.ndarray  # (N,) J
    potential: np.ndarray | None  # (N,) J, None when no field acts
    work: np.ndarray | None  # (N,) J, None without non-conservative loads
    total: np.ndarray  # (N,) J, T + V
    invariants: dict[str, np.ndarray]  # relative drift, see module docstring
    euler_angles: np.ndarray | None = None  # (N, 3) rad (ψ, θ, φ), when asked for

    def max_drift(self) -> dict[str, float]:
        """max |drift| over the run, per invariant."""
        return {name: float(np.max(np.abs(v))) if v.size else 0.0 for name, v in self.invariants.items()}


def build_trajectory(scene: Scene, solution: Solution, stats: RunStats, euler_angles: bool = False) -> Trajectory:
    """Diagnostics of the valid part of ``solution``, converted to the user's frames.
    Near a blow-up a finite state can have an overflowing energy: it is reported as inf."""
    with np.errstate(over="ignore", invalid="ignore"):
        return _build(scene, solution, stats, euler_angles)


def _build(scene: Scene, solution: Solution, stats: RunStats, euler_angles: bool) -> Trajectory:
    n = solution.valid
    t = solution.t[:n]
    q_p = solution.state[:n, 0:4]
    w_p = solution.state[:n, 4:7]
    work = solution.state[:n, 7]

    unit_q = q_p / np.linalg.norm(q_p, axis=1, keepdims=True)
    L_p = w_p * scene.moments
    L_space = quat.rotate_to_space_array(unit_q, L_p)
    kinetic = 0.5 * np.sum(w_p * L_p, axis=1)
    potential = _potential(scene, unit_q) if scene.has_potential else None
    total = kinetic if potential is None else kinetic + potential

    if scene.is_principal:
        q_user, w_user, L_user = q_p, w_p, L_p
    else:
        q_user = quat.multiply_array(q_p, quat.conjugate_array(scene.axes_quaternion))
        w_user, L_user = w_p @ scene.axes.T, L_p @ scene.axes.T

    invariants = _drifts(scene, q_p, L_p, L_space, total - work, kinetic, potential)
    return Trajectory(
        scene=scene,
        stats=stats,
        t=t,
        quaternion=q_user,
        omega=w_user,
        L_body=L_user,
        L_space=L_space,
        kinetic=kinetic,
        potential=potential,
        work=work if scene.has_work else None,
        total=total,
        invariants=invariants,
        euler_angles=_continuous_euler_angles(q_user) if euler_angles else None,
    )


def _continuous_euler_angles(q: np.ndarray) -> np.ndarray:
    """3-1-3 angles along the run with ψ and φ unwrapped (continuous in time, not cut at ±π)."""
    angles = quat.to_euler_313(q / np.linalg.norm(q, axis=1, keepdims=True))
    angles[:, 0] = np.unwrap(angles[:, 0])
    angles[:, 2] = np.unwrap(angles[:, 2])
    return angles


def _potential(scene: Scene, unit_q: np.ndarray) -> np.ndarray:
    v = np.zeros(unit_q.shape[0])
    for row in scene.loads.forces:
        v -= quat.rotate_to_space_array(unit_q, np.broadcast_to(row[:3], (unit_q.shape[0], 3))) @ row[3:]
    return v


def _relative(x: np.ndarray, scale: float) -> np.ndarray:
    return x / scale if scale > 0.0 else x


def _drifts(scene: Scene, q_p, L_p, L_space, invariant_energy, kinetic, potential) -> dict[str, np.ndarray]:
    if not len(q_p):
        return {name: np.zeros(0) for name in scene.invariants}
    L0 = float(np.linalg.norm(L_p[0]))
    e_scale = max(abs(float(invariant_energy[0])), float(kinetic[0]) + (abs(float(potential[0])) if potential is not None else 0.0))
    out: dict[str, np.ndarray] = {}
    for name in scene.invariants:
        if name == "energy":
            out[name] = _relative(invariant_energy - invariant_energy[0], e_scale)
        elif name == "quaternion_norm":
            out[name] = np.linalg.norm(q_p, axis=1) - 1.0
        elif name == "L_norm":
            out[name] = _relative(np.linalg.norm(L_p, axis=1) - L0, L0)
        elif name == "L_space":
            out[name] = _relative(np.linalg.norm(L_space - L_space[0], axis=1), L0)
        elif name == "L_vertical":
            out[name] = _relative((L_space - L_space[0]) @ scene.field_direction, L0)
        elif name == "L_symmetry":
            out[name] = _relative((L_p - L_p[0]) @ scene.symmetry_axis, L0)
    return out
