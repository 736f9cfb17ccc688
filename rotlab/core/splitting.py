"""Symplectic splitting for conservative scenes: exact axis rotations and potential kicks,
composed to order 2, 4, 6 or 8.

Hamiltonian H = T1 + T2 + T3 + V,  T_i = (L_i − h_i)² / (2 I_i),  V(Λ) = −Σ F·(R p), with
L = I ω + h (body; h the momentum of a gyrostat's rotors, constant in the body, else 0).
Each part is integrated exactly:

* R_i(τ), the flow of T_i: the body turns about its axis e_i at the constant rate ω_i = (L_i − h_i) / I_i,
  so with α = τ ω_i
      Λ ← Λ ∘ (cos(α/2), sin(α/2) e_i),     L ← rotation of L by −α about e_i  (L_i unchanged).
  The space vector R L is unchanged; |Λ| changes only by rounding (product of unit quaternions),
  |L| likewise (for a gyrostat too: L, not I ω, is what turns).
* K(τ), the flow of V at fixed Λ (a kick):  L ← L + τ Σ p × (Rᵀ F)  (``conservative_torque``).

Base method (symmetric, 2nd order, symplectic, time-reversible), Strang splitting with the free
part split symmetrically 1-2-3-2-1:

    S(h) = K(h/2) ∘ R1(h/2) R2(h/2) R3(h) R2(h/2) R1(h/2) ∘ K(h/2).

Higher orders by symmetric composition  Ψ(h) = S(γ_1 h) ⋯ S(γ_s h),  γ_{s+1−k} = γ_k:

    order 4, s = 5:   Suzuki's fractal composition, γ1 = γ2 = γ4 = γ5 = 1/(4 − 4^{1/3}),
                      γ3 = 1 − 4 γ1 (M. Suzuki, Phys. Lett. A 146 (1990) 319–323)
    order 6, s = 9:   Kahan & Li's optimal coefficients
    order 8, s = 17:  Kahan & Li's optimal coefficients
                      (W. Kahan, R.-C. Li, Math. Comp. 66 (1997) 1089–1099, as printed in Hairer,
                      Lubich & Wanner, "Geometric Numerical Integration", 2nd ed., §V.3.2,
                      eqs. (3.12) and (3.14))

Adjacent flows of the same kind are merged (R1 then R1 when no force acts, K then K between
stages and steps), so a 2nd-order step of the free body costs four axis rotations, and one of a
body in a field five rotations and one force evaluation; an order-p step costs s times that.
Merging never crosses a sample: the state written at a sample is the state after whole steps.

Rounding.  Each rotation is formed from sin and cos of α/4 (Taylor polynomials below |α| ≤ 1,
libm above) as cos − 1 = −2 sin²(·) and sin, so that a small rotation keeps full relative
precision; L is updated as L + (increment), and the rotations of a step (between kicks) are
accumulated in a near-identity quaternion applied to Λ once: |Λ| − 1 and |L| then random-walk at
~1 ulp per step instead of per rotation.  The kernel allows fused multiply-add (fastmath
"contract" only: no reassociation).

The work W (y[7]) is untouched: a conservative scene does no work (it stays 0).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from rotlab.core.dynamics import store_row
from rotlab.core.kernel_status import OK, state_status
from rotlab.core.targets import overload
from rotlab.core.torques import conservative_torque, has_forces


ORDERS = (2, 4, 6, 8)

_SUZUKI = 1.0 / (4.0 - 4.0 ** (1.0 / 3.0))
_G2 = np.array([1.0])
_G4 = np.array([_SUZUKI, _SUZUKI, 1.0 - 4.0 * _SUZUKI, _SUZUKI, _SUZUKI])
_KL6 = [0.39216144400731413927925056, 0.33259913678935943859974864, -0.70624617255763935980996482, 0.08221359629355080023149045]
_G6 = np.array(_KL6 + [0.79854399093482996339895035] + _KL6[::-1])
_KL8 = [
    0.13020248308889008087881763,
    0.56116298177510838456196441,
    -0.38947496264484728640807860,
    0.15884190655515560089621075,
    -0.39590389413323757733623154,
    0.18453964097831570709183254,
    0.25837438768632204729397911,
    0.29501172360931029887096624,
]
_G8 = np.array(_KL8 + [-0.60550853383003451169892108] + _KL8[::-1])

COEFFICIENTS = {2: _G2, 4: _G4, 6: _G6, 8: _G8}


def stages(order: int) -> int:
    """Number of base steps S per step (= force evaluations per step, kicks merged)."""
    return COEFFICIENTS[order].shape[0]


@njit(cache=True)
def _coefficients(order):
    if order == 2:
        return _G2
    if order == 6:
        return _G6
    if order == 8:
        return _G8
    return _G4


SMALL_ANGLE = 0.25  # |α/4| below which sin and cos come from their Taylor polynomials
_S3, _S5, _S7, _S9, _S11, _S13 = (-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0, -1.0 / 39916800.0, 1.0 / 6227020800.0)
_C4, _C6, _C8, _C10, _C12, _C14 = (1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0, -1.0 / 3628800.0, 1.0 / 479001600.0, -1.0 / 87178291200.0)


@njit(cache=True, forceinline=True)
def _kick_torque(y, model):
    """``conservative_torque`` typed once, inlined by LLVM at both kicks (not by numba at each)."""
    return conservative_torque(y, model)


def _less_rotors(l, rotors, k):
    """l − h_k: the body's own part of L_k, for a gyrostat's rotors' h (l itself without rotors)."""
    raise NotImplementedError("compiled only")


def _plus_rotors(l, rotors, k):
    """l + h_k (l itself without rotors)."""
    raise NotImplementedError("compiled only")


@overload(_less_rotors, inline="always")
def _less_rotors_impl(l, rotors, k):
    if isinstance(rotors, types.NoneType):
        return lambda l, rotors, k: l
    return lambda l, rotors, k: l - rotors[k]


@overload(_plus_rotors, inline="always")
def _plus_rotors_impl(l, rotors, k):
    if isinstance(rotors, types.NoneType):
        return lambda l, rotors, k: l
    return lambda l, rotors, k: l + rotors[k]


@njit(cache=True, forceinline=True)
def sin_cos_small(x):
    """sin x, cos x for |x| ≤ 0.25 from their Taylor polynomials of degree 13 and 14 (truncation
    < 3e-21 relative), in Estrin form (short dependency chains): as accurate as libm (a few ulp)
    and, on the critical path of a step, faster."""
    z = x * x
    z2 = z * z
    z4 = z2 * z2
    s = x * ((1.0 + _S3 * z) + z2 * (_S5 + _S7 * z) + z4 * ((_S9 + _S11 * z) + _S13 * z2))
    c = (1.0 - 0.5 * z) + z2 * (_C4 + _C6 * z) + z4 * ((_C8 + _C10 * z) + z2 * (_C12 + _C14 * z))
    return s, c


@njit(cache=True, forceinline=True)
def _half_angle(tau, l, inv):
    """For α = τ l I_i⁻¹ (l = L_i − h_i): (d, s, e, σ) with (1 + d, s) = (cos(α/2), sin(α/2)) and
    (1 + e, σ) = (cos α, sin α); d = −2 sin²(α/4) and e = −2 sin²(α/2) are formed without
    cancellation, so that small rotations keep full relative precision."""
    quarter = 0.25 * tau * l * inv
    if abs(quarter) <= SMALL_ANGLE:
        s4, c4 = sin_cos_small(quarter)
    else:
        s4 = math.sin(quarter)
        c4 = math.cos(quarter)
    d = -2.0 * s4 * s4
    s = 2.0 * s4 * c4
    return d, s, -2.0 * s * s, 2.0 * (s + s * d)


# The rotations accumulate in P = (1 + a0, a1, a2, a3), stored as a0 = p0 − 1 so that a near-identity
# P keeps full relative precision; P ∘ (1 + d, s e_i) in that form (q0 = 1 + a0, c = 1 + d):
#   a0' = a0 + d + a0 d − a_i s,   a_i' = a_i + d a_i + s + a0 s,   a_j' = a_j + d a_j ± s a_k.
# Λ itself is touched once per flush (Λ ← Λ ∘ P): one rounding of Λ per step instead of one per
# rotation, which keeps the random walk of |Λ| − 1 at the level of the one-product-per-step methods.


@njit(cache=True, forceinline=True)
def _turn1(tau, a0, a1, a2, a3, l1, l2, l3, inv1, rotors):
    """R1(τ): P ∘ (cos(α/2), sin(α/2), 0, 0), (L2, L3) turned by −α."""
    d, s, e, sa = _half_angle(tau, _less_rotors(l1, rotors, 0), inv1)
    return (
        a0 + d + a0 * d - a1 * s,
        a1 + d * a1 + s + a0 * s,
        a2 + d * a2 + s * a3,
        a3 + d * a3 - s * a2,
        l1,
        l2 + (e * l2 + sa * l3),
        l3 + (e * l3 - sa * l2),
    )


@njit(cache=True, forceinline=True)
def _turn2(tau, a0, a1, a2, a3, l1, l2, l3, inv2, rotors):
    """R2(τ): P ∘ (cos(α/2), 0, sin(α/2), 0), (L3, L1) turned by −α."""
    d, s, e, sa = _half_angle(tau, _less_rotors(l2, rotors, 1), inv2)
    return (
        a0 + d + a0 * d - a2 * s,
        a1 + d * a1 - s * a3,
        a2 + d * a2 + s + a0 * s,
        a3 + d * a3 + s * a1,
        l1 + (e * l1 - sa * l3),
        l2,
        l3 + (e * l3 + sa * l1),
    )


@njit(cache=True, forceinline=True)
def _turn3(tau, a0, a1, a2, a3, l1, l2, l3, inv3, rotors):
    """R3(τ): P ∘ (cos(α/2), 0, 0, sin(α/2)), (L1, L2) turned by −α."""
    d, s, e, sa = _half_angle(tau, _less_rotors(l3, rotors, 2), inv3)
    return (
        a0 + d + a0 * d - a3 * s,
        a1 + d * a1 + s * a2,
        a2 + d * a2 - s * a1,
        a3 + d * a3 + s + a0 * s,
        l1 + (e * l1 + sa * l2),
        l2 + (e * l2 - sa * l1),
        l3,
    )


@njit(cache=True, forceinline=True)
def _apply(q0, q1, q2, q3, a0, a1, a2, a3):
    """Λ ∘ P for P = (1 + a0, a1, a2, a3):  Λ + Λ ∘ (a0, a)."""
    return (
        q0 + (q0 * a0 - q1 * a1 - q2 * a2 - q3 * a3),
        q1 + (q0 * a1 + q1 * a0 + q2 * a3 - q3 * a2),
        q2 + (q0 * a2 + q2 * a0 + q3 * a1 - q1 * a3),
        q3 + (q0 * a3 + q3 * a0 + q1 * a2 - q2 * a1),
    )


@njit(cache=True, fastmath={"contract"})
def splitting_advance(y, times, out, i_start, substeps, max_steps, model, order):
    """Advance ``y`` (the state at ``times[i_start − 1]``) sample by sample, ``substeps`` equal
    steps of the order-``order`` composition per sample interval (see ``rotlab.core.rk4`` for the
    contract).  Only the conservative forces of ``model`` act.  A negative step (decreasing
    ``times``) runs the method backwards: it is its own adjoint."""
    kicks = has_forces(model)
    euler = model.euler
    gam = _coefficients(order)
    ns = gam.shape[0]
    inv1, inv2, inv3 = euler[3], euler[4], euler[5]
    q0, q1, q2, q3 = y[0], y[1], y[2], y[3]
    rotors = model.rotors
    l1, l2, l3 = _plus_rotors(y[4] / inv1, rotors, 0), _plus_rotors(y[5] / inv2, rotors, 1), _plus_rotors(y[6] / inv3, rotors, 2)
    steps = 0
    i = i_start
    while i < times.shape[0] and steps + substeps <= max_steps:
        t0 = times[i - 1]
        h = (times[i] - t0) / substeps
        pk = 0.0  # pending K time: the closing half kick of a stage waits for the next opening one
        p1 = 0.0  # pending R1 time: without kicks, the closing R1 waits for the next opening one
        for j in range(substeps):
            a0 = a1 = a2 = a3 = 0.0  # P = identity
            for k in range(ns):
                g = gam[k] * h
                if kicks:  # K(pk + g/2): Λ ← Λ ∘ P first, the torque depends on it
                    q0, q1, q2, q3 = _apply(q0, q1, q2, q3, a0, a1, a2, a3)
                    a0 = a1 = a2 = a3 = 0.0
                    y[0], y[1], y[2], y[3] = q0, q1, q2, q3
                    cx, cy, cz = _kick_torque(y, model)
                    pk += 0.5 * g
                    l1 += pk * cx
                    l2 += pk * cy
                    l3 += pk * cz
                    pk = 0.0
                a0, a1, a2, a3, l1, l2, l3 = _turn1(p1 + 0.5 * g, a0, a1, a2, a3, l1, l2, l3, inv1, rotors)
                a0, a1, a2, a3, l1, l2, l3 = _turn2(0.5 * g, a0, a1, a2, a3, l1, l2, l3, inv2, rotors)
                a0, a1, a2, a3, l1, l2, l3 = _turn3(g, a0, a1, a2, a3, l1, l2, l3, inv3, rotors)
                a0, a1, a2, a3, l1, l2, l3 = _turn2(0.5 * g, a0, a1, a2, a3, l1, l2, l3, inv2, rotors)
                if kicks:
                    a0, a1, a2, a3, l1, l2, l3 = _turn1(0.5 * g, a0, a1, a2, a3, l1, l2, l3, inv1, rotors)
                    p1 = 0.0
                    pk = 0.5 * g
                else:
                    p1 = 0.5 * g
            if p1 != 0.0 and j == substeps - 1:  # close the sample interval: whole steps only
                a0, a1, a2, a3, l1, l2, l3 = _turn1(p1, a0, a1, a2, a3, l1, l2, l3, inv1, rotors)
            q0, q1, q2, q3 = _apply(q0, q1, q2, q3, a0, a1, a2, a3)
        if pk != 0.0:
            y[0], y[1], y[2], y[3] = q0, q1, q2, q3
            cx, cy, cz = _kick_torque(y, model)
            l1 += pk * cx
            l2 += pk * cy
            l3 += pk * cz
        steps += substeps
        y[0], y[1], y[2], y[3] = q0, q1, q2, q3
        y[4], y[5], y[6] = _less_rotors(l1, rotors, 0) * inv1, _less_rotors(l2, rotors, 1) * inv2, _less_rotors(l3, rotors, 2) * inv3
        status = state_status(y)  # (end_sample written out: a contracting kernel's FMAs depend on its code's shape)
        if status != OK:
            return status, i, steps
        store_row(out, i, y)
        i += 1
    return OK, i, steps
