"""Read a scenario file and turn every problem into one line naming the key and the fix."""

from __future__ import annotations

import difflib
import tomllib
import types
import typing
from pathlib import Path
from typing import Any, Mapping

from pydantic import BaseModel, ValidationError

from rotlab.config.models import LOAD_MODELS, Scenario
from rotlab.errors import InputError

MAX_FILE_BYTES = 16 * 1024 * 1024


def read_toml(path: str | Path) -> dict[str, Any]:
    """Parse a TOML file; any problem with the file itself becomes an ``InputError``."""
    p = Path(path)
    where = str(p)
    if not p.exists():
        raise InputError(where, "no such file")
    if p.is_dir():
        raise InputError(where, "is a directory: give a scenario file such as configs/lagrange.toml")
    try:
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise InputError(where, f"file is {size:,} bytes: a scenario is a small TOML text file")
        data = p.read_bytes()
    except OSError as exc:
        raise InputError(where, f"cannot read: {exc.strerror}") from None
    if not data.strip():
        raise InputError(where, "file is empty: start from a template, e.g. `rotlab new lagrange > scenario.toml`")
    if b"\x00" in data:
        raise InputError(where, "binary file, not TOML text")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(where, f"not UTF-8 text (bad byte at offset {exc.start}): save the file as UTF-8") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(where, f"TOML syntax error: {exc}") from None


def load_scenario(path: str | Path, overrides: Mapping[tuple[str, ...], Any] | None = None) -> Scenario:
    """Read, apply ``overrides`` ({('solver', 'method'): 'rk4', ...}) and validate a scenario."""
    return parse_scenario(read_toml(path), source=str(path), overrides=overrides)


def parse_scenario(
    data: Mapping[str, Any], source: str = "<scenario>", overrides: Mapping[tuple[str, ...], Any] | None = None
) -> Scenario:
    """Validate a parsed TOML document (a dict) into a ``Scenario``."""
    data = _with_overrides(data, overrides or {})
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors(include_url=False)
        first = errors[0]
        key, message = _describe(first)
        more = f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})" if len(errors) > 1 else ""
        raise InputError(f"{source}: {key}" if key else source, message + more) from None


def _with_overrides(data: Mapping[str, Any], overrides: Mapping[tuple[str, ...], Any]) -> dict[str, Any]:
    merged: dict[str, Any] = dict(data)
    for path, value in overrides.items():
        node = merged
        for part in path[:-1]:
            child = node.get(part)
            node[part] = dict(child) if isinstance(child, dict) else {}
            node = node[part]
        node[path[-1]] = value
    return merged


def _describe(error: Mapping[str, Any]) -> tuple[str, str]:
    """(dotted key, message with the fix) for one pydantic error."""
    raw_loc = tuple(error["loc"])
    loc = _clean_loc(raw_loc)
    ctx = error.get("ctx") or {}
    if "key" in ctx:
        loc = loc + tuple(str(ctx["key"]).split("."))
    kind = error["type"]
    if kind == "missing":
        return _dotted(loc), "required key is missing: add it"
    if kind == "extra_forbidden":
        allowed = _allowed_keys(raw_loc[:-1])
        close = difflib.get_close_matches(str(loc[-1]), allowed, n=1)
        hint = f"did you mean '{close[0]}'?" if close else f"allowed keys: {', '.join(allowed)}"
        return _dotted(loc), f"unknown key: {hint}"
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        return _dotted(loc + ("type",)), f"load type must be one of: {', '.join(LOAD_MODELS)}"
    if kind in ("tuple_type", "list_type") or kind.startswith("too_"):
        return _dotted(loc), f"{error['msg'].lower()}"
    if kind == "model_type" or kind == "dict_type":
        return _dotted(loc), "must be a table, e.g. [section] or { key = value }"
    if kind == "literal_error":
        return _dotted(loc), error["msg"].replace("Input should be", "must be")
    return _dotted(loc), error["msg"].replace("Input should be", "must be").replace("Value error, ", "")


def _clean_loc(loc: tuple[Any, ...]) -> tuple[Any, ...]:
    """Drop pydantic's union-tag entries (loads.1.torque.frame → loads.1.frame)."""
    out: list[Any] = []
    for k, part in enumerate(loc):
        if k > 0 and isinstance(loc[k - 1], int) and part in LOAD_MODELS:
            continue
        out.append(part)
    return tuple(out)


def _dotted(loc: tuple[Any, ...]) -> str:
    """TOML-style key path: loads[1].frame, sweep.parameters."initial.omega[0]"."""
    text = ""
    for part in loc:
        if isinstance(part, int):
            text += f"[{part}]"
            continue
        key = f'"{part}"' if any(c in str(part) for c in '.[] "') else str(part)
        text += f".{key}" if text else key
    return text


def _allowed_keys(raw_loc: tuple[Any, ...]) -> list[str]:
    """Field names of the model found at pydantic's ``raw_loc`` (union tags included)."""
    model: Any = Scenario
    for part in raw_loc:
        if isinstance(part, int):
            continue
        if model is _LOAD_UNION:
            model = LOAD_MODELS.get(part)
        elif model is not None and part in model.model_fields:
            model = _model_of(model.model_fields[part].annotation)
        else:
            return []
    return list(model.model_fields) if isinstance(model, type) and issubclass(model, BaseModel) else []


_LOAD_UNION = object()


def _model_of(annotation: Any) -> Any:
    """The BaseModel inside Optional[...] / list[...] / Annotated[Union[...]] annotations."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    args = typing.get_args(annotation)
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        models = [a for a in args if isinstance(a, type) and issubclass(a, BaseModel)]
        if len(models) > 1:
            return _LOAD_UNION
        return models[0] if models else None
    for arg in args:
        found = _model_of(arg)
        if found is not None:
            return found
    return None
