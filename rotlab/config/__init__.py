"""Scenario configuration: TOML → validated pydantic models."""

from rotlab.config.loader import load_scenario, parse_scenario
from rotlab.config.models import Scenario

__all__ = ["Scenario", "load_scenario", "parse_scenario"]
