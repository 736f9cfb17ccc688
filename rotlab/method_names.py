"""The names of the methods, read from the modules in ``rotlab/methods/catalog/`` without
importing any of them, so that validating a config (``rotlab.config.models``) loads no method
and compiles nothing.

Adding a method: write ``rotlab/methods/catalog/<name>.py`` exposing ``METHOD``
(``rotlab.methods.base.Method``); nothing else lists it.
"""

from __future__ import annotations

import pkgutil
from pathlib import Path

CATALOG = Path(__file__).parent / "methods" / "catalog"
CATALOG_PACKAGE = "rotlab.methods.catalog"

# the order the methods are listed in (help, bench tables); a new method is listed after these
_LISTED_FIRST = ("rk4", "dop853", "splitting", "dmv", "rkmk4", "taylor", "exact")


def _catalog() -> tuple[str, ...]:
    found = {module.name for module in pkgutil.iter_modules([str(CATALOG)]) if not module.name.startswith("_")}
    return tuple(sorted(found, key=lambda name: (_LISTED_FIRST.index(name) if name in _LISTED_FIRST else len(_LISTED_FIRST), name)))


METHODS: tuple[str, ...] = _catalog()  # every method, in listing order
METHOD_NAMES: tuple[str, ...] = ("auto", *METHODS)  # what ``solver.method`` accepts
