"""Every load kind, declared once: its config model (``rotlab.config.models``), the load group it
compiles to (whose torque ``rotlab.core.torques`` computes, for the kernels, the recording's load
view and the bench's peers alike), whether it has a potential or does work, and how the viewer
draws it.  ``KINDS`` is keyed by the config model; a config model without a kind here (or a kind
without a config model) is an error at import, so no load can be dropped on its way to the
kernels.

Load groups (columns named in ``rotlab.core.torques``), body vectors in the principal frame:

* forces   constant space-frame force F at body point p:  M = p × (Rᵀ F)   potential V = −F · (R p)
* terms    offset + amplitude · sin(w t + φ) inside [on, off), body or space frame    work W
* tables   piecewise-linear M(t), body or space frame                                 work W
* damping  M = −k ω                                                                   work W
* formulas components are programs (``rotlab.config.expressions``) of t, ω, Λ, γ, L in the
           user's body frame; a torque, or a force at a body point                    work W

Work of the non-conservative loads: Ẇ = M_nc · ω, so that T + V − W is invariant.

Adding a load kind: its pydantic model in ``rotlab.config.models`` (listed in ``LOAD_KINDS``) and
one ``LoadKind`` here; a new load group also needs its torque in ``rotlab.core.torques``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from rotlab.config import models as cfg
from rotlab.core.torques import BODY, SPACE
from rotlab.scene import geomagnetic



@dataclass(frozen=True)
class Arrow:
    """How the viewer draws a load: a force at its point of application (``point``, user's body
    frame; ``force`` in ``frame``) or its torque at the fixed point."""

    shows: Literal["force", "torque"]
    letter: str  # the 3D label's letter: F1, M2; a fixed label (``mg``) when ``numbered`` is False
    frame: str  # "body" | "space": the frame the load's vectors are given in
    description: str  # may name its ``{number}`` among the loads drawn with the same letter
    point: tuple[float, float, float] | None = None
    force: np.ndarray | None = None
    numbered: bool = True


class Compiling:
    """The scenario's loads being turned into the kernels' groups (``rotlab.scene.loads``)."""

    def __init__(self, body: cfg.Body, axes: np.ndarray, programs: Any) -> None:
        self.body, self.to_principal, self.programs = body, axes.T, programs
        self.forces: list[np.ndarray] = []
        self.terms: list[np.ndarray] = []
        self.tables: list[list[float]] = []
        self.table_t: list[float] = []
        self.table_v: list[np.ndarray] = []
        self.damping = 0.0

    def body_vector(self, v: tuple[float, float, float]) -> np.ndarray:
        """A vector given in the user's body frame, in principal components (Pᵀ v)."""
        return self.to_principal @ np.asarray(v, dtype=float)

    def vector(self, frame: str, v: tuple[float, float, float]) -> np.ndarray:
        """A vector given in ``frame``: body vectors in principal components, space ones unchanged."""
        return self.body_vector(v) if frame == "body" else np.asarray(v, dtype=float)

    def force(self, point: np.ndarray, force: np.ndarray) -> None:
        self.forces.append(np.concatenate([point, force]))

    def term(self, frame: str, window: cfg.Window | None, offset: np.ndarray, amplitude: np.ndarray = np.zeros(3),
             w: float = 0.0, phase: float = 0.0) -> None:
        self.terms.append(np.array([frame_code(frame), *window_of(window), *offset, *amplitude, w, phase], dtype=float))

    def table(self, frame: str, window: cfg.Window | None, times: tuple[float, ...], values: list[np.ndarray]) -> None:
        first = len(self.table_t)
        self.table_t.extend(times)
        self.table_v.extend(values)
        self.tables.append([frame_code(frame), *window_of(window), first, len(self.table_t)])


def window_of(window: cfg.Window | None) -> tuple[float, float]:
    """[on, off) of a load; always on without a window."""
    return (-np.inf, np.inf) if window is None else (window.on, window.off)


def frame_code(frame: str) -> float:
    """A frame's name as the kernels read it: BODY or SPACE."""
    return BODY if frame == "body" else SPACE


@dataclass(frozen=True)
class LoadKind:
    """One load kind: ``compile(load, index, compiling, names)`` adds its rows to a load group
    (module docstring: the forces group has a potential, every other group does work; ``names``:
    what each formula component is called in a failure message); ``arrow(load, body)``: how
    the viewer draws it."""

    model: type[cfg.Load]
    compile: Callable[..., None]
    arrow: Callable[[Any, cfg.Body], Arrow]


def _torque_arrow(load: Any, body: cfg.Body) -> Arrow:
    frame = getattr(load, "frame", "body")
    return Arrow("torque", "M", frame, f"{load.type} ({frame} frame), drawn at the fixed point")


def _force_arrow(load: cfg.Force, body: cfg.Body) -> Arrow:
    return Arrow("force", "F", load.frame, f"force {{number}} ({load.frame} frame) at its point", point=load.point,
                 force=np.asarray(load.value, dtype=float))


def _gravity(load: cfg.Gravity, index: int, c: Compiling, names: Any) -> None:
    mass = c.body.total_mass() or 0.0
    c.force(c.body_vector(c.body.centre()), mass * np.asarray(load.g, dtype=float))


def _gravity_arrow(load: cfg.Gravity, body: cfg.Body) -> Arrow:
    mass = body.total_mass() or 0.0
    return Arrow("force", "mg", "space", "gravity m·g at the centre of mass (space frame)", point=body.centre(),
                 force=mass * np.asarray(load.g, dtype=float), numbered=False)


def _force(load: cfg.Force, index: int, c: Compiling, names: Any) -> None:
    point = c.body_vector(load.point)
    if load.frame == "space" and load.window is None:  # conservative: potential −F · (R p)
        c.force(point, np.asarray(load.value, dtype=float))
    elif load.frame == "space":  # switched on and off: does work, a formula force at the point
        c.programs.formulas([repr(float(v)) for v in load.value], {}, SPACE, window_of(load.window), point=point, names=names)
    else:  # a body-frame force: the constant follower torque p × F
        c.term("body", load.window, np.cross(point, c.body_vector(load.value)))


def _torque(load: cfg.Torque, index: int, c: Compiling, names: Any) -> None:
    c.term(load.frame, load.window, c.vector(load.frame, load.value))


def _harmonic(load: cfg.HarmonicTorque, index: int, c: Compiling, names: Any) -> None:
    offset, amplitude = c.vector(load.frame, load.offset), c.vector(load.frame, load.amplitude)
    if load.angular_frequency == 0.0:  # a constant: folded into the offset
        offset, amplitude = offset + amplitude * np.sin(load.phase), np.zeros(3)
    c.term(load.frame, load.window, offset, amplitude, load.angular_frequency, load.phase)


def _table(load: cfg.TorqueTable, index: int, c: Compiling, names: Any) -> None:
    c.table(load.frame, load.window, load.times, [c.vector(load.frame, v) for v in load.values])


def _damping(load: cfg.Damping, index: int, c: Compiling, names: Any) -> None:
    c.damping += load.coefficient


def _expression(load: cfg.Expression, index: int, c: Compiling, names: Any) -> None:
    point = None if load.point is None else c.body_vector(load.point)
    up = np.asarray(load.up, dtype=float)
    c.programs.add(load.programs(), frame_code(load.frame), window_of(load.window), point=point, up=up / np.linalg.norm(up), names=names)


def _pd_terms(load: cfg.PDControl) -> tuple[list[str], dict[str, float]]:
    """The three components of −kp sgn(δ₀) δ_v − kd ω (unclipped) as formulas, and their constants:
    δ = Λ̃_target ∘ Λ, δ₀ = τ₀λ₀ + τ·λ,  δ_v = τ₀ λ_v − λ₀ τ_v − τ_v × λ_v  (τ the target)."""
    constants = {"a0": load.target[0], "a1": load.target[1], "a2": load.target[2], "a3": load.target[3], "kp": load.kp, "kd": load.kd}
    d0 = "(a0*q[0] + a1*q[1] + a2*q[2] + a3*q[3])"
    delta = ["(a0*q[1] - q[0]*a1 - (a2*q[3] - a3*q[2]))",
             "(a0*q[2] - q[0]*a2 - (a3*q[1] - a1*q[3]))",
             "(a0*q[3] - q[0]*a3 - (a1*q[2] - a2*q[1]))"]
    return [f"-kp*sign({d0})*{d} - kd*omega[{i}]" for i, d in enumerate(delta)], constants


def _clipped(text: str, limit: float | None, constants: dict[str, float]) -> str:
    """``text`` clipped to ±``limit`` (as is without one)."""
    if limit is None:
        return text
    constants["limit"] = limit
    return f"max(-limit, min(limit, {text}))"


def _pd_control(load: cfg.PDControl, index: int, c: Compiling, names: Any) -> None:
    """M_i = sat(−kp sgn(δ₀) δ_i − kd ω_i) (``_pd_terms``)."""
    texts, constants = _pd_terms(load)
    c.programs.formulas([_clipped(text, load.max_torque, constants) for text in texts], constants, BODY, window_of(load.window), names=names)


def drive_formula(rotor: cfg.Rotor) -> tuple[list[tuple[Any, int]], tuple[float, float]]:
    """A driven rotor's drive torque u as a program, and its window: the user's formula, or a
    ``pd_control`` drive's share of the controller's body torque M: the body feels −u â, so
    u = −â·M = kp sgn(δ₀) â·δ_v + kd â·ω, clipped to ±max_torque (â the axis, user's body frame)."""
    from rotlab.config.expressions import parse_formula

    if isinstance(rotor.torque, str):
        return [rotor.program()], (-np.inf, np.inf)
    load = rotor.torque
    axis = rotor.unit_axis()
    texts, constants = _pd_terms(load)  # type: ignore[arg-type]
    constants.update({f"e{i}": float(axis[i]) for i in range(3)})
    share = " + ".join(f"e{i}*({text})" for i, text in enumerate(texts))
    return [parse_formula(_clipped(f"-({share})", load.max_torque, constants), constants)], window_of(load.window)  # type: ignore[union-attr]


def _quadratic_drag(load: cfg.QuadraticDrag, index: int, c: Compiling, names: Any) -> None:
    """M = −c |ω| ω."""
    texts = [f"-c*sqrt(omega[0]**2 + omega[1]**2 + omega[2]**2)*omega[{i}]" for i in range(3)]
    c.programs.formulas(texts, {"c": load.coefficient}, BODY, window_of(load.window), names=names)


def _gravity_gradient(load: cfg.GravityGradient, index: int, c: Compiling, names: Any) -> None:
    """M = 3 n² γ × (I γ), γ the local vertical in the user's body frame, turning at the orbit rate."""
    inertia = user_inertia(c.body)
    constants = {"k": 3.0 * load.orbit_rate**2, **{f"I{i}{j}": float(inertia[i, j]) for i in range(3) for j in range(3)}}
    ig = [f"(I{i}0*gamma[0] + I{i}1*gamma[1] + I{i}2*gamma[2])" for i in range(3)]
    texts = [f"k*(gamma[{(i + 1) % 3}]*{ig[(i + 2) % 3]} - gamma[{(i + 2) % 3}]*{ig[(i + 1) % 3]})" for i in range(3)]
    vertical = np.asarray(load.vertical, dtype=float) / np.linalg.norm(load.vertical)
    normal = np.asarray(load.orbit_normal, dtype=float) / np.linalg.norm(load.orbit_normal)
    c.programs.formulas(texts, constants, BODY, (-np.inf, np.inf), up=vertical, up2=np.cross(normal, vertical), rate=load.orbit_rate,
                        names=names)


MAGNETIC_FORMULA_NODES = 1200  # the B-dot torque written out (B six times per component): longer than a user's formula may be


def _magnetic_field(load: cfg.MagneticDipole | cfg.BDotDetumbling) -> tuple[list[str], dict[str, float], dict[str, object]]:
    """(B's body components as formulas, their constants, the row's γ: r̂(t) in body components)
    of ``rotlab.scene.geomagnetic``'s field: B = b (3 (m̂·r̂) γ − Rᵀ m̂), m̂·r̂ = c1 cos(n t) + c2 sin(n t),
    Rᵀ m̂ from Λ (q, the user's body frame)."""
    n = geomagnetic.orbit_rate(load.altitude)
    u, v = geomagnetic.orbit_plane(load.inclination_deg)
    m_hat = geomagnetic.dipole_axis(load.tilt_deg)
    constants = {"b": geomagnetic.field_strength(load.altitude, load.field), "n": n, "c1": float(m_hat @ u), "c2": float(m_hat @ v),
                 "m0": float(m_hat[0]), "m1": float(m_hat[1]), "m2": float(m_hat[2])}
    rotation = [["1 - 2*(q[2]**2 + q[3]**2)", "2*(q[1]*q[2] - q[0]*q[3])", "2*(q[1]*q[3] + q[0]*q[2])"],  # R(Λ), body → space
                ["2*(q[1]*q[2] + q[0]*q[3])", "1 - 2*(q[1]**2 + q[3]**2)", "2*(q[2]*q[3] - q[0]*q[1])"],
                ["2*(q[1]*q[3] - q[0]*q[2])", "2*(q[2]*q[3] + q[0]*q[1])", "1 - 2*(q[1]**2 + q[2]**2)"]]
    m_body = [" + ".join(f"({rotation[j][i]})*m{j}" for j in range(3)) for i in range(3)]
    field = [f"(b*(3*(c1*cos(n*t) + c2*sin(n*t))*gamma[{i}] - ({m_body[i]})))" for i in range(3)]
    return field, constants, {"up": u, "up2": v, "rate": n}


def _cross(a: list[str], b: list[str]) -> list[str]:
    """The components of a × b, as formulas."""
    return [f"({a[(i + 1) % 3]}*{b[(i + 2) % 3]} - {a[(i + 2) % 3]}*{b[(i + 1) % 3]})" for i in range(3)]


def _magnetic_dipole(load: cfg.MagneticDipole, index: int, c: Compiling, names: Any) -> None:
    """M = m × B (body frame)."""
    field, constants, gamma = _magnetic_field(load)
    constants.update({f"d{i}": float(load.dipole[i]) for i in range(3)})
    texts = _cross(["d0", "d1", "d2"], field)
    c.programs.formulas(texts, constants, BODY, window_of(load.window), max_nodes=MAGNETIC_FORMULA_NODES, names=names, **gamma)


def _bdot(load: cfg.BDotDetumbling, index: int, c: Compiling, names: Any) -> None:
    """m = sat(k ω × B) per body axis, M = m × B."""
    field, constants, gamma = _magnetic_field(load)
    constants.update({"k": load.gain, "limit": load.max_dipole})
    dipole = [f"max(-limit, min(limit, k*{x}))" for x in _cross(["omega[0]", "omega[1]", "omega[2]"], field)]
    c.programs.formulas(_cross(dipole, field), constants, BODY, window_of(load.window), max_nodes=MAGNETIC_FORMULA_NODES, names=names,
                        **gamma)


def user_inertia(body: cfg.Body) -> np.ndarray:
    """The inertia tensor in the user's body frame."""
    return body.tensor()


_DECLARED = (
    LoadKind(cfg.Gravity, _gravity, _gravity_arrow),
    LoadKind(cfg.Force, _force, _force_arrow),
    LoadKind(cfg.Torque, _torque, _torque_arrow),
    LoadKind(cfg.HarmonicTorque, _harmonic, _torque_arrow),
    LoadKind(cfg.TorqueTable, _table, _torque_arrow),
    LoadKind(cfg.Damping, _damping, _torque_arrow),
    LoadKind(cfg.Expression, _expression, _torque_arrow),
    LoadKind(cfg.PDControl, _pd_control, _torque_arrow),
    LoadKind(cfg.QuadraticDrag, _quadratic_drag, _torque_arrow),
    LoadKind(cfg.GravityGradient, _gravity_gradient, _torque_arrow),
    LoadKind(cfg.MagneticDipole, _magnetic_dipole, _torque_arrow),
    LoadKind(cfg.BDotDetumbling, _bdot, _torque_arrow),
)
KINDS: dict[type, LoadKind] = {kind.model: kind for kind in _DECLARED}


def _check_complete() -> None:
    """Every config load model has exactly one kind here, and every kind a config model."""
    declared, configured = set(KINDS), set(cfg.LOAD_KINDS)
    if declared != configured or len(_DECLARED) != len(KINDS):
        missing = ", ".join(m.__name__ for m in configured - declared) or "none"
        extra = ", ".join(m.__name__ for m in declared - configured) or "none"
        raise TypeError(f"load kinds out of step with rotlab.config.models.LOAD_KINDS: no LoadKind for {missing}; no config model for {extra}")


_check_complete()


def kind_of(load: cfg.Load) -> LoadKind:
    """The declaration of ``load``'s kind."""
    return KINDS[type(load)]
