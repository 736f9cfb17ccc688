"""Heavy symmetric top (Lagrange case) in closed form, evaluated directly at the sample times.

Top with principal moments (A, A, C) about the fixed point, centre of mass r_c = (0, 0, l) on the
body symmetry axis e₃, gravity g_space = (0, 0, −g); mgl = m g l (any sign, 0 allowed).  With
u = cos θ = R₃₃, γ = Rᵀ e_z (the vertical in body components) and

    a = C r / A,   b = L_z / A = γ₁ p + γ₂ q + a u,   β = 2 mgl / A,   α = p² + q² + β u,

the first integrals E, L_z, L₃ = C r reduce the motion to

    u̇² = f(u) = (α − β u)(1 − u²) − (b − a u)²,   ü = f'(u)/2.

f ≥ 0 on the nutation band [u₁, u₂] ⊂ [−1, 1], Δ = u₂ − u₁; the third root u₃ lies beyond the
band on the side of sign β (at infinity for β = 0).  With B = |β (u₃ − u_s)|, u_s the band edge
away from u₃, and u̇² = B Δ² sn² cn² dn² = (2λΔ sn cn dn)²:

    u = u₁ + Δ sn²(w | m)  (β ≥ 0),   u = u₂ − Δ sn²(w | m)  (β < 0),
    w = λ (t − t₀) + w₀,   λ = √B / 2,   m = |β| Δ / B,   nutation period 2K(m)/λ.

Orientation: the Cayley–Klein (half-angle) form of Λ = Λ_z(ψ) ∘ Λ_x(θ) ∘ Λ_z(φ),

    q₀ + i q₃ = cos(θ/2) e^{iσ},   q₁ + i q₂ = sin(θ/2) e^{iδ},   σ = (ψ + φ)/2,  δ = (ψ − φ)/2,
    σ̇ = ν + s / (2 (1 + u)),   δ̇ = −ν + d / (2 (1 − u)),
    ν = r (A − C) / (2A),   s = b + a,   d = b − a.

Each rate is singular only where its own amplitude factor vanishes, so Λ stays regular where the
axis passes near or through the vertical; ψ and φ themselves are never formed.  Writing
1 + ε u = e + Δ z² (ε = ∓1, z = sn w or cn w, e ≥ 0 the closest approach to the vertical
u = −ε), ∫ dt / (1 + ε u) is an elliptic integral of the third kind with characteristic
n ∈ [0, 1) (the sn² form is shifted by a quarter period K to reach that range):

    ∫ dt/(1 + ε u) = Ω (t − t₀) + (periodic part: Carlson R_J at the reduced argument),

Ω the mean rate (Π(n|m) by Garrett's AGM).  Where e = 0 (d = 0 or s = 0: the axis passes through
the vertical) the coefficient vanishes and the amplitude is signed, sin(θ/2) = √(Δ/2) z, which
continues Λ analytically through θ = 0 (resp. cos(θ/2) through θ = π).

Body angular velocity: r = r₀ and, with h₋ = sin(θ/2), h₊ = cos(θ/2),

    q + i p = e^{i(σ − δ)} N / (2 h₊ h₋),   N = (b − a u) − i u̇,

evaluated per sample in whichever of three equal forms has the smallest rounding bound:
[(d − i u̇)/(2h₋) + a h₋]/h₊ near θ = 0 (|d − i u̇|² = d² + f(u) = O(1 − u), so the ratio is
bounded), its mirror [(s − i u̇)/(2h₊) − a h₊]/h₋ near θ = π, and
[(b − a u₀) − a (u − u₀) − i u̇]/(2h₊h₋) elsewhere (no O(a) cancellation for fast tops).

Accuracy.  The O(1) set-up runs in 40-digit decimal arithmetic from the exact float inputs
(roots bracketed and Newton-polished, K(m) and Π(n|m) by AGM); the secular terms λ(t − t₀)/K and
Ω (t − t₀) are formed in double-double, so no phase error accumulates over many periods.  Small
quantities are cancellation-free: the band edges come from f written about u₀ (coefficients
u̇₀², 2ü₀, f''(u₀)/2, β: well conditioned near regular precession), the distances e from f written
about ∓1 (constant term −d², −s²), the third root from f(±1) = −d², −s² as a product.  sn, cn, dn
are theta series at |y| ≤ K/2, y the distance to the nearest multiple of K, so each keeps its
relative accuracy near its zeros and for m → 1 (scipy's ellipj does not).

Special cases.  Δ < 1e-50 (regular precession, sleeping top — also an unstable one, which in
exact arithmetic stays vertical): u ≡ u₀, σ̇ and δ̇ constant (error ≲ √Δ).  e < 1e-50 (the axis
passes within ~1e-25 of a vertical) is taken as a passage through it.  1 − m < 1e-150 (m = 1:
the separatrix, infinite period) is raised to 1e-150, which keeps every Carlson argument
≥ 1e-200 (scipy's range): this moves the state by ≲ 1e-75, i.e. errors ≲ 1e-75 e^{λ|t − t₀|}.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from decimal import Context, Decimal, localcontext

import numpy as np
from scipy import special

from rotlab.core.exact.doubledouble import from_decimal, two_prod, two_sum

__all__ = ["lagrange_top_evaluator", "lagrange_top_solution"]

_MC_MIN = 1e-150  # 1 − m floor: m = 1 (infinite period) as the limit of the periodic motion
_E_MIN = Decimal("1e-50")  # nutation width Δ, closest approach 1 ∓ u to a vertical: 0 below this
_DIGITS = 40  # decimal precision of the set-up
_EPS = 2.0**-53  # unit roundoff of the evaluation (float64)
_NEAR_PASS = 1e-20  # |h| below this: at a pass through the vertical taken as exact (e < 1e-50)
_PI = Decimal("3.141592653589793238462643383279502884197169399375105820974944592")
_EXACT = Context(prec=60)
_TWO_PI = (2.0 * math.pi, float(_EXACT.subtract(_EXACT.multiply(2, _PI), Decimal(2.0 * math.pi))))  # hi + lo


# ------------------------------------------------------------- polynomials (decimal) ---


def _horner(c: tuple, x):
    """Σ c_k x^k (coefficients low to high)."""
    acc = 0 * x
    for ck in reversed(c):
        acc = acc * x + ck
    return acc


def _derivative(c: tuple) -> tuple:
    return tuple(k * c[k] for k in range(1, len(c))) or (0 * c[0],)


def _polish(c: tuple, x, iterations: int = 12):
    """Newton steps on the polynomial c from x, kept only while |c(x)| decreases."""
    dc = _derivative(c)
    fx = _horner(c, x)
    for _ in range(iterations):
        dfx = _horner(dc, x)
        if fx == 0 or dfx == 0:
            break
        xn = x - fx / dfx
        fn = _horner(c, xn)
        if not abs(fn) < abs(fx):
            break
        x, fx = xn, fn
    return x


def _sign(x) -> int:
    return (x > 0) - (x < 0)


def _quadratic_roots(c: tuple) -> list:
    """Real roots of c₀ + c₁x + c₂x² (stable form; linear and constant cases included).  For a
    complex pair their real part −c₁/(2c₂): a double root split by rounding is not lost (callers
    only use these as breakpoints or as candidates checked against an accurate guess)."""
    c0, c1, c2 = (tuple(c) + (0 * c[0], 0 * c[0]))[:3]
    if c2 == 0:
        return [] if c1 == 0 else [-c0 / c1]
    disc = c1 * c1 - 4 * c2 * c0
    if disc < 0:
        return [-c1 / (2 * c2)]
    qq = -(c1 + (disc.sqrt() if c1 >= 0 else -disc.sqrt())) / 2
    return [qq / c2, c0 / qq] if qq != 0 else [qq]


def _solve_bracketed(c: tuple, a, b):
    """The root of the polynomial c in a monotone bracket [a, b] (either order), c(a) ≠ 0 and
    sign c(b) ≠ sign c(a): Newton steps kept inside the shrinking bracket, else bisection."""
    dc = _derivative(c)
    sa = _sign(_horner(c, a))
    x = b if abs(_horner(c, b)) < abs(_horner(c, a)) else a
    for _ in range(400):
        fx = _horner(c, x)
        if fx == 0:
            return x
        if _sign(fx) == sa:
            a = x
        else:
            b = x
        dfx = _horner(dc, x)
        xn = x - fx / dfx if dfx != 0 else (a + b) / 2
        if not min(a, b) < xn < max(a, b):
            xn = (a + b) / 2
        if xn == x or abs(b - a) <= _tolerance() * max(abs(a), abs(b)):
            return xn
        x = xn
    return x


def _first_root(c: tuple, a, b):
    """First zero of the polynomial c met going from a (where c(a) ≠ 0) towards b; b if none."""
    sa = _sign(_horner(c, a))
    lo, hi = min(a, b), max(a, b)
    crit = sorted((x for x in _quadratic_roots(_derivative(c)) if lo < x < hi), key=lambda x: abs(x - a))
    left = a
    for right in [*crit, b]:
        if _sign(_horner(c, right)) != sa:
            return _solve_bracketed(c, left, right)
        left = right
    return b


# --------------------------------------------------------------------- double-double ---










def _dd_times(rate: tuple[float, float], dt: tuple[np.ndarray, np.ndarray]):
    """rate·dt as an unnormalised pair (p, e), p + e exact to ~1e-32 relative."""
    p, e = two_prod(rate[0], dt[0])
    return p, e + rate[0] * dt[1] + rate[1] * dt[0]


def _angle(rate: tuple[float, float], dt) -> np.ndarray:
    """rate·dt reduced to (−π, π] without losing the low-order bits."""
    p, e = _dd_times(rate, dt)
    k = np.rint(p / _TWO_PI[0])
    kh, kl = two_prod(k, _TWO_PI[0])
    return ((p - kh) - kl) + (e - k * _TWO_PI[1])


def _rj(x, y, z, p):
    """Carlson R_J (scipy) safe for tiny arguments: x < 1e-40 min(y, p) is set to 0 (R_J changes by
    O(√(x/p)) < 1e-20 relative), then R_J(kx, ky, kz, kp) = k^{−3/2} R_J(x, y, z, p) with k a power
    of 4 (exact) balancing the smallest argument against z = 1 (scipy overflows below ~1e-150)."""
    small = np.minimum(y, p)
    x = np.where(x < 1e-40 * small, 0.0, x)
    small = np.where(x > 0.0, np.minimum(small, x), small)
    j = np.rint(-0.25 * np.log2(np.minimum(small, z)))
    k = np.exp2(2.0 * j)
    return special.elliprj(k * x, k * y, k * z, k * p) * np.exp2(3.0 * j)


# ------------------------------------------------------------- Jacobi elliptic functions ---


@dataclass(frozen=True)
class _Modulus:
    """Parameter m (1 − m given separately, exactly), quarter periods and theta nome.

    m ≤ ½: nome q = exp(−π K'/K), θ-series at ζ = π y / (2K).  m > ½: Jacobi's imaginary
    transformation, series in the complementary nome q' = exp(−π K/K') at ζ' = i π y / (2K').
    """

    m: float
    mc: float
    K: float
    Kp: float
    kp: float
    nome: float
    theta2: float  # θ₂(0)/(2 q^{1/4}), θ₃(0), θ₄(0) for the nome in use
    theta3: float
    theta4: float

    @classmethod
    def of(cls, m: float, mc: float, K: float) -> _Modulus:
        Kp = float(special.ellipkm1(m))
        x = math.exp(-math.pi * Kp / K) if m <= 0.5 else math.exp(-math.pi * K / Kp)
        return cls(
            m=m, mc=mc, K=K, Kp=Kp, kp=math.sqrt(mc), nome=x,
            theta2=1.0 + x**2 + x**6 + x**12,
            theta3=1.0 + 2.0 * (x + x**4 + x**9),
            theta4=1.0 - 2.0 * x + 2.0 * x**4 - 2.0 * x**9,
        )


def _jacobi_small_m(y: np.ndarray, mod: _Modulus):
    """sn, cn, dn (m ≤ ½, |y| ≲ K/2) from θ₁…θ₄ at ζ = π y / (2K), four terms each:
    sn = θ₃(0)θ₁/(θ₂(0)θ₄), cn = θ₄(0)θ₂/(θ₂(0)θ₄), dn = θ₄(0)θ₃/(θ₃(0)θ₄)."""
    z = (0.5 * np.pi / mod.K) * y
    s1, c1 = np.sin(z), np.cos(z)
    t2 = 2.0 * (c1 * c1 - s1 * s1)  # 2 cos 2ζ: multiple angles by the Chebyshev recurrence
    s3 = s1 * (t2 + 1.0)
    s5 = t2 * s3 - s1
    s7 = t2 * s5 - s3
    c3 = c1 * (t2 - 1.0)
    c5 = t2 * c3 - c1
    c7 = t2 * c5 - c3
    e2 = 0.5 * t2
    e4 = t2 * e2 - 1.0
    e6 = t2 * e4 - e2
    q = mod.nome
    th1 = s1 - q**2 * s3 + q**6 * s5 - q**12 * s7
    th2 = c1 + q**2 * c3 + q**6 * c5 + q**12 * c7
    th3 = 1.0 + 2.0 * (q * e2 + q**4 * e4 + q**9 * e6)
    th4 = 1.0 + 2.0 * (-q * e2 + q**4 * e4 - q**9 * e6)
    return (
        (mod.theta3 / mod.theta2) * th1 / th4,
        (mod.theta4 / mod.theta2) * th2 / th4,
        (mod.theta4 / mod.theta3) * th3 / th4,
    )


def _jacobi_large_m(y: np.ndarray, mod: _Modulus):
    """sn, cn, dn (m > ½, |y| ≲ K/2) by sn(y|m) = −i sc(iy|1−m) etc.: hyperbolic θ-series in the
    complementary nome at a = π|y|/(2K'), all scaled by e^{−a} (no overflow as m → 1)."""
    v = (0.5 * np.pi / mod.Kp) * y
    a = np.abs(v)
    big_l = np.pi * mod.K / mod.Kp  # −ln q'
    s_odd = -0.5 * np.expm1(-2.0 * a)  # Σ (−1)ⁿ q'^{n(n+1)} sinh((2n+1)a) e^{−a}
    c_odd = 0.5 * (1.0 + np.exp(-2.0 * a))  # Σ q'^{n(n+1)} cosh((2n+1)a) e^{−a}
    c_even3 = np.exp(-a)  # θ₃(ia) e^{−a}
    c_even4 = c_even3.copy()  # θ₄(ia) e^{−a}
    for n in (1, 2, 3):
        grow = np.exp(2 * n * a - n * (n + 1) * big_l)
        sign = -1.0 if n % 2 else 1.0
        s_odd += sign * 0.5 * grow * -np.expm1(-(4 * n + 2) * a)
        c_odd += 0.5 * (grow + np.exp(-(2 * n + 2) * a - n * (n + 1) * big_l))
        even = np.exp((2 * n - 1) * a - n * n * big_l) + np.exp(-(2 * n + 1) * a - n * n * big_l)
        c_even3 += even
        c_even4 += sign * even
    return (
        np.sign(v) * (mod.theta3 / mod.theta4) * s_odd / c_odd,
        (mod.theta2 / mod.theta4) * c_even4 / c_odd,
        (mod.theta2 / mod.theta3) * c_even3 / c_odd,
    )


def _jacobi(n: np.ndarray, y: np.ndarray, mod: _Modulus):
    """(sn, cn, dn)(y) for |y| ≲ K/2, and at nK + y by the quarter-period shifts
    sn(y + K) = cd y, cn(y + K) = −k' sd y, dn(y + K) = k' nd y (sn, cn change sign under + 2K)."""
    sn, cn, dn = (_jacobi_small_m if mod.m <= 0.5 else _jacobi_large_m)(y, mod)
    r = np.mod(n, 4)
    odd = (r % 2) == 1
    flip = np.where(r >= 2, -1.0, 1.0)
    shifted = (
        flip * np.where(odd, cn / dn, sn),
        flip * np.where(odd, -mod.kp * sn / dn, cn),
        np.where(odd, mod.kp / dn, dn),
    )
    return (sn, cn, dn), shifted


# ------------------------------------------------- complete integrals (decimal, by AGM) ---


def _tolerance() -> Decimal:
    return Decimal(10) ** (2 - _DIGITS)


def _complete_k(mc: Decimal) -> Decimal:
    """K(m) = π / (2 AGM(1, √(1 − m)))."""
    a, g = Decimal(1), mc.sqrt()
    while abs(a - g) > a * _tolerance():
        a, g = (a + g) / 2, (a * g).sqrt()
    return _PI / (2 * a)


def _complete_pi(n: Decimal, one_minus_n: Decimal, mc: Decimal) -> Decimal:
    """Π(n | m), 0 ≤ n < 1, by Garrett's AGM iteration (all terms positive):
    δ₀ = (1−n)/k', ε₀ = n/(1−n), ζ₀ = 0;  ζ ← (ε + ζ)/2, ε ← (δε + ζ)/(1 + δ), (a, g) ← AGM step,
    δ ← g (2 + δ + 1/δ) / (4a);  Π = π (1 + ζ) / (2a)."""
    a, g = Decimal(1), mc.sqrt()
    delta, eps, zeta = one_minus_n / g, n / one_minus_n, Decimal(0)
    for _ in range(500):
        zeta, eps = (eps + zeta) / 2, (delta * eps + zeta) / (1 + delta)
        a, g = (a + g) / 2, (a * g).sqrt()
        delta = g * (2 + delta + 1 / delta) / (4 * a)
        if abs(a - g) <= a * _tolerance() and abs(delta - 1) <= _tolerance():
            break
    return _PI * (1 + zeta) / (2 * a)


# ----------------------------------------------------------------------- state and roots ---


@dataclass(frozen=True)
class _State:
    """Initial data reduced to the quantities of the u-motion (decimal)."""

    p: Decimal
    q: Decimal
    r: Decimal
    nu: Decimal  # r (A − C) / (2A)
    beta: Decimal  # 2 mgl / A
    a: Decimal
    d: Decimal  # b − a
    s: Decimal  # b + a
    one_minus_u0: Decimal
    one_plus_u0: Decimal
    u0: Decimal
    udot0: Decimal
    quat: tuple[Decimal, ...]


def _state(A: float, C: float, mgl: float, omega0, q0) -> _State:
    """From the float inputs (exact as decimals): the normalised Λ₀, γ₁ = R₃₁, γ₂ = R₃₂,
    1 − u₀ = 2(q₁² + q₂²), 1 + u₀ = 2(q₀² + q₃²), b ∓ a = γ₁p + γ₂q ∓ (1 ∓ u₀) a, u̇₀ = γ₁q − γ₂p."""
    quat = [Decimal(float(x)) for x in np.asarray(q0, dtype=float).reshape(4)]
    norm = sum(x * x for x in quat).sqrt()
    c0, c1, c2, c3 = (x / norm for x in quat)
    p, q, r = (Decimal(float(x)) for x in np.asarray(omega0, dtype=float).reshape(3))
    A, C, mgl = Decimal(A), Decimal(C), Decimal(mgl)
    g1, g2 = 2 * (c1 * c3 - c0 * c2), 2 * (c2 * c3 + c0 * c1)
    one_minus_u0, one_plus_u0 = 2 * (c1 * c1 + c2 * c2), 2 * (c0 * c0 + c3 * c3)
    a = C * r / A
    horiz = g1 * p + g2 * q
    return _State(
        p=p, q=q, r=r, nu=r * (A - C) / (2 * A), beta=2 * mgl / A, a=a,
        d=horiz - one_minus_u0 * a, s=horiz + one_plus_u0 * a,
        one_minus_u0=one_minus_u0, one_plus_u0=one_plus_u0, u0=(one_plus_u0 - one_minus_u0) / 2,
        udot0=g1 * q - g2 * p, quat=(c0, c1, c2, c3),
    )


def _cubic_about_u0(st: _State) -> tuple:
    """f(u₀ + x) = u̇₀² + 2ü₀ x + (f''(u₀)/2) x² + β x³, ü₀ = a(b − a u₀) − u₀(p²+q²) − β(1 − u₀²)/2."""
    perp2 = st.p * st.p + st.q * st.q
    b_minus_au0 = st.d + st.a * st.one_minus_u0
    uddot = st.a * b_minus_au0 - st.u0 * perp2 - st.beta * st.one_minus_u0 * st.one_plus_u0 / 2
    return (st.udot0 * st.udot0, 2 * uddot, 2 * st.beta * st.u0 - perp2 - st.a * st.a, st.beta)


def _cubic_about_pole(st: _State, side: int) -> tuple:
    """f in v = 1 + side·u, the distance from the vertical u = −side (side −1: up, +1: down):
    f = −k² + 2(g + side·a k) v − (g + 2 side·β + a²) v² + side·β v³,
    k = d or s (f(∓1) = −k²), g = α + side·β = p² + q² + side·β (1 + side·u₀)."""
    k = st.d if side < 0 else st.s
    g = st.p * st.p + st.q * st.q + side * st.beta * (st.one_minus_u0 if side < 0 else st.one_plus_u0)
    return (-k * k, 2 * (g + side * st.a * k), -(g + 2 * side * st.beta + st.a * st.a), side * st.beta)


def _band(st: _State) -> tuple[Decimal, Decimal]:
    """Band edges x₁ ≤ 0 ≤ x₂ (u = u₀ + x): the zeros of f about u₀ enclosing x = 0.
    At a turning point (u̇₀ = 0) the sign of ü₀ says on which side the band lies."""
    c = _cubic_about_u0(st)
    zero, lo, hi = Decimal(0), -st.one_plus_u0, st.one_minus_u0
    if c[0] > 0:
        return _first_root(c, zero, lo), _first_root(c, zero, hi)
    if c[1] == 0:
        return zero, zero
    deflated = c[1:]  # f = x · (c₁ + c₂ x + β x²)
    if c[1] > 0:
        return zero, _first_root(deflated, zero, hi)
    return _first_root(deflated, zero, lo), zero


def _pole_distance(st: _State, side: int, guess: Decimal) -> Decimal:
    """e = 1 + side·u at the band edge nearest the vertical u = −side, to relative accuracy: the
    root of f written about that vertical nearest to the guess; exactly 0 when the constant
    term −k² is 0 and the band reaches the vertical."""
    c = _cubic_about_pole(st, side)
    if c[0] == 0:
        candidates = [Decimal(0), *(_polish(c[1:], x) for x in _quadratic_roots(c[1:]))]
        return min(candidates, key=lambda x: abs(x - guess))
    return max(_polish(c, guess), Decimal(0))


def _third_root_gap(st: _State, e, delta, side: int):
    """|β (u₃ − u_e)|, u_e the band edge next to u₃ = the vertical −side, from
    f(−side) = −k² = β ∏(−side − u_i): |β| |u₃ + side| = k² / (e (e + Δ)), or where e = 0 from
    the cubic about the pole with its zero root divided out."""
    if e > 0:
        k = st.d if side < 0 else st.s
        return abs(st.beta) * e + k * k / (e * (e + delta))
    return _cubic_about_pole(st, side)[1] / delta


# ------------------------------------------------------------------------ the set-up ---


@dataclass(frozen=True)
class _Side:
    """Half-angle factor h = sin(θ/2) (side −1) or cos(θ/2) (side +1), 1 + side·u = e + Δ z²,
    z = cn w (odd: sharp at odd multiples of K) or sn w.  ∫ dt/(1 + side·u) is
        rate (t − t₀) + kn3 [T(N + shift, y) − T(j + shift, ρ₀) − R_J(0, 1−m, 1, 1−n*)(y − ρ₀)/K],
    rate = lin + κ Π(n*|m)/K its mean, T the Carlson part of Π(n*; am(w − shift·K) | m)."""

    side: int
    coef: float  # d (side −1) or s (side +1)
    e: float
    odd: bool
    kn3: float = 0.0
    n_star: float = 0.0
    one_minus_n_star: float = 1.0
    rj_complete: float = 0.0
    shift: int = 0
    dropped: float = 0.0  # the coefficient taken as 0 for a pass within ~1e-25 of the vertical (e < 1e-50)


def _side(side: int, coef, e, odd: bool, delta, lam, m, mc, K) -> tuple[_Side, Decimal]:
    """Side constants (float) and its mean rate (Decimal).  1/(e + Δ cn²) = 1/(c₀ − Δ sn²),
    c₀ = e + Δ, n = Δ/c₀; the sn² form is moved there by w → w − K:
    1/(e + Δ sn²) = m/(e m + Δ) + [(1 − m)Δ/(e m + Δ)] / (c₀ − (Δ + e m) sn²(w − K)).
    A pass with e < 1e-50 (within ~1e-25 of the vertical) is taken as through it (coefficient 0,
    signed amplitude: the same motion to ~1e-25, and no Carlson argument below float range)."""
    dropped = 0.0
    if e < _E_MIN:
        e, coef, dropped = Decimal(0), 0, float(coef)
    if coef == 0:
        return _Side(side, 0.0, float(e), odd, dropped=dropped), Decimal(0)
    c0 = e + delta
    n, one_minus_n = delta / c0, e / c0
    if odd:
        kappa, lin, n_star, one_minus_star, shift = 1 / c0, Decimal(0), n, one_minus_n, 0
    else:
        em = e * m + delta
        kappa, lin = mc * delta / (em * c0), m / em
        n_star, one_minus_star, shift = n + m * one_minus_n, one_minus_n * mc, 1
    rate = lin + kappa * _complete_pi(n_star, one_minus_star, mc) / K
    rjc = float(_rj(0.0, float(mc), 1.0, float(one_minus_star)))
    kn3 = float(kappa * n_star / (3 * lam))
    floats = (float(coef), float(e), odd, kn3, float(n_star), float(one_minus_star), rjc, shift)
    return _Side(side, *floats), rate


@dataclass(frozen=True)
class _Motion:
    """Everything the evaluation needs: floats for bounded terms, double-double for secular ones."""

    lam: float
    delta: float
    sign_u: float  # +1: u = u₁ + Δ sn², −1: u = u₂ − Δ sn²
    mod: _Modulus
    sides: tuple[_Side, _Side]  # (sin(θ/2): side −1, cos(θ/2): side +1)
    phase_rate: tuple[float, float]  # λ/K
    sigma_rate: tuple[float, float]  # mean σ̇
    delta_rate: tuple[float, float]  # mean δ̇
    a: float = 0.0  # C r / A
    horiz0: float = 0.0  # b − a u₀ = γ₁ p₀ + γ₂ q₀
    x_start: float = 0.0  # u_s − u₀, u = u_s ± Δ sn²
    j: int = 0
    rho0: float = 0.0


def _motion(st: _State, x1: Decimal, x2: Decimal) -> _Motion:
    """The u-motion and the mean rates (decimal), from the band x₁ ≤ 0 ≤ x₂ about u₀, Δ > 0."""
    delta = x2 - x1
    e_m = _pole_distance(st, -1, st.one_minus_u0 - x2)
    e_p = _pole_distance(st, +1, st.one_plus_u0 + x1)
    up = st.beta >= 0  # u = u₁ + Δ sn² (third root above), else u = u₂ − Δ sn²
    if st.beta == 0:
        gap = -_cubic_about_u0(st)[2]  # p² + q² + a²
    else:
        gap = max(_third_root_gap(st, e_m if up else e_p, delta, -1 if up else +1), Decimal(0))
    big_b = gap + abs(st.beta) * delta
    lam = big_b.sqrt() / 2
    m, mc = abs(st.beta) * delta / big_b, max(gap / big_b, Decimal(_MC_MIN))
    K = _complete_k(mc)
    minus, rate_m = _side(-1, st.d, e_m, up, delta, lam, m, mc, K)
    plus, rate_p = _side(+1, st.s, e_p, not up, delta, lam, m, mc, K)
    mot = _Motion(
        lam=float(lam), delta=float(delta), sign_u=1.0 if up else -1.0,
        mod=_Modulus.of(float(m), float(mc), float(K)), sides=(minus, plus),
        phase_rate=from_decimal(lam / K),
        sigma_rate=from_decimal(st.nu + st.s * rate_p / 2),
        delta_rate=from_decimal(-st.nu + st.d * rate_m / 2),
        a=float(st.a), horiz0=float(st.d + st.a * st.one_minus_u0), x_start=float(x1 if up else x2),
    )
    s2, c2 = (-x1, x2) if up else (x2, -x1)
    return _with_initial_phase(mot, s2, c2, direction=_sign(st.udot0) * _sign(mot.sign_u))


def _with_initial_phase(mot: _Motion, s2: Decimal, c2: Decimal, direction: int) -> _Motion:
    """w₀ = j K + ρ₀, |ρ₀| ≤ K/2, from sn²(w₀) ∝ |x_start|, cn²(w₀) ∝ |x_end| and the sign of u̇₀
    (w₀ ≥ 0 at a turning point); F by Carlson R_F at w₀, or at the reflected point K − |w₀|
    (sn = c/d, cn² = (1−m)s²/d², dn² = (1−m)/d²)."""
    mod, direction = mot.mod, direction or 1
    s2, c2 = float(s2 / (s2 + c2)), float(c2 / (s2 + c2))
    d2 = mod.mc + mod.m * c2
    if c2 >= mod.kp * s2:  # |w₀| ≤ K/2: sn²(K/2) = 1/(1 + k')
        return replace(mot, rho0=direction * math.sqrt(s2) * float(special.elliprf(c2, d2, 1.0)))
    reflected = math.sqrt(c2 / d2) * float(special.elliprf(mod.mc * s2 / d2, mod.mc / d2, 1.0))
    return replace(mot, j=direction, rho0=-direction * reflected)


# ------------------------------------------------------------------------ evaluation ---


def _side_terms(sd: _Side, n: np.ndarray, y: np.ndarray, base, mod: _Modulus) -> np.ndarray:
    """T(N, y) = s³ R_J(c², d², 1, 1 − n* s²) at the point y (N even) or, N odd, the remainder
    sign(y)[R_J(0, 1−m, 1, 1−n*) − s'³ R_J(…)] at K − |y| (s' = cd y, c'² = (1−m) sd² y,
    d'² = (1−m) nd² y): cancellation-free arguments on both sides of the sharp point."""
    sn, cn, dn = base
    odd = ((n + sd.shift) % 2) == 1
    s = np.where(odd, cn / dn, sn)
    c2 = np.where(odd, mod.mc * (sn / dn) ** 2, cn * cn)
    d2 = np.where(odd, mod.mc / (dn * dn), dn * dn)
    t = s**3 * _rj(c2, d2, 1.0, sd.one_minus_n_star + sd.n_star * c2)
    return np.where(odd, np.sign(y) * (sd.rj_complete - t), t)


def _amplitude(sd: _Side, z: np.ndarray, delta: float) -> np.ndarray:
    """h = √((e + Δ z²)/2), signed √(Δ/2) z where e = 0 (analytic through the vertical)."""
    return np.sqrt(0.5 * (sd.e + delta * z * z)) if sd.e > 0.0 else math.sqrt(0.5 * delta) * z


def _ratio(sd: _Side, h, zdot, udot, delta: float):
    """(k − i u̇)/(2h) (k = d or s); = −i·side·√(2Δ) ż where e = 0 (u̇ = 2·side·Δ z ż)."""
    if sd.e > 0.0:
        return (sd.coef - 1j * udot) / (2.0 * h)
    return -1j * sd.side * math.sqrt(2.0 * delta) * zdot


def _z(mot: _Motion, sd: _Side, at_w):
    """z and ż for the side: cn w (ż = −λ sn dn) or sn w (ż = λ cn dn)."""
    sn, cn, dn = at_w
    return (cn, -mot.lam * sn * dn) if sd.odd else (sn, mot.lam * cn * dn)


@dataclass(frozen=True)
class _Samples:
    """Phase at the samples: w = N K + y, |y| ≲ K/2, and the Jacobi functions of y and of w."""

    n: np.ndarray
    y: np.ndarray
    base: tuple
    at_w: tuple


def _samples(mot: _Motion, dt) -> _Samples:
    p, e = _dd_times(mot.phase_rate, dt)  # λ(t − t₀)/K
    n_rel = np.rint(p + mot.rho0 / mot.mod.K)
    y = ((p - n_rel) + e) * mot.mod.K + mot.rho0
    n = n_rel.astype(np.int64) + mot.j
    base, at_w = _jacobi(n, y, mot.mod)
    return _Samples(n, y, base, at_w)


def _periodic(mot: _Motion, sd: _Side, smp: _Samples, ref: _Samples) -> np.ndarray:
    """Bounded part of ∫ dt/(1 + side·u) − rate (t − t₀) (zero where the coefficient is)."""
    if sd.coef == 0.0:
        return np.zeros_like(smp.y)
    terms = _side_terms(sd, smp.n, smp.y, smp.base, mot.mod)
    terms -= _side_terms(sd, ref.n, ref.y, ref.base, mot.mod)
    return sd.kn3 * (terms - sd.rj_complete * (smp.y - ref.y) / mot.mod.K)


def _velocity_factor(mot: _Motion, h_m, h_p, ratio_m, ratio_p, udot, sn) -> np.ndarray:
    """N / (2 h₊ h₋), N = (b − a u) − i u̇, so that q + i p = e^{i(σ−δ)} N/(2 h₊ h₋), in whichever of
    three equal forms has the smallest error bound at the sample (none dividing by < 1e-100):
        [(d − i u̇)/(2h₋) + a h₋] / h₊   (near θ = 0),   [(s − i u̇)/(2h₊) − a h₊] / h₋   (near θ = π),
        [(b − a u₀) − a (u − u₀) − i u̇] / (2 h₊ h₋)   (elsewhere: no O(a) cancellation, fast tops).
    Bound = (ε · size of the numerator + what a dropped coefficient (a pass within ~1e-25 of the
    vertical taken as through it) leaves out of it, |k|/(2|h|)) / |denominator|: a top that passes
    that close to θ = 0 and turns near θ = π gets the second form there, not the first divided by
    h₊ ~ 1e-25."""
    a = mot.a
    minus, plus = mot.sides
    x = mot.x_start + mot.sign_u * mot.delta * sn * sn  # u − u₀
    numerators = (ratio_m + a * h_m, ratio_p - a * h_p, (mot.horiz0 - a * x) - 1j * udot)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # unchosen forms may blow up
        errors = (
            _EPS * (np.abs(ratio_m) + np.abs(a * h_m)) + _dropped_error(minus, h_m),
            _EPS * (np.abs(ratio_p) + np.abs(a * h_p)) + _dropped_error(plus, h_p),
            _EPS * (abs(mot.horiz0) + abs(a) * (abs(mot.x_start) + mot.delta * sn * sn) + np.abs(udot)),  # x: a difference
        )
        dens = (h_p, h_m, 2.0 * h_p * h_m)
        forms = [num / den for num, den in zip(numerators, dens)]
        bounds = [np.where(np.abs(d) > 1e-100, err / np.abs(d), np.inf) for err, d in zip(errors, dens)]
    best = np.argmin(np.nan_to_num(np.stack(bounds), nan=np.inf), axis=0)
    return np.choose(best, forms)


def _dropped_error(sd: _Side, h):
    """|k|/(2|h|): what the ratio (k − i u̇)/(2h) misses where k was dropped, away from that
    side's vertical (|h| ≥ ``_NEAR_PASS``); near it the passage's own limit is the model (0 there,
    and where nothing was dropped)."""
    if sd.dropped == 0.0:
        return 0.0
    magnitude = np.abs(h)
    far = magnitude >= _NEAR_PASS
    return np.where(far, abs(sd.dropped) / (2.0 * np.where(far, magnitude, 1.0)), 0.0)


def _half_angles(mot: _Motion, smp: _Samples, ref: _Samples, dt):
    """σ − σ₀, δ − δ₀ (mean rate in double-double plus the periodic part), h₋, h₊ and the
    velocity factor N/(2h₊h₋)."""
    minus, plus = mot.sides
    sigma = _angle(mot.sigma_rate, dt) + 0.5 * plus.coef * _periodic(mot, plus, smp, ref)
    delta = _angle(mot.delta_rate, dt) + 0.5 * minus.coef * _periodic(mot, minus, smp, ref)
    z_m, zdot_m = _z(mot, minus, smp.at_w)
    z_p, zdot_p = _z(mot, plus, smp.at_w)
    h_m, h_p = _amplitude(minus, z_m, mot.delta), _amplitude(plus, z_p, mot.delta)
    sn, cn, dn = smp.at_w
    udot = mot.sign_u * 2.0 * mot.delta * mot.lam * sn * cn * dn
    ratio_m = _ratio(minus, h_m, zdot_m, udot, mot.delta)
    ratio_p = _ratio(plus, h_p, zdot_p, udot, mot.delta)
    return sigma, delta, h_m, h_p, _velocity_factor(mot, h_m, h_p, ratio_m, ratio_p, udot, sn)


def _cayley_klein(st: _State) -> tuple[float, float, float, float]:
    """(cos(θ₀/2), σ₀, sin(θ₀/2), δ₀) of Λ₀: q₀ + i q₃ = cos(θ/2) e^{iσ}, q₁ + i q₂ = sin(θ/2) e^{iδ}."""
    c0, c1, c2, c3 = (float(x) for x in st.quat)
    return math.hypot(c0, c3), math.atan2(c3, c0), math.hypot(c1, c2), math.atan2(c2, c1)


def _initial_angles(st: _State, sides: tuple[_Side, _Side], h_m: float, h_p: float, factor: complex):
    """σ₀, δ₀ from Λ₀, the sign of a signed amplitude at t₀ absorbed into its phase.  Where the
    motion passes through a vertical (e = 0) and t₀ is at it (|h| < 1e-20), that amplitude's phase
    is taken from q₀ + i p₀ = e^{i(σ₀−δ₀)}·factor instead: defined even where h = 0, and right
    where a passage within ~1e-25 (taken as exact) is under way at t₀."""
    _, sigma0, _, delta0 = _cayley_klein(st)
    sigma0 += math.pi if h_p < 0.0 else 0.0
    delta0 += math.pi if h_m < 0.0 else 0.0
    w0 = complex(float(st.q), float(st.p))
    near = [(abs(h), sd.side) for sd, h in zip(sides, (h_m, h_p)) if sd.e == 0.0 and abs(h) < _NEAR_PASS]
    if near and w0 != 0 and factor != 0:
        turn = float(np.angle(w0) - np.angle(factor))  # σ₀ − δ₀
        if min(near)[1] < 0:
            delta0 = sigma0 - turn
        else:
            sigma0 = delta0 + turn
    return sigma0, delta0


def _assemble(h_p, sigma, h_m, delta, w, r):
    """Λ from the Cayley–Klein pair (renormalised: |Λ| = 1 to rounding), ω = (Im w, Re w, r)."""
    quat = np.stack([h_p * np.cos(sigma), h_m * np.cos(delta), h_m * np.sin(delta), h_p * np.sin(sigma)], -1)
    quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
    omega = np.stack([w.imag, w.real, np.full_like(w.real, r)], axis=-1)
    return quat, omega


def _evaluate_nutating(st: _State, mot: _Motion, dt) -> tuple[np.ndarray, np.ndarray]:
    """Λ and ω at the samples: the half-angle phases and amplitudes, q + i p = e^{i(σ−δ)}·factor."""
    zero = (np.zeros(1), np.zeros(1))
    ref = _samples(mot, zero)
    *_, h_m0, h_p0, factor0 = _half_angles(mot, ref, ref, zero)
    sigma0, delta0 = _initial_angles(st, mot.sides, h_m0[0], h_p0[0], factor0[0])
    sigma, delta, h_m, h_p, factor = _half_angles(mot, _samples(mot, dt), ref, dt)
    sigma, delta = sigma + sigma0, delta + delta0
    return _assemble(h_p, sigma, h_m, delta, np.exp(1j * (sigma - delta)) * factor, float(st.r))


def _evaluate_regular(st: _State, dt) -> tuple[np.ndarray, np.ndarray]:
    """No nutation: u ≡ u₀, constant σ̇ = ν + s/(2(1+u₀)), δ̇ = −ν + d/(2(1−u₀)) (terms with
    s = 0 or d = 0 dropped: then 1 ± u₀ may vanish), q + i p turning with φ̇ = σ̇ − δ̇."""
    sigma_rate = st.nu + (st.s / (2 * st.one_plus_u0) if st.s != 0 else 0)
    delta_rate = -st.nu + (st.d / (2 * st.one_minus_u0) if st.d != 0 else 0)
    h_p, sigma0, h_m, delta0 = _cayley_klein(st)
    dsigma, ddelta = _angle(from_decimal(sigma_rate), dt), _angle(from_decimal(delta_rate), dt)
    w = complex(float(st.q), float(st.p)) * np.exp(1j * (dsigma - ddelta))
    ones = np.ones_like(dsigma)
    return _assemble(h_p * ones, sigma0 + dsigma, h_m * ones, delta0 + ddelta, w, float(st.r))


def lagrange_top_solution(
    A: float, C: float, mgl: float, omega0, q0, t0: float, t
) -> tuple[np.ndarray, np.ndarray]:
    """Exact motion of the heavy symmetric top: moments (A, A, C) about the fixed point, centre of
    mass on body axis 3 at height l, gravity −g e_z, mgl = m g l of any sign (0: torque-free).

    omega0 (3,) body ω at t0, q0 (4,) unit quaternion (scalar first, body → space) at t0,
    t (N,) sample times (any order, may be < t0; any shape S gives S + (4,), S + (3,)).
    Returns (q (N, 4), omega (N, 3)).
    Closed form (Jacobi elliptic functions, Carlson integrals), vectorised over the samples.
    """
    return lagrange_top_evaluator(A, C, mgl, omega0, q0, t0)(t)


def lagrange_top_evaluator(A: float, C: float, mgl: float, omega0, q0, t0: float) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """``t ↦ lagrange_top_solution(A, C, mgl, omega0, q0, t0, t)``, the motion's constants (its
    band, in extended precision) computed once: each later call costs only its samples."""
    if not (A > 0.0 and C > 0.0):
        raise ValueError(f"moments must be positive, got A={A}, C={C}")
    omega0 = np.asarray(omega0, dtype=float).reshape(3)
    k = _rate_unit(float(A), float(mgl), omega0)
    with localcontext(Context(prec=_DIGITS)):  # independent of the caller's decimal context
        st = _state(float(A), float(C), float(mgl) / k / k, omega0 / k, q0)
        x1, x2 = _band(st)
        motion = None if x2 - x1 < _E_MIN else _motion(st, x1, x2)  # None: no nutation (to ~1e-25 in Λ)

    def solution(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        dt = tuple(part * k for part in two_sum(t.ravel(), np.full(t.size, -float(t0))))
        with localcontext(Context(prec=_DIGITS)):
            q, omega = _evaluate_regular(st, dt) if motion is None else _evaluate_nutating(st, motion, dt)
        omega *= k
        omega[:, 2] = omega0[2]  # C ṙ = 0: exactly the input, also where ω₀/k is inexact (subnormal)
        return q.reshape(t.shape + (4,)), omega.reshape(t.shape + (3,))

    return solution


def _rate_unit(A: float, mgl: float, omega0: np.ndarray) -> float:
    """The motion's rate scale max(|ω₀|, √|2 mgl/A|) rounded to a power of 2 (1 if zero): the
    solution is computed with time in that unit (ω → ω/k, mgl → mgl/k², t → k t, all exact), so
    its float quantities stay O(1) whatever the units."""
    scale = max(float(np.abs(omega0).max()), math.sqrt(abs(2.0 * mgl / A)))
    return 1.0 if scale == 0.0 or not math.isfinite(scale) else math.ldexp(1.0, math.frexp(scale)[1])
