"""A scene: the scenario in the principal frame, classified, with its invariants.

Frames.  The user's body frame U (where the inertia was given) and the principal frame P are
related by the proper rotation ``axes`` (columns = principal axes in U): r_U = axes · r_P.
Internally Λ_P = Λ_U ∘ Λ_axes and ω_P = axesᵀ ω_U; every reported quantity is converted back.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from rotlab import invariants as invariant_table
from rotlab.config import models as cfg
from rotlab.core import quaternion as quat
from rotlab.core.state import LAMBDA, OMEGA, STATE_SIZE
from rotlab.core.faults import Fault
from rotlab.core.torques import F_FORCE, F_POINT
from rotlab import inertia
from rotlab.kept import Kept
from rotlab.scene import fault_words
from rotlab.scene.loads import (
    LoadArrays,
    Model,
    active_forces,
    build_model,
    compile_loads,
    formula_rows,
    has_nonconservative,
    has_switches,
    load_rates,
    loads_key,
    shortest_window,
    torque_scale,
)
from rotlab.scene.user_torque import user_torque

SYMMETRY_RTOL = 1e-12  # two moments this close are treated as equal (axisymmetric body)

TORQUE_FREE, LAGRANGE, GYROSTAT, GENERAL = "torque_free", "lagrange", "gyrostat", "general"


@dataclass(frozen=True, eq=False)
class Rigid:
    """What a scene derives from its body and loads alone (the initial state aside), built once
    and shared by every scene with the same body and loads (``build_scene``): a sweep over
    initial states or a loop over ``rotlab.simulate`` compiles the loads and builds the kernels'
    model once.  Principal frame (module docstring)."""

    body: cfg.Body
    specs: tuple[cfg.Load, ...]  # the loads as the scenario gives them
    moments: np.ndarray  # principal moments (A, B, C), kg·m²
    axes: np.ndarray  # (3, 3) proper rotation, columns = principal axes in the user's body frame
    axes_quaternion: np.ndarray  # Λ of ``axes``
    loads: LoadArrays
    kind: str  # TORQUE_FREE | LAGRANGE | GYROSTAT | GENERAL
    kind_reason: str
    free_of_loads: bool  # no load exerts a torque: L (rotors' h included) is conserved in space
    rotor_momentum: np.ndarray | None  # h of the rotors (principal frame, N·m·s); None without (or with h = 0)
    has_potential: bool  # some conservative field exerts torque
    has_work: bool  # some non-conservative load
    field_direction: np.ndarray | None  # unit "up" (−F̂) when all forces are parallel: L·up is invariant
    symmetry_axis: np.ndarray | None  # Lagrange top: unit symmetry axis (principal frame), L·e is invariant
    _kernel_constants: dict[tuple[str, int | None], tuple] = field(default_factory=dict, init=False, repr=False)

    @cached_property
    def model(self) -> Model:
        """The one value the kernels receive: Euler coefficients, breakpoints and the loads,
        absent groups as None (``rotlab.scene.loads.Model``)."""
        return build_model(self.loads, self.moments, rotors=self.rotor_momentum)

    @cached_property
    def content_key(self) -> tuple | None:
        """The loads and the principal moments as bytes (None with a Python torque)."""
        loads_bytes = loads_key(self.loads)
        return None if loads_bytes is None else (self.moments.tobytes(), loads_bytes)

    @cached_property
    def is_principal(self) -> bool:
        """The user's body axes are the principal axes (no conversion of the series)."""
        return bool(np.array_equal(self.axes, np.eye(3)))

    @cached_property
    def load_rate(self) -> float:
        """The loads' part of ``Scene.rate_scale``: √(|M|/I_min), their frequencies, damping / I_min."""
        smallest = float(np.min(self.moments))
        rates = [np.sqrt(torque_scale(self.loads) / smallest), self.loads.damping / smallest]
        return float(max(rates + load_rates(self.loads).tolist()))

    @cached_property
    def shortest_window(self) -> float:
        """The shortest time a windowed load or a table segment acts, s (inf when none)."""
        return shortest_window(self.loads)

    @cached_property
    def formula_switches(self) -> bool:
        """A formula (a load's, ``pd_control``'s, a rotor drive's) applies abs, sign, min or max to
        an argument that varies with the time or the state: it may jump or kink where no
        breakpoint marks it (``rotlab.scene.loads.has_switches``)."""
        return has_switches(self.loads)

    @cached_property
    def has_switches(self) -> bool:
        """A load may jump or kink where no breakpoint marks it: ``formula_switches``, or a Python
        torque, whose smoothness is unknown.  A fixed step crosses such a switch at low order,
        whatever its probe measured between switches."""
        return self.formula_switches or self.loads.user is not None

    @cached_property
    def formula_rows(self) -> int:
        """The size of the formula loads' programs (``rotlab.scene.loads.formula_rows``)."""
        return formula_rows(self.loads)

    @cached_property
    def each_load(self) -> tuple[tuple[LoadArrays, Model], ...]:
        """Each load of ``specs`` alone: its arrays and a model of ``model``'s numba type (the
        groups the scene has present, empty where this load has no rows; no Python torque), so
        that one compiled specialisation evaluates any of them (the recording's load views)."""
        like = self.model if self.model.user is None else self.model._replace(user=None)
        alone = [compile_loads(self.body, (load,), self.axes, self.moments) for load in self.specs]
        return tuple((arrays, build_model(arrays, self.moments, like=like)) for arrays in alone)

    def kernel_constants(self, method: str, order: int | None, build: Callable[[], tuple]) -> tuple:
        """The constants ``method``'s kernel takes at ``order`` besides the model (a force map, a
        table of modified moments), built on first use."""
        key = (method, order)
        if key not in self._kernel_constants:
            self._kernel_constants[key] = build()
        return self._kernel_constants[key]


def _rigid_field(name: str) -> property:
    return property(lambda scene: getattr(scene.rigid, name), doc=f"``Rigid.{name}``")


@dataclass(frozen=True)
class Scene:
    """A scenario to run: its shared ``rigid`` part (body and loads) and its initial state."""

    scenario: cfg.Scenario
    rigid: Rigid
    omega0: np.ndarray  # ω at t0, principal body frame
    q0: np.ndarray  # Λ at t0, principal body → space

    moments = _rigid_field("moments")
    axes = _rigid_field("axes")
    axes_quaternion = _rigid_field("axes_quaternion")
    loads = _rigid_field("loads")
    kind = _rigid_field("kind")
    kind_reason = _rigid_field("kind_reason")
    has_potential = _rigid_field("has_potential")
    has_work = _rigid_field("has_work")
    field_direction = _rigid_field("field_direction")
    symmetry_axis = _rigid_field("symmetry_axis")
    free_of_loads = _rigid_field("free_of_loads")
    rotor_momentum = _rigid_field("rotor_momentum")
    model = _rigid_field("model")
    content_key = _rigid_field("content_key")
    is_principal = _rigid_field("is_principal")
    shortest_window = _rigid_field("shortest_window")
    has_switches = _rigid_field("has_switches")
    formula_switches = _rigid_field("formula_switches")
    formula_rows = _rigid_field("formula_rows")

    def explain_fault(self, fault: Fault) -> str:
        """A run's failure message for the fault one of its compiled loads recorded."""
        return fault_words.explain(fault, self.loads)

    @cached_property
    def state0(self) -> np.ndarray:
        """The state at t0 in ``rotlab.core.state``'s layout: Λ, ω (principal frame), W = 0, and
        the driven rotors' momenta (``drive_momenta0``).
        Read-only: a run starts from a copy (``rotlab.methods.stepping.initial_state``)."""
        y = np.zeros(STATE_SIZE + len(self.drive_momenta0))
        y[LAMBDA], y[OMEGA] = self.q0, self.omega0
        y[STATE_SIZE:] = self.drive_momenta0
        y.flags.writeable = False
        return y

    @cached_property
    def drive_momenta0(self) -> np.ndarray:
        """J Ω of each driven rotor at t0 (N·m·s): the state's columns after ``STATE_SIZE``."""
        return np.array([rotor.momentum_value() for _, rotor in self.scenario.driven_rotors()], dtype=float)

    @cached_property
    def rate_scale(self) -> float:
        """A characteristic angular rate (rad/s) of the scene: max(|ω0|, √(|M|/I_min), load frequencies)."""
        return self.rate_from(self.omega0.tolist())

    def rate_from(self, omega0: Sequence[float]) -> float:
        """``rate_scale`` of this body and loads started with ``omega0`` (three numbers) instead."""
        return max(math.sqrt(sum(w * w for w in omega0)), self.rigid.load_rate)

    @cached_property
    def invariants(self) -> tuple[str, ...]:
        """The names of the quantities this scene conserves (``rotlab.invariants``)."""
        return invariant_table.names_for(self)


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
    body frame in, M in ``frame``) compiled by numba (``rotlab.scene.user_torque``)."""
    if torque is None:
        rigid = RIGID_PARTS.get(scenario)
    else:
        rigid = _build_rigid(scenario, user_torque(torque, frame, _principal(scenario.body)[1]), torque)
    q0 = initial_quaternion(scenario.initial)
    if scenario.body.principal_moments is None:  # Λ_P = Λ_U ∘ Λ_axes
        q0 = quat.multiply(q0, rigid.axes_quaternion)
    omega0 = rigid.axes.T @ np.asarray(scenario.initial.omega, dtype=float)
    return Scene(scenario=scenario, rigid=rigid, q0=q0, omega0=omega0)


class RigidParts:
    """The ``Rigid`` part of the scenarios seen, by body and loads (at most ``size``, the oldest
    dropped first): equal bodies and loads share one, however the scenario was written."""

    def __init__(self, size: int = 256) -> None:
        self._kept: Kept[Rigid] = Kept(size)

    def get(self, scenario: cfg.Scenario) -> Rigid:
        key: object = (scenario.body, tuple(scenario.loads), tuple(scenario.rotors))  # frozen models, compared by value ...
        try:
            hash(key)
        except TypeError:  # ... unless a load holds a mapping (an expression's constants)
            key = "".join(part.model_dump_json() for part in (scenario.body, *scenario.loads, *scenario.rotors))
        return self._kept.get(key, lambda: _build_rigid(scenario, None))


RIGID_PARTS = RigidParts()


def _principal(body: cfg.Body) -> tuple[np.ndarray, np.ndarray]:
    """(principal moments, axes): columns of ``axes`` are the principal axes in the user's frame."""
    if body.principal_moments is not None:  # the user's axes are the principal axes
        return np.asarray(body.principal_moments, dtype=float), np.eye(3)
    return inertia.principal_axes(body.tensor())


def _build_rigid(scenario: cfg.Scenario, user, user_function: Callable | None = None) -> Rigid:
    moments, axes = _principal(scenario.body)
    axes_q = np.array([1.0, 0.0, 0.0, 0.0]) if scenario.body.principal_moments is not None else quat.from_matrix(axes)
    loads = compile_loads(scenario.body, scenario.loads, axes, moments, user, user_function, scenario.rotors)
    forces = active_forces(loads)
    has_work = has_nonconservative(loads)  # the rotors' drives too: they work on the body
    external_work = has_nonconservative(loads._replace(drives=None))  # (a drive is internal: L = I ω + h is kept)
    direction = _common_direction(forces[:, F_FORCE:F_FORCE + 3]) if len(forces) and not external_work else None
    h = axes.T @ scenario.rotor_momentum()  # principal frame
    rotors = h if np.any(h != 0.0) else None
    gyrostat = rotors is not None or loads.drives is not None
    kind, reason, symmetry_axis = _gyrostat(scenario) if gyrostat else _classify(moments, forces, has_work)
    return Rigid(body=scenario.body, specs=tuple(scenario.loads), moments=moments, axes=axes, axes_quaternion=axes_q, loads=loads, kind=kind, kind_reason=reason,
                 free_of_loads=not len(forces) and not external_work, rotor_momentum=rotors,
                 has_potential=bool(len(forces)), has_work=has_work, field_direction=None if direction is None else -direction,
                 symmetry_axis=symmetry_axis)


def _gyrostat(scenario: cfg.Scenario) -> tuple[str, str, None]:
    """A body with rotors: a gyrostat, whatever its loads (no closed form here; no symmetry invariant kept)."""
    driven = len(scenario.driven_rotors())
    drives = f", {driven} of them driven" if driven else ""
    h = np.array2string(scenario.rotor_momentum(driven=None), precision=4)
    return GYROSTAT, f"rotors carry the momentum h = {h} N·m·s at t0 (body frame){drives}", None


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
    arm = forces[0, F_POINT:F_POINT + 3] / np.linalg.norm(forces[0, F_POINT:F_POINT + 3])
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
