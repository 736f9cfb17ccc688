"""``dmv``: discrete Moser–Veselov algorithm for the free rigid body, with Hairer & Vilmart's
modified moments of inertia (coefficients derived by tools/derive_dmv_moments.py) for orders
``ORDERS`` = 2, 4, 6, 8, 10, 12 (``solver.order``, default the highest).

Torque-free scenes only.  Conserves |L| and the energy exactly up to rounding (no drift) and
L_space up to O(h^order); |Λ| = 1 to rounding (never renormalised).  No right-hand side
evaluations.  See ``rotlab.core.dmv``.
"""

from __future__ import annotations

from rotlab.core.dmv import ORDERS, dmv_advance, modified_coefficients
from rotlab.methods.fixed_step import FixedStepMethod
from rotlab.scene.scene import TORQUE_FREE, Scene


def _requires(scene: Scene) -> str | None:
    if scene.kind != TORQUE_FREE:
        return f"dmv integrates the torque-free body only, and this scene is not torque-free ({scene.kind_reason})"
    return None


METHOD = FixedStepMethod(
    name="dmv",
    summary="discrete Moser–Veselov with modified moments (Hairer–Vilmart), orders 2–12, free body, fixed step",
    kernel=dmv_advance,
    order_of_accuracy=2,
    orders=ORDERS,
    default_order=max(ORDERS),
    evaluations_per_step=lambda scene, order: 0,  # no right-hand side: an implicit rotation per step
    requires=_requires,
    extra_args=lambda scene, order: (order, modified_coefficients(scene.moments)),
    auto_orders=(8, 10, 12),  # (the lower orders never win at the tolerances auto is asked for)
    auto_probe=False,  # high order: the a priori step of the cost model, no probe run
    given_step_preference=0,  # the free body
)
