"""The scenarios shipped inside the package (``rotlab/configs``, package data).

The top-level ``configs/`` directory of the source tree is their one source: ``rotlab/configs`` is a
symlink to it, dereferenced when the wheel is built, so an installed rotlab reads real copies through
``importlib.resources`` and never looks outside its own package.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def shipped_configs() -> Path:
    """The directory holding the shipped ``*.toml`` scenarios, inside the installed package."""
    resource = files("rotlab").joinpath("configs")
    if not isinstance(resource, Path):  # e.g. a zip import: the bench and the tests need real files
        raise RuntimeError(f"rotlab's shipped configs are not on the file system ({resource}): install rotlab with pip")
    return resource


def shipped_config(name: str) -> Path:
    """One shipped scenario, e.g. ``shipped_config("lagrange.toml")``."""
    return shipped_configs() / name
