"""Events in the ensemble kernels: each case's events found as its rows are made, as a single
run's ``rotlab.events.EventWatch`` finds them — the same crossings (``crosses``), the same root
(``rotlab.core.event_root`` on the method's own local solution, ``method_calls.local_state``),
the same stops — and reduced to what a sweep reports of them: per event the number of
occurrences and the first and last times (``rotlab.events.observed``).

A case stops where an event's formula is not finite, as its single run does, keeping the rows
before, and where a terminal event occurs for the ``count``-th time, keeping the rows before and
ending with the state at the event: ``scan_events`` returns that row and writes ``fault``
(``FAULT_*``; a fault's message is ``rotlab.events``'): kind, event, formula (0: ``when``,
j + 1: ``record[j]``), t0, t1 —

    AT_SAMPLE_FAULT   a formula not finite at the sample t0 (= t1)
    BETWEEN_FAULT     ``when`` not finite on the local solution in (t0, t1]
    RECORD_FAULT      a ``record`` formula not finite at the event, t0 (= t1) its time
    TERMINAL          not a fault: a terminal event ended the case at t0 (= t1), its state in the
                      scratch's ``y`` (``case_end``)

The kernels scan a case's rows after each call of its method's kernel, in the calls its single run
makes (``rotlab.methods.stepping.run_chunks``: ``chunk_steps``), so that a case an event stops
takes the steps its single run takes.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, types

from rotlab.core.dynamics import STATE_SIZE, store_row
from rotlab.core.event_root import AT_SAMPLE, NOT_FINITE, PENDING, POLE, ROOT_STATE, locate_next, locate_start, time_tolerance
from rotlab.core.event_values import crosses, formula_value, formula_values
from rotlab.core.kernel_status import OK, WATCHED_STEPS, first_invalid_row
from rotlab.core.targets import gpu_overload
from rotlab.ensemble.method_calls import local_state
from rotlab.ensemble.observe import observe_rows

FOUND_COUNT, FOUND_FIRST, FOUND_LAST = 0, 1, 2  # columns of a case's ``found`` row per event
FOUND_COLUMNS = 3
FAULT_KIND, FAULT_EVENT, FAULT_FORMULA, FAULT_T0, FAULT_T1 = 0, 1, 2, 3, 4
FAULT_COLUMNS = 5
NO_FAULT, AT_SAMPLE_FAULT, BETWEEN_FAULT, RECORD_FAULT, TERMINAL = 0, 1, 2, 3, 4
BLOCK = 512  # rows whose ``when`` values are evaluated together (``scan_events``; a GPU's thread: one, ``device_event_scratch``)


class EventInputs(NamedTuple):
    """A scene's compiled events for the kernels (``rotlab.ensemble.block.event_inputs``; a scene
    without events passes None instead, and the kernels compile without the events' code:
    ``if events is None`` is decided while compiling)."""

    fn: int  # the generated function's address
    consts: np.ndarray  # the formulas' constants (``rotlab.scene.formulas.constant_values``)
    rows: np.ndarray  # (E, EX_COLUMNS): each event's ``up``
    axes: np.ndarray  # (3, 3) user's body axes in principal components
    axes_q: np.ndarray  # (4,)
    moments: np.ndarray  # (3,)
    direction: np.ndarray  # (E,) int64: RISING / FALLING bits
    records: np.ndarray  # (E,) int64: number of ``record`` formulas
    rates_only: np.ndarray  # (E, 1 + max records) bool: the formula reads only t and ω
    terminal: np.ndarray  # (E,) int64: the occurrence that ends the case (``count``), 0: not terminal
    table: np.ndarray  # the formulas' ``rotlab.core.formula_table`` (a GPU's ``fn``: ``rotlab.ensemble.gpu``)
    depth: int  # the deepest formula's stack


class EventScratch(NamedTuple):
    """One case's working arrays (``event_scratch``)."""

    g: np.ndarray  # (E,) each ``when`` at the last row seen
    g_now: np.ndarray  # (E,) … at the row being scanned
    tau: np.ndarray  # (E,) the located root from the interval's start
    when: np.ndarray  # (E,) its time
    verdict: np.ndarray  # (E,) int64: ``event_root`` verdict, −1: no crossing (or taken)
    values: np.ndarray  # (E, BLOCK) each ``when`` on a block of rows (BLOCK: its width)
    root: np.ndarray  # (ROOT_STATE,)
    y: np.ndarray  # (state,) the local solution
    grid: np.ndarray  # (2,)
    out: np.ndarray  # (2, state)
    counters: np.ndarray  # (3,) int64, the local solution's (discarded)


@njit(cache=True)
def event_scratch(events, width):
    """``EventScratch`` for ``events`` (``EventInputs``) and states of ``width`` columns."""
    if events is None:
        return None
    e = events.direction.shape[0]
    return EventScratch(np.zeros(e), np.zeros(e), np.zeros(e), np.zeros(e), np.full(e, -1, dtype=np.int64), np.zeros((e, BLOCK)),
                        np.zeros(ROOT_STATE), np.zeros(width), np.zeros(2), np.zeros((2, width)), np.zeros(3, dtype=np.int64))


def device_event_scratch(count):
    """A GPU thread's ``EventScratch`` for ``count`` events (a compile-time constant; None for 0)
    and states of ``STATE_SIZE`` columns, in its local memory (uninitialised: ``open_events`` and
    ``_interval`` set what they read), ``values`` one row wide (a thread scans its rows one at a
    time).  This Python body is what numba's CUDA simulator runs."""
    if count == 0:
        return None
    return EventScratch(np.zeros(count), np.zeros(count), np.zeros(count), np.zeros(count), np.full(count, -1, dtype=np.int64),
                        np.zeros((count, 1)), np.zeros(ROOT_STATE), np.zeros(STATE_SIZE), np.zeros(2), np.zeros((2, STATE_SIZE)),
                        np.zeros(3, dtype=np.int64))


@gpu_overload(device_event_scratch, inline="always")
def _device_event_scratch_gpu(count):
    if not isinstance(count, types.IntegerLiteral):
        return None
    if count.literal_value == 0:
        return lambda count: None
    from numba import cuda

    e, f = count.literal_value, types.float64
    return lambda count: EventScratch(cuda.local.array(e, f), cuda.local.array(e, f), cuda.local.array(e, f), cuda.local.array(e, f),
                                      cuda.local.array(e, types.int64), cuda.local.array((e, 1), f),
                                      cuda.local.array(ROOT_STATE, f), cuda.local.array(STATE_SIZE, f), cuda.local.array(2, f),
                                      cuda.local.array((2, STATE_SIZE), f), cuda.local.array(3, types.int64))


@njit(cache=True, inline="always")
def _value(events, k, formula, t, y):
    return formula_value(events.fn, events.consts, events.rows, k, formula, t, y, events.axes, events.axes_q, events.moments,
                         events.rates_only[k, formula])


@njit(cache=True)
def _locate(method, solver, model, events, k, t0, y0, t1, s):
    """Event ``k``'s verdict in (t0, t1] (``rotlab.core.event_root``) into ``s.tau[k]``,
    ``s.when[k]`` and ``s.verdict[k]``, from g(t0) = ``s.g[k]``, as ``EventWatch._locate``."""
    tau = locate_start(s.root, s.g[k], t1 - t0, time_tolerance(t0, t1))
    while True:
        local_state(method, solver, model, y0, t0, t0 + tau, s)
        verdict, tau = locate_next(s.root, _value(events, k, 0, t0 + tau, s.y))
        if verdict != PENDING:
            break
    s.tau[k], s.verdict[k] = tau, verdict
    s.when[k] = t1 if verdict == NOT_FINITE or verdict == AT_SAMPLE else t0 + tau


@njit(cache=True)
def _fault(fault, kind, k, formula, t0, t1):
    fault[FAULT_KIND], fault[FAULT_EVENT], fault[FAULT_FORMULA], fault[FAULT_T0], fault[FAULT_T1] = kind, k, formula, t0, t1


@njit(cache=True)
def open_events(events, times, rows, fault, s):
    """Start watching a case's events at its first sample (row 0): 1, or 0 where a ``when`` is
    not finite there (the case ends at its first sample, as its single run; ``fault`` says why)."""
    if events is None:
        return 1
    for k in range(events.direction.shape[0]):
        s.g[k] = _value(events, k, 0, times[0], rows[0])
        if not math.isfinite(s.g[k]):
            _fault(fault, AT_SAMPLE_FAULT, k, 0, times[0], times[0])
            return 0
    return 1


@njit(cache=True)
def scan_events(method, solver, model, events, times, rows, stop, found, fault, s):
    """The events of one case in its rows ``1 … stop − 1`` (at ``times``; row 0 the last one
    seen, ``open_events`` or the last scan's): each occurrence counted in ``found``
    (E, FOUND_COLUMNS), in time order within an interval.  Returns ``stop``, or the row where an
    event's formula or a terminal event stopped the case (its rows before are valid; ``fault``
    says why: module docstring).  Each ``when`` is evaluated on ``BLOCK`` rows at a time (``s.values``' width) by ``formula_values``, the
    single run's loop (its rows' loop compiles for what the formula reads: ~7 ns a row, where a
    test per row and event of what it reads cost ~60)."""
    if events is None:
        return stop
    fn, consts, ex_rows, axes, axes_q, moments, direction, _, rates_only, _, _, _ = events
    g, g_now, values = s.g, s.g_now, s.values
    for r0 in range(1, stop, values.shape[1]):
        r1 = min(stop, r0 + values.shape[1])
        for k in range(g.shape[0]):
            formula_values(fn, consts, ex_rows, k, 0, times[r0:r1], rows[r0:r1], axes, axes_q, moments, rates_only[k, 0], values[k])
        for r in range(r0, r1):
            crossed = False
            for k in range(g.shape[0]):
                value = values[k, r - r0]
                if not math.isfinite(value):
                    _fault(fault, AT_SAMPLE_FAULT, k, 0, times[r], times[r])
                    return r
                crossed = crossed or crosses(g[k], value, direction[k])
            if crossed:
                for k in range(g.shape[0]):
                    g_now[k] = values[k, r - r0]
                if not _interval(method, solver, model, events, times, rows, r, found, fault, s):
                    return r
            for k in range(g.shape[0]):
                g[k] = values[k, r - r0]
    return stop


@njit(cache=True)
def _interval(method, solver, model, events, times, rows, r, found, fault, s):
    """The occurrences in the interval that ends at row ``r``, located (``_locate``) and counted
    in time order (ties: in the events' order); False where an event's formula or a terminal
    event stopped the case."""
    t0, t1 = times[r - 1], times[r]
    for k in range(s.g.shape[0]):
        s.verdict[k] = -1
        if crosses(s.g[k], s.g_now[k], events.direction[k]):
            _locate(method, solver, model, events, k, t0, rows[r - 1], t1, s)
    while True:
        k = -1
        for m in range(s.g.shape[0]):
            if s.verdict[m] >= 0 and (k < 0 or s.when[m] < s.when[k]):
                k = m
        if k < 0:
            return True
        verdict, s.verdict[k] = s.verdict[k], -1
        if verdict == POLE:
            continue
        if verdict == NOT_FINITE:
            _fault(fault, BETWEEN_FAULT, k, 0, t0, t1)
            return False
        if events.records[k] > 0:  # (the state at the event, made again: the same bits)
            local_state(method, solver, model, rows[r - 1], t0, t0 + s.tau[k], s)
            for j in range(events.records[k]):
                if not math.isfinite(_value(events, k, 1 + j, s.when[k], s.y)):
                    _fault(fault, RECORD_FAULT, k, 1 + j, s.when[k], s.when[k])
                    return False
        if found[k, FOUND_COUNT] == 0.0:
            found[k, FOUND_FIRST] = s.when[k]
        found[k, FOUND_LAST] = s.when[k]
        found[k, FOUND_COUNT] += 1.0
        if found[k, FOUND_COUNT] == events.terminal[k]:  # the case ends with the state at the event (``EventWatch._interval``)
            if events.records[k] == 0:
                local_state(method, solver, model, rows[r - 1], t0, t0 + s.tau[k], s)
            _fault(fault, TERMINAL, k, 0, s.when[k], s.when[k])
            return False


@njit(cache=True)
def chunk_steps(events, chunk):
    """The steps a case's method takes per call, as its single run's (``run_chunks``): ``chunk``,
    or ``WATCHED_STEPS`` where a terminal event may end the case."""
    if events is None:
        return chunk
    for k in range(events.terminal.shape[0]):
        if events.terminal[k] > 0:
            return WATCHED_STEPS
    return chunk


@njit(cache=True)
def scan_call(method, solver, model, events, times, rows, i, made, code, found, fault, s):
    """The events in the rows [i, made) of a call of the case's kernel (``code`` its status: its
    valid rows only; row i − 1 the last one seen), by ``scan_events``: the end of the rows that
    stand (``made``, or the row where an event stopped the case)."""
    if code != OK:
        made = first_invalid_row(rows, i, made)
    return i - 1 + scan_events(method, solver, model, events, times[i - 1:made], rows[i - 1:made], made - i + 1, found, fault, s)


@njit(cache=True)
def case_end(s, fault, y, t, samples, constants, forces, folded):
    """(last state, its time, samples) of a case whose last sample is ``y`` at t, the ``samples``-th:
    or, where a terminal event ended it (``fault``), the state at the event (``s.y``), which
    becomes its last sample and is folded into its observables (``folded``)."""
    if s is None:
        return y, t, samples
    if fault[FAULT_KIND] != TERMINAL:
        return y, t, samples
    s.grid[1] = fault[FAULT_T0]
    store_row(s.out, 1, s.y)
    observe_rows(s.grid, s.out, 1, 2, False, constants, forces, folded)
    return s.y, s.grid[1], samples + 1
