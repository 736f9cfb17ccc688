"""Expand a ``[sweep]`` section into cases.

Cases are the Cartesian product of the grid values (in the order the parameters are written),
each repeated ``samples`` times with fresh random draws when there are random parameters.
Case k draws from ``numpy.random.default_rng([seed, k])``: any case can be reproduced alone
from its number and the seed.
"""

from __future__ import annotations

import copy
import itertools
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from rotlab.config import models as cfg
from rotlab.errors import InputError

_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)")


@dataclass(frozen=True)
class Case:
    index: int
    values: dict[str, Any]  # dotted path → value applied to the base scenario


def parse_path(path: str) -> list[str | int]:
    """'loads[0].value[2]' → ['loads', 0, 'value', 2]."""
    parts: list[str | int] = []
    for piece in path.split("."):
        match = _PART.fullmatch(piece)
        if not match:
            raise InputError(f"sweep.parameters.{path}", "not a key path: write e.g. initial.omega[2] or body.mass")
        parts.append(match.group(1))
        parts.extend(int(k) for k in re.findall(r"\[(\d+)\]", match.group(2)))
    return parts


def expand(sweep: cfg.Sweep) -> list[Case]:
    grid_keys = [k for k, v in sweep.parameters.items() if isinstance(v, list)]
    random_keys = [k for k, v in sweep.parameters.items() if not isinstance(v, list)]
    points = list(itertools.product(*(sweep.parameters[k] for k in grid_keys)))
    repeats = sweep.samples or 1
    cases = []
    for index in range(len(points) * repeats):
        values: dict[str, Any] = dict(zip(grid_keys, points[index // repeats]))
        if random_keys:
            rng = np.random.default_rng([sweep.seed, index])
            for key in random_keys:
                values[key] = draw(sweep.parameters[key], rng)
        cases.append(Case(index, values))
    return cases


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
    """The raw scenario dict with ``values`` set at their paths (no [sweep] section)."""
    data = copy.deepcopy(raw)
    data.pop("sweep", None)
    for path, value in values.items():
        _set(data, base, parse_path(path), value, path)
    return data


def _set(data: dict[str, Any], base: cfg.Scenario, parts: list[str | int], value: Any, path: str) -> None:
    node: Any = data
    for depth, part in enumerate(parts[:-1]):
        nxt = parts[depth + 1]
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                raise InputError(f"sweep.parameters.{path}", f"index [{part}] is out of range")
            node = node[part]
            continue
        if part not in node or node[part] is None:
            node[part] = _default(base, parts[: depth + 1]) if isinstance(nxt, int) else {}
        node = node[part]
    last = parts[-1]
    if isinstance(last, int):
        if not isinstance(node, list) or last >= len(node):
            raise InputError(f"sweep.parameters.{path}", f"index [{last}] is out of range")
    node[last] = value


def _default(base: cfg.Scenario, parts: list[str | int]) -> list[Any]:
    """The validated base value at ``parts`` as a list (for indexing into a default vector)."""
    obj: Any = base
    for part in parts:
        obj = obj[part] if isinstance(part, int) else getattr(obj, part, None)
    if obj is None:
        raise InputError(".".join(map(str, parts)), "has no value in the base scenario to index into: give it in full")
    return [list(v) if isinstance(v, tuple) else v for v in obj]
