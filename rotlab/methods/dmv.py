"""``dmv``: discrete Moser–Veselov algorithm for the free rigid body, with Hairer & Vilmart's
modified moments of inertia for orders 2, 4, 6, 8, 10 (``solver.order``, default 4).

Torque-free scenes only.  Conserves |L| and the energy exactly up to rounding (no drift) and
L_space up to O(h^order); |Λ| = 1 to rounding (never renormalised).  No right-hand side
evaluations.  See ``rotlab.core.dmv``.
"""

from __future__ import annotations

import numpy as np

from rotlab.core.dmv import ORDERS, dmv_advance, modified_coefficients
from rotlab.errors import InputError
from rotlab.methods.base import ProgressCallback, Settings, Solution
from rotlab.methods.fixed_step import FixedStepMethod
from rotlab.scene.scene import TORQUE_FREE, Scene

DEFAULT_ORDER = 2


def chosen_order(settings: Settings) -> int:
    order = getattr(settings, "order", None)
    order = DEFAULT_ORDER if order is None else order
    if order not in ORDERS:
        raise InputError("solver.order", f"dmv offers orders {', '.join(map(str, ORDERS))} (got {order})")
    return int(order)


def _requires(scene: Scene) -> str | None:
    if scene.kind != TORQUE_FREE:
        return f"dmv integrates the torque-free body only, and this scene is not torque-free ({scene.kind_reason})"
    return None


class DMVMethod(FixedStepMethod):
    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        order = chosen_order(settings)
        solution = super().solve(scene, t, settings, progress)
        solution.details["order"] = order
        return solution


METHOD = DMVMethod(
    name="dmv",
    summary="discrete Moser–Veselov with modified moments (Hairer–Vilmart), order 2–10, free body, fixed step",
    kernel=dmv_advance,
    evaluations_per_step=0,
    requires=_requires,
    extra_args=lambda scene, settings: (chosen_order(settings), modified_coefficients(scene.moments)),
)
