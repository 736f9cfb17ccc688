"""Each applied load as the viewer shows it: an arrow at its point of application (space frame)
and its torque over time, from the scene's own load model.

For load i alone, the torque is the one the kernels integrate (``core.torques``, body, principal
frame), evaluated by the compiled ``core.torques.torque_samples`` with a model of load i alone of
the scene model's numba type (``Rigid.each_load``): one specialisation serves every load of a
scene.  How each kind is drawn is its declaration's ``arrow``
(``rotlab.scene.load_kinds``): a force F at body point p as F (space frame) starting at R p,
gravity as m g at R r_c, every other load as its torque M (space frame) at the fixed point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rotlab.core import quaternion as quat
from rotlab.core.torques import torque_samples
from rotlab.recording.style import MAX_3D_LABEL
from rotlab.scene.load_kinds import kind_of

MAX_LOAD_SAMPLES = 20_000  # load arrows drawn per load and run


@dataclass(frozen=True)
class LoadView:
    symbol: str  # 3D label: F1, M2, mg
    kind: str  # "force" (arrow is a force at a point) or "torque" (arrow is a torque at the fixed point)
    conservative: bool  # a constant space-frame force (gravity included): has a potential, no work
    point: np.ndarray | None  # body frame (user's), m — forces only
    force: np.ndarray | None  # N, in ``force_frame``
    force_frame: str  # "space" | "body"
    arrays: object  # LoadArrays of this load alone (principal frame)
    model: object  # the kernels' Model of the same (what the torque is evaluated with)
    description: str


def load_views(scene) -> list[LoadView]:
    """One ``LoadView`` per load of the scenario, in the order written."""
    out = []
    counts: dict[str, int] = {}
    for load, (alone, model) in zip(scene.rigid.specs, scene.rigid.each_load):
        arrow = kind_of(load).arrow(load, scene.rigid.body)
        counts[arrow.letter] = number = counts.get(arrow.letter, 0) + 1
        out.append(LoadView(_symbol(arrow.letter, number) if arrow.numbered else arrow.letter, arrow.shows, len(alone.forces) > 0,
                            None if arrow.point is None else np.asarray(arrow.point, float), arrow.force, arrow.frame, alone, model,
                            arrow.description.format(number=number)))
    return out


def _symbol(letter: str, number: int) -> str:
    """The 3D label of the ``number``-th load of a kind (F1, M2); past 99, "M+" (the Run tab lists
    every load: a 3D label is at most ``MAX_3D_LABEL`` characters)."""
    text = f"{letter}{number}"
    return text if len(text) <= MAX_3D_LABEL else f"{letter}+"


def torques(scene, view: LoadView, t: np.ndarray, q_p: np.ndarray, w_p: np.ndarray) -> np.ndarray:
    """(N, 3) torque of one load, principal body frame, at the given samples (principal state)."""
    out = np.empty((t.shape[0], 3))
    torque_samples(np.ascontiguousarray(t, dtype=np.float64), np.ascontiguousarray(q_p), np.ascontiguousarray(w_p), view.model, out)
    return out


def principal_state(scene, quaternion_user: np.ndarray, omega_user: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Λ_P, ω_P) from the user's-frame series: Λ_P = Λ_U ∘ Λ_axes, ω_P = axesᵀ ω_U."""
    q_p = quat.multiply_array(quaternion_user, np.broadcast_to(scene.axes_quaternion, quaternion_user.shape))
    return q_p, omega_user @ scene.axes


def sample_stride(scene) -> int:
    """Evaluate loads at every k-th sample so that a run costs at most MAX_LOAD_SAMPLES calls per load."""
    return max(1, -(-scene.scenario.time.sample_count // MAX_LOAD_SAMPLES))
