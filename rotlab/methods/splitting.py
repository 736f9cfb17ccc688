"""``splitting``: symplectic splitting of T1 + T2 + T3 + V (exact axis rotations, potential
kicks), symmetric composition of order 2, 4, 6 or 8 (``solver.order``, default 4).

Conservative scenes only (free body, gravity, constant space-frame forces).  Symplectic and
time-reversible: energy error bounded without drift, L along a common force direction and, for
the free body, |L| and L_space conserved to rounding; |Λ| = 1 to rounding (never renormalised).
See ``rotlab.core.splitting`` for the scheme and the composition coefficients.
"""

from __future__ import annotations

import numpy as np

from rotlab.core.splitting import ORDERS, splitting_advance, stages
from rotlab.errors import InputError
from rotlab.methods.base import ProgressCallback, Settings, Solution
from rotlab.methods.fixed_step import FixedStepMethod
from rotlab.scene.scene import Scene

DEFAULT_ORDER = 4


def chosen_order(settings: Settings) -> int:
    order = getattr(settings, "order", None)
    order = DEFAULT_ORDER if order is None else order
    if order not in ORDERS:
        raise InputError("solver.order", f"splitting offers orders {', '.join(map(str, ORDERS))} (got {order})")
    return int(order)


def _requires(scene: Scene) -> str | None:
    if scene.has_work:
        return (
            "splitting needs a conservative scene (free body, gravity, constant space-frame forces), "
            "but this one has loads that do work (torques, torque tables, body-frame forces or damping)"
        )
    return None


class SplittingMethod(FixedStepMethod):
    def solve(self, scene: Scene, t: np.ndarray, settings: Settings, progress: ProgressCallback | None) -> Solution:
        order = chosen_order(settings)
        solution = super().solve(scene, t, settings, progress)
        kicks = len(scene.loads.forces) > 0  # force evaluations: one per stage (kicks merged)
        solution.rhs_evaluations = stages(order) * solution.steps if kicks else 0
        solution.details["order"] = order
        return solution


METHOD = SplittingMethod(
    name="splitting",
    summary="symplectic splitting (axis rotations + kicks), composed to order 2/4/6/8, fixed step",
    kernel=splitting_advance,
    evaluations_per_step=1,  # per stage; see SplittingMethod.solve
    requires=_requires,
    extra_args=lambda scene, settings: (chosen_order(settings),),
)
