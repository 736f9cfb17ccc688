"""Which method runs a scene: the user's choice (checked), or ``auto`` with its reason."""

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
    return get_method("dop853"), "auto: the adaptive general-purpose method (no exact or geometric method for this scene yet)"
