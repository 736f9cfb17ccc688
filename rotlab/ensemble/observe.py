"""A case's observables reduced as its samples are made (compiled; an ensemble keeps no trajectory).

The same quantities a sweep reports from a stored trajectory (``rotlab.observables``,
``rotlab.invariants``), in the same formulas, one sample at a time (principal frame, unit Λ = Λ/|Λ|):

    flip:      c = a·ω (a: the flip axis row, user's body axis in principal components); a sign
               change of c between samples k, k+1 is a reversal at t_k − c_k (t_{k+1} − t_k)/(c_{k+1} − c_k);
               the first and last crossing times and the count are folded; the period is
               ``rotlab.checks.period_of`` of them
    nutation:  cos ϑ = (R(Λ) e)·d = (2 q0² − 1)(e·d) + 2 (q·e)(q·d) + 2 q0 q·(e × d); max ϑ = arccos min cos ϑ
    drifts:    max |drift| of each invariant of ``rotlab.invariants.TABLE`` (its formulas, ``drifts_at``),
               from the values at the first sample: L = I ω + h, L_space = R(Λ) L, T = ½ ω·I ω,
               V = −Σ F·(R(Λ) p), H = T + V − W.

Per-case inputs (``CASE_*`` columns of ``case``): the flip axis row, e and d, the first sample's
H₀, energy scale, L₀, L_space₀, |L₀|.  Shared (``SHARED_*`` columns of ``shared``): the moments,
the field direction "up", the symmetry axis and a gyrostat's rotors' h (principal frame; zeros
where the scene has none).
``applies[k]``: the scene has invariant k (``INVARIANTS`` order).  Results (``ACC_*`` of ``acc``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from rotlab import invariants
from rotlab.core.quaternion import rotate_to_space
from rotlab.core.targets import on_gpu, work_matrix
from rotlab.core.torques import F_FORCE, F_POINT

# the invariants in the order of ``drifts_at``'s values; checked against the table at import
INVARIANTS = ("energy", "quaternion_norm", "L_norm", "L_space", "L_vertical", "L_symmetry")
if INVARIANTS != invariants.NAMES:
    raise TypeError(f"rotlab.ensemble.observe reduces {INVARIANTS}, the invariants table has {invariants.NAMES}: "
                    "give drifts_at a value for each invariant, in the table's order")

CASE_FLIP, CASE_E, CASE_D, CASE_H0, CASE_SCALE, CASE_L0, CASE_LS0, CASE_LNORM = 0, 3, 6, 9, 10, 11, 14, 17
CASE_COLUMNS = 18
SHARED_MOMENTS, SHARED_UP, SHARED_SYMMETRY, SHARED_ROTORS = 0, 3, 6, 9
SHARED_COLUMNS = 12
ACC_REVERSALS, ACC_FIRST, ACC_LAST, ACC_PREV_C, ACC_PREV_T, ACC_MIN_COS, ACC_DRIFT = 0, 1, 2, 3, 4, 5, 6
ACC_COLUMNS = ACC_DRIFT + len(INVARIANTS)


class Constants(NamedTuple):
    """One case's ``case`` and ``shared`` inputs as numbers (``constants_of``, once per case): the
    samples' loop passes only numbers and tuples (an array passed to a compiled function costs
    two atomic reference-count updates a call, ~70 ns a sample on the CPU)."""

    flip_axis: tuple[float, float, float]  # a
    e: tuple[float, float, float]
    d: tuple[float, float, float]
    moments: tuple[float, float, float]
    rotors: tuple[float, float, float]  # h
    up: tuple[float, float, float]
    symmetry: tuple[float, float, float]
    energy0: float  # H₀
    L0: tuple[float, float, float]
    L_space0: tuple[float, float, float]
    L_norm0: float  # |L₀|
    applies: tuple[bool, bool, bool, bool, bool, bool]


@njit(cache=True, inline="always")
def _triple(a, k):
    return a[k], a[k + 1], a[k + 2]


@njit(cache=True)
def constants_of(case, shared, applies):
    """``Constants`` of one case (its row of ``case``)."""
    return Constants(_triple(case, CASE_FLIP), _triple(case, CASE_E), _triple(case, CASE_D), _triple(shared, SHARED_MOMENTS), _triple(shared, SHARED_ROTORS), _triple(shared, SHARED_UP),
                     _triple(shared, SHARED_SYMMETRY), case[CASE_H0], _triple(case, CASE_L0), _triple(case, CASE_LS0),
                     case[CASE_LNORM], (applies[0], applies[1], applies[2], applies[3], applies[4], applies[5]))


@njit(cache=True, inline="always")
def drifts_at(w1, w2, w3, work, potential, has_forces, norm, u0, u1, u2, u3, k):
    """|drift| × its scale of each invariant (``INVARIANTS`` order; 0 where the scene has none) at
    the state (Λ, ω, W) — the formulas of ``rotlab.invariants``, the division by the scale left
    to ``max_drifts`` (once, not once a sample: max |x|/s is max |x/s| for s > 0, bit for bit).
    |Λ|, Λ/|Λ| and V = −Σ F·(R(Λ) p) (``has_forces``: the scene has forces) given; ``k``: the
    case's ``Constants``."""
    l1, l2, l3 = w1 * k.moments[0], w2 * k.moments[1], w3 * k.moments[2]
    energy = l_norm = l_space = l_vertical = l_symmetry = 0.0
    if k.applies[0]:  # energy: T + V − W − H₀
        kinetic = 0.5 * (w1 * l1 + w2 * l2 + w3 * l3)  # (I ω, before h is added)
        total = kinetic + potential if has_forces else kinetic
        energy = abs(total - work - k.energy0)
    l1, l2, l3 = l1 + k.rotors[0], l2 + k.rotors[1], l3 + k.rotors[2]  # L = I ω + h
    if k.applies[2]:  # L_norm: |L| − |L₀|
        l_norm = abs(math.sqrt(l1 * l1 + l2 * l2 + l3 * l3) - k.L_norm0)
    if k.applies[3] or k.applies[4]:
        s1, s2, s3 = rotate_to_space(u0, u1, u2, u3, l1, l2, l3)
        d1, d2, d3 = s1 - k.L_space0[0], s2 - k.L_space0[1], s3 - k.L_space0[2]
        if k.applies[3]:  # L_space: |L_space − L_space₀|
            l_space = math.sqrt(d1 * d1 + d2 * d2 + d3 * d3)
        if k.applies[4]:  # L_vertical: (L_space − L_space₀)·up
            l_vertical = abs(d1 * k.up[0] + d2 * k.up[1] + d3 * k.up[2])
    if k.applies[5]:  # L_symmetry: (L − L₀)·e
        e = k.symmetry
        l_symmetry = abs((l1 - k.L0[0]) * e[0] + (l2 - k.L0[1]) * e[1] + (l3 - k.L0[2]) * e[2])
    return energy, abs(norm - 1.0), l_norm, l_space, l_vertical, l_symmetry  # quaternion_norm: |Λ| − 1


@njit(cache=True, inline="always")
def _lower(m, x):
    """min(m, x) as ``np.min`` folds it: a NaN, once seen, stays (numba's ``min`` drops one)."""
    return x if x != x else min(m, x)  # (numba's min(NaN, x) is NaN: only a NaN x needs the test)


@njit(cache=True, inline="always")
def _higher(m, x):
    """max(m, x) as ``np.max`` folds it: a NaN, once seen, stays."""
    return x if x != x else max(m, x)


@njit(cache=True, inline="always")
def _nutation_cosine(u0, u1, u2, u3, e, d):
    """cos ϑ = (R(Λ) e)·d (``rotlab.core.quaternion.projection_array``) for the unit Λ, clipped to [−1, 1] as ``np.clip`` clips."""
    e0, e1, e2 = e
    d0, d1, d2 = d
    ed = e0 * d0 + e1 * d1 + e2 * d2
    qe = u1 * e0 + u2 * e1 + u3 * e2
    qd = u1 * d0 + u2 * d1 + u3 * d2
    c1, c2, c3 = e1 * d2 - e2 * d1, e2 * d0 - e0 * d2, e0 * d1 - e1 * d0
    qc = u1 * c1 + u2 * c2 + u3 * c3
    return _lower(1.0, _higher(-1.0, (2.0 * u0 * u0 - 1.0) * ed + 2.0 * (qe * qd + u0 * qc)))  # (NaN kept, as np.clip keeps it)


@njit(cache=True, inline="always")
def _unit(q0, q1, q2, q3):
    """|Λ| and Λ/|Λ| (``rotlab.rows.unit_rows``' order)."""
    norm = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    return norm, q0 / norm, q1 / norm, q2 / norm, q3 / norm


@njit(cache=True, inline="always")
def _force_term(u0, u1, u2, u3, forces, f):
    """F·(R(Λ) p) of force f (V = −Σ of them over the forces, in their order)."""
    ax, ay, az = rotate_to_space(u0, u1, u2, u3, forces[f, F_POINT], forces[f, F_POINT + 1], forces[f, F_POINT + 2])
    return ax * forces[f, F_FORCE] + ay * forces[f, F_FORCE + 1] + az * forces[f, F_FORCE + 2]


@njit(cache=True, inline="always")
def _values(norm, u0, u1, u2, u3, w1, w2, w3, work, potential, has_forces, k):
    """One sample's (c = a·ω, cos ϑ, the six drifts of ``drifts_at``)."""
    a0, a1, a2 = k.flip_axis
    d0, d1, d2, d3, d4, d5 = drifts_at(w1, w2, w3, work, potential, has_forces, norm, u0, u1, u2, u3, k)
    return a0 * w1 + a1 * w2 + a2 * w3, _nutation_cosine(u0, u1, u2, u3, k.e, k.d), d0, d1, d2, d3, d4, d5


@njit(cache=True, inline="always")
def _fold(folded, t, opening, c, cos, d0, d1, d2, d3, d4, d5):
    """``folded`` (reversals, first and last crossing, min cos ϑ, the last c and t, the six max
    drifts) after the sample at ``t`` (``opening``: the case's first sample, no crossing before it)."""
    reversals, first_t, last_t, min_cos, c_prev, t_prev, m0, m1, m2, m3, m4, m5 = folded
    if not opening and ((c > 0.0 and c_prev < 0.0) or (c < 0.0 and c_prev > 0.0)):  # (signs opposite, neither 0)
        crossing = t_prev - c_prev * (t - t_prev) / (c - c_prev)
        if reversals == 0.0:
            first_t = crossing
        last_t = crossing
        reversals += 1.0
    return (reversals, first_t, last_t, _lower(min_cos, cos), c, t, _higher(m0, d0), _higher(m1, d1), _higher(m2, d2), _higher(m3, d3),
            _higher(m4, d4), _higher(m5, d5))


@njit(cache=True, error_model="numpy")  # (as ``_fold_blocks``)
def _fold_samples(times, rows, start, stop, first, k, forces, folded):
    """``_fold`` of samples ``start … stop − 1``, one after the other (a GPU's way: it folds one
    sample a call, from a thread's two rows)."""
    has_forces = forces.shape[0] > 0
    for i in range(start, stop):
        norm, u0, u1, u2, u3 = _unit(rows[i, 0], rows[i, 1], rows[i, 2], rows[i, 3])
        potential = 0.0
        for f in range(forces.shape[0]):
            potential -= _force_term(u0, u1, u2, u3, forces, f)
        c, cos, d0, d1, d2, d3, d4, d5 = _values(norm, u0, u1, u2, u3, rows[i, 4], rows[i, 5], rows[i, 6], rows[i, 7], potential,
                                                 has_forces, k)
        folded = _fold(folded, times[i], first and i == start, c, cos, d0, d1, d2, d3, d4, d5)
    return folded


BLOCK = 64  # samples a pass of ``_fold_blocks`` (its scratch: 18 × 64 doubles, 9 kB)


@njit(cache=True, error_model="numpy")  # (no division-by-0 test: every row folded passed ``state_status``, |Λ| ≥ 1.5e-154)
def _fold_blocks(times, rows, start, stop, first, k, forces, folded):
    """``_fold`` of samples ``start … stop − 1``, BLOCK at a time: the rows' columns copied into
    one array each, then a pass for Λ/|Λ|, one for each force's term and one for ``_values``, with
    no branch between samples (the CPU runs each as vector instructions, 8 samples at a time:
    ~2.3× faster than ``_fold_samples``, whose loop reads a sample's 8 values side by side in a
    row), then the folds, sample by sample: ``_fold_samples``' result, bit for bit."""
    x = work_matrix(18, BLOCK)  # 0–7: Λ (then Λ/|Λ|), ω, W; 8: |Λ|; 9: V; 10–17: ``_values``
    has_forces = forces.shape[0] > 0
    for b in range(start, stop, BLOCK):
        m = min(BLOCK, stop - b)
        for j in range(m):
            for col in range(8):
                x[col, j] = rows[b + j, col]
        for j in range(m):
            x[8, j], x[0, j], x[1, j], x[2, j], x[3, j] = _unit(x[0, j], x[1, j], x[2, j], x[3, j])
            x[9, j] = 0.0
        for f in range(forces.shape[0]):
            for j in range(m):
                x[9, j] -= _force_term(x[0, j], x[1, j], x[2, j], x[3, j], forces, f)
        for j in range(m):
            x[10, j], x[11, j], x[12, j], x[13, j], x[14, j], x[15, j], x[16, j], x[17, j] = _values(
                x[8, j], x[0, j], x[1, j], x[2, j], x[3, j], x[4, j], x[5, j], x[6, j], x[7, j], x[9, j], has_forces, k)
        for j in range(m):
            folded = _fold(folded, times[b + j], first and b + j == start, x[10, j], x[11, j], x[12, j], x[13, j], x[14, j], x[15, j],
                           x[16, j], x[17, j])
    return folded


@njit(cache=True, error_model="numpy")  # (as ``_fold_blocks``)
def observe_rows(times, rows, start, stop, first, k, forces, acc):
    """Fold samples ``start … stop − 1`` of ``rows`` (at ``times``) into ``acc``; ``first``: row
    ``start`` is the case's first sample (it opens ``acc``); ``k``: the case's ``Constants``.  The
    running values are kept in locals and stored once.  On the CPU in blocks (``_fold_blocks``), on
    a GPU sample by sample (``_fold_samples``): the same values, bit for bit."""
    if first:
        acc[ACC_REVERSALS], acc[ACC_FIRST], acc[ACC_LAST], acc[ACC_MIN_COS] = 0.0, math.nan, math.nan, 1.0
        for j in range(len(INVARIANTS)):
            acc[ACC_DRIFT + j] = 0.0
    folded = (acc[ACC_REVERSALS], acc[ACC_FIRST], acc[ACC_LAST], acc[ACC_MIN_COS], acc[ACC_PREV_C], acc[ACC_PREV_T], acc[ACC_DRIFT],
              acc[ACC_DRIFT + 1], acc[ACC_DRIFT + 2], acc[ACC_DRIFT + 3], acc[ACC_DRIFT + 4], acc[ACC_DRIFT + 5])
    if on_gpu():
        folded = _fold_samples(times, rows, start, stop, first, k, forces, folded)
    else:
        folded = _fold_blocks(times, rows, start, stop, first, k, forces, folded)
    (acc[ACC_REVERSALS], acc[ACC_FIRST], acc[ACC_LAST], acc[ACC_MIN_COS], acc[ACC_PREV_C], acc[ACC_PREV_T], acc[ACC_DRIFT],
     acc[ACC_DRIFT + 1], acc[ACC_DRIFT + 2], acc[ACC_DRIFT + 3], acc[ACC_DRIFT + 4], acc[ACC_DRIFT + 5]) = folded


SCALED_BY = (CASE_SCALE, -1, CASE_LNORM, CASE_LNORM, CASE_LNORM, CASE_LNORM)  # each invariant's scale column (−1: none)


def max_drifts(acc: np.ndarray, case: np.ndarray) -> np.ndarray:
    """(B, len(INVARIANTS)) max |relative drift| of each case: the folded maxima divided by their
    scale where it is positive (``rotlab.invariants._relative``)."""
    out = acc[:, ACC_DRIFT:ACC_DRIFT + len(INVARIANTS)].copy()
    for k, column in enumerate(SCALED_BY):
        if column >= 0:
            scale = case[:, column]
            np.divide(out[:, k], scale, out=out[:, k], where=scale > 0.0)
    return out
