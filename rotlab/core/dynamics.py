"""Right-hand side of the rigid body about a fixed point, principal body frame.

State y = (Λ, ω, W), 8 components:
    Λ̇ = ½ Λ ∘ (0, ω)                                   (Poisson, scalar-first quaternion)
    A ṗ = (B − C) q r + M1,  B q̇ = (C − A) r p + M2,  C ṙ = (A − B) p q + M3   (Euler)
    Ẇ = M_nc · ω                                        (work of the non-conservative loads)
Loads: see ``rotlab.scene.loads``.  Λ is not renormalised: |Λ| − 1 is reported as drift.

A scene pays only for the loads it has: a load group passed as ``None`` (see
``LoadArrays.for_kernel``) compiles to nothing, by type specialisation (``overload`` below),
which numba caches like any other signature.
"""

from __future__ import annotations

import numpy as np
from numba import njit, types
from numba.extending import overload

from rotlab.core.quaternion import rotate_to_body

STATE_SIZE = 8


def euler_coefficients(moments: np.ndarray) -> np.ndarray:
    """[(B − C)/A, (C − A)/B, (A − B)/C, 1/A, 1/B, 1/C]: Euler's equations without divisions,
    ṗ = (B − C)/A · q r + M1/A, ..."""
    a, b, c = (float(x) for x in moments)
    return np.array([(b - c) / a, (c - a) / b, (a - b) / c, 1.0 / a, 1.0 / b, 1.0 / c])


def conservative_torque(y, forces):
    """Σ p × (Rᵀ F) over constant space-frame forces (rows [p, F]); body components."""
    raise NotImplementedError("compiled only: see the overload")


def nonconservative_torque(t, y, terms, tables, table_t, table_v, damping):
    """Torque terms + tables + damping −kω at time t; body components."""
    raise NotImplementedError("compiled only: see the overload")


@overload(conservative_torque)
def _conservative_torque(y, forces):
    if isinstance(forces, types.NoneType):
        return lambda y, forces: (0.0, 0.0, 0.0)

    def impl(y, forces):
        cx = cy = cz = 0.0
        for k in range(forces.shape[0]):
            fx, fy, fz = rotate_to_body(y[0], y[1], y[2], y[3], forces[k, 3], forces[k, 4], forces[k, 5])
            px, py, pz = forces[k, 0], forces[k, 1], forces[k, 2]
            cx += py * fz - pz * fy
            cy += pz * fx - px * fz
            cz += px * fy - py * fx
        return cx, cy, cz

    return impl


@overload(nonconservative_torque)
def _nonconservative_torque(t, y, terms, tables, table_t, table_v, damping):
    if isinstance(terms, types.NoneType):
        return lambda t, y, terms, tables, table_t, table_v, damping: (0.0, 0.0, 0.0)

    def impl(t, y, terms, tables, table_t, table_v, damping):
        q0, q1, q2, q3 = y[0], y[1], y[2], y[3]
        nx = ny = nz = 0.0
        for k in range(terms.shape[0]):
            if terms[k, 1] <= t < terms[k, 2]:
                mx, my, mz = terms[k, 3], terms[k, 4], terms[k, 5]
                if terms[k, 9] != 0.0:
                    s = np.sin(terms[k, 9] * t + terms[k, 10])
                    mx += terms[k, 6] * s
                    my += terms[k, 7] * s
                    mz += terms[k, 8] * s
                if terms[k, 0] != 0.0:
                    mx, my, mz = rotate_to_body(q0, q1, q2, q3, mx, my, mz)
                nx += mx
                ny += my
                nz += mz
        for k in range(tables.shape[0]):
            if tables[k, 1] <= t < tables[k, 2]:
                mx, my, mz = table_value(table_t, table_v, int(tables[k, 3]), int(tables[k, 4]), t)
                if tables[k, 0] != 0.0:
                    mx, my, mz = rotate_to_body(q0, q1, q2, q3, mx, my, mz)
                nx += mx
                ny += my
                nz += mz
        nx -= damping * y[4]
        ny -= damping * y[5]
        nz -= damping * y[6]
        return nx, ny, nz

    return impl


@njit(cache=True)
def table_segment(tt, first, stop, t):
    """The row lo of rows [first, stop) of a table with tt[lo] ≤ t < tt[lo + 1]; −1 outside."""
    if t < tt[first] or t >= tt[stop - 1]:
        return -1
    lo, hi = first, stop - 1  # bisection: tt[lo] <= t < tt[hi]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if tt[mid] <= t:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def table_value(tt, tv, first, stop, t):
    """Piecewise-linear interpolation in rows [first, stop) of a table; zero outside."""
    lo = table_segment(tt, first, stop, t)
    if lo < 0:
        return 0.0, 0.0, 0.0
    hi = lo + 1
    s = (t - tt[lo]) / (tt[hi] - tt[lo])
    return (
        tv[lo, 0] + s * (tv[hi, 0] - tv[lo, 0]),
        tv[lo, 1] + s * (tv[hi, 1] - tv[lo, 1]),
        tv[lo, 2] + s * (tv[hi, 2] - tv[lo, 2]),
    )


@njit(cache=True, inline="always")
def rhs(t, y, dy, euler, forces, terms, tables, table_t, table_v, damping):
    """dy ← f(t, y) for the 8-component state (see module docstring); ``euler`` from
    ``euler_coefficients``; loads as in ``LoadArrays`` (groups may be None)."""
    q0, q1, q2, q3 = y[0], y[1], y[2], y[3]
    p, q, r = y[4], y[5], y[6]
    cx, cy, cz = conservative_torque(y, forces)
    nx, ny, nz = nonconservative_torque(t, y, terms, tables, table_t, table_v, damping)
    dy[0] = -0.5 * (q1 * p + q2 * q + q3 * r)
    dy[1] = 0.5 * (q0 * p + q2 * r - q3 * q)
    dy[2] = 0.5 * (q0 * q + q3 * p - q1 * r)
    dy[3] = 0.5 * (q0 * r + q1 * q - q2 * p)
    dy[4] = euler[0] * q * r + (cx + nx) * euler[3]
    dy[5] = euler[1] * r * p + (cy + ny) * euler[4]
    dy[6] = euler[2] * p * q + (cz + nz) * euler[5]
    dy[7] = nx * p + ny * q + nz * r


@njit(cache=True, inline="always")
def next_piece(t, t_end, breaks, b):
    """(end, t_last, b) of the step piece starting at t: it ends at the next load breakpoint
    (``rotlab.scene.loads.breakpoints``) in (t, t_end] or at t_end; its last stage samples the
    loads at ``t_last`` (the left limit at a breakpoint); ``b`` indexes the next breakpoint."""
    nb = breaks.shape[0]
    while b < nb and breaks[b] <= t:
        b += 1
    if b < nb and breaks[b] <= t_end:
        return breaks[b], np.nextafter(breaks[b], -np.inf), b
    return t_end, t_end, b


@njit(cache=True)
def all_finite(y):
    for k in range(y.shape[0]):
        if not np.isfinite(y[k]):
            return False
    return True
