"""Per-case observables of a sweep, from the case's trajectory (user's frames).

flip_period_s
    Where the spin component reverses (the intermediate-axis flip): twice the mean time between
    sign changes of ω_a, a = the ``[checks] flip_period`` axis if given, else the body axis with
    the largest |ω(t0)| component.  Empty (NaN) with fewer than 3 reversals.
max_nutation_deg
    max over the run of the angle between the reference body axis e (symmetry axis of a
    Lagrange top; else the principal axis nearest L(t0), signed along it) and the reference space
    direction d ("up" against a uniform field; else L̂(t0), fixed in space for a torque-free body):
    ϑ(t) = arccos(R(t) e · d).  For a Lagrange top this is the largest Euler angle θ.
"""

from __future__ import annotations

import math

import numpy as np

from rotlab.checks import AXES, flip_times
from rotlab.core import quaternion as quat
from rotlab.recording.geometry import reference_body_axis
from rotlab.trajectory import Trajectory

MIN_REVERSALS = 3


def flip_period(traj: Trajectory) -> float:
    """2 · mean spacing of ω_a's sign changes (s); NaN with fewer than 3 reversals."""
    if not len(traj.t):
        return math.nan
    spec = traj.scene.scenario.checks.flip_period
    axis = AXES[spec.axis] if spec is not None else int(np.argmax(np.abs(traj.omega[0])))
    crossings = flip_times(traj.t, traj.omega[:, axis])
    if crossings.size < MIN_REVERSALS:
        return math.nan
    return 2.0 * float(np.mean(np.diff(crossings)))


def reference_axes(traj: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """(e, d): the reference body axis (user's body frame) and space direction, both unit."""
    scene = traj.scene
    L0_space = traj.L_space[0]
    e, _ = reference_body_axis(scene, traj.L_body[0])
    if scene.field_direction is not None:
        d = scene.field_direction
    elif np.linalg.norm(L0_space) > 0.0:
        d = L0_space / np.linalg.norm(L0_space)
    else:
        d = np.array([0.0, 0.0, 1.0])
    return e / np.linalg.norm(e), d


def nutation(traj: Trajectory) -> np.ndarray:
    """ϑ(t) in radians (see module docstring)."""
    if not len(traj.t):
        return np.zeros(0)
    e, d = reference_axes(traj)
    unit_q_principal = traj._quantities[0]  # R(Λ_user) e = R(Λ_P) Pᵀ e
    return np.arccos(np.clip(quat.projection_array(unit_q_principal, traj.scene.axes.T @ e, d), -1.0, 1.0))


def case_observables(traj: Trajectory) -> dict[str, float]:
    """The observables of one case (NaN where not defined)."""
    theta = nutation(traj)
    return {
        "flip_period_s": flip_period(traj),
        "max_nutation_deg": float(np.degrees(np.max(theta))) if theta.size else math.nan,
    }
