"""Which method runs a scene: the user's choice (checked), or ``auto`` with its reason.

``auto`` takes the cheapest method that is exact or meets the tolerance for the scene:
  exact solution (torque-free body, Lagrange top)  →  no stepping at all;
  otherwise adaptive DOP853 with dense output.
"""

from __future__ import annotations

from rotlab.errors import InputError
from rotlab.methods.base import Method
from rotlab.methods.registry import METHOD_MODULES, get_method
from rotlab.scene.scene import Scene


def choose_method(scene: Scene, requested: str) -> tuple[Method, str]:
    """(method, why it was chosen).  An explicit method that cannot run the scene is an input error."""
    if requested != "auto":
        if requested not in METHOD_MODULES:
            raise InputError("solver.method", f"unknown method '{requested}': choose one of auto, {', '.join(METHOD_MODULES)}")
        method = get_method(requested)
        why_not = method.unsupported(scene)
        if why_not:
            raise InputError("solver.method", f"'{requested}' cannot run this scene: {why_not}; use method = \"auto\"")
        return method, "requested in the scenario or on the command line"
    kind = scene.kind.replace("_", "-")
    exact = get_method("exact")
    if exact.unsupported(scene) is None:
        return exact, f"auto: {kind} scene has an exact solution, evaluated at the samples without stepping"
    return get_method("dop853"), f"auto: {kind} scene ({scene.kind_reason}): adaptive DOP853 meets the tolerance"
