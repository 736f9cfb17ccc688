"""Keep glibc's heap between NumPy's temporaries, in rotlab's worker processes.

A sweep worker reports its cases with NumPy arithmetic on (cases, samples) arrays larger than
glibc's default thresholds.  By default glibc gives the top of its heap back to the system once
more than 128 kB is free there (``M_TRIM_THRESHOLD``) and maps large blocks afresh
(``M_MMAP_THRESHOLD``), so every such temporary faults its pages in again, a cost that keeping
the memory avoids (docs/benchmarks.md, "Sweeps: what a case costs").  ``keep_heap`` raises both
thresholds: blocks up to 32 MB come from the heap, and up to 64 MB of free heap is kept for the
next one.  Only for rotlab's own processes (workers, the sweep command): a library user's
process is left alone.
"""

from __future__ import annotations

import ctypes

M_TRIM_THRESHOLD = -1  # glibc's mallopt parameters (malloc.h)
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 32 << 20  # bytes: larger blocks are still mapped (and unmapped when freed)
TRIM_THRESHOLD = 64 << 20  # bytes of free heap kept before it is given back


def keep_heap() -> bool:
    """Raise glibc's mmap and trim thresholds (module docstring).  False where the C library has
    no ``mallopt`` (not glibc) or refuses: nothing changes then."""
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
