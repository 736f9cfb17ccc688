"""Scenario configuration: TOML → validated pydantic models.  The exports below are imported on
first use, so that the formula parser (``rotlab.config.expressions``) imports without pydantic."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rotlab.config.loader import load_scenario, parse_scenario
    from rotlab.config.models import Scenario

__all__ = ["Scenario", "load_scenario", "parse_scenario"]
_WHERE = {"Scenario": "rotlab.config.models", "load_scenario": "rotlab.config.loader", "parse_scenario": "rotlab.config.loader"}


def __getattr__(name: str) -> object:
    if name not in _WHERE:
        raise AttributeError(f"module 'rotlab.config' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(_WHERE[name]), name)
