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


_SINGULAR_FROM_THE_START = (  # f(0, y0) not finite: NaN (sqrt of a negative number) and overflow
    "0.001*sqrt(t-1)",
    "1e308*exp(t*1000)",
)


def _expression_scene(torque_x: str, method: str) -> str:
    return ('[body]\nprincipal_moments = [0.01, 0.016, 0.022]\n[initial]\nomega = [1.0, 0.5, 3.0]\n'
            f'[time]\nend = 2.0\n[solver]\nmethod = "{method}"\nrtol = 1e-10\n'
            f'[[loads]]\ntype = "expression"\nframe = "body"\ntorque = ["{torque_x}", "0", "0"]\n')


@pytest.mark.parametrize("torque_x", _SINGULAR_FROM_THE_START)
def test_dop853_stops_at_once_when_the_right_hand_side_is_not_finite_at_the_start(tmp_path, torque_x):
    """dop853 used to take a NaN first step and reject it forever inside one kernel call: Ctrl-C,
    SIGTERM and --timeout were never honoured (only SIGKILL ended it); an overflowing f gave a
    ZeroDivisionError traceback.  A subprocess with a timeout, so a regression fails, not hangs."""
    config = tmp_path / "singular.toml"
    config.write_text(_expression_scene(torque_x, "dop853"))
    done = subprocess.run([sys.executable, "-m", "rotlab", "run", str(config), "-o", str(tmp_path / "s.rrd"), "-q"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr and len(done.stderr.strip().splitlines()) == 1
    if "sqrt" in torque_x:  # f is NaN at the start: the formula is named (tests/test_load_faults.py)
        assert f"loads[0].torque[0] = '{torque_x}' is not finite at t = 0 s (ω = [1. , 0.5, 3. ] rad/s" in done.stderr
    else:  # f is finite (1e308) and the state overflows
        assert "state became non-finite between t = 0 s and t = 0.01 s" in done.stderr
        assert "last valid state: Λ = [1. 0. 0. 0.]" in done.stderr
    assert (tmp_path / "s.partial.rrd").exists() and not (tmp_path / "s.rrd").exists()


@pytest.mark.parametrize("method", ["taylor", "rk4"])
def test_a_failure_message_names_the_last_sample_it_keeps(method):
    """A kernel can write non-finite rows before it stops (``taylor`` evaluates a whole step's
    samples): the message names the interval after the last finite row, which is what is kept
    (it said "between t = 2 s and t = 2 s; last valid state: Λ = [nan nan nan nan]")."""
    from rotlab.config import parse_scenario
    import tomllib

    traj = rotlab.simulate(parse_scenario(tomllib.loads(_expression_scene(_SINGULAR_FROM_THE_START[1], method))), check=False)
    failure = traj.stats.failure  # rk4: the state overflows; taylor: the formula's series does, and is named
    assert failure.startswith("state became non-finite between t = 0 s and t = 0.01 s; last valid state: Λ = [1. 0. 0. 0.]") or (
        failure.startswith("loads[0].torque[0] = '1e308*exp(t*1000)' has no finite Taylor series at t = 0 s (ω = [1. , 0.5, 3. ] rad/s"))
    assert "nan" not in failure and len(traj.omega) == 1


def test_dop853_counts_rejected_steps_against_a_calls_budget():
    """Every attempt counts, rejected ones included, so a kernel call always returns to the
    driver (Ctrl-C, --timeout and the step budget are checked between calls)."""
    import numpy as np

    from rotlab.core import dop853
    from rotlab.scene.scene import build_scene

    scene = build_scene(rotlab.load(CONFIGS / "lagrange.toml", method="dop853"))
    times = np.linspace(0.0, 10.0, 3)
    out = np.empty((3, 8))
    counters = np.zeros(3, dtype=np.int64)
    y = scene.state0.copy()
    # a first trial step of 10 s on a top spinning at 50 rad/s: rejected several times over
    status, i, t, h = dop853.dop853_advance(y, 0.0, 10.0, times, out, 1, 10.0, 1e-10, 1e-12, 3, scene.model, counters)
    assert status == dop853.OK and counters[1] >= 1
    assert counters[0] + counters[1] == 3


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_an_adaptive_runs_step_budget_message_names_how_far_its_steps_got(method):
    """A fast-growing spin from t = 0 (tiny moments, a torque growing with ω) exhausts the step
    budget long before the first sample at 0.01 s: the message names the integrator's time, not
    the last sample's (it said "exhausted at t = 0 s")."""
    from rotlab.config import parse_scenario

    sc = parse_scenario({"body": {"principal_moments": [1e-12, 1.5e-12, 2e-12]}, "initial": {"omega": [0.3, 0.2, 5.0]},
                         "loads": [{"type": "expression", "frame": "body",
                                    "torque": ["omega[1]*omega[2]*1e-10", "omega[0]**2*1e-11", "1"]}],
                         "time": {"end": 5.0}, "solver": {"method": method, "max_steps": 1000}})
    traj = rotlab.simulate(sc, check=False)
    failure = traj.stats.failure
    assert failure.startswith("step budget of 1,000 steps exhausted at t = ") and len(traj.omega) == 1
    reached = float(failure.split("at t = ")[1].split(" s")[0])
    assert 0.0 < reached < 0.01
