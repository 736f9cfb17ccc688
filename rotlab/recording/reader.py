"""Read time series back from a recording with Rerun's own reader (tests, checks)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
from rerun.chunk import RrdReader

from rotlab.recording.layout import TIMELINE


def read_series(path: str | Path, entity: str, component: str = "Scalars:scalars") -> tuple[np.ndarray, np.ndarray]:
    """(times in s, values (N, k)) of one entity's temporal component, sorted by time."""
    times: list[np.ndarray] = []
    values: list[np.ndarray] = []
    for chunk in RrdReader(str(path)).stream().filter(content=entity, is_static=False, components=component):
        batch = chunk.to_record_batch()
        if TIMELINE not in batch.schema.names:
            continue
        times.append(batch.column(TIMELINE).cast(pa.int64()).to_numpy())
        column = batch.column(batch.schema.get_field_index(component))
        values.append(np.array(column.to_pylist(), dtype=np.float64))
    if not times:
        raise KeyError(f"no temporal {component} at {entity} in {path}")
    t = np.concatenate(times)
    v = np.concatenate(values)
    order = np.argsort(t, kind="stable")
    return t[order] * 1e-9, v[order]


def read_text(path: str | Path, entity: str) -> str:
    """The static TextDocument at ``entity``."""
    for chunk in RrdReader(str(path)).stream().filter(content=entity, is_static=True, components="TextDocument:text"):
        batch = chunk.to_record_batch()
        last = batch.column(batch.schema.get_field_index("TextDocument:text")).to_pylist()[-1]
        return str(last[0] if isinstance(last, list) else last)
    raise KeyError(f"no TextDocument at {entity} in {path}")
