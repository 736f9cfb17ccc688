"""Inertia tensors: validation and principal axes.

A physical inertia tensor is symmetric positive definite and its principal moments satisfy the
triangle inequalities A + B ≥ C, B + C ≥ A, C + A ≥ B (each moment is ∫(r² − x_k²) dm, and
x_i² + x_j² ≥ x_k² ... summed over the mass).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

SYMMETRY_RTOL = 1e-9
TRIANGLE_RTOL = 1e-12


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
