"""Peers: what users write today, on the SAME equations as rotlab.

State y = (Λ, ω), 7 components, principal body frame of the scene (rotlab's state without the
work W):

    Λ̇ = ½ Λ ∘ (0, ω)                                   (Poisson, scalar-first quaternion)
    ṗ = (B − C)/A · q r + M1/A,  q̇ = (C − A)/B · r p + M2/B,  ṙ = (A − B)/C · p q + M3/C

with the torque M of the scene's loads from rotlab's own compiled torque (``rotlab.core.torques.
groups_torque``, every load kind), as a user who compiles the torque and writes the rest would do.
The rest of the right-hand side is plain Python on floats (``y.tolist()`` first): on 7 components
that is faster than NumPy vector operations, so the peers get the quickest right-hand side a
Python user would reasonably write, and the ratios are lower bounds.

* ``scipy:RK45``, ``scipy:DOP853``, ``scipy:LSODA``, ``scipy:Radau`` — ``scipy.integrate.solve_ivp``
  with ``t_eval`` = the sample times, ``rtol``, ``atol``; no Jacobian (finite differences for
  LSODA and Radau, as most users leave it).
* ``seed:rk4-renormalised`` — the seeds' approach: classical RK4 in a Python loop over NumPy
  arrays, a fixed number of equal steps per sample interval, |Λ| renormalised after every step.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from rotlab.scene.scene import Scene

SCIPY_METHODS = ("RK45", "DOP853", "LSODA", "Radau")
SEED_RK4 = "seed:rk4-renormalised"
PEERS = tuple(f"scipy:{m}" for m in SCIPY_METHODS) + (SEED_RK4,)


@dataclass
class PeerSolution:
    """States at the sample times, principal frame: ``state[:, 0:4]`` Λ, ``state[:, 4:7]`` ω;
    only the first ``valid`` rows are meaningful."""

    t: np.ndarray
    state: np.ndarray
    valid: int
    steps: int = 0
    rhs_evaluations: int = 0
    failure: str | None = None
    details: dict[str, object] = field(default_factory=dict)


def make_rhs(scene: Scene) -> Callable[[float, np.ndarray], np.ndarray]:
    """f(t, y) → ẏ for the 7-component state of ``scene`` (principal frame): Euler and Poisson in
    plain Python, the loads' torque compiled (``groups_torque``; not called for a torque-free body)."""
    from rotlab.core.state import STATE_SIZE
    from rotlab.core.torques import groups_torque

    ea, eb, ec, ia, ib, ic = scene.model.euler.tolist()
    m = scene.model
    groups = (m.forces, m.terms, m.tables, m.table_t, m.table_v, m.damping, m.expressions, m.user)
    free = not scene.scenario.loads and scene.loads.user is None
    y8 = np.zeros(STATE_SIZE)

    def f(t: float, y: np.ndarray) -> np.ndarray:
        q0, q1, q2, q3, p, q, r = y.tolist()
        mx = my = mz = 0.0
        if not free:
            y8[:7] = y
            mx, my, mz = groups_torque(t, y8, *groups)
        return np.array([
            -0.5 * (q1 * p + q2 * q + q3 * r),
            0.5 * (q0 * p + q2 * r - q3 * q),
            0.5 * (q0 * q + q3 * p - q1 * r),
            0.5 * (q0 * r + q1 * q - q2 * p),
            ea * q * r + mx * ia,
            eb * r * p + my * ib,
            ec * p * q + mz * ic,
        ])

    return f


def initial_state7(scene: Scene) -> np.ndarray:
    return np.concatenate([scene.q0, scene.omega0]).astype(float)


def solve_scipy(method: str, scene: Scene, t: np.ndarray, rtol: float, atol: float) -> PeerSolution:
    """``scipy.integrate.solve_ivp(method)`` over the sample times ``t``."""
    from scipy.integrate import solve_ivp

    f = make_rhs(scene)
    result = solve_ivp(f, (float(t[0]), float(t[-1])), initial_state7(scene), method=method, t_eval=t, rtol=rtol, atol=atol)
    state = np.full((t.shape[0], 7), np.nan)
    valid = result.y.shape[1]
    state[:valid] = result.y.T
    failure = None if result.success and valid == t.shape[0] else f"solve_ivp: {result.message}"
    return PeerSolution(t=t, state=state, valid=valid, rhs_evaluations=int(result.nfev), failure=failure,
                        details={"njev": int(result.njev), "nlu": int(result.nlu)})


def solve_seed_rk4(scene: Scene, t: np.ndarray, substeps: int) -> PeerSolution:
    """The seeds' approach: RK4 in a Python loop, ``substeps`` equal steps per sample interval,
    Λ ← Λ / |Λ| after every step."""
    f = make_rhs(scene)
    y = initial_state7(scene)
    state = np.full((t.shape[0], 7), np.nan)
    state[0] = y
    steps = 0
    for i in range(1, t.shape[0]):
        t0 = float(t[i - 1])
        h = (float(t[i]) - t0) / substeps
        for k in range(substeps):
            tk = t0 + k * h
            k1 = f(tk, y)
            k2 = f(tk + 0.5 * h, y + (0.5 * h) * k1)
            k3 = f(tk + 0.5 * h, y + (0.5 * h) * k2)
            k4 = f(tk + h, y + h * k3)
            y = y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            y[0:4] /= np.linalg.norm(y[0:4])
        steps += substeps
        if not np.all(np.isfinite(y)):
            return PeerSolution(t=t, state=state, valid=i, steps=steps, rhs_evaluations=4 * steps,
                                failure=f"state became non-finite before t = {t[i]:.6g} s")
        state[i] = y
    return PeerSolution(t=t, state=state, valid=t.shape[0], steps=steps, rhs_evaluations=4 * steps)
