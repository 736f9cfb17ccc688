"""``taylor``: adaptive high-order Taylor series (Jorba–Zou order and step control), every load;
the order from ``solver.rtol`` (⌈−½ ln rtol⌉ + 1) unless ``solver.order`` gives it.  The dense
output is the series itself, so many samples per step cost only a polynomial evaluation each.
See ``rotlab.core.taylor``.
"""

from __future__ import annotations

import numpy as np

from rotlab.core import taylor as kernel
from rotlab.core.torques import F_FORCE, F_POINT, T_FRAME, TB_FRAME
from rotlab.errors import InputError
from rotlab.methods.base import ADAPTIVE, LocalSolution, ProgressCallback, Settings, Solution
from rotlab.methods.cost import Estimate, Work, taylor_estimate
from rotlab.methods.stepping import adaptive_failure_message, initial_state, run_chunks
from rotlab.core.torques import SPACE
from rotlab.scene.loads import active_forces, has_nonconservative
from rotlab.scene.scene import Scene

MIN_ORDER, MAX_ORDER = 4, 40
# auto runs taylor at local tolerance rtol / MARGIN: its global error is up to ~20× its local
# tolerance on fast spinners (configs/lagrange.toml, general.toml), near a separatrix rtol / the
# amplification ...
MARGIN = 10.0
# ... and never below MIN_TOLERANCE: a smaller tolerance asks for no more than rounding gives and only
# shrinks the steps toward the step budget (a spin exactly on a separatrix asked for 1e-303)
MIN_TOLERANCE = 1e-16


class Taylor:
    name = "taylor"
    summary = "adaptive high-order Taylor series (Jorba–Zou), any loads, dense output from the series"
    stepping = ADAPTIVE
    adaptive = True  # steps chosen from rtol/atol, not a fixed step
    orders = tuple(range(MIN_ORDER, MAX_ORDER + 1))  # solver.order; default from rtol
    order_of_accuracy = None  # chosen per run (``order_for``)
    given_step_preference = None
    ends_steps_at_switches = True

    def evaluations_per_step(self, scene: Scene, order: int | None) -> int:
        return 0  # no right-hand-side evaluation: one Taylor series (O(order²) products) per step

    def unsupported(self, scene: Scene) -> str | None:
        if scene.loads.user is not None:
            return "taylor needs the Taylor series of every load, and a Python torque function has none (use dop853, rk4 or rkmk4)"
        if scene.loads.drives is not None:
            return "taylor's series do not carry a driven rotor's momentum (use dop853, rk4 or rkmk4)"
        return None

    def auto_estimates(self, scene: Scene, settings: Settings, work: Work) -> list[Estimate]:
        """At local tolerance rtol / ``MARGIN`` (or / the amplification near a separatrix), the
        cheapest order from Jorba–Zou's up (``cost.taylor_estimate``), or ``solver.order``."""
        if settings.order is not None and not MIN_ORDER <= settings.order <= MAX_ORDER:
            return []
        tolerance = max(settings.rtol / max(MARGIN, work.amplification), MIN_TOLERANCE)
        return [taylor_estimate(settings.order, tolerance, work)]

    def auto_settings(self, estimate: Estimate, settings: Settings) -> Settings:
        """The estimate's order and local tolerance (atol scaled alike), steps from them."""
        return settings.at_tolerance(estimate.rtol, estimate.order)

    def order_for(self, settings: Settings) -> int:
        if settings.order is not None:
            return settings.order
        return kernel.default_order(settings.rtol)

    def checked_order(self, settings: Settings) -> int:
        """``order_for``, an ``InputError`` outside MIN_ORDER … MAX_ORDER."""
        order = self.order_for(settings)
        if not MIN_ORDER <= order <= MAX_ORDER:
            raise InputError("solver.order", f"taylor takes orders {MIN_ORDER} to {MAX_ORDER}, not {order}")
        return order

    def constants(self, scene: Scene) -> tuple:
        """``kernel_constants`` of the scene, made once per body and loads."""
        return scene.rigid.kernel_constants(self.name, None, lambda: kernel_constants(scene))

    def local_solution(self, scene: Scene, t: np.ndarray, settings: Settings) -> LocalSolution:
        """Its series steps from (t0, y) at the run's order and tolerances, ending at t1 (``Method.local_solution``)."""
        order = self.checked_order(settings)
        c0, T, lever_force, flags = self.constants(scene)
        model, counters, grid, out = scene.model, np.zeros(1, dtype=np.int64), np.empty(2), np.empty((2, scene.state0.shape[0]))

        def advance(y0: np.ndarray, t0: float, t1: float) -> np.ndarray:
            y = y0.copy()
            kernel.taylor_local(y, t0, t1, grid, out, order, settings.rtol, settings.atol, settings.max_steps, model, c0, T, lever_force,
                                flags, counters)
            return y

        return advance

    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        order = self.checked_order(settings)
        c0, T, lever_force, flags = self.constants(scene)
        model = scene.model
        y = initial_state(scene)
        counters = np.zeros(1, dtype=np.int64)
        clock = {"t": float(t[0])}

        def advance(times: np.ndarray, out: np.ndarray, i: int, budget: int) -> tuple[int, int, int]:
            before = int(counters[0])
            status, i, clock["t"] = kernel.taylor_advance(y, clock["t"], times, out, i, order, settings.rtol, settings.atol, budget,
                                                          model, c0, T, lever_force, flags, counters)
            return status, i, int(counters[0]) - before

        def describe(status: int, times: np.ndarray, out: np.ndarray, i: int) -> str:
            return adaptive_failure_message(status, clock["t"], times, out, i)

        solution = run_chunks(t, y, advance, settings.max_steps, progress, describe, lambda: clock["t"], explain_fault=scene.explain_fault)
        solution.steps = int(counters[0])
        solution.details = {"order": order, "rtol": settings.rtol, "atol": settings.atol}
        return solution


def kernel_constants(scene: Scene) -> tuple:
    """The kernel's per-scene arguments besides ``scene.model``: the force map (c₀, T), the lever
    and force [p, F] of a lone constant force (``lone_force``, else None), and (has_products,
    has_space, has_work).  Several forces, space-frame loads and expressions need the products
    (expressions: their γ, Rᵀ M)."""
    loads = scene.loads
    forces, has_space = active_forces(loads), _has_space(loads)
    lever_force = _lone_force(loads, forces, has_space)
    c0, T = kernel.force_map(forces[:0] if lever_force is not None else forces)
    flags = ((len(forces) > 0 and lever_force is None) or has_space or loads.expressions is not None, has_space, has_nonconservative(loads))
    return c0, T, lever_force, flags


def lone_force(scene: Scene) -> np.ndarray | None:
    """[p, F] (2 × 3) when one constant force acts and nothing else in space (no space-frame
    torques, no expressions): the kernel then takes its torque through γ = Rᵀ F; else None."""
    return _lone_force(scene.loads, active_forces(scene.loads), _has_space(scene.loads))


def _lone_force(loads, forces: np.ndarray, has_space: bool) -> np.ndarray | None:
    if len(forces) != 1 or has_space or loads.expressions is not None:
        return None
    return np.array([forces[0, F_POINT:F_POINT + 3], forces[0, F_FORCE:F_FORCE + 3]])


def _has_space(loads) -> bool:
    return bool(np.any(loads.terms[:, T_FRAME] == SPACE) or np.any(loads.tables[:, TB_FRAME] == SPACE))


METHOD = Taylor()
