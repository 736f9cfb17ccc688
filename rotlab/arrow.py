"""pyarrow without pandas in rotlab's own processes (``rotlab run``, ``rotlab sweep``, batch and
sweep workers).

Rerun converts every NumPy column with ``pyarrow.array``, whose first call asks "is this a pandas
Series?" and, to answer, imports pandas if it is installed: start-up time and memory spent in a
process that never holds a pandas object (apache/arrow#34994); the first conversion of a Python
sequence (a sweep's results.parquet) asks again, from C++.  ``withhold_pandas`` lets both probes find no
pandas, so pyarrow answers "not pandas" from then on; pyarrow's pandas APIs
(``Table.to_pandas``, ``pa.array(series)`` after pandas is in use) import pandas themselves when
called, as usual.  Only for processes whose pyarrow calls are rotlab's: a library user's own
process is left alone.
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
