"""Events: the times where a formula of the state crosses zero, located on the method's own
local solution, and the values recorded there (a Poincaré section when ``record`` is given).

An event's ``when`` is a formula g(t, ω, Λ, γ, L) of the expression-load grammar (user's body
frame; γ the event's ``up`` in body components).  It is evaluated at every sample as the run
makes it (``EventWatch``, a ``stepping.RowWatch``); where it changes sign between samples t_k
and t_{k+1} in the event's direction

    rising:  g_k < 0 ≤ g_{k+1}        falling:  g_k > 0 ≥ g_{k+1}        both: either,

its root is found by Brent's method on

    τ ↦ g(Φ(y_k, t_k, t_k + τ)),   τ ∈ (0, t_{k+1} − t_k],

Φ the method's local solution (``Method.local_solution``: the run's own steps from the sample
y_k, so that Φ(y_k, t_k, t_{k+1}) is the run's next sample; the closed form for ``exact``), to
|δτ| ≤ 10⁻¹⁴ max(|t_k|, |t_{k+1}|) + 4 ε τ (``rotlab.core.event_root``).  The event time then carries the method's own
error only: δt ≈ δg / |ġ|, δg the error of g on the method's state.

Detection is on the samples: two crossings inside one sample interval cancel and are not seen
(raise ``time.sample_rate`` to resolve them).  A sign change through a pole (g = 1/x) is not an
occurrence: where Brent's method ends, |g| exceeds its values at both samples.  An event at t0 itself is not an occurrence.
A ``terminal`` event ends the run at its ``count``-th occurrence: the run keeps its samples
before it and ends with the state at the event.  A value of ``when`` or of a ``record`` formula
that is not finite stops the run, naming the event and the time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np

from rotlab.core import event_root as root
from rotlab.core.event_values import FALLING, RISING, crossings, first_not_finite, formula_values
from rotlab.core.formula_table import formula_table
from rotlab.core import quaternion as quat
from rotlab.core import opcodes
from rotlab.core.quaternion import from_matrix
from rotlab.kept import Kept
from rotlab.core.torques import EX_COLUMNS, EX_OFF, EX_UP
from rotlab.methods.stepping import Stop
from rotlab.scene import formulas

if TYPE_CHECKING:
    from rotlab.config.models import Event
    from rotlab.methods.base import LocalSolution
    from rotlab.scene.scene import Scene

RATE_INPUTS = opcodes.INPUTS["omega"][0] + opcodes.INPUTS["omega"][1]  # t and ω: the inputs before Λ
DIRECTIONS = {"rising": RISING, "falling": FALLING, "both": RISING | FALLING}
POLE = np.empty(0)  # ``_locate``'s mark of a sign change through a pole
OBSERVED = ("count", "first_s", "interval_s")  # what a sweep reports of each event (``observables``)
_COMPILED: Kept[CompiledEvents] = Kept(64)  # compiled event sets (``compile_events``)


@dataclass(frozen=True)
class EventLog:
    """The occurrences of one event: times ``t`` (s), the ``record`` formulas' values there
    (``values[:, j]`` is ``record[j]``, user's frames as in the formula), whether g rose
    through 0 (``rising``), and the state there (``quaternion`` body → space, scalar first, and
    ``omega``, rad/s, user's body frame)."""

    name: str
    record: tuple[str, ...]
    t: np.ndarray  # (n,) s
    values: np.ndarray  # (n, len(record))
    rising: np.ndarray  # (n,) bool
    quaternion: np.ndarray  # (n, 4)
    omega: np.ndarray  # (n, 3) rad/s, body

    @property
    def count(self) -> int:
        return int(self.t.shape[0])

    def intervals(self) -> np.ndarray:
        """Times between consecutive occurrences (s)."""
        return np.diff(self.t)


class CompiledEvents:
    """A scenario's events compiled: each event's formulas (``when``, then ``record``) as one
    generated function, evaluated on principal-frame states through ``formula_values``."""

    def __init__(self, events: list[Event], scene: Scene) -> None:
        self.specs = tuple(events)
        parsed = [event.programs() for event in events]
        self.programs = [[program for program, _ in formulas_] for formulas_ in parsed]
        self.depth = max(depth for formulas_ in parsed for _, depth in formulas_)
        self.table = formula_table(self.programs)  # (a GPU's way to evaluate them: ``rotlab.ensemble.gpu``)
        self._function = formulas.compiled(self.programs, checked=False)  # kept alive: the kernels hold its address only
        self.fn = self._function.address
        self.consts = formulas.constant_values(self.programs)
        self.rows = np.zeros((len(events), EX_COLUMNS))
        for k, event in enumerate(events):
            up = np.asarray(event.up, dtype=float)
            self.rows[k, EX_UP:EX_UP + 3] = up / np.linalg.norm(up)
            self.rows[k, EX_OFF] = np.inf
        # the formulas of each event that read only t and ω (VAR inputs 0–3: ``core.opcodes.INPUTS``)
        self.rates_only = [[all(arg < RATE_INPUTS for opcode, arg in program if opcode == opcodes.VAR) for program in formulas_]
                           for formulas_ in self.programs]
        self.axes = np.ascontiguousarray(scene.axes, dtype=float)
        self.axes_q = from_matrix(self.axes)
        self.moments = np.asarray(scene.moments, dtype=float)

    def values(self, k: int, component: int, t: np.ndarray, states: np.ndarray) -> np.ndarray:
        """Formula ``component`` (0: ``when``, j + 1: ``record[j]``) of event ``k`` at each row of
        ``states`` (principal frame) at times ``t``."""
        out = np.empty(t.shape[0])
        formula_values(self.fn, self.consts, self.rows, k, component, np.ascontiguousarray(t, dtype=float),
                       np.ascontiguousarray(states), self.axes, self.axes_q, self.moments, self.rates_only[k][component], out)
        return out


def compile_events(scene: Scene) -> CompiledEvents | None:
    """The scene's events compiled (None without events); kept for scenes of equal events and
    body frame (a sweep's cases, repeated runs)."""
    events = scene.scenario.events
    if not events:
        return None
    key = (tuple(e.model_dump_json() for e in events), scene.axes.tobytes(), np.asarray(scene.moments, dtype=float).tobytes())
    return _COMPILED.get(key, lambda: CompiledEvents(list(events), scene))


@dataclass
class _Found:
    t: list[float] = field(default_factory=list)
    values: list[np.ndarray] = field(default_factory=list)
    rising: list[bool] = field(default_factory=list)
    states: list[np.ndarray] = field(default_factory=list)  # principal frame


class EventWatch:
    """Finds the events in the rows of a run as they are made (module docstring); a terminal
    event ends the run (``final``: its time and state, principal frame)."""

    def __init__(self, compiled: CompiledEvents, local: Callable[[], LocalSolution]) -> None:
        """``local`` makes the method's local solution, when the first occurrence is located (a
        fixed-step method's may need its probe run again)."""
        self.compiled, self._make_local = compiled, local
        self._local: LocalSolution | None = None
        self.ends_runs = any(spec.terminal for spec in compiled.specs)  # ``stepping.RowWatch``
        self.found = [_Found() for _ in compiled.specs]
        self.final: tuple[float, np.ndarray] | None = None
        self.ended_by: str | None = None
        self._t: float | None = None  # the last row seen
        self._y: np.ndarray | None = None
        self._g: np.ndarray | None = None  # its value of each event's ``when``

    def rows(self, start: int, t: np.ndarray, state: np.ndarray) -> Stop | None:
        """``stepping.RowWatch``: the occurrences in (previous row, last of these rows]."""
        g = np.empty((len(self.compiled.specs), t.shape[0]))
        for k in range(g.shape[0]):
            g[k] = self.compiled.values(k, 0, t, state)
        cut = [first_not_finite(row) for row in g]
        n = min(cut)
        stop = self._scan(t, state, g, n)
        if stop is not None or n == t.shape[0]:
            return stop
        return Stop(n, self._not_finite(cut.index(n), 0, float(t[n])))

    def _scan(self, t: np.ndarray, state: np.ndarray, g: np.ndarray, n: int) -> Stop | None:
        """Locate the occurrences in the first ``n`` rows (finite values), in time order, and
        remember the last of them; a ``Stop`` keeps the rows before the interval it ends in."""
        if n == 0:
            return None
        first = 0
        if self._g is None:  # the run's first row: no interval ends there
            self._t, self._y, self._g, first = float(t[0]), state[0].copy(), g[:, 0].copy(), 1
        found: dict[int, list[int]] = {}  # row → the events crossing in the interval that ends there
        rows = np.empty(max(n - first, 0), dtype=np.int64)
        for k, spec in enumerate(self.compiled.specs):
            for r in rows[:crossings(self._g[k], g[k, first:n], DIRECTIONS[spec.direction], rows)].tolist():
                found.setdefault(first + r, []).append(k)
        for r in sorted(found):
            t0, y0, g0 = (self._t, self._y, self._g) if r == first else (float(t[r - 1]), state[r - 1], g[:, r - 1])
            stop = self._interval(r, t0, y0, float(t[r]), found[r], g0)
            if stop is not None:
                return stop
        self._t, self._y, self._g = float(t[n - 1]), state[n - 1].copy(), g[:, n - 1].copy()
        return None

    def _interval(self, row: int, t0: float, y0: np.ndarray, t1: float, events: list[int], g0: np.ndarray) -> Stop | None:
        """The occurrences of ``events`` in (t0, t1] (ending at ``row`` of the rows being
        scanned), in time order; a terminal one ends the run there, keeping the rows before ``row``."""
        located = sorted(((*self._locate(k, t0, y0, t1, float(g0[k])), k) for k in events), key=lambda item: item[0])
        for when, y, k in located:
            if y is POLE:
                continue
            spec, found = self.compiled.specs[k], self.found[k]
            if y is None:
                return Stop(row, not_finite_between_message(spec, t0, t1))
            values = np.array([self.compiled.values(k, 1 + j, np.array([when]), y[None, :])[0] for j in range(len(spec.record))])
            if not np.all(np.isfinite(values)):
                return Stop(row, self._not_finite(k, 1 + int(np.argmin(np.isfinite(values))), when))
            found.t.append(when)
            found.values.append(values)
            found.rising.append(bool(g0[k] < 0.0))
            found.states.append(y[:7].copy())
            if spec.terminal and len(found.t) == spec.count:
                self.final = (when, y)
                self.ended_by = ended_by_message(spec, when)
                return Stop(row)
        return None

    def _locate(self, k: int, t0: float, y0: np.ndarray, t1: float, g0: float) -> tuple[float, np.ndarray | None]:
        """(time, state) of event ``k``'s root in (t0, t1] on the local solution from (t0, y0)
        (``rotlab.core.event_root``); state None when the formula is not finite there, ``POLE``
        when the sign changed through a pole (no occurrence)."""
        s = np.empty(root.ROOT_STATE)
        tau = root.locate_start(s, g0, t1 - t0, root.time_tolerance(t0, t1))
        while True:
            y = self.local(y0, t0, t0 + tau)
            verdict, tau = root.locate_next(s, float(self.compiled.values(k, 0, np.array([t0 + tau]), y[None, :])[0]))
            if verdict != root.PENDING:
                break
        if verdict == root.NOT_FINITE:
            return t1, None
        if verdict == root.AT_SAMPLE:  # (the sample's own time)
            return t1, y
        return t0 + tau, POLE if verdict == root.POLE else y

    def local(self, y: np.ndarray, t0: float, t1: float) -> np.ndarray:
        """The method's local solution (``Method.local_solution``), made on first use."""
        if self._local is None:
            self._local = self._make_local()
        return self._local(y, t0, t1)

    def _not_finite(self, k: int, component: int, t: float) -> str:
        return not_finite_message(self.compiled.specs[k], component, t)

    def logs(self) -> dict[str, EventLog]:
        """Each event's occurrences so far, by name."""
        out = {}
        for spec, found in zip(self.compiled.specs, self.found):
            width = len(spec.record)
            values = np.array(found.values, dtype=float).reshape(len(found.t), width)
            states = np.array(found.states, dtype=float).reshape(len(found.t), 7)
            quaternion = quat.multiply_array(states[:, 0:4], quat.conjugate_array(self.compiled.axes_q))  # Λ_U = Λ_P ∘ Λ̃_axes
            out[spec.name] = EventLog(spec.name, tuple(spec.record), np.array(found.t, dtype=float), values,
                                      np.array(found.rising, dtype=bool), quaternion, states[:, 4:7] @ self.compiled.axes.T)
        return out


def observable_names(events: list[Event]) -> list[str]:
    """The columns a sweep reports for ``events`` (``observables``)."""
    return [f"event_{e.name}_{what}" for e in events for what in OBSERVED]


def ended_by_message(spec: Event, t: float) -> str:
    """A run that terminal event ``spec`` ended at t (its ``count``-th occurrence)."""
    return f"event '{spec.name}' (occurrence {spec.count}) at t = {t:.12g} s"


def not_finite_message(spec: Event, component: int, t: float) -> str:
    """Event ``spec``'s formula ``component`` (0: ``when``, j + 1: ``record[j]``) is not finite at t."""
    formula, text = ("when", spec.when) if component == 0 else (f"record[{component - 1}]", spec.record[component - 1])
    return (f"event '{spec.name}': {formula} = \"{text}\" is not finite at t = {t:.9g} s "
            "(a log, sqrt or division outside its domain?): write it so that it is defined on the whole motion")


def not_finite_between_message(spec: Event, t0: float, t1: float) -> str:
    """Event ``spec``'s ``when`` is not finite on the method's solution between two samples."""
    return (f"event '{spec.name}': when = \"{spec.when}\" is not finite on the method's solution "
            f"between t = {t0:.9g} s and t = {t1:.9g} s: write it so that it is defined on the whole motion")


def observed(count: int, first: float, last: float) -> tuple[float, float, float]:
    """An event's ``OBSERVED`` values from its number of occurrences and their first and last
    times: the count, the first time (s) and the mean interval (t_last − t_first)/(count − 1)
    (s; NaN where undefined)."""
    nan = float("nan")
    return float(count), first if count else nan, (last - first) / (count - 1) if count > 1 else nan


def observables(logs: dict[str, EventLog]) -> dict[str, float]:
    """A run's events as a sweep's observables (``observed``), by column."""
    out: dict[str, float] = {}
    for name, log in logs.items():
        values = observed(log.count, float(log.t[0]) if log.count else 0.0, float(log.t[-1]) if log.count else 0.0)
        out.update({f"event_{name}_{what}": value for what, value in zip(OBSERVED, values)})
    return out
