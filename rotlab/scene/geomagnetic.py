"""Earth's magnetic field along a circular orbit, as the magnetic loads see it (``load_kinds``):
a tilted dipole fixed in the inertial (space) frame,

    B(t) = B₀ (R_E/r)³ [3 (m̂·r̂) r̂ − m̂],     m̂ = −(sin δ, 0, cos δ),
    r̂(t) = cos(n t) x̂ + sin(n t) (cos i ŷ + sin i ẑ),     n = √(μ/r³),   r = R_E + h,

space frame: z along Earth's axis, x toward the ascending node (at t = 0 the body is there) and
the dipole's meridian; δ the dipole's tilt, i the orbit's inclination, h its altitude.  B₀ is
the field at the magnetic equator on the surface; m̂ points to the southern hemisphere, as
Earth's dipole moment does (B at the equator points north, −m̂).  Not modelled: Earth's
rotation under the orbit (the dipole would turn once a day), the higher harmonics (IGRF), the
orbit's decay.  Constants: B₀ = 3.12 × 10⁻⁵ T, R_E = 6,371.2 km (IGRF's reference radius),
μ = 3.986004418 × 10¹⁴ m³/s² (WGS 84); the default tilt 11.5°.
"""

from __future__ import annotations

import math

import numpy as np

B0 = 3.12e-5  # T
EARTH_RADIUS = 6.3712e6  # m
MU = 3.986004418e14  # m³/s²
TILT_DEG = 11.5


def orbit_rate(altitude: float) -> float:
    """n (rad/s) of a circular orbit at ``altitude`` (m)."""
    return math.sqrt(MU / (EARTH_RADIUS + altitude) ** 3)


def dipole_axis(tilt_deg: float) -> np.ndarray:
    """m̂, space frame."""
    tilt = math.radians(tilt_deg)
    return -np.array([math.sin(tilt), 0.0, math.cos(tilt)])


def orbit_plane(inclination_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """(x̂, the in-plane direction a quarter orbit later): r̂(t) = cos(n t) u + sin(n t) v."""
    inclination = math.radians(inclination_deg)
    return np.array([1.0, 0.0, 0.0]), np.array([0.0, math.cos(inclination), math.sin(inclination)])


def field_strength(altitude: float, field: float = B0) -> float:
    """B₀ (R_E/r)³ (T): the dipole's field at the orbit's radius on the magnetic equator."""
    return field * (EARTH_RADIUS / (EARTH_RADIUS + altitude)) ** 3


def field_in_space(t: np.ndarray, altitude: float, inclination_deg: float, tilt_deg: float = TILT_DEG, field: float = B0) -> np.ndarray:
    """B(t) (T), space frame, (N, 3): the module docstring's formula (tests, checks)."""
    n = orbit_rate(altitude)
    u, v = orbit_plane(inclination_deg)
    t = np.asarray(t, dtype=float)
    r_hat = np.cos(n * t)[:, None] * u + np.sin(n * t)[:, None] * v
    m_hat = dipole_axis(tilt_deg)
    return field_strength(altitude, field) * (3.0 * (r_hat @ m_hat)[:, None] * r_hat - m_hat)
