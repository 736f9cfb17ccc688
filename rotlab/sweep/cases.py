"""Expand a ``[sweep]`` section into cases, and each case's scenario.

Cases are the Cartesian product of the grid values (in the order the parameters are written),
each repeated ``samples`` times with fresh random draws when there are random parameters.
Case k draws from ``numpy.random.default_rng([seed, k])``: any case can be reproduced alone
from its number and the seed.
"""

from __future__ import annotations

import difflib
import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property
from types import UnionType
from typing import Annotated, Any, Union, get_args, get_origin, overload

import numpy as np
from pydantic import BaseModel, ValidationError

from rotlab.config import models as cfg
from rotlab.config.loader import parse_scenario, set_value
from rotlab.config.paths import group_of, model_defaults, parse_key_path
from rotlab.errors import InputError


@dataclass(frozen=True)
class Case:
    index: int
    values: dict[str, Any]  # dotted path → value applied to the base scenario


def parameter_key(path: str) -> str:
    """A sweep parameter's key as the loader writes it: sweep.parameters."initial.omega[2]"."""
    return f'sweep.parameters."{path}"'


def check_parameters(base: cfg.Scenario, source: str) -> None:
    """The checks of ``base.sweep``'s parameters that need the scenario (``check_path`` for each,
    ``check_overlaps``), their errors named in ``source``, the file, as the loader names a key."""
    try:
        for path in base.sweep.parameters:
            check_path(base, path)
        check_overlaps(list(base.sweep.parameters))
    except InputError as exc:
        raise InputError(f"{source}: {exc.where}", exc.message) from None


def check_path(base: cfg.Scenario, path: str) -> None:
    """A sweep parameter's key path must name a scenario key (an unknown key is an input error
    with the closest known key, as for the scenario's own keys), and its values must have a shape
    the key's type takes: a number, a list of n numbers for an n-vector, a list of any length for a
    list.  A value of the wrong shape is an error of the sweep, not of each case that draws it;
    whether a value is valid in its case (with the case's other values) is the case's validation."""
    shapes = _shapes(_key_type(base, path))
    if shapes is None:  # a type whose values are not numbers or lists of numbers: the cases' validation checks them
        return
    parameter = base.sweep.parameters[path]
    wanted = " or ".join(_SHAPE_WORDS.get(s, f"a list of {s} numbers") for s in sorted(shapes))
    if not isinstance(parameter, list):  # a distribution: a sphere draws a 3-vector, the others a float
        drawn = 3 if isinstance(parameter, cfg.Sphere) else NUMBER
        if not _takes(shapes, drawn):
            what = "a 3-vector" if drawn == 3 else "a number"
            fix = ("give a grid of integers" if INTEGER in shapes else "use uniform, log_uniform or normal" if NUMBER in shapes
                   else "sweep its components one by one, or use { sphere = r }")
            raise InputError(parameter_key(path), f"draws {what}, but the key holds {wanted}: {fix}")
        return
    for i, value in enumerate(parameter):
        if not _takes(shapes, _shape_of(value)):
            raise InputError(f"{parameter_key(path)}[{i}]", f"must be {wanted}, as the key holds, found {value!r}")


INTEGER, NUMBER, LIST = -3, -2, -1  # shapes of a value: an integer, a number, a list of any length (n ≥ 0: a list of n numbers)
_SHAPE_WORDS = {INTEGER: "an integer", NUMBER: "a number", LIST: "a list of numbers"}


def _shape_of(value: Any) -> int:
    return len(value) if isinstance(value, list) else INTEGER if isinstance(value, int) else NUMBER


def _takes(shapes: set[int], shape: int) -> bool:
    """Whether a key of ``shapes`` takes a value of ``shape`` (a number takes an integer, a list a list of any length)."""
    return shape in shapes or (shape == INTEGER and NUMBER in shapes) or (shape >= 0 and LIST in shapes)


def _shapes(annotation: Any) -> set[int] | None:
    """The shapes a type takes (``INTEGER``, ``NUMBER``, n, ``LIST``), None where it takes something else."""
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return _shapes(args[0])
    if origin in (Union, UnionType):
        parts = [_shapes(a) for a in args if a is not type(None)]
        return None if any(p is None for p in parts) else set().union(*parts)
    if annotation in (float, int):
        return {NUMBER if annotation is float else INTEGER}
    numbers = all(_shapes(a) in ({NUMBER}, {INTEGER}) for a in args if a is not Ellipsis)
    if origin is tuple and args and numbers:
        return {LIST} if Ellipsis in args else {len(args)}
    if origin is list and args and numbers:
        return {LIST}
    return None


def _key_type(base: cfg.Scenario, path: str) -> Any:
    """The type of the scenario's value at ``path`` (None where it cannot be told: an optional
    section the base leaves out, an element of a list of tables)."""
    obj: Any = base
    annotation: Any = None
    parts = parse_key_path(path, parameter_key(path))
    if parts[0] == "sweep":
        raise InputError(parameter_key(path), "the sweep's own settings are not swept: sweep a key of the scenario")
    for n, part in enumerate(parts):
        if obj is None:  # an optional section the base leaves out: the case's validation checks the rest
            return None
        wrong = _shape_mismatch(obj, part, "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in parts[:n]).lstrip("."))
        if wrong is not None:
            raise InputError(parameter_key(path), wrong)
        if isinstance(part, int):
            if part >= len(obj):
                raise InputError(parameter_key(path), f"index [{part}] is out of range")
            obj, annotation = obj[part], _element(annotation, part)
            continue
        if isinstance(obj, dict):  # a table of the user's own keys (a formula's constants): those the file gives
            if part not in obj:
                otherwise = f"give it in the file's {parts[n - 1]} (it gives {', '.join(obj) or 'none'}) to sweep it"
                raise InputError(parameter_key(path), f"unknown key '{part}': {_hint(part, list(obj), otherwise)}")
            obj, annotation = obj[part], _element(annotation, 1)
            continue
        fields = type(obj).model_fields if isinstance(obj, BaseModel) else {}
        if part not in fields:
            otherwise = f"allowed keys: {', '.join(fields)}" if fields else "it has no keys"
            raise InputError(parameter_key(path), f"unknown key '{part}': {_hint(part, list(fields), otherwise)}")
        obj, annotation = getattr(obj, part), fields[part].annotation
    return annotation


def _hint(part: str, keys: list[str], otherwise: str) -> str:
    """"did you mean" the key of ``keys`` closest to ``part``, else ``otherwise``."""
    close = difflib.get_close_matches(part, keys, n=1)
    return f"did you mean '{close[0]}'?" if close else otherwise


def _shape_mismatch(obj: Any, part: str | int, held: str) -> str | None:
    """Why ``part`` (an index or a key) cannot address ``obj``, the value at the path ``held``
    (None when it can: an index of a list, a key of a table)."""
    is_list, is_table = isinstance(obj, (list, tuple)), isinstance(obj, (BaseModel, dict))
    if isinstance(part, int):
        if is_list:
            return None
        return f"'{held}' is a table, not a list: name one of its keys" if is_table else f"'{held}' holds one value, not a list: remove [{part}]"
    if is_table:
        return None
    return f"'{held}' is a list: index it, e.g. {held}[0]" if is_list else f"'{held}' holds one value: remove .{part}"


def _element(annotation: Any, index: int) -> Any:
    """The type of element ``index`` of a tuple or list type, or of a dict's values for index 1
    (None where it cannot be told)."""
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is Annotated:
        return _element(args[0], index)
    if origin in (Union, UnionType):
        found = [_element(a, index) for a in args if a is not type(None)]
        return found[0] if len(found) == 1 else None
    if origin is tuple and args:
        return args[0] if Ellipsis in args else args[index] if index < len(args) else None
    if origin is list and args:
        return args[0]
    if origin is dict and args and index == 1:
        return args[1]
    return None


def check_overlaps(paths: list[str]) -> None:
    """No two sweep parameters may set the same value: 'initial.omega' with 'initial.omega[1]'
    (one silently overwrote the other, depending on the order and on which one was drawn), or
    'initial.omega[2]' with 'initial.omega[02]'."""
    parsed = [(path, _quantities(parse_key_path(path, parameter_key(path)))) for path in paths]
    for (a, parts_a), (b, parts_b) in itertools.combinations(parsed, 2):
        (whole, whole_parts), (part, part_parts) = sorted(((a, parts_a), (b, parts_b)), key=lambda item: len(item[1]))
        if part_parts[: len(whole_parts)] != whole_parts:
            continue
        if len(part_parts) == len(whole_parts):
            same = parse_key_path(part, part) == parse_key_path(whole, whole)
            raise InputError(parameter_key(part), f"the same key as '{whole}': give it once" if same else
                             f"the same quantity as '{whole}', given another way (one would replace the other): sweep one of them")
        raise InputError(parameter_key(part), f"sets part of '{whole}', which is swept too: sweep the whole value or its parts, not both")


def _quantities(parts: list[str | int]) -> tuple:
    """The key path's parts with each key that names a quantity given one of several ways
    (``omega``, ``omega_rpm``, ``omega_deg``: ``ONE_QUANTITY``) replaced by that quantity."""
    return tuple((group_of(part, cfg.ONE_QUANTITY) or part) if isinstance(part, str) else part for part in parts)


class Cases(Sequence[Case]):
    """The cases of a ``[sweep]``, each made when asked for (a million cases are not held): case k
    is grid point k // samples (the grid's last parameter varying fastest) and draw k."""

    def __init__(self, sweep: cfg.Sweep) -> None:
        self.sweep = sweep
        self.grid_keys = [k for k, v in sweep.parameters.items() if isinstance(v, list)]
        self.random_keys = [k for k, v in sweep.parameters.items() if not isinstance(v, list)]
        self.sizes = [len(sweep.parameters[k]) for k in self.grid_keys]
        self.repeats = sweep.samples or 1
        self._len = math.prod(self.sizes) * self.repeats

    def __len__(self) -> int:
        return self._len

    @overload
    def __getitem__(self, index: int) -> Case: ...

    @overload
    def __getitem__(self, index: slice) -> list[Case]: ...

    def __getitem__(self, index: int | slice) -> Case | list[Case]:
        if isinstance(index, slice):
            return [self._case(k) for k in range(*index.indices(self._len))]
        k = index + self._len if index < 0 else index
        if not 0 <= k < self._len:
            raise IndexError(index)
        return self._case(k)

    def _case(self, index: int) -> Case:
        point, values = index // self.repeats, {}
        for key, size in zip(reversed(self.grid_keys), reversed(self.sizes)):  # itertools.product's order
            point, at = divmod(point, size)
            values[key] = self.sweep.parameters[key][at]
        values = {key: values[key] for key in self.grid_keys}
        if self.random_keys:
            rng = np.random.default_rng([self.sweep.seed, index])
            for key in self.random_keys:
                values[key] = draw(self.sweep.parameters[key], rng)
        return Case(index, values)


def expand(sweep: cfg.Sweep) -> Cases:
    return Cases(sweep)


def draw(dist: cfg.Distribution, rng: np.random.Generator) -> float | list[float]:
    if isinstance(dist, cfg.Uniform):
        return float(rng.uniform(*dist.uniform))
    if isinstance(dist, cfg.LogUniform):
        low, high = np.log(dist.log_uniform)
        return float(np.exp(rng.uniform(low, high)))
    if isinstance(dist, cfg.Normal):
        return float(rng.normal(*dist.normal))
    direction = rng.normal(size=3)
    return (dist.sphere * direction / np.linalg.norm(direction)).tolist()


def apply(raw: dict[str, Any], base: cfg.Scenario, values: dict[str, Any]) -> dict[str, Any]:
    """The raw scenario dict with ``values`` set at their paths (``set_value``: as `--set` sets
    them, a value given another way replacing the file's) and no [sweep] section.  ``set_at``
    copies only the tables and arrays on those paths (a deep copy of the whole document was half
    of a case's validation); the rest is shared with ``raw``, which validation does not change."""
    data = {key: value for key, value in raw.items() if key != "sweep"}
    for path, value in values.items():
        set_value(data, path, value, parameter_key(path), model_defaults(base))
    return data


def case_scenario(raw: dict[str, Any], base: cfg.Scenario, case: Case, source: str) -> cfg.Scenario | InputError:
    """The scenario of ``case``: its values applied to the file's document, validated (an invalid
    case is returned as its error).  A case that changes initial conditions only has its
    ``[initial]`` table validated alone and shares the rest of ``base`` (``initial_case``)."""
    try:
        scenario = initial_case(raw, base, case.values) if initial_only(case.values) else None
        if scenario is not None:
            return scenario
        document = apply(raw, base, case.values)
    except InputError as exc:  # a path the file's document cannot take (an index into a value it does not give): named in the file
        return InputError(f"{source}: {exc.where}", exc.message)
    try:
        return parse_scenario(document, source=f"{source} case {case.index}")
    except InputError as exc:
        return exc


def initial_only(paths: Iterable[str]) -> bool:
    """Every swept key is an initial condition."""
    return all(path.startswith("initial.") for path in paths)


def initial_case(raw: dict[str, Any], base: cfg.Scenario, values: dict[str, Any]) -> cfg.Scenario | None:
    """``base`` with the ``[initial]`` table that ``values`` (initial conditions only) make of the
    file's, validated alone (``Scenario.with_initial``: 10 µs a case against the whole document's
    23, docs/benchmarks.md).  None when that table is invalid: the whole document's validation
    then names the key and says why, as for any case."""
    table = apply({"initial": raw["initial"]} if "initial" in raw else {}, base, values)["initial"]
    try:
        return base.with_initial(cfg.Initial.model_validate(table))
    except ValidationError:
        return None


@dataclass
class SweepPlan:
    """A sweep file read: its scenario (``base``), its cases and the document they change."""

    base: cfg.Scenario
    cases: Sequence[Case]  # ``Cases``: made when asked for
    raw: dict[str, Any]  # the file's document, to which each case's values are applied
    source: str  # the file, as error messages name it

    @cached_property
    def scenarios(self) -> list[cfg.Scenario | InputError]:
        """Every case validated (a bad case is kept as its error).  Local workers validate their
        own cases instead: validating takes less than pickling a validated scenario."""
        return [case_scenario(self.raw, self.base, case, self.source) for case in self.cases]
