"""Method names → method objects, each imported on first use from ``rotlab.methods.catalog``
(the names: ``rotlab.method_names``, which imports nothing)."""

from __future__ import annotations

import importlib
from functools import cache

from rotlab.method_names import CATALOG_PACKAGE, METHODS
from rotlab.methods.base import Method

__all__ = ["METHODS", "all_methods", "get_method"]


@cache
def get_method(name: str) -> Method:
    """The method object registered under ``name`` (not 'auto': see ``rotlab.methods.choose``)."""
    if name not in METHODS:
        raise KeyError(f"unknown method {name!r}: choose one of {', '.join(METHODS)}")
    method = importlib.import_module(f"{CATALOG_PACKAGE}.{name}").METHOD
    if method.name != name:
        raise TypeError(f"{CATALOG_PACKAGE}.{name} declares METHOD.name = {method.name!r}: a method's module is named as the method")
    return method


def all_methods() -> tuple[Method, ...]:
    """Every method, in listing order."""
    return tuple(get_method(name) for name in METHODS)
