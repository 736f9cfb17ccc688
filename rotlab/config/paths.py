"""Key paths into a scenario document: ``loads[0].value[2]``, ``initial.omega``, ``body.mass``.

One setter serves every place that edits a scenario before it is validated: ``--set KEY=VALUE``
on the command line, ``overrides={...}`` in the Python API and the cases of a ``[sweep]``.
"""

from __future__ import annotations

import copy
import re
import tomllib
from collections.abc import Sequence
from functools import lru_cache
from typing import Any, Callable

from rotlab.errors import InputError

_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)")

Defaults = Callable[[list[str | int]], Any]  # the validated value at a path (for indexing into a default)


def parse_key_path(path: str, where: str) -> list[str | int]:
    """'loads[0].value[2]' → ['loads', 0, 'value', 2]; ``where`` names the path in errors."""
    return list(_key_parts(path, where))


@lru_cache(maxsize=256)
def _key_parts(path: str, where: str) -> tuple[str | int, ...]:
    """``parse_key_path``'s parts, parsed once per path (a sweep sets the same paths in every case)."""
    parts: list[str | int] = []
    for piece in path.split("."):
        match = _PART.fullmatch(piece)
        if not match:
            raise InputError(where, "not a key path: write e.g. initial.omega[2] or body.mass")
        parts.append(match.group(1))
        parts.extend(int(k) for k in re.findall(r"\[(\d+)\]", match.group(2)))
    return tuple(parts)


def parse_assignment(text: str) -> tuple[str, Any]:
    """'initial.omega=[0, 0, 50]' → ('initial.omega', [0, 0, 50]).  The value is a TOML value;
    a bare word that is not one (``solver.method=rk4``) is taken as a string."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(f"--set {text}", "write KEY=VALUE, e.g. --set initial.omega=[0,0,50] or --set solver.method=rk4")
    try:
        value = tomllib.loads(f"value = {raw.strip()}")["value"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    except ValueError:  # an integer literal beyond Python's digit limit (4,300)
        raise InputError(f"--set {key}", "a number too long to read: write it with an exponent, e.g. 1e30") from None
    return key, value


def set_at(data: dict[str, Any], path: str, value: Any, where: str, defaults: Defaults) -> None:
    """Set ``value`` at ``path`` in the raw scenario ``data`` (in place).  Missing tables are
    created; indexing into a vector the file does not give takes the model's default from
    ``defaults`` first (``initial.omega[2]`` on a file without ``omega``).  The tables and arrays
    along the path are replaced by copies, so ``data`` may share the rest with the document it was
    made from (a shallow copy of it) without changing that document."""
    parts = parse_key_path(path, where)
    node: Any = data
    for depth, part in enumerate(parts[:-1]):
        nxt = parts[depth + 1]
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                raise InputError(where, f"index [{part}] is out of range")
        else:
            if not isinstance(node, dict):
                raise InputError(where, f"'{part}' is inside a value, not a table")
            if part not in node or node[part] is None:
                node[part] = _as_lists(defaults(parts[: depth + 1]), where) if isinstance(nxt, int) else {}
        child = node[part]
        if isinstance(child, (dict, list)):
            child = node[part] = copy.copy(child)
        node = child
    last = parts[-1]
    if isinstance(last, int):
        if not isinstance(node, list) or last >= len(node):
            raise InputError(where, f"index [{last}] is out of range")
    elif not isinstance(node, dict):
        raise InputError(where, f"'{last}' is inside a value, not a table")
    node[last] = value


def group_of(key: str, groups: Sequence[set[str]]) -> frozenset[str] | None:
    """The group of ``groups`` that holds ``key`` (None where none does)."""
    return next((frozenset(group) for group in groups if key in group), None)


def drop_other_forms(data: dict[str, Any], path: str, groups: Sequence[set[str]], where: str) -> None:
    """Remove, beside the key that ``path`` names or indexes into (``omega`` of
    ``initial.omega[0]``), the other keys of its group of ``groups`` (``omega_rpm``, ``omega_deg``),
    in its table (already copied by ``set_at``)."""
    parts = parse_key_path(path, where)
    last = max(k for k, part in enumerate(parts) if isinstance(part, str))
    group = group_of(parts[last], groups)
    if group is None:
        return
    node: Any = data
    for part in parts[:last]:
        node = node[part]
    if isinstance(node, dict):
        for key in group - {parts[last]}:
            node.pop(key, None)


def model_defaults(model: Any) -> Defaults:
    """``defaults`` for ``set_at`` reading a validated scenario (or any pydantic model)."""

    def value_at(parts: list[str | int]) -> Any:
        obj: Any = model() if callable(model) else model
        for part in parts:
            obj = obj[part] if isinstance(part, int) else getattr(obj, part, None)
        return obj

    return value_at


def _as_lists(value: Any, where: str) -> list[Any]:
    if value is None:
        raise InputError(where, "has no value in the scenario to index into: give the whole vector")
    return [list(v) if isinstance(v, tuple) else v for v in value]
