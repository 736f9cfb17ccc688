"""Tests of rotlab.core.exact.torque_free against 40-digit mpmath references.

References
----------
* ``MpReference``: a high-precision closed form written independently of the module (Landau–Lifshitz
  form: frame (cn axis, middle, dn axis), polar axis = dn axis, 3-1-3 angles (φ, θ, ψ), mpmath's own
  ellipfun / ellipf / ellippi with their quasi-periodicity, no argument reduction of its own; on the
  separatrix tanh/sech and mpmath.quad for the precession integral).
* ``ode_reference``: the 7-dim ODE (Euler + Poisson) integrated with mpmath.odefun (Taylor) at 30
  digits.  ``test_reference_matches_ode`` validates ``MpReference`` against it, so the long-span tests
  do not rely on the formula alone.

Error measures: |ω − ω_ref| / |ω_ref| and |Λ − Λ_ref| (Λ unit), maximum over the samples.
"""

from __future__ import annotations

import functools
from fractions import Fraction

import mpmath as mp
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from rotlab.core.exact.torque_free import torque_free_solution
from rotlab.core.quaternion import conjugate_array, from_matrix, multiply_array, rotate_to_space_array

DPS = 40
HYPOTHESIS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# ============================================================== mpmath references
def _mp_qmul(a, b):
    return [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] + a[2] * b[0] + a[3] * b[1] - a[1] * b[3],
        a[0] * b[3] + a[3] * b[0] + a[1] * b[2] - a[2] * b[1],
    ]


def _mp_axis_q(axis, angle):
    q = [mp.cos(angle / 2), mp.mpf(0), mp.mpf(0), mp.mpf(0)]
    q[1 + axis] = mp.sin(angle / 2)
    return q


def _mp_conj(q):
    return [q[0], -q[1], -q[2], -q[3]]


def _mp_from_matrix(r):
    """Unit quaternion of a rotation matrix (entries exact in mp), Shepperd's largest-pivot choice."""
    r = [[mp.mpf(float(x)) for x in row] for row in r]
    trace = r[0][0] + r[1][1] + r[2][2]
    k = max(range(4), key=lambda i: [trace, r[0][0], r[1][1], r[2][2]][i])
    if k == 0:
        s = 2 * mp.sqrt(1 + trace)
        return [s / 4, (r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s]
    i, j, l = k - 1, k % 3, (k + 1) % 3
    s = 2 * mp.sqrt(1 + r[i][i] - r[j][j] - r[l][l])
    q = [(r[l][j] - r[j][l]) / s, 0, 0, 0]
    q[1 + i], q[1 + j], q[1 + l] = s / 4, (r[j][i] + r[i][j]) / s, (r[l][i] + r[i][l]) / s
    return q


def _mp(x: Fraction):
    return mp.mpf(x.numerator) / x.denominator


class MpReference:
    """40-digit Euler–Poinsot solution for an asymmetric or axisymmetric body (not for permanent rotations).

    Frame H = (h1, h2, h3) = (cn axis, middle, dn axis), made right-handed by flipping h2 if needed;
    K1, K2, K3 its moments, T2 = 2T, M = |L|.  Landau–Lifshitz §37:
        ω = (s1 a1 cn v, s2 a2 sn v, s3 a3 dn v),  v = λ (t − t0) + v0,
        a1² = (T2 K3 − M²)/(K1 (K3 − K1)),  a2² = (T2 K3 − M²)/(K2 (K3 − K2)),  a3² = (M² − T2 K1)/(K3 (K3 − K1)),
        λ² = (K3 − K2)(M² − T2 K1)/(K1 K2 K3),  m = (K2 − K1)(T2 K3 − M²)/((K3 − K2)(M² − T2 K1)),
    s3 = sgn ω3(t0), s1 = +1 (separatrix: sgn ω1(t0)), s2 from K2 ω̇2 = (K3 − K1) ω3 ω1.
    Attitude Λ = C ∘ Λ_z(φ) ∘ Λ_x(θ) ∘ Λ_z(ψ) ∘ Λ_P with ℓ = (sin θ sin ψ, sin θ cos ψ, cos θ) and
        φ̇ = M (K1 ω1² + K2 ω2²)/(K1² ω1² + K2² ω2²) = M/K3 + M (T2 K3 − M²) / (K3 K1² a1² (1 − n' sn² v)),
        n' = −K3² a3² m / (K1² a1²).
    """

    def __init__(self, moments, omega0, q0, t0, dps=DPS):
        self.dps = dps
        inertia = [Fraction(float(x)) for x in moments]
        w = [Fraction(float(x)) for x in omega0]
        t2 = sum(i * x * x for i, x in zip(inertia, w))
        l2 = sum(i * i * x * x for i, x in zip(inertia, w))
        small, mid, large = sorted(range(3), key=lambda i: inertia[i])
        dist = l2 - t2 * inertia[mid]
        h = (small, mid, large) if dist >= 0 else (large, mid, small)
        parity = 1 if h in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1
        signs = (1, parity, 1)
        self.perm = np.zeros((3, 3))
        for a in range(3):
            self.perm[a, h[a]] = signs[a]
        k1, k2, k3 = (inertia[i] for i in h)
        wh = [signs[a] * w[h[a]] for a in range(3)]
        self.separatrix = dist == 0
        with mp.workdps(dps):
            self.t0 = mp.mpf(float(t0))
            self.k = [_mp(k1), _mp(k2), _mp(k3)]
            self.big_m = mp.sqrt(_mp(l2))
            self.a = [
                mp.sqrt(_mp((t2 * k3 - l2) / (k1 * (k3 - k1)))),
                mp.sqrt(_mp((t2 * k3 - l2) / (k2 * (k3 - k2)))),
                mp.sqrt(_mp((l2 - t2 * k1) / (k3 * (k3 - k1)))),
            ]
            self.lam = mp.sqrt(_mp((k3 - k2) * (l2 - t2 * k1) / (k1 * k2 * k3)))
            self.m = mp.mpf(1) if self.separatrix else _mp((k2 - k1) * (t2 * k3 - l2) / ((k3 - k2) * (l2 - t2 * k1)))
            self.s3 = 1 if wh[2] > 0 else -1
            self.s1 = (1 if wh[0] > 0 else -1) if self.separatrix else 1
            self.s2 = (1 if k3 > k1 else -1) * self.s3 * self.s1
            sn0 = _mp(wh[1]) / (self.s2 * self.a[1])
            sn0 = max(min(sn0, mp.mpf(1)), mp.mpf(-1))
            cn0 = _mp(wh[0]) / (self.s1 * self.a[0])
            if self.separatrix:
                self.v0 = mp.atanh(sn0)
            else:
                self.kk = mp.ellipk(self.m)
                self.v0 = mp.ellipf(mp.atan2(sn0, cn0), self.m)
            self.n = -((self.k[2] * self.a[2]) ** 2) * self.m / (self.k[0] * self.a[0]) ** 2
            self.coef = self.big_m * _mp(t2 * k3 - l2) / (self.k[2] * (self.k[0] * self.a[0]) ** 2 * self.lam)
            self.q_perm = _mp_from_matrix(self.perm)
            q0m = [mp.mpf(float(x)) for x in q0]
            norm = mp.sqrt(sum(x * x for x in q0m))
            self.third0 = self._angles(self.t0)[2]
            q_h0 = self.attitude_h(self.t0)[0]
            self.c = _mp_qmul(_mp_qmul([x / norm for x in q0m], _mp_conj(self.q_perm)), _mp_conj(q_h0))

    def _jacobi(self, v):
        if self.separatrix:
            return mp.tanh(v), mp.sech(v), mp.sech(v)
        return mp.ellipfun("sn", v, m=self.m), mp.ellipfun("cn", v, m=self.m), mp.ellipfun("dn", v, m=self.m)

    def _third_kind(self, v, am):
        """∫_0^v dv' / (1 − n' sn² v')."""
        if not self.separatrix:
            return mp.ellippi(self.n, am, self.m)
        cap = mp.mpf(40)  # beyond, tanh² = 1 − O(e^{−80})
        clipped = max(min(v, cap), -cap)
        integrand = lambda x: 1 / (1 - self.n * mp.tanh(x) ** 2)  # noqa: E731
        return mp.quad(integrand, [0, clipped]) + (v - clipped) / (1 - self.n)

    def _angles(self, t):
        """(θ, ψ, ∫_0^v dv'/(1 − n' sn²), ω_H) at time t; ψ continuous (follows am v)."""
        v = self.lam * (t - self.t0) + self.v0
        sn, cn, dn = self._jacobi(v)
        omega = [self.s1 * self.a[0] * cn, self.s2 * self.a[1] * sn, self.s3 * self.a[2] * dn]
        ell = [self.k[i] * omega[i] / self.big_m for i in range(3)]
        am = mp.atan2(sn, cn)
        if not self.separatrix:
            am += 2 * mp.pi * mp.nint((mp.pi * v / (2 * self.kk) - am) / (2 * mp.pi))
        psi = mp.atan2(ell[0], ell[1])
        psi_lin = self.s1 * mp.pi / 2 - self.s1 * self.s2 * am  # same quadrant as ψ, continuous
        psi += 2 * mp.pi * mp.nint((psi_lin - psi) / (2 * mp.pi))
        return mp.acos(ell[2]), psi, self._third_kind(v, am), omega

    def attitude_h(self, t):
        """(Λ_z(φ) ∘ Λ_x(θ) ∘ Λ_z(ψ), ω_H) at mp time t."""
        theta, psi, third, omega = self._angles(t)
        phi = self.big_m / self.k[2] * (t - self.t0) + self.coef * (third - self.third0)
        return _mp_qmul(_mp_qmul(_mp_axis_q(2, phi), _mp_axis_q(0, theta)), _mp_axis_q(2, psi)), omega

    def state(self, t):
        """(Λ, ω) in the caller's frame as mp lists at mp time t."""
        q_h, w_h = self.attitude_h(t)
        q = _mp_qmul(_mp_qmul(self.c, q_h), self.q_perm)
        return q, [sum(self.perm[a, i] * w_h[a] for a in range(3)) for i in range(3)]

    def __call__(self, times):
        """(q (N, 4), ω (N, 3)) as float arrays."""
        with mp.workdps(self.dps):
            states = [self.state(mp.mpf(float(t))) for t in np.ravel(times)]
        to_float = lambda rows: np.array([[float(x) for x in row] for row in rows])  # noqa: E731
        return to_float(q for q, _ in states), to_float(w for _, w in states)

    @property
    def period(self) -> float:
        """Period of ω (4K/λ); 2π/|ω|-scale rotation time on the separatrix."""
        with mp.workdps(self.dps):
            if self.separatrix:
                return float(2 * mp.pi * self.k[1] / self.big_m)
            return float(4 * self.kk / self.lam)


@functools.lru_cache(maxsize=None)
def ode_reference(moments, omega0, q0, t0, times, dps=30):
    """mpmath.odefun (Taylor) solution of Euler + Λ̇ = ½ Λ ∘ (0, ω) at times ≥ t0: list of mp (Λ, ω)."""
    with mp.workdps(dps):
        a, b, c = (mp.mpf(x) for x in moments)

        def rhs(_, y):
            p, q, r = y[:3]
            dq = _mp_qmul(y[3:], [0, p, q, r])
            return [(b - c) / a * q * r, (c - a) / b * r * p, (a - b) / c * p * q] + [x / 2 for x in dq]

        lam0 = [mp.mpf(x) for x in q0]
        norm = mp.sqrt(sum(x * x for x in lam0))
        sol = mp.odefun(rhs, mp.mpf(t0), [mp.mpf(x) for x in omega0] + [x / norm for x in lam0])
        return [(y[3:], y[:3]) for y in (sol(mp.mpf(t)) for t in times)]


def _errors(q, omega, q_ref, omega_ref):
    e_w = np.max(np.linalg.norm(omega - omega_ref, axis=-1) / np.linalg.norm(omega_ref, axis=-1))
    e_q = np.max(np.linalg.norm(q - q_ref, axis=-1))
    return e_w, e_q


def _unit(q):
    q = np.asarray(q, dtype=float)
    return q / np.linalg.norm(q)


# ============================================================== input generation
def _on_separatrix_offset(inertia, omega_small_mid, eps, order):
    """ω0 in caller order with (L² − 2T I_mid) = eps · I_s (I_mid − I_s) ω_s² (sorted axes s, mid, lg)."""
    i_s, i_m, i_l = np.sort(inertia)
    w_s, w_m, sign_l = omega_small_mid
    w_l = sign_l * np.sqrt(i_s * (i_m - i_s) * w_s**2 * (1.0 + eps) / (i_l * (i_l - i_m)))
    sorted_omega = np.array([w_s, w_m, w_l])
    omega = np.empty(3)
    omega[order] = sorted_omega
    return omega


@st.composite
def bodies(draw, eps_strategy):
    """Asymmetric body (moments in random order), ω0 at a chosen relative separatrix offset, random Λ0."""
    moments = np.sort(draw(st.lists(st.floats(0.5, 4.0), min_size=3, max_size=3)))
    gaps = np.diff(moments)
    if np.min(gaps) < 0.05 * moments[-1]:
        moments = moments[0] + np.array([0.0, 0.4, 1.0]) * (0.5 + moments[-1] - moments[0])
    order = np.array(draw(st.permutations([0, 1, 2])))
    inertia = np.empty(3)
    inertia[order] = moments
    w_s = draw(st.floats(0.2, 2.0)) * draw(st.sampled_from([-1.0, 1.0]))
    w_m = draw(st.floats(-2.0, 2.0))
    sign_l = draw(st.sampled_from([-1.0, 1.0]))
    eps = draw(eps_strategy)
    omega = _on_separatrix_offset(moments, (w_s, w_m, sign_l), eps, order)
    q0 = _unit(draw(st.lists(st.floats(-1.0, 1.0), min_size=4, max_size=4)) + np.array([1e-3, 0, 0, 0]))
    t0 = draw(st.floats(-10.0, 10.0))
    return inertia, omega, q0, t0


def _signed_log(lo, hi):
    return st.tuples(st.sampled_from([-1.0, 1.0]), st.floats(lo, hi)).map(lambda x: x[0] * 10.0 ** x[1])


GENERIC = _signed_log(-3.0, 0.0).map(lambda e: max(e, -0.95))
NEAR = _signed_log(-6.5, -5.5)


def _long_span_times(rng_seed, t0, period, n=12):
    rng = np.random.default_rng(rng_seed)
    span = 1000.0 * period
    return t0 + np.concatenate([[span, -span], rng.uniform(-span, span, n - 2)])


def _check_long_span(inertia, omega, q0, t0, bound=1e-12):
    ref = MpReference(inertia, omega, q0, t0)
    t = _long_span_times(abs(hash((tuple(inertia), t0))) % 2**32, t0, ref.period)
    q, w = torque_free_solution(inertia, omega, q0, t0, t)
    e_w, e_q = _errors(q, w, *ref(t))
    assert e_w < bound and e_q < bound, (e_w, e_q, ref.m)
    return e_w, e_q


# ============================================================== reference validation
ODE_CASES = {
    # name: (moments, omega0, q0, t0, span)
    "largest-axis side": ((1.0, 2.0, 3.0), (0.4, 0.9, 1.1), (0.9, 0.1, -0.3, 0.2), 0.5, 6.0),
    "smallest-axis side, permuted": ((3.0, 1.0, 2.0), (0.3, 1.4, 0.7), (0.5, 0.5, -0.5, 0.5), 0.0, 8.0),
    "near separatrix 1e-6": (
        (2.0, 1.0, 3.5),
        tuple(_on_separatrix_offset(np.array([2.0, 1.0, 3.5]), (0.8, 0.05, 1.0), 1e-6, np.array([1, 0, 2]))),
        (1.0, 0.0, 0.0, 0.0),
        0.0,
        9.0,
    ),
    "separatrix exact": ((6.0, 3.0, 2.0), (0.25, 0.7, 0.75), (0.3, -0.2, 0.9, 0.1), 1.0, 6.0),
    "axisymmetric": ((2.0, 1.0, 2.0), (0.5, 0.6, -0.4), (0.6, 0.0, 0.8, 0.0), 0.0, 11.0),
}


def _ode_case(name):
    moments, omega0, q0, t0, span = ODE_CASES[name]
    q0 = tuple(_unit(q0))
    times = tuple(t0 + span * np.array([0.0, 0.13, 0.5, 0.77, 1.0]))
    return moments, omega0, q0, t0, times


@pytest.mark.parametrize("name", list(ODE_CASES))
def test_reference_matches_ode(name):
    """MpReference (40 digits) vs mpmath.odefun (30 digits) over ~1 period of ω: |ΔΛ|, |Δω| < 1e-25."""
    moments, omega0, q0, t0, times = _ode_case(name)
    ref = MpReference(moments, omega0, q0, t0)
    with mp.workdps(DPS):
        for t, (q_ode, w_ode) in zip(times, ode_reference(moments, omega0, q0, t0, times)):
            q, w = ref.state(mp.mpf(t))
            assert max(abs(x - y) for x, y in zip(q + w, list(q_ode) + list(w_ode))) < 1e-25


@pytest.mark.parametrize("name", list(ODE_CASES))
def test_module_matches_ode(name):
    """Module vs mpmath.odefun over ~1 period of ω: |Δω|/|ω|, |ΔΛ| < 5e-15."""
    moments, omega0, q0, t0, times = _ode_case(name)
    ode = ode_reference(moments, omega0, q0, t0, times)
    q_ode = np.array([[float(x) for x in q] for q, _ in ode])
    w_ode = np.array([[float(x) for x in w] for _, w in ode])
    q, w = torque_free_solution(moments, omega0, q0, t0, np.array(times))
    e_w, e_q = _errors(q, w, q_ode, w_ode)
    assert e_w < 5e-15 and e_q < 5e-15, (e_w, e_q)


# ============================================================== long spans (1000 periods of ω)
@HYPOTHESIS
@given(bodies(GENERIC))
def test_long_span_generic(case):
    """Both sides of the separatrix, |L² − 2T I_mid| ≥ 1e-3 · scale: errors < 1e-12 over ±1000 periods."""
    _check_long_span(*case)


@HYPOTHESIS
@given(bodies(NEAR))
def test_long_span_near_separatrix(case):
    """|L² − 2T I_mid| ≈ 1e-6 (relative), both sides: errors < 1e-12 over ±1000 periods."""
    _check_long_span(*case)


@HYPOTHESIS
@given(bodies(st.just(0.0)))
def test_long_span_on_separatrix_rounded(case):
    """ω0 on the separatrix up to float rounding (m1 ~ 1e-16 or exactly 0): errors < 1e-12."""
    _check_long_span(*case)


@pytest.mark.parametrize("order", [(0, 1, 2), (2, 0, 1), (1, 0, 2)])
@pytest.mark.parametrize("base", [((2.0, 3.0, 6.0), 3.0), ((3.0, 4.0, 6.0), 2.0)])
@pytest.mark.parametrize("signs", [(1, 1, 1), (-1, 1, 1), (1, -1, -1)])
def test_exact_separatrix(base, order, signs):
    """L² = 2T I_mid exactly (I_l (I_l − I_m) / (I_s (I_m − I_s)) = k², ω_s = k ω_l): errors < 1e-12
    over ±1000 rotation times 2π I_mid/|L|; ω tends to ±the middle axis."""
    (moments, k) = base
    w_l = 0.3125
    sorted_omega = np.array([signs[0] * k * w_l, signs[1] * 0.8, signs[2] * w_l])
    inertia, omega = np.empty(3), np.empty(3)
    inertia[list(order)] = moments
    omega[list(order)] = sorted_omega
    ref = MpReference(inertia, omega, _unit([0.2, 0.3, -0.4, 0.8]), 0.5)
    assert ref.separatrix
    _check_long_span(inertia, omega, _unit([0.2, 0.3, -0.4, 0.8]), 0.5)
    _, w = torque_free_solution(inertia, omega, [1, 0, 0, 0], 0.5, np.array([500.0]))
    mid = order[1]
    assert abs(abs(w[0, mid]) - np.linalg.norm(w[0])) < 1e-12


# ============================================================== invariants and the differential equations
@HYPOTHESIS
@given(bodies(st.one_of(GENERIC, NEAR, st.just(0.0))))
def test_invariants(case):
    """2T and |L| constant to 1e-14 (relative), L_space constant to 1e-13 |L|, |Λ| = 1 to 1e-15, over ±1000 periods."""
    inertia, omega0, q0, t0 = case
    t = t0 + np.linspace(-1.0, 1.0, 2001) * 1000.0 * MpReference(inertia, omega0, q0, t0).period
    q, w = torque_free_solution(inertia, omega0, q0, t0, t)
    t2_0, l_0 = omega0 @ (inertia * omega0), np.linalg.norm(inertia * omega0)
    l_space0 = rotate_to_space_array(q0, inertia * omega0)
    assert np.max(np.abs(np.sum(inertia * w * w, axis=-1) / t2_0 - 1.0)) < 1e-14
    assert np.max(np.abs(np.linalg.norm(inertia * w, axis=-1) / l_0 - 1.0)) < 1e-14
    assert np.max(np.linalg.norm(rotate_to_space_array(q, inertia * w) - l_space0, axis=-1)) < 1e-13 * l_0
    assert np.max(np.abs(np.linalg.norm(q, axis=-1) - 1.0)) < 1e-15


def _five_point_derivative(f, t, h):
    """4th-order central difference; t, h chosen so that t ± k h are exact floats."""
    return (f(t - 2 * h) - 8 * f(t - h) + 8 * f(t + h) - f(t + 2 * h)) / (12 * h)


@HYPOTHESIS
@given(bodies(st.one_of(GENERIC, NEAR)), st.integers(0, 2**32 - 1))
def test_differential_equations(case, seed):
    """At random points within ±100 periods: Λ̇ = ½ Λ ∘ (0, ω) and Euler's equations hold with
    residual < 1e-10 |ω|² (5-point differences, h = 2⁻⁸/|ω|: truncation ~h⁴|ω|⁵/30, rounding ~ε/h)."""
    inertia, omega0, q0, t0 = case
    scale = np.linalg.norm(omega0)
    h = 2.0 ** (np.floor(np.log2(1.0 / scale)) - 8)
    rng = np.random.default_rng(seed)
    period = MpReference(inertia, omega0, q0, t0).period
    t = np.round((t0 + rng.uniform(-100, 100, 8) * period) / h) * h
    q_of = lambda s: torque_free_solution(inertia, omega0, q0, t0, s)[0]  # noqa: E731
    w_of = lambda s: torque_free_solution(inertia, omega0, q0, t0, s)[1]  # noqa: E731
    q, w = torque_free_solution(inertia, omega0, q0, t0, t)
    dq = _five_point_derivative(q_of, t, h)
    dw = _five_point_derivative(w_of, t, h)
    kin = dq - 0.5 * multiply_array(q, np.concatenate([np.zeros((len(t), 1)), w], axis=-1))
    a, b, c = inertia
    p, qq, r = w.T
    euler = inertia * dw - np.stack([(b - c) * qq * r, (c - a) * r * p, (a - b) * p * qq], axis=-1)
    assert np.max(np.abs(kin)) < 1e-10 * scale
    assert np.max(np.abs(euler)) < 1e-10 * scale**2 * np.max(inertia)


# ============================================================== special cases
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_axisymmetric_precession(axis):
    """Two equal moments (symmetry axis k, axial C, transverse A): ω_k constant and ω_⊥ rotates about e_k at
    Ω = (C − A) ω_k / A, |Δω| < 1e-13 |ω| for |t − t0| ≤ 50; Λ vs MpReference < 1e-12 over ±1000 periods."""
    inertia = np.full(3, 1.5)
    inertia[axis] = 4.0
    omega0 = np.array([0.3, -0.7, 0.9])
    q0 = _unit([0.1, 0.7, -0.2, 0.4])
    t = np.linspace(-50.0, 50.0, 201)
    _, w = torque_free_solution(inertia, omega0, q0, 0.0, t)
    big_omega = (4.0 - 1.5) * omega0[axis] / 1.5
    i, j = (axis + 1) % 3, (axis + 2) % 3
    c, s = np.cos(big_omega * t), np.sin(big_omega * t)
    expected = np.empty((t.size, 3))
    expected[:, axis] = omega0[axis]
    expected[:, i] = c * omega0[i] - s * omega0[j]
    expected[:, j] = s * omega0[i] + c * omega0[j]
    assert np.max(np.abs(w - expected)) < 1e-13 * np.linalg.norm(omega0)
    _check_long_span(inertia, omega0, q0, 0.0)


def test_spherical_and_fixed_axis():
    """Spherical body, and permanent rotation about each principal axis (the middle one included):
    ω constant (exactly), Λ = Λ_n(|ω| τ) ∘ Λ0 with n = R(Λ0) ω0/|ω|, |ΔΛ| < 1e-14 for |τ| ≤ 30; ω0 = 0: Λ = Λ0."""
    q0 = _unit([0.3, -0.1, 0.5, 0.8])
    t = np.linspace(-30.0, 30.0, 61)
    cases = [((2.0, 2.0, 2.0), (0.3, -0.5, 0.2))]
    cases += [((1.0, 2.0, 3.0), tuple(0.7 * np.eye(3)[k])) for k in range(3)]
    cases += [((3.0, 1.0, 2.0), (0.0, -1.3, 0.0)), ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0))]
    for inertia, omega0 in cases:
        omega0 = np.array(omega0)
        q, w = torque_free_solution(inertia, omega0, q0, 0.0, t)
        assert np.array_equal(w, np.broadcast_to(omega0, w.shape))
        rate = np.linalg.norm(omega0)
        axis = rotate_to_space_array(q0, omega0) / rate if rate > 0 else np.array([0.0, 0.0, 1.0])
        rot = np.concatenate([np.cos(0.5 * rate * t)[:, None], np.sin(0.5 * rate * t)[:, None] * axis], axis=-1)
        assert np.max(np.abs(q - multiply_array(rot, q0))) < 1e-14


@pytest.mark.parametrize(
    "inertia, omega0",
    [
        ((1.0, 1.0 + 1e-9, 2.0), (0.6, 0.5, 0.7)),  # nearly axisymmetric, rotation about the largest axis side
        ((2.0, 1.0, 2.0 * (1 + 1e-9)), (0.6, 0.5, 0.7)),
        ((1.0, 1.0 + 1e-9, 1.0 + 2e-9), (0.6, 0.5, 0.7)),  # nearly spherical
        ((1.0, 2.0, 3.0), (1e-8, 1.0, -1e-8)),  # ω0 within 1e-8 of the middle axis
        ((1.0, 2.0, 3.0), (1e-3, 0.0, 2.0)),  # close to permanent rotation about the largest axis
        ((1.0, 2.0, 3.0), (2.0, 0.0, 1e-3)),  # close to permanent rotation about the smallest axis
    ],
)
def test_nearly_degenerate(inertia, omega0):
    """Nearly equal moments (1e-9 relative) and near-permanent rotations: errors < 1e-12 vs MpReference
    over ±1000 periods of ω (capped at 1e6 time units)."""
    ref = MpReference(inertia, omega0, (1.0, 0.0, 0.0, 0.0), 0.0)
    t = np.concatenate([[1.0, -1.0], np.linspace(-1.0, 1.0, 9)]) * min(1000.0 * ref.period, 1e6)
    q, w = torque_free_solution(inertia, omega0, (1.0, 0.0, 0.0, 0.0), 0.0, t)
    e_w, e_q = _errors(q, w, *ref(t))
    assert e_w < 1e-12 and e_q < 1e-12, (e_w, e_q)


@pytest.mark.parametrize("offset", [1e-100, 1e-160])
def test_extremely_close_to_middle_axis(offset):
    """ω0 = (δ, 1, δ) with δ = 1e-100, 1e-160 (m1 ~ δ², not the separatrix): errors < 1e-12 vs a 450-digit
    MpReference over ±100 periods of ω (the orbit flips every 2K/λ ≈ 800–1300 time units)."""
    inertia, omega0, q0 = (1.0, 2.0, 3.0), (offset, 1.0, offset), _unit([0.3, 0.1, -0.5, 0.7])
    ref = MpReference(inertia, omega0, q0, 0.0, dps=450)
    assert not ref.separatrix
    t = np.array([1.0, -1.0, 0.31, -0.47]) * 100.0 * ref.period
    q, w = torque_free_solution(inertia, omega0, q0, 0.0, t)
    e_w, e_q = _errors(q, w, *ref(t))
    assert e_w < 1e-12 and e_q < 1e-12, (e_w, e_q)


def test_nearly_axisymmetric_is_continuous():
    """(1, 1 + δ, 2) vs the exact axisymmetric (1, 1, 2): differences O(δ |ω| t) (< 10 δ (1 + |ω| t))."""
    omega0, q0 = np.array([0.6, 0.5, 0.7]), _unit([0.9, 0.1, 0.2, 0.3])
    t = np.linspace(0.0, 200.0, 101)
    for delta in (1e-9, 1e-12):
        q1, w1 = torque_free_solution((1.0, 1.0 + delta, 2.0), omega0, q0, 0.0, t)
        q2, w2 = torque_free_solution((1.0, 1.0, 2.0), omega0, q0, 0.0, t)
        bound = 10 * delta * (1 + np.linalg.norm(omega0) * t)
        assert np.all(np.linalg.norm(w1 - w2, axis=-1) < bound)
        assert np.all(np.linalg.norm(q1 - q2, axis=-1) < bound)


def test_dzhanibekov_flip():
    """Moments (1, 2, 3), ω0 near the middle axis: ω2 changes sign every 2K(m)/λ (period 4K/λ), with K, m, λ
    computed independently (Landau–Lifshitz, M² < 2T I2 side) with mpmath; crossing spacing error < 1e-10 relative."""
    inertia, omega0 = np.array([1.0, 2.0, 3.0]), np.array([0.02, 1.0, 0.01])
    with mp.workdps(30):
        i1, i2, i3 = (mp.mpf(x) for x in inertia)
        w = [mp.mpf(x) for x in omega0]
        t2 = i1 * w[0] ** 2 + i2 * w[1] ** 2 + i3 * w[2] ** 2
        l2 = (i1 * w[0]) ** 2 + (i2 * w[1]) ** 2 + (i3 * w[2]) ** 2
        assert l2 < t2 * i2  # the motion circles the smallest axis: swap 1 ↔ 3 in the L–L formulas
        m = (i2 - i3) * (t2 * i1 - l2) / ((i1 - i2) * (l2 - t2 * i3))
        lam = mp.sqrt((i1 - i2) * (l2 - t2 * i3) / (i1 * i2 * i3))
        half = float(2 * mp.ellipk(m) / lam)
    f = lambda s: torque_free_solution(inertia, omega0, (1, 0, 0, 0), 0.0, np.atleast_1d(s))[1][..., 1]  # noqa: E731
    grid = np.linspace(0.0, 6.2 * half, 6201)
    values = f(grid)
    idx = np.flatnonzero(np.sign(values[1:]) != np.sign(values[:-1]))
    roots = np.array([brentq(lambda s: f(s)[0], grid[k], grid[k + 1], xtol=1e-14, rtol=1e-15) for k in idx])
    assert len(roots) >= 5
    assert np.max(np.abs(np.diff(roots) / half - 1.0)) < 1e-10
    assert np.max(np.abs(np.diff(roots[::2]) / (2 * half) - 1.0)) < 1e-10
    assert np.all(np.abs(f(roots[:-1] + 0.5 * half)) > 0.9)  # a full flip between crossings


PROPER_PERMUTATIONS = [
    ((0, 1, 2), (1, 1, 1)),
    ((1, 2, 0), (1, 1, 1)),
    ((2, 0, 1), (1, 1, 1)),
    ((1, 0, 2), (1, 1, -1)),
    ((0, 2, 1), (-1, 1, 1)),
    ((2, 1, 0), (1, -1, 1)),
]


@HYPOTHESIS
@given(bodies(st.one_of(GENERIC, NEAR, st.just(0.0))))
def test_axis_order_invariance(case):
    """Relabelling the body axes by any signed permutation P (det +1): ω' = P ω, Λ' = Λ ∘ Λ_P⁻¹, to 1e-12
    over ±1000 periods."""
    inertia, omega0, q0, t0 = case
    t = _long_span_times(7, t0, MpReference(inertia, omega0, q0, t0).period)
    q, w = torque_free_solution(inertia, omega0, q0, t0, t)
    for perm_idx, signs in PROPER_PERMUTATIONS:
        perm = np.zeros((3, 3))
        perm[range(3), perm_idx] = signs
        q_perm = from_matrix(perm)
        q0_perm = multiply_array(q0, conjugate_array(q_perm))
        q2, w2 = torque_free_solution(inertia[list(perm_idx)], perm @ omega0, q0_perm, t0, t)
        e_w, e_q = _errors(q2, w2, multiply_array(q, conjugate_array(q_perm)), w @ perm.T)
        assert e_w < 1e-12 and e_q < 1e-12, (perm_idx, e_w, e_q)


def test_initial_state_shapes_and_order():
    """At t = t0 the inputs are returned (1e-15); unsorted times, t < t0 and an empty t are fine."""
    inertia, omega0, q0 = (3.0, 1.0, 2.0), np.array([0.3, -0.8, 0.5]), _unit([0.5, -0.5, 0.1, 0.7])
    t = np.array([2.0, -3.0, 2.0, 0.0, 1e3, -1e3])
    q, w = torque_free_solution(inertia, omega0, q0, 2.0, t)
    assert q.shape == (6, 4) and w.shape == (6, 3)
    assert np.max(np.abs(w[0] - omega0)) < 1e-15 and np.max(np.abs(q[0] - q0)) < 1e-15
    assert np.max(np.abs(q[0] - q[2])) < 1e-16
    q_sorted, w_sorted = torque_free_solution(inertia, omega0, q0, 2.0, np.sort(t))
    order = np.argsort(t, kind="stable")
    assert np.max(np.abs(q_sorted - q[order])) < 1e-16 and np.max(np.abs(w_sorted - w[order])) < 1e-16
    q_empty, w_empty = torque_free_solution(inertia, omega0, q0, 2.0, np.array([]))
    assert q_empty.shape == (0, 4) and w_empty.shape == (0, 3)
