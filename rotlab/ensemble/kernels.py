"""Many cases of one scene's body and loads per call, in parallel over cases (numba ``prange``):
each case is the method's own kernel run as a single run calls it, its observables reduced as
its samples are made (``rotlab.ensemble.observe``), and only the samples of the cases asked for
kept (every ``stride``-th and the last valid one).

Each case's method is called as its single run calls it (``rotlab.methods.stepping.run_chunks``):
on the same windows of ``kernel_status.WINDOW`` samples (an adaptive step ends at a window's last
sample), in calls of the same step budgets (``CHUNK_STEPS``; ``WATCHED_STEPS`` where a terminal
event may end the case), so a case takes its single run's steps wherever it stops.  After each
call its events (``rotlab.ensemble.event_scan``) are found in the new rows before they are
observed: an event's formula that is not finite ends the case there, and a terminal event at its
``count``-th occurrence, the state at the event its last sample, as each ends its single run.

Fixed-step methods (``advance(y, times, out, i, substeps, max_steps, model, *extra)``, see
``rotlab.methods.fixed_step``), named by a string the kernel is compiled for
(``rotlab.ensemble.method_calls``), hold one window of rows a case (``thread_grids``): a fixed step
starts each sample interval afresh, so the windows change no bit, and a case needs WINDOW + 1 rows
of memory whatever its length.  ``dop853`` and ``taylor`` run over the whole sample grid, as a
single run does, so a case holds its N rows while it runs.
"""

from __future__ import annotations

import numpy as np
from numba import get_num_threads, get_thread_id, literally, njit, prange, types
from numba.extending import overload

from rotlab.core.dop853 import dop853_advance
from rotlab.core.taylor import taylor_advance
from rotlab.core.dynamics import STATE_SIZE, store_row
from rotlab.core.kernel_status import CHUNK_STEPS, OK, STALLED, WINDOW, first_invalid_row, needs_whole_chunks, pace_judged, stall_needs
from rotlab.ensemble.event_scan import case_end, chunk_steps, event_scratch, open_events, scan_call
from rotlab.ensemble.method_calls import advance_of
from rotlab.ensemble.observe import ACC_COLUMNS, constants_of, observe_rows
from rotlab.core.model import Expressions, Model

def own(x):
    """A copy of an array (anything else as it is)."""
    raise NotImplementedError("compiled code only")


@overload(own)
def _own(x):
    if isinstance(x, types.Array):
        return lambda x: x.copy()
    return lambda x: x


def parallel_model(model: Model) -> tuple[Model, Expressions | None]:
    """``model`` as the parallel kernels take it: without its formulas, and its formulas apart
    (numba's parallel loop hands a tuple's arrays to its threads one level deep, and the formulas
    are a tuple of arrays inside the model); ``own_model`` puts them together for each case."""
    return model._replace(expressions=None), model.expressions


def own_expressions(expressions):
    """A copy of the formulas' arrays (None as it is)."""
    raise NotImplementedError("compiled code only")


@overload(own_expressions)
def _own_expressions(expressions):
    if isinstance(expressions, types.NoneType):
        return lambda expressions: None
    return lambda expressions: Expressions(expressions.rows.copy(), expressions.code.copy(), expressions.consts.copy(), expressions.axes.copy(),
                                           expressions.axes_q.copy(), expressions.moments.copy(), expressions.depth, expressions.aux,
                                           expressions.fn)


@njit(cache=True)
def own_model(model, expressions):
    """``model`` with ``expressions`` (``parallel_model``), its arrays copied for one thread:
    numba counts references to an array passed to a function with an atomic write, and two
    threads passing the same array contend for its cache line."""
    return Model(own(model.euler), own(model.breaks), own(model.forces), own(model.terms), own(model.tables),
                 own(model.table_t), own(model.table_v), model.damping, own_expressions(expressions), model.user, own(model.rotors),
                 model.drives)


@njit(cache=True)
def keep_samples(rows, times, start, stop, offset, stride, kept, kept_t, count):
    """Copy the rows ``start … stop − 1`` whose sample index (row + ``offset``) is a multiple of
    ``stride`` into ``kept`` after its ``count[0]`` rows."""
    for i in range(start, stop):
        if (i + offset) % stride == 0:
            store_row(kept, count[0], rows[i])
            kept_t[count[0]] = times[i]
            count[0] += 1


@njit(cache=True)
def _keep_last(row, t, kept, kept_t, count):
    """The last valid sample, if ``keep_samples`` did not take it."""
    if count[0] == 0 or kept_t[count[0] - 1] != t:
        store_row(kept, count[0], row)
        kept_t[count[0]] = t
        count[0] += 1


@njit(cache=True, parallel=True)
def fixed_step_ensemble(method, y0, times, substeps, max_steps, model, expressions, grids, extra, case, shared, applies, forces, events, found,
                        fault, status, valid, steps, last, acc, keep, stride, kept, kept_t, kept_count):
    """Every case b from ``y0[b]`` with ``substeps[b]`` steps per sample interval of the fixed-step
    method named ``method``: ``status[b]``,
    ``valid[b]`` (samples made), ``steps[b]``, ``acc[b]`` (observables), ``found[b]`` and
    ``fault[b]`` (its ``events``, None without: ``event_scan``); case b's samples go to
    ``kept[keep[b]]`` (``kept_count[b]`` rows) when ``keep[b] ≥ 0``; ``last[b]``: its last valid
    state; ``grids``: ``thread_grids(min(n, WINDOW + 1))``.  A case with ``substeps[b] ≤ 0`` is
    not run (its outputs are left as they are)."""
    n, chunked = times.shape[0], chunk_steps(events, CHUNK_STEPS)
    for b in prange(y0.shape[0]):
        if substeps[b] <= 0:
            continue
        y = y0[b].copy()
        mine = own_model(model, expressions)
        folded = np.empty(acc.shape[1])  # this case's own (a row of ``acc`` shares cache lines with its neighbours')
        rows = grids[get_thread_id()]
        store_row(rows, 0, y)
        solver, watch = (substeps[b], extra), event_scratch(events, STATE_SIZE)
        opened = open_events(events, times, rows, fault[b], watch)
        constants = constants_of(case[b], shared, applies)
        observe_rows(times, rows, 0, 1, True, constants, forces, folded)
        count = np.zeros(1, dtype=np.int64)
        if keep[b] >= 0:
            keep_samples(rows, times, 0, 1, 0, stride, kept[keep[b]], kept_t[keep[b]], count)
        code, i, taken, lo, hi, chunk = OK, 1, 0, 0, min(n, WINDOW + 1), chunked
        while i < n and opened == 1:  # (its single run's calls: ``stepping.run_chunks``)
            budget = min(chunk, max_steps - taken)
            code, made, done = advance_of(literally(method), y, times[lo:hi], rows, i - lo, substeps[b], budget, mine, extra)
            taken += done
            if needs_whole_chunks(code, done, lo + made > i, budget, chunk):
                chunk = CHUNK_STEPS
                continue
            j = scan_call(literally(method), solver, mine, events, times[lo:hi], rows, i - lo, made, code, found[b], fault[b], watch)
            observe_rows(times[lo:hi], rows, i - lo, j, False, constants, forces, folded)
            if keep[b] >= 0:
                keep_samples(rows, times[lo:hi], i - lo, j, lo, stride, kept[keep[b]], kept_t[keep[b]], count)
            ended = code != OK or lo + j == i or j < made  # not valid, the step budget cannot reach the next sample, or an event stopped it
            i = lo + j
            if ended:
                break
            if i == hi < n:  # window full: its last row starts the next one
                store_row(rows, 0, rows[hi - lo - 1])
                lo, hi = hi - 1, min(n, hi + WINDOW)
        y, t, samples = case_end(watch, fault[b], rows[i - 1 - lo], times[i - 1], i, constants, forces, folded)
        report_fixed_step(b, code, samples, taken, y, t, folded, count, status, valid, steps, last, acc, keep, kept, kept_t, kept_count)


@njit(cache=True)
def report_fixed_step(b, code, samples, taken, y, t, folded, count, status, valid, steps, last, acc, keep, kept, kept_t, kept_count):
    """Case b's report after a fixed-step run that made ``samples`` samples with ``taken`` steps
    (``code`` its status, ``y`` its last valid state, at t, ``folded`` its observables, ``count``
    the samples kept so far): the last sample kept, and the outputs written."""
    if keep[b] >= 0:
        _keep_last(y, t, kept[keep[b]], kept_t[keep[b]], count)
    status[b], valid[b], steps[b] = code, samples, taken
    store_row(last, b, y)
    store_row(acc, b, folded)
    kept_count[b] = count[0]


def thread_grids(rows: int) -> np.ndarray:
    """A grid of ``rows`` rows for each thread of the parallel loops below (``grids[get_thread_id()]``:
    the grid of the thread's case; allocated here: a compiled function that asks for the number of
    threads cannot be cached).  A grid allocated and freed case by case had glibc hand its pages
    back to the system and two threads fault them in again, contending in the kernel: on the free
    body's 0.3 ms cases the 2-thread speed-up went from 1.4 to 1.95 between identical calls."""
    return np.empty((get_num_threads(), rows, STATE_SIZE))


@njit(cache=True)
def _start_whole(y0, b, rows, model, expressions, counts):
    """Case b's state, ``rows`` (its thread's grid) with its first sample in row 0, its own copy
    of the model, its own ``counts`` counters, the scratch of ``report_whole`` and its clock
    (``dop853_case``) (none shares a cache line or a reference count with another case's: a row
    of ``acc`` shares cache lines with its neighbours')."""
    y = y0[b].copy()
    store_row(rows, 0, y)
    return (y, rows, own_model(model, expressions), np.zeros(counts, dtype=np.int64), np.empty(ACC_COLUMNS), np.zeros(1, dtype=np.int64),
            np.zeros(3))


@njit(cache=True)
def dop853_case(y, times, rows, rtol, atol, max_steps, chunk, model, counted, clock, events, found, fault, watch):
    """One ``dop853`` case from ``rows[0]`` = y over the sample grid ``times``, as its single run
    steps (in calls of ``chunk`` attempts, ``chunk_steps``, on ``stepping.run_chunks``'s windows: a
    step stops at a window's end) and stops (``STALLED``: after a whole chunk whose pace cannot
    finish, as ``run_chunks`` judges it; or where its ``events``, opened at its first sample, stop
    it, ``event_scan``: found, fault and watch its outputs and scratch): (status, samples made); ``counted``: accepted,
    rejected, evaluations; ``clock``: the integrator's time, and a stalled chunk's start and steps."""
    if open_events(events, times, rows, fault, watch) == 0:  # an event's formula is not finite at the first sample: the case ends there
        return OK, 1
    n, solver, chunk = times.shape[0], (rtol, atol, max_steps), chunk_steps(events, chunk)
    # (i an int64 from the start: a literal 1 would have numba compile ``scan_call`` for it too)
    code, i, t, h, attempts, lo, hi = OK, np.int64(1), times[0], 0.0, 0, 0, min(n, WINDOW + 1)
    while i < n and attempts < max_steps:
        before, start, budget = counted[0] + counted[1], t, min(chunk, max_steps - attempts)
        code, j, t, h = dop853_advance(y, t, h, times[lo:hi], rows[lo:hi], i - lo, times[hi - 1], rtol, atol, budget, model, counted)
        stop = scan_call("dop853", solver, model, events, times, rows, i, lo + j, code, found, fault, watch)
        taken = counted[0] + counted[1] - before
        attempts += taken
        if stop < lo + j:  # (rows cut: past a state not valid, or where an event stopped the case)
            i = stop
            break
        i = lo + j
        code, ended, lo, hi = _after_call(code, start, t, taken, budget, chunk, attempts, max_steps, times, i, lo, hi, clock)
        if ended:
            break
    clock[0] = t
    return code, i


@njit(cache=True)
def _after_call(code, start, t, taken, budget, chunk, steps, max_steps, times, i, lo, hi, clock):
    """After an adaptive case's call of ``taken`` steps from ``start`` to ``t`` (``steps`` in
    all), samples made to i on the window [lo, hi): (status, whether the case ends, the next
    window).  It ends on a kernel's status, or ``STALLED`` after a whole chunk whose pace cannot
    finish with the steps left (``stall_needs``, judged as ``stepping.run_chunks`` judges it: its
    start and steps go to ``clock``)."""
    n = times.shape[0]
    if code != OK:
        return code, True, lo, hi
    if pace_judged(taken, budget, chunk, steps, max_steps) and stall_needs(start, t, taken, times[n - 1], max_steps - steps) != 0.0:
        clock[1], clock[2] = start, taken
        return STALLED, True, lo, hi
    if i == hi < n:
        lo, hi = hi - 1, min(n, hi + WINDOW)
    return code, False, lo, hi


@njit(cache=True)
def report_whole(b, code, i, rows, times, case, shared, applies, forces, status, valid, last, acc, keep, stride, kept, kept_t,
                 kept_count, folded, count, watch, fault):
    """Case b's report from its whole grid of ``rows`` (samples [0, i) made, ``code`` its status;
    ``watch``, ``fault``: its events' scratch and stop, ``case_end``): its observables, its last
    state, its kept samples (``folded``, ``count``: scratch of ``ACC_COLUMNS`` floats and one integer)."""
    if code != OK:
        i = first_invalid_row(rows, 1, i)
    constants = constants_of(case[b], shared, applies)
    observe_rows(times, rows, 0, i, True, constants, forces, folded)
    y, t, samples = case_end(watch, fault, rows[i - 1], times[i - 1], i, constants, forces, folded)
    store_row(acc, b, folded)
    count[0] = 0
    if keep[b] >= 0:
        keep_samples(rows, times, 0, i, 0, stride, kept[keep[b]], kept_t[keep[b]], count)
        _keep_last(y, t, kept[keep[b]], kept_t[keep[b]], count)
    status[b], valid[b] = code, samples
    store_row(last, b, y)
    kept_count[b] = count[0]


@njit(cache=True, parallel=True)
def dop853_ensemble(y0, times, rtol, atol, max_steps, chunk, model, expressions, grids, counters, clocks, case, shared, applies, forces, events, found, fault,
                    status, valid, last, acc, keep, stride, kept, kept_t, kept_count):
    """``fixed_step_ensemble`` for ``dop853`` (``counters[b]``: accepted, rejected, evaluations;
    ``clocks[b]``: ``dop853_case``'s clock; ``grids``: ``thread_grids(n)``, a case's whole grid)."""
    for b in prange(y0.shape[0]):
        y, rows, mine, counted, folded, count, clock = _start_whole(y0, b, grids[get_thread_id()], model, expressions, np.int64(3))
        watch = event_scratch(events, STATE_SIZE)
        code, i = dop853_case(y, times, rows, rtol, atol, max_steps, chunk, mine, counted, clock, events, found[b], fault[b], watch)
        store_row(counters, b, counted)
        store_row(clocks, b, clock)
        report_whole(b, code, i, rows, times, case, shared, applies, forces, status, valid, last, acc, keep, stride, kept, kept_t,
                     kept_count, folded, count, watch, fault[b])


@njit(cache=True)
def taylor_case(y, times, rows, order, rtol, atol, max_steps, chunk, model, c0, T, lever_force, flags, counted, clock, events, found, fault,
                watch):
    """One ``taylor`` case from ``rows[0]`` = y over the sample grid ``times``, as its single run
    steps and stops (``dop853_case``): (status, samples made); ``counted[0]``: steps."""
    if open_events(events, times, rows, fault, watch) == 0:  # (as ``dop853_case``)
        return OK, 1
    n, chunk = times.shape[0], chunk_steps(events, chunk)
    solver = (order, rtol, atol, max_steps, c0, T, lever_force, flags)
    code, i, t, lo, hi = OK, np.int64(1), times[0], 0, min(n, WINDOW + 1)  # (as ``dop853_case``)
    while i < n and counted[0] < max_steps:
        before, start, budget = counted[0], t, min(chunk, max_steps - counted[0])
        code, j, t = taylor_advance(y, t, times[lo:hi], rows[lo:hi], i - lo, order, rtol, atol, budget, model, c0, T, lever_force, flags,
                                    counted)
        stop = scan_call("taylor", solver, model, events, times, rows, i, lo + j, code, found, fault, watch)
        if stop < lo + j:  # (rows cut: past a state not valid, or where an event stopped the case)
            i = stop
            break
        i = lo + j
        code, ended, lo, hi = _after_call(code, start, t, counted[0] - before, budget, chunk, counted[0], max_steps, times, i, lo, hi, clock)
        if ended:
            break
    clock[0] = t
    return code, i


@njit(cache=True, parallel=True)
def taylor_ensemble(y0, times, order, rtol, atol, max_steps, chunk, model, expressions, grids, c0, T, lever_force, flags, counters, clocks, case,
                    shared, applies, forces, events, found, fault, status, valid, last, acc, keep, stride, kept, kept_t, kept_count):
    """``fixed_step_ensemble`` for ``taylor`` at ``order`` (its ``kernel_constants`` c0, T,
    lever_force, flags; ``counters[b, 0]``: steps; ``clocks[b]``: ``taylor_case``'s clock;
    ``grids``: ``thread_grids(n)``)."""
    for b in prange(y0.shape[0]):
        y, rows, mine, counted, folded, count, clock = _start_whole(y0, b, grids[get_thread_id()], model, expressions, np.int64(1))
        watch = event_scratch(events, STATE_SIZE)
        code, i = taylor_case(y, times, rows, order, rtol, atol, max_steps, chunk, mine, c0, T, lever_force, flags, counted, clock, events,
                              found[b], fault[b], watch)
        counters[b, 0] = counted[0]
        store_row(clocks, b, clock)
        report_whole(b, code, i, rows, times, case, shared, applies, forces, status, valid, last, acc, keep, stride, kept, kept_t,
                     kept_count, folded, count, watch, fault[b])
