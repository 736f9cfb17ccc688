"""A scene: the scenario in the principal frame, classified, with its invariants.

Frames.  The user's body frame U (where the inertia was given) and the principal frame P are
related by the proper rotation ``axes`` (columns = principal axes in U): r_U = axes · r_P.
Internally Λ_P = Λ_U ∘ Λ_axes and ω_P = axesᵀ ω_U; every reported quantity is converted back.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, TypeVar

import numpy as np

from rotlab import invariants as invariant_table
from rotlab.config import models as cfg
from rotlab.core import quaternion as quat
from rotlab.core.state import LAMBDA, OMEGA, STATE_SIZE
from rotlab.core.torques import EX_RATE
from rotlab.core.faults import Fault
from rotlab.scene import fault_words, inertia
from rotlab.scene.loads import (
    LoadArrays,
    Model,
    active_forces,
    build_model,
    compile_loads,
    has_nonconservative,
    loads_key,
    shortest_window,
    torque_scale,
    user_torque,
)

T = TypeVar("T")

SHARED_SIZE = 256  # scenes' shared constants kept (``Scene.shared``), oldest dropped first
_SHARED: dict[tuple, Any] = {}

SYMMETRY_RTOL = 1e-12  # two moments this close are treated as equal (axisymmetric body)

TORQUE_FREE, LAGRANGE, GENERAL = "torque_free", "lagrange", "general"


@dataclass(frozen=True)
class Scene:
    scenario: cfg.Scenario
    moments: np.ndarray  # principal moments (A, B, C), kg·m²
    axes: np.ndarray  # (3, 3) proper rotation, columns = principal axes in the user's body frame
    axes_quaternion: np.ndarray  # Λ of ``axes``
    omega0: np.ndarray  # ω at t0, principal body frame
    q0: np.ndarray  # Λ at t0, principal body → space
    loads: LoadArrays
    kind: str  # TORQUE_FREE | LAGRANGE | GENERAL
    kind_reason: str
    has_potential: bool  # some conservative field exerts torque
    has_work: bool  # some non-conservative load
    field_direction: np.ndarray | None  # unit "up" (−F̂) when all forces are parallel: L·up is invariant
    symmetry_axis: np.ndarray | None  # Lagrange top: unit symmetry axis (principal frame), L·e is invariant
    _memo: dict[str, Any] = field(default_factory=dict, init=False, repr=False, compare=False)

    def cached(self, key: str, build: Callable[[], T]) -> T:
        """What a method derives from the scene alone (kernel constants), built on first use and
        kept with the scene: repeated solves of one scene (sweeps, benchmarks) pay for it once."""
        if key not in self._memo:
            self._memo[key] = build()
        return self._memo[key]

    def shared(self, key: str, build: Callable[[], T]) -> T:
        """Like ``cached``, for what depends only on the loads and the principal moments (the
        kernels' model and load constants): shared among scenes with equal loads and moments, so
        a sweep over initial states or a loop over ``rotlab.simulate``, which build a new scene
        each call, pays for it once.  Kept per scene when a Python torque is among the loads."""
        content = self.content_key
        if content is None:
            return self.cached(key, build)
        found = _SHARED.get((key, content))
        if found is None:
            if len(_SHARED) >= SHARED_SIZE:
                _SHARED.pop(next(iter(_SHARED)))
            found = _SHARED[(key, content)] = self.cached(key, build)
        return found

    def explain_fault(self, fault: Fault) -> str:
        """A run's failure message for the fault one of its compiled loads recorded."""
        return fault_words.explain(fault, self.loads)

    @cached_property
    def state0(self) -> np.ndarray:
        """The state at t0 in ``rotlab.core.state``'s layout: Λ, ω (principal frame), W = 0.
        Read-only: a run starts from a copy (``rotlab.methods.stepping.initial_state``)."""
        y = np.zeros(STATE_SIZE)
        y[LAMBDA], y[OMEGA] = self.q0, self.omega0
        y.flags.writeable = False
        return y

    @cached_property
    def content_key(self) -> tuple | None:
        """The loads and the principal moments as bytes (None with a Python torque)."""
        return _content_key(self.moments, self.loads)

    @cached_property
    def is_principal(self) -> bool:
        """The user's body axes are the principal axes (no conversion of the series)."""
        return _is_identity(self.axes)

    @cached_property
    def rate_scale(self) -> float:
        """A characteristic angular rate (rad/s) of the scene: max(|ω0|, √(|M|/I_min), load frequencies)."""
        return self.rate_from(self.omega0.tolist())

    def rate_from(self, omega0: Sequence[float]) -> float:
        """``rate_scale`` of this body and loads started with ``omega0`` (three numbers) instead."""
        return max(math.sqrt(sum(w * w for w in omega0)), self.shared("load rate", self._load_rate))

    def _load_rate(self) -> float:
        """The loads' part of ``rate_scale``: √(|M|/I_min), their frequencies, damping / I_min."""
        rates = [np.sqrt(torque_scale(self.loads) / float(np.min(self.moments)))]
        if self.loads.terms.size:
            rates.append(float(np.max(np.abs(self.loads.terms[:, 9]))))
        rates.append(self.loads.damping / float(np.min(self.moments)))
        if self.loads.expressions is not None:
            rates.append(float(np.max(np.abs(self.loads.expressions.rows[:, EX_RATE]))))
        return float(max(rates))

    @cached_property
    def model(self) -> Model:
        """The one value the kernels receive: Euler coefficients, breakpoints and the loads,
        absent groups as None (``rotlab.scene.loads.Model``)."""
        return self.shared("model", lambda: build_model(self.loads, self.moments))

    @cached_property
    def invariants(self) -> tuple[str, ...]:
        """The names of the quantities this scene conserves (``rotlab.invariants``)."""
        return invariant_table.names_for(self)

    @cached_property
    def shortest_window(self) -> float:
        """The shortest time a windowed load or a table segment acts, s (inf when none)."""
        return self.shared("shortest window", lambda: shortest_window(self.loads))


def initial_quaternion(initial: cfg.Initial) -> np.ndarray:
    """Λ(t0) in the user's frames from whichever orientation key was given."""
    if initial.quaternion is not None:
        q = np.asarray(initial.quaternion, dtype=float)
        return q / np.linalg.norm(q)
    if initial.axis_angle is not None:
        v = np.asarray(initial.axis_angle, dtype=float)
        angle = float(np.linalg.norm(v))
        return quat.from_axis_angle(v, angle) if angle > 0.0 else np.array([1.0, 0.0, 0.0, 0.0])
    if initial.euler_313 is not None:
        return quat.from_euler_313(*initial.euler_313)
    if initial.euler_313_deg is not None:
        return quat.from_euler_313(*np.radians(initial.euler_313_deg))
    return np.array([1.0, 0.0, 0.0, 0.0])


def build_scene(scenario: cfg.Scenario, torque: Callable | None = None, frame: str = "body") -> Scene:
    """The scene of ``scenario``; ``torque`` adds a Python function fn(t, q, omega) -> M (user's
    body frame in, M in ``frame``) compiled by numba (``rotlab.scene.loads.user_torque``)."""
    rigid = _rigid_part(scenario) if torque is None else _build_rigid(scenario, user_torque(torque, frame, _principal(scenario.body)[1]), torque)
    q0 = initial_quaternion(scenario.initial)
    if scenario.body.principal_moments is None:  # Λ_P = Λ_U ∘ Λ_axes
        q0 = quat.multiply(q0, rigid.fields["axes_quaternion"])
    omega0 = rigid.fields["axes"].T @ np.asarray(scenario.initial.omega, dtype=float)
    scene = Scene(scenario=scenario, q0=q0, omega0=omega0, **rigid.fields)
    scene.__dict__.update(rigid.properties)  # cached properties, filled in
    return scene


@dataclass(frozen=True)
class _Rigid:
    """What a scene derives from its body and loads alone (the initial state aside)."""

    fields: dict[str, Any]  # Scene's fields from moments to symmetry_axis
    properties: dict[str, Any]  # Scene's cached properties that depend on these alone


RIGID_SIZE = 256  # bodies-with-loads kept, oldest dropped first
_RIGID: dict[tuple, _Rigid] = {}


def _rigid_part(scenario: cfg.Scenario) -> _Rigid:
    """``_build_rigid``, shared among scenarios with equal body and loads (frozen models, compared
    by value): a sweep over initial states or a loop over ``rotlab.simulate`` builds it once."""
    key = (scenario.body, tuple(scenario.loads))
    try:
        found = _RIGID.get(key)
    except TypeError:  # a load holding a mapping (an expression's constants): not shared
        return _build_rigid(scenario, None)
    if found is None:
        if len(_RIGID) >= RIGID_SIZE:
            _RIGID.pop(next(iter(_RIGID)))
        found = _RIGID[key] = _build_rigid(scenario, None)
    return found


def _principal(body: cfg.Body) -> tuple[np.ndarray, np.ndarray]:
    """(principal moments, axes): columns of ``axes`` are the principal axes in the user's frame."""
    if body.principal_moments is not None:  # the user's axes are the principal axes
        return np.asarray(body.principal_moments, dtype=float), np.eye(3)
    return inertia.principal_axes(np.asarray(body.inertia_tensor, dtype=float))


def _build_rigid(scenario: cfg.Scenario, user, user_function: Callable | None = None) -> _Rigid:
    moments, axes = _principal(scenario.body)
    axes_q = np.array([1.0, 0.0, 0.0, 0.0]) if scenario.body.principal_moments is not None else quat.from_matrix(axes)
    loads = compile_loads(scenario, axes, moments, user, user_function)
    forces = active_forces(loads)
    has_work = has_nonconservative(loads)
    field = _common_direction(forces[:, 3:]) if len(forces) and not has_work else None
    kind, reason, symmetry_axis = _classify(moments, forces, has_work)
    fields = dict(moments=moments, axes=axes, axes_quaternion=axes_q, loads=loads, kind=kind, kind_reason=reason,
                  has_potential=bool(len(forces)), has_work=has_work, field_direction=None if field is None else -field,
                  symmetry_axis=symmetry_axis)
    return _Rigid(fields, {"is_principal": _is_identity(axes), "content_key": _content_key(moments, loads)})


def _content_key(moments: np.ndarray, loads: LoadArrays) -> tuple | None:
    loads_bytes = loads_key(loads)
    return None if loads_bytes is None else (moments.tobytes(), loads_bytes)


def _is_identity(axes: np.ndarray) -> bool:
    return bool(np.array_equal(axes, np.eye(3)))


def _common_direction(vectors: np.ndarray) -> np.ndarray | None:
    """The unit direction shared by all ``vectors`` (same sense), or None."""
    unit = vectors / np.linalg.norm(vectors, axis=1, keepdims=True)
    if np.all(np.linalg.norm(unit - unit[0], axis=1) < 1e-12):
        return unit[0]
    return None


def _classify(moments: np.ndarray, forces: np.ndarray, has_work: bool) -> tuple[str, str, np.ndarray | None]:
    if not len(forces) and not has_work:
        return TORQUE_FREE, "no load exerts a torque", None
    if has_work:
        return GENERAL, "non-conservative or time-dependent loads", None
    if len(forces) > 1:
        return GENERAL, f"{len(forces)} forces act", None
    arm = forces[0, :3] / np.linalg.norm(forces[0, :3])
    scale = float(np.max(moments))
    if np.ptp(moments) <= SYMMETRY_RTOL * scale:
        return LAGRANGE, "spherical body, one uniform force (symmetry axis through the centre of mass)", arm
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        on_axis = abs(arm[i]) <= 1e-12 and abs(arm[j]) <= 1e-12
        if on_axis and abs(moments[i] - moments[j]) <= SYMMETRY_RTOL * scale:
            axis = np.zeros(3)
            axis[k] = np.sign(arm[k])
            return LAGRANGE, f"axisymmetric body (axis {k + 1}), centre of mass on the axis", axis
    return GENERAL, "one force, body not axisymmetric about its point of application", None
