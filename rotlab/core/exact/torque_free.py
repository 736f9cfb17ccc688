"""Exact torque-free motion of a rigid body (Euler–Poinsot), evaluated directly at sample times.

Conventions (fixed for the package): Λ = (q0, q1, q2, q3), scalar first, maps body to space;
ω = (p, q, r) in body principal components; Λ̇ = ½ Λ ∘ (0, ω) and

    A ṗ = (B − C) q r,    B q̇ = (C − A) r p,    C ṙ = (A − B) p q.

Invariants 2T = Σ I_i ω_i², L² = Σ I_i² ω_i², L_space = R(Λ) (I ω).  τ = t − t0.

Fixed axis and axisymmetric body (symmetry axis k, transverse moment A, axial moment C):

    ω(t) = R_k(Ω τ) ω0,   Ω = (C − A) ω0_k / A,
    Λ(t) = Λ_n(|L| τ / A) ∘ Λ0 ∘ Λ_k(−Ω τ),   n = L_space / |L|.

A spherical body, ω0 = 0 and permanent rotation about any principal axis use A = C (Ω = 0).

Asymmetric body: a proper signed permutation P of the body axes gives the right-handed frame G with
axes (1, 2, 3) = (middle, "dn" axis, "cn" axis), moments J1 (middle), J2, J3 (the extremes), chosen
so that L² − 2T J1 has the sign of J2 − J1 (J2 largest if L² > 2T I_mid, else smallest) and
ω2(t0) > 0, ω3(t0) ≥ 0.  With  E1 = L² − 2T J1,  E2 = 2T J2 − L²,  E3 = L² − 2T J3  (each evaluated as
Σ_i J_i (J_i − J_k) ω_i², exactly, from the initial state):

    ω_G = (β sn u, γ dn u, α cn u),   u = λ τ + u0,   parameter m, m1 = 1 − m,
    α² = E2 / (J3 (J2 − J3)),   β² = E2 / (J1 (J2 − J1)),   γ² = E3 / (J2 (J2 − J3)),
    λ  = sgn(J2 − J1) √((J2 − J1) E3 / (J1 J2 J3)),   m1 = (J2 − J3) E1 / ((J2 − J1) E3),
    u0 = F(am u0 | m) = sn0 R_F(cn0², dn0², 1)   (|u0| ≤ K since cn0 ≥ 0).

On the separatrix (E1 = 0 exactly): sn = tanh, cn = dn = sech.  Attitude

    Λ(t) = Λ_S ∘ Λ_z(ψ) ∘ Λ_Q(t) ∘ Λ_P,   Λ_Q = Λ_x(θ) ∘ Λ_z(φ),

where Λ_Q (built pointwise from ℓ = L_G/|L| = (sin θ sin φ, sin θ cos φ, cos θ)) takes ℓ to e_z and Λ_S
is constant.  The polar axis is the cn axis, so sin θ ≥ J2 γ / |L| > 0 and cos φ ∝ dn > 0.  Then

    ψ̇ = |L| (J1 ω1² + J2 ω2²) / (J1² ω1² + J2² ω2²) = |L|/J3 − c λ / (1 − n sn² u),
    c = |L| (J2 − J3) / (J2 J3 λ),   n = −ν = −J3 E2 / (J2 E3) ≤ 0,

    ψ = ψ̄ τ + p(u) − p(u0),   ψ̄ = (|L|/J3) (1 − (J2 − J3) Π(n|m) / (J2 K)),
    p(r) = (c Π(n|m)/K) r − c Π(n; am r|m),  Π(n; am r|m) = r + (n/3) sn³ R_J(cn², dn², 1, 1 − n sn²)

(Carlson's form with F(am r|m) = r), where u = 2K j + r, |r| ≤ K, and Π(n; φ + jπ|m) = Π(n; φ|m) + 2jΠ(n|m)
moves the secular part into ψ̄ τ (p is odd, 2K-periodic, p(±K) = 0).  On the separatrix ψ̄ = |L|/J1 and
p(u) = −c √ν atan(√ν tanh u) / (1 + ν).

Precision: the invariants are exact rationals (fractions.Fraction); λ, K, Π(n|m), ψ̄, |L| come from
60-digit decimal arithmetic (Bulirsch's cel), u0, used as a float only, from Carlson's duplication
at 34 digits.  The secular phases λ τ and ψ̄ τ
are formed in double-double and reduced modulo 2K and 4π, so that the error does not grow with τ
beyond a few ulp of the reduced phase.  sn, cn, dn come from scipy.special.ellipj for m1 ≥ 0.5 and
otherwise from the sech/tanh lattice sums (nome q1 = e^(−πK/K')), which keep full relative accuracy
of cn and dn near u = ±K for m arbitrarily close to 1.  Nearly equal moments need no special form:
every difference of moments is exact.  For extreme 0 < m1 the O(K) terms of p(r) cost some digits
(measured: |ΔΛ| 4e-12 at m1 = 2e-200 over 1000 periods; ≤ 1e-13 for m1 ≥ 1e-16).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from decimal import Decimal, getcontext, localcontext
from fractions import Fraction

import numpy as np
from scipy import special

from rotlab.core.quaternion import conjugate_array, from_matrix, multiply_array, rotate_to_space_array
from rotlab.core.exact.doubledouble import from_decimal, two_prod, two_sum

__all__ = ["torque_free_evaluator", "torque_free_solution"]

_DIGITS = 60
_U0_DIGITS = 34  # u0 = F(am u0 | m) is a float: 34 digits round it correctly (``_u0_integral``)
_PI = Decimal("3.141592653589793238462643383279502884197169399375105820974944592307816")
_SERIES_BELOW_M1 = 0.5  # sn, cn, dn from the hyperbolic lattice sums when m1 < this (else ellipj)

_CHUNK = 1 << 15  # samples per vectorised block

DD = tuple[float, float]  # double-double number hi + lo (floats or arrays)
Evaluator = Callable[[DD], tuple[np.ndarray, np.ndarray]]  # τ = t − t0 ↦ (q (n, 4), ω (n, 3))


# ---------------------------------------------------------------- double-double arithmetic








def _decimal_context():
    """60-digit context for the scalar per-call constants; _cel and _rf assume it is active."""
    return localcontext(prec=_DIGITS)


with _decimal_context():
    _FOUR_PI = from_decimal(4 * _PI)


def _reduce(rate: DD, tau: DD, offset: float, period: DD | None):
    """x = rate · τ + offset in double-double, split as x = j · period + r with |r| ≤ period/2.

    Returns (j, r) as float arrays; r is accurate to a few ulp of |r| + ε²|x|."""
    hi, lo = two_prod(rate[0], tau[0])
    lo = lo + (rate[0] * tau[1] + rate[1] * tau[0])
    hi, e = two_sum(hi, offset)
    lo = lo + e
    if period is None:
        return np.zeros_like(hi), hi + lo
    j = np.rint((hi + lo) / period[0])
    q, f = two_prod(j, period[0])  # hi − q is exact (Sterbenz)
    return j, (hi - q) + (lo - f - j * period[1])


# ---------------------------------------------------------------- 60-digit scalar special functions (decimal)
def _dec(x: Fraction) -> Decimal:
    return Decimal(x.numerator) / Decimal(x.denominator)


def _cel(kc: Decimal, p: Decimal) -> Decimal:
    """Bulirsch's complete integral ∫_0^{π/2} dθ / ((cos²θ + p sin²θ) √(cos²θ + kc² sin²θ)), p > 0.

    K(m) = cel(√m1, 1),  Π(n|m) = cel(√m1, 1 − n)."""
    tol = Decimal(10) ** (-_DIGITS // 2)
    a, e, em = Decimal(1), kc, Decimal(1)
    p = p.sqrt()
    b = 1 / p
    while True:
        f = a
        a += b / p
        g = e / p
        b = 2 * (b + f * g)
        p += g
        g = em
        em += kc
        if abs(g - kc) <= g * tol:
            return _PI / 2 * (b + a * em) / (em * (em + p))
        kc = 2 * e.sqrt()
        e = kc * em


def _rf(x: Decimal, y: Decimal, z: Decimal) -> Decimal:
    """Carlson's R_F by duplication (x, y, z ≥ 0, at most one zero) to the active context's
    precision p: stop when the deviations are below 10^(−p/6 − 1), where the fifth-order series
    leaves ~10^(−p)."""
    tol = Decimal(10) ** (-getcontext().prec // 6 - 1)
    while True:
        mu = (x + y + z) / 3
        dx, dy = 1 - x / mu, 1 - y / mu
        dz = -dx - dy
        if max(abs(dx), abs(dy), abs(dz)) < tol:
            e2, e3 = dx * dy - dz * dz, dx * dy * dz
            return (1 - e2 / 10 + e3 / 14 + e2 * e2 / 24 - 3 * e2 * e3 / 44) / mu.sqrt()
        sx, sy, sz = x.sqrt(), y.sqrt(), z.sqrt()
        lam = sx * (sy + sz) + sy * sz
        x, y, z = (x + lam) / 4, (y + lam) / 4, (z + lam) / 4


def _u0_integral(cn0_sq: Decimal, dn0_sq: Decimal) -> Decimal:
    """R_F(cn0², dn0², 1) for u0, which is used as a float only: to ``_U0_DIGITS`` digits, ~10⁻³³
    relative after the duplication's roundings, so float(u0) is the correctly rounded value
    except within ~10⁻³³ of a rounding boundary (60 digits would need more duplications, each
    dearer, for the same float)."""
    with localcontext(prec=_U0_DIGITS):
        return _rf(+cn0_sq, +dn0_sq, Decimal(1))


# ---------------------------------------------------------------- quaternion pieces
def _axis_quaternion(axis: int, angle: np.ndarray) -> np.ndarray:
    """Λ_k(angle) = (cos(angle/2), sin(angle/2) e_k), shape (N, 4)."""
    q = np.zeros(angle.shape + (4,))
    q[:, 0] = np.cos(0.5 * angle)
    q[:, 1 + axis] = np.sin(0.5 * angle)
    return q


def _lframe_quaternion(ang_mom: np.ndarray) -> np.ndarray:
    """Λ_Q = Λ_x(θ) ∘ Λ_z(φ) taking ℓ = L/|L| = (sin θ sin φ, sin θ cos φ, cos θ) to e_z.

    Requires L_2 > 0 or L_1 ≠ 0 (sin θ > 0); uses cos φ ≥ 0, i.e. φ ∈ [−π/2, π/2]."""
    l1, l2, l3 = ang_mom.T
    rho = np.hypot(l1, l2)  # |L| sin θ
    norm = np.hypot(rho, l3)
    big = np.sqrt((norm + np.abs(l3)) / (2.0 * norm))  # larger of cos(θ/2), sin(θ/2)
    small = rho / (2.0 * norm * big)
    upper = l3 >= 0.0
    ct, st = np.where(upper, big, small), np.where(upper, small, big)
    cp = np.sqrt((rho + l2) / (2.0 * rho))
    sp = l1 / (2.0 * rho * cp)
    return np.stack([ct * cp, st * cp, -st * sp, ct * sp], axis=-1)


def _spin_about_z(psi: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Λ_z(ψ) ∘ q."""
    c, s = np.cos(0.5 * psi), np.sin(0.5 * psi)
    q0, q1, q2, q3 = q.T
    return np.stack([c * q0 - s * q3, c * q1 - s * q2, c * q2 + s * q1, c * q3 + s * q0], axis=-1)


def _sandwich_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """4×4 M with q @ M = a ∘ q ∘ b for constant a, b (row i = a ∘ e_i ∘ b)."""
    return multiply_array(multiply_array(a, np.eye(4)), b)


# ---------------------------------------------------------------- fixed axis / axisymmetric
def _axisymmetric(inertia, omega0, q0, k: int, a_perp: float, c_axis: float) -> Evaluator:
    """ω = R_k(Ωτ) ω0,  Λ = Λ_n(|L|τ/A) ∘ Λ0 ∘ Λ_k(−Ωτ),  Ω = (C − A) ω0_k / A."""
    w = [Fraction(x) for x in omega0]
    big_l2 = sum(Fraction(i) ** 2 * x * x for i, x in zip(inertia, w))
    with _decimal_context():
        rate_body = from_decimal(_dec((Fraction(c_axis) - Fraction(a_perp)) * w[k] / Fraction(a_perp)))
        rate_space = from_decimal(_dec(big_l2).sqrt() / _dec(Fraction(a_perp)))
    l_space = rotate_to_space_array(q0, inertia * omega0)
    norm = np.linalg.norm(l_space)
    n = l_space / norm if norm > 0.0 else np.array([0.0, 0.0, 1.0])
    i, j = (k + 1) % 3, (k + 2) % 3

    def evaluate(tau: DD):
        phi_b = _reduce(rate_body, tau, 0.0, _FOUR_PI)[1]
        phi_s = _reduce(rate_space, tau, 0.0, _FOUR_PI)[1]
        c, s = np.cos(phi_b), np.sin(phi_b)
        omega = np.empty(phi_b.shape + (3,))
        omega[:, k] = omega0[k]
        omega[:, i] = c * omega0[i] - s * omega0[j]
        omega[:, j] = s * omega0[i] + c * omega0[j]
        rot_space = np.concatenate([np.cos(0.5 * phi_s)[:, None], np.sin(0.5 * phi_s)[:, None] * n], axis=-1)
        return multiply_array(rot_space, multiply_array(q0, _axis_quaternion(k, -phi_b))), omega

    return evaluate


# ---------------------------------------------------------------- asymmetric body
@dataclass(frozen=True)
class _Elliptic:
    """Per-call constants of the elliptic (or separatrix) solution in frame G (see module docstring)."""

    amp: np.ndarray  # (β, γ, α)
    lam: DD
    u0: float
    half_period: DD | None  # 2K, None on the separatrix
    m: float
    m1: float
    k_big: float  # K (inf on the separatrix)
    k_comp: float  # K' = K(m1)
    nu: float
    psi_rate: DD  # ψ̄
    # periodic part of ψ:  p(r) = p_a r + p_b sn³ R_J(cn², dn², 1, 1 + ν sn²),
    # on the separatrix    p(u) = −p_a atan(p_b tanh u)
    p_a: float  # c Π(n|m)/K − c   (separatrix: c √ν / (1 + ν))
    p_b: float  # c ν / 3          (separatrix: √ν)


def _jacobi_lattice(r, k_big: float, k_comp: float, m1: float):
    """sn, cn, dn from the lattice sums (x_n = π (r − 2nK) / (2K')):

        dn = π/(2K') Σ sech x_n,  cn = π/(2kK') Σ (−1)^n sech x_n,  sn = π/(2kK') Σ (−1)^n tanh x_n,

    the tanh sum taken symmetrically in ±n.  For |r| ≤ K, e^{−|x_{±n}|} ≤ q1^{n − 1/2}; exact at K = ∞."""
    shift = np.pi / (2.0 * k_comp)
    x0 = shift * r
    e0 = np.exp(-np.abs(x0))
    sn, dn = np.tanh(x0), 2.0 * e0 / (1.0 + e0 * e0)  # sech without overflow
    cn = dn.copy()
    if np.isfinite(k_big):
        step = 2.0 * shift * k_big  # −ln q1
        q1 = np.exp(-step)
        ea, eb = np.exp(x0 - step), np.exp(-x0 - step)  # e^{x_1}, e^{−x_{−1}}; then × q1 per n
        for n in range(1, 2 + int(np.ceil(39.2 / step))):
            ea2, eb2 = ea * ea, eb * eb
            da, db = 1.0 + ea2, 1.0 + eb2
            sech_sum = 2.0 * (ea / da + eb / db)
            tanh_sum = 2.0 * (ea2 - eb2) / (da * db)  # tanh x_n + tanh x_{−n}
            if n % 2:
                sn -= tanh_sum
                cn -= sech_sum
            else:
                sn += tanh_sum
                cn += sech_sum
            dn += sech_sum
            ea *= q1
            eb *= q1
    scale = shift / np.sqrt(1.0 - m1)
    return sn * scale, cn * scale, dn * shift


def _elliptic_constants(inertia_g: np.ndarray, omega_g: np.ndarray) -> _Elliptic:
    j1, j2, j3 = (Fraction(x) for x in inertia_g)
    w1, w2, w3 = (Fraction(x) for x in omega_g)
    e1 = j2 * (j2 - j1) * w2 * w2 + j3 * (j3 - j1) * w3 * w3
    e2 = j1 * (j2 - j1) * w1 * w1 + j3 * (j2 - j3) * w3 * w3
    e3 = j1 * (j1 - j3) * w1 * w1 + j2 * (j2 - j3) * w2 * w2
    big_l2 = j1 * j1 * w1 * w1 + j2 * j2 * w2 * w2 + j3 * j3 * w3 * w3
    m1 = (j2 - j3) * e1 / ((j2 - j1) * e3)
    nu = j3 * e2 / (j2 * e3)
    with _decimal_context():
        big_l = _dec(big_l2).sqrt()
        lam = _dec((j2 - j1) * e3 / (j1 * j2 * j3)).sqrt() * (1 if j2 > j1 else -1)
        amp = [_dec(x).sqrt() for x in (e2 / (j1 * (j2 - j1)), e3 / (j2 * (j2 - j3)), e2 / (j3 * (j2 - j3)))]  # β, γ, α
        cn0_sq, dn0_sq = _dec(j3 * (j2 - j3) * w3 * w3 / e2), _dec(j2 * (j2 - j3) * w2 * w2 / e3)
        sn0 = _dec(j1 * (j2 - j1) * w1 * w1 / e2).sqrt() * (1 if w1 >= 0 else -1)
        u0 = sn0 * _u0_integral(cn0_sq, dn0_sq) if sn0 != 0 else Decimal(0)
        c = big_l * _dec(j2 - j3) / (_dec(j2 * j3) * lam)
        sqrt_nu = _dec(nu).sqrt()
        if m1 == 0:
            k_big, half_period = Decimal("Infinity"), None
            psi_rate = big_l / _dec(j1)
            p_a, p_b = c * sqrt_nu / (1 + _dec(nu)), sqrt_nu
        else:
            kc = _dec(m1).sqrt()
            k_big, pi_c = _cel(kc, Decimal(1)), _cel(kc, 1 + _dec(nu))
            half_period = from_decimal(2 * k_big)
            psi_rate = big_l / _dec(j3) * (1 - _dec(j2 - j3) * pi_c / (_dec(j2) * k_big))
            p_a, p_b = c * (pi_c / k_big - 1), c * _dec(nu) / 3
        return _Elliptic(
            amp=np.array([float(x) for x in amp]),
            lam=from_decimal(lam),
            u0=float(u0),
            half_period=half_period,
            m=float(1 - m1),
            m1=float(m1),
            k_big=float(k_big),
            k_comp=float(special.ellipk(float(m1))),
            nu=float(nu),
            psi_rate=from_decimal(psi_rate),
            p_a=float(p_a),
            p_b=float(p_b),
        )


def _elliptic_state(ell: _Elliptic, j: np.ndarray, r: np.ndarray):
    """ω_G and the periodic part p of ψ at u = 2K j + r (|r| ≤ K; j = 0 on the separatrix)."""
    if ell.m1 >= _SERIES_BELOW_M1:
        sn, cn, dn, _ = special.ellipj(r, ell.m)
    else:
        sn, cn, dn = _jacobi_lattice(r, ell.k_big, ell.k_comp, ell.m1)
    sign = 1.0 - 2.0 * (j - 2.0 * np.floor(0.5 * j))  # (−1)^j: sn, cn change sign every 2K
    omega = np.stack([sign * sn, dn, sign * cn], axis=-1) * ell.amp
    if ell.half_period is None:
        p = -ell.p_a * np.arctan(ell.p_b * sn)
    else:
        cn2, dn2 = cn * cn, dn * dn
        p = ell.p_a * r + ell.p_b * (sn * sn * sn) * special.elliprj(cn2, dn2, 1.0, 1.0 + ell.nu * sn * sn)
        if ell.m1 < 1e-200:  # cn², dn² may underflow near ±K, where p is linear: p(±K) = 0, p' = p_a + 3 p_b/(1 + ν)
            slope = ell.p_a + 3.0 * ell.p_b / (1.0 + ell.nu)
            p = np.where(cn2 + dn2 < 1e-200, slope * (r - np.copysign(ell.k_big, r)), p)
    return omega, p


def _frame_permutation(inertia: np.ndarray, omega0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed permutation P (det +1) with rows (middle, dn axis, cn axis) and P ω0 = (·, > 0, ≥ 0)."""
    order = np.argsort(inertia, kind="stable")
    small, mid, large = (int(x) for x in order)
    w = [Fraction(x) for x in omega0]
    inv = [Fraction(x) for x in inertia]
    dist = sum(inv[i] * (inv[i] - inv[mid]) * w[i] ** 2 for i in (small, large))  # L² − 2T I_mid
    dn_axis, cn_axis = (large, small) if dist >= 0 else (small, large)
    idx = (mid, dn_axis, cn_axis)
    s2 = 1.0 if omega0[dn_axis] > 0 else -1.0
    s3 = 1.0 if omega0[cn_axis] >= 0 else -1.0
    parity = 1.0 if idx in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    perm = np.zeros((3, 3))
    for row, (col, sign) in enumerate(zip(idx, (s2 * s3 * parity, s2, s3))):
        perm[row, col] = sign
    return perm, np.array(idx)


def _asymmetric(inertia, omega0, q0) -> Evaluator:
    """Λ = Λ_S ∘ Λ_z(ψ) ∘ Λ_Q ∘ Λ_P and ω = Pᵀ ω_G, with Λ_S fixed by Λ(t0) = Λ0 (ψ(t0) = 0)."""
    perm, idx = _frame_permutation(inertia, omega0)
    inertia_g = inertia[idx]
    ell = _elliptic_constants(inertia_g, perm @ omega0)
    omega_i, p0 = _elliptic_state(ell, np.zeros(1), np.array([ell.u0]))
    q_perm = from_matrix(perm)
    q_lframe0 = _lframe_quaternion(inertia_g * omega_i)[0]
    q_space = multiply_array(multiply_array(q0, conjugate_array(q_perm)), conjugate_array(q_lframe0))  # Λ_S
    matrix = _sandwich_matrix(q_space, q_perm)

    def evaluate(tau: DD):
        j, r = _reduce(ell.lam, tau, ell.u0, ell.half_period)
        omega_g, p = _elliptic_state(ell, j, r)
        psi = _reduce(ell.psi_rate, tau, 0.0, _FOUR_PI)[1] + (p - p0[0])
        return _spin_about_z(psi, _lframe_quaternion(inertia_g * omega_g)) @ matrix, omega_g @ perm

    return evaluate


# ---------------------------------------------------------------- public API
def torque_free_solution(moments, omega0, q0, t0, t) -> tuple[np.ndarray, np.ndarray]:
    """Exact attitude and body angular velocity of a torque-free rigid body.

    moments: (3,) positive principal moments (A, B, C) in any order (equal pairs allowed);
    omega0: (3,) body angular velocity at t0; q0: (4,) unit quaternion (scalar first, body → space) at t0;
    t: (N,) sample times (any order, may precede t0).  Returns (q (N, 4), omega (N, 3)).
    O(1) per sample, no time stepping (see the module docstring for the formulas)."""
    return torque_free_evaluator(moments, omega0, q0, t0)(t)


def torque_free_evaluator(moments, omega0, q0, t0) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """``t ↦ torque_free_solution(moments, omega0, q0, t0, t)``, its constants (the elliptic
    parameters, in extended precision) computed once: each later call costs only its samples."""
    inertia = np.asarray(moments, dtype=float).reshape(3)
    omega0 = np.asarray(omega0, dtype=float).reshape(3)
    q0 = np.asarray(q0, dtype=float).reshape(4)
    if not (np.all(np.isfinite(inertia)) and np.all(inertia > 0.0)):
        raise ValueError("moments must be finite and positive")
    if not (np.all(np.isfinite(omega0)) and np.all(np.isfinite(q0)) and np.linalg.norm(q0) > 0.0):
        raise ValueError("omega0 and q0 must be finite, q0 non-zero")
    q0 = q0 / np.linalg.norm(q0)

    distinct = np.unique(inertia)
    nonzero = np.flatnonzero(omega0)
    if distinct.size < 3:  # axisymmetric (k = the odd axis) or spherical
        k = int(np.argmin([np.count_nonzero(inertia == x) for x in inertia])) if distinct.size == 2 else 2
        evaluate = _axisymmetric(inertia, omega0, q0, k, float(inertia[(k + 1) % 3]), float(inertia[k]))
    elif nonzero.size <= 1:  # at rest or permanent rotation about a principal axis: A = C, Ω = 0
        k = int(nonzero[0]) if nonzero.size else 2
        evaluate = _axisymmetric(inertia, omega0, q0, k, float(inertia[k]), float(inertia[k]))
    else:
        evaluate = _asymmetric(inertia, omega0, q0)

    def solution(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        if not np.all(np.isfinite(t)):
            raise ValueError("sample times must be finite")
        tau_hi, tau_lo = two_sum(t.ravel(), -float(t0))  # t − t0 exactly
        q, omega = np.empty((t.size, 4)), np.empty((t.size, 3))
        for start in range(0, t.size, _CHUNK):  # chunks keep the temporaries in cache
            part = slice(start, start + _CHUNK)
            q[part], omega[part] = evaluate((tau_hi[part], tau_lo[part]))
        return q.reshape(t.shape + (4,)), omega.reshape(t.shape + (3,))

    return solution
