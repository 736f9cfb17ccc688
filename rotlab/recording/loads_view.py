"""Each applied load as the viewer shows it: an arrow at its point of application (space frame)
and its torque over time, from the scene's own load model.

For load i alone, the torque is the one the kernels integrate: ``core.torques`` applied to the
model of a scenario holding load i only (body, principal frame),
    M_i = conservative_torque(y, model_i) + nonconservative_torque(t, y, model_i).
The plain load kinds (forces, torque terms, tables, damping) are evaluated with NumPy over all
samples at once (``array_torques``, the same formulas as ``core.torques``: its tests pin them to
the compiled ones): compiling that kernel once per load kind took ~5 s of a first general.toml
run, more than its stepping kernel.  Expression loads and Python torques use the compiled kernel.
Arrows: a force F at body point p is drawn as F (space frame) starting at R p; gravity as m g at
R r_c; every other load as its torque M (space frame) starting at the fixed point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from rotlab.config import models as cfg
from rotlab.core import quaternion as quat
from rotlab.core.state import STATE_SIZE
from rotlab.core.torques import conservative_torque, nonconservative_torque
from rotlab.recording.style import MAX_3D_LABEL
from rotlab.scene.loads import LoadArrays, build_model, compile_loads

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
    """One ``LoadView`` per load of the scenario, in the order written (built once per scene)."""
    return scene.cached("recording.load_views", lambda: _build(scene))


def _build(scene) -> list[LoadView]:
    scenario = scene.scenario
    out = []
    n_force = n_torque = 0
    for load in scenario.loads:
        alone = compile_loads(scenario.model_copy(update={"loads": [load]}), scene.axes, scene.moments, None)
        kind_name = getattr(load, "type", type(load).__name__.lower())
        frame = getattr(load, "frame", "space")
        if isinstance(load, cfg.Gravity):
            mass = scenario.body.mass or 0.0
            out.append(LoadView("mg", "force", True, np.asarray(scenario.body.center_of_mass, float),
                                mass * np.asarray(load.g, float), "space", alone, build_model(alone, scene.moments), "gravity m·g at the centre of mass (space frame)"))
        elif isinstance(load, cfg.Force):
            n_force += 1
            out.append(LoadView(_symbol("F", n_force), "force", frame == "space", np.asarray(load.point, float),
                                np.asarray(load.value, float), frame, alone, build_model(alone, scene.moments), f"force {n_force} ({frame} frame) at its point"))
        else:
            n_torque += 1
            out.append(LoadView(_symbol("M", n_torque), "torque", False, None, None, frame, alone, build_model(alone, scene.moments),
                                f"{kind_name} ({frame} frame), drawn at the fixed point"))
    return out


def _symbol(letter: str, number: int) -> str:
    """The 3D label of the ``number``-th load of a kind (F1, M2); past 99, "M+" (the Run tab lists
    every load: a 3D label is at most ``MAX_3D_LABEL`` characters)."""
    text = f"{letter}{number}"
    return text if len(text) <= MAX_3D_LABEL else f"{letter}+"


def compiled(view: LoadView) -> bool:
    """Is the load evaluated by the numba kernel ``_torques`` (expressions, a Python torque)
    rather than by NumPy (``array_torques``)?"""
    return view.arrays.expressions is not None or view.arrays.user is not None


def torques(scene, view: LoadView, t: np.ndarray, q_p: np.ndarray, w_p: np.ndarray) -> np.ndarray:
    """(N, 3) torque of one load, principal body frame, at the given samples (principal state)."""
    if not compiled(view):
        return array_torques(view.arrays, np.asarray(t, dtype=np.float64), q_p, w_p)
    out = np.empty((t.shape[0], 3))
    _torques(np.ascontiguousarray(t, dtype=np.float64), np.ascontiguousarray(q_p), np.ascontiguousarray(w_p), view.model, out)
    return out


def array_torques(loads: LoadArrays, t: np.ndarray, q_p: np.ndarray, w_p: np.ndarray) -> np.ndarray:
    """(N, 3) torque of the forces, torque terms, tables and damping of ``loads`` (not
    expressions or Python torques), principal body frame, at N samples, as ``core.torques``:
        forces  Σ p × (Rᵀ F)
        terms   offset + amplitude sin(w t + φ) for on ≤ t < off, Rᵀ M in the space frame
        tables  piecewise-linear in t for on ≤ t < off and first knot ≤ t < last knot
        damping −k ω."""
    out = np.zeros((t.shape[0], 3))
    for p_x, p_y, p_z, *force in loads.forces:
        out += quat.cross_array(np.array([p_x, p_y, p_z]), quat.rotate_to_body_array(q_p, np.array(force)))
    for frame, on, off, *rest in loads.terms:
        offset, amplitude, (w, phase) = np.array(rest[:3]), np.array(rest[3:6]), rest[6:]
        m = offset + amplitude * np.sin(w * t + phase)[:, None] if w != 0.0 else np.broadcast_to(offset, (t.shape[0], 3))
        out += _acting(t, on, off, _in_body(q_p, frame, m))
    for frame, on, off, first, stop in loads.tables:
        tt, tv = loads.table_t[int(first) : int(stop)], loads.table_v[int(first) : int(stop)]
        lo = np.clip(np.searchsorted(tt, t, side="right") - 1, 0, len(tt) - 2)
        s = (t - tt[lo]) / (tt[lo + 1] - tt[lo])
        m = tv[lo] + s[:, None] * (tv[lo + 1] - tv[lo])
        out += _acting(t, max(on, tt[0]), min(off, tt[-1]), _in_body(q_p, frame, m))
    if loads.damping > 0.0:
        out += -loads.damping * w_p
    return out


def _in_body(q_p: np.ndarray, frame: float, m: np.ndarray) -> np.ndarray:
    """Body components of vectors given in the body (frame 0) or the space frame (Rᵀ M)."""
    return quat.rotate_to_body_array(q_p, m) if frame != 0.0 else m


def _acting(t: np.ndarray, on: float, off: float, m: np.ndarray) -> np.ndarray:
    """``m`` where on ≤ t < off, else 0."""
    return np.where(((on <= t) & (t < off))[:, None], m, 0.0)


@njit(cache=True)
def _torques(t, q_p, w_p, model, out):
    """out[k] = the torque of ``model``'s loads at sample k (see module docstring)."""
    y = np.zeros(STATE_SIZE)
    for k in range(t.shape[0]):
        for i in range(4):
            y[i] = q_p[k, i]
        for i in range(3):
            y[4 + i] = w_p[k, i]
        cx, cy, cz = conservative_torque(y, model)
        nx, ny, nz = nonconservative_torque(t[k], y, model)
        out[k, 0], out[k, 1], out[k, 2] = cx + nx, cy + ny, cz + nz


def principal_state(scene, quaternion_user: np.ndarray, omega_user: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Λ_P, ω_P) from the user's-frame series: Λ_P = Λ_U ∘ Λ_axes, ω_P = axesᵀ ω_U."""
    q_p = quat.multiply_array(quaternion_user, np.broadcast_to(scene.axes_quaternion, quaternion_user.shape))
    return q_p, omega_user @ scene.axes


def sample_stride(scene) -> int:
    """Evaluate loads at every k-th sample so that a run costs at most MAX_LOAD_SAMPLES calls per load."""
    return max(1, -(-scene.scenario.time.sample_count // MAX_LOAD_SAMPLES))
