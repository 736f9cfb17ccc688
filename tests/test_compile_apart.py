"""A long run compiles its kernels in a child process (rotlab.compile_apart): the run's own
process loads every kernel from numba's cache and compiles nothing."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numba
import pytest

from rotlab.compile_apart import WouldCompile, compiling_refused

# a heavy-free body with an expression torque: the method's kernel and the recording's load-view
# kernel (``core.torques.torque_samples``) both compile on an empty cache
SCENE = """
[body]
principal_moments = [1.0, 2.0, 3.0]

[initial]
omega = [0.3, 1.0, 0.2]

[[loads]]
type = "expression"
frame = "body"
constants = { k = 0.1 }
torque = ["-k*omega[0]", "0.05*sin(t)", "-k*omega[2]"]

[time]
end = 0.5
sample_rate = 100

[solver]
method = "rk4"
"""

RECORD = """
import json, sys
from pathlib import Path
from rotlab import api, compile_apart
from rotlab.core import rk4, torques
from rotlab.recording.sink import LiveOptions, RecordingSink
from rotlab.scene.scene import build_scene

compile_apart.LONG_RUN = 1  # this 51-sample run counts as long
scene = build_scene(api.load(Path(sys.argv[1])))
run, writing, final = api.record(scene, RecordingSink(Path(sys.argv[2]), LiveOptions()))
print(json.dumps({"kernels": run.stats.details.get("kernels"), "compile_seconds": run.stats.compile_seconds, "final": str(final),
                  "integration_seconds": run.stats.seconds,
                  "samples": run.samples, "hits": {f.__name__: sum(f.stats.cache_hits.values()) for f in (rk4.rk4_advance, torques.torque_samples)},
                  "overloads": {f.__name__: len(f.overloads) for f in (rk4.rk4_advance, torques.torque_samples)}}))
"""


def _record(tmp_path: Path, cache: Path) -> dict:
    """RECORD in a process run from a folder that holds a decoy ``rotlab/`` (a checkout beside
    an installed rotlab): the child must import the run's rotlab, not the working directory's."""
    config = tmp_path / "scene.toml"
    config.write_text(SCENE)
    (tmp_path / "rotlab").mkdir(exist_ok=True)
    (tmp_path / "rotlab" / "__init__.py").write_text("raise ImportError('the decoy rotlab in the working directory')\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "ROTLAB_CACHE": str(cache / "formulas")}
    done = subprocess.run([sys.executable, "-P", "-c", RECORD, str(config), str(tmp_path / "run.rrd")], env=env, cwd=tmp_path,
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


def test_on_an_empty_cache_a_long_run_loads_kernels_a_child_compiled(tmp_path):
    """Every kernel the run calls is loaded from the cache (one cache hit per specialisation),
    none compiled in the run's process; the child's time is reported as compile time."""
    cache = tmp_path / "numba-cache"
    first = _record(tmp_path, cache)
    assert first["kernels"] == "compiled in a child process"
    assert first["samples"] == 51 and Path(first["final"]).is_file()
    assert first["overloads"] == {"rk4_advance": 1, "torque_samples": 1}
    assert first["hits"] == first["overloads"], first  # loaded, not compiled here
    assert first["compile_seconds"] > 0.5  # the child: a Python start-up and rk4's compilation
    again = _record(tmp_path, cache)
    assert again["kernels"] is None  # nothing left to compile: no child
    # the rehearsal's cache loads are compile time, not taken off the integration (it read 0 s)
    assert first["integration_seconds"] > 0 and again["integration_seconds"] > 0
    assert again["hits"] == again["overloads"] == first["overloads"]


def test_refused_compiling_raises_and_cached_code_still_runs():
    @numba.njit
    def twice(x):
        return 2.0 * x

    with pytest.raises(WouldCompile, match="twice"), compiling_refused():
        twice(1.5)
    assert twice(1.5) == 3.0  # the refusal ended with its block: compiled now
    with compiling_refused():
        assert twice(2.5) == 5.0  # the same specialisation: nothing to compile


LONG_SCENE = SCENE.replace("end = 0.5\nsample_rate = 100", "end = 1000.0\nsample_rate = 1000")  # 10⁶ samples: compiled apart


def _children_of(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == pid:
            found.append(int(entry.name))
    return found


@pytest.mark.parametrize("stop", ["timeout", "sigint"])
def test_a_run_stopped_while_the_child_compiles_kills_it_and_writes_nothing(tmp_path, stop):
    config = tmp_path / "long.toml"
    config.write_text(LONG_SCENE)
    output = tmp_path / "long.rrd"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache"), "ROTLAB_CACHE": str(tmp_path / "formulas")}
    command = [sys.executable, "-m", "rotlab", "run", str(config), "-o", str(output), "--quiet"]
    if stop == "timeout":
        command += ["--timeout", "1.5"]
    run = subprocess.Popen(command, env=env, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    child: list[int] = []
    deadline = time.monotonic() + 60
    while not child and time.monotonic() < deadline and run.poll() is None:
        child = _children_of(run.pid)
        time.sleep(0.05)
    assert child, "no child process compiled the kernels"
    if stop == "sigint":
        time.sleep(0.5)
        run.send_signal(signal.SIGINT)
    out, err = run.communicate(timeout=120)
    said = {"timeout": "wall-clock limit of 1.5 s (--timeout) reached at t = 0 s (while a child process compiled the kernels)",
            "sigint": "interrupted by the user at t = 0 s (while a child process compiled the kernels)"}[stop]
    assert run.returncode == (1 if stop == "timeout" else 130), err
    assert said in err and "no sample was kept" in err and "Traceback" not in err, err
    assert not Path(f"/proc/{child[0]}").exists() or "compile_apart" not in Path(f"/proc/{child[0]}/cmdline").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["formulas", "long.toml", "numba-cache"]  # no recording, no partial file


@pytest.mark.parametrize("child_status, outcome", [(0, (False, False)), (1, (False, False)), (None, (True, True))])
def test_when_the_child_cannot_leave_loadable_kernels_the_run_compiles_them_itself(monkeypatch, child_status, outcome):
    """A child that exits 0 but leaves nothing to load (numba could not write its cache) or
    fails: not ``compiled_apart`` (the run compiles in process); killed at the deadline: timed out."""
    from rotlab import compile_apart
    from rotlab.methods.registry import get_method
    from rotlab.scene.scene import build_scene
    from tests.helpers import scenario

    @numba.njit
    def kernel(x):
        return x + 1.0

    monkeypatch.setattr(compile_apart, "rehearse", lambda scene, method, settings: kernel(1.0))
    monkeypatch.setattr(compile_apart, "_compile_in_child", lambda *args: child_status)
    scene = build_scene(scenario(body={"principal_moments": [1.0, 2.0, 3.0]}, initial={"omega": [0.1, 1.0, 0.1]}))
    got = compile_apart.prepare(scene, get_method("rk4"), None)
    assert (got.compiled_apart, got.timed_out) == outcome
    assert not kernel.signatures  # nothing compiled in this process yet: the run will, if it must


def test_a_rehearsal_that_fails_otherwise_leaves_the_error_to_the_run(monkeypatch):
    """An error other than a refused compile (a bug, a scene that fails at once) starts no child:
    the run meets it itself and reports it as it always has."""
    from rotlab import compile_apart
    from rotlab.methods.registry import get_method
    from rotlab.scene.scene import build_scene
    from tests.helpers import scenario

    def broken(scene, method, settings):
        raise ValueError("not a compile")

    monkeypatch.setattr(compile_apart, "rehearse", broken)
    monkeypatch.setattr(compile_apart, "_compile_in_child", lambda *args: pytest.fail("no child expected"))
    scene = build_scene(scenario(body={"principal_moments": [1.0, 2.0, 3.0]}, initial={"omega": [0.1, 1.0, 0.1]}))
    assert compile_apart.prepare(scene, get_method("rk4"), None) == compile_apart.Outcome(False, 0.0)


def test_a_child_that_ends_before_reading_its_input_is_a_failed_child(monkeypatch):
    """Writing the arguments to a child that already exited (its stdin closed) must not raise
    out of the run: it is a child that failed, and the run compiles in process."""
    from rotlab import compile_apart

    monkeypatch.setattr(compile_apart.sys, "executable", "/bin/false")
    monkeypatch.setattr(compile_apart.pickle, "dumps", lambda obj: b"x" * (1 << 22))  # more than a pipe holds
    assert compile_apart._compile_in_child(None, "rk4", None, None) == 1
