"""Read a scenario file and turn every problem into one line naming the key and the fix."""

from __future__ import annotations

import difflib
import re
import signal
import stat
import threading
import tomllib
import types
import typing
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Mapping, Sequence

from pydantic import BaseModel, ValidationError

from rotlab.config.models import DRIVE_TAGS, LOAD_MODELS, ONE_QUANTITY, SWEEP_TAGS, Scenario
from rotlab.config.paths import Defaults, drop_other_forms, model_defaults, set_at
from rotlab.errors import InputError

MAX_FILE_BYTES = 16 * 1024 * 1024
MAX_KEY_PARTS = 64  # dotted keys longer than this are no scenario (and tomllib is quadratic in them)
PARSE_SECONDS = 10.0  # wall-clock limit on parsing one file (main thread only)
# a match starts only at a token's start and never gives back a bare key's characters (possessive
# ++): backtracking into a long token would make the search quadratic in the token's length
_LONG_DOTTED_KEY = re.compile(r'(?<![A-Za-z0-9_-])(?:(?:[A-Za-z0-9_-]++|"[^"\n]*"|\'[^\'\n]*\')[ \t]*\.[ \t]*){%d,}' % MAX_KEY_PARTS)


def read_toml(path: str | Path) -> dict[str, Any]:
    """Parse a TOML file; any problem with the file itself becomes an ``InputError``.

    Only regular files are read (a FIFO would block, a device never end), at most
    ``MAX_FILE_BYTES``, parsed within ``PARSE_SECONDS``."""
    p = Path(path)
    where = str(p)
    data = _read_limited(p, where)
    if not data.strip():
        raise InputError(where, "file is empty: start from a template, e.g. `rotlab new lagrange > scenario.toml`")
    if b"\x00" in data:
        raise InputError(where, "binary file, not TOML text")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(where, f"not UTF-8 text (bad byte at offset {exc.start}): save the file as UTF-8") from None
    return parse_toml_text(text, where)


def _read_limited(p: Path, where: str) -> bytes:
    try:
        info = p.stat()
    except FileNotFoundError:
        raise InputError(where, "no such file") from None
    except OSError as exc:
        raise InputError(where, f"cannot read: {exc.strerror or exc}") from None
    if stat.S_ISDIR(info.st_mode):
        raise InputError(where, "is a directory: give a scenario file such as configs/lagrange.toml")
    if not stat.S_ISREG(info.st_mode):
        raise InputError(where, "is not a regular file (a device, FIFO or socket): give a scenario file such as configs/lagrange.toml")
    if info.st_size > MAX_FILE_BYTES:
        raise InputError(where, f"file is {info.st_size:,} bytes: a scenario is a small TOML text file (at most {MAX_FILE_BYTES:,} bytes)")
    try:
        with open(p, "rb") as handle:
            data = handle.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise InputError(where, f"cannot read: {exc.strerror or exc}") from None
    if len(data) > MAX_FILE_BYTES:  # files that report no size (/proc, ...)
        raise InputError(where, f"file is over {MAX_FILE_BYTES:,} bytes: a scenario is a small TOML text file")
    return data


def parse_toml_text(text: str, where: str) -> dict[str, Any]:
    """``tomllib.loads`` with the limits of ``read_toml``: key depth, nesting depth and time."""
    try:
        with _time_limit(PARSE_SECONDS):
            long_key = _LONG_DOTTED_KEY.search(text)
            if long_key:
                line = text.count("\n", 0, long_key.start()) + 1
                raise InputError(f"{where}: line {line}", f"a dotted key of more than {MAX_KEY_PARTS} parts: no scenario key is that deep")
            return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(where, f"TOML syntax error: {exc}") from None
    except RecursionError:
        raise InputError(where, "arrays or tables nested too deeply: a scenario nests a few levels at most") from None
    except ValueError as exc:  # tomllib's int() of a literal beyond Python's digit limit (4,300)
        raise InputError(where, f"a number too long to read ({str(exc).split(':')[0].lower()}): write it with an exponent, e.g. 1e30") from None
    except _ParseTimeout:
        raise InputError(where, f"took more than {PARSE_SECONDS:g} s to parse: a scenario is a small TOML text file") from None


class _ParseTimeout(Exception):
    pass


@contextmanager
def _time_limit(seconds: float):
    """Raise ``_ParseTimeout`` in the block after ``seconds`` of wall time (main thread with
    SIGALRM only; elsewhere the size and key limits alone apply)."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "setitimer"):
        yield
        return

    def expire(signum, frame):
        raise _ParseTimeout

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def load_scenario(path: str | Path, overrides: Mapping[str, Any] | None = None, duration: float | None = None) -> Scenario:
    """Read, apply ``overrides`` ({'solver.method': 'rk4', 'initial.omega[2]': 50.0}) and
    ``duration`` (end = start + duration, s), and validate a scenario."""
    return parse_scenario(read_toml(path), source=str(path), overrides=overrides, duration=duration)


def parse_scenario(
    data: Mapping[str, Any], source: str = "<scenario>", overrides: Mapping[str, Any] | None = None, duration: float | None = None
) -> Scenario:
    """Validate a parsed TOML document (a dict) into a ``Scenario``, after ``overrides`` (key
    path → value, checked like the file's own keys) and ``duration``."""
    data = _with_overrides(data, source, overrides or {}, duration)
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        raise input_error(exc, source) from None


def input_error(exc: ValidationError, source: str) -> InputError:
    errors = exc.errors(include_url=False)
    key, message = _describe(errors[0], errors)
    more = f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})" if len(errors) > 1 else ""
    return InputError(f"{source}: {key}" if key else source, message + more)


def set_value(data: dict[str, Any], path: str, value: Any, where: str, defaults: Defaults) -> None:
    """``set_at``, and a value given another way replaces the document's: setting ``initial.omega``
    or a component of it drops the table's ``omega_rpm`` and ``omega_deg`` (``ONE_QUANTITY``; the
    other components are the file's, converted).  What `--set`, the API's
    ``overrides`` and a sweep's cases do to a scenario document."""
    set_at(data, path, value, where, defaults)
    drop_other_forms(data, path, ONE_QUANTITY, where)


def _with_overrides(data: Mapping[str, Any], source: str, overrides: Mapping[str, Any], duration: float | None) -> dict[str, Any]:
    if not overrides and duration is None:
        return dict(data)
    merged = dict(data)  # set_at copies the tables it changes

    def file_scenario() -> Scenario:  # the file's own values, for indexing into a vector it omits
        try:
            return Scenario.model_validate(data)
        except ValidationError as exc:
            raise input_error(exc, source) from None

    for path, value in overrides.items():
        set_value(merged, path, value, path, model_defaults(file_scenario))
    if duration is not None:
        time = merged["time"] = dict(merged["time"]) if isinstance(merged.get("time"), dict) else {}
        start = time.get("start", 0.0)
        if isinstance(start, (int, float)) and not isinstance(start, bool):
            time["end"] = start + duration
    return merged


def _describe(error: Mapping[str, Any], errors: Sequence[Mapping[str, Any]] = ()) -> tuple[str, str]:
    """(dotted key, message with the fix) for one pydantic error (``errors``: all of them, for the
    length a short vector needs)."""
    raw_loc = tuple(error["loc"])
    loc = _clean_loc(raw_loc)
    ctx = error.get("ctx") or {}
    if "key" in ctx:
        parts = ctx["key"] if isinstance(ctx["key"], (tuple, list)) else str(ctx["key"]).split(".")
        loc = loc + tuple(int(part) if part.isdigit() else part for part in parts)
    kind = error["type"]
    if kind == "missing" and loc and isinstance(loc[-1], int) and isinstance(error.get("input"), (list, tuple)):
        return _short_vector(loc, error, errors)
    if kind == "missing":
        return _dotted(loc), "required key is missing: add it"
    if kind == "extra_forbidden":
        allowed = _allowed_keys(raw_loc[:-1])
        close = difflib.get_close_matches(str(loc[-1]), allowed, n=1)
        hint = f"did you mean '{close[0]}'?" if close else f"allowed keys: {', '.join(allowed)}"
        return _dotted(loc), f"unknown key: {hint}"
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        return _dotted(loc + ("type",)), f"load type must be one of: {', '.join(LOAD_MODELS)}"
    if kind in ("too_long", "too_short") and "Tuple" in error["msg"]:
        needed = re.search(r"at (?:most|least) (\d+) item", error["msg"])
        count = len(error["input"]) if isinstance(error.get("input"), (list, tuple)) else "another number of"
        return _dotted(loc), f"needs {needed.group(1) if needed else 'a fixed number of'} components, got {count}: give one value per component"
    if kind == "tuple_type":
        return _dotted(loc), f"must be a list of numbers in brackets, e.g. [0.0, 0.0, 1.0], not {_shown(error.get('input'))}"
    if kind in ("list_type",) or kind.startswith("too_"):
        return _dotted(loc), f"{error['msg'].lower()}"
    if kind == "model_type" or kind == "dict_type":
        return _dotted(loc), "must be a table, e.g. [section] or { key = value }"
    if kind == "literal_error":
        return _dotted(loc), error["msg"].replace("Input should be", "must be")
    return _dotted(loc), error["msg"].replace("Input should be", "must be").replace("Value error, ", "")


def _short_vector(loc: tuple[Any, ...], error: Mapping[str, Any], errors: Sequence[Mapping[str, Any]]) -> tuple[str, str]:
    """A fixed-length vector given too few components: how many it needs (its missing positions
    are errors of their own), how many it has."""
    raw = tuple(error["loc"])[:-1]
    needed = 1 + max(e["loc"][-1] for e in errors if e["type"] == "missing" and tuple(e["loc"])[:-1] == raw and isinstance(e["loc"][-1], int))
    return _dotted(loc[:-1]), f"needs {needed} components, got {len(error['input'])}: give one value per component"


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _clean_loc(loc: tuple[Any, ...]) -> tuple[Any, ...]:
    """Drop pydantic's union-tag entries: a load's type (loads.1.torque.frame → loads.1.frame), a
    rotor's drive (rotors.0.torque.pd_control.kp → rotors.0.torque.kp) and a sweep parameter's
    shape (sweep.parameters.K.grid.1 → sweep.parameters.K[1])."""
    out: list[Any] = []
    for k, part in enumerate(loc):
        if k > 1 and loc[k - 2] == "loads" and isinstance(loc[k - 1], int) and part in LOAD_MODELS:
            continue
        if k > 2 and loc[k - 3] == "rotors" and loc[k - 1] == "torque" and part in DRIVE_TAGS:
            continue
        if k > 2 and loc[:2] == ("sweep", "parameters") and part in SWEEP_TAGS:
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
