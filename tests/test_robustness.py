"""Runs that go wrong: refused steps, Ctrl-C, and outputs that are never clobbered."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import rotlab
from rotlab.errors import InputError
from tests.conftest import CONFIGS, VALID_BODY


def test_too_large_fixed_step_is_refused():
    sc = rotlab.load(CONFIGS / "lagrange.toml", method="rk4")
    sc = sc.model_copy(update={"solver": sc.solver.model_copy(update={"step": 0.05})})
    with pytest.raises(InputError, match="too large to be stable.*rk4's limit 2.8"):
        rotlab.simulate(sc)


def test_adaptive_method_adapts_where_a_fixed_step_is_refused():
    traj = rotlab.simulate(rotlab.load(CONFIGS / "lagrange.toml", method="dop853", duration=0.5))
    assert traj.stats.failure is None and max(traj.max_drift().values()) < 1e-9


def test_failed_run_never_replaces_an_existing_recording(cli, write, tmp_path):
    (tmp_path / "out.rrd").write_bytes(b"a good recording")
    path = write("boom.toml", VALID_BODY + '[initial]\nomega = [0, 0, 1]\n[[loads]]\ntype = "torque"\nframe = "body"\n'
                 'value = [1e30, 1e30, 0]\nwindow = { on = 0.5, off = 1.0 }\n[time]\nend = 1.0\nsample_rate = 100\n'
                 '[solver]\nmethod = "dop853"\n')
    result = cli("run", str(path), "-o", "out.rrd")
    assert result.exit_code == 1
    assert (tmp_path / "out.rrd").read_bytes() == b"a good recording"
    assert (tmp_path / "out.partial.rrd").exists()


def _rerun() -> str:
    return shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))


def test_ctrl_c_leaves_a_valid_partial_recording_or_none(tmp_path):
    config = tmp_path / "long.toml"
    config.write_text(VALID_BODY + "[initial]\nomega = [0.1, 2.0, 0.1]\n[time]\nend = 100000.0\nsample_rate = 1\n"
                      '[solver]\nmethod = "rk4"\nstep = 1e-4\nmax_steps = 2_000_000_000\n')
    proc = subprocess.Popen([sys.executable, "-m", "rotlab", "run", str(config), "-o", str(tmp_path / "long.rrd")],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(6.0)  # imports, cached kernels, then ~10⁸ steps/s·… of stepping
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "long.rrd").exists()
    partial = tmp_path / "long.partial.rrd"
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert not leftovers
    if partial.exists():  # interrupted while stepping: what was computed, complete and valid
        done = subprocess.run([_rerun(), "rrd", "verify", str(partial)], capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        assert "interrupted by the user" in err
    else:  # interrupted before stepping began: nothing written
        assert "interrupted" in err
