"""``rk4``: classical fixed-step Runge–Kutta 4 — the seeds' baseline, compiled, no renormalisation."""

from rotlab.core.rk4 import rk4_advance
from rotlab.methods.fixed_step import FixedStepMethod

METHOD = FixedStepMethod(
    name="rk4",
    summary="classical Runge–Kutta 4, fixed step",
    kernel=rk4_advance,
    order_of_accuracy=4,
    evaluations_per_step=lambda scene, order: 4,
)
