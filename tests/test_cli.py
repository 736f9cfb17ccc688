"""The command line through typer's test runner."""

from __future__ import annotations

import subprocess
import sys

import pytest

import rotlab
from rotlab.config import load_scenario
from rotlab.recording import layout
from rotlab.recording.reader import read_series
from tests.conftest import CONFIGS


def test_version(cli):
    result = cli("--version")
    assert result.exit_code == 0 and result.stdout.strip() == f"rotlab {rotlab.__version__}"


def test_run_writes_default_output_in_working_directory(cli, tmp_path):
    result = cli("run", str(CONFIGS / "euler.toml"), "--duration", "0.5")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "euler.rrd").exists()
    out = result.stdout
    assert "torque-free" in out and "exact" in out and "L_space" in out and "euler.rrd" in out


def test_run_overrides_method_and_duration(cli, tmp_path):
    result = cli("run", str(CONFIGS / "lagrange.toml"), "-o", "top.rrd", "--method", "rk4", "--duration", "0.25")
    assert result.exit_code == 0, result.output
    t, _ = read_series(tmp_path / "top.rrd", layout.OMEGA)
    assert t[-1] == pytest.approx(0.25)
    assert "rk4" in result.stdout


def test_validate_many(cli):
    result = cli("validate", *[str(p) for p in sorted(CONFIGS.glob("*.toml"))])
    assert result.exit_code == 0
    assert result.stdout.count(": ok") == len(list(CONFIGS.glob("*.toml")))


@pytest.mark.parametrize("kind", ["euler", "lagrange", "general", "box", "satellite"])
def test_new_prints_a_valid_commented_template(cli, tmp_path, kind):
    result = cli("new", kind)
    assert result.exit_code == 0
    assert result.stdout.count("#") > 10  # commented for students
    path = tmp_path / "t.toml"
    path.write_text(result.stdout)
    load_scenario(path)


def test_new_unknown_kind(cli):
    result = cli("new", "kovalevskaya")
    assert result.exit_code == 2 and "'euler', 'lagrange', 'general', 'box', 'satellite'" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_help_is_fast_and_imports_nothing_heavy():
    code = "import sys; import rotlab.cli; print(sorted(m for m in ('numpy', 'numba', 'rerun', 'scipy', 'pydantic') if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "[]", done.stdout + done.stderr


def test_a_run_imports_the_scipy_it_uses_only(tmp_path):
    """A run imports none of SciPy's optimize (24 MB and 0.4 s with the linear algebra and special
    functions it pulls in), integrate or special: a loaded body, a heavy top (whose portrait
    computes K(m) and the mean precession with NumPy) and a run whose events cross (their roots are
    rotlab's own: ``rotlab.core.event_root``)."""
    code = """
import sys
from rotlab.cli import main
sys.argv = ["rotlab", "run", sys.argv[1], "--duration", sys.argv[3], "-o", sys.argv[2]]
try:
    main()
except SystemExit:
    pass
print(sorted(m for m in ("scipy.optimize", "scipy.integrate", "scipy.special") if m in sys.modules))
"""
    seen = {}
    for config, seconds in (("general.toml", "0.2"), ("lagrange.toml", "0.2"), ("chaotic_top.toml", "10")):  # (~5 returns in 10 s)
        done = subprocess.run([sys.executable, "-c", code, str(CONFIGS / config), str(tmp_path / "run.rrd"), seconds], capture_output=True,
                              text=True, timeout=300)
        seen[config] = done.stdout.strip().splitlines()[-1] if done.stdout.strip() else done.stderr
    assert seen["general.toml"] == seen["lagrange.toml"] == seen["chaotic_top.toml"] == "[]", seen
