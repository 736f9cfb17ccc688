"""A case's observables reduced as its samples are made (compiled; an ensemble keeps no trajectory).

The same quantities a sweep reports from a stored trajectory (``rotlab.observables``,
``rotlab.invariants``), in the same formulas, one sample at a time (principal frame, unit Λ = Λ/|Λ|):

    flip:      c = a·ω (a: the flip axis row, user's body axis in principal components); a sign
               change of c between samples k, k+1 is a reversal at t_k − c_k (t_{k+1} − t_k)/(c_{k+1} − c_k);
               period = 2 (last − first)/(reversals − 1), NaN with fewer than ``MIN_REVERSALS``
    nutation:  cos ϑ = (R(Λ) e)·d = (2 q0² − 1)(e·d) + 2 (q·e)(q·d) + 2 q0 q·(e × d); max ϑ = arccos min cos ϑ
    drifts:    max |drift| of each invariant of ``rotlab.invariants.TABLE`` (its formulas, ``fold_drifts``),
               from the values at the first sample: L = I ω, L_space = R(Λ) L, T = ½ ω·L,
               V = −Σ F·(R(Λ) p), H = T + V − W.

Per-case inputs (``CASE_*`` columns of ``case``): the flip axis row, e and d, the first sample's
H₀, energy scale, L₀, L_space₀, |L₀|.  Shared (``SHARED_*`` columns of ``shared``): the moments,
the field direction "up" and the symmetry axis (principal frame; zeros where the scene has none).
``applies[k]``: the scene has invariant k (``INVARIANTS`` order).  Results (``ACC_*`` of ``acc``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from rotlab import invariants
from rotlab.core.torques import F_FORCE, F_POINT

# the invariants in the order of ``fold_drifts``'s branches; checked against the table at import
INVARIANTS = ("energy", "quaternion_norm", "L_norm", "L_space", "L_vertical", "L_symmetry")
if INVARIANTS != invariants.NAMES:
    raise TypeError(f"rotlab.ensemble.observe reduces {INVARIANTS}, the invariants table has {invariants.NAMES}: "
                    "give fold_drifts a branch for each invariant, in the table's order")

CASE_FLIP, CASE_E, CASE_D, CASE_H0, CASE_SCALE, CASE_L0, CASE_LS0, CASE_LNORM = 0, 3, 6, 9, 10, 11, 14, 17
CASE_COLUMNS = 18
SHARED_MOMENTS, SHARED_UP, SHARED_SYMMETRY = 0, 3, 6
SHARED_COLUMNS = 9
ACC_REVERSALS, ACC_FIRST, ACC_LAST, ACC_PREV_C, ACC_PREV_T, ACC_MIN_COS, ACC_DRIFT = 0, 1, 2, 3, 4, 5, 6
ACC_COLUMNS = ACC_DRIFT + len(INVARIANTS)
MIN_REVERSALS = 3  # as rotlab.checks.MIN_REVERSALS (checked by tests/test_ensemble.py)


@njit(cache=True, inline="always")
def _to_space(u0, u1, u2, u3, x, y, z):
    """R(Λ) v in ``rotlab.core.quaternion.rotate_to_space_array``'s order."""
    t1, t2, t3 = 2.0 * (u2 * z - u3 * y), 2.0 * (u3 * x - u1 * z), 2.0 * (u1 * y - u2 * x)
    return (x + u0 * t1) + (u2 * t3 - u3 * t2), (y + u0 * t2) + (u3 * t1 - u1 * t3), (z + u0 * t3) + (u1 * t2 - u2 * t1)


@njit(cache=True, inline="always")
def fold_drifts(row, norm, u0, u1, u2, u3, case, shared, applies, forces, acc, drift):
    """acc[ACC_DRIFT + k] ← max(itself, |drift of invariant k at the state ``row``| × its scale) for
    each invariant the scene has (``INVARIANTS`` order; the formulas of ``rotlab.invariants``):
    the division by the scale is left to ``max_drifts`` (once, not once a sample: max |x|/s is
    max |x/s| for s > 0, bit for bit).  |Λ| and Λ/|Λ| given; ``drift``: scratch of len(INVARIANTS)."""
    l1, l2, l3 = row[4] * shared[SHARED_MOMENTS], row[5] * shared[SHARED_MOMENTS + 1], row[6] * shared[SHARED_MOMENTS + 2]
    scale_l = case[CASE_LNORM]
    if applies[0]:  # energy: (T + V − W − H₀)/scale
        kinetic = 0.5 * (row[4] * l1 + row[5] * l2 + row[6] * l3)
        potential = 0.0
        for f in range(forces.shape[0]):
            ax, ay, az = _to_space(u0, u1, u2, u3, forces[f, F_POINT], forces[f, F_POINT + 1], forces[f, F_POINT + 2])
            potential -= ax * forces[f, F_FORCE] + ay * forces[f, F_FORCE + 1] + az * forces[f, F_FORCE + 2]
        total = kinetic + potential if forces.shape[0] else kinetic
        drift[0] = total - row[7] - case[CASE_H0]
    drift[1] = norm - 1.0  # quaternion_norm
    if applies[2]:  # L_norm
        drift[2] = math.sqrt(l1 * l1 + l2 * l2 + l3 * l3) - scale_l
    if applies[3] or applies[4]:
        s1, s2, s3 = _to_space(u0, u1, u2, u3, l1, l2, l3)
        d1, d2, d3 = s1 - case[CASE_LS0], s2 - case[CASE_LS0 + 1], s3 - case[CASE_LS0 + 2]
        if applies[3]:  # L_space
            drift[3] = math.sqrt(d1 * d1 + d2 * d2 + d3 * d3)
        if applies[4]:  # L_vertical
            drift[4] = d1 * shared[SHARED_UP] + d2 * shared[SHARED_UP + 1] + d3 * shared[SHARED_UP + 2]
    if applies[5]:  # L_symmetry
        sym = shared[SHARED_SYMMETRY:SHARED_SYMMETRY + 3]
        drift[5] = (l1 - case[CASE_L0]) * sym[0] + (l2 - case[CASE_L0 + 1]) * sym[1] + (l3 - case[CASE_L0 + 2]) * sym[2]
    for k in range(len(INVARIANTS)):
        if applies[k]:
            acc[ACC_DRIFT + k] = max(acc[ACC_DRIFT + k], abs(drift[k]))


@njit(cache=True, inline="always")
def _nutation_cosine(u0, u1, u2, u3, case):
    """cos ϑ = (R(Λ) e)·d (``rotlab.core.quaternion.projection_array``) for the unit Λ, clipped to [−1, 1]."""
    e, d = case[CASE_E:CASE_E + 3], case[CASE_D:CASE_D + 3]
    ed = e[0] * d[0] + e[1] * d[1] + e[2] * d[2]
    qe = u1 * e[0] + u2 * e[1] + u3 * e[2]
    qd = u1 * d[0] + u2 * d[1] + u3 * d[2]
    c1, c2, c3 = e[1] * d[2] - e[2] * d[1], e[2] * d[0] - e[0] * d[2], e[0] * d[1] - e[1] * d[0]
    qc = u1 * c1 + u2 * c2 + u3 * c3
    return min(1.0, max(-1.0, (2.0 * u0 * u0 - 1.0) * ed + 2.0 * (qe * qd + u0 * qc)))


@njit(cache=True)
def observe_rows(times, rows, start, stop, first, case, shared, applies, forces, acc):
    """Fold samples ``start … stop − 1`` of ``rows`` (at ``times``) into ``acc``; ``first``: row
    ``start`` is the case's first sample (it opens ``acc``)."""
    drift = np.empty(len(INVARIANTS))
    for i in range(start, stop):
        row = rows[i]
        t = times[i]
        c = case[CASE_FLIP] * row[4] + case[CASE_FLIP + 1] * row[5] + case[CASE_FLIP + 2] * row[6]
        if first and i == start:
            acc[ACC_REVERSALS] = 0.0
            acc[ACC_FIRST] = math.nan
            acc[ACC_LAST] = math.nan
            acc[ACC_MIN_COS] = 1.0
            for k in range(len(INVARIANTS)):
                acc[ACC_DRIFT + k] = 0.0
        elif np.sign(c) * np.sign(acc[ACC_PREV_C]) < 0.0:
            c_prev, t_prev = acc[ACC_PREV_C], acc[ACC_PREV_T]
            crossing = t_prev - c_prev * (t - t_prev) / (c - c_prev)
            if acc[ACC_REVERSALS] == 0.0:
                acc[ACC_FIRST] = crossing
            acc[ACC_LAST] = crossing
            acc[ACC_REVERSALS] += 1.0
        acc[ACC_PREV_C] = c
        acc[ACC_PREV_T] = t
        q0, q1, q2, q3 = row[0], row[1], row[2], row[3]
        norm = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)  # (``rotlab.rows.unit_rows``' order)
        u0, u1, u2, u3 = q0 / norm, q1 / norm, q2 / norm, q3 / norm
        acc[ACC_MIN_COS] = min(acc[ACC_MIN_COS], _nutation_cosine(u0, u1, u2, u3, case))
        fold_drifts(row, norm, u0, u1, u2, u3, case, shared, applies, forces, acc, drift)


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


@njit(cache=True)
def flip_period(acc):
    """2 (last − first)/(reversals − 1), NaN with fewer than ``MIN_REVERSALS`` reversals."""
    reversals = acc[ACC_REVERSALS]
    if reversals < MIN_REVERSALS:
        return math.nan
    return 2.0 * (acc[ACC_LAST] - acc[ACC_FIRST]) / max(reversals - 1.0, 1.0)
