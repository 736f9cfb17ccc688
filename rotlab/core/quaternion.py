"""Quaternion algebra, scalar first: Λ = (q0, q1, q2, q3).

Product  (a0, a) ∘ (b0, b) = (a0 b0 − a·b,  a0 b + b0 a + a × b).
A unit Λ maps body to space:  r_space = Λ ∘ r_body ∘ Λ̃,  i.e.  r_space = R(Λ) r_body.

Scalar helpers are numba-compiled for use inside kernels; the ``*_array`` versions are
vectorised numpy over a leading sample axis for post-processing.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rotlab.rows import row_dot


@njit(cache=True, inline="always")
def qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    """Λ ∘ M for scalar-first components; returns a 4-tuple."""
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 + a2 * b0 + a3 * b1 - a1 * b3,
        a0 * b3 + a3 * b0 + a1 * b2 - a2 * b1,
    )


@njit(cache=True, inline="always")
def _twice_cross(q1, q2, q3, x, y, z):
    """t = 2 q × v, the rotations' first product."""
    return 2.0 * (q2 * z - q3 * y), 2.0 * (q3 * x - q1 * z), 2.0 * (q1 * y - q2 * x)


@njit(cache=True, inline="always")
def rotate_to_space(q0, q1, q2, q3, x, y, z):
    """R(Λ) v = Λ ∘ v ∘ Λ̃ for a unit Λ (v in body components → space components)."""
    # v' = v + 2 q0 (q × v) + 2 q × (q × v)
    tx, ty, tz = _twice_cross(q1, q2, q3, x, y, z)
    return (
        x + q0 * tx + (q2 * tz - q3 * ty),
        y + q0 * ty + (q3 * tx - q1 * tz),
        z + q0 * tz + (q1 * ty - q2 * tx),
    )


@njit(cache=True, inline="always")
def rotate_to_body(q0, q1, q2, q3, x, y, z):
    """R(Λ)ᵀ v = Λ̃ ∘ v ∘ Λ for a unit Λ (v in space components → body components):
    ``rotate_to_space`` of the conjugate, v − q0 t + q × t with t = 2 q × v, its products and sums
    rounded alike (negating q negates t exactly) without the three negations."""
    tx, ty, tz = _twice_cross(q1, q2, q3, x, y, z)
    return (
        x - q0 * tx + (q2 * tz - q3 * ty),
        y - q0 * ty + (q3 * tx - q1 * tz),
        z - q0 * tz + (q1 * ty - q2 * tx),
    )


def cross_array(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over broadcast leading axes, (..., 3): the products and differences of ``np.cross``
    (the same floating-point result) without its axis handling, which dominates on short arrays."""
    a1, a2, a3 = a[..., 0], a[..., 1], a[..., 2]
    b1, b2, b3 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    np.subtract(a2 * b3, a3 * b2, out=out[..., 0])
    np.subtract(a3 * b1, a1 * b3, out=out[..., 1])
    np.subtract(a1 * b2, a2 * b1, out=out[..., 2])
    return out


def multiply_array(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Λ ∘ M over broadcast leading axes; inputs (..., 4) scalar first."""
    a0, av = a[..., :1], a[..., 1:]
    b0, bv = b[..., :1], b[..., 1:]
    scalar = a0 * b0 - np.sum(av * bv, axis=-1, keepdims=True)
    vector = a0 * bv + b0 * av + cross_array(av, bv)
    return np.concatenate([scalar, vector], axis=-1)


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Λ ∘ M for one pair of quaternions: ``multiply_array``'s operations in its order (the same
    floating-point result) on Python floats, without the array overhead that dominates a single
    product."""
    a0, a1, a2, a3 = a.tolist()
    b0, b1, b2, b3 = b.tolist()
    return np.array([a0 * b0 - (a1 * b1 + a2 * b2 + a3 * b3), a0 * b1 + b0 * a1 + (a2 * b3 - a3 * b2),
                     a0 * b2 + b0 * a2 + (a3 * b1 - a1 * b3), a0 * b3 + b0 * a3 + (a1 * b2 - a2 * b1)])


def conjugate_array(q: np.ndarray) -> np.ndarray:
    """Λ̃ = (q0, −q1, −q2, −q3)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def rotate_to_space_array(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(Λ) v for arrays q (..., 4) and v (..., 3), Λ assumed unit."""
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    t1, t2, t3 = 2.0 * (q2 * z - q3 * y), 2.0 * (q3 * x - q1 * z), 2.0 * (q1 * y - q2 * x)  # t = 2 q × v
    out = np.empty(np.broadcast_shapes(q.shape[:-1], v.shape[:-1]) + (3,), dtype=np.result_type(q, v))
    np.add(x + q0 * t1, q2 * t3 - q3 * t2, out=out[..., 0])  # v + q0 t + q × t, one component at a time
    np.add(y + q0 * t2, q3 * t1 - q1 * t3, out=out[..., 1])
    np.add(z + q0 * t3, q1 * t2 - q2 * t1, out=out[..., 2])
    return out


def projection_array(q: np.ndarray, w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(R(Λ) w)·v for unit quaternion rows q (..., N, 4) and 3-vectors w, v (..., 3), fixed along
    each run of rows (one run: q (N, 4), w and v (3,); B runs stacked: (B, N, 4) and (B, 3)):

        (R w)·v = (2 q0² − 1)(w·v) + 2 (q·w)(q·v) + 2 q0 q·(w × v)     (q the vector part, |Λ| = 1),

    three dot products per sample instead of rotating N vectors."""
    w, v = np.asarray(w, dtype=float), np.asarray(v, dtype=float)
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]

    def along(u: np.ndarray) -> np.ndarray:  # q·u, u fixed along each run
        u = u[..., None, :]
        return q1 * u[..., 0] + q2 * u[..., 1] + q3 * u[..., 2]

    return (2.0 * q0 * q0 - 1.0) * row_dot(w, v)[..., None] + 2.0 * (along(w) * along(v) + q0 * along(cross_array(w, v)))


def rotate_to_body_array(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(Λ)ᵀ v for arrays q (..., 4) and v (..., 3), Λ assumed unit."""
    return rotate_to_space_array(conjugate_array(q), v)


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix R(Λ) (body → space) of a unit quaternion, shape (..., 3, 3)."""
    q = np.asarray(q, dtype=float)
    eye = np.broadcast_to(np.eye(3), q.shape[:-1] + (3, 3))
    return np.stack([rotate_to_space_array(q, eye[..., :, k]) for k in range(3)], axis=-1)


def from_matrix(m: np.ndarray) -> np.ndarray:
    """Unit quaternion (q0 ≥ 0) of a proper rotation matrix (Shepperd's method, stable)."""
    m = np.asarray(m, dtype=float)
    trace = np.trace(m)
    candidates = np.array([trace, m[0, 0], m[1, 1], m[2, 2]])
    k = int(np.argmax(candidates))
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + trace)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif k == 1:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif k == 2:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    q /= np.linalg.norm(q)
    return q if q[0] >= 0.0 else -q


def from_axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Λ = (cos(α/2), sin(α/2) e) for a rotation by α about the unit axis e."""
    e = np.asarray(axis, dtype=float)
    e = e / np.linalg.norm(e)
    return np.concatenate([[np.cos(0.5 * angle)], np.sin(0.5 * angle) * e])


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation Λ taking direction a to direction b (R(Λ) â = b̂)."""
    a = np.asarray(a, dtype=float) / np.linalg.norm(a)
    b = np.asarray(b, dtype=float) / np.linalg.norm(b)
    axis = np.cross(a, b)
    sin, cos = np.linalg.norm(axis), float(np.dot(a, b))
    if sin < 1e-15:
        if cos > 0.0:
            return np.array([1.0, 0.0, 0.0, 0.0])
        helper = np.eye(3)[int(np.argmin(np.abs(a)))]  # half turn about any axis ⊥ a
        return np.concatenate([[0.0], np.cross(a, helper) / np.linalg.norm(np.cross(a, helper))])
    return from_axis_angle(axis, np.arctan2(sin, cos))


def from_euler_313(psi: float, theta: float, phi: float) -> np.ndarray:
    """Classical 3-1-3 Euler angles: Λ = Λ_z(ψ) ∘ Λ_x(θ) ∘ Λ_z(φ) (precession, nutation, spin),
    multiplied out:  Λ = (cos ½θ cos ½(ψ+φ), sin ½θ cos ½(ψ−φ), sin ½θ sin ½(ψ−φ), cos ½θ sin ½(ψ+φ))."""
    c, s = math.cos(0.5 * theta), math.sin(0.5 * theta)
    plus, minus = 0.5 * (psi + phi), 0.5 * (psi - phi)
    return np.array([c * math.cos(plus), s * math.cos(minus), s * math.sin(minus), c * math.sin(plus)])


def to_euler_313(q: np.ndarray) -> np.ndarray:
    """3-1-3 Euler angles (ψ, θ, φ) of unit quaternions (..., 4) → (..., 3).

    θ = arccos(R33) ∈ [0, π]; ψ = atan2(R13, −R23), φ = atan2(R31, R32).  At θ = 0 or π
    only ψ ± φ is defined: there φ is set to 0 and the whole rotation goes into ψ.
    """
    r = to_matrix(q)
    r33 = np.clip(r[..., 2, 2], -1.0, 1.0)
    theta = np.arccos(r33)
    sin_theta = np.hypot(r[..., 0, 2], r[..., 1, 2])
    regular = sin_theta > 1e-12
    psi = np.where(regular, np.arctan2(r[..., 0, 2], -r[..., 1, 2]), np.arctan2(r[..., 1, 0], r[..., 0, 0]))
    phi = np.where(regular, np.arctan2(r[..., 2, 0], r[..., 2, 1]), 0.0)
    # at θ = π the rotation is Rz(ψ) Rx(π): ψ from R11 = cos ψ, R21 = sin ψ still holds
    return np.stack([psi, theta, phi], axis=-1)


N_PRODUCTS = 10  # λ_i λ_j, i ≤ j: (00, 01, 02, 03, 11, 12, 13, 22, 23, 33)


@njit(cache=True)
def rotate_quadratic(P, o, vx, vy, vz):
    """L(P, v): the part of Rᵀ v = v − 2 λ₀ (λ × v) + 2 λ × (λ × v) that is quadratic in Λ,
    written in the products P[o + 0..9] (λ = (λ₁, λ₂, λ₃)); linear in P and in v."""
    p01, p02, p03 = P[o + 1], P[o + 2], P[o + 3]
    p11, p12, p13, p22, p23, p33 = P[o + 4], P[o + 5], P[o + 6], P[o + 7], P[o + 8], P[o + 9]
    n2 = p11 + p22 + p33
    return (
        -2.0 * (p02 * vz - p03 * vy) + 2.0 * (p11 * vx + p12 * vy + p13 * vz - vx * n2),
        -2.0 * (p03 * vx - p01 * vz) + 2.0 * (p12 * vx + p22 * vy + p23 * vz - vy * n2),
        -2.0 * (p01 * vy - p02 * vx) + 2.0 * (p13 * vx + p23 * vy + p33 * vz - vz * n2),
    )
