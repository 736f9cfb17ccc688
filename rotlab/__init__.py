"""rotlab — rotation of a rigid body about a fixed point: scenarios, integrators, recordings."""

from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["__version__", "load", "simulate"]


def __getattr__(name: str):  # lazy: `import rotlab` stays light for the CLI
    if name in ("load", "simulate"):
        from rotlab import api

        return getattr(api, name)
    raise AttributeError(name)
