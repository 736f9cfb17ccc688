"""Imports a dependency would make, in rotlab's own processes (``rotlab run``, ``rotlab sweep``,
batch and sweep workers), to answer a question rotlab never asks.  Only there: a library user's
own process is left alone.

* pandas, by pyarrow.  Rerun converts every NumPy column with ``pyarrow.array``, whose first call
  asks "is this a pandas Series?" and, to answer, imports pandas if it is installed: start-up
  time and memory spent in a process that never holds a pandas object (apache/arrow#34994); the
  first conversion of a Python sequence (a sweep's results.parquet) asks again, from C++.
  ``withhold_pandas`` lets both probes find no pandas, so pyarrow answers "not pandas" from then
  on; pyarrow's pandas APIs (``Table.to_pandas``, ``pa.array(series)`` after pandas is in use)
  import pandas themselves when called, as usual.
* SciPy's linear algebra, by numba.  Setting up its CPU target (the first kernel compiled or
  loaded from the cache), numba imports ``scipy.linalg`` to learn whether BLAS is there for
  ``np.convolve`` and ``np.correlate``, which no rotlab kernel calls: 11 MB of a run's resident
  memory and ~0.2 s.  ``withhold_scipy_linalg`` refuses that one probe (numba then takes its own
  loop for those two functions); any other import of ``scipy.linalg``, numba's ``np.dot`` and
  ``np.linalg`` included, proceeds as usual.
"""

from __future__ import annotations

import sys


class _NoPandas:
    """A meta-path finder that refuses ``pandas`` (only while pyarrow's probe runs)."""

    def find_spec(self, name: str, path: object = None, target: object = None) -> None:
        if name == "pandas" or name.startswith("pandas."):
            raise ModuleNotFoundError("pandas is not needed by rotlab's recording", name=name)
        return None


def withhold_pandas() -> bool:
    """Run pyarrow's one-time pandas probe with pandas out of reach.  Returns True when the
    probe ran without pandas; False when pandas was already imported (nothing to save)."""
    if "pandas" in sys.modules:
        return False
    import numpy as np
    import pyarrow as pa

    blocker = _NoPandas()
    sys.meta_path.insert(0, blocker)
    try:
        pa.array(np.zeros(1))  # NumPy input: pyarrow checks is_series once, and remembers the answer
        pa.array([0.0])  # a Python sequence (a sweep's results table): its C++ converter's own probe, also remembered
    finally:
        sys.meta_path.remove(blocker)
    return "pandas" not in sys.modules


BLAS_PROBE = ("numba.np.arraymath", "_check_blas")  # (module, function) of numba's one-time probe


class _NoBlasProbe:
    """A meta-path finder, used once: it refuses ``scipy.linalg`` to numba's BLAS probe, then
    leaves ``sys.meta_path``; an import of ``scipy.linalg`` from anywhere else, first, makes it
    leave at once (nothing to save then)."""

    def find_spec(self, name: str, path: object = None, target: object = None) -> None:
        if name != "scipy.linalg":
            return None
        _leave(self)
        frame = sys._getframe(1)
        while frame is not None:
            if (frame.f_globals.get("__name__"), frame.f_code.co_name) == BLAS_PROBE:
                raise ModuleNotFoundError("numba's BLAS probe: not needed by rotlab's kernels", name=name)
            frame = frame.f_back
        return None


def _leave(finder: object) -> None:
    """Take ``finder`` out of ``sys.meta_path`` by replacing the list: importlib may be walking
    the old one now (removing from it would skip the next finder for this import)."""
    if finder in sys.meta_path:
        sys.meta_path = [other for other in sys.meta_path if other is not finder]


def withhold_scipy_linalg() -> bool:
    """Refuse ``scipy.linalg`` to numba's BLAS probe when it runs (see the module docstring).
    Returns False when the probe has run already or ``scipy.linalg`` is imported (nothing to save)."""
    if "scipy.linalg" in sys.modules or BLAS_PROBE[0] in sys.modules:
        return False
    if not any(isinstance(finder, _NoBlasProbe) for finder in sys.meta_path):
        sys.meta_path.insert(0, _NoBlasProbe())
    return True
