"""Method names → method objects, imported lazily so that validating a config compiles nothing.
The names live in ``rotlab.methods.names`` (a module that imports nothing)."""

from __future__ import annotations

import importlib

from rotlab.methods.base import Method
from rotlab.methods.names import METHOD_MODULES, METHOD_NAMES

__all__ = ["METHOD_MODULES", "METHOD_NAMES", "get_method"]


_LOADED: dict[str, Method] = {}


def get_method(name: str) -> Method:
    """The method object registered under ``name`` (not 'auto': see ``rotlab.methods.choose``)."""
    method = _LOADED.get(name)
    if method is None:  # (import_module costs ~3 µs even for a loaded module; auto asks ~8 times a choice)
        method = _LOADED[name] = importlib.import_module(METHOD_MODULES[name]).METHOD
    return method
