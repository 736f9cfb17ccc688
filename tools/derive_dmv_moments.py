"""Derive the modified moments of inertia of the preprocessed discrete Moser–Veselov algorithm.

Development tool (needs sympy; ``rotlab`` never imports it).  Usage::

    python tools/derive_dmv_moments.py [ORDER] > table.py     # ORDER 4, 6, …, 14 (default 12)

Method (Hairer & Vilmart 2006 for the ansatz; the coefficients are derived here from scratch).
One DMV step (see ``rotlab.core.dmv``) is run with the moments

    1/Ĩ_k = C_S α_k + C_D,   α_k = 1/I_k,
    C_S = 1 + Σ_{j≥1} h^{2j} Σ_l σ_{j,l} N^{j−l} H^l,   C_D = Σ_{j≥1} h^{2j} Σ_l δ_{j,l} N^{j−l} H^l,

N = ½|m|², H = ½ Σ α_k m_k², and both the step and the exact flow over time h are expanded as
power series in h whose coefficients are polynomials in m (and Laurent polynomials in α):

* exact flow: m(h) = Σ hⁿ/n! Lⁿ m with L the Lie derivative along ṁ = m × (α∘m); the rotation
  Λ(h) = Λ₀ ∘ q(h) with q̇ = ½ q ∘ (0, α∘m(t)), q(0) = 1, solved term by term;
* DMV step: c = (1 + |c|²) a + f ⊙ (c₂c₃, c₃c₁, c₁c₂) solved order by order in h (c = O(h); the
  h^n term of the right-hand side only needs c up to h^{n−1}), with f_k = J_k (1/J_i − 1/J_j),
  J_k = 1/Ĩ_k = C_S (α_k + D), D = C_D/C_S, every reciprocal expanded in h²; then
  q = (1, c)/√(1 + |c|²) and m_k ← m_k + (4/h)(Ĩ_i − Ĩ_j) c_i c_j/(1 + |c|²).

Degree by degree (j = 1, 2, …): with the coefficients of degree < j known and those of degree j
set to zero, the residual (DMV − exact) vanishes up to h^{2j}; the degree-j coefficients enter the
h^{2j+1} term linearly, and only through

    m_k:  + S_j(N, H) (α_j − α_i) m_i m_j            (the right-hand side of Euler's equations)
    q:    + ½ (S_j(N, H) α∘m + D_j(N, H) m)           (vector part; the scalar part is unaffected)

with S_j = Σ_l σ_{j,l} N^{j−l} H^l, D_j likewise.  Asking the h^{2j+1} residual to vanish for every
m gives an overdetermined linear system for the 2(j + 1) unknowns σ_{j,l}, δ_{j,l}: it is solved
exactly (rational functions of α) on a square subsystem chosen at a random numerical point, and
then, as a proof that it is consistent, the whole series is recomputed with the solution and the
residual of m and of q is checked to be exactly zero at h^{2j+1} AND h^{2j+2} (the latter holds by
symmetry of the method, and is checked, not assumed).  Hence the local error is O(h^{2j+3}): order
2j + 2 for both m and Λ.

Output: each coefficient as P(e1, e2, e3)/e3^k in the elementary symmetric functions of the moments
e1 = A + B + C, e2 = AB + BC + CA, e3 = ABC (the symmetry under permutations of the axes is thus
verified: sympy's symmetrize leaves no remainder), printed as Python for
``rotlab.core.dmv.modified_coefficients``.

Run time (one core, sympy 1.14, pure-Python rationals; the script prints its own timings):
order 4 ≈ 0.5 s, 6 ≈ 1 s, 8 ≈ 3 s, 10 ≈ 17 s, 12 ≈ 55 s (the default; the table in
``rotlab.core.dmv``), 14 ≈ 3–7 min (derived and verified, but not offered: its error cannot be
measured against a double-precision reference over a range of steps wide enough to show order 14).
"""

from __future__ import annotations

import random
import sys
import time

import sympy as sp
from sympy import QQ
from sympy.polys.polyfuncs import symmetrize
from sympy.polys.matrices import DomainMatrix
from sympy.polys.rings import ring

# m1, m2, m3 and the inverse moments α_k (exponents of α may be negative: Laurent polynomials)
R, m1, m2, m3, a1, a2, a3 = ring("m1,m2,m3,a1,a2,a3", QQ)
M = (m1, m2, m3)
ALPHA = (a1, a2, a3)
CYCLIC = ((0, 1, 2), (1, 2, 0), (2, 0, 1))  # (k, i, j)
ONE, ZERO = R.one, R.zero


def inv_alpha(k: int, power: int = 1):
    exponent = [0] * 6
    exponent[3 + k] = -power
    return R({tuple(exponent): QQ(1)})


# --- truncated power series in h: lists s[0..P] of ring elements ---------------------------------


def s_zero(P):
    return [ZERO] * (P + 1)


def s_const(x, P):
    s = s_zero(P)
    s[0] = x
    return s


def s_add(s, t):
    return [x + y for x, y in zip(s, t)]


def s_sub(s, t):
    return [x - y for x, y in zip(s, t)]


def s_scale(s, x):
    return [x * y for y in s]


def s_mul(s, t):
    P = len(s) - 1
    out = s_zero(P)
    nz_s = [i for i in range(P + 1) if s[i]]
    nz_t = [i for i in range(P + 1) if t[i]]
    for i in nz_s:
        for j in nz_t:
            if i + j > P:
                break
            out[i + j] += s[i] * t[j]
    return out


def s_shift_down(s):
    """s/h for a series with s[0] = 0 (the top term becomes unknown: zero, and unused)."""
    assert not s[0]
    return s[1:] + [ZERO]


def s_compose(coefficients, x):
    """Σ_n coefficients[n] xⁿ for a series x with x[0] = 0."""
    assert not x[0]
    P = len(x) - 1
    out = s_const(coefficients[0], P)
    power = s_const(ONE, P)
    for n in range(1, P + 1):
        power = s_mul(power, x)
        if not any(power):
            break
        out = s_add(out, s_scale(power, coefficients[n]))
    return out


def binomial_series(exponent, P):
    """coefficients of (1 + x)^exponent."""
    out, c = [], QQ(1)
    for n in range(P + 1):
        out.append(c)
        c = c * (exponent - n) / (n + 1)
    return out


def s_inverse_one_plus(s):
    """1/s for a series with s[0] = 1."""
    assert s[0] == ONE
    P = len(s) - 1
    x = [ZERO] + s[1:]
    return s_compose([ONE * c for c in binomial_series(QQ(-1), P)], x)


# --- quaternions (scalar, x, y, z) of ring elements ----------------------------------------------


def q_mul(p, q):
    p0, p1, p2, p3 = p
    q0, q1, q2, q3 = q
    return (
        p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
        p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
        p0 * q2 + p2 * q0 + p3 * q1 - p1 * q3,
        p0 * q3 + p3 * q0 + p1 * q2 - p2 * q1,
    )


# --- exact flow ------------------------------------------------------------------------------------

EULER = [(ALPHA[j] - ALPHA[i]) * M[i] * M[j] for k, i, j in CYCLIC]  # ṁ = m × (α∘m)


def lie(f):
    return sum((f.diff(M[k]) * EULER[k] for k in range(3)), ZERO)


def exact_flow(P):
    """Taylor coefficients (h^0..h^P) of m(h) (3 series) and q(h) (4 series)."""
    m_series = [[ZERO] * (P + 1) for _ in range(3)]
    for k in range(3):
        term = M[k]
        for n in range(P + 1):
            m_series[k][n] = term
            term = lie(term) * QQ(1, n + 1)
    omega = [[ALPHA[k] * m_series[k][n] for k in range(3)] for n in range(P + 1)]
    q = [(ONE, ZERO, ZERO, ZERO)]
    for n in range(P):
        total = [ZERO] * 4
        for r in range(n + 1):
            prod = q_mul(q[r], (ZERO, *omega[n - r]))
            total = [t + x for t, x in zip(total, prod)]
        q.append(tuple(t * QQ(1, 2 * (n + 1)) for t in total))
    q_series = [[q[n][c] for n in range(P + 1)] for c in range(4)]
    return m_series, q_series


# --- one DMV step ----------------------------------------------------------------------------------

N_INV = (m1**2 + m2**2 + m3**2) * QQ(1, 2)
H_INV = (a1 * m1**2 + a2 * m2**2 + a3 * m3**2) * QQ(1, 2)


def monomials(j):
    return [N_INV ** (j - l) * H_INV**l for l in range(j + 1)]


def dmv_step(P, sigma, delta):
    """Series (h^0..h^P) of the DMV step's m (3) and q (4) with the tables sigma[j], delta[j]
    (lists of ring elements, coefficients of N^{j−l} H^l, degree j = 1, 2, …)."""
    top = P
    P = P + 1  # the kick (4/h) c_i c_j needs c_i c_j to h^{P+1}
    cs = s_const(ONE, P)
    cd = s_zero(P)
    for j in sigma:
        if 2 * j <= P:
            cs[2 * j] = sum((s * mono for s, mono in zip(sigma[j], monomials(j))), ZERO)
            cd[2 * j] = sum((d * mono for d, mono in zip(delta[j], monomials(j))), ZERO)
    inv_cs = s_inverse_one_plus(cs)
    D = s_mul(cd, inv_cs)  # D = C_D / C_S = O(h²)
    # 1/(α_k + D) = Σ (−D)ⁿ / α_k^{n+1}
    inv_shift = [s_compose([inv_alpha(k, n + 1) * (-1) ** n for n in range(P + 1)], D) for k in range(3)]
    J = [s_mul(cs, s_add(s_const(ALPHA[k], P), D)) for k in range(3)]  # 1/Ĩ_k
    Itilde = [s_mul(inv_cs, inv_shift[k]) for k in range(3)]  # Ĩ_k
    # a_k = h m_k J_k / 2
    a = [[ZERO] + [M[k] * J[k][n] * QQ(1, 2) for n in range(P)] for k in range(3)]
    # f_k = J_k (Ĩ_i − Ĩ_j) = (α_k + D)(α_j − α_i) / ((α_i + D)(α_j + D))
    f = [None] * 3
    for k, i, j in CYCLIC:
        f[k] = s_scale(s_mul(s_add(s_const(ALPHA[k], P), D), s_mul(inv_shift[i], inv_shift[j])), ALPHA[j] - ALPHA[i])
    # c order by order
    c = [s_zero(P) for _ in range(3)]

    def product_term(x, y, n):  # [x y]_n from terms < n
        return sum((x[p] * y[n - p] for p in range(1, n) if x[p] and y[n - p]), ZERO)

    for n in range(1, P + 1):
        norm2 = [ZERO] * (n + 1)  # [|c|²]_r, r < n (needs c up to r − 1)
        for r in range(2, n):
            norm2[r] = sum((product_term(c[k], c[k], r) for k in range(3)), ZERO)
        for k, i, j in CYCLIC:
            value = a[k][n]
            for r in range(1, n - 1):  # [|c|² a]_n
                if norm2[n - r] and a[k][r]:
                    value += norm2[n - r] * a[k][r]
            for t in range(0, n - 1):  # [f c_i c_j]_n
                if f[k][t]:
                    value += f[k][t] * product_term(c[i], c[j], n - t)
            c[k][n] = value
    norm2 = s_zero(P)
    for k in range(3):
        norm2 = s_add(norm2, s_mul(c[k], c[k]))
    x = [ZERO] + norm2[1:]
    rsqrt = s_compose([ONE * b for b in binomial_series(QQ(-1, 2), P)], x)
    recip = s_compose([ONE * b for b in binomial_series(QQ(-1), P)], x)
    q_series = [rsqrt] + [s_mul(c[k], rsqrt) for k in range(3)]
    m_series = []
    for k, i, j in CYCLIC:
        kick = s_mul(s_mul(s_sub(Itilde[i], Itilde[j]), s_shift_down(s_mul(c[i], c[j]))), recip)
        m_series.append(s_add(s_const(M[k], P), s_scale(kick, QQ(4)))[: top + 1])
    return m_series, [s[: top + 1] for s in q_series]


def residuals(P, sigma, delta, exact):
    m_dmv, q_dmv = dmv_step(P, sigma, delta)
    m_ex, q_ex = exact
    return [s_sub(x, y) for x, y in zip(m_dmv, [s[: P + 1] for s in m_ex])], [
        s_sub(x, y) for x, y in zip(q_dmv, [s[: P + 1] for s in q_ex])
    ]


# --- conversions ---------------------------------------------------------------------------------

F, fa1, fa2, fa3 = sp.field("a1,a2,a3", QQ)  # rational functions of the α
F_ALPHA = (fa1, fa2, fa3)


def by_m_monomial(poly):
    """{m-exponents: {α-exponents: coefficient}}."""
    out = {}
    for mon, v in poly.terms():
        inner = out.setdefault(mon[:3], {})
        inner[mon[3:]] = inner.get(mon[3:], QQ(0)) + v
    return out


def laurent_at(d, point):
    total = QQ(0)
    for mon, v in d.items():
        term = v
        for x, e in zip(point, mon):
            term *= x**e
        total += term
    return total


def laurent_to_field(d):
    total = F.zero
    for mon, v in d.items():
        term = F(v)
        for x, e in zip(F_ALPHA, mon):
            term *= x**e  # negative powers fine in the field
        total += term
    return total


def field_to_ring(x):
    """A rational function of the α whose denominator is a monomial → Laurent ring element."""
    num, den = x.numer, x.denom
    if len(den.terms()) != 1:
        raise ArithmeticError(f"denominator is not a monomial: {den}")
    (den_mon, den_coeff), = den.terms()
    return R({(0, 0, 0) + tuple(e - d for e, d in zip(mon, den_mon)): v / den_coeff for mon, v in num.terms()})


# --- solving ---------------------------------------------------------------------------------------


def solve_degree(j, res_m, res_q):
    """σ_{j,l}, δ_{j,l} from the h^{2j+1} residuals (with the degree-j coefficients zero)."""
    n = 2 * j + 1
    monos = monomials(j)
    # contribution of each unknown to (m1, m2, m3, q1, q2, q3) at h^n
    contributions = []
    for mono in monos:  # σ_{j,l}
        contributions.append([mono * EULER[k] for k in range(3)] + [mono * ALPHA[k] * M[k] * QQ(1, 2) for k in range(3)])
    for mono in monos:  # δ_{j,l}
        contributions.append([ZERO] * 3 + [mono * M[k] * QQ(1, 2) for k in range(3)])
    targets = [-res_m[k][n] for k in range(3)] + [-res_q[1 + k][n] for k in range(3)]
    if res_q[0][n]:
        raise ArithmeticError(f"scalar part of q has a residual at h^{n} that no coefficient can fix")
    rows, rhs = [], []
    for comp in range(6):
        tables = [by_m_monomial(contrib[comp]) for contrib in contributions]
        target = by_m_monomial(targets[comp])
        keys = set(target).union(*[set(t) for t in tables])
        for key in sorted(keys):
            rows.append([t.get(key, {}) for t in tables])
            rhs.append(target.get(key, {}))
    unknowns = len(contributions)
    # a square subsystem of full rank, chosen greedily at a random rational point
    rng = random.Random(12345)
    point = [QQ(rng.randint(2, 97), rng.randint(2, 97)) for _ in range(3)]
    chosen = []
    for r, row in enumerate(rows):
        trial = DomainMatrix([[laurent_at(x, point) for x in rows[i]] for i in chosen + [r]], (len(chosen) + 1, unknowns), QQ)
        if trial.rank() > len(chosen):
            chosen.append(r)
            if len(chosen) == unknowns:
                break
    if len(chosen) < unknowns:
        raise ArithmeticError("the linear system is rank deficient")
    domain = F.to_domain()
    matrix = DomainMatrix([[laurent_to_field(x) for x in rows[i]] for i in chosen], (unknowns, unknowns), domain)
    vector = DomainMatrix([[laurent_to_field(rhs[i])] for i in chosen], (unknowns, 1), domain)
    solution = [field_to_ring(matrix.lu_solve(vector)[i, 0].element) for i in range(unknowns)]
    # (the solution is then proven to solve the whole system: derive() recomputes the residual)
    return solution[: j + 1], solution[j + 1 :]


def derive(order):
    degrees = order // 2 - 1
    P = order
    t0 = time.perf_counter()
    exact = exact_flow(P)
    print(f"# exact flow to h^{P}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    sigma, delta = {}, {}
    for j in range(1, degrees + 1):
        n = 2 * j + 1
        t1 = time.perf_counter()
        res_m, res_q = residuals(n, sigma, delta, exact)
        for s in res_m + res_q:  # lower orders already match
            assert not any(s[:n]), "residual below h^{2j+1}"
        sigma[j], delta[j] = solve_degree(j, res_m, res_q)
        # proof: with the solution, the residual vanishes exactly at h^{2j+1} and h^{2j+2}
        res_m, res_q = residuals(n + 1, sigma, delta, exact)
        for s in res_m + res_q:
            if any(s):
                raise ArithmeticError(f"degree {j}: residual left at h^{[i for i, x in enumerate(s) if x]}")
        print(f"# degree {j} (order {2 * j + 2}) solved and verified through h^{n + 1}: {time.perf_counter() - t1:.1f} s", file=sys.stderr)
    print(f"# total {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return sigma, delta


# --- output --------------------------------------------------------------------------------------

MOMENTS = sp.symbols("A B C", positive=True)
E1, E2, E3 = sp.symbols("e1 e2 e3")


def in_symmetric_functions(coefficient):
    """The coefficient (Laurent ring element in α) as P(e1, e2, e3)/e3^k."""
    expr = sp.Add(
        *[sp.Rational(int(v.numerator), int(v.denominator)) * sp.Mul(*[s ** (-e) for s, e in zip(MOMENTS, mon[3:])]) for mon, v in coefficient.terms()]
    )  # α_k = 1/I_k
    num, den = sp.fraction(sp.cancel(sp.together(expr)))
    den_poly = sp.Poly(den, *MOMENTS)
    (den_mon, den_coeff), = den_poly.terms()
    k = max(den_mon)
    num = sp.expand(num * sp.Mul(*[s ** (k - e) for s, e in zip(MOMENTS, den_mon)]))  # over (ABC)^k
    symmetric, remainder = symmetrize(num, *MOMENTS, formal=True, symbols=(E1, E2, E3))[:2]
    if remainder != 0:
        raise ArithmeticError(f"coefficient not symmetric in the moments: {expr}")
    return sp.expand(symmetric) / (den_coeff * E3**k)


def python_source(sigma, delta):
    lines = []
    for j in sorted(sigma):
        lines.append(f"    # degree {j} (order {2 * j + 2})")
        for which, table in ((0, sigma), (1, delta)):
            entries = []
            for coefficient in table[j]:
                num, den = sp.fraction(sp.factor(in_symmetric_functions(coefficient)))
                entries.append(f"({sp.pycode(num)}) / ({sp.pycode(den)})" if den != 1 else f"{sp.pycode(num)}")
            lines.append(f"    c[{which}, {j - 1}, :{j + 1}] = [")
            lines.extend(f"        {e}," for e in entries)
            lines.append("    ]")
    return "\n".join(lines)


if __name__ == "__main__":
    order = int(sys.argv[1]) if len(sys.argv) > 1 else 12
    if order not in (4, 6, 8, 10, 12, 14):
        raise SystemExit("ORDER: one of 4, 6, 8, 10, 12, 14")
    sigma, delta = derive(order)
    size = order // 2
    print(
        f'''def modified_coefficients(moments) -> np.ndarray:
    """(2, {size}, {size}) table: [0] the s-coefficients, [1] the d-coefficients; row j − 1 holds the
    coefficients of N^{{j−l}} H^l, l = 0..j, of degree j (orders up to {order}).  Derived (exact
    rational functions, here in the elementary symmetric functions e1, e2, e3 of the moments) and
    printed by tools/derive_dmv_moments.py, which proves the local error O(h^{{2j+3}}) for m and Λ."""
    A, B, C = (float(x) for x in moments)
    e1 = A + B + C
    e2 = A * B + B * C + C * A
    e3 = A * B * C
    c = np.zeros((2, {size}, {size}))'''
    )
    print(python_source(sigma, delta))
    print("    return c")
