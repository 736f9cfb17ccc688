"""Installed truth: what a command needs ships inside the package (issue 16.1)."""

from __future__ import annotations

from pathlib import Path

import pytest

import rotlab
from rotlab.bench.problems import CONFIGS as BENCH_CONFIGS
from rotlab.bench.problems import get_problems
from tests.conftest import CONFIGS, SOURCE_CONFIGS

PACKAGE = Path(rotlab.__file__).resolve().parent


def test_shipped_configs_are_package_data():
    """The bench reads its configs inside the imported package, never beside it (site-packages/configs)."""
    assert BENCH_CONFIGS == CONFIGS
    assert CONFIGS.resolve().is_relative_to(PACKAGE) or CONFIGS.is_relative_to(PACKAGE)
    names = sorted(p.name for p in CONFIGS.glob("*.toml"))
    assert {"lagrange.toml", "euler.toml", "dzhanibekov.toml", "general.toml"} <= set(names)
    assert get_problems(["lagrange"])[0].config.is_file()


def test_package_configs_equal_the_source_configs():
    """configs/ is the one source: the package's copies (the wheel's, when installed) are byte-identical."""
    if not SOURCE_CONFIGS.is_dir():
        pytest.skip(f"no source configs/ beside the tests ({SOURCE_CONFIGS})")
    source = {p.name: p.read_bytes() for p in SOURCE_CONFIGS.glob("*.toml")}
    package = {p.name: p.read_bytes() for p in CONFIGS.glob("*.toml")}
    assert package == source

