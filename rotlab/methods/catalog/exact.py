"""``exact``: evaluate the closed-form / elliptic-function solution at every sample time —
no time stepping.  Torque-free bodies (``rotlab.core.exact.torque_free``) and the Lagrange top
(``rotlab.core.exact.lagrange``).

The Lagrange solution is written for a canonical frame: symmetry axis = body z, centre of mass
at (0, 0, l) with l > 0, field along −z in space.  A scene is mapped there by a body rotation B
(e_sym → e_z; the two equal moments stay in the plane ⊥ e_z, so the inertia is diag(A, A, C))
and a space rotation S (−F̂ → e_z):  Λ_c = Λ_S ∘ Λ ∘ Λ̃_B,  ω_c = B ω, and back.
"""

from __future__ import annotations

import numpy as np

from rotlab.core import quaternion as quat
from rotlab.core.torques import F_FORCE, F_POINT
from rotlab.methods.base import NO_STEPS, LocalSolution, ProgressCallback, Settings, Solution
from rotlab.methods.cost import Estimate, Work, exact_estimate
from rotlab.methods.stepping import evaluate_in_windows
from rotlab.scene.scene import LAGRANGE, TORQUE_FREE, Scene
from rotlab.scene.loads import active_forces

E_Z = np.array([0.0, 0.0, 1.0])


class Exact:
    name = "exact"
    summary = "closed-form solution evaluated at the sample times (no stepping)"
    stepping = NO_STEPS
    adaptive = False
    orders: tuple[int, ...] = ()
    order_of_accuracy = None
    given_step_preference = None
    ends_steps_at_switches = False

    def evaluations_per_step(self, scene: Scene, order: int | None) -> int:
        return 0

    def unsupported(self, scene: Scene) -> str | None:
        if scene.kind in (TORQUE_FREE, LAGRANGE):
            return None
        return f"no exact solution for a {scene.kind} scene ({scene.kind_reason}); exact covers torque-free bodies and the Lagrange top"

    def auto_estimates(self, scene: Scene, settings: Settings, work: Work) -> list[Estimate]:
        """Set-up and a cost per sample (no steps); offers no order."""
        return [exact_estimate(_closed_form(scene), work)] if settings.order is None else []

    def auto_settings(self, estimate: Estimate, settings: Settings) -> Settings:
        return settings

    def local_solution(self, scene: Scene, t: np.ndarray, settings: Settings) -> LocalSolution:
        """The closed form at t1 (it needs no state at t0: ``Method.local_solution``)."""
        evaluate = _evaluator(scene, float(t[0]))
        return lambda y0, t0, t1: evaluate(np.array([t1]))[0]

    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        solution = evaluate_in_windows(t, _evaluator(scene, float(t[0])), progress)
        solution.details = {"evaluated samples": int(solution.valid)}
        return solution


def _evaluator(scene: Scene, t0: float):
    """times → the (len(times), 8) states of the closed form from the scene's state at t0 (its
    constants computed once)."""
    from rotlab.core.exact.torque_free import torque_free_evaluator  # (scipy.special: imported when it runs, not when auto weighs it)

    solution = torque_free_evaluator(scene.moments, scene.omega0, scene.q0, t0) if scene.kind == TORQUE_FREE else _lagrange(scene, t0)

    def evaluate(times: np.ndarray) -> np.ndarray:
        q, omega = solution(times)
        state = np.zeros((times.shape[0], 8))
        state[:, 0:4] = q
        state[:, 4:7] = omega
        return state

    return evaluate


def _closed_form(scene: Scene) -> str:
    """Which closed form runs (its cost differs): "lagrange", "axisymmetric" (a symmetric body,
    or a spin about a principal axis) or "asymmetric" (Jacobi elliptic functions)."""
    if scene.kind == LAGRANGE:
        return "lagrange"
    distinct = len({float(x) for x in scene.moments})
    return "axisymmetric" if distinct < 3 or np.count_nonzero(scene.omega0) <= 1 else "asymmetric"


def _lagrange(scene: Scene, t0: float):
    """times → (Λ, ω) of the Lagrange top from the scene's state at t0, mapped to the canonical
    frames and back (module docstring)."""
    from rotlab.core.exact.lagrange import lagrange_top_evaluator

    (row,) = active_forces(scene.loads)
    arm, force = row[F_POINT:F_POINT + 3], row[F_FORCE:F_FORCE + 3]
    axis = scene.symmetry_axis
    body_q = quat.between(axis, E_Z)  # B: principal → canonical body frame
    space_q = quat.between(-force, E_Z)  # S: space → canonical space ("up" = −F̂ → e_z)
    B = quat.to_matrix(body_q)
    c_moment = float(axis @ (scene.moments * axis))
    a_moment = 0.5 * (float(np.sum(scene.moments)) - c_moment)
    mgl = float(np.linalg.norm(force) * (arm @ axis))
    q_c0 = quat.multiply_array(quat.multiply_array(space_q, scene.q0), quat.conjugate_array(body_q))
    canonical = lagrange_top_evaluator(a_moment, c_moment, mgl, B @ scene.omega0, q_c0, t0)

    def solution(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q_c, omega_c = canonical(t)
        q = quat.multiply_array(quat.multiply_array(quat.conjugate_array(space_q), q_c), body_q)
        return q, omega_c @ B

    return solution


METHOD = Exact()
