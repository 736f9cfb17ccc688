"""The benchmark problem set: scenarios, references, and the error each one is judged by.

Every problem is a scenario (a dict for ``rotlab.config.parse_scenario``, or a shipped config) with
sample times, and a metric:

* ``state`` — max over the samples of  max(|ω − ω_ref| / max|ω_ref|,  min |Λ ∓ Λ_ref|)
  (ω relative to its largest magnitude over the run; the attitude as the distance between unit
  quaternions up to their sign, ≈ half the rotation angle between the two attitudes, rad).
* ``energy`` — max |H − H₀| / max(|H₀|, T₀ + |V₀|), H = T + V (a chaotic heavy top: no reference).
* ``kovalevskaya`` — max |K − K₀| / K₀ of Kovalevskaya's fourth integral (below).

Problems
--------
``gni``  GNI free body: I = (2, 1, 2/3), m₀ = L₀ = (cos 1.1, 0, sin 1.1), ω₀ = m₀ / I, t ∈ [0, 100],
    101 samples (Hairer, Lubich & Wanner, "Geometric Numerical Integration", §VII.5).  Breaks the
    triangle inequality: a test problem (``allow_triangle_violation``).  Reference: ``exact``.

``krogh``  Krogh's rigid body (DETEST B5, Hull et al. 1972): y′ = (y₂y₃, −y₁y₃, −0.51 y₁y₂),
    y₀ = (0, 1, 1), t ∈ [0, 12], exact y = (sn, cn, dn)(t | 0.51).  As Euler's equations
    ṗ = a q r, q̇ = b r p, ṙ = c p q  (a = (B − C)/A, b = (C − A)/B, c = (A − B)/C) it needs a
    scaling ω = (s₁y₁, s₂y₂, s₃y₃): a s₂s₃/s₁ = 1, b s₃s₁/s₂ = −1, c s₁s₂/s₃ = −0.51, i.e.
        s₁² = 0.51/(bc),  s₂² = −0.51/(ac),  s₃² = −1/(ab),
    which works for any moments with B > A > C.  (Taking s = 1, i.e. (a, b, c) = (1, −1, −0.51)
    directly, is impossible: a = 1, b = −1 force B = A and C = 0.)  We take (A, B, C) = (2, 3, 1),
    a flat plate (A + C = B): a = 1, b = −1/3, c = −1, s = (√1.53, √0.51, √3), ω₀ = (0, √0.51, √3),
    and ω(t) = (√1.53 sn, √0.51 cn, √3 dn)(t | 0.51) exactly, with no time scaling.  Reference: ω
    from ``scipy.special.ellipj`` (independent of rotlab), Λ from rotlab's ``exact`` (whose ω agrees
    with ellipj to ~1e-14).

``hnw-eulr``  Hairer–Nørsett–Wanner EULR (Solving ODEs I, §II.10): I = (0.5, 2, 3), ω₀ = (1, 0, 0.9),
    ω̇₃ forced by f(t) = 0.25 sin² t for 3π ≤ t ≤ 4π, t ∈ [0, 20] (201 samples).  As a body torque
    M₃ = C f(t) = 0.375 − 0.375 cos 2t = ``harmonic_torque`` with offset 0.375, amplitude 0.375,
    angular frequency 2, phase −π/2, window [3π, 4π).  Reference: rotlab ``dop853`` at rtol 1e-15,
    atol 1e-17 (checked against scipy DOP853 at rtol 1e-13: the difference is reported).

``lagrange``  ``configs/lagrange.toml`` (heavy symmetric top, 2001 samples over 10 s).  Reference:
    ``exact`` (elliptic functions), checked against dop853 at rtol 1e-14; if ``exact`` fails the
    reference falls back to that dop853 run and the record says so.

``heavy-top``  A heavy asymmetric top: I = (1, 1.5, 2) kg·m², m = 1 kg at r_c = (0.1, 0.2, 0.5) m,
    g = 9.81 m/s², ω₀ = (1, 0.5, 6) rad/s, (ψ, θ, φ) = (0, 0.5, 0), t ∈ [0, 20] (201 samples).
    Chaotic, no closed form: the figure is the energy error.

``kovalevskaya``  Kovalevskaya top: I = (2, 2, 1), centre of mass (1, 0, 0), m = 1, g = (0, 0, −1)
    (unit m g), ω₀ = (0.5, 1, 1.5), (ψ, θ, φ) = (0.3, 1, 0.2), t ∈ [0, 50] (501 samples).
    With A = B = 2C, centre of mass (x₀, 0, 0) and γ = Rᵀ e_up (the upward vertical in body
    components), Euler gives ṗ = qr/2, q̇ = −rp/2 + νγ₃/2, ṙ = −νγ₂ with ν = m g x₀ / C, and
    γ̇ = γ × ω.  For ξ = p + iq, z = γ₁ + iγ₂:  ξ̇ = −(ir/2)ξ + iνγ₃/2,  ż = −irz + iγ₃ξ, so
    w = ξ² − νz obeys ẇ = −irw and
        K = |ξ² − νz|² = (p² − q² − νγ₁)² + (2pq − νγ₂)²
    is constant; here ν = 1·1·1/1 = 1.  The figure is max |K − K₀| / K₀ (K₀ ≈ 0.872).

``config:<name>``  Every other shipped ``configs/*.toml`` (lagrange.toml is ``lagrange``): the
    reference is ``exact`` where it applies (torque-free), otherwise dop853 at rtol 1e-15.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rotlab.config.models import Scenario
from rotlab.core import quaternion as quat
from rotlab.scene.loads import potential
from rotlab.scene.scene import Scene
from rotlab.shipped import shipped_configs

CONFIGS = shipped_configs()

STATE, ENERGY, KOVALEVSKAYA = "state", "energy", "kovalevskaya"

GNI_MOMENTS = (2.0, 1.0, 2.0 / 3.0)
KROGH_M = 0.51
KROGH_MOMENTS = (2.0, 3.0, 1.0)


def krogh_scales(moments: tuple[float, float, float] = KROGH_MOMENTS, m: float = KROGH_M) -> np.ndarray:
    """(s₁, s₂, s₃) with ω = (s₁ sn, s₂ cn, s₃ dn)(t | m) the free rotation of ``moments`` (B > A > C)."""
    a_, b_, c_ = moments
    a, b, c = (b_ - c_) / a_, (c_ - a_) / b_, (a_ - b_) / c_
    if not (a > 0.0 and b < 0.0 and c < 0.0):
        raise ValueError("Krogh's mapping needs B > A > C")
    return np.array([math.sqrt(m / (b * c)), math.sqrt(-m / (a * c)), math.sqrt(-1.0 / (a * b))])


@dataclass(frozen=True)
class Problem:
    name: str
    title: str
    data: dict[str, Any] | None = None  # scenario as a dict (parse_scenario) ...
    config: Path | None = None  # ... or a scenario file
    metric: str = STATE
    reference: str = "exact"  # exact | krogh | dop853 | none
    quick: bool = True  # part of the --quick subset
    notes: str = ""
    kovalevskaya_nu: float = 0.0  # ν = m g x₀ / C for the Kovalevskaya integral
    extra: dict[str, Any] = field(default_factory=dict)

    def scenario(self) -> Scenario:
        from rotlab.config import load_scenario, parse_scenario

        if self.config is not None:
            return load_scenario(self.config)
        assert self.data is not None
        return parse_scenario(self.data, source=self.name)


def _gni() -> Problem:
    m0 = np.array([math.cos(1.1), 0.0, math.sin(1.1)])
    return Problem(
        name="gni",
        title="GNI free body, I = (2, 1, 2/3), t ≤ 100",
        data={
            "body": {"principal_moments": list(GNI_MOMENTS), "allow_triangle_violation": True},
            "initial": {"omega": (m0 / np.array(GNI_MOMENTS)).tolist()},
            "time": {"end": 100.0, "samples": 101},
        },
        reference="exact",
    )


def _krogh() -> Problem:
    s = krogh_scales()
    return Problem(
        name="krogh",
        title="Krogh's rigid body (DETEST B5), (sn, cn, dn)(t | 0.51), t ≤ 12",
        data={
            "body": {"principal_moments": list(KROGH_MOMENTS)},
            "initial": {"omega": [0.0, float(s[1]), float(s[2])]},
            "time": {"end": 12.0, "samples": 121},
        },
        reference="krogh",
        notes="moments (2, 3, 1), ω = (√1.53 sn, √0.51 cn, √3 dn)(t | 0.51)",
    )


def _hnw_eulr() -> Problem:
    return Problem(
        name="hnw-eulr",
        title="HNW EULR, I = (0.5, 2, 3), forced on [3π, 4π], t ≤ 20",
        data={
            "body": {"principal_moments": [0.5, 2.0, 3.0], "allow_triangle_violation": True},
            "initial": {"omega": [1.0, 0.0, 0.9]},
            "loads": [{
                "type": "harmonic_torque", "frame": "body", "offset": [0.0, 0.0, 0.375], "amplitude": [0.0, 0.0, 0.375],
                "angular_frequency": 2.0, "phase": -math.pi / 2.0, "window": {"on": 3.0 * math.pi, "off": 4.0 * math.pi},
            }],
            "time": {"end": 20.0, "samples": 201},
        },
        reference="dop853",
        notes="M₃ = C·0.25 sin²t = 0.375 − 0.375 cos 2t on [3π, 4π)",
    )


def _lagrange() -> Problem:
    return Problem(name="lagrange", title="Lagrange top, configs/lagrange.toml", config=CONFIGS / "lagrange.toml", reference="exact")


def _heavy_top() -> Problem:
    return Problem(
        name="heavy-top",
        title="heavy asymmetric top, I = (1, 1.5, 2), r_c = (0.1, 0.2, 0.5): energy error",
        data={
            "body": {"principal_moments": [1.0, 1.5, 2.0], "mass": 1.0, "center_of_mass": [0.1, 0.2, 0.5],
                     "allow_triangle_violation": True},  # a test problem: m r_c² exceeds what these moments allow a real body
            "initial": {"omega": [1.0, 0.5, 6.0], "euler_313": [0.0, 0.5, 0.0]},
            "loads": [{"type": "gravity", "g": [0.0, 0.0, -9.81]}],
            "time": {"end": 20.0, "samples": 201},
        },
        metric=ENERGY,
        reference="none",
    )


def _kovalevskaya() -> Problem:
    return Problem(
        name="kovalevskaya",
        title="Kovalevskaya top, I = (2, 2, 1), r_c = (1, 0, 0), unit m g: max |K − K₀|/K₀",
        data={
            "body": {"principal_moments": [2.0, 2.0, 1.0], "mass": 1.0, "center_of_mass": [1.0, 0.0, 0.0],
                     "allow_triangle_violation": True},  # normalised: unit m at unit distance is no realisable body
            "initial": {"omega": [0.5, 1.0, 1.5], "euler_313": [0.3, 1.0, 0.2]},
            "loads": [{"type": "gravity", "g": [0.0, 0.0, -1.0]}],
            "time": {"end": 50.0, "samples": 501},
        },
        metric=KOVALEVSKAYA,
        reference="none",
        kovalevskaya_nu=1.0,  # ν = m g x₀ / C = 1·1·1/1
    )


def shipped_config_problems() -> list[Problem]:
    """``configs/*.toml`` except lagrange.toml (that one is the ``lagrange`` problem)."""
    from rotlab.config import load_scenario
    from rotlab.scene.scene import TORQUE_FREE, build_scene

    problems = []
    for path in sorted(CONFIGS.glob("*.toml")):
        if path.stem == "lagrange":
            continue
        scene = build_scene(load_scenario(path))
        reference = "exact" if scene.kind == TORQUE_FREE else "dop853"
        problems.append(Problem(name=f"config:{path.stem}", title=f"configs/{path.name} ({scene.kind.replace('_', '-')})", config=path,
                                reference=reference, quick=path.stem in ("euler", "general")))
    return problems


def all_problems() -> list[Problem]:
    return [_gni(), _krogh(), _hnw_eulr(), _lagrange(), _heavy_top(), _kovalevskaya(), *shipped_config_problems()]


def get_problems(names: list[str] | None = None, quick: bool = False) -> list[Problem]:
    """The problems named (all when ``names`` is empty), or the ``--quick`` subset."""
    problems = all_problems()
    if names:
        known = {p.name: p for p in problems}
        missing = [n for n in names if n not in known]
        if missing:
            raise KeyError(f"unknown problem(s) {', '.join(missing)}: choose from {', '.join(known)}")
        return [known[n] for n in names]
    return [p for p in problems if p.quick or not quick]


# --- references and metrics ---------------------------------------------------------------------


@dataclass
class Reference:
    """The reference states (principal frame) at the sample times, how they were obtained, and a
    cross-check (max difference against an independent solution, same metric as the runs)."""

    state: np.ndarray | None  # (N, 7) [Λ, ω], None when the metric needs no reference
    how: str
    check: float | None = None
    check_how: str = ""
    uses_exact: bool = False  # rotlab's exact method is (part of) the reference


def reference_solution(problem: Problem, scene: Scene, t: np.ndarray) -> Reference:
    from rotlab.methods.base import Settings
    from rotlab.methods.registry import get_method

    def dop853(rtol: float = 1e-14, atol: float = 1e-16) -> np.ndarray:  # the check of exact references
        return get_method("dop853").solve(scene, t, Settings(rtol=rtol, atol=atol, max_steps=10**9), None).state[:, :7].copy()

    if problem.reference == "none":
        return Reference(None, "none (invariant metric)")
    if problem.reference == "dop853":
        from rotlab.bench.peers import solve_scipy

        ref = dop853(1e-15, 1e-17)
        other = solve_scipy("DOP853", scene, t, 1e-13, 1e-15).state
        return Reference(ref, "rotlab dop853, rtol 1e-15, atol 1e-17", state_error(other, ref)[0], "scipy DOP853 rtol 1e-13")
    if problem.reference == "krogh":
        from scipy.special import ellipj

        exact = get_method("exact").solve(scene, t, Settings(), None).state[:, :7].copy()
        sn, cn, dn, _ = ellipj(t - t[0], KROGH_M)
        s = krogh_scales()
        ref = exact.copy()
        ref[:, 4:7] = np.column_stack([s[0] * sn, s[1] * cn, s[2] * dn])
        return Reference(ref, "ω: scipy.special.ellipj (sn, cn, dn)(t | 0.51); Λ: rotlab exact",
                         state_error(exact, ref)[0], "ω of rotlab exact vs ellipj", uses_exact=True)
    # exact, checked against dop853 at rtol 1e-14; falls back to that run if exact fails
    check = dop853()
    try:
        solution = get_method("exact").solve(scene, t, Settings(), None)
        if solution.failure:
            raise RuntimeError(solution.failure)
        ref = solution.state[:, :7].copy()
    except Exception as exc:  # noqa: BLE001 - any failure of the exact module: fall back, say so
        return Reference(check, f"rotlab dop853 rtol 1e-14 (exact failed: {type(exc).__name__}: {exc})")
    return Reference(ref, "rotlab exact", state_error(check, ref)[0], "rotlab dop853 rtol 1e-14", uses_exact=True)


def state_error(state: np.ndarray, ref: np.ndarray) -> tuple[float, float, float]:
    """(max error, ω error, attitude error) of ``state`` (N, ≥7) against ``ref`` (N, 7): see the
    module docstring.  Rows of ``state`` that are missing (NaN) make the error infinite."""
    n = ref.shape[0]
    s = state[:n, :7]
    if s.shape[0] < n or not np.all(np.isfinite(s)):
        return math.inf, math.inf, math.inf
    omega_scale = float(np.max(np.linalg.norm(ref[:, 4:7], axis=1))) or 1.0
    omega = float(np.max(np.linalg.norm(s[:, 4:7] - ref[:, 4:7], axis=1))) / omega_scale
    dq = np.minimum(np.linalg.norm(s[:, 0:4] - ref[:, 0:4], axis=1), np.linalg.norm(s[:, 0:4] + ref[:, 0:4], axis=1))
    attitude = float(np.max(dq))
    return max(omega, attitude), omega, attitude


def energy_error(scene: Scene, state: np.ndarray) -> float:
    """max |H − H₀| / max(|H₀|, T₀ + |V₀|), H = T + V (conservative scenes), principal frame."""
    if not np.all(np.isfinite(state[:, :7])):
        return math.inf
    q = state[:, 0:4] / np.linalg.norm(state[:, 0:4], axis=1, keepdims=True)
    w = state[:, 4:7]
    kinetic = 0.5 * np.sum(scene.moments * w * w, axis=1)
    v = potential(scene.loads, q)
    total = kinetic + v
    scale = max(abs(total[0]), kinetic[0] + abs(v[0])) or 1.0
    return float(np.max(np.abs(total - total[0]))) / scale


def kovalevskaya_integral(state: np.ndarray, nu: float, up: np.ndarray = np.array([0.0, 0.0, 1.0])) -> np.ndarray:
    """K = (p² − q² − ν γ₁)² + (2pq − ν γ₂)², γ = Rᵀ up (see the module docstring)."""
    q = state[:, 0:4] / np.linalg.norm(state[:, 0:4], axis=1, keepdims=True)
    gamma = quat.rotate_to_body_array(q, np.broadcast_to(up, (q.shape[0], 3)))
    p, r2 = state[:, 4], state[:, 5]
    return (p * p - r2 * r2 - nu * gamma[:, 0]) ** 2 + (2.0 * p * r2 - nu * gamma[:, 1]) ** 2


def kovalevskaya_error(state: np.ndarray, nu: float, up: np.ndarray) -> float:
    if not np.all(np.isfinite(state[:, :7])):
        return math.inf
    k = kovalevskaya_integral(state, nu, up)
    return float(np.max(np.abs(k - k[0]))) / abs(float(k[0]))


def norm_error(state: np.ndarray) -> float:
    """max ||Λ| − 1|."""
    if not np.all(np.isfinite(state[:, :4])):
        return math.inf
    return float(np.max(np.abs(np.linalg.norm(state[:, 0:4], axis=1) - 1.0)))
