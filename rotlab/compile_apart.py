"""A long run compiles its numba kernels in a child process, so that the compiler's memory never
enters the process that streams the run.

numba keeps what it compiled for the life of the process: LLVM's modules and the JIT's code,
native memory that neither ``gc.collect()`` nor ``malloc_trim`` returns.  A kernel loaded from
the on-disk cache costs a fraction of that.  So before a run of ``LONG_RUN`` samples
or more (``rotlab run``), the kernels the run calls are *rehearsed* on its first few samples with
compiling refused: if numba would compile any of them, a child process rehearses the same scene,
method and settings (compiling and saving every kernel to the cache, at the price of a child's
start-up on top of the compilation), and the run then loads them from the cache: its memory peak
is that of loaded kernels, not of the compiler's leftovers.

If the child fails, or its kernels cannot be loaded after it (numba could not write its cache),
the run compiles in process instead (and reports any error itself).  Ctrl-C or ``--timeout``
during the child's compilation kill it.

    python -m rotlab.compile_apart    # the child: a pickled (scenario, method, settings) on stdin
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rotlab.config.models import Scenario
from rotlab.methods.base import NO_STEPS, Method, Settings
from rotlab.scene.scene import Scene

LONG_RUN = 100_000  # samples: from here on a run's kernels are compiled apart (a default shipped run has ≤ 2,001)
REHEARSAL_SAMPLES = 3


class WouldCompile(Exception):
    """numba was about to compile (not load from its cache) a kernel while compiling was refused."""


@dataclass(frozen=True)
class Outcome:
    compiled_apart: bool  # a child process compiled the run's kernels
    seconds: float  # the child's wall time (0 when nothing had to compile)
    timed_out: bool = False  # the deadline passed while the child compiled (it was killed)
    interrupted: bool = False  # Ctrl-C (or SIGTERM) while the child compiled (it was killed)


def rehearse(scene: Scene, method: Method, settings: Settings) -> None:
    """Call every numba kernel a streamed run of ``scene`` calls, on its first samples: the
    method's (streamed, as ``rotlab run`` does) and the recording's load views (``loads_view``)."""
    from rotlab.methods.stepping import RunControl, SampleTimes, controlled
    from rotlab.recording import loads_view

    time_ = scene.scenario.time
    interval = (time_.end - time_.start) / max(time_.sample_count - 1, 1)
    t = SampleTimes(time_.start, time_.start + (REHEARSAL_SAMPLES - 1) * interval, REHEARSAL_SAMPLES)
    with controlled(RunControl(consumer=_Discard())):
        solution = method.solve(scene, t, settings, None)
    q_p, w_p = solution.state[:, :4], solution.state[:, 4:7]  # the last window's rows: [valid − len, valid)
    times = np.asarray(t[solution.valid - q_p.shape[0]:solution.valid], dtype=np.float64)
    for view in loads_view.load_views(scene):
        loads_view.torques(scene, view, times, q_p, w_p)


def needs_rehearsal(scene: Scene, method: Method) -> bool:
    """Does a run call any numba kernel (a stepping method, or the recording's view of a load)?"""
    return method.stepping != NO_STEPS or bool(scene.scenario.loads)


def prepare(scene: Scene, method: Method, settings: Settings, announce: Callable[[bool], None] | None = None,
            deadline: float | None = None) -> Outcome:
    """Make sure the run's kernels load from numba's cache, compiling them in a child process when
    they are not there (``deadline``: a ``time.monotonic()`` value past which the child is killed)."""
    if not needs_rehearsal(scene, method) or _loads_from_cache(scene, method, settings):
        return Outcome(False, 0.0)
    if announce is not None:
        announce(True)
    try:
        started = time.perf_counter()
        status = _compile_in_child(scene.scenario, method.name, settings, deadline)
        seconds = time.perf_counter() - started
    finally:
        if announce is not None:
            announce(False)
    if status is None:
        return Outcome(True, seconds, timed_out=True)
    # the child failed, or could not write numba's cache: the run compiles in this process
    return Outcome(status == 0 and _loads_from_cache(scene, method, settings), seconds)


def _loads_from_cache(scene: Scene, method: Method, settings: Settings) -> bool:
    """Does the rehearsal run with compiling refused (every kernel loaded, or already in memory)?
    Any other error counts as yes: the run itself meets it and reports it where it belongs."""
    try:
        with compiling_refused():
            rehearse(scene, method, settings)
    except WouldCompile:
        return False
    except Exception:  # noqa: BLE001 - not this module's to report
        return True
    return True


@contextmanager
def compiling_refused() -> Iterator[None]:
    """Raise ``WouldCompile`` where numba would compile a function in the block (a cache load is
    allowed): numba announces each compilation as the event ``numba:compile`` before it starts."""
    from numba.core import event

    class Refuse(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            function = getattr(ev.data.get("dispatcher"), "py_func", None)
            raise WouldCompile(getattr(function, "__qualname__", "a numba function"))

        def on_end(self, ev: event.Event) -> None:
            pass

    with event.install_listener("numba:compile", Refuse()):
        yield


def _compile_in_child(scenario: Scenario, method: str, settings: Settings, deadline: float | None) -> int | None:
    """Run this module in a child on the pickled arguments; its exit status (None: killed at the
    deadline).  The child imports the same rotlab as this process (numba's cache is keyed by the
    kernels' files) and inherits its environment, so its numba cache too."""
    package_root = str(Path(__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH")) if p))
    # -P: not the working directory first on the path (a checkout's rotlab/ beside an installed one)
    child = subprocess.Popen([sys.executable, "-P", "-m", "rotlab.compile_apart"], stdin=subprocess.PIPE,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    try:
        try:
            with child.stdin:
                child.stdin.write(pickle.dumps((scenario, method, settings)))
        except BrokenPipeError:  # the child ended before reading: its exit status says it failed
            pass
        return child.wait(None if deadline is None else max(deadline - time.monotonic(), 0.0))
    except subprocess.TimeoutExpired:
        return None
    finally:
        if child.returncode is None:
            child.kill()
            child.wait()


class _Discard:
    def rows(self, start: int, t: np.ndarray, state: np.ndarray) -> None:
        pass


def _main() -> int:
    from rotlab.methods.registry import get_method
    from rotlab.scene.scene import build_scene

    scenario, method, settings = pickle.loads(sys.stdin.buffer.read())
    rehearse(build_scene(scenario), get_method(method), settings)
    return 0


if __name__ == "__main__":
    sys.exit(_main())
