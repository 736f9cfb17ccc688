"""glibc's heap and NumPy's temporaries: kept in rotlab's worker processes, given back in a long run.

A sweep worker reports its cases with NumPy arithmetic on (cases, samples) arrays larger than
glibc's default thresholds.  By default glibc gives the top of its heap back to the system once
more than 128 kB is free there (``M_TRIM_THRESHOLD``) and maps large blocks afresh
(``M_MMAP_THRESHOLD``), so every such temporary faults its pages in again, a cost that keeping
the memory avoids (docs/benchmarks.md, "Sweeps: what a case costs").  ``keep_heap`` raises both
thresholds: blocks up to 32 MB come from the heap, and up to 64 MB of free heap is kept for the
next one.  Only for rotlab's own processes (workers, the sweep command): a library user's
process is left alone.

A streamed run (``rotlab.recording.stream``) is the opposite case: its chunks' temporaries
(0.1–1 MB each) come and go for the whole run, and glibc keeps the free space they leave inside
its heap; a run's resident memory rose by up to 70 MB that way, at a random point of a long run.
``HeapTrimmer`` gives the free pages back (``malloc_trim``) at most every ``TRIM_SECONDS``.
"""

from __future__ import annotations

import ctypes
import gc
import time
from collections.abc import Iterator
from contextlib import contextmanager

M_TRIM_THRESHOLD = -1  # glibc's mallopt parameters (malloc.h)
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 32 << 20  # bytes: larger blocks are still mapped (and unmapped when freed)
TRIM_THRESHOLD = 64 << 20  # bytes of free heap kept before it is given back


def _c_function(name: str, argtypes: tuple, restype):
    """The C library's function ``name`` with its types, or None where there is none (glibc's
    ``mallopt`` and ``malloc_trim``: not on macOS, musl or Windows)."""
    try:
        function = getattr(ctypes.CDLL(None), name)
    except (OSError, AttributeError, TypeError):  # (TypeError: Windows loads no library from None)
        return None
    function.argtypes, function.restype = argtypes, restype
    return function


def keep_heap() -> bool:
    """Raise glibc's mmap and trim thresholds (module docstring).  False where the C library has
    no ``mallopt`` (not glibc) or refuses: nothing changes then."""
    mallopt = _c_function("mallopt", (ctypes.c_int, ctypes.c_int), ctypes.c_int)
    if mallopt is None:
        return False
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))


@contextmanager
def objects_frozen() -> Iterator[None]:
    """Within: Python's cyclic collector leaves alone the objects alive on entry (``gc.freeze``;
    ``gc.unfreeze`` on exit, for a process that goes on: a caller's objects frozen for good
    would never be collected) — the ~10⁵ functions, classes and other objects of the modules
    imported before a sweep's cases, which each of its collections would otherwise traverse
    again while the cases make and drop their scenarios (in `rotlab sweep`'s own process,
    where the ensemble runs the cases: 9 → 8 s for 10⁵ short cases, docs/benchmarks.md,
    "Sweeps: what a case costs").  What they hold is still freed when nothing refers to it.
    Nothing is done where the process has frozen objects already: its own use of the collector stands."""
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


TRIM_SECONDS = 0.05  # s between two malloc_trim calls of a HeapTrimmer


class HeapTrimmer:
    """``trim()`` gives glibc's free heap pages back to the system (``malloc_trim(0)``: the top of
    the heap and whole free pages inside it), at most once every ``every`` seconds."""

    def __init__(self, every: float = TRIM_SECONDS) -> None:
        self.every, self._last = every, time.monotonic()
        self._trim = _c_function("malloc_trim", (ctypes.c_size_t,), ctypes.c_int)

    def trim(self) -> None:
        if self._trim is not None and time.monotonic() - self._last >= self.every:
            self._trim(0)
            self._last = time.monotonic()
