"""Local worker processes for batch runs and sweeps.

Workers come from a ``forkserver``: forking a process that already runs threads (numba's
parallel layer, Rerun's writer) is unsafe, and ``spawn`` would re-import everything per worker.
"""

from __future__ import annotations

import multiprocessing
from concurrent.futures import ProcessPoolExecutor


def process_pool(jobs: int) -> ProcessPoolExecutor:
    return ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("forkserver"))
