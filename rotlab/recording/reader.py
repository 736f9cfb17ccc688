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
    """The static TextDocument at ``entity`` (the last one logged: a streamed run logs it at the
    start and again at the end)."""
    text = None
    for chunk in RrdReader(str(path)).stream().filter(content=entity, is_static=True, components="TextDocument:text"):
        batch = chunk.to_record_batch()
        last = batch.column(batch.schema.get_field_index("TextDocument:text")).to_pylist()[-1]
        text = str(last[0] if isinstance(last, list) else last)
    if text is None:
        raise KeyError(f"no TextDocument at {entity} in {path}")
    return text


def read_static(path: str | Path, entity: str, component: str) -> list:
    """The last value of one static component (a list: one element per instance); KeyError when absent."""
    for chunk in RrdReader(str(path)).stream().filter(content=entity, is_static=True, components=component).to_chunks():
        batch = chunk.to_record_batch()
        return batch.column(batch.schema.get_field_index(component)).to_pylist()[-1]
    raise KeyError(f"no static {component} at {entity}")


def entity_paths(path: str | Path) -> set[str]:
    """Every entity of the recording (not its blueprint) that holds data."""
    return {str(chunk.entity_path) for chunk in RrdReader(str(path)).stream().to_chunks()}


def view_queries(path: str | Path) -> dict[str, tuple[str, str, list[str]]]:
    """The default blueprint's views: view id → (name, origin, query lines)."""
    reader = RrdReader(str(path))
    views: dict[str, dict[str, object]] = {}
    for store in reader.blueprints():
        for chunk in reader.stream(store=store).to_chunks():
            entity = str(chunk.entity_path)
            if not entity.startswith("/view/"):
                continue
            view_id = entity.split("/")[2]
            batch = chunk.to_record_batch()
            for column, key in (("ViewContents:query", "query"), ("ViewBlueprint:space_origin", "origin"),
                                ("ViewBlueprint:display_name", "name")):
                if column in batch.schema.names:
                    value = batch.column(column).to_pylist()[-1]
                    views.setdefault(view_id, {})[key] = value
    out = {}
    for view_id, v in views.items():
        query = v.get("query") or ["$origin/**"]
        name = v.get("name") or ""
        origin = v.get("origin") or "/"
        out[view_id] = (name[0] if isinstance(name, list) else str(name), origin[0] if isinstance(origin, list) else str(origin),
                        list(query) if isinstance(query, list) else [str(query)])
    return out


def query_matches(lines: list[str], origin: str, entities: set[str]) -> set[str]:
    """The entities a view's query selects, by Rerun's rules: one rule per line, ``+ path`` (or a
    bare path) includes, ``- path`` excludes, ``$origin`` is the view's origin, a trailing ``/**``
    takes the whole subtree; anything else (e.g. a ``*`` inside a path) matches literally."""
    def rule_matches(rule: str, entity: str) -> bool:
        rule = rule.replace("$origin", origin.rstrip("/") if origin != "/" else "")
        if rule.endswith("/**"):
            base = rule[:-3]
            return base == "" or entity == base or entity.startswith(base + "/")
        return entity == (rule or "/")

    included: set[str] = set()
    excluded: set[str] = set()
    for raw in (r for line in lines for r in line.splitlines()):
        rule = raw.strip()
        if not rule:
            continue
        target = excluded if rule.startswith("-") else included
        rule = rule.lstrip("+-").strip()
        target.update(e for e in entities if rule_matches(rule, e))
    return included - excluded
