"""``rk4``: classical fixed-step Runge–Kutta 4 — the seeds' baseline, compiled, no renormalisation."""

from rotlab.core.rk4 import rk4_advance
from rotlab.methods.fixed_step import FixedStepMethod

METHOD = FixedStepMethod(
    name="rk4",
    summary="classical Runge–Kutta 4, fixed step",
    kernel=rk4_advance,
    order_of_accuracy=4,
    step_limit=2.8,  # RK4 is stable on the imaginary axis up to h·ω = 2√2
    evaluations_per_step=lambda scene, order: 4,
    auto_orders=(None,),
    # a fixed step crosses a switch (abs, sign, min, max) where no breakpoint marks it at low order
    auto_applies=lambda scene: not scene.has_switches,
    given_step_preference=2,  # any scene
)
