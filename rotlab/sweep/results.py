"""A sweep's results as its cases finish: each case's row appended to ``results.partial.csv`` at
once (a killed sweep keeps the rows of the cases that finished there; the finished sweep writes
results.csv and results.parquet whole, in case order, and removes it — an earlier results.csv is
never half overwritten), and kept column by column — 8 bytes a
number, so 10⁶ cases cost ~100 MB, not a Python object per cell — for the final files, the
terminal table and the comparison recording.

Columns: case, one per swept parameter (vectors spread out: ``key[i]``), status, method, steps,
seconds (this case's own wall time and its share of its chunk's report; empty when cases ran
together in an ensemble kernel), the observables (``OBSERVABLES``, then each event's count, first time and mean
interval: ``rotlab.events.observables``), the max drift of each invariant
(``max_drift_<name>``), message.  Only the cases that did not pass have a message; only the
``compared`` cases keep their decimated series (``CaseOutcome.t``) for the comparison recording.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from rotlab.sweep.runner import CaseOutcome

OBSERVABLES = ("flip_period_s", "max_nutation_deg")  # rotlab.observables
STATUSES = ("pass", "fail", "error")
DIGITS = {"seconds": 6, **{name: 9 for name in OBSERVABLES}}  # decimals the files keep (the rest: every digit)
FIXED = ("status", "method", "steps", "seconds")
COUNT_SUFFIX = "_count"  # an observable counting occurrences (``rotlab.events.observables``): an integer where defined
PARTIAL_RESULTS = "results.partial.csv"  # the rows as cases finish (module docstring)
TERMINAL_ROWS = 50  # a larger sweep's terminal table shows only the cases that did not pass


def parameter_names(values: dict[str, Any]) -> list[str]:
    """The columns of a case's parameter values: a vector value spreads to ``key[i]``."""
    names: list[str] = []
    for key, value in values.items():
        names += [f"{key}[{i}]" for i in range(len(value))] if isinstance(value, list) else [key]
    return names


def _flat(values: dict[str, Any]) -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for key, value in values.items():
        if isinstance(value, list):
            flat.update({f"{key}[{i}]": v for i, v in enumerate(value)})
        else:
            flat[key] = value
    return flat


def _number(value: float, digits: int) -> float | str:
    """A table cell: the value rounded to ``digits`` decimals, or empty when undefined (NaN)."""
    return "" if not math.isfinite(value) else round(float(value), digits)


class Results:
    """The results table of a sweep (module docstring); ``add`` each finished case."""

    def __init__(self, params: list[str], invariants: list[str], csv_path: Path | None = None, observables: list[str] | None = None) -> None:
        self.params = list(params)
        self.invariants = list(invariants)
        self.observables = [*OBSERVABLES, *(observables or [])]  # and the events' (``rotlab.events.observable_names``)
        self.methods: list[str] = []
        self.messages: dict[int, str] = {}  # row → message (cases that did not pass)
        self.compared: list[CaseOutcome] = []  # outcomes that carry series, in the order they finished
        self._numbers: dict[str, np.ndarray] = {}
        self._size = 0
        self._csv: IO[str] | None = None
        self._writer: Any = None
        self._written_header: list[str] | None = None
        self._csv_path = csv_path

    # -- columns ---------------------------------------------------------------------------------
    @property
    def header(self) -> list[str]:
        return ["case", *self.params, *FIXED, *self.observables, *[f"max_drift_{n}" for n in self.invariants], "message"]

    def __len__(self) -> int:
        return self._size

    def column(self, name: str) -> np.ndarray:
        """A numeric column (NaN where empty); ``case``, ``steps``, ``status`` (codes into ``STATUSES``)
        and ``method`` (into ``methods``) as int64."""
        values = self._numbers.get(name)
        return values[: self._size] if values is not None else np.full(self._size, np.nan)

    def status(self) -> np.ndarray:
        return self.column("status").astype(np.int64)

    def failing(self) -> np.ndarray:
        """Rows of the cases that did not pass."""
        return np.flatnonzero(self.status() != 0)

    def values(self, name: str, rows: np.ndarray) -> np.ndarray | list[str]:
        """Column ``name`` at ``rows`` as the files hold it: numbers rounded to their ``DIGITS`` (NaN
        where undefined), the text columns as strings ("" for none)."""
        if name == "status":
            return [STATUSES[k] for k in self.column(name)[rows].tolist()]
        if name == "method":
            return [self.methods[k] if self.methods else "" for k in self.column(name)[rows].tolist()]
        if name == "message":
            return [self.messages.get(k, "") for k in rows.tolist()]
        values = self.column(name)[rows]
        return np.round(values, DIGITS[name]) if name in DIGITS else values

    def table(self, rows: np.ndarray) -> list[list[object]]:
        """The given rows as the CSV holds them (empty cells for undefined numbers)."""
        rows = np.asarray(rows, dtype=np.int64)

        def cells(name: str) -> list[object]:
            values = self.values(name, rows)
            if isinstance(values, list) or values.dtype.kind in "iu":
                return values if isinstance(values, list) else values.tolist()
            whole = int if name.endswith(COUNT_SUFFIX) else float  # counts (of events) as integers
            return ["" if not math.isfinite(v) else whole(v) for v in values.tolist()]

        return [list(r) for r in zip(*(cells(name) for name in self.header))]

    def in_case_order(self) -> np.ndarray:
        return np.argsort(self.column("case"), kind="stable")

    # -- adding ------------------------------------------------------------------------------------
    def _store(self, name: str, values: np.ndarray) -> None:
        """``values`` into column ``name`` at the rows being added (a column grows by doubling; a
        column first seen now is empty (NaN) in the rows before)."""
        column = self._numbers.get(name)
        need = self._size + values.shape[0]
        if column is None or column.shape[0] < need:
            size = max(1024, 2 * need)
            grown = np.zeros(size, dtype=np.int64) if values.dtype.kind in "iu" else np.full(size, np.nan)
            if column is not None:
                grown[: column.shape[0]] = column
            column = self._numbers[name] = grown
        column[self._size: need] = values

    def add(self, outcomes: list[CaseOutcome]) -> None:
        """The rows of ``outcomes`` (appended to results.csv at once, flushed)."""
        if not outcomes:
            return
        for o in outcomes:
            self.params += [n for n in parameter_names(o.values) if n not in self.params]
            self.invariants += [n for n in o.drift if n not in self.invariants]
            self.observables += [n for n in o.observables if n not in self.observables]
        flat = [_flat(o.values) for o in outcomes]
        for name in self.params:
            self._store(name, np.array([_param(f.get(name)) for f in flat], dtype=float))
        for o in outcomes:
            if o.method not in self.methods:
                self.methods.append(o.method)
        self._store("case", np.array([o.index for o in outcomes], dtype=np.int64))
        self._store("status", np.array([STATUSES.index(o.status) for o in outcomes], dtype=np.int64))
        self._store("method", np.array([self.methods.index(o.method) for o in outcomes], dtype=np.int64))
        self._store("steps", np.array([o.steps for o in outcomes], dtype=np.int64))
        self._store("seconds", np.array([o.seconds for o in outcomes], dtype=float))
        for name in self.observables:
            self._store(name, np.array([o.observables.get(name, math.nan) for o in outcomes], dtype=float))
        for name in self.invariants:
            self._store(f"max_drift_{name}", np.array([o.drift.get(name, math.nan) for o in outcomes], dtype=float))
        first = self._size
        for k, o in enumerate(outcomes):
            if o.message:
                self.messages[first + k] = o.message
            if o.t is not None:
                self.compared.append(o)
        self._size += len(outcomes)
        self._append_csv(first)

    def _append_csv(self, first: int) -> None:
        if self._csv_path is None:
            return
        if self._csv is None:
            self._csv = self._csv_path.open("w", newline="", encoding="utf-8")
            self._writer = csv.writer(self._csv)
            self._written_header = self.header
            self._writer.writerow(self._written_header)
        if self._written_header == self.header:  # (a new column: the final file, written whole, has it)
            self._writer.writerows(self.table(np.arange(first, self._size)))
            self._csv.flush()

    def close(self, remove: bool = False) -> None:
        """Close the partial file (``remove``: and delete it, the whole files being written)."""
        if self._csv is not None:
            self._csv.close()
            self._csv = None
        if remove and self._csv_path is not None:
            self._csv_path.unlink(missing_ok=True)


def _param(value: object) -> float:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan
