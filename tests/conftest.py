from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from rotlab.cli import app

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"

VALID_BODY = '[body]\nprincipal_moments = [1.0, 2.0, 2.5]\n'
VALID_TIME = '[time]\nend = 1.0\nsample_rate = 10\n'


@pytest.fixture
def cli(tmp_path, monkeypatch):
    """Run the CLI in a temporary working directory: cli("run", "x.toml") → Result."""
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()

    def invoke(*args: str):
        return runner.invoke(app, list(args), catch_exceptions=False)

    return invoke


@pytest.fixture
def write(tmp_path):
    """write("name.toml", text or bytes) → Path in the temporary directory."""

    def _write(name: str, content: str | bytes) -> Path:
        path = tmp_path / name
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8")
        return path

    return _write
