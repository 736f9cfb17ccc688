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
    tensor = body.tensor()
    r_c = np.asarray(body.centre(), dtype=float)
    mass = body.total_mass()
    if mass is not None and np.any(r_c != 0.0):
        central = tensor - mass * (np.dot(r_c, r_c) * np.eye(3) - np.outer(r_c, r_c))
        moments, axes = inertia.principal_axes(central)
        if moments[0] > 0.0 and inertia.triangle_violation(moments) is None:
            return Ellipsoid(r_c, _semi_axes(moments, mass), quat.from_matrix(axes))
    moments, axes = inertia.principal_axes(tensor)
    semi = _semi_axes(moments, mass if mass is not None else 1.0)
    if mass is None:  # only the proportions are known: largest semi-axis = 1
        semi = semi / np.max(semi)
    return Ellipsoid(np.zeros(3), semi, quat.from_matrix(axes))


def _semi_axes(moments: np.ndarray, mass: float) -> np.ndarray:
    a, b, c = moments
    squares = 2.5 / mass * np.array([b + c - a, c + a - b, a + b - c])
    floor = 1e-3 * np.max(squares)  # test problems breaking the triangle inequality: a thin disc
    return np.sqrt(np.maximum(squares, floor))


POINT_SIZE = 0.04  # a point mass drawn as a ball of this fraction of the body's size
THIN = 0.02  # a disc's thickness and a rod's radius, as a fraction of its size


def primitives(body: Body, size: float) -> dict[str, dict[str, list]]:
    """A body given by its geometry as the viewer's primitives, body frame (origin at the fixed
    point): "box" (centers, half_sizes), "cylinder" (centers, lengths, radii: along z; discs and
    rods too, thin), "ball" (centers, half_sizes: spheres, and point masses at ``POINT_SIZE`` ×
    ``size``).  Empty for a body given by its moments."""
    from rotlab.config.models import shape_kind

    pieces = [(body.shape, np.zeros(3))] if body.shape is not None else [(p.shape, np.asarray(p.center, dtype=float)) for p in body.parts or []]
    out: dict[str, dict[str, list]] = {}
    pivot = np.asarray(body.pivot, dtype=float)
    for shape, centre in pieces:
        kind, dims = shape_kind(shape)
        at = (centre - pivot).tolist()
        if kind == "box":
            _add(out, "box", centers=at, half_sizes=[0.5 * float(x) for x in dims])
        elif kind in ("cylinder", "disc", "rod"):
            radius = dims["radius"] if kind != "rod" else THIN * float(dims)
            length = dims["length"] if kind == "cylinder" else (THIN * 2.0 * dims["radius"] if kind == "disc" else float(dims))
            _add(out, "cylinder", centers=at, lengths=float(length), radii=float(radius))
        else:
            radius = float(dims) if kind == "sphere" else POINT_SIZE * size
            _add(out, "ball", centers=at, half_sizes=[radius] * 3)
    return out


def _add(out: dict[str, dict[str, list]], kind: str, **fields: object) -> None:
    for name, value in fields.items():
        out.setdefault(kind, {}).setdefault(name, []).append(value)


WHEEL_RADIUS, WHEEL_WIDTH = 0.3, 0.06  # a rotor's disc, as fractions of the body's size


def rotor_wheels(rotors, size: float) -> dict[str, list]:
    """A gyrostat's rotors as the viewer's cylinders, body frame (origin at the fixed point): each a
    disc on its axis at its ``position``, by default just outside the body (``size`` along the axis)."""
    centers, rotations = [], []
    for rotor in rotors:
        axis = rotor.unit_axis()
        centers.append(np.asarray(rotor.position, dtype=float) if rotor.position is not None else size * axis)
        rotations.append(quat.between(np.array([0.0, 0.0, 1.0]), axis))  # the viewer's cylinders lie along z
    return {"centers": centers, "quaternions": rotations, "lengths": [WHEEL_WIDTH * size] * len(centers),
            "radii": [WHEEL_RADIUS * size] * len(centers)}
