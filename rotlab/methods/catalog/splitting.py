"""``splitting``: symplectic splitting of T1 + T2 + T3 + V (exact axis rotations, potential
kicks), symmetric composition of order 2, 4, 6 or 8 (``solver.order``, default 4).

Conservative scenes only (free body, gravity, constant space-frame forces; a gyrostat's rotors
too).  Symplectic and time-reversible: energy error bounded without drift, L along a common force
direction and, for the free body or gyrostat, |L| and L_space conserved to rounding; |Λ| = 1 to
rounding (never renormalised).
See ``rotlab.core.splitting`` for the scheme and the composition coefficients.
"""

from __future__ import annotations

from rotlab.core.splitting import ORDERS, splitting_advance, stages
from rotlab.methods.fixed_step import FixedStepMethod
from rotlab.scene.scene import TORQUE_FREE, Scene


def _requires(scene: Scene) -> str | None:
    if scene.loads.drives is not None:
        return "splitting needs a conservative scene, and a driven rotor's drive does work on the body (use dop853, rk4 or rkmk4)"
    if scene.has_work:
        return (
            "splitting needs a conservative scene (free body, gravity, constant space-frame forces), "
            "but this one has loads that do work (torques, torque tables, body-frame forces or damping)"
        )
    return None


METHOD = FixedStepMethod(
    name="splitting",
    summary="symplectic splitting (axis rotations + kicks), composed to order 2/4/6/8, fixed step",
    kernel=splitting_advance,
    order_of_accuracy=4,
    orders=ORDERS,
    default_order=4,
    # force evaluations: one per stage (kicks merged), none for the free body
    evaluations_per_step=lambda scene, order: stages(order) if len(scene.loads.forces) else 0,
    requires=_requires,
    extra_args=lambda scene, order: (order,),
    auto_orders=(4, 6, 8),
    auto_applies=lambda scene: scene.kind != TORQUE_FREE,  # on a free body dmv is cheaper at every order, at equal accuracy
    given_step_preference=1,  # conservative scenes
)
