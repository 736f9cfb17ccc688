"""The time a call spends compiling numba kernels or loading them from the on-disk cache, so that
a run's summary reports integration and writing time apart from it (otherwise the first run in a
process would report its method kernel's compilation as integration, and the load views'
kernel's as writing).

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
from contextlib import AbstractContextManager, contextmanager, nullcontext
from functools import cache


class _Holds:
    """numba's outermost compiler-lock holds in this process, summed (one listener, registered on
    first use: installing a listener per run would add a fixed cost to every short ``simulate``)."""

    def __init__(self) -> None:
        self.total = 0.0
        self.since: float | None = None  # start of the hold in progress
        self.depth = 0

    @property
    def seconds(self) -> float:
        return self.total + (0.0 if self.since is None else time.perf_counter() - self.since)

    def on_start(self) -> None:
        self.depth += 1
        if self.depth == 1:
            self.since = time.perf_counter()

    def on_end(self) -> None:
        self.depth = max(self.depth - 1, 0)
        if self.depth == 0:
            self.close()

    def close(self) -> None:
        """End the hold in progress: also one cut short (Ctrl-C raised inside numba) whose end
        numba never announced."""
        if self.since is not None:
            self.total += time.perf_counter() - self.since
        self.since, self.depth = None, 0


class CompileClock:
    """The compiler-lock holds since the clock started; read while its block runs (``seconds``
    includes a hold in progress) and fixed when the block ends.  Without numba it reads 0."""

    def __init__(self, holds: _Holds | None = None) -> None:
        self._holds = holds
        self._start = 0.0 if holds is None else holds.seconds
        self._final: float | None = None

    @property
    def seconds(self) -> float:
        if self._final is not None:
            return self._final
        return 0.0 if self._holds is None else self._holds.seconds - self._start

    def released(self) -> None:
        """Nothing compiles now: close a hold whose end numba never announced."""
        if self._holds is not None:
            self._holds.close()

    def stop(self) -> None:
        self.released()
        self._final = self.seconds


def compile_clock(announce: Callable[[bool], None] | None = None) -> AbstractContextManager[CompileClock]:
    """A ``CompileClock`` running over the block; ``announce(compiling)`` at the outermost
    start and end of each real compilation."""
    if "numba" not in sys.modules:  # a method that uses numba imports it before it runs (registry → module)
        return nullcontext(CompileClock())
    if announce is None:
        return _Block(CompileClock(_holds()))
    return _announcing(announce)


class _Block:
    """The block of a clock (a class: a generator-based context manager costs more per run)."""

    def __init__(self, clock: CompileClock) -> None:
        self.clock = clock

    def __enter__(self) -> CompileClock:
        return self.clock

    def __exit__(self, *exc) -> None:
        self.clock.stop()


@contextmanager
def _announcing(announce: Callable[[bool], None]) -> Iterator[CompileClock]:
    from numba.core import event

    with _Block(CompileClock(_holds())) as clock:
        with event.install_listener("numba:compile", _Listener(lambda: announce(True), lambda: announce(False))):
            yield clock


@cache
def _holds() -> _Holds:
    """The process's ``_Holds``, its listener registered with numba (once)."""
    from numba.core import event

    holds = _Holds()
    event.register("numba:compiler_lock", _listener_classes()[0](holds.on_start, holds.on_end))  # _Holds counts the depth
    return holds


def _Listener(start: Callable[[], None], end: Callable[[], None]):  # noqa: N802 — a numba Listener
    """A numba event listener calling ``start`` at the outermost start event and ``end`` at its end."""
    return _listener_classes()[1](start, end)


@cache
def _listener_classes():
    """(forward every event, forward the outermost ones): made once (numba's ``Listener`` base is
    imported only when numba is)."""
    from numba.core import event

    class Forward(event.Listener):
        def __init__(self, start: Callable[[], None], end: Callable[[], None]) -> None:
            self.start, self.end = start, end

        def on_start(self, ev) -> None:
            self.start()

        def on_end(self, ev) -> None:
            self.end()

    class Outermost(Forward):
        def __init__(self, start: Callable[[], None], end: Callable[[], None]) -> None:
            super().__init__(start, end)
            self.depth = 0

        def on_start(self, ev) -> None:
            self.depth += 1
            if self.depth == 1:
                self.start()

        def on_end(self, ev) -> None:
            self.depth -= 1
            if self.depth == 0:
                self.end()

    return Forward, Outermost
