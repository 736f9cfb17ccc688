"""The time a call spends compiling numba kernels or loading them from the on-disk cache, so that
a run's summary reports integration time apart from it (a first ``rk4`` run in a process used to
report ~9 s of "integration" that was compilation).

numba holds its global compiler lock while it compiles a kernel or loads one from the cache, and
announces it as the event ``numba:compiler_lock``; a ``TimingListener`` on that event sums the
outermost holds.  When numba has not been imported, nothing can compile and the clock reads 0.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass


@dataclass
class CompileClock:
    seconds: float = 0.0  # compile + cache-load time inside the ``with`` block


@contextmanager
def compile_clock() -> Iterator[CompileClock]:
    clock = CompileClock()
    if "numba" not in sys.modules:  # a method that uses numba imports it before it runs (registry → module)
        yield clock
        return
    from numba.core import event

    listener = event.TimingListener()
    with event.install_listener("numba:compiler_lock", listener):
        yield clock
    clock.seconds = listener.duration if listener.done else 0.0
