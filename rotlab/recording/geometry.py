"""Static geometry that explains a run in the 3D view.

* the path of the tip of the reference axis (``reference_body_axis``: the symmetry axis of a
  Lagrange top, else the principal axis nearest L(t0) — the spin axis, which flips in the
  Dzhanibekov scene), on a sphere of radius ``reach`` (nutation loops and cusps);
* the field direction, where a uniform field acts;
* torque-free bodies — Poinsot's construction, with ω drawn at the ω-arrow scale s: the
  herpolhode (tip of s·ω in space) lies on the invariable plane ⊥ L at distance s·2T/|L| from
  the fixed point, and the polhode (tip of s·ω in the body frame) on the body's inertia
  ellipsoid ω·Iω = 2T.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rotlab.core import quaternion as quat
from rotlab.trajectory import Trajectory

MAX_PATH_POINTS = 20_000


@dataclass(frozen=True)
class Plane:
    center: np.ndarray
    normal: np.ndarray
    half_size: float


@dataclass(frozen=True)
class Geometry:
    axis_label: str
    axis_body: np.ndarray  # unit, user's body frame
    axis_tips: np.ndarray  # (N, 3) space frame, one per sample
    field_up: np.ndarray | None  # unit "up" (against the field), space frame
    herpolhode: np.ndarray | None  # (M, 3) space frame
    polhode: np.ndarray | None  # (M, 3) user's body frame
    invariable_plane: Plane | None


def reference_body_axis(scene, L0_body: np.ndarray) -> tuple[np.ndarray, str]:
    """(unit axis in the user's body frame, name): the symmetry axis of a Lagrange top; else the
    principal axis nearest L(t0), pointing along it (body z when L(t0) = 0)."""
    axis = reference_body_axes(scene, L0_body[None, :])[0]
    if scene.symmetry_axis is not None:
        return axis, "symmetry axis tip"
    return axis, "spin axis tip" if np.any(L0_body) else "body z tip"


def reference_body_axes(scene, L0_body: np.ndarray) -> np.ndarray:
    """``reference_body_axis`` of each row of ``L0_body`` (B, 3): (B, 3) unit axes."""
    if scene.symmetry_axis is not None:
        return np.broadcast_to(scene.axes @ scene.symmetry_axis, L0_body.shape)
    along = np.einsum("bj,jk->bk", L0_body, scene.axes)  # L(t0) along each principal axis
    k = np.argmax(np.abs(along), axis=-1)
    sign = np.where(np.take_along_axis(along, k[:, None], -1) >= 0.0, 1.0, -1.0)
    nearest = scene.axes.T[k] * sign
    return np.where(np.any(L0_body, axis=-1)[:, None], nearest, np.array([0.0, 0.0, 1.0]))


def scene_geometry(traj: Trajectory, unit_q: np.ndarray, omega_space: np.ndarray, omega_scale: float, reach: float) -> Geometry:
    scene = traj.scene
    axis, label = reference_body_axis(scene, traj.L_body[0] if len(traj.t) else np.zeros(3))
    tips = quat.rotate_to_space_array(unit_q, np.broadcast_to(reach * axis, unit_q.shape[:-1] + (3,)))
    herpolhode = polhode = plane = None
    if scene.kind == "torque_free" and len(traj.t) and np.linalg.norm(traj.L_space[0]) > 0.0:
        stride = max(1, len(traj.t) // MAX_PATH_POINTS)
        herpolhode = omega_space[::stride] * omega_scale
        polhode = traj.omega[::stride] * omega_scale
        l_hat = traj.L_space[0] / np.linalg.norm(traj.L_space[0])
        distance = omega_scale * 2.0 * traj.kinetic[0] / np.linalg.norm(traj.L_space[0])
        extent = float(np.max(np.linalg.norm(herpolhode - distance * l_hat, axis=1))) if len(herpolhode) else 0.0
        plane = Plane(distance * l_hat, l_hat, max(1.2 * extent, 0.3 * reach))
    return Geometry(label, axis, tips, scene.field_direction, herpolhode, polhode, plane)


def decimate(path: np.ndarray) -> np.ndarray:
    return path[:: max(1, len(path) // MAX_PATH_POINTS)]
