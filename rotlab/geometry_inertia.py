"""Inertia of bodies described by their geometry: the textbook moments of uniform solids about
their centres (own axes: a box's edges along x, y, z; a cylinder's, disc's and rod's axis along z)
and the parallel-axis theorem to the fixed point,

    I_O = Σ_parts [ I_c + m (|d|² 𝟙 − d dᵀ) ],   d = the part's centre − the fixed point,

    box a×b×c:          m/12 · diag(b² + c², a² + c², a² + b²)
    cylinder r, L:      diag(m(3r² + L²)/12, m(3r² + L²)/12, m r²/2)
    sphere r (solid):   2/5 m r² 𝟙
    thin disc r:        diag(m r²/4, m r²/4, m r²/2)
    thin rod L:         diag(m L²/12, m L²/12, 0)
    point:              0

(Goldstein, Poole & Safko, "Classical Mechanics", 3rd ed., §5.3 and its table.)  Lengths in m,
masses in kg; the result in kg·m², in the body frame whose origin is the fixed point.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

SHAPES = ("box", "cylinder", "sphere", "disc", "rod", "point")


def central_inertia(kind: str, size: dict[str, float] | Sequence[float] | float | bool, mass: float) -> np.ndarray:
    """The inertia (kg·m²) of a uniform ``kind`` of ``mass`` about its centre, in its own axes."""
    if kind == "box":
        a, b, c = (float(x) for x in size)  # type: ignore[union-attr]
        return mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])
    if kind == "cylinder":
        r, length = float(size["radius"]), float(size["length"])  # type: ignore[index]
        across = mass * (3.0 * r * r + length * length) / 12.0
        return np.diag([across, across, 0.5 * mass * r * r])
    if kind == "sphere":
        r = float(size)  # type: ignore[arg-type]
        return 0.4 * mass * r * r * np.eye(3)
    if kind == "disc":
        r = float(size["radius"])  # type: ignore[index]
        return mass * r * r * np.diag([0.25, 0.25, 0.5])
    if kind == "rod":
        length = float(size)  # type: ignore[arg-type]
        return mass * length * length / 12.0 * np.diag([1.0, 1.0, 0.0])
    if kind == "point":
        return np.zeros((3, 3))
    raise ValueError(f"unknown shape {kind!r}")


def shifted(central: np.ndarray, mass: float, d: np.ndarray) -> np.ndarray:
    """The parallel-axis theorem: the inertia about a point at −d from the centre (d = centre − point)."""
    return central + mass * (float(d @ d) * np.eye(3) - np.outer(d, d))


def about_pivot(parts: Sequence[tuple[str, object, float, np.ndarray]], pivot: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(inertia about ``pivot`` (3×3), centre of mass from ``pivot`` (m), total mass) of ``parts``
    (kind, size, mass, centre), positions in one frame."""
    total = sum(m for _, _, m, _ in parts)
    tensor = np.zeros((3, 3))
    moment = np.zeros(3)
    for kind, size, m, centre in parts:
        d = np.asarray(centre, dtype=float) - pivot
        tensor += shifted(central_inertia(kind, size, m), m, d)
        moment += m * d
    return tensor, moment / total, total


def describe(body) -> list[str]:
    """Report lines ("- …") of what ``about_pivot`` computed for a body given by its geometry
    (``config.models.Body.geometry``): none for one given by its moments (run report, ``rotlab validate``)."""
    computed = body.geometry()
    if computed is None:
        return []
    tensor, centre, mass = computed
    rows = "; ".join(np.array2string(row, precision=6, separator=", ") for row in tensor)
    return [f"- body from its {'shape' if body.shape is not None else f'{len(body.parts)} parts'}: mass {mass:.6g} kg, centre of mass "
            f"{np.array2string(centre, precision=6, separator=', ')} m from the fixed point; inertia about it [{rows}] kg·m² (body frame)"]
