"""Discrete Moser–Veselov algorithm (DMV) for the free rigid body, with the modified moments of
inertia of Hairer & Vilmart for orders 2, 4, 6, 8, 10, 12.

Method: E. Hairer, G. Vilmart, "Preprocessed discrete Moser–Veselov algorithm for the full
dynamics of a rigid body", J. Phys. A: Math. Gen. 39 (2006) 13225–13235.  The coefficients of
the modified moments (``modified_coefficients``) were derived for this project by
tools/derive_dmv_moments.py (sympy; exact Taylor matching of one step against the exact flow,
which proves a local error O(h^{p+1}) for m and Λ); the tests measure order p for ω and Λ.

DMV step in quaternion form (m = I ω body angular momentum, h the step):  with the moments
Ĩ_k (below), a_k = h m_k / (2 Ĩ_k) and f_1 = (Ĩ_2 − Ĩ_3)/Ĩ_1 (cyclic), solve for c ∈ R³

    c_k = (1 + |c|²) a_k + f_k c_i c_j        ((k, i, j) cyclic)

by Newton's method from one Gauss–Seidel sweep c = a + f a a (a fixed-point sweep only contracts
by O(h|ω|): 15 sweeps at h|ω| = 0.45, against 3–4 Newton iterations at any step), stopped once
an update is ≤ 10⁻⁸ |c|: Newton's next update would be ≲ ½ ‖J⁻¹‖ ‖r''‖ (10⁻⁸ |c|)², r'' of size
2|a| + |f| and |c| ~ h|ω|/2, i.e. at rounding level (tests: within 2e-15 |c| of a 50-digit solution
for moments over two decades and h|ω| ≤ 1; measured 4.6e-16).  A step with no solution near the
identity makes the state non-finite, reported as such.  Then

    Λ ← Λ ∘ (1, c) / √(1 + |c|²),      m_k ← m_k + (4/h) (Ĩ_i − Ĩ_j) c_i c_j / (1 + |c|²).

The rotation Ω = R((1, c)/√(1 + |c|²))ᵀ is the Moser–Veselov solution of h m̂ = Ωᵀ D − D Ω,
m ← Ω m: with the exact c, a map that conserves |m| and ½ Σ m_k²/Ĩ_k, and L_space.  Λ is
multiplied by that unit quaternion (multiplying by (1, c) and projecting back to |Λ| = 1 would
be the same map in exact arithmetic, but hides drift); Λ is never renormalised: |Λ| − 1 stays at
rounding level.

Preprocessing (Hairer & Vilmart): plain DMV (Ĩ = I) is of order 2; by backward error analysis its
modified equation is again a rigid body, with moments given by series in h² whose coefficients
depend on the two invariants H = ½ Σ m_k²/I_k and N = ½ |m|².  Running DMV with moments chosen so
that this modified rigid body is the true one up to O(h^p),

    1/Ĩ_k = C_S / I_k + C_D,     C_S = 1 + Σ_{j≥1} s_j(h² N, h² H),  C_D = Σ_{j≥1} d_j(h² N, h² H)

(s_j, d_j homogeneous of degree j; j ≤ p/2 − 1), gives order p for both m and Λ.  The
coefficients are symmetric functions of the moments, written in e1 = I_1 + I_2 + I_3,
e2 = I_1 I_2 + I_2 I_3 + I_3 I_1, e3 = I_1 I_2 I_3; degree 1, for instance:
s_1 = (e1 h²N − 2 e2 h²H)/(6 e3), d_1 = (e1 h²H − 2 h²N)/(6 e3).  No other transformation of the
initial data is needed (the derivation matches the step itself, from the given m and Λ); the
tests measure order p for ω and Λ against a dop853 reference.  H and N are exact invariants of
the DMV map with fixed Ĩ (H because C_S ≠ 0), so the Ĩ are computed once per sample interval from
the current m: the same values up to rounding as from the initial m, and the kernel stays a
function of its state.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rotlab.core.kernel_status import OK, end_sample


ORDERS = (2, 4, 6, 8, 10, 12)
_MAX_ITERATIONS = 50  # Newton iterations (3–4 at h|ω| ≤ 0.5)
_QUADRATIC_STOP = 1e-8  # stop once an update is ≤ this × |c|: the next one would be ≲ 1e-16 |c|


def modified_coefficients(moments) -> np.ndarray:
    """(2, 6, 6) table: [0] the s-coefficients, [1] the d-coefficients; row j − 1 holds the
    coefficients of N^{j−l} H^l, l = 0..j, of degree j (orders up to 12).  Derived (exact
    rational functions, here in the elementary symmetric functions e1, e2, e3 of the moments) and
    printed by tools/derive_dmv_moments.py, which proves the local error O(h^{2j+3}) for m and Λ."""
    A, B, C = (float(x) for x in moments)
    e1 = A + B + C
    e2 = A * B + B * C + C * A
    e3 = A * B * C
    c = np.zeros((2, 6, 6))
    # degree 1 (order 4)
    c[0, 0, :2] = [
        (e1) / (6*e3),
        (-e2) / (3*e3),
    ]
    c[1, 0, :2] = [
        (-1) / (3*e3),
        (e1) / (6*e3),
    ]
    # degree 2 (order 6)
    c[0, 1, :3] = [
        (e1**2 - 3*e2) / (30*e3**2),
        (-e1*e2 + 4*e3) / (30*e3**2),
        (-e1*e3 + 2*e2**2) / (60*e3**2),
    ]
    c[1, 1, :3] = [
        (-e1) / (60*e3**2),
        (-e1**2 + 8*e2) / (60*e3**2),
        (-e1*e2 - 6*e3) / (60*e3**2),
    ]
    # degree 3 (order 8)
    c[0, 2, :4] = [
        (17*e1**3 - 66*e1*e2 + 100*e3) / (2520*e3**3),
        (-6*e1**2*e2 - 5*e1*e3 + 22*e2**2) / (420*e3**3),
        (41*e1**2*e3 + 6*e1*e2**2 - 212*e2*e3) / (2520*e3**3),
        (e1*e2*e3 - e2**3 + 18*e3**2) / (630*e3**3),
    ]
    c[1, 2, :4] = [
        (-19*e1**2 + 72*e2) / (2520*e3**3),
        (e1**3 - e1*e2 - 88*e3) / (1260*e3**3),
        (13*e1**2*e2 + 110*e1*e3 - 64*e2**2) / (2520*e3**3),
        (-13*e1**2*e3 + e1*e2**2 + 30*e2*e3) / (1260*e3**3),
    ]
    # degree 4 (order 10)
    c[0, 3, :5] = [
        (62*e1**4 - 342*e1**2*e2 + 291*e1*e3 + 378*e2**2) / (45360*e3**4),
        (-77*e1**3*e2 + 141*e1**2*e3 + 306*e1*e2**2 - 1128*e2*e3) / (22680*e3**4),
        (3*e1**3*e3 + 26*e1**2*e2**2 + 30*e1*e2*e3 - 102*e2**3 + 318*e3**2) / (7560*e3**4),
        (-66*e1**2*e2*e3 - e1*e2**3 - 207*e1*e3**2 + 276*e2**2*e3) / (11340*e3**4),
        (153*e1**2*e3**2 - 3*e1*e2**2*e3 + 2*e2**4 - 486*e2*e3**2) / (45360*e3**4),
    ]
    c[1, 3, :5] = [
        (-61*e1**3 + 243*e1*e2 - 610*e3) / (45360*e3**4),
        (-e1**4 + 222*e1**2*e2 + 684*e1*e3 - 864*e2**2) / (45360*e3**4),
        (-5*e1**3*e2 - 133*e1**2*e3 + 19*e1*e2**2 + 356*e2*e3) / (7560*e3**4),
        (97*e1**3*e3 - 15*e1**2*e2**2 - 276*e1*e2*e3 + 64*e2**3 - 648*e3**2) / (22680*e3**4),
        (-6*e1**2*e2*e3 - e1*e2**3 + 459*e1*e3**2 - 126*e2**2*e3) / (45360*e3**4),
    ]
    # degree 5 (order 12)
    c[0, 4, :6] = [
        (1382*e1**5 - 9672*e1**3*e2 + 11067*e1**2*e3 + 16578*e1*e2**2 - 33300*e2*e3) / (4989600*e3**5),
        (-2074*e1**4*e2 + 1747*e1**3*e3 + 12438*e1**2*e2**2 - 15186*e1*e2*e3 - 16578*e2**3 + 34000*e3**2) / (2494800*e3**5),
        (2759*e1**4*e3 + 4154*e1**3*e2**2 - 39228*e1**2*e2*e3 - 16596*e1*e2**3 - 45948*e1*e3**2 + 145320*e2**2*e3) / (4989600*e3**5),
        (-90*e1**3*e2*e3 - 694*e1**2*e2**3 + 11481*e1**2*e3**2 - 963*e1*e2**2*e3 + 2766*e2**4 - 41814*e2*e3**2) / (1247400*e3**5),
        (-7339*e1**3*e3**2 + 5241*e1**2*e2**2*e3 + 10*e1*e2**4 + 31338*e1*e2*e3**2 - 21124*e2**3*e3 + 59508*e3**3) / (4989600*e3**5),
        (-819*e1**2*e2*e3**2 + 4*e1*e2**3*e3 - 7641*e1*e3**3 - 2*e2**5 + 5022*e2**2*e3**2) / (2494800*e3**5),
    ]
    c[1, 4, :6] = [
        (-1384*e1**4 + 8559*e1**2*e2 - 3270*e1*e3 - 12096*e2**2) / (4989600*e3**5),
        (e1**5 + 1813*e1**3*e2 - 10365*e1**2*e3 - 7263*e1*e2**2 + 47298*e2*e3) / (2494800*e3**5),
        (251*e1**4*e2 + 12444*e1**3*e3 - 8790*e1**2*e2**2 - 45960*e1*e2*e3 + 31104*e2**3 - 110664*e3**2) / (4989600*e3**5),
        (-1095*e1**4*e3 + 219*e1**3*e2**2 + 7782*e1**2*e2*e3 - 871*e1*e2**3 + 26793*e1*e3**2 - 20496*e2**2*e3) / (1247400*e3**5),
        (-774*e1**3*e2*e3 + 251*e1**2*e2**3 - 48285*e1**2*e3**2 + 12198*e1*e2**2*e3 - 1024*e2**4 + 63288*e2*e3**2) / (4989600*e3**5),
        (2169*e1**3*e3**2 - 555*e1**2*e2**2*e3 + e1*e2**4 - 2133*e1*e2*e3**2 + 510*e2**3*e3 - 8424*e3**3) / (2494800*e3**5),
    ]
    return c


@njit(cache=True)
def modified_inverse_moments(m1, m2, m3, h, inv1, inv2, inv3, coefficients, order):
    """1/Ĩ_k for the order-``order`` DMV (``order`` 2: the true 1/I_k)."""
    nn = 0.5 * h * h * (m1 * m1 + m2 * m2 + m3 * m3)
    hh = 0.5 * h * h * (m1 * m1 * inv1 + m2 * m2 * inv2 + m3 * m3 * inv3)
    if nn == 0.0:  # at rest: every term of degree ≥ 1 vanishes
        return inv1, inv2, inv3
    ratio = hh / nn  # Σ_l s_{j,l} N^{j−l} H^l = N^j Σ_l s_{j,l} ρ^l, ρ = H/N (Horner in ρ; no pow calls)
    css = 1.0
    cdd = 0.0
    n_pow = 1.0
    for j in range(order // 2 - 1):  # degree j + 1
        deg = j + 1
        n_pow *= nn
        ps = coefficients[0, j, deg]
        pd = coefficients[1, j, deg]
        for l in range(deg - 1, -1, -1):
            ps = ps * ratio + coefficients[0, j, l]
            pd = pd * ratio + coefficients[1, j, l]
        css += n_pow * ps
        cdd += n_pow * pd
    return css * inv1 + cdd, css * inv2 + cdd, css * inv3 + cdd


@njit(cache=True, inline="always")
def dmv_rotation(h, m1, m2, m3, j1, j2, j3, f1, f2, f3):
    """c of the DMV step (see module docstring); j_k = 1/Ĩ_k, f_k = (Ĩ_i − Ĩ_j)/Ĩ_k.
    Returns (c1, c2, c3, 1 + |c|²)."""
    a1 = 0.5 * h * m1 * j1
    a2 = 0.5 * h * m2 * j2
    a3 = 0.5 * h * m3 * j3
    c1 = a1 + f1 * a2 * a3
    c2 = a2 + f2 * c1 * a3
    c3 = a3 + f3 * c1 * c2
    for _ in range(_MAX_ITERATIONS):
        alpha = 1.0 + (c1 * c1 + c2 * c2 + c3 * c3)
        r1 = c1 - alpha * a1 - f1 * c2 * c3
        r2 = c2 - alpha * a2 - f2 * c3 * c1
        r3 = c3 - alpha * a3 - f3 * c1 * c2
        # Jacobian of the residual: I − 2 a cᵀ − F,  F = [[0, f1 c3, f1 c2], [f2 c3, 0, f2 c1], [f3 c2, f3 c1, 0]]
        j11 = 1.0 - 2.0 * a1 * c1
        j12 = -2.0 * a1 * c2 - f1 * c3
        j13 = -2.0 * a1 * c3 - f1 * c2
        j21 = -2.0 * a2 * c1 - f2 * c3
        j22 = 1.0 - 2.0 * a2 * c2
        j23 = -2.0 * a2 * c3 - f2 * c1
        j31 = -2.0 * a3 * c1 - f3 * c2
        j32 = -2.0 * a3 * c2 - f3 * c1
        j33 = 1.0 - 2.0 * a3 * c3
        k11 = j22 * j33 - j23 * j32
        k12 = j13 * j32 - j12 * j33
        k13 = j12 * j23 - j13 * j22
        inverse_det = 1.0 / (j11 * k11 + j21 * k12 + j31 * k13)
        d1 = (k11 * r1 + k12 * r2 + k13 * r3) * inverse_det
        d2 = ((j23 * j31 - j21 * j33) * r1 + (j11 * j33 - j13 * j31) * r2 + (j13 * j21 - j11 * j23) * r3) * inverse_det
        d3 = ((j21 * j32 - j22 * j31) * r1 + (j12 * j31 - j11 * j32) * r2 + (j11 * j22 - j12 * j21) * r3) * inverse_det
        c1 -= d1
        c2 -= d2
        c3 -= d3
        if abs(d1) + abs(d2) + abs(d3) <= _QUADRATIC_STOP * (abs(c1) + abs(c2) + abs(c3)):
            return c1, c2, c3, 1.0 + (c1 * c1 + c2 * c2 + c3 * c3)  # the next update is at rounding level
    return np.nan, np.nan, np.nan, np.nan  # no solution found: reported as a non-finite state


@njit(cache=True)
def dmv_advance(y, times, out, i_start, substeps, max_steps, model, order, coefficients):
    """Advance ``y`` (the state at ``times[i_start − 1]``) sample by sample, ``substeps`` DMV
    steps of order ``order`` per sample interval (contract of ``rotlab.core.rk4``).  Free body
    only: only ``model.euler`` is read.  ``coefficients`` from ``modified_coefficients(moments)``."""
    inv1, inv2, inv3 = model.euler[3], model.euler[4], model.euler[5]
    q0, q1, q2, q3 = y[0], y[1], y[2], y[3]
    steps = 0
    i = i_start
    while i < times.shape[0] and steps + substeps <= max_steps:
        # m = I ω from the stored ω at every sample, not carried over: each sample interval starts
        # afresh, so the samples do not depend on how a run is cut into calls (windows, ensembles)
        m1, m2, m3 = y[4] / inv1, y[5] / inv2, y[6] / inv3
        t0 = times[i - 1]
        h = (times[i] - t0) / substeps
        j1, j2, j3 = modified_inverse_moments(m1, m2, m3, h, inv1, inv2, inv3, coefficients, order)
        product = 1.0 / (j1 * j2 * j3)  # Ĩ_k = j_i j_j / (j1 j2 j3): one division, not three
        big1, big2, big3 = j2 * j3 * product, j3 * j1 * product, j1 * j2 * product
        d1 = big2 - big3
        d2 = big3 - big1
        d3 = big1 - big2
        f1, f2, f3 = d1 * j1, d2 * j2, d3 * j3
        kick = 4.0 / h
        for _ in range(substeps):
            c1, c2, c3, alpha = dmv_rotation(h, m1, m2, m3, j1, j2, j3, f1, f2, f3)
            # Λ ← Λ ∘ (1 + e0, e), the unit quaternion (1, c)/√α with e0 = 1/√α − 1 formed without
            # cancellation; Λ + Λ ∘ (e0, e) rounds Λ once per step
            root = math.sqrt(alpha)
            scale = 1.0 / root
            e0 = -(alpha - 1.0) * scale / (1.0 + root)
            e1, e2, e3 = c1 * scale, c2 * scale, c3 * scale
            q0, q1, q2, q3 = (
                q0 + (q0 * e0 - q1 * e1 - q2 * e2 - q3 * e3),
                q1 + (q1 * e0 + q0 * e1 + q2 * e3 - q3 * e2),
                q2 + (q2 * e0 + q0 * e2 + q3 * e1 - q1 * e3),
                q3 + (q3 * e0 + q0 * e3 + q1 * e2 - q2 * e1),
            )
            w = kick / alpha
            m1, m2, m3 = m1 + d1 * c2 * c3 * w, m2 + d2 * c3 * c1 * w, m3 + d3 * c1 * c2 * w
        steps += substeps
        y[0], y[1], y[2], y[3] = q0, q1, q2, q3
        y[4], y[5], y[6] = m1 * inv1, m2 * inv2, m3 * inv3
        status = end_sample(y, out, i)
        if status != OK:
            return status, i, steps
        i += 1
    return OK, i, steps
