from __future__ import annotations

import contextlib
import io
import os
import signal
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import settings

from rotlab.cli import main
from rotlab.shipped import shipped_configs

# CI sees the same property-test inputs on every run (a failure there is reproducible, never a
# coin toss); locally hypothesis explores new inputs each run.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

ROOT = Path(__file__).resolve().parents[1]


def pytest_report_header(config) -> str:
    import rotlab

    return f"rotlab {rotlab.__version__} imported from {Path(rotlab.__file__).resolve().parent}"


def pytest_configure(config) -> None:
    """``ROTLAB_TESTS_INSTALLED=1`` (set by .ci/run): the tests must see the installed wheel, not
    the checkout's rotlab/ folder (which would hide a file missing from the wheel).

    Ctrl-C as a terminal delivers it: a shell without job control starts a background command
    with SIGINT ignored, every process after it inherits that (xdist workers, the runs the tests
    start), and the tests that send SIGINT saw nothing happen (7 failures in such a CI run)."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if os.environ.get("ROTLAB_TESTS_INSTALLED") == "1":
        import rotlab

        package = Path(rotlab.__file__).resolve().parent
        if "site-packages" not in package.parts:
            raise pytest.UsageError(f"ROTLAB_TESTS_INSTALLED=1 but rotlab was imported from {package}; run `pytest`, not `python -m pytest`")
# The shipped scenarios as the imported rotlab sees them (its package data): the tests also run
# against an installed wheel from a directory outside the source tree (.ci/run).
CONFIGS = shipped_configs()
SOURCE_CONFIGS = ROOT / "configs"  # configs/ of the checkout (copied beside tests/ by .ci/run)

VALID_BODY = '[body]\nprincipal_moments = [1.0, 2.0, 2.5]\n'
VALID_TIME = '[time]\nend = 1.0\nsample_rate = 10\n'


@dataclass
class Result:
    exit_code: int
    stdout: str
    stderr: str

    @property
    def output(self) -> str:
        return self.stdout + self.stderr


@pytest.fixture
def cli(tmp_path, monkeypatch):
    """Run the console entry point (``rotlab.cli.main``, as the installed ``rotlab`` does) in a
    temporary working directory: cli("run", "x.toml") → Result(exit_code, stdout, stderr)."""
    monkeypatch.chdir(tmp_path)

    def invoke(*args: str) -> Result:
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                main(list(args))
                code = 0
            except SystemExit as stop:
                code = stop.code if isinstance(stop.code, int) else (0 if stop.code is None else 1)
        return Result(code, out.getvalue(), err.getvalue())

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
