"""Method names → modules, imported lazily so that validating a config compiles nothing.

Adding a method: write ``rotlab/methods/<name>.py`` exposing ``METHOD`` (see ``base.Method``)
and add one line here.
"""

from __future__ import annotations

import importlib

from rotlab.methods.base import Method

METHOD_MODULES: dict[str, str] = {
    "rk4": "rotlab.methods.rk4",
    "dop853": "rotlab.methods.dop853",
    "splitting": "rotlab.methods.splitting",
    "dmv": "rotlab.methods.dmv",
    "rkmk4": "rotlab.methods.rkmk4",
    "taylor": "rotlab.methods.taylor",
    "exact": "rotlab.methods.exact",
}

METHOD_NAMES: tuple[str, ...] = ("auto", *METHOD_MODULES)


def get_method(name: str) -> Method:
    """The method object registered under ``name`` (not 'auto': see ``rotlab.methods.choose``)."""
    return importlib.import_module(METHOD_MODULES[name]).METHOD
