"""Adaptive high-order Taylor series method (Jorba & Zou, "A software package for the numerical
integration of ODEs by means of high-order Taylor methods", Exp. Math. 14, 2005), compiled.

The right-hand side of ``rotlab.core.dynamics`` is a polynomial of degree 2 in y = (Λ, ω) plus
functions of time alone, so its Taylor coefficients follow by automatic differentiation:
Cauchy products (u v)^[k] = Σ_{j=0..k} u^[j] v^[k−j] and y^[k+1] = f^[k] / (k + 1), with

    Λ̇ = ½ Λ ∘ (0, ω),   ṗ = (B − C)/A · q r + M₁/A, ...,   Ẇ = M_nc · ω.

Loads (body components, principal frame; products P_ij = λ_i λ_j, i ≤ j, 10 series):
* a constant space vector v seen in the body: Rᵀ v = v + L(P, v), L bilinear (``rotate_quadratic``);
  so every constant force gives p × Rᵀ F = p × F + (p × L(·, F)) P: a 3 × 10 matrix (``force_map``);
* one constant force and nothing else in space (gravity: the heavy, Lagrange and Kovalevskaya tops)
  is cheaper through γ = Rᵀ F, which obeys Poisson's equation γ̇ = γ × ω: the torque p × γ, with
  (γ × ω)^[k] = Σ_j γ^[j] × ω^[k−j] (6 products a term, against the 10 products λ_i λ_j and a 3 × 10
  map), γ^[0] = F + L(P^[0], F) at the start of each step (``lever_force`` = [p, F]);
* body-frame time functions b(τ) (harmonic terms, table segments): their own series;
* space-frame time functions s(τ): (Rᵀ s)^[k] = s^[k] + Σ_j L(P^[j], s^[k−j]);
* damping −d ω;
* a gyrostat's rotors: h × ω, linear in ω: (h × ω)^[k] = h × ω^[k].
Windows and table knots are breakpoints: steps end there, so each step sees one smooth load;
steps also end where an abs, sign, min or max of an expression switches branch.

Order and step (Jorba & Zou §3.2): N = ⌈−½ ln ε⌉ + 1 with ε = rtol (or the order asked for);
h = e^(−0.7/(N−1)) · min over j ∈ {N−1, N} and the groups g ∈ {Λ, ω} of
(ε_g / ‖y_g^[j]‖∞)^(1/j),  ε_g = atol + rtol ‖y_g‖∞.  No step is rejected.
Dense output: the step's own polynomial, evaluated at the samples in (t, t + h] by Horner.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
from numba import njit

from rotlab.core.dynamics import STATE_SIZE, count_at_or_below, next_piece, store_row
from rotlab.core.expressions import release_forced
from rotlab.core.kernel_status import OK, STEP_TOO_SMALL, state_status
from rotlab.core.quaternion import N_PRODUCTS, cross_array, rotate_quadratic
from rotlab.core.torques import F_FORCE, F_POINT, load_series, nonconservative_series, series_workspace, switch_step, with_gyrostatic



def default_order(rtol: float) -> int:
    """Jorba & Zou's order for tolerance ε: ⌈−½ ln ε⌉ + 1 (at least 4)."""
    return max(4, math.ceil(-0.5 * math.log(rtol)) + 1)


def force_map(forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(c₀, T) with Σ_k p_k × Rᵀ F_k = c₀ + T P for constant space forces (rows [p, F]):
    column m of T is p × L(e_m, F), L linear in the products P (``rotate_quadratic``)."""
    c0 = np.zeros(3)
    T = np.zeros((3, N_PRODUCTS))
    maps = _quadratic_maps()
    for row in forces:
        arm, force = row[F_POINT:F_POINT + 3], row[F_FORCE:F_FORCE + 3]
        c0 += cross_array(arm, force)
        T += cross_array(arm, maps @ force).T
    return c0, T


@cache
def _quadratic_maps() -> np.ndarray:
    """(N_PRODUCTS, 3, 3): L(e_m, v) = maps[m] v for the unit product e_m (L is linear in v; its
    entries are 0 and ±2, so maps[m] v rounds as ``rotate_quadratic`` does)."""
    units = np.eye(N_PRODUCTS).ravel()
    columns = [[rotate_quadratic.py_func(units, N_PRODUCTS * m, *e) for e in np.eye(3)] for m in range(N_PRODUCTS)]
    return np.ascontiguousarray(np.array(columns).transpose(0, 2, 1))


@njit(cache=True)
def series(t, X, order, model, c0, T, lever_force, G, body, space, P, M, has_products, has_space, has_work, inputs, tape, stack):
    """Fill X[1..order] (Taylor coefficients of the state, X[0] given) and M[0..order−1] (the
    non-conservative torque, body components, ``rotlab.core.torques.nonconservative_series``).
    P holds the products' coefficients; G those of γ = Rᵀ F when ``lever_force`` is given (when
    it is None, numba prunes the γ code from the compiled kernel: no compile time for scenes
    without a lone force)."""
    euler = model.euler
    if lever_force is not None:
        _gamma_start(X, lever_force, P, G)
    for k in range(order):
        a0 = a1 = a2 = a3 = 0.0
        e0 = e1 = e2 = 0.0
        s00 = s01 = s02 = s03 = s11 = s12 = s13 = s22 = s23 = s33 = 0.0
        g0 = g1 = g2 = 0.0
        for j in range(k + 1):
            l0, l1, l2, l3 = X[j, 0], X[j, 1], X[j, 2], X[j, 3]
            p, q, r = X[k - j, 4], X[k - j, 5], X[k - j, 6]
            a0 -= l1 * p + l2 * q + l3 * r
            a1 += l0 * p + l2 * r - l3 * q
            a2 += l0 * q + l3 * p - l1 * r
            a3 += l0 * r + l1 * q - l2 * p
            e0 += X[j, 5] * r
            e1 += X[j, 6] * p
            e2 += X[j, 4] * q
            if lever_force is not None:  # (γ × ω)^[k]
                g0 += G[j, 1] * r - G[j, 2] * q
                g1 += G[j, 2] * p - G[j, 0] * r
                g2 += G[j, 0] * q - G[j, 1] * p
            if has_products:
                u0, u1, u2, u3 = X[k - j, 0], X[k - j, 1], X[k - j, 2], X[k - j, 3]
                s00 += l0 * u0
                s01 += l0 * u1
                s02 += l0 * u2
                s03 += l0 * u3
                s11 += l1 * u1
                s12 += l1 * u2
                s13 += l1 * u3
                s22 += l2 * u2
                s23 += l2 * u3
                s33 += l3 * u3
        tx = ty = tz = 0.0
        if has_products:
            o = N_PRODUCTS * k
            P[o], P[o + 1], P[o + 2], P[o + 3], P[o + 4] = s00, s01, s02, s03, s11
            P[o + 5], P[o + 6], P[o + 7], P[o + 8], P[o + 9] = s12, s13, s22, s23, s33
            for m in range(N_PRODUCTS):
                tx += T[0, m] * P[o + m]
                ty += T[1, m] * P[o + m]
                tz += T[2, m] * P[o + m]
            if k == 0:
                tx += c0[0]
                ty += c0[1]
                tz += c0[2]
        if lever_force is not None:  # p × γ^[k]
            px, py, pz = lever_force[0, 0], lever_force[0, 1], lever_force[0, 2]
            tx += py * G[k, 2] - pz * G[k, 1]
            ty += pz * G[k, 0] - px * G[k, 2]
            tz += px * G[k, 1] - py * G[k, 0]
        tx, ty, tz = with_gyrostatic((tx, ty, tz), X[k, 4], X[k, 5], X[k, 6], model.rotors)  # (h × ω)^[k] = h × ω^[k]
        nx = ny = nz = 0.0
        if has_work:  # else no load does work: the series below is zero (a call per order saved)
            nx, ny, nz = nonconservative_series(k, t, X, P, model, body, space, has_space, inputs, tape, stack)
        M[k, 0], M[k, 1], M[k, 2] = nx, ny, nz
        work = 0.0
        if has_work:
            for j in range(k + 1):
                work += M[j, 0] * X[k - j, 4] + M[j, 1] * X[k - j, 5] + M[j, 2] * X[k - j, 6]
        inv = 1.0 / (k + 1)
        X[k + 1, 0] = 0.5 * inv * a0
        X[k + 1, 1] = 0.5 * inv * a1
        X[k + 1, 2] = 0.5 * inv * a2
        X[k + 1, 3] = 0.5 * inv * a3
        X[k + 1, 4] = inv * (euler[0] * e0 + euler[3] * (tx + nx))
        X[k + 1, 5] = inv * (euler[1] * e1 + euler[4] * (ty + ny))
        X[k + 1, 6] = inv * (euler[2] * e2 + euler[5] * (tz + nz))
        X[k + 1, 7] = inv * work
        if lever_force is not None:
            G[k + 1, 0] = inv * g0
            G[k + 1, 1] = inv * g1
            G[k + 1, 2] = inv * g2


@njit(cache=True)
def _gamma_start(X, lever_force, P, G):
    """γ^[0] = Rᵀ F = F + L(P^[0], F) from Λ = X[0, 0:4], as the products would give it."""
    l0, l1, l2, l3 = X[0, 0], X[0, 1], X[0, 2], X[0, 3]
    P[0], P[1], P[2], P[3], P[4] = l0 * l0, l0 * l1, l0 * l2, l0 * l3, l1 * l1
    P[5], P[6], P[7], P[8], P[9] = l1 * l2, l1 * l3, l2 * l2, l2 * l3, l3 * l3
    fx, fy, fz = lever_force[1, 0], lever_force[1, 1], lever_force[1, 2]
    lx, ly, lz = rotate_quadratic(P, 0, fx, fy, fz)
    G[0, 0], G[0, 1], G[0, 2] = fx + lx, fy + ly, fz + lz


@njit(cache=True)
def step_size(X, order, y, rtol, atol):
    """Jorba & Zou's step (module docstring); inf when the series terminates (all zero)."""
    lam = max(abs(y[0]), abs(y[1]), abs(y[2]), abs(y[3]))
    omega = max(abs(y[4]), abs(y[5]), abs(y[6]))
    eps_lam = atol + rtol * lam
    eps_omega = atol + rtol * omega
    rho = np.inf
    for j in range(order - 1, order + 1):
        c_lam = max(abs(X[j, 0]), abs(X[j, 1]), abs(X[j, 2]), abs(X[j, 3]))
        c_omega = max(abs(X[j, 4]), abs(X[j, 5]), abs(X[j, 6]))
        ratio = min(eps_lam / c_lam if c_lam > 0.0 else np.inf, eps_omega / c_omega if c_omega > 0.0 else np.inf)
        if ratio < np.inf:  # x ↦ x^(1/j) is increasing: one power per order
            rho = min(rho, ratio ** (1.0 / j))
    return rho * math.exp(-0.7 / (order - 1))


@njit(cache=True)
def evaluate(X, order, s, out):
    """out ← Σ_k X[k] s^k (Horner; the 8 components in locals, not in ``out``, which the
    compiler cannot keep in registers: 33 → 27 ns a sample at order 13, same values)."""
    o0 = X[order, 0]
    o1 = X[order, 1]
    o2 = X[order, 2]
    o3 = X[order, 3]
    o4 = X[order, 4]
    o5 = X[order, 5]
    o6 = X[order, 6]
    o7 = X[order, 7]
    for k in range(order - 1, -1, -1):
        o0 = o0 * s + X[k, 0]
        o1 = o1 * s + X[k, 1]
        o2 = o2 * s + X[k, 2]
        o3 = o3 * s + X[k, 3]
        o4 = o4 * s + X[k, 4]
        o5 = o5 * s + X[k, 5]
        o6 = o6 * s + X[k, 6]
        o7 = o7 * s + X[k, 7]
    out[0] = o0
    out[1] = o1
    out[2] = o2
    out[3] = o3
    out[4] = o4
    out[5] = o5
    out[6] = o6
    out[7] = o7


@njit(cache=True)
def taylor_advance(y, t, times, out, i, order, rtol, atol, max_steps, model, c0, T, lever_force, flags, counters):
    """Advance from (t, y), writing ``out[i]`` for every sample passed, until all samples are
    written or ``max_steps`` steps were taken; steps end at every time in ``model.breaks``.
    ``flags`` = (has_products, has_space, has_work); ``lever_force`` = [p, F] of a lone force or
    None; ``counters`` (int64[1]) += steps.  Returns (status, next sample index, t)."""
    has_products, has_space, has_work = flags
    X = np.zeros((order + 1, STATE_SIZE))
    G = np.zeros((order + 1, 3))
    P = np.zeros(N_PRODUCTS * (order + 1))
    M = np.zeros((order + 1, 3))
    body = np.zeros((order + 1, 3))
    space = np.zeros((order + 1, 3))
    t_end = times[times.shape[0] - 1]
    inputs, tape, stack = series_workspace(model, order)
    breaks = model.breaks
    b = count_at_or_below(breaks, t)
    steps = 0
    while i < times.shape[0] and steps < max_steps:
        for m in range(STATE_SIZE):
            X[0, m] = y[m]
        release_forced(tape)
        load_series(t, order, model, body, space)
        limit, _, b = next_piece(t, t_end, breaks, b)
        cut = -1.0
        for _ in range(3):  # formed again when a switch of an expression sits at t (``switch_step``)
            series(t, X, order, model, c0, T, lever_force, G, body, space, P, M, has_products, has_space, has_work, inputs, tape, stack)
            h = min(step_size(X, order, y, rtol, atol), limit - t)
            cut = switch_step(t, model, tape, order, h)
            if cut >= 0.0:
                break
        t_new = t + cut
        if t_new - t < 10.0 * (np.nextafter(t, np.inf) - t):
            return STEP_TOO_SMALL, i, t
        h = t_new - t
        while i < times.shape[0] and times[i] <= t_new:
            evaluate(X, order, times[i] - t, out[i])
            i += 1
        evaluate(X, order, h, y)
        t = t_new
        steps += 1
        counters[0] += 1
        status = state_status(y)
        if status != OK:
            return status, i, t
    return OK, i, t


@njit(cache=True)
def coefficients(t, y, order, model, c0, T, lever_force, flags):
    """The Taylor coefficients X[0..order] of the state at (t, y), as ``taylor_advance`` forms
    them for a step from t (for checks and tools)."""
    X = np.zeros((order + 1, STATE_SIZE))
    store_row(X, 0, y)
    body = np.zeros((order + 1, 3))
    space = np.zeros((order + 1, 3))
    inputs, tape, stack = series_workspace(model, order)
    load_series(t, order, model, body, space)
    series(t, X, order, model, c0, T, lever_force, np.zeros((order + 1, 3)), body, space, np.zeros(N_PRODUCTS * (order + 1)),
           np.zeros((order + 1, 3)), flags[0], flags[1], flags[2], inputs, tape, stack)
    return X


@njit(cache=True)
def taylor_local(y, t0, t1, grid, out, order, rtol, atol, max_steps, model, c0, T, lever_force, flags, counters):
    """The local solution Φ(y, t0, t1) (``Method.local_solution``): y ← the state at t1 of the
    series steps from (t0, y) at ``order`` and the tolerances (NaN where they fail); ``grid``
    (2) and ``out`` (2, len(y)) scratch."""
    grid[0], grid[1] = t0, t1
    for m in range(out.shape[1]):
        out[1, m] = math.nan
    # (an int64, not the literal 1, which numba would compile the whole advance again for)
    taylor_advance(y, t0, grid, out, np.int64(1), order, rtol, atol, max_steps, model, c0, T, lever_force, flags, counters)
    for m in range(out.shape[1]):
        y[m] = out[1, m]
