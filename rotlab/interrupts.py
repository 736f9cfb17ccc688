"""Ctrl-C (SIGINT) that always ends a run cleanly.

Python turns SIGINT into a ``KeyboardInterrupt`` at whatever Python code runs next.  Two kinds of
foreign code break that: a ctypes callback (llvmlite calls one while numba compiles or loads a kernel)
swallows the exception ("Exception ignored on calling ctypes callback function") and the run goes on
as if Ctrl-C had never been pressed; code that a C extension runs through ``PyRun_String`` (Cython
modules do, on import) marks the interrupt as unhandled, so the interpreter ends by the signal itself
(exit −2, after rotlab has printed its message and chosen exit 130) even though rotlab caught it.

The executable therefore defers Ctrl-C over those two phases — imports and numba's compiler lock —
and delivers it when they end: at the next Python line, where rotlab's handlers catch it.  Between
phases, and inside compiled kernels (which return to Python every chunk), nothing changes.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator


@contextlib.contextmanager
def deferred(deliver: bool = True) -> Iterator[None]:
    """Hold Ctrl-C inside the block; at its end raise ``KeyboardInterrupt`` if one came
    (``deliver=False``: drop it — for finishing a file, when the run is already over).
    Outside the main thread (where signals cannot be handled): no change."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if received and deliver:
        raise KeyboardInterrupt


class _CompilerLockShield:
    """numba event listener: SIGINT held while the main thread holds numba's compiler lock
    (compiling, or loading a kernel from the on-disk cache), re-sent to the process when the
    outermost hold ends, so the handler in force then (usually Python's) sees it."""

    def __init__(self) -> None:
        self.depth = 0
        self.previous: object = None
        self.received = False

    def on_start(self, event: object) -> None:
        if threading.current_thread() is not threading.main_thread():
            return
        self.depth += 1
        if self.depth == 1:
            self.received = False
            self.previous = signal.signal(signal.SIGINT, self._hold)

    def on_end(self, event: object) -> None:
        if threading.current_thread() is not threading.main_thread() or self.depth == 0:
            return
        self.depth -= 1
        if self.depth == 0:
            signal.signal(signal.SIGINT, self.previous)  # type: ignore[arg-type]
            if self.received:
                signal.raise_signal(signal.SIGINT)

    def _hold(self, signum: int, frame: object) -> None:
        self.received = True


_shield: _CompilerLockShield | None = None


def shield_numba_compilation() -> None:
    """From now on, Ctrl-C during a numba compilation or cache load is delivered after it
    (idempotent; the rotlab executable calls it, the library API does not touch signals)."""
    global _shield
    if _shield is not None:
        return
    from numba.core import event

    shield = _CompilerLockShield()

    class Listener(event.Listener):  # numba's abstract listener, forwarding to the shield
        def on_start(self, ev: event.Event) -> None:
            shield.on_start(ev)

        def on_end(self, ev: event.Event) -> None:
            shield.on_end(ev)

    event.register("numba:compiler_lock", Listener())
    _shield = shield
