"""Shared test helpers: scenarios from dicts, and the axisymmetric torque-free closed form."""

from __future__ import annotations

from typing import Any

import numpy as np

from rotlab.config import parse_scenario
from rotlab.config.models import Scenario
from rotlab.core import quaternion as quat


def scenario(**sections: Any) -> Scenario:
    """A validated scenario from keyword sections, e.g. scenario(body={...}, time={...})."""
    data: dict[str, Any] = {"time": {"end": 1.0}}
    data.update(sections)
    return parse_scenario(data)


def axisymmetric_free_body(a: float, c: float, omega0: np.ndarray, q0: np.ndarray, t: np.ndarray):
    """Exact torque-free motion of a body with moments (A, A, C), principal frame.

    ω:  p + i q = (p₀ + i q₀) e^{iΩt},  r = r₀,  Ω = (C − A) r₀ / A
    Λ:  Λ(t) = Λ(l̂, |L| t / A) ∘ Λ₀ ∘ Λ(e₃, −Ω t),  l̂ = R(Λ₀) L₀ / |L₀|  (space frame)
    (derivation: Ṙ = (|L|/A)[l̂]× R − Ω R [e₃]× gives ω_body = L_body/A − Ω e₃ = (p, q, r)).
    """
    p0, q0_, r0 = omega0
    big_omega = (c - a) * r0 / a
    rot = (p0 + 1j * q0_) * np.exp(1j * big_omega * t)
    omega = np.column_stack([rot.real, rot.imag, np.full_like(t, r0)])
    L0 = np.array([a * p0, a * q0_, c * r0])
    l_space = quat.rotate_to_space_array(q0, L0)
    norm_L = np.linalg.norm(L0)
    e3 = np.array([0.0, 0.0, 1.0])
    precession = np.array([quat.from_axis_angle(l_space, norm_L * s / a) for s in t])
    spin_back = np.array([quat.from_axis_angle(e3, -big_omega * s) for s in t])
    q = quat.multiply_array(quat.multiply_array(precession, np.broadcast_to(q0, (len(t), 4))), spin_back)
    return q, omega


def same_rotation_error(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """|qa − qb| up to the sign ambiguity of unit quaternions (±Λ is the same rotation)."""
    return np.minimum(np.linalg.norm(qa - qb, axis=-1), np.linalg.norm(qa + qb, axis=-1))


def heap_free_after_a_large_temporary() -> int:
    """Bytes glibc's heap holds free after a 4 MB NumPy array is made and dropped (``mallinfo2``):
    ~4 MB when the heap is kept (``rotlab.heap.keep_heap``), ~0 when the block was mapped and
    given back (glibc's defaults)."""
    import ctypes

    class MallInfo2(ctypes.Structure):
        _fields_ = [(name, ctypes.c_size_t) for name in
                    ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]

    mallinfo2 = ctypes.CDLL(None).mallinfo2
    mallinfo2.restype = MallInfo2
    temporary = np.ones(1 << 19)
    del temporary
    return int(mallinfo2().fordblks)
