"""A body shape that matches the inertia: the equivalent uniform solid ellipsoid.

A uniform ellipsoid of mass m and semi-axes (a, b, c) has central principal moments
A = m(b² + c²)/5, B = m(c² + a²)/5, C = m(a² + b²)/5, hence a² = 5(B + C − A)/(2m), ...
With a mass and an offset centre of mass r_c, the central inertia is
I_c = I_O − m(|r_c|² E − r_c r_cᵀ) (parallel-axis theorem) and the ellipsoid sits at r_c;
otherwise the ellipsoid of I_O is centred on the fixed point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rotlab.config.models import Body
from rotlab.core import quaternion as quat
from rotlab import inertia


@dataclass(frozen=True)
class Ellipsoid:
    center: np.ndarray  # body frame, m
    half_sizes: np.ndarray  # semi-axes along its own axes
    orientation: np.ndarray  # Λ of its axes in the body frame, scalar first

    @property
    def size(self) -> float:
        return float(np.linalg.norm(self.center) + np.max(self.half_sizes))


def equivalent_ellipsoid(body: Body) -> Ellipsoid:
    tensor = np.diag(body.principal_moments) if body.principal_moments is not None else np.array(body.inertia_tensor)
    r_c = np.asarray(body.center_of_mass, dtype=float)
    if body.mass is not None and np.any(r_c != 0.0):
        central = tensor - body.mass * (np.dot(r_c, r_c) * np.eye(3) - np.outer(r_c, r_c))
        moments, axes = inertia.principal_axes(central)
        if moments[0] > 0.0 and inertia.triangle_violation(moments) is None:
            return Ellipsoid(r_c, _semi_axes(moments, body.mass), quat.from_matrix(axes))
    moments, axes = inertia.principal_axes(tensor)
    semi = _semi_axes(moments, body.mass if body.mass is not None else 1.0)
    if body.mass is None:  # only the proportions are known: largest semi-axis = 1
        semi = semi / np.max(semi)
    return Ellipsoid(np.zeros(3), semi, quat.from_matrix(axes))


def _semi_axes(moments: np.ndarray, mass: float) -> np.ndarray:
    a, b, c = moments
    squares = 2.5 / mass * np.array([b + c - a, c + a - b, a + b - c])
    floor = 1e-3 * np.max(squares)  # test problems breaking the triangle inequality: a thin disc
    return np.sqrt(np.maximum(squares, floor))
