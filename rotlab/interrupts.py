"""Ctrl-C (SIGINT) and SIGTERM that always end a run cleanly.

Python turns SIGINT into a ``KeyboardInterrupt`` at whatever Python code runs next; the rotlab
executable makes SIGTERM (``kill``, ``timeout``, a cancelled CI job) do the same (``stop_on_sigterm``),
so both keep the valid samples in ``NAME.partial.rrd``.  Two kinds of foreign code break that: a
ctypes callback (llvmlite calls one while numba compiles or loads a kernel) swallows the exception
("Exception ignored on calling ctypes callback function") and the run goes on as if nothing had
happened; and an interrupt that ends code run from source text (``exec``/``eval`` of a string)
is marked unhandled even when caught, so the interpreter would end by the signal itself (exit −2)
after rotlab has chosen exit 130: the executable ends with ``os._exit`` (``rotlab.ending.leave``),
which that mark cannot reach.

The executable therefore holds these signals over the two phases — imports and numba's compiler
lock — and delivers them when the phase ends, at the next Python line, where rotlab's handlers catch
them.  Between phases, and inside compiled kernels (which return to Python every chunk), nothing
changes.  Only signals whose handler is Python code are held: a library user's SIGTERM (the
default action) still ends the process at once.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
stopped_by: int | None = None  # the last stop signal the executable turned into KeyboardInterrupt


def stop_on_sigterm() -> None:
    """SIGTERM raises ``KeyboardInterrupt`` like Ctrl-C (the rotlab executable; remembered in
    ``stopped_by`` for the exit code 143 and the wording)."""
    signal.signal(signal.SIGTERM, _raise_stop)


def _raise_stop(signum: int, frame: object) -> None:
    global stopped_by
    stopped_by = signum
    raise KeyboardInterrupt


def stopped_at(t: float) -> str:
    """A run's failure when a stop signal ended it at time ``t``: "interrupted by the user" (Ctrl-C)
    or "stopped by SIGTERM", "at t = … s"."""
    reason = "stopped by SIGTERM" if stopped_by == signal.SIGTERM else "interrupted by the user"
    return f"{reason} at t = {t:.9g} s"


def exit_code() -> int:
    """The executable's exit code after a stop: 128 + the signal (130 Ctrl-C, 143 SIGTERM)."""
    return 128 + (stopped_by or signal.SIGINT)


def _hold(record: Callable[[int, object], None]) -> dict[int, object]:
    """Install ``record`` for every stop signal that Python code handles; returns what it replaced."""
    saved: dict[int, object] = {}
    for signum in STOP_SIGNALS:
        current = signal.getsignal(signum)
        if callable(current):
            saved[signum] = signal.signal(signum, record)
    return saved


def _restore(saved: dict[int, object]) -> None:
    for signum, handler in saved.items():
        signal.signal(signum, handler)  # type: ignore[arg-type]


@contextlib.contextmanager
def deferred(deliver: bool = True) -> Iterator[None]:
    """Hold stop signals inside the block; at its end re-send the first that came, so the handler
    in force raises ``KeyboardInterrupt`` there (``deliver=False``: drop it — for finishing a file,
    when the run is already over).  Outside the main thread (where signals cannot be handled): no change."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    saved = _hold(lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        _restore(saved)
    if received and deliver:
        signal.raise_signal(received[0])


class _CompilerLockShield:
    """numba event listener: stop signals held while the main thread holds numba's compiler lock
    (compiling, or loading a kernel from the on-disk cache), re-sent to the process when the
    outermost hold ends, so the handler in force then (usually Python's) sees them.

    The hold follows the lock itself, not a count of events: an event can be lost (a listener
    that raises, e.g. a Ctrl-C delivered inside another listener, stops numba's broadcast), and a
    count stuck above 0 would hold Ctrl-C for the rest of the process.  So the hold ends at an end event
    after which the main thread no longer owns the lock, and a signal that finds no compilation
    under way (a lost end) ends the hold and is delivered at once."""

    def __init__(self, is_compiling: Callable[[], bool]) -> None:
        self.is_compiling = is_compiling  # does this (the main) thread own numba's compiler lock?
        self.saved: dict[int, object] | None = None
        self.received: list[int] = []

    def on_start(self, event: object) -> None:
        if threading.current_thread() is not threading.main_thread() or self.saved is not None:
            return
        self.received = []
        self.saved = _hold(self._record)

    def on_end(self, event: object) -> None:
        if threading.current_thread() is not threading.main_thread() or self.saved is None:
            return
        if not self.is_compiling():  # the outermost hold ended (numba releases, then announces)
            self._release()

    def _record(self, signum: int, frame: object) -> None:
        self.received.append(signum)
        if not self.is_compiling():  # a hold whose end was lost: deliver now
            self._release()

    def _release(self) -> None:
        saved, self.saved = self.saved, None
        _restore(saved or {})
        if self.received:
            signal.raise_signal(self.received[0])


_shield: _CompilerLockShield | None = None


def shield_numba_compilation() -> None:
    """From now on, a stop signal during a numba compilation or cache load is delivered after it
    (idempotent; the rotlab executable calls it, the library API does not touch signals)."""
    global _shield
    if _shield is not None:
        return
    from numba.core import event
    from numba.core.compiler_lock import global_compiler_lock

    shield = _CompilerLockShield(global_compiler_lock.is_locked)

    class Listener(event.Listener):  # numba's abstract listener, forwarding to the shield
        def on_start(self, ev: event.Event) -> None:
            shield.on_start(ev)

        def on_end(self, ev: event.Event) -> None:
            shield.on_end(ev)

    event.register("numba:compiler_lock", Listener())
    _shield = shield
