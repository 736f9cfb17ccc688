"""Per-case observables of a sweep (user's frames), computed for B runs of one scene at once
(``rotlab.trajectory.Runs``); each is a (B,) array, NaN where not defined.

flip_period_s
    Where the spin component reverses (the intermediate-axis flip): twice the mean time between
    sign changes of ω_a, a = the ``[checks] flip_period`` axis if given, else the body axis with
    the largest |ω(t0)| component (``flip_axes``).  NaN with fewer than 3 reversals.
max_nutation_deg
    max over the run of the angle between the reference body axis e (symmetry axis of a
    Lagrange top; else the principal axis nearest L(t0), signed along it) and the reference space
    direction d ("up" against a uniform field; else L̂(t0), fixed in space for a torque-free body):
    ϑ(t) = arccos(R(t) e · d).  For a Lagrange top this is the largest Euler angle θ.
"""

from __future__ import annotations

import numpy as np

from rotlab.checks import AXES, flip_period
from rotlab.core import quaternion as quat
from rotlab.recording.geometry import reference_body_axes
from rotlab.rows import row_norm, unit_rows
from rotlab.trajectory import Runs

NOT_GIVEN = -1  # in ``flip_axes``: no [checks] flip_period axis, take the largest |ω(t0)| component


def flip_axes(runs: Runs, given: list[str | None]) -> np.ndarray:
    """(B,) the body axis whose ω component each run's flip period is measured on: the ``given``
    axis name ("x", "y", "z") or, where None, the largest |ω(t0)| component."""
    chosen = np.array([NOT_GIVEN if axis is None else AXES[axis] for axis in given], dtype=np.int64)
    if runs.t.shape[0]:
        chosen = np.where(chosen == NOT_GIVEN, np.argmax(np.abs(runs.omega[:, 0]), axis=-1), chosen)
    return chosen


def flips(runs: Runs, axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(period, reversals) of ω along ``axes`` (``flip_axes``) in each run (``checks.flip_period``)."""
    component = np.take_along_axis(runs.omega, np.maximum(axes, 0)[:, None, None], -1)[..., 0]
    return flip_period(runs.t, component)


def reference_axes(runs: Runs) -> tuple[np.ndarray, np.ndarray]:
    """(e, d) of each run, (B, 3) each: the reference body axis (user's body frame) and space
    direction, both unit."""
    scene = runs.scene
    e = reference_body_axes(scene, runs.L_body0)
    if scene.field_direction is not None:
        d = np.broadcast_to(scene.field_direction, e.shape)
    else:
        norm = row_norm(runs.L_space0)[:, None]
        d = np.where(norm > 0.0, runs.L_space0 / np.where(norm > 0.0, norm, 1.0), np.array([0.0, 0.0, 1.0]))
    return unit_rows(e), d


def nutation(runs: Runs) -> np.ndarray:
    """ϑ(t) in radians, (B, N) (module docstring)."""
    return np.arccos(_nutation_cosine(runs))


def _nutation_cosine(runs: Runs) -> np.ndarray:
    """cos ϑ(t) = R(t) e · d, (B, N), clipped to [−1, 1]."""
    e, d = reference_axes(runs)
    principal_e = np.einsum("bj,jk->bk", e, runs.scene.axes)  # R(Λ_user) e = R(Λ_P) Pᵀ e
    return np.clip(quat.projection_array(runs.unit_q, principal_e, d), -1.0, 1.0)


def observables(runs: Runs, flip_period_s: np.ndarray) -> dict[str, np.ndarray]:
    """The observables of each run, (B,) each; ``flip_period_s`` from ``flips``.  The largest ϑ
    is arccos of the smallest cos ϑ (arccos decreases): one arccos per run."""
    if not runs.t.shape[0]:
        nan = np.full(runs.omega.shape[0], np.nan)
        return {"flip_period_s": nan, "max_nutation_deg": nan}
    return {"flip_period_s": flip_period_s, "max_nutation_deg": np.degrees(np.arccos(np.min(_nutation_cosine(runs), axis=-1)))}
