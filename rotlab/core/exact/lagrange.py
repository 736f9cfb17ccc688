"""Heavy symmetric top (Lagrange case) in closed form, evaluated directly at the sample times.

Top with principal moments (A, A, C) about the fixed point, centre of mass r_c = (0, 0, l) on the
body symmetry axis e₃, gravity g_space = (0, 0, −g); mgl = m g l (any sign, 0 allowed).  With
u = cos θ = R₃₃, γ = Rᵀ e_z (the vertical in body components) and

    a = C r / A,   b = L_z / A = γ₁ p + γ₂ q + a u,   β = 2 mgl / A,   α = p² + q² + β u,

the first integrals E, L_z, L₃ = C r reduce the motion to

    u̇² = f(u) = (α − β u)(1 − u²) − (b − a u)²,   ü = f'(u)/2.

f ≥ 0 on [u₁, u₂] ⊂ [−1, 1] (the nutation band, Δ = u₂ − u₁); its third root u₃ lies beyond the
band on the side of sign(β) (at infinity for β = 0).  With B = |β (u₃ − u_s)| = 2λ², u_s the band
edge away from u₃, m = |β| Δ / B, w = λ (t − t₀) + w₀:

    u = u₁ + Δ sn²(w | m)   (β ≥ 0),       u = u₂ − Δ sn²(w | m)   (β < 0),

period of the nutation 2K(m)/λ.  The orientation uses the Cayley–Klein (half-angle) form of the
3-1-3 angles, Λ = Λ_z(ψ) ∘ Λ_x(θ) ∘ Λ_z(φ):

    q₀ + i q₃ = cos(θ/2) e^{iσ},   q₁ + i q₂ = sin(θ/2) e^{iδ},   σ = (ψ + φ)/2,  δ = (ψ − φ)/2,
    σ̇ = ν + s / (2 (1 + u)),   δ̇ = −ν + d / (2 (1 − u)),
    ν = r (A − C) / (2A),   s = b + a,   d = b − a.

Each rate is singular only where its own amplitude factor vanishes, so Λ stays regular where
the axis passes near (or through) the vertical; ψ and φ are never formed.  Writing
1 ∓ u = e∓ + Δ z², z ∈ {sn w, cn w}, e∓ ≥ 0 the closest approach to ±vertical, the integrals
∫ dt / (1 ∓ u) are complete/incomplete elliptic integrals of the third kind (Carlson R_J,
parameter n ∈ [0, 1) only), quasi-periodic in w.  Where e∓ = 0 (d = 0 or s = 0: the axis
passes through the vertical) the coefficient vanishes and the amplitude is taken signed,
sin(θ/2) = √(Δ/2) z, which continues Λ analytically through θ = 0 (resp. cos(θ/2), θ = π).

Body angular velocity, r = r₀ constant and, with h₋ = sin(θ/2), h₊ = cos(θ/2),

    q + i p = e^{i(σ − δ)} [h₊ (d − i u̇)/(2 h₋) + h₋ (s − i u̇)/(2 h₊)],

both ratios bounded (|d − i u̇|² = d² + f(u) = O(1 − u)).

Accuracy: every small quantity is computed free of cancellation.  The band edges come from the
cubic written about u₀ (coefficients u̇₀², 2ü₀, f''(u₀)/2, β — well conditioned near regular
precession), the distances e∓ from the cubic written about ±1 (constant term −d², −s²); the
third root from f(±1) = −d², −s² as a product.  sn, cn, dn are evaluated by theta series with
the argument reduced to |y| ≤ K/2 about the nearest multiple of K, so each is accurate to a
few ulp relative, also near its zeros and for m → 1 (scipy's ellipj is not).

Special cases: Δ = 0 (regular precession, sleeping top: u stays constant, ψ̇ and φ̇ constant,
also for an unstable sleeping top, which in exact arithmetic stays vertical); m = 1 exactly
(separatrix, infinite period) is evaluated as 1 − m = 1e-300, i.e. exactly up to the point
where the solution diverges from the separatrix by ~1e-150 (λ t ≳ 170).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import special

__all__ = ["lagrange_top_solution"]

_MC_MIN = 1e-300  # 1 − m is clamped here: m = 1 (infinite period) is the limit of the periodic case


# --------------------------------------------------------------------------- polynomials ---


def _horner(c: tuple[float, ...], x: float) -> float:
    """Σ c_k x^k (coefficients low to high)."""
    acc = 0.0
    for ck in reversed(c):
        acc = acc * x + ck
    return acc


def _derivative(c: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(k * c[k] for k in range(1, len(c))) or (0.0,)


def _quadratic_roots(c: tuple[float, ...]) -> list[float]:
    """Real roots of c₀ + c₁x + c₂x² (stable form; linear and constant cases included)."""
    c0, c1, c2 = (tuple(c) + (0.0, 0.0, 0.0))[:3]
    if c2 == 0.0:
        return [] if c1 == 0.0 else [-c0 / c1]
    disc = c1 * c1 - 4.0 * c2 * c0
    if disc < 0.0:
        return []
    qq = -0.5 * (c1 + np.copysign(np.sqrt(disc), c1))
    roots = [qq / c2]
    if qq != 0.0:
        roots.append(c0 / qq)
    return roots


def _solve_bracketed(c: tuple[float, ...], a: float, b: float) -> float:
    """The root of the polynomial c in a monotone bracket [a, b] (either order) with c(a) ≠ 0 and
    sign c(b) ≠ sign c(a): Newton steps kept inside the shrinking bracket, else bisection."""
    dc = _derivative(c)
    sa = np.sign(_horner(c, a))
    x = b if abs(_horner(c, b)) < abs(_horner(c, a)) else a
    for _ in range(200):
        fx = _horner(c, x)
        if fx == 0.0:
            return x
        if np.sign(fx) == sa:
            a = x
        else:
            b = x
        dfx = _horner(dc, x)
        step = fx / dfx if dfx != 0.0 else np.inf
        xn = x - step
        if not (min(a, b) < xn < max(a, b)):
            xn = 0.5 * (a + b)
        if xn == x or abs(b - a) <= 2.0 * np.spacing(max(abs(a), abs(b))):
            return xn
        x = xn
    return x


def _first_root(c: tuple[float, ...], a: float, b: float) -> float:
    """First zero of the polynomial c met going from a (where c(a) ≠ 0) towards b; b if none."""
    sa = np.sign(_horner(c, a))
    lo, hi = min(a, b), max(a, b)
    crit = sorted((x for x in _quadratic_roots(_derivative(c)) if lo < x < hi), key=lambda x: abs(x - a))
    left = a
    for right in [*crit, b]:
        if np.sign(_horner(c, right)) != sa:
            return _solve_bracketed(c, left, right)
        left = right
    return b


def _polish(c: tuple[float, ...], x: float, iterations: int = 8) -> float:
    """Newton steps on the polynomial c from x, kept only while |c(x)| decreases."""
    dc = _derivative(c)
    fx = _horner(c, x)
    for _ in range(iterations):
        dfx = _horner(dc, x)
        if fx == 0.0 or dfx == 0.0:
            break
        xn = x - fx / dfx
        fn = _horner(c, xn)
        if not abs(fn) < abs(fx):
            break
        x, fx = xn, fn
    return x


# ------------------------------------------------------------- Jacobi elliptic functions ---


@dataclass(frozen=True)
class _Modulus:
    """Parameter m (with 1 − m given separately, exactly), quarter periods and theta nome.

    m ≤ ½: nome q = exp(−π K'/K) and θ-series in ζ = π y / (2K).  m > ½: Jacobi's imaginary
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
    def of(cls, m: float, mc: float) -> _Modulus:
        K, Kp = float(special.ellipkm1(mc)), float(special.ellipkm1(m))
        x = np.exp(-np.pi * Kp / K) if m <= 0.5 else np.exp(-np.pi * K / Kp)
        return cls(
            m=m, mc=mc, K=K, Kp=Kp, kp=float(np.sqrt(mc)), nome=float(x),
            theta2=1.0 + x**2 + x**6 + x**12,
            theta3=1.0 + 2.0 * (x + x**4 + x**9),
            theta4=1.0 - 2.0 * x + 2.0 * x**4 - 2.0 * x**9,
        )


def _jacobi_small_m(y: np.ndarray, mod: _Modulus):
    """sn, cn, dn (m ≤ ½, |y| ≤ K/2) from θ₁…θ₄ at ζ = π y / (2K), four terms each:
    sn = θ₃(0)θ₁/(θ₂(0)θ₄), cn = θ₄(0)θ₂/(θ₂(0)θ₄), dn = θ₄(0)θ₃/(θ₃(0)θ₄)."""
    z = (0.5 * np.pi / mod.K) * y
    s1, c1 = np.sin(z), np.cos(z)
    t2 = 2.0 * (c1 * c1 - s1 * s1)  # 2 cos 2ζ: multiple angles by Chebyshev recurrence
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
    q2, q4, q6, q9, q12 = q**2, q**4, q**6, q**9, q**12
    th1 = s1 - q2 * s3 + q6 * s5 - q12 * s7
    th2 = c1 + q2 * c3 + q6 * c5 + q12 * c7
    th3 = 1.0 + 2.0 * (q * e2 + q4 * e4 + q9 * e6)
    th4 = 1.0 + 2.0 * (-q * e2 + q4 * e4 - q9 * e6)
    return (
        (mod.theta3 / mod.theta2) * th1 / th4,
        (mod.theta4 / mod.theta2) * th2 / th4,
        (mod.theta4 / mod.theta3) * th3 / th4,
    )


def _jacobi_large_m(y: np.ndarray, mod: _Modulus):
    """sn, cn, dn (m > ½, |y| ≤ K/2) by sn(y|m) = −i sc(iy|1−m) etc.: hyperbolic θ-series in the
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
    """(sn, cn, dn)(y) for |y| ≤ K/2 and (sn, cn, dn)(nK + y) by the quarter-period shifts
    sn(y + K) = cd y, cn(y + K) = −k' sd y, dn(y + K) = k' nd y; sn, cn change sign under + 2K."""
    sn, cn, dn = (_jacobi_small_m if mod.m <= 0.5 else _jacobi_large_m)(y, mod)
    r = np.mod(n, 4)
    odd = (r % 2) == 1
    shifted_s = np.where(odd, cn / dn, sn)
    shifted_c = np.where(odd, -mod.kp * sn / dn, cn)
    shifted_d = np.where(odd, mod.kp / dn, dn)
    flip = np.where(r >= 2, -1.0, 1.0)
    return (sn, cn, dn), (flip * shifted_s, flip * shifted_c, shifted_d)


# ----------------------------------------------------------------------- state and roots ---


@dataclass(frozen=True)
class _State:
    """Initial data reduced to the quantities of the u-motion (all cancellation-free)."""

    r: float
    nu: float  # r (A − C) / (2A)
    beta: float  # 2 mgl / A
    a: float
    d: float  # b − a
    s: float  # b + a
    one_minus_u0: float
    one_plus_u0: float
    u0: float
    udot0: float
    w0: complex  # q + i p at t₀
    perp2: float  # p² + q²
    quat: np.ndarray  # unit Λ₀


def _state(A: float, C: float, mgl: float, omega0, q0) -> _State:
    quat = np.asarray(q0, dtype=float).reshape(4)
    quat = quat / np.linalg.norm(quat)
    c0, c1, c2, c3 = quat
    p, q, r = (float(x) for x in np.asarray(omega0, dtype=float).reshape(3))
    g1, g2 = 2.0 * (c1 * c3 - c0 * c2), 2.0 * (c2 * c3 + c0 * c1)  # R₃₁, R₃₂
    one_minus_u0, one_plus_u0 = 2.0 * (c1 * c1 + c2 * c2), 2.0 * (c0 * c0 + c3 * c3)
    u0 = 0.5 * (one_plus_u0 - one_minus_u0)
    a = C * r / A
    horiz = g1 * p + g2 * q
    return _State(
        r=r, nu=0.5 * r * (A - C) / A, beta=2.0 * mgl / A, a=a,
        d=horiz - one_minus_u0 * a, s=horiz + one_plus_u0 * a,
        one_minus_u0=one_minus_u0, one_plus_u0=one_plus_u0, u0=u0,
        udot0=g1 * q - g2 * p, w0=complex(q, p), perp2=p * p + q * q, quat=quat,
    )


def _cubic_about_u0(st: _State) -> tuple[float, float, float, float]:
    """f(u₀ + x) = u̇₀² + 2ü₀ x + (f''(u₀)/2) x² + β x³, ü₀ = a(b − a u₀) − u₀(p²+q²) − β(1 − u₀²)/2."""
    b_minus_au = st.d + st.a * st.one_minus_u0
    uddot = st.a * b_minus_au - st.u0 * st.perp2 - 0.5 * st.beta * st.one_minus_u0 * st.one_plus_u0
    return (st.udot0**2, 2.0 * uddot, 2.0 * st.beta * st.u0 - st.perp2 - st.a**2, st.beta)


def _cubic_about_pole(st: _State, side: int) -> tuple[float, float, float, float]:
    """f in v = 1 + side·u, the distance from the vertical u = −side (side −1: up, +1: down):
    f = −k² + 2(g + side·a k) v − (g + 2 side·β + a²) v² + side·β v³,
    k = d or s (f(∓1) = −k²), g = α + side·β = p² + q² + side·β (1 + side·u₀)."""
    k = st.d if side < 0 else st.s
    g = st.perp2 + side * st.beta * (st.one_minus_u0 if side < 0 else st.one_plus_u0)
    return (-k * k, 2.0 * (g + side * st.a * k), -(g + 2.0 * side * st.beta + st.a**2), side * st.beta)


def _band(st: _State) -> tuple[float, float]:
    """Band edges x₁ ≤ 0 ≤ x₂ (u = u₀ + x): the zeros of f about u₀ enclosing x = 0.
    At a turning point (u̇₀ = 0) the sign of ü₀ says which side the band lies on."""
    c = _cubic_about_u0(st)
    lo, hi = -st.one_plus_u0, st.one_minus_u0
    if c[0] > 0.0:
        return _first_root(c, 0.0, lo), _first_root(c, 0.0, hi)
    if c[1] == 0.0:
        return 0.0, 0.0
    deflated = c[1:]  # f = x · (c₁ + c₂ x + β x²)
    if c[1] > 0.0:
        return 0.0, _first_root(deflated, 0.0, hi)
    return _first_root(deflated, 0.0, lo), 0.0


def _pole_distance(st: _State, side: int, guess: float) -> float:
    """e = 1 + side·u at the band edge nearest the vertical u = −side, to relative accuracy:
    the root of f written about that vertical nearest to the guess (exactly 0 when the
    constant term −k² is 0 and the band reaches the vertical)."""
    c = _cubic_about_pole(st, side)
    if c[0] == 0.0:
        candidates = [0.0, *(_polish(c[1:], x) for x in _quadratic_roots(c[1:]))]
        return min(candidates, key=lambda x: abs(x - guess))
    return max(_polish(c, guess), 0.0) if guess < 0.5 else guess


# ------------------------------------------------------------------------ the solution ---


@dataclass(frozen=True)
class _Side:
    """One half-angle factor h = sin(θ/2) (side −1) or cos(θ/2) (side +1): 1 + side·u = e + Δ z²,
    z = cn w ("odd": sharp at odd multiples of K) or sn w, and ∫ dt/(1 + side·u) as
        I(t) = rate (t − t₀) + kn3 [(N − j) R_J(0, 1−m, 1, 1−n*) + T(N + shift, y) − T(j + shift, ρ₀)],
    the quasi-periodic Carlson form of Π(n*; am(w − shift·K) | m)."""

    side: int
    coef: float  # d (side −1) or s (side +1)
    e: float
    odd: bool
    rate: float = 0.0
    kn3: float = 0.0
    n_star: float = 0.0
    one_minus_n_star: float = 1.0
    rj_complete: float = 0.0
    shift: int = 0


def _side(side: int, coef: float, e: float, odd: bool, delta: float, lam: float, mod: _Modulus) -> _Side:
    """1/(e + Δ cn²) = 1/(c₀ − Δ sn²), c₀ = e + Δ, n = Δ/c₀; the sn² form is moved to that one by
    w → w − K: 1/(e + Δ sn²) = m/(e m + Δ) + [(1 − m)Δ/(e m + Δ)] / (c₀ − (Δ + e m) sn²(w − K))."""
    if coef == 0.0:
        return _Side(side, coef, e, odd)
    c0 = e + delta
    n, one_minus_n = delta / c0, e / c0
    if odd:
        kappa, lin, n_star, one_minus_star, shift = 1.0 / c0, 0.0, n, one_minus_n, 0
    else:
        em = e * mod.m + delta
        kappa, lin = mod.mc * delta / (em * c0), mod.m / em
        n_star, one_minus_star, shift = n + mod.m * one_minus_n, one_minus_n * mod.mc, 1
    rjc = float(special.elliprj(0.0, mod.mc, 1.0, one_minus_star))
    return _Side(side, coef, e, odd, kappa + lin, kappa * n_star / (3.0 * lam), n_star, one_minus_star, rjc, shift)


def _side_integral_terms(sd: _Side, n: np.ndarray, y: np.ndarray, base, mod: _Modulus) -> np.ndarray:
    """T(N, y): s³ R_J(c², d², 1, 1 − n* s²) at the point y (N even) or, N odd, the remainder
    sign(y)[R_J(0, 1−m, 1, 1−n*) − s'³ R_J(…)] at K − |y| (s' = cd y, c'² = (1−m) sd² y,
    d'² = (1−m) nd² y): exact cancellation-free arguments on both sides of the sharp point."""
    sn, cn, dn = base
    odd = ((n + sd.shift) % 2) == 1
    s = np.where(odd, cn / dn, sn)
    c2 = np.where(odd, mod.mc * (sn / dn) ** 2, cn * cn)
    d2 = np.where(odd, mod.mc / (dn * dn), dn * dn)
    rj = special.elliprj(c2, d2, 1.0, sd.one_minus_n_star + sd.n_star * c2)
    t = s**3 * rj
    return np.where(odd, np.sign(y) * (sd.rj_complete - t), t)


def _amplitude(sd: _Side, z: np.ndarray, delta: float) -> np.ndarray:
    """h = √((e + Δ z²)/2), signed √(Δ/2) z where e = 0 (analytic through the vertical)."""
    return np.sqrt(0.5 * (sd.e + delta * z * z)) if sd.e > 0.0 else np.sqrt(0.5 * delta) * z


def _ratio(sd: _Side, h, z, zdot, udot, delta: float):
    """(k − i u̇)/(2h) (k = d or s), bounded; = −i·side·√(2Δ) ż where e = 0 (u̇ = 2·side·Δ z ż)."""
    if sd.e > 0.0:
        return (sd.coef - 1j * udot) / (2.0 * h)
    return -1j * sd.side * np.sqrt(2.0 * delta) * zdot


@dataclass(frozen=True)
class _Nutating:
    st: _State
    lam: float
    delta: float
    sign_u: float  # +1: u = u₁ + Δ sn², −1: u = u₂ − Δ sn²
    mod: _Modulus
    j: int
    rho0: float
    sides: tuple[_Side, _Side]  # (sin(θ/2) side −1, cos(θ/2) side +1)
    sigma0: float
    delta0: float

    def _phase(self, dt: np.ndarray):
        """w = λ dt + w₀ = N K + y, |y| ≤ K/2, with w₀ = j K + ρ₀; Jacobi functions of y and w."""
        tau = self.lam * dt + self.rho0
        n_rel = np.rint(tau / self.mod.K)
        y = tau - n_rel * self.mod.K
        n = n_rel.astype(np.int64) + self.j
        base, at_w = _jacobi(n, y, self.mod)
        return n, y, base, at_w

    def _z(self, sd: _Side, at_w):
        """z and dz/dt for the side: cn (ż = −λ sn dn) or sn (ż = λ cn dn)."""
        sn, cn, dn = at_w
        if sd.odd:
            return cn, -self.lam * sn * dn
        return sn, self.lam * cn * dn

    def _integral(self, sd: _Side, dt, n, y, base) -> np.ndarray:
        if sd.coef == 0.0:
            return np.zeros_like(dt)
        j = np.array([self.j])
        base0 = _jacobi(j, np.array([self.rho0]), self.mod)[0]
        t0_term = _side_integral_terms(sd, j, np.array([self.rho0]), base0, self.mod)[0]
        periodic = (n - self.j) * sd.rj_complete + _side_integral_terms(sd, n, y, base, self.mod) - t0_term
        return sd.rate * dt + sd.kn3 * periodic

    def evaluate(self, dt: np.ndarray):
        st, minus, plus = self.st, *self.sides
        n, y, base, at_w = self._phase(dt)
        sigma = self.sigma0 + st.nu * dt + 0.5 * st.s * self._integral(plus, dt, n, y, base)
        delta = self.delta0 - st.nu * dt + 0.5 * st.d * self._integral(minus, dt, n, y, base)
        z_m, zdot_m = self._z(minus, at_w)
        z_p, zdot_p = self._z(plus, at_w)
        h_m, h_p = _amplitude(minus, z_m, self.delta), _amplitude(plus, z_p, self.delta)
        sn, cn, dn = at_w
        udot = self.sign_u * 2.0 * self.delta * self.lam * sn * cn * dn
        ratio_m = _ratio(minus, h_m, z_m, zdot_m, udot, self.delta)
        ratio_p = _ratio(plus, h_p, z_p, zdot_p, udot, self.delta)
        w = np.exp(1j * (sigma - delta)) * (h_p * ratio_m + h_m * ratio_p)
        return _assemble(h_p, sigma, h_m, delta, w, st.r)


def _assemble(h_p, sigma, h_m, delta, w, r):
    """Λ from the Cayley–Klein pair (renormalised: |Λ| = 1 to rounding), ω = (Im w, Re w, r)."""
    quat = np.stack([h_p * np.cos(sigma), h_m * np.cos(delta), h_m * np.sin(delta), h_p * np.sin(sigma)], axis=-1)
    quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
    omega = np.stack([w.imag, w.real, np.full_like(w.real, r)], axis=-1)
    return quat, omega


def _regular(st: _State, dt: np.ndarray):
    """Δ = 0: u ≡ u₀, σ̇, δ̇ constant, q + i p = (q₀ + i p₀) e^{i φ̇ t} with φ̇ = σ̇ − δ̇."""
    q = st.quat
    h_p, h_m = np.hypot(q[0], q[3]), np.hypot(q[1], q[2])
    sigma_rate = st.nu + (0.5 * st.s / st.one_plus_u0 if st.s != 0.0 else 0.0)
    delta_rate = -st.nu + (0.5 * st.d / st.one_minus_u0 if st.d != 0.0 else 0.0)
    sigma = np.arctan2(q[3], q[0]) + sigma_rate * dt
    delta = np.arctan2(q[2], q[1]) + delta_rate * dt
    w = st.w0 * np.exp(1j * (sigma_rate - delta_rate) * dt)
    return _assemble(np.full_like(dt, h_p), sigma, np.full_like(dt, h_m), delta, w, st.r)


def _third_root_gap(st: _State, e_far: float, delta: float, side: int) -> float:
    """|β (u₃ − u_e)|, u_e the band edge next to u₃, from f(±1) = −k² = β ∏(±1 − u_i):
    |β|(|u₃| − 1) = k²/(e (e + Δ)) (cancellation-free), or from the deflated cubic where e = 0."""
    beta = abs(st.beta)
    k = st.d if side < 0 else st.s
    if e_far > 0.0:
        return beta * e_far + k * k / (e_far * (e_far + delta))
    return _cubic_about_pole(st, side)[1] / delta


def _nutating(st: _State, x1: float, x2: float) -> _Nutating:
    delta = x2 - x1
    e_m = _pole_distance(st, -1, st.one_minus_u0 - x2)
    e_p = _pole_distance(st, +1, st.one_plus_u0 + x1)
    up = st.beta >= 0.0  # u = u₁ + Δ sn² (third root above), else u = u₂ − Δ sn²
    if st.beta == 0.0:
        gap = -_cubic_about_u0(st)[2]  # p² + q² + a²
    else:
        gap = _third_root_gap(st, e_m if up else e_p, delta, -1 if up else +1)
    gap = max(gap, 0.0)
    big_b = gap + abs(st.beta) * delta
    lam = 0.5 * np.sqrt(big_b)
    m, mc = abs(st.beta) * delta / big_b, max(gap / big_b, _MC_MIN)
    mod = _Modulus.of(m, mc)
    # initial phase: sn²(w₀) = |x_start|/Δ, cn²(w₀) = |x_end|/Δ, sign from u̇₀
    s2, c2 = (-x1 / delta, x2 / delta) if up else (x2 / delta, -x1 / delta)
    s2, c2 = s2 / (s2 + c2), c2 / (s2 + c2)
    d2 = mc + m * c2
    direction = 1.0 if st.udot0 * (1.0 if up else -1.0) >= 0.0 else -1.0
    if s2 * (1.0 + mod.kp) <= 1.0:  # |w₀| ≤ K/2
        j, rho0 = 0, direction * np.sqrt(s2) * float(special.elliprf(c2, d2, 1.0))
    else:  # w₀ = ±(K − F(am⁻¹ cd w₀)), reflected point sn = c/d, cn² = (1−m)s²/d², dn² = (1−m)/d²
        reflected = np.sqrt(c2 / d2) * float(special.elliprf(mc * s2 / d2, mc / d2, 1.0))
        j, rho0 = int(direction), -direction * reflected
    sides = (
        _side(-1, st.d, e_m, up, delta, lam, mod),
        _side(+1, st.s, e_p, not up, delta, lam, mod),
    )
    sol = _Nutating(st, lam, delta, 1.0 if up else -1.0, mod, j, rho0, sides, 0.0, 0.0)
    return _with_initial_angles(sol)


def _with_initial_angles(sol: _Nutating) -> _Nutating:
    """σ₀, δ₀ from Λ₀; the sign of a signed amplitude at t₀ is absorbed into the phase, and where
    an amplitude vanishes at t₀ its phase follows from q₀ + i p₀ (the formula for ω at t₀)."""
    st, (minus, plus) = sol.st, sol.sides
    q = st.quat
    sigma0, delta0 = np.arctan2(q[3], q[0]), np.arctan2(q[2], q[1])
    *_, at_w = sol._phase(np.zeros(1))
    z_m, zdot_m = (v[0] for v in sol._z(minus, at_w))
    z_p, zdot_p = (v[0] for v in sol._z(plus, at_w))
    h_m, h_p = _amplitude(minus, z_m, sol.delta), _amplitude(plus, z_p, sol.delta)
    if minus.e == 0.0 and h_m < 0.0:
        delta0 += np.pi
    if plus.e == 0.0 and h_p < 0.0:
        sigma0 += np.pi
    if h_m == 0.0:  # q + i p = e^{i(σ−δ)} h₊ i √(2Δ) ż₋
        delta0 = -np.angle(st.w0 * np.exp(-1j * sigma0) / (1j * h_p * zdot_m))
    elif h_p == 0.0:  # q + i p = e^{i(σ−δ)} h₋ (−i) √(2Δ) ż₊
        sigma0 = np.angle(st.w0 * np.exp(1j * delta0) / (-1j * h_m * zdot_p))
    return replace(sol, sigma0=float(sigma0), delta0=float(delta0))


def lagrange_top_solution(A: float, C: float, mgl: float, omega0, q0, t0: float, t) -> tuple[np.ndarray, np.ndarray]:
    """Exact motion of the heavy symmetric top (moments A, A, C about the fixed point, centre of
    mass on body axis 3 at height l, gravity −g e_z, mgl = m g l of any sign).

    omega0 (3,) body ω at t0, q0 (4,) unit quaternion (scalar first, body → space) at t0,
    t (N,) sample times (any order, may be < t0).  Returns (q (N, 4), omega (N, 3)).
    Closed form (Jacobi elliptic functions, Carlson integrals), vectorised over samples.
    """
    if not (A > 0.0 and C > 0.0):
        raise ValueError(f"moments must be positive, got A={A}, C={C}")
    st = _state(float(A), float(C), float(mgl), omega0, q0)
    dt = np.asarray(t, dtype=float) - float(t0)
    x1, x2 = _band(st)
    if x2 - x1 == 0.0:
        return _regular(st, dt)
    return _nutating(st, x1, x2).evaluate(dt)
