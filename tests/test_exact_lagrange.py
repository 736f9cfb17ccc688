"""Heavy symmetric top (Lagrange case): the closed form pinned against high-precision references.

References (mpmath):
* ``taylor_ode``: the 7-dim system (ω, Λ) — Euler's equations with the gravity torque
  M = mgl (γ₂, −γ₁, 0), γ = Rᵀe_z, and Λ̇ = ½ Λ ∘ (0, ω) — integrated by mpmath.odefun (Taylor
  series, 20–30 digits) over spans of a few time units, forwards and backwards;
* ``mp_closed_form``: the same solution path in 40–90 digits (roots by polyroots, u by ellipfun,
  ∫dt/(1 ± u) by ellippi with quasi-periodicity, ω in the classical Euler-angle form), itself
  checked against the Taylor ODE to 1e-20; used for 1000 nutation periods.

Bounds (Λ: max |Λ − Λ_ref|; ω: max |ω − ω_ref| / max |ω_ref|):
* 1000 nutation periods, random tops (hypothesis): < 1e-13 (the issue asks 1e-12; observed ≤ 1.4e-15 in 150 examples);
* short spans against the Taylor ODE, special cases included: < 1e-14 (observed ≤ 2e-15);
* E, L_z, L₃ constant to 1e-14 relative, | |Λ| − 1 | < 1e-15 over 1000 periods;
* finite differences (8th order): Λ̇ = ½ Λ∘ω and Euler's equations to 1e-10 (relative);
* fast tops: (p, q) to 1e-13 of |ω⊥| over 1000 periods (observed ~7e-16);
* nutation period 2K/λ = spacing of the minima of θ to 1e-13 relative (minima 1000 periods apart);
* any input (hypothesis, subnormal to 1e3): finite, unit Λ, initial state reproduced;
* the private theta-series sn, cn, dn: ≤ 8 ulp relative, also at their zeros and m → 1.
"""

from __future__ import annotations

import math
import warnings

import mpmath as mp
import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from rotlab.core import quaternion as quat
from rotlab.core.exact.lagrange import lagrange_top_solution

# ------------------------------------------------------------------------- references ---


def _qmul(a, b):
    a0, a1, a2, a3 = a
    b0, b1, b2, b3 = b
    return [
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 + a2 * b0 + a3 * b1 - a1 * b3,
        a0 * b3 + a3 * b0 + a1 * b2 - a2 * b1,
    ]


def taylor_ode(A, C, mgl, omega0, q0, t0, ts, dps=20):
    """(Λ, ω) at ts by mpmath.odefun; times before t0 through the time-reversed system."""
    rows = []
    with mp.workdps(dps):
        A, C, mgl = mp.mpf(A), mp.mpf(C), mp.mpf(mgl)
        lam0 = [mp.mpf(float(x)) for x in q0]
        norm = mp.sqrt(sum(x * x for x in lam0))
        y0 = [mp.mpf(float(x)) for x in omega0] + [x / norm for x in lam0]

        def rhs(direction):
            def f(_, y):
                p, q, r, *lam = y
                g1, g2 = 2 * (lam[1] * lam[3] - lam[0] * lam[2]), 2 * (lam[2] * lam[3] + lam[0] * lam[1])
                dlam = _qmul(lam, [0, p, q, r])
                dw = [((A - C) * q * r + mgl * g2) / A, ((C - A) * r * p - mgl * g1) / A, mp.mpf(0)]
                return [direction * x for x in dw + [v / 2 for v in dlam]]

            return f

        forward, backward = mp.odefun(rhs(1), 0, y0), mp.odefun(rhs(-1), 0, y0)
        for t in ts:
            s = mp.mpf(float(t)) - mp.mpf(float(t0))
            rows.append(forward(s) if s >= 0 else backward(-s))
    return rows


def mp_closed_form(A, C, mgl, omega0, q0, t0, ts, dps=40):
    """Same solution path in mpmath: (rows of [Λ, ω] as mpf, nutation period 2K/λ, smallest of
    Δ, 1 − u₂, 1 + u₁ — the reference needs digits beyond −log₁₀ of it)."""
    with mp.workdps(dps):
        A, C, mgl, t0 = (mp.mpf(float(x)) for x in (A, C, mgl, t0))
        lam = [mp.mpf(float(x)) for x in q0]
        norm = mp.sqrt(sum(x * x for x in lam))
        lam = [x / norm for x in lam]
        p, q, r = (mp.mpf(float(x)) for x in omega0)
        g1, g2 = 2 * (lam[1] * lam[3] - lam[0] * lam[2]), 2 * (lam[2] * lam[3] + lam[0] * lam[1])
        u0 = lam[0] ** 2 - lam[1] ** 2 - lam[2] ** 2 + lam[3] ** 2
        a, beta = C * r / A, 2 * mgl / A
        b, alpha = g1 * p + g2 * q + a * u0, p * p + q * q + beta * u0
        nu, s, d, udot0 = r * (A - C) / (2 * A), b + a, b - a, g1 * q - g2 * p
        coeffs = [beta, -(alpha + a * a), 2 * a * b - beta, alpha - b * b]
        with warnings.catch_warnings():  # mpmath ≥ 1.4 asks for asc=…, which 1.3 lacks
            warnings.simplefilter("ignore", DeprecationWarning)
            found = mp.polyroots(coeffs if beta else coeffs[1:], maxsteps=400, extraprec=3 * dps)
        roots = sorted(mp.re(x) for x in found)
        if beta > 0:
            u1, u2, u3 = roots
            lam_n, m, u_s, sg = mp.sqrt(beta * (u3 - u1)) / 2, (u2 - u1) / (u3 - u1), u1, 1
        elif beta < 0:
            u3, u1, u2 = roots
            lam_n, m, u_s, sg = mp.sqrt(-beta * (u2 - u3)) / 2, (u2 - u1) / (u2 - u3), u2, -1
        else:
            u1, u2 = roots
            lam_n, m, u_s, sg = mp.sqrt(alpha + a * a) / 2, mp.mpf(0), u1, 1
        delta = u2 - u1
        K = mp.ellipk(m)
        sn2 = min(max((u0 - u_s) / (sg * delta), mp.mpf(0)), mp.mpf(1))
        phi0 = mp.asin(mp.sqrt(sn2)) * (1 if udot0 * sg >= 0 else -1)
        w0 = mp.ellipf(phi0, m)

        def pole_integral(side, phi):  # ∫ dw / (1 + side·u) over the amplitude φ = am w
            c0 = 1 + side * u_s
            return mp.ellippi(-side * sg * delta / c0, phi, m) / c0

        sigma0, delta0 = mp.atan2(lam[3], lam[0]), mp.atan2(lam[2], lam[1])
        rows = []
        for t in ts:
            t = mp.mpf(float(t))
            w = lam_n * (t - t0) + w0
            sn, cn, dn = (mp.ellipfun(k, w, m=m) for k in ("sn", "cn", "dn"))
            at = mp.atan2(sn, cn)
            phi = at + 2 * mp.pi * mp.nint((mp.pi * w / (2 * K) - at) / (2 * mp.pi))
            u, udot = u_s + sg * delta * sn**2, sg * 2 * delta * lam_n * sn * cn * dn
            jump_p = s / 2 * (pole_integral(1, phi) - pole_integral(1, phi0)) / lam_n if s else 0
            jump_m = d / 2 * (pole_integral(-1, phi) - pole_integral(-1, phi0)) / lam_n if d else 0
            sig, dlt = sigma0 + nu * (t - t0) + jump_p, delta0 - nu * (t - t0) + jump_m
            ch, sh = mp.sqrt((1 + u) / 2), mp.sqrt((1 - u) / 2)
            # classical form: q + i p = ((b − a u) − i u̇) e^{iφ} / sin θ, φ = σ − δ
            wc = ((b - a * u) - 1j * udot) * mp.expj(sig - dlt) / (2 * ch * sh)
            lam_t = [ch * mp.cos(sig), sh * mp.cos(dlt), sh * mp.sin(dlt), ch * mp.sin(sig)]
            rows.append([*lam_t, mp.im(wc), mp.re(wc), r])
        return rows, float(2 * K / lam_n), float(min(delta, 1 - u2, 1 + u1))


def as_arrays(rows, omega_first=False):
    arr = np.array([[float(x) for x in row] for row in rows])
    return (arr[:, 3:], arr[:, :3]) if omega_first else (arr[:, :4], arr[:, 4:])


def errors(q, w, q_ref, w_ref):
    """(max |Λ − Λ_ref|, max |ω − ω_ref| / max |ω_ref|)."""
    scale = max(np.linalg.norm(w_ref, axis=-1).max(), 1e-300)
    return np.abs(q - q_ref).max(), np.abs(w - w_ref).max() / scale


def check_against_ode(A, C, mgl, omega0, q0, ts, t0=0.0, bound=1e-14):
    q, w = lagrange_top_solution(A, C, mgl, omega0, q0, t0, ts)
    eq, ew = errors(q, w, *as_arrays(taylor_ode(A, C, mgl, omega0, q0, t0, ts), omega_first=True))
    assert eq < bound and ew < bound, (eq, ew)
    return q, w


# -------------------------------------------------------------------------- scenarios ---

A0, C0 = 1.0, 1.5
Q_TILT = quat.from_euler_313(0.2, 0.8, 0.3)


def body_vertical(q0):
    return quat.to_matrix(np.asarray(q0))[2]  # (γ₁, γ₂, u₀)


def omega_with(q0, r, d_offset=0.0, perp=0.3, A=A0, C=C0):
    """ω₀ with spin r and b − a = d_offset (+ rounding): (p, q) = λ(γ₁, γ₂) + μ(γ₂, −γ₁)."""
    g1, g2, u0 = body_vertical(q0)
    g = g1 * g1 + g2 * g2
    along = (C * r / A * (1 - u0) + d_offset) / g
    return np.array([along * g1 + perp * g2, along * g2 - perp * g1, r])


def omega_bottom(q0, r, perp=0.3, A=A0, C=C0):
    """ω₀ with b + a = 0 (+ rounding): the axis passes (near) the downward vertical."""
    g1, g2, u0 = body_vertical(q0)
    g = g1 * g1 + g2 * g2
    along = -C * r / A * (1 + u0) / g
    return np.array([along * g1 + perp * g2, along * g2 - perp * g1, r])


def omega_separatrix(eps, q0=Q_TILT, mgl=0.7, r=0.8, A=A0, C=C0):
    """b = a and p² + q² = β(1 − u₀)(1 + eps): u₂ = 1 and u₃ → 1 as eps → 0 (m → 1)."""
    g1, g2, u0 = body_vertical(q0)
    g = g1 * g1 + g2 * g2
    along = C * r / A * (1 - u0) / g
    perp = math.sqrt((2 * mgl / A * (1 - u0) * (1 + eps) - along**2 * g) / g)
    return np.array([along * g1 + perp * g2, along * g2 - perp * g1, r])


def omega_regular(theta, phi, psi_dot, mgl, A=A0, C=C0):
    """Regular precession: θ̇ = 0 and ü = 0, i.e. a = (u ψ̇² + β/2)/ψ̇."""
    u, beta = math.cos(theta), 2 * mgl / A
    r = A * (u * psi_dot**2 + beta / 2) / psi_dot / C
    return np.array([psi_dot * math.sin(theta) * math.sin(phi), psi_dot * math.sin(theta) * math.cos(phi), r])


# ---------------------------------------------------------------- reference validation ---


@pytest.mark.parametrize(
    ("mgl", "omega0"),
    [(0.7, [0.4, -0.9, 2.1]), (-1.1, [1.3, 0.2, -0.7]), (0.0, [0.5, -0.3, 1.2])],
)
def test_mp_closed_form_matches_taylor_ode(mgl, omega0):
    """The long-span reference agrees with the 30-digit Taylor ODE to 1e-20 over ~1 period."""
    q0, ts = quat.from_euler_313(0.5, 1.1, -0.4), [-1.3, 0.4, 2.0]
    ref, *_ = mp_closed_form(A0, C0, mgl, omega0, q0, 0.1, ts)
    ode = taylor_ode(A0, C0, mgl, omega0, q0, 0.1, ts, dps=30)
    for row, (p, q, r, *lam) in zip(ref, ode):
        assert max(abs(x - y) for x, y in zip(row, [*lam, p, q, r])) < 1e-20


# ------------------------------------------------------------------- random, long span ---

vec = st.floats(-4.0, 4.0, allow_nan=False)


@settings(max_examples=20, deadline=None)
@given(
    A=st.floats(0.3, 3.0),
    c_over_a=st.floats(0.1, 2.0),
    mgl=st.floats(-2.0, 2.0),
    omega0=st.lists(vec, min_size=3, max_size=3),
    q0=st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4),
    t0=st.floats(-5.0, 5.0),
    fractions=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3),
)
def test_random_tops_over_1000_periods(A, c_over_a, mgl, omega0, q0, t0, fractions):
    """Λ and ω within 1e-13 of the 60-digit reference anywhere in ±1000 nutation periods."""
    assume(np.linalg.norm(q0) > 0.1)
    try:
        _, period, closest = mp_closed_form(A, A * c_over_a, mgl, omega0, q0, t0, [], dps=60)
    except (mp.libmp.NoConvergence, ZeroDivisionError):  # degenerate roots: special cases below
        assume(False)
    assume(closest > 1e-20 and period < 1e4)  # Δ → 0 (regular precession), θ → 0, π: tested below
    ts = t0 + 1000.0 * period * np.array([-1.0, -0.5003, 0.0, 1e-3, 0.25, 1.0, *fractions])
    q, w = lagrange_top_solution(A, A * c_over_a, mgl, omega0, q0, t0, ts)
    ref = as_arrays(mp_closed_form(A, A * c_over_a, mgl, omega0, q0, t0, ts, dps=60)[0])
    eq, ew = errors(q, w, *ref)
    assert eq < 1e-13 and ew < 1e-13, (eq, ew)


# ---------------------------------------------------------------- structural properties ---

TOPS = {
    "standing": (1.0, 1.5, 0.7, [0.4, -0.9, 2.1]),
    "hanging": (1.2, 0.6, -1.1, [1.3, 0.2, -0.7]),
    "torque_free": (1.0, 1.5, 0.0, [0.5, -0.3, 1.2]),
}


@pytest.mark.parametrize("name", TOPS)
def test_invariants_and_norm(name):
    """E, L_z, L₃ constant to 1e-14 relative and |Λ| = 1 to 1e-15 over 1000 nutation periods."""
    A, C, mgl, omega0 = TOPS[name]
    _, period, _ = mp_closed_form(A, C, mgl, omega0, Q_TILT, 0.0, [])
    t = np.linspace(-1000 * period, 1000 * period, 20001)
    q, w = lagrange_top_solution(A, C, mgl, omega0, Q_TILT, 0.0, t)
    rot = quat.to_matrix(q)
    l_body = w * np.array([A, A, C])
    energy = 0.5 * np.sum(l_body * w, axis=-1) + mgl * rot[:, 2, 2]
    l_z = np.einsum("nj,nj->n", rot[:, 2, :], l_body)
    scale_e = 0.5 * np.sum(l_body * w, axis=-1).max() + abs(mgl)
    scale_l = np.linalg.norm(l_body, axis=-1).max()
    assert np.ptp(energy) / scale_e < 1e-14
    assert np.ptp(l_z) / scale_l < 1e-14
    assert np.ptp(l_body[:, 2]) == 0.0
    assert np.abs(np.linalg.norm(q, axis=-1) - 1.0).max() < 1e-15


FD_WEIGHTS = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])


@pytest.mark.parametrize("name", TOPS)
def test_finite_differences_satisfy_equations_of_motion(name):
    """8th-order central differences (h = 2e-3): Λ̇ = ½ Λ∘(0, ω) and A ṗ = (A − C) q r + M₁,
    A q̇ = (C − A) r p + M₂, ṙ = 0 at random times within ±1000 periods, to 1e-10 relative."""
    A, C, mgl, omega0 = TOPS[name]
    _, period, _ = mp_closed_form(A, C, mgl, omega0, Q_TILT, 0.0, [])
    centres = np.random.default_rng(7).uniform(-1000 * period, 1000 * period, 12)
    h = 2e-3
    stencil = centres[:, None] + h * np.arange(-4, 5)[None, :]
    q, w = lagrange_top_solution(A, C, mgl, omega0, Q_TILT, 0.0, stencil.ravel())
    q, w = q.reshape(12, 9, 4), w.reshape(12, 9, 3)
    q_dot, w_dot = np.einsum("k,nkj->nj", FD_WEIGHTS, q) / h, np.einsum("k,nkj->nj", FD_WEIGHTS, w) / h
    qc, wc = q[:, 4], w[:, 4]
    kin = q_dot - 0.5 * quat.multiply_array(qc, np.concatenate([np.zeros((12, 1)), wc], axis=-1))
    g = quat.to_matrix(qc)[:, 2, :]
    torque = mgl * np.stack([g[:, 1], -g[:, 0], np.zeros(12)], axis=-1)
    p, qq, r = wc.T
    euler = [A * w_dot[:, 0] - (A - C) * qq * r, A * w_dot[:, 1] - (C - A) * r * p, C * w_dot[:, 2]]
    dyn = np.stack(euler, axis=-1) - torque
    scale = np.linalg.norm(wc, axis=-1).max()
    assert np.abs(kin).max() < 1e-10 * scale
    assert np.abs(dyn).max() < 1e-10 * (max(A, C) * scale**2 + abs(mgl))


@pytest.mark.parametrize("name", ["standing", "hanging"])
def test_nutation_period_is_spacing_of_theta_minima(name):
    """θ is smallest where u̇ = γ₁ q − γ₂ p crosses zero downwards; minima found by bisection
    near t = 0 and 1000 periods later are 2K/λ and 1000·2K/λ apart (1e-13 relative)."""
    A, C, mgl, omega0 = TOPS[name]
    _, period, _ = mp_closed_form(A, C, mgl, omega0, Q_TILT, 0.0, [])

    def udot(t):
        q, w = lagrange_top_solution(A, C, mgl, omega0, Q_TILT, 0.0, np.atleast_1d(t))
        g = quat.to_matrix(q)[:, 2, :]
        return g[:, 0] * w[:, 1] - g[:, 1] * w[:, 0]

    def theta_minima(start, count):
        t = np.linspace(start, start + (count + 0.5) * period, 400 * count)
        v = udot(t)
        found = []
        for i in np.nonzero((v[:-1] > 0) & (v[1:] <= 0))[0]:
            lo, hi = t[i], t[i + 1]
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if udot(mid)[0] > 0 else (lo, mid)
            found.append(0.5 * (lo + hi))
        return np.array(found)

    early, late = theta_minima(0.0, 2), theta_minima(1000 * period, 1)
    assert abs(np.diff(early)[0] / period - 1) < 1e-13
    assert abs((late[0] - early[0]) / (1000 * period) - 1) < 1e-13


# ---------------------------------------------------------------------- special cases ---

TS = np.array([-1.3, -0.4, 0.0, 0.35, 1.1, 2.0])


@pytest.mark.parametrize("mgl", [0.5, 5.0], ids=["stable", "unstable"])
def test_sleeping_top_stays_vertical(mgl):
    """θ₀ = 0, ω₀ = (0, 0, r): Λ = Λ₀ ∘ Λ_z(r t), ω constant, whether C²r² > 4A·mgl (stable)
    or not (the exact solution of an unstable equilibrium stays there), to 1e-15 for |t| ≤ 100."""
    q0, r = quat.from_axis_angle([0, 0, 1], 0.7), 3.0
    t = np.linspace(-100, 100, 101)
    q, w = lagrange_top_solution(A0, C0, mgl, [0, 0, r], q0, 0.0, t)
    spin = np.stack([np.cos(r * t / 2), 0 * t, 0 * t, np.sin(r * t / 2)], axis=-1)
    expected = quat.multiply_array(q0, spin)
    assert np.abs(q - expected).max() < 1e-13
    assert np.abs(w - [0, 0, r]).max() == 0.0


def test_start_at_vertical_with_tilting_rate():
    """θ₀ = 0 exactly with (p, q) ≠ 0: b = a, the band reaches u = 1 and sin(θ/2) is signed; the
    phase at t₀ comes from q₀ + i p₀.  Against the Taylor ODE (1e-14), including a return to θ = 0."""
    q0 = quat.from_axis_angle([0, 0, 1], 0.7)
    for mgl, omega0 in [(0.5, [0.3, -0.2, 3.0]), (5.0, [1e-3, 0.0, 1.0])]:
        check_against_ode(A0, C0, mgl, omega0, q0, TS)


@pytest.mark.parametrize("mgl", [-0.5, 0.5], ids=["hanging", "standing"])
def test_start_at_downward_vertical(mgl):
    """θ₀ = π exactly (b + a = 0, u₁ = −1, cos(θ/2) signed), against the Taylor ODE (1e-14)."""
    check_against_ode(A0, C0, mgl, [0.3, 0.1, 1.0], quat.from_axis_angle([1, 0, 0], math.pi), TS)


def test_regular_precession():
    """θ̇₀ = 0 and ü₀ = 0: u constant to 1e-15 and Λ = Λ_z(ψ₀ + ψ̇t) Λ_x(θ) Λ_z(φ₀ + φ̇t),
    φ̇ = r − ψ̇ cos θ, to 1e-13 over |t| ≤ 100 (the float inputs are regular only to rounding)."""
    theta, phi0, psi0, psi_dot, mgl = 0.8, 0.3, 0.2, 1.3, 0.7
    omega0 = omega_regular(theta, phi0, psi_dot, mgl)
    t = np.linspace(-100, 100, 201)
    q, w = lagrange_top_solution(A0, C0, mgl, omega0, quat.from_euler_313(psi0, theta, phi0), 0.0, t)
    phi_dot = omega0[2] - psi_dot * math.cos(theta)
    expected = np.array([quat.from_euler_313(psi0 + psi_dot * s, theta, phi0 + phi_dot * s) for s in t])
    assert np.ptp(quat.to_matrix(q)[:, 2, 2]) < 1e-15
    assert np.abs(q - expected).max() < 1e-13
    assert np.abs(np.linalg.norm(w, axis=-1) - np.linalg.norm(omega0)).max() < 1e-13


@pytest.mark.parametrize("eps", [1e-12, 1e-8, 1e-4])
def test_near_regular_precession_small_m(eps):
    """A perturbed regular precession (m ~ eps, nutation amplitude ~ eps) against the Taylor ODE."""
    omega0 = omega_regular(0.8, 0.3, 1.3, 0.7) + [eps, 0.0, 0.0]
    check_against_ode(A0, C0, 0.7, omega0, quat.from_euler_313(0.2, 0.8, 0.3), TS)


def test_exact_regular_precession_at_horizontal():
    """θ₀ = π/2 exactly, θ̇₀ = 0 (Δ ~ 1e-40): against the Taylor ODE (1e-14)."""
    check_against_ode(1.0, 1.0, 1.0, [0.0, 1.0, 1.0], np.array([1.0, 1.0, 0.0, 0.0]) / math.sqrt(2), TS)


@pytest.mark.parametrize("omega0", [[0.0, 0.9, 2.0], [0.0, 2.5, 0.4]], ids=["upper", "lower"])
def test_start_at_turning_point(omega0):
    """u̇₀ = 0 exactly (Λ₀ about e₁, p₀ = 0), at the upper or the lower edge of the band."""
    check_against_ode(A0, C0, 0.7, omega0, quat.from_axis_angle([1, 0, 0], 0.8), TS)


@pytest.mark.parametrize("d_offset", [0.0, 1e-10, 1e-6], ids=["rounding", "1e-10", "1e-6"])
def test_axis_passing_near_upward_vertical(d_offset):
    """b − a small: the axis passes within ~|b − a| of θ = 0, ψ swings by π in a very short time.
    Against the Taylor ODE across the passage (1e-14), against the 90-digit reference over 1000
    periods (1e-12), and continuous on a fine grid through the passage."""
    omega0 = omega_with(Q_TILT, 2.0, d_offset)
    check_against_ode(A0, C0, 0.7, omega0, Q_TILT, np.linspace(-1.5, 2.0, 5))
    _, period, _ = mp_closed_form(A0, C0, 0.7, omega0, Q_TILT, 0.0, [], dps=90)
    ts = period * np.array([-1000.0, -333.3, 0.4, 777.7, 1000.0])
    ref = as_arrays(mp_closed_form(A0, C0, 0.7, omega0, Q_TILT, 0.0, ts, dps=90)[0])
    eq, ew = errors(*lagrange_top_solution(A0, C0, 0.7, omega0, Q_TILT, 0.0, ts), *ref)
    assert eq < 1e-12 and ew < 1e-12, (eq, ew)
    t = np.linspace(0, 2 * period, 20001)
    q, w = lagrange_top_solution(A0, C0, 0.7, omega0, Q_TILT, 0.0, t)
    step = np.linalg.norm(np.diff(q, axis=0), axis=-1)
    assert step.max() <= 0.5 * np.linalg.norm(w, axis=-1).max() * (t[1] - t[0]) * (1 + 1e-6)


@pytest.mark.parametrize("mgl", [-0.7, 0.3], ids=["hanging", "standing"])
def test_axis_passing_downward_vertical(mgl):
    """b + a ≈ 0: u₁ ≈ −1 (cos(θ/2) side), against the Taylor ODE (1e-14)."""
    check_against_ode(A0, C0, mgl, omega_bottom(Q_TILT, 2.0), Q_TILT, np.linspace(-1.5, 2.0, 5))


@pytest.mark.parametrize("eps", [1e-10, 0.0], ids=["1e-10", "rounding"])
def test_near_separatrix_m_close_to_one(eps):
    """u₂ = 1 = u₃ up to eps (1 − m ~ 1e-11 … 1e-15, θ_min ~ 1e-15): Taylor ODE over a passage
    (1e-14) and the 90-digit reference over 1000 periods (1e-12)."""
    omega0 = omega_separatrix(eps)
    check_against_ode(A0, C0, 0.7, omega0, Q_TILT, np.array([-3.0, 0.0, 1.0, 2.5]))
    _, period, _ = mp_closed_form(A0, C0, 0.7, omega0, Q_TILT, 0.0, [], dps=90)
    ts = period * np.array([-1000.0, -1.5, 499.9, 1000.0])
    ref = as_arrays(mp_closed_form(A0, C0, 0.7, omega0, Q_TILT, 0.0, ts, dps=90)[0])
    eq, ew = errors(*lagrange_top_solution(A0, C0, 0.7, omega0, Q_TILT, 0.0, ts), *ref)
    assert eq < 1e-12 and ew < 1e-12, (eq, ew)


@pytest.mark.parametrize(("C", "omega0"), [(1.5, [0.05, -0.03, 200.0]), (1.9, [0.3, 0.1, 1e3])])
def test_fast_top_transverse_rate(C, omega0):
    """C r ≫ A |ω⊥|: (p, q) to 1e-13 of |ω⊥| itself (not only of |ω|) over ±1000 periods against
    the 60-digit reference — the velocity factor avoids the O(a) cancellation of b − a u."""
    _, period, _ = mp_closed_form(A0, C, 0.7, omega0, Q_TILT, 0.0, [], dps=60)
    ts = period * np.array([-1000.0, -1.3, 0.2, 2.7, 999.9])
    q, w = lagrange_top_solution(A0, C, 0.7, omega0, Q_TILT, 0.0, ts)
    q_ref, w_ref = as_arrays(mp_closed_form(A0, C, 0.7, omega0, Q_TILT, 0.0, ts, dps=60)[0])
    assert np.abs(q - q_ref).max() < 1e-14
    assert np.abs(w[:, :2] - w_ref[:, :2]).max() < 1e-13 * np.linalg.norm(w_ref[:, :2], axis=-1).max()


def test_torque_free_limit():
    """mgl = 0 (m = 0) equals the axisymmetric free body: q + i p ∝ e^{−iΩt}, Ω = (C − A) r/A,
    Λ = Λ(l̂, |L| t/A) ∘ Λ₀ ∘ Λ(e₃, −Ω t); to 1e-14 for |t| ≤ 50."""
    omega0, t = np.array([0.5, -0.3, 1.2]), np.linspace(-50, 50, 41)
    q, w = lagrange_top_solution(A0, C0, 0.0, omega0, Q_TILT, 0.0, t)
    big_omega = (C0 - A0) * omega0[2] / A0
    spin = (omega0[0] + 1j * omega0[1]) * np.exp(1j * big_omega * t)
    l_body = omega0 * [A0, A0, C0]
    l_space = quat.rotate_to_space_array(Q_TILT, l_body)
    turn = np.array([quat.from_axis_angle(l_space, np.linalg.norm(l_body) * s / A0) for s in t])
    back = np.array([quat.from_axis_angle([0, 0, 1], -big_omega * s) for s in t])
    expected = quat.multiply_array(quat.multiply_array(turn, np.broadcast_to(Q_TILT, (len(t), 4))), back)
    assert np.abs(q - expected).max() < 1e-14
    assert np.abs(w - np.stack([spin.real, spin.imag, 0 * t + omega0[2]], axis=-1)).max() < 1e-14


def test_mirror_symmetry_hanging_standing():
    """Turning the body axis over (Λ → Λ ∘ Λ_x(π), ω → (p, −q, −r), mgl → −mgl) is the same motion:
    the hanging-top branch (β < 0) reproduces the standing one to 1e-14 over 100 periods."""
    flip = np.array([0.0, 1.0, 0.0, 0.0])
    omega0, t = np.array([0.4, -0.9, 2.1]), np.linspace(-300, 300, 61)
    q, w = lagrange_top_solution(A0, C0, 0.7, omega0, Q_TILT, 0.0, t)
    q_flip = quat.multiply_array(Q_TILT, flip)
    qm, wm = lagrange_top_solution(A0, C0, -0.7, omega0 * [1, -1, -1], q_flip, 0.0, t)
    assert np.abs(qm - quat.multiply_array(q, flip)).max() < 1e-14
    assert np.abs(wm - w * [1, -1, -1]).max() < 1e-14


def test_sample_conventions():
    """Any order of t, t < t₀, a non-unit Λ₀ (normalised), t = t₀ returns the initial state."""
    omega0, t0 = np.array([0.4, -0.9, 2.1]), 3.0
    t = np.array([5.0, -2.0, t0, 4.0, 1.0])
    q, w = lagrange_top_solution(A0, C0, 0.7, omega0, 2.0 * Q_TILT, t0, t)
    order = np.argsort(t)
    qs, ws = lagrange_top_solution(A0, C0, 0.7, omega0, Q_TILT, t0, t[order])
    assert np.abs(q[order] - qs).max() < 1e-15 and np.abs(w[order] - ws).max() < 1e-15
    assert np.abs(q[2] - Q_TILT).max() < 1e-15
    assert np.abs(w[2] - omega0).max() < 2e-15 * np.linalg.norm(omega0)
    with pytest.raises(ValueError):
        lagrange_top_solution(0.0, C0, 0.7, omega0, Q_TILT, t0, t)


wide = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


@settings(max_examples=40, deadline=None)
@example(A=1.0, C=1.0, mgl=-1.0, omega0=[1.0, 0.0, 0.0], q0=[0.0, 0.001953125, 0.0, 1.7296216587159435e-28], t=[0.0])
@given(
    A=st.floats(1e-3, 1e3),
    C=st.floats(1e-3, 1e3),
    mgl=wide,
    omega0=st.lists(wide, min_size=3, max_size=3),
    q0=st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4),
    t=st.lists(wide, min_size=1, max_size=4),
)
def test_any_input_gives_a_finite_unit_solution(A, C, mgl, omega0, q0, t):
    """Tiny, subnormal, zero and large inputs alike: finite output, | |Λ| − 1 | ≤ 2e-16, r exactly
    constant, and the initial state returned at t = t₀: Λ to 1e-15, ω to 1e-14 of the motion's rate
    scale |ω₀| + √|β| (the documented floors Δ, e ≥ 1e-50 and 1 − m ≥ 1e-150 move the state by
    ≲ 1e-25 of that scale)."""
    assume(np.linalg.norm(q0) > 1e-3)
    q, w = lagrange_top_solution(A, C, mgl, omega0, q0, 0.0, np.array([0.0, *t]))
    assert np.isfinite(q).all() and np.isfinite(w).all()
    assert np.abs(np.linalg.norm(q, axis=-1) - 1.0).max() <= 2.3e-16
    assert np.all(w[:, 2] == omega0[2])
    assert np.abs(q[0] - np.asarray(q0) / np.linalg.norm(q0)).max() < 1e-15
    assert np.abs(w[0] - omega0).max() <= 1e-14 * (np.abs(omega0).max() + math.sqrt(2 * abs(mgl) / A))


def test_extreme_magnitudes_against_ode():
    """A swing through both verticals with b ∓ a ~ 3e-152 and p₀ = 0, q₀ ~ 3e-152 (all set-up
    quantities far outside float range are handled in decimal): against the Taylor ODE (1e-14)."""
    q0 = [-0.32046270014277567, 0.25, 0.7324362217747717, -0.8356313485471913]
    omega0 = [0.0, 3.175544195522085e-152, 0.0]
    check_against_ode(27.72, 23.56, 8.07, omega0, np.asarray(q0) / np.linalg.norm(q0), TS)


@pytest.mark.parametrize("m", [0.0, 1e-10, 0.3, 0.5, 0.5 + 1e-9, 0.9, 1 - 1e-6, 1 - 1e-12, "1-1e-60"])
def test_jacobi_theta_series_relative_accuracy(m):
    """The private sn, cn, dn (theta series at |y| ≤ K/2 plus quarter-period shifts) keep ≤ 8 ulp
    relative accuracy, near their zeros and for m → 1 too (scipy's ellipj loses ~1e-4 relative in
    cn, dn at m = 1 − 1e-12)."""
    from decimal import Decimal, localcontext

    from rotlab.core.exact import lagrange as impl

    with mp.workdps(120):
        mc = mp.mpf("1e-60") if m == "1-1e-60" else 1 - mp.mpf(m)
        m_mp = 1 - mc
        with localcontext() as ctx:
            ctx.prec = 40
            K = float(impl._complete_k(Decimal(str(mc))))
        mod = impl._Modulus.of(float(m_mp), float(mc), K)
        rng = np.random.default_rng(3)
        y = np.concatenate([rng.uniform(-K / 2, K / 2, 30), [1e-9, -K / 2, K / 2]])
        n = rng.integers(-9, 10, len(y))
        base, shifted = impl._jacobi(n, y, mod)
        k_true = mp.ellipk(m_mp)
        for i, yi in enumerate(y):
            for name, b, s in zip(("sn", "cn", "dn"), base, shifted):
                for point, value in ((mp.mpf(yi), b[i]), (mp.mpf(yi) + n[i] * k_true, s[i])):
                    ref = mp.ellipfun(name, point, m=m_mp)
                    assert abs(value - ref) <= 8 * 2.2e-16 * abs(ref), (name, yi, n[i])
