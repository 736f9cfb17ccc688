"""A bounded memo: values kept by key, at most ``size`` of them, the oldest dropped first.  For
what a pure function computes from its inputs (``auto``'s choices, a scene's shared part), so a
loop or a sweep computes each once."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

V = TypeVar("V")


class Kept(Generic[V]):
    def __init__(self, size: int) -> None:
        self.size = size
        self._values: OrderedDict[Hashable, V] = OrderedDict()

    def get(self, key: Hashable, build: Callable[[], V]) -> V:
        """The value kept for ``key``, else ``build()``, kept."""
        found = self._values.get(key)
        if found is None:
            if len(self._values) >= self.size:
                self._values.popitem(last=False)
            found = self._values[key] = build()
        return found

    def clear(self) -> None:
        self._values.clear()
