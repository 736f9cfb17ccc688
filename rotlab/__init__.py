"""rotlab — rotation of a rigid body about a fixed point: scenarios, integrators, recordings."""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["InputError", "Interrupted", "Lyapunov", "RunFailure", "Scenario", "Stability", "Trajectory", "__version__", "load",
           "lyapunov", "parse_scenario", "save", "show", "simulate", "stability"]

_LAZY = {
    "load": "rotlab.api",
    "simulate": "rotlab.api",
    "save": "rotlab.api",
    "show": "rotlab.api",
    "parse_scenario": "rotlab.config.loader",
    "stability": "rotlab.linear_stability",
    "lyapunov": "rotlab.lyapunov_exponent",
    "Lyapunov": "rotlab.lyapunov_exponent",
    "Stability": "rotlab.linear_stability",
    "Scenario": "rotlab.config.models",
    "Trajectory": "rotlab.trajectory",
    "InputError": "rotlab.errors",
    "RunFailure": "rotlab.errors",
    "Interrupted": "rotlab.errors",
}


def __getattr__(name: str):  # lazy: `import rotlab` stays light for the CLI
    if name in _LAZY:
        import importlib

        value = globals()[name] = getattr(importlib.import_module(_LAZY[name]), name)  # found directly from now on
        return value
    raise AttributeError(f"module 'rotlab' has no attribute '{name}'")
