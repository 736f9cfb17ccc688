"""Inertia tensors: validation and principal axes.

A physical inertia tensor is symmetric positive definite and its principal moments satisfy the
triangle inequalities A + B ≥ C, B + C ≥ A, C + A ≥ B (each moment is ∫(r² − x_k²) dm, and
x_i² + x_j² ≥ x_k² ... summed over the mass).

Both say one thing: the second-moment tensor S = ∫ r rᵀ dm = ½ tr(I) 𝟙 − I is positive
semidefinite (I = tr(S) 𝟙 − S).  About the centre of mass c (mass m, r_c from the fixed point)
it is S_c = S − m r_c r_cᵀ (the parallel-axis theorem for second moments), which must be
positive semidefinite too: a mass too far out for the moments about the fixed point (or a mass
in grams typed as kilograms) makes it indefinite, and no body has that inertia about its centre.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

SYMMETRY_RTOL = 1e-9
TRIANGLE_RTOL = 1e-12
CENTRE_RTOL = 1e-9  # S_c may fall this far (relative to tr S) below 0: a point mass sits on the bound
MAX_MOMENT_RATIO = 1e12  # principal moments further apart: no body (a 1 m rod 1 µm thick is 2e11)


def asymmetry(tensor: np.ndarray) -> float:
    """max |I − Iᵀ| relative to max |I|."""
    scale = float(np.max(np.abs(tensor))) or 1.0
    return float(np.max(np.abs(tensor - tensor.T))) / scale


def principal_axes(tensor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigen-decomposition I = P diag(m) Pᵀ with ascending moments m and P a proper rotation
    (det P = +1): the columns of P are the principal axes in the user's body frame."""
    sym = 0.5 * (tensor + tensor.T)
    moments, axes = np.linalg.eigh(sym)
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


def triangle_violation(moments: Sequence[float]) -> str | None:
    """The first violated triangle inequality as text (e.g. 'A + B < C'), or None."""
    names = "ABC"
    scale = float(sum(moments))  # (A + B) + C, as np.sum adds three numbers
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        if moments[i] + moments[j] < moments[k] - TRIANGLE_RTOL * scale:
            return f"{names[i]} + {names[j]} < {names[k]} ({moments[i]:g} + {moments[j]:g} < {moments[k]:g})"
    return None


def moment_ratio_violation(moments: Sequence[float]) -> str | None:
    """Why the principal moments are too far apart for any body (None when they are not)."""
    low, high = min(moments), max(moments)
    if high > MAX_MOMENT_RATIO * low:
        return f"the largest principal moment is {high / low:.3g} times the smallest (at most {MAX_MOMENT_RATIO:.0e})"
    return None


def centre_of_mass_violation(tensor: Sequence[Sequence[float]], mass: float, centre: Sequence[float]) -> str | None:
    """Why no body has inertia ``tensor`` about the fixed point with ``mass`` at ``centre`` (m,
    body frame): S_c = ½ tr(I) 𝟙 − I − m r_c r_cᵀ not positive semidefinite (module docstring);
    None when it is.  Plain Python on 3 × 3 (every principal minor ≥ 0): a sweep validates each case."""
    trace = tensor[0][0] + tensor[1][1] + tensor[2][2]
    s = [[(0.5 * trace if i == j else 0.0) - tensor[i][j] - mass * centre[i] * centre[j] for j in range(3)] for i in range(3)]
    scale = 0.5 * trace
    for i in range(3):
        if s[i][i] < -CENTRE_RTOL * scale:
            return f"the second moment of mass about the centre of mass along body axis {'xyz'[i]} is {s[i][i]:.3g} kg·m² < 0"
    minors = [s[i][i] * s[j][j] - s[i][j] ** 2 for i, j in ((0, 1), (1, 2), (0, 2))]
    det = (s[0][0] * (s[1][1] * s[2][2] - s[1][2] ** 2) - s[0][1] * (s[0][1] * s[2][2] - s[1][2] * s[0][2])
           + s[0][2] * (s[0][1] * s[1][2] - s[1][1] * s[0][2]))
    if min(minors) < -CENTRE_RTOL * scale**2 or det < -CENTRE_RTOL * scale**3:
        return "the second moments of mass about the centre of mass are not positive semidefinite"
    return None
