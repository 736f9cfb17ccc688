"""The time a call spends compiling numba kernels or loading them from the on-disk cache, so that
a run's summary reports integration and writing time apart from it (a first ``rk4`` run in a
process used to report ~9 s of "integration" that was compilation, and a first ``general.toml``
run ~6 s of "writing" that was the load views' kernel).

numba holds its global compiler lock while it compiles a kernel or loads one from the cache, and
announces it as the event ``numba:compiler_lock``; the clock sums the outermost holds and can be
read while its block runs (``seconds`` includes a hold in progress), so a part of the block (the
writer) can take its own compile time out.  A real compilation (not a cache load) is announced
as ``numba:compile``: ``announce(True)`` when the outermost one starts, ``announce(False)`` when it
ends (the progress bar says "compiling").  When numba has not been imported, nothing can compile
and the clock reads 0.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from functools import cache


class CompileClock:
    """Outermost compiler-lock holds (compile + cache load) inside a ``compile_clock`` block."""

    def __init__(self) -> None:
        self._total = 0.0
        self._since: float | None = None  # start of the hold in progress

    @property
    def seconds(self) -> float:
        held = 0.0 if self._since is None else time.perf_counter() - self._since
        return self._total + held

    def held(self) -> None:
        self._since = time.perf_counter()

    def released(self) -> None:
        if self._since is not None:
            self._total += time.perf_counter() - self._since
            self._since = None


@contextmanager
def compile_clock(announce: Callable[[bool], None] | None = None) -> Iterator[CompileClock]:
    """A ``CompileClock`` running over the block; ``announce(compiling)`` at the outermost
    start and end of each real compilation."""
    clock = CompileClock()
    if "numba" not in sys.modules:  # a method that uses numba imports it before it runs (registry → module)
        yield clock
        return
    from numba.core import event

    with ExitStack() as listening:
        listening.callback(clock.released)  # a compile cut short (Ctrl-C raised inside numba) never sends its end
        listening.enter_context(event.install_listener("numba:compiler_lock", _Listener(clock.held, clock.released)))
        if announce is not None:
            listening.enter_context(event.install_listener("numba:compile", _Listener(lambda: announce(True), lambda: announce(False))))
        yield clock


def _Listener(start: Callable[[], None], end: Callable[[], None]):  # noqa: N802 — a numba Listener
    """A numba event listener calling ``start`` at the outermost start event and ``end`` at its end."""
    return _outermost_class()(start, end)


@cache
def _outermost_class():
    """The listener class, made once (numba's ``Listener`` base is imported only when numba is)."""
    from numba.core import event

    class Outermost(event.Listener):
        def __init__(self, start: Callable[[], None], end: Callable[[], None]) -> None:
            self.start, self.end, self.depth = start, end, 0

        def on_start(self, ev) -> None:
            self.depth += 1
            if self.depth == 1:
                self.start()

        def on_end(self, ev) -> None:
            self.depth -= 1
            if self.depth == 0:
                self.end()

    return Outermost
