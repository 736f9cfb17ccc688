"""Which method runs a scene: the user's choice (checked), or ``auto`` with its reason.

``auto`` takes the cheapest method that is exact or meets ``solver.rtol`` for the scene:
  exact solution (torque-free body, Lagrange top)     →  no stepping at all;
  conservative scene (gravity, constant space forces)  →  symplectic splitting, the order with
      the least work (stages × steps, steps from the tolerance probe): bounded energy error;
  anything else (work done, time-dependent loads)      →  adaptive Taylor series: on the bench's
      general scenes it is 2–3× faster than DOP853 at equal rtol and more accurate
      (docs/benchmarks.md).
"""

from __future__ import annotations

import numpy as np

from rotlab.errors import InputError
from rotlab.methods.base import Method, Settings
from rotlab.methods.registry import METHOD_MODULES, get_method
from rotlab.scene.scene import Scene


def choose_method(scene: Scene, requested: str, settings: Settings, t: np.ndarray) -> tuple[Method, str, Settings]:
    """(method, why it was chosen, the settings it runs with).  An explicit method that cannot
    run the scene is an input error."""
    if requested != "auto":
        if requested not in METHOD_MODULES:
            raise InputError("solver.method", f"unknown method '{requested}': choose one of auto, {', '.join(METHOD_MODULES)}")
        method = get_method(requested)
        why_not = method.unsupported(scene)
        if why_not:
            raise InputError("solver.method", f"'{requested}' cannot run this scene: {why_not}; use method = \"auto\"")
        return method, "requested in the scenario or on the command line", settings
    kind = scene.kind.replace("_", "-")
    exact = get_method("exact")
    if exact.unsupported(scene) is None:
        return exact, f"auto: {kind} scene has an exact solution, evaluated at the samples without stepping", settings
    if not scene.has_work and settings.step is None:
        splitting = get_method("splitting")
        work = {order: splitting.evaluations_per_step(scene, order) / splitting.step_for_tolerance(scene, t, settings.rtol, order)
                for order in splitting.orders}
        order = min(work, key=work.get)
        chosen = Settings(step=None, rtol=settings.rtol, atol=settings.atol, max_steps=settings.max_steps, order=order)
        return splitting, (f"auto: conservative {kind} scene ({scene.kind_reason}): symplectic splitting of order {order}, "
                           f"the least work for rtol = {settings.rtol:g}; energy error bounded, no drift"), chosen
    return get_method("taylor"), f"auto: {kind} scene ({scene.kind_reason}): adaptive Taylor series meets rtol = {settings.rtol:g}", settings
