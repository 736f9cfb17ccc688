"""What a run produces, in the user's frames, with every diagnostic of the scene.

    T = ½ ω·Iω,  L = Iω (body) and R L (space),  V = −Σ F·(R p)  (constant space-frame forces,
    gravity included),  W = ∫ M_nc·ω dt,  and the invariant H = T + V − W.
The invariants and their relative drift: ``rotlab.invariants`` (one table).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property, wraps
from typing import TypeVar

import numpy as np

from rotlab import invariants
from rotlab.core import quaternion as quat
from rotlab.core.state import STATE_SIZE
from rotlab.events import EventLog
from rotlab.methods.base import Solution
from rotlab.rows import row_dot, row_norm, unit_rows
from rotlab.scene.loads import potential as potential_energy
from rotlab.scene.scene import Scene

Result = TypeVar("Result")


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
    compile_seconds: float = 0.0  # numba compilation / cache loading during the run (not in ``seconds``)


def _near_blow_up(compute: Callable[..., Result]) -> Callable[..., Result]:
    """``compute`` without numpy's overflow warnings: near a blow-up a finite state can have an
    overflowing energy, reported as inf."""

    @wraps(compute)
    def quietly(*args, **kwargs) -> Result:
        with np.errstate(over="ignore", invalid="ignore"):
            return compute(*args, **kwargs)

    return quietly


class Trajectory:
    """Time series of a run.  Vectors: ``omega``, ``L_body`` body frame; ``L_space`` space frame;
    ``quaternion`` body → space, scalar first (as integrated: |Λ| − 1 is in ``invariants``).

    Built from the integrated state (principal frame, kept private: the series handed out are
    copies); every other series is computed on first use and kept, so a call that needs only Λ
    and ω does not pay for the energies and drifts."""

    scene: Scene
    stats: RunStats
    t: np.ndarray  # (N,) s

    def __init__(self, scene: Scene, stats: RunStats, t: np.ndarray, state: np.ndarray, reference: Reference | None = None,
                 euler_angles: bool = False, previous_angles: np.ndarray | None = None,
                 series: dict[str, object] | None = None) -> None:
        """``state``: (N, 8) rows [Λ_P, ω_P, W] (principal frame); drifts from ``reference``
        (None: from the first row); Euler angles when ``euler_angles``, unwrapped on from
        ``previous_angles``; ``series``: values already computed (name → array)."""
        self.scene, self.stats, self.t = scene, stats, t
        self.events: dict[str, EventLog] = {}  # name → occurrences (``rotlab.events``), set by the run
        self._state, self._reference = state, reference
        self._euler, self._previous_angles = euler_angles, previous_angles
        self.__dict__.update(series or {})  # read by the cached properties below before they compute

    @cached_property
    def quaternion(self) -> np.ndarray:  # (N, 4)
        q = self._user_quaternion()
        return q.copy() if self.scene.is_principal else q

    @cached_property
    def omega(self) -> np.ndarray:  # (N, 3) rad/s, body
        return self._to_user(self._state[:, 4:7])

    @cached_property
    def L_body(self) -> np.ndarray:  # (N, 3) kg·m²/s, body
        return self._to_user(self._quantities[1])

    @cached_property
    def L_space(self) -> np.ndarray:  # (N, 3) kg·m²/s, space
        return self._quantities[2]

    @property
    def inertia(self) -> np.ndarray:  # (3, 3) kg·m², about the fixed point, user's body frame
        return self.scene.scenario.body.tensor()

    @property
    def center_of_mass(self) -> np.ndarray:  # (3,) m, from the fixed point, user's body frame
        return np.asarray(self.scene.scenario.body.centre(), dtype=float)

    @cached_property
    def gamma(self) -> np.ndarray | None:  # (N, 3) the field's unit "up" (−F̂), body; None without one field direction
        up = self.scene.field_direction
        if up is None:
            return None
        return self._to_user(quat.rotate_to_body_array(self._quantities[0], np.asarray(up, dtype=float)))

    @cached_property
    def kinetic(self) -> np.ndarray:  # (N,) J
        return self._quantities[3]

    @cached_property
    def potential(self) -> np.ndarray | None:  # (N,) J, None when no field acts
        return self._quantities[4]

    @cached_property
    def work(self) -> np.ndarray | None:  # (N,) J, None without non-conservative loads
        return self._state[:, 7].copy() if self.scene.has_work else None

    @cached_property
    def rotor_momenta(self) -> np.ndarray | None:  # (N, n) N·m·s, J Ω of each driven rotor (scenario order); None without
        return self._state[:, STATE_SIZE:].copy() if self.scene.loads.drives is not None else None

    @cached_property
    def rotor_speeds(self) -> np.ndarray | None:  # (N, n) rad/s, Ω of each driven rotor relative to the body (NaN: no inertia given)
        if self.rotor_momenta is None:
            return None
        inertia = np.array([rotor.inertia or np.nan for _, rotor in self.scene.scenario.driven_rotors()])
        return self.rotor_momenta / inertia

    @cached_property
    def total(self) -> np.ndarray:  # (N,) J, T + V
        return self._quantities[5]

    @cached_property
    def invariants(self) -> dict[str, np.ndarray]:  # relative drift, see module docstring
        return self._quantities[7]

    @cached_property
    def euler_angles(self) -> np.ndarray | None:  # (N, 3) rad (ψ, θ, φ), when asked for
        return _continuous_euler_angles(self._user_quaternion(), self._previous_angles) if self._euler else None

    @cached_property
    def _quantities(self):
        """(unit Λ_P, L_P, L_space, T, V, T + V, T + V − W, drifts): see ``_quantities``; the drifts
        are taken with them, so that nothing a caller does to the series handed out changes them."""
        quantities = _quantities(self.scene, self._state)
        reference = self._reference if self._reference is not None or not len(self.t) else _reference(quantities)
        return (*quantities, _drifts(self.scene, self._state[:, 0:4], quantities[1], quantities[2], quantities[6], reference))

    @_near_blow_up
    def _user_quaternion(self) -> np.ndarray:
        q_p = self._state[:, 0:4]
        return q_p if self.scene.is_principal else quat.multiply_array(q_p, quat.conjugate_array(self.scene.axes_quaternion))

    @_near_blow_up
    def _to_user(self, rows: np.ndarray) -> np.ndarray:
        """``rows`` in the user's body frame, never a view of the state: the series computed later
        come from the state, so a caller editing ω in place must not change them."""
        return rows.copy() if self.scene.is_principal else _rows_times(rows, self.scene.axes.T)

    def max_drift(self) -> dict[str, float]:
        """max |drift| over the run, per invariant."""
        return dict(self._max_drift)

    @cached_property
    def _max_drift(self) -> dict[str, float]:
        return {name: float(value) for name, value in largest_drifts(self.invariants).items()}

    @property
    def ok(self) -> bool:
        """The run covered the whole span (no failure, no interrupt)."""
        return self.stats.failure is None

    def __repr__(self) -> str:
        n = self.t.shape[0]
        span = f"{self.t[0]:g}–{self.t[-1]:g} s" if n else "no samples"
        drift = ", ".join(f"{name} {value:.1e}" for name, value in self.max_drift().items())
        state = "ok" if self.ok else f"stopped: {self.stats.failure}"
        return (f"<Trajectory {self.scene.kind.replace('_', '-')} scene, {n:,} samples over {span}, "
                f"method {self.stats.method}, max drift {drift or 'none'}; {state}>")

    def _repr_html_(self) -> str:
        """A notebook's view of the run: a summary table and small plots (``rotlab.notebook``)."""
        from rotlab.notebook import trajectory_html

        return trajectory_html(self)

    def columns(self) -> dict[str, tuple[np.ndarray, str]]:
        """Every series as a named column: name → (values, unit).  Vectors name their frame."""
        out: dict[str, tuple[np.ndarray, str]] = {"t": (self.t, "s")}
        for k in range(4):
            out[f"q{k}"] = (self.quaternion[:, k], "1 (body → space, scalar first)")
        for label, values, unit in (("omega", self.omega, "rad/s"), ("L", self.L_body, "kg·m²/s")):
            for k, axis in enumerate("xyz"):
                out[f"{label}_{axis}_body"] = (values[:, k], unit)
        for k, axis in enumerate("xyz"):
            out[f"L_{axis}_space"] = (self.L_space[:, k], "kg·m²/s")
        out["kinetic"] = (self.kinetic, "J")
        if self.potential is not None:
            out["potential"] = (self.potential, "J")
            out["total"] = (self.total, "J")
        if self.work is not None:
            out["work"] = (self.work, "J")
        if self.rotor_momenta is not None:
            for k, (name, _) in enumerate(self.scene.scenario.driven_rotors()):
                out[f"rotor_momentum_{name}"] = (self.rotor_momenta[:, k], "N·m·s (J Ω)")
                out[f"rotor_speed_{name}"] = (self.rotor_speeds[:, k], "rad/s (Ω, relative to the body)")
        for name, drift in self.invariants.items():
            out[f"drift_{name}"] = (drift, "1 (relative)")
        if self.euler_angles is not None:
            for k, name in enumerate(("psi", "theta", "phi")):
                out[name] = (self.euler_angles[:, k], "rad")
        return out

    def to_dataframe(self):
        """A pandas DataFrame of ``columns()``; units in ``df.attrs["units"]`` (needs pandas)."""
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("Trajectory.to_dataframe needs pandas: pip install pandas (or rotlab[dataframe])") from None
        columns = self.columns()
        frame = pd.DataFrame({name: values for name, (values, _) in columns.items()})
        frame.attrs["units"] = {name: unit for name, (_, unit) in columns.items()}
        return frame

    def take(self, rows: np.ndarray) -> Trajectory:
        """The samples ``rows`` (indices) of this trajectory."""
        return _per_series([self], lambda arrays: arrays[0][rows])

    def summary(self) -> RunSummary:
        n = self.t.shape[0]
        return RunSummary(self.scene, self.stats, n, float(self.t[0]) if n else 0.0, float(self.t[-1]) if n else 0.0, self.max_drift(),
                          self.events)


def concatenate(parts: list[Trajectory]) -> Trajectory:
    """Consecutive pieces of one run (same scene and stats) as one ``Trajectory``."""
    return parts[0] if len(parts) == 1 else _per_series(parts, np.concatenate)


# The per-sample series of a Trajectory (None where the scene has no such series), drifts apart.
_SERIES = ("quaternion", "omega", "L_body", "L_space", "kinetic", "potential", "work", "rotor_momenta", "rotor_speeds", "total",
           "euler_angles")


def _per_series(parts: list[Trajectory], combine: Callable[[list[np.ndarray]], np.ndarray]) -> Trajectory:
    """A Trajectory of ``parts[0]``'s scene and stats whose every series (and drift) is
    ``combine`` of that series in each of ``parts`` (computed in each part first)."""
    first = parts[0]
    series: dict[str, object] = {name: None if getattr(first, name) is None else combine([getattr(p, name) for p in parts])
                                 for name in _SERIES}
    series["invariants"] = {name: combine([p.invariants[name] for p in parts]) for name in first.invariants}
    return Trajectory(first.scene, first.stats, combine([p.t for p in parts]), combine([p._state for p in parts]),
                      first._reference, first._euler, series=series)


@dataclass(frozen=True)
class Runs:
    """B runs of one scene over the same sample times, stacked (a sweep's report of many cases at
    once, ``stack_runs``): the series it needs, computed by the same functions as one
    ``Trajectory``'s, with a leading axis of runs."""

    scene: Scene
    t: np.ndarray  # (N,) s
    unit_q: np.ndarray  # (B, N, 4) unit Λ_P, principal body → space
    omega: np.ndarray  # (B, N, 3) rad/s, user's body frame
    L_body0: np.ndarray  # (B, 3) kg·m²/s, L(t0), user's body frame
    L_space0: np.ndarray  # (B, 3) kg·m²/s, L(t0), space frame
    drifts: dict[str, np.ndarray]  # invariant → (B, N) relative drift

    def max_drift(self) -> dict[str, np.ndarray]:
        """max |drift| over each run, per invariant: (B,) each (0 for runs without samples)."""
        return largest_drifts(self.drifts)


def largest_drifts(drifts: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """max |drift| over the samples (last axis), per invariant; 0 without samples."""
    return {name: np.max(np.abs(v), axis=-1) if v.shape[-1] else np.zeros(v.shape[:-1]) for name, v in drifts.items()}


def stack_runs(trajectories: list[Trajectory]) -> Runs:
    """The runs ``trajectories`` stacked: all of one scene's body and loads, with the same sample times."""
    first = trajectories[0]
    return runs_of(first.scene, first.t, np.stack([traj._state for traj in trajectories]))


def runs_of(scene: Scene, t: np.ndarray, state: np.ndarray) -> Runs:
    """The ``Runs`` of stacked principal-frame states ``state`` (B, N, 8) of ``scene`` at times ``t``."""
    quantities = _quantities(scene, state)
    unit_q, L_p, L_space = quantities[:3]
    started = t.shape[0] > 0
    drifts = _drifts(scene, state[..., 0:4], L_p, L_space, quantities[6], _reference(quantities) if started else None)
    L_body0, L_space0 = (L_p[:, 0], L_space[:, 0]) if started else (np.zeros((state.shape[0], 3)),) * 2
    omega = state[..., 4:7]  # (a stacked copy: no trajectory's state is shared)
    if not scene.is_principal:
        omega, L_body0 = _rows_times(omega, scene.axes.T), _rows_times(L_body0, scene.axes.T)
    return Runs(scene, t, unit_q, omega, L_body0, L_space0, drifts)


@dataclass
class RunSummary:
    """What reports say about a run without holding its samples (a streamed run has none)."""

    scene: Scene
    stats: RunStats
    samples: int
    start: float  # s, first sample
    end: float  # s, last valid sample
    drift: dict[str, float]  # max |relative drift| per invariant
    events: dict[str, EventLog] = field(default_factory=dict)  # name → occurrences

    def max_drift(self) -> dict[str, float]:
        return self.drift


@dataclass(frozen=True)
class Reference:
    """The values at the run's first sample that the drifts are measured from (principal frame),
    shaped to broadcast against the run's samples: (1, 3) vectors and (1,) scalars for one run,
    (B, 1, 3) and (B, 1) for B stacked runs (``stack_runs``)."""

    L_p: np.ndarray  # body L₀
    L_space: np.ndarray  # space L₀
    L_norm: np.ndarray  # |L₀|
    invariant_energy: np.ndarray  # H₀ = T₀ + V₀ − W₀
    energy_scale: np.ndarray  # max(|H₀|, T₀ + |V₀|)


def build_trajectory(scene: Scene, solution: Solution, stats: RunStats, euler_angles: bool = False) -> Trajectory:
    """Diagnostics of the valid part of ``solution``, converted to the user's frames (computed on
    first use)."""
    n = solution.valid
    return Trajectory(scene, stats, solution.t[:n], solution.state[:n], None, euler_angles)


def build_chunk(scene: Scene, stats: RunStats, t: np.ndarray, state: np.ndarray, reference: Reference | None,
                euler_angles: bool, previous_angles: np.ndarray | None) -> Trajectory:
    """The diagnostics of consecutive samples ``state`` (principal frame) of a run: drifts from
    ``reference`` (None: this chunk starts the run), Euler angles unwrapped on from
    ``previous_angles`` (the last angles of the previous chunk)."""
    return Trajectory(scene, stats, t, state, reference, euler_angles, previous_angles)


def reference_of(scene: Scene, state0: np.ndarray) -> Reference:
    """The ``Reference`` of a run that starts in ``state0`` (one row, principal frame), or of B
    runs that start in the rows of ``state0`` (B, 8)."""
    return _reference(_quantities(scene, state0[..., None, :]))


def _reference(quantities) -> Reference:
    """The ``Reference`` from the first sample of ``_quantities`` (of one run, or of each of
    stacked runs; row-wise operations: the same numbers whether computed for that row alone or
    for a chunk that starts with it)."""
    unit_q, L_p, L_space, kinetic, potential, _, invariant_energy = quantities
    v0 = np.abs(potential[..., :1]) if potential is not None else 0.0
    h0 = invariant_energy[..., :1].copy()
    return Reference(L_p[..., :1, :].copy(), L_space[..., :1, :].copy(), row_norm(L_p[..., :1, :]), h0,
                     np.maximum(np.abs(h0), kinetic[..., :1] + v0))


@_near_blow_up
def _quantities(scene: Scene, state: np.ndarray):
    """(unit Λ_P, L_P, L_space, T, V (None without a field), T + V, T + V − W) of principal-frame rows."""
    q_p, w_p, work = state[..., 0:4], state[..., 4:7], state[..., 7]
    unit_q = unit_rows(q_p)
    I_w = w_p * scene.moments
    L_p = I_w if scene.rotor_momentum is None else I_w + scene.rotor_momentum  # a gyrostat's L = Iω + h
    if scene.loads.drives is not None:  # and its driven rotors' momenta, the state's last columns
        L_p = L_p + np.einsum("...j,jk->...k", state[..., STATE_SIZE:], scene.loads.drives.axes)
    L_space = quat.rotate_to_space_array(unit_q, L_p)
    kinetic = 0.5 * row_dot(w_p, I_w)
    potential = potential_energy(scene.loads, unit_q) if scene.has_potential else None
    total = kinetic if potential is None else kinetic + potential
    return unit_q, L_p, L_space, kinetic, potential, total, total - work


@_near_blow_up
def _continuous_euler_angles(q: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """3-1-3 angles along the run with ψ and φ unwrapped (continuous in time, not cut at ±π),
    continuing from ``previous`` (the angles of the sample before ``q``) when given."""
    angles = quat.to_euler_313(q / np.linalg.norm(q, axis=1, keepdims=True))
    if previous is not None:
        angles = np.vstack([previous[None, :], angles])
    angles[:, 0] = np.unwrap(angles[:, 0])
    angles[:, 2] = np.unwrap(angles[:, 2])
    return angles[1:] if previous is not None else angles


def _rows_times(rows: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``rows @ matrix`` for (..., 3) rows and a 3×3 matrix or 3-vector, without BLAS: its threads
    busy-wait against the recording's encoder thread, which starves both on a loaded machine."""
    return np.einsum("...j,jk->...k" if matrix.ndim == 2 else "...j,j->...", rows, matrix)


@_near_blow_up
def _drifts(scene: Scene, q_p, L_p, L_space, invariant_energy, reference: Reference | None) -> dict[str, np.ndarray]:
    """Relative drift of each of the scene's invariants (``rotlab.invariants``) from ``reference``."""
    if not q_p.shape[-2] or reference is None:
        return {name: np.zeros(q_p.shape[:-1]) for name in scene.invariants}
    series = invariants.Series(q_p, L_p, L_space, invariant_energy, reference.invariant_energy, reference.L_p, reference.L_space,
                               reference.energy_scale, reference.L_norm, scene.field_direction, scene.symmetry_axis)
    return invariants.drifts(scene.invariants, series)

