"""Row-wise vector arithmetic over the last axis of (..., k) arrays (numpy only): one run's (N, 3)
samples or B runs' (B, N, 3).  One component at a time, in the order ``np.sum`` and
``np.linalg.norm`` add (the same floating-point results): NumPy's reductions and broadcasts over a
last axis of 3 or 4 cost several times the arithmetic itself."""

from __future__ import annotations

import numpy as np


def row_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a·b over the last axis (``np.sum(a * b, axis=-1)``'s result)."""
    total = a[..., 0] * b[..., 0]
    for k in range(1, a.shape[-1]):
        total += a[..., k] * b[..., k]
    return total


def row_norm(x: np.ndarray) -> np.ndarray:
    """|x| over the last axis: ``np.linalg.norm(x, axis=-1)``'s result (``row_dot``'s order)."""
    return np.sqrt(row_dot(x, x))


def unit_rows(x: np.ndarray) -> np.ndarray:
    """x / |x| over the last axis (the same result as dividing by ``np.linalg.norm``), one component at a time.
    A zero row gives NaN without a warning: it has no direction."""
    norm = row_norm(x)
    out = np.empty(x.shape, dtype=norm.dtype)
    with np.errstate(divide="ignore", invalid="ignore"):
        for k in range(x.shape[-1]):
            np.divide(x[..., k], norm, out=out[..., k])
    return out
