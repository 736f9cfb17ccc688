"""The phase portraits of the integrable scenes, from their integrals (principal body frame).

Torque-free body (moments I₁ < I₂ < I₃ after sorting): L (body frame) moves on the sphere
|L| = L₀ along its intersection with the energy ellipsoid L₁²/I₁ + L₂²/I₂ + L₃²/I₃ = 2T — a
polhode.  With h = 2T/L₀² in [1/I₃, 1/I₁], the polhodes of h > 1/I₂ circle the axis of I₁, those
of h < 1/I₂ the axis of I₃; h = 1/I₂ are the separatrices, two great-circle-like curves through
the unstable equilibria ±L₀ e₂.  Around the axis a (the other two b, c), in polar coordinates
(ρ, φ) of the (b, c) components:

    ρ² = (h − 1/I_a) / (cos²φ (1/I_b − 1/I_a) + sin²φ (1/I_c − 1/I_a)),   L_a = ±√(1 − ρ²)   (L₀ = 1).

Lagrange top (symmetry axis e, A across it, C along it, k = −c·e = m g l): with u = cos θ the
conserved p_ψ = L·γ and ω₃ = ω·e reduce the motion to A θ̇²/2 + U(θ) = E', where

    U(θ) = (p_ψ − C ω₃ cos θ)² / (2 A sin²θ) + k cos θ,      E' = ½ A |ω − ω₃ e|² + k e·γ,

and A² u̇² = f(u) = 2Ak u³ − (2AE' + C²ω₃²) u² + 2(p_ψ C ω₃ − Ak) u + 2AE' − p_ψ², a cubic with roots
u₁ ≤ u₂ in [−1, 1] (the turning points, θ₁ ≥ θ₂) and u₃ ≥ 1.  θ nutates between them with period
T = 4 A K(m) / √(2Ak (u₃ − u₁)),  m = (u₂ − u₁)/(u₃ − u₁) (f = 2Ak (u − u₁)(u − u₂)(u − u₃)).
A fast top (C²ω₃² ≫ A k) nutates at ≈ C ω₃ / A and precesses on average at ≈ k / (C ω₃).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rotlab.core import quaternion as quat
from rotlab.core.torques import F_FORCE, F_POINT
from rotlab.scene.scene import LAGRANGE, Scene

POLHODE_LEVELS = 4  # polhodes drawn on each side of the separatrix
POLHODE_POINTS = 181  # points on each curve
VERTICAL = 1e-9  # |cos θ| within this of 1: the axis is vertical (ψ undefined)
DOUBLE_ROOT = 1e-7  # roots of the cubic closer than this are one double root (~√ε of rounding splits it)


def polhodes(moments: np.ndarray, L0: float, levels: int = POLHODE_LEVELS) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """(polhodes, separatrices) on the sphere |L| = L0 (principal body frame): closed curves
    (n, 3), ``levels`` energy levels around each of the stable axes, and the separatrices (module
    docstring).  Moments in the scene's principal order (any order of sizes; equal ones give none)."""
    order = np.argsort(moments)
    inv = 1.0 / np.asarray(moments, dtype=float)[order]  # 1/I₁ > 1/I₂ > 1/I₃
    if not (inv[0] > inv[1] > inv[2]):
        return [], []
    curves, separatrices = [], []
    for a, b, c, between in ((0, 1, 2, np.linspace(inv[1], inv[0], levels + 2)[1:-1]),
                             (2, 1, 0, np.linspace(inv[2], inv[1], levels + 2)[1:-1])):
        for h in between:
            curves += _around(inv, a, b, c, float(h), order, L0)
    for curve in _around(inv, 0, 1, 2, float(inv[1]), order, L0):
        separatrices.append(curve)
    return curves, separatrices


def _around(inv: np.ndarray, a: int, b: int, c: int, h: float, order: np.ndarray, L0: float) -> list[np.ndarray]:
    """The two polhodes of level h circling sorted axis a (L_a > 0 and < 0), in the scene's axes."""
    phi = np.linspace(0.0, 2.0 * np.pi, POLHODE_POINTS)
    rho2 = (h - inv[a]) / (np.cos(phi) ** 2 * (inv[b] - inv[a]) + np.sin(phi) ** 2 * (inv[c] - inv[a]))
    rho = np.sqrt(np.clip(rho2, 0.0, 1.0))
    out = []
    for sign in (1.0, -1.0):
        sorted_L = np.zeros((phi.size, 3))
        sorted_L[:, a] = sign * np.sqrt(np.clip(1.0 - rho**2, 0.0, 1.0))
        sorted_L[:, b], sorted_L[:, c] = rho * np.cos(phi), rho * np.sin(phi)
        L = np.empty_like(sorted_L)
        L[:, order] = sorted_L
        out.append(L0 * L)
    return out



def complete_elliptic_k(m: float) -> float:
    """K(m) = ∫₀^{π/2} dφ / √(1 − m sin²φ) = π / (2 M(1, √(1 − m))), 0 ≤ m < 1, M the
    arithmetic–geometric mean (Abramowitz & Stegun 17.6): it converges quadratically, a few rounds
    to rounding (NumPy alone: no SciPy in a recording)."""
    a, b = 1.0, math.sqrt(1.0 - m)
    for _ in range(60):  # (≤ 6 rounds for m ≤ 1 − 1e-15)
        if a - b <= 4e-16 * a:
            break
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    return math.pi / (a + b)


def periodic_mean(f, rtol: float = 1e-14, most: int = 1 << 16) -> float:
    """(1/π) ∫₀^π f(s) ds of a smooth π-periodic ``f`` (vectorised) by the trapezoidal rule on 16, 32, …
    points until two agree to ``rtol`` (for an analytic periodic f the error falls exponentially
    with the points); at most ``most`` points."""
    n = 16
    mean = float(np.mean(f(np.arange(n) * (math.pi / n))))
    while n < most:
        n *= 2
        finer = 0.5 * (mean + float(np.mean(f((np.arange(n // 2) * 2 + 1) * (math.pi / n)))))  # the new midpoints only
        if abs(finer - mean) <= rtol * abs(finer):
            return finer
        mean = finer
    return mean

@dataclass(frozen=True)
class TopReduction:
    """A Lagrange top's motion in θ (module docstring): SI units, angles in radians."""

    a_moment: float  # A, kg·m²
    c_moment: float  # C, kg·m²
    spin: float  # ω₃, rad/s
    p_psi: float  # L·γ, kg·m²/s
    k: float  # m g l, J
    energy: float  # E', J

    def potential(self, theta):
        """U(θ) (J)."""
        return (self.p_psi - self.c_moment * self.spin * np.cos(theta)) ** 2 / (2.0 * self.a_moment * np.sin(theta) ** 2) + self.k * np.cos(theta)

    def cubic_roots(self) -> np.ndarray:
        """The three roots of f(u), ascending (real parts); a double root (a steady precession, a
        sleeping top), which rounding splits into two √ε apart, is returned twice."""
        A, b = self.a_moment, self.c_moment * self.spin
        coefficients = [2.0 * A * self.k, -(2.0 * A * self.energy + b * b), 2.0 * (self.p_psi * b - A * self.k), 2.0 * A * self.energy - self.p_psi**2]
        roots = np.sort(np.real(np.roots(coefficients)))
        if roots[1] - roots[0] < DOUBLE_ROOT:
            roots[0] = roots[1] = 0.5 * (roots[0] + roots[1])
        return roots

    def turning_points(self) -> tuple[float, float]:
        """(θ₁, θ₂) radians, θ₁ ≥ θ₂: where θ̇ = 0."""
        u1, u2, _ = self.cubic_roots()
        return math.acos(min(1.0, max(-1.0, u1))), math.acos(min(1.0, max(-1.0, u2)))

    def nutation_period(self) -> float:
        """T (s) of θ's oscillation between the turning points: 4 A K(m) / √(2Ak (u₃ − u₁))."""
        u1, u2, u3 = self.cubic_roots()
        return 4.0 * self.a_moment * complete_elliptic_k((u2 - u1) / (u3 - u1)) / math.sqrt(2.0 * self.a_moment * self.k * (u3 - u1))

    def mean_precession_rate(self) -> float:
        """ψ̇ averaged over a nutation period (rad/s): (2/T) ∫ (p_ψ − Cω₃u)/(1 − u²) du/√f(u) over
        [u₁, u₂] (ψ̇ = (p_ψ − Cω₃ u)/(A(1 − u²)), dt = A du/√f), with u = u₁ + (u₂ − u₁) sin²s removing
        the endpoints' square-root singularities: du/√f = 2 ds / √(2Ak (u₃ − u)).  NaN when the axis
        reaches the vertical (|u| = 1: ψ is not defined there, a sleeping top).  The integrand in s is
        analytic and π-periodic, even about 0 and π/2, so the integral over [0, π/2] is half its
        period's, which the trapezoidal rule gives to rounding (``periodic_mean``)."""
        u1, u2, u3 = self.cubic_roots()
        if max(abs(u1), abs(u2)) > 1.0 - VERTICAL:
            return math.nan
        b, A = self.c_moment * self.spin, self.a_moment

        def integrand(s: np.ndarray) -> np.ndarray:
            u = u1 + (u2 - u1) * np.sin(s) ** 2
            return (self.p_psi - b * u) / (1.0 - u * u) * 2.0 / np.sqrt(2.0 * A * self.k * (u3 - u))

        integral = 0.5 * math.pi * periodic_mean(integrand)
        return 2.0 * integral / self.nutation_period()

    @property
    def fast_nutation_frequency(self) -> float:
        """C ω₃ / A (rad/s): the nutation of a fast top."""
        return self.c_moment * self.spin / self.a_moment

    @property
    def fast_precession_rate(self) -> float:
        """k / (C ω₃) (rad/s): the mean precession of a fast top."""
        return self.k / (self.c_moment * self.spin)


def field_arm(scene: Scene) -> np.ndarray:
    """c = Σ (F_i·up) p_i (principal frame) of parallel constant forces F_i at points p_i: their
    torque is c × γ, γ the field's up (``scene.field_direction``) in body axes."""
    up = np.asarray(scene.field_direction, dtype=float)
    forces = scene.loads.forces
    return np.sum((forces[:, F_FORCE:F_FORCE + 3] @ up)[:, None] * forces[:, F_POINT:F_POINT + 3], axis=0)


def lagrange_top(scene: Scene) -> TopReduction | None:
    """The ``TopReduction`` of a Lagrange scene in its initial state (None for another scene)."""
    if scene.kind != LAGRANGE or scene.symmetry_axis is None or scene.field_direction is None:
        return None
    q = scene.state0[0:4] / np.linalg.norm(scene.state0[0:4])
    gamma = quat.rotate_to_body_array(q, np.asarray(scene.field_direction, dtype=float))
    return top_reduction(np.asarray(scene.moments, dtype=float), np.asarray(scene.symmetry_axis, dtype=float), scene.omega0, gamma,
                         field_arm(scene))


def top_reduction(moments: np.ndarray, axis: np.ndarray, omega: np.ndarray, gamma: np.ndarray, c: np.ndarray) -> TopReduction:
    """The ``TopReduction`` of a Lagrange top (principal frame: ``axis`` e its symmetry axis, a
    principal axis; ``gamma`` the field's up in body axes; ``c`` = Σ s_i p_i, the forces' moment
    arm, so that M = c × γ) in the state (ω, γ)."""
    a_moment, c_moment = float(np.max(moments * (1.0 - np.abs(axis)))), float(moments @ np.abs(axis))
    spin, p_psi, k = float(omega @ axis), float((moments * omega) @ gamma), float(-(c @ axis))
    across = omega - spin * axis
    energy = 0.5 * a_moment * float(across @ across) + k * float(axis @ gamma)
    return TopReduction(a_moment, c_moment, spin, p_psi, k, energy)
