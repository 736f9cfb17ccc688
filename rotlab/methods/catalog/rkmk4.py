"""``rkmk4``: Runge–Kutta–Munthe-Kaas of order 4 — Λ on SO(3) through the exponential map
(|Λ| = 1 to rounding, never renormalised), ω and W by classical RK4 stages.  Any scene,
time-dependent and non-conservative loads included.  See ``rotlab.core.rkmk4``."""

from rotlab.core.rkmk4 import rkmk4_advance
from rotlab.methods.fixed_step import FixedStepMethod

METHOD = FixedStepMethod(
    name="rkmk4",
    summary="Runge–Kutta–Munthe-Kaas 4 (Lie-group RK4, exponential map), fixed step",
    kernel=rkmk4_advance,
    order_of_accuracy=4,
    step_limit=2.8,  # its RK4 stages: stable up to h·ω = 2√2
    evaluations_per_step=lambda scene, order: 4,
)
