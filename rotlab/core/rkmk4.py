"""Runge–Kutta–Munthe-Kaas of order 4 on SO(3) × R⁴ (Λ on the group; ω and W in a vector space),
for any scene: time-dependent and non-conservative loads included (the full ``rhs``).

Λ(t) = Λ₀ ∘ Exp(θ(t)), Exp(θ) = (cos(|θ|/2), sin(|θ|/2) θ/|θ|) the unit quaternion of the body
rotation vector θ; Λ̇ = ½ Λ ∘ (0, ω) becomes, in the Lie algebra so(3) ≅ (R³, ×),

    θ̇ = dexp⁻¹_{−θ}(ω) = ω + ½ θ × ω + (1/12) θ × (θ × ω) + O(|θ|³ |ω|)

(the series truncated after the terms that order 4 needs: Munthe-Kaas, BIT 39 (1999) 92–108;
Iserles, Munthe-Kaas, Nørsett & Zanna, Acta Numerica 9 (2000), §4).  Classical RK4 is applied
to (θ, ω, W) from θ = 0 with ω̇, Ẇ from ``rhs``:

    stage s (c = 0, ½, ½, 1; θ_s = 0, k₁/2, k₂/2, k₃):  Y_s = (Λ₀ ∘ Exp(θ_s), ω_s, W_s),
    k_s = h dexp⁻¹_{−θ_s}(ω_s),  (ω, W) stages as in classical RK4;
    Λ₁ = Λ₀ ∘ Exp((k₁ + 2k₂ + 2k₃ + k₄)/6).

Λ is only ever multiplied by unit quaternions: |Λ| = 1 up to rounding, with no renormalisation.
"""

from __future__ import annotations

import math

from numba import njit

from rotlab.core.dynamics import count_at_or_below, next_piece, rhs_llvm_inlined, state_size
from rotlab.core.kernel_status import OK, end_sample
from rotlab.core.splitting import SMALL_ANGLE, sin_cos_small
from rotlab.core.targets import work_vector



@njit(cache=True, forceinline=True)
def expmap(x, y, z):
    """Exp(θ) = (cos(|θ|/2), sin(|θ|/2) θ/|θ|) as (e0, e1, e2, e3) with e0 = cos(|θ|/2) − 1
    = −2 sin²(|θ|/4), free of cancellation for small |θ| (see ``_stage_orientation``)."""
    n2 = x * x + y * y + z * z
    n = math.sqrt(n2)
    if n <= 4.0 * SMALL_ANGLE:
        s4, c4 = sin_cos_small(0.25 * n)
    else:
        s4 = math.sin(0.25 * n)
        c4 = math.cos(0.25 * n)
    if n < 1e-4:
        f = 0.5 - n2 / 48.0 + n2 * n2 / 3840.0  # sin(n/2)/n, error < n⁶/10⁶
    else:
        f = 2.0 * s4 * c4 / n
    return -2.0 * s4 * s4, f * x, f * y, f * z


@njit(cache=True, forceinline=True)
def _dexpinv(ux, uy, uz, wx, wy, wz):
    """dexp⁻¹_{−u}(w) truncated: w + ½ u × w + (1/12) u × (u × w)."""
    cx = uy * wz - uz * wy
    cy = uz * wx - ux * wz
    cz = ux * wy - uy * wx
    dx = uy * cz - uz * cy
    dy = uz * cx - ux * cz
    dz = ux * cy - uy * cx
    return wx + 0.5 * cx + dx / 12.0, wy + 0.5 * cy + dy / 12.0, wz + 0.5 * cz + dz / 12.0


@njit(cache=True, forceinline=True)
def _stage_orientation(y, tmp, ux, uy, uz):
    """tmp[0:4] ← Λ₀ ∘ Exp(u) = Λ₀ + Λ₀ ∘ (e0, e): Λ₀ is rounded once."""
    e0, e1, e2, e3 = expmap(ux, uy, uz)
    q0, q1, q2, q3 = y[0], y[1], y[2], y[3]
    tmp[0] = q0 + (q0 * e0 - q1 * e1 - q2 * e2 - q3 * e3)
    tmp[1] = q1 + (q0 * e1 + q1 * e0 + q2 * e3 - q3 * e2)
    tmp[2] = q2 + (q0 * e2 + q2 * e0 + q3 * e1 - q1 * e3)
    tmp[3] = q3 + (q0 * e3 + q3 * e0 + q1 * e2 - q2 * e1)


@njit(cache=True)
def rkmk4_advance(y, times, out, i_start, substeps, max_steps, model):
    """Advance ``y`` (the state at ``times[i_start − 1]``) sample by sample, ``substeps`` RKMK4
    steps per sample interval (contract of ``rotlab.core.rk4``, steps split at the load
    breaks in the same way)."""
    n = state_size(model)  # (8; more with driven rotors)
    k1 = work_vector(n)
    k2 = work_vector(n)
    k3 = work_vector(n)
    k4 = work_vector(n)
    tmp = work_vector(n)
    steps = 0
    i = i_start
    breaks = model.breaks
    b = count_at_or_below(breaks, times[i_start - 1])  # next breakpoint
    while i < times.shape[0] and steps + substeps <= max_steps:
        t0 = times[i - 1]
        h_nominal = (times[i] - t0) / substeps
        for j in range(substeps):
            t = t0 + j * h_nominal
            t_end = times[i] if j == substeps - 1 else t0 + (j + 1) * h_nominal
            while t < t_end:  # one step, or its pieces between breakpoints (see rotlab.core.rk4)
                end, t_last, b = next_piece(t, t_end, breaks, b)
                h = end - t
                # stage 1: θ = 0, dexp⁻¹ = identity
                rhs_llvm_inlined(t, y, k1, model)
                a1x, a1y, a1z = h * y[4], h * y[5], h * y[6]
                # stage 2: θ = k1/2
                ux, uy, uz = 0.5 * a1x, 0.5 * a1y, 0.5 * a1z
                _stage_orientation(y, tmp, ux, uy, uz)
                for m in range(4, n):
                    tmp[m] = y[m] + 0.5 * h * k1[m]
                rhs_llvm_inlined(t + 0.5 * h, tmp, k2, model)
                a2x, a2y, a2z = _dexpinv(ux, uy, uz, h * tmp[4], h * tmp[5], h * tmp[6])
                # stage 3: θ = k2/2
                ux, uy, uz = 0.5 * a2x, 0.5 * a2y, 0.5 * a2z
                _stage_orientation(y, tmp, ux, uy, uz)
                for m in range(4, n):
                    tmp[m] = y[m] + 0.5 * h * k2[m]
                rhs_llvm_inlined(t + 0.5 * h, tmp, k3, model)
                a3x, a3y, a3z = _dexpinv(ux, uy, uz, h * tmp[4], h * tmp[5], h * tmp[6])
                # stage 4: θ = k3
                ux, uy, uz = a3x, a3y, a3z
                _stage_orientation(y, tmp, ux, uy, uz)
                for m in range(4, n):
                    tmp[m] = y[m] + h * k3[m]
                rhs_llvm_inlined(t_last, tmp, k4, model)
                a4x, a4y, a4z = _dexpinv(ux, uy, uz, h * tmp[4], h * tmp[5], h * tmp[6])
                # update
                _stage_orientation(
                    y,
                    tmp,
                    (a1x + 2.0 * (a2x + a3x) + a4x) / 6.0,
                    (a1y + 2.0 * (a2y + a3y) + a4y) / 6.0,
                    (a1z + 2.0 * (a2z + a3z) + a4z) / 6.0,
                )
                y[0], y[1], y[2], y[3] = tmp[0], tmp[1], tmp[2], tmp[3]
                for m in range(4, n):
                    y[m] += h / 6.0 * (k1[m] + 2.0 * (k2[m] + k3[m]) + k4[m])
                steps += 1
                t = end
        status = end_sample(y, out, i)
        if status != OK:
            return status, i, steps
        i += 1
    return OK, i, steps
