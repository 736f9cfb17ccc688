"""Linear stability of a relative equilibrium: the eigenvalues of the equations of motion
linearised about the scene's initial state, and a verdict.

Phase space (principal body frame): ω for a torque-free body; (ω, γ) for a body in a uniform
field, γ = Rᵀ·up the field's "up" in body axes (the Euler–Poisson equations).  Parallel
constant forces F_i = s_i·up at body points p_i give M = c × γ with c = Σ s_i p_i, so

    I ω̇ = (I ω + h) × ω + c × γ,        γ̇ = γ × ω,

(h: a gyrostat's rotors' momentum, zero without rotors),

and the attitude about "up" (and, torque-free, the whole attitude) is left out: it is neutral and
does not feed back.  An equilibrium of these equations is a relative equilibrium of the body: a
permanent rotation about a principal axis, or a top spinning about the vertical (sleeping).  A
Lagrange top's steady precession is one in the top's reduced coordinates (θ, θ̇) instead
(``steady_precession``).
The Jacobian is exact:

    ∂ω̇/∂ω = I⁻¹([Iω + h]× − [ω]× I),  ∂ω̇/∂γ = I⁻¹[c]×,  ∂γ̇/∂ω = [γ]×,  ∂γ̇/∂γ = −[ω]×.

Verdict: "unstable" when the largest real part exceeds ``NEUTRAL`` × the scene's rate scale (the
eigenvalues of a Jacobian with repeated zero eigenvalues — the Casimirs |γ|, L·γ — carry
rounding of ~√ε relative); else "linearly stable": every eigenvalue on the imaginary axis,
small oscillations neither grow nor decay (a linearisation cannot decide nonlinear stability:
the free body's major and minor axes are stable, energy–Casimir; a sleeping top with C²ω₃² >
4 A m g l is too).  Closed forms the tests hold it to: the intermediate axis grows at
λ = Ω √((I₂−I₁)(I₃−I₂)/(I₁I₃)); a sleeping top is unstable iff C²ω₃² < 4 A m g l, growing at
√(4 A m g l − C²ω₃²)/(2A); a gyrostat spinning at Ω about principal axis 2 with h = h e₂ has
λ² = −((I₂−I₃)Ω + h)((I₂−I₁)Ω + h)/(I₁I₃): a rotor can hold the intermediate axis (a dual-spin body).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from rotlab.config.models import Scenario
from rotlab.core import quaternion as quat
from rotlab.errors import InputError
from rotlab.phase_portrait import field_arm, top_reduction

NEUTRAL = 1e-6  # |Re λ| below this × the rate scale counts as zero
EQUILIBRIUM = 1e-9  # |dx/dt| below this × its scale counts as at rest (in the body frame)


@dataclass(frozen=True)
class Stability:
    """The linearisation of a scene at its initial state (module docstring)."""

    space: str  # the phase space, in words
    state: np.ndarray  # x₀: ω (rad/s) or (ω, γ), principal body frame
    jacobian: np.ndarray  # ∂ẋ/∂x at x₀, 1/s
    eigenvalues: np.ndarray  # 1/s, complex, largest real part first
    growth_rate: float  # max Re λ, 1/s (≤ 0 to within NEUTRAL: none)
    verdict: str  # "unstable" | "linearly stable"
    rate_scale: float  # 1/s: |ω₀| and √(|c| / I_min)

    def __str__(self) -> str:
        lines = [f"phase space: {self.space}", f"verdict: {self.verdict}"]
        if self.verdict == "unstable":
            lines.append(f"growth rate: {self.growth_rate:.9g} 1/s (e-folding time {1.0 / self.growth_rate:.6g} s)")
        lines.append("eigenvalues (1/s): " + ", ".join(_complex(v) for v in self.eigenvalues))
        return "\n".join(lines)


def _complex(value: complex) -> str:
    re, im = float(np.real(value)), float(np.imag(value))
    return f"{re:.6g}" if im == 0.0 else f"{re:.6g}{im:+.6g}i"


def _cross_matrix(v: np.ndarray) -> np.ndarray:
    """[v]×: [v]× u = v × u."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def stability(scenario: Scenario | str | Path, *, overrides: Mapping[str, Any] | None = None) -> Stability:
    """The linear stability of ``scenario`` (object or file) at its initial state (module
    docstring).  An ``InputError`` names what makes the scene out of reach: loads that are not
    constant parallel forces, or an initial state that is not an equilibrium."""
    from rotlab.api import scenario_of
    from rotlab.scene.scene import build_scene

    scene = build_scene(scenario_of(scenario, overrides=overrides))
    if scene.has_work or (scene.has_potential and scene.field_direction is None):
        raise InputError("loads", "stability analyses a torque-free body or one in a uniform field (constant parallel forces); "
                                  f"this scene is {scene.kind}: {scene.kind_reason}")
    moments = np.asarray(scene.moments, dtype=float)
    state0 = scene.state0
    omega = state0[4:7].copy()
    inverse = np.diag(1.0 / moments)
    h = np.zeros(3) if scene.rotor_momentum is None else np.asarray(scene.rotor_momentum, dtype=float)
    d_omega_d_omega = inverse @ (_cross_matrix(moments * omega + h) - _cross_matrix(omega) @ np.diag(moments))
    if not scene.has_potential:
        rate = float(np.linalg.norm(omega))
        _check_rest(moments, h, omega, None, None, rate)
        jacobian, x0, space = d_omega_d_omega, omega, "ω (principal body frame, rad/s); the attitude is neutral"
    else:
        up = np.asarray(scene.field_direction, dtype=float)
        unit_q = state0[0:4] / np.linalg.norm(state0[0:4])
        gamma = quat.rotate_to_body_array(unit_q, up)
        c = field_arm(scene)
        rate = float(max(np.linalg.norm(omega), np.sqrt(np.linalg.norm(c) / np.min(moments))))
        if scene.symmetry_axis is not None and not _at_rest(moments, h, omega, gamma, c, rate):
            return steady_precession(moments, np.asarray(scene.symmetry_axis, dtype=float), omega, gamma, c, rate)
        _check_rest(moments, h, omega, gamma, c, rate)
        jacobian = np.block([[d_omega_d_omega, inverse @ _cross_matrix(c)], [_cross_matrix(gamma), -_cross_matrix(omega)]])
        x0 = np.concatenate([omega, gamma])
        space = ("(ω, γ): ω (principal body frame, rad/s) and γ = Rᵀ·up, the field's up in body axes; "
                 "the attitude about up is neutral")
    eigenvalues = np.linalg.eigvals(jacobian)
    eigenvalues = eigenvalues[np.argsort(-eigenvalues.real, kind="stable")]
    growth = float(np.max(eigenvalues.real)) if eigenvalues.size else 0.0
    unstable = rate > 0.0 and growth > NEUTRAL * rate
    return Stability(space, x0, jacobian, eigenvalues, growth if unstable else 0.0, "unstable" if unstable else "linearly stable", rate)


def _rates(moments: np.ndarray, h: np.ndarray, omega: np.ndarray, gamma: np.ndarray | None,
           c: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(ω̇, γ̇) of the module docstring's equations."""
    torque = np.zeros(3) if c is None else np.cross(c, gamma)
    return (np.cross(moments * omega + h, omega) + torque) / moments, np.zeros(3) if gamma is None else np.cross(gamma, omega)


def _at_rest(moments: np.ndarray, h: np.ndarray, omega: np.ndarray, gamma: np.ndarray | None, c: np.ndarray | None,
             rate: float) -> bool:
    """ω̇ = 0 and γ̇ = 0 at the state, to ``EQUILIBRIUM`` of rate² and rate."""
    omega_dot, gamma_dot = _rates(moments, h, omega, gamma, c)
    return rate == 0.0 or (np.linalg.norm(omega_dot) <= EQUILIBRIUM * rate**2 and np.linalg.norm(gamma_dot) <= EQUILIBRIUM * rate)


def _check_rest(moments: np.ndarray, h: np.ndarray, omega: np.ndarray, gamma: np.ndarray | None, c: np.ndarray | None,
                rate: float) -> None:
    """An ``InputError`` unless the state is at rest (``_at_rest``)."""
    if not _at_rest(moments, h, omega, gamma, c, rate):
        omega_dot, gamma_dot = _rates(moments, h, omega, gamma, c)
        what = ("a permanent rotation about a principal axis (ω₀ along one)" if gamma is None and not np.any(h) else
                "a gyrostat's permanent rotation (I ω₀ + h parallel to ω₀)" if gamma is None else
                "a permanent rotation about a principal axis that is vertical, with the centre of mass on it (a sleeping top), "
                "or a Lagrange top's steady precession")
        raise InputError("initial", f"not an equilibrium: |dω/dt| = {np.linalg.norm(omega_dot):.3g} rad/s², |dγ/dt| = "
                                    f"{np.linalg.norm(gamma_dot):.3g} 1/s in the body frame; stability analyses {what}")


def steady_precession(moments: np.ndarray, axis: np.ndarray, omega: np.ndarray, gamma: np.ndarray, c: np.ndarray,
                      rate: float) -> Stability:
    """A Lagrange top (symmetry axis e, A about the axes across it, C along it) in steady
    precession: ω = ψ̇ γ + φ̇ e (θ̇ = 0) at a tilt θ₀ where the effective potential
    (``phase_portrait.TopReduction.potential``)

        U(θ) = (p_ψ − C ω₃ cos θ)² / (2 A sin² θ) + k cos θ,   p_ψ = L·γ, ω₃ = ω·e, k = −c·e (= m g l)

    is stationary.  With p_ψ and ω₃ conserved, A θ̈ = −U'(θ): about θ₀ the eigenvalues are
    ±√(−U''(θ₀)/A) — the nutation at √(U''/A) rad/s when U'' > 0.  U' by a complex step, U'' by a
    central difference of it (~1e-10 relative)."""
    cos0 = float(np.clip(axis @ gamma, -1.0, 1.0))
    theta0 = float(np.arccos(cos0))
    along = np.linalg.lstsq(np.column_stack([gamma, axis]), omega, rcond=None)[0]
    nodal = float(np.linalg.norm(omega - along[0] * gamma - along[1] * axis))
    top = top_reduction(moments, axis, omega, gamma, c)  # e is a principal axis
    a_moment, spin, p_psi, k = top.a_moment, top.spin, top.p_psi, top.k

    def slope(theta: float) -> float:
        return float(np.imag(top.potential(theta + 1e-20j)) / 1e-20)

    scale = abs(k) + a_moment * rate**2  # J: the potential's and the kinetic energy's size
    if np.sin(theta0) < 1e-9 or nodal > EQUILIBRIUM * rate or abs(slope(theta0)) > EQUILIBRIUM * scale:
        raise InputError("initial", f"not an equilibrium: a Lagrange top at θ = {np.degrees(theta0):.6g}° with θ̇ = {nodal:.3g} rad/s "
                                    f"and U'(θ) = {slope(theta0):.3g} J is not in steady precession; stability analyses a permanent "
                                    "rotation, a sleeping top, or a steady precession (ω = ψ̇ γ + φ̇ e with A ψ̇² cos θ − C ω₃ ψ̇ + m g l = 0)")
    delta = 1e-5
    curvature = (slope(theta0 + delta) - slope(theta0 - delta)) / (2.0 * delta)
    root = np.sqrt(complex(-curvature / a_moment))
    eigenvalues = np.array([root, -root])
    eigenvalues = eigenvalues[np.argsort(-eigenvalues.real, kind="stable")]
    growth = float(np.max(eigenvalues.real))
    unstable = growth > NEUTRAL * rate
    jacobian = np.array([[0.0, 1.0], [-curvature / a_moment, 0.0]])
    return Stability(f"(θ, θ̇) of the Lagrange top at p_ψ = {p_psi:.6g} kg·m²/s and ω₃ = {spin:.6g} rad/s (steady precession at "
                     f"θ₀ = {np.degrees(theta0):.6g}°, ψ̇ = {along[0]:.6g} rad/s)", np.array([theta0, 0.0]), jacobian, eigenvalues,
                     growth if unstable else 0.0, "unstable" if unstable else "linearly stable", rate)
