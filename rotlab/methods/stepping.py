"""The driver shared by the time-stepping methods: it calls a compiled kernel in chunks of
steps, so Python runs once per chunk (progress bar, Ctrl-C, wall-clock limit, streaming,
failure reporting), never per step.

Two ways to run, chosen by the caller of ``Method.solve`` through ``streaming(...)``:

* whole (the default, ``rotlab.simulate``): the kernel writes into one (N, 8) array that the
  ``Solution`` returns;
* streamed (``rotlab run``): the samples are produced in windows of at most ``WINDOW`` rows;
  every finished run of rows goes to the ``RowConsumer`` as soon as the kernel returns, and the
  window is reused, so memory does not grow with the run's length.  The ``Solution`` then holds
  only the last window (``state`` rows ``[valid − len(state), valid)``).

Both call the kernel on the same windows of at most ``WINDOW`` samples, and an adaptive method
ends a step at its window's last sample: a streamed run and a whole one give the same states, bit
for bit.  A kernel call sees a window of the sample times ``times = t[lo − 1 : hi]`` and of the output
``out`` (row 0 is the sample before the window: the kernels continue from the state ``y`` they
carry, so the window's first row is never written) and the local index i ≥ 1 of its next sample.
"""

from __future__ import annotations

import contextlib
import contextvars
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Iterator, Protocol

import numpy as np

from rotlab import interrupts
from rotlab.core import faults
from rotlab.core.dynamics import STATE_SIZE
from rotlab.core.kernel_status import ATTITUDE_LOST, CHUNK_STEPS, STEP_TOO_SMALL, WATCHED_STEPS, WINDOW, needs_whole_chunks, pace_judged, \
    stall_needs, valid_rows
from rotlab.methods.base import ProgressCallback, Solution

if TYPE_CHECKING:
    from rotlab.scene.scene import Scene

# a chunk of kernel work: advance(times, out, i, budget) → (status, next local sample index, steps taken)
Chunk = Callable[[np.ndarray, np.ndarray, int, int], tuple[int, int, int]]



class RowConsumer(Protocol):
    def rows(self, start: int, t: np.ndarray, state: np.ndarray) -> None:
        """Samples ``start, start + 1, …`` (times ``t``, states ``state`` (n, 8), principal frame):
        valid and final; the arrays are reused after the call returns."""


@dataclass(frozen=True)
class Stop:
    """What a ``RowWatch`` asks of the run: keep the first ``keep`` rows it was shown and end,
    with ``failure`` (None: a normal end, such as a terminal event)."""

    keep: int
    failure: str | None = None


class RowWatch(Protocol):
    ends_runs: bool  # it may end a run early (a terminal event): the kernel then runs in shorter calls

    def rows(self, start: int, t: np.ndarray, state: np.ndarray) -> Stop | None:
        """Samples ``start, start + 1, …`` as they are made (every run, streamed or whole, the
        initial sample first), before any consumer sees them; a ``Stop`` ends the run there."""


@dataclass(frozen=True)
class RunControl:
    """Run-wide controls the driver honours between kernel calls."""

    consumer: RowConsumer | None = None  # streaming: where the rows go
    watch: RowWatch | None = None  # events: sees every row first, may end the run
    deadline: float | None = None  # time.monotonic() value; past it the run stops (``--timeout``)
    timeout: float | None = None  # the limit in seconds, for the message


_CONTROL: contextvars.ContextVar[RunControl] = contextvars.ContextVar("rotlab_run_control", default=RunControl())


@contextlib.contextmanager
def controlled(control: RunControl) -> Iterator[None]:
    """Run the methods called inside the block under ``control`` (streaming and/or a deadline)."""
    token = _CONTROL.set(control)
    try:
        yield
    finally:
        _CONTROL.reset(token)


def current_control() -> RunControl:
    return _CONTROL.get()


class SampleTimes:
    """``np.linspace(start, end, n)`` without the array: element k is k·step + start with
    step = (end − start)/(n − 1) and the last element exactly ``end`` (NumPy's own arithmetic,
    so the values are identical).  Indexing with an int gives a float, with a slice an array:
    a streamed run of any length never holds its sample times (8 bytes per sample)."""

    def __init__(self, start: float, end: float, n: int) -> None:
        self.start, self.end, self.n = float(start), float(end), int(n)
        self.step = (self.end - self.start) / (self.n - 1) if self.n > 1 else 0.0
        self.shape = (self.n,)

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, key: int | slice) -> float | np.ndarray:
        if isinstance(key, slice):
            k = np.arange(*key.indices(self.n), dtype=float)
            values = k * self.step + self.start
            if values.size and k[-1] == self.n - 1:
                values[-1] = self.end
            return values
        k = int(key) + (self.n if int(key) < 0 else 0)
        if not 0 <= k < self.n:
            raise IndexError(key)
        return self.end if k == self.n - 1 else k * self.step + self.start


def initial_state(scene: Scene) -> np.ndarray:
    """The scene's state at t0, a copy the kernel may advance in place."""
    return scene.state0.copy()


def timeout_message(control: RunControl, t_now: float) -> str:
    return f"wall-clock limit of {control.timeout:g} s (--timeout) reached at t = {t_now:.9g} s"


def run_chunks(
    t: np.ndarray,
    y: np.ndarray,
    advance: Chunk,
    max_steps: int,
    progress: ProgressCallback | None,
    describe_failure: Callable[[int, np.ndarray, np.ndarray, int], str],
    integrator_time: Callable[[], float] | None = None,
    explain_fault: Callable[[faults.Fault], str] | None = None,
) -> Solution:
    """Call ``advance`` until every sample is written, a failure, the step budget, the
    wall-clock limit or Ctrl-C; ``y`` is the state at ``t[0]`` (advanced in place by the kernel).

    ``describe_failure(status, times, out, i)`` words a non-zero status; i is the number of valid
    rows of the window (``out`` row i − 1 is the last valid state, at ``times[i − 1]``); when a
    compiled load recorded a fault (``rotlab.core.faults``), ``explain_fault(fault)`` words it
    instead: that load stopped the run.  A KeyboardInterrupt ends the run cleanly,
    keeping the samples written so far.  ``integrator_time()`` (adaptive methods): how far the
    steps got, named when the step budget or the time limit stops them between two samples.
    """
    control = current_control()
    n = t.shape[0]
    streamed = control.consumer is not None
    out = np.empty((min(n, WINDOW + 1) if streamed else n, y.shape[0]))  # (STATE_SIZE, and a column per driven rotor)
    out[0] = y
    # the window: global samples [base, hi); streamed, out row 0 is sample base (the array is reused),
    # whole, out row k is sample k.  Both runs see the same windows: an adaptive kernel ends its
    # steps at a window's last sample, so a streamed run and a whole one take the same steps
    base, hi = 0, min(n, WINDOW + 1)
    i, steps, failure, interrupted, ended = 1, 0, None, False, False
    now = integrator_time or (lambda: float(t[i - 1]))

    def exhausted() -> str:
        return budget_message(max_steps, now())

    faults.clear()
    try:
        first = _watched(control, 0, t[:1], out[:1])
        if first is not None:  # the watch refuses the initial state itself (an event formula not finite there)
            failure = first.failure
        if streamed:  # the first row can flush (a kernel that took > FLUSH_SECONDS to load): Ctrl-C there too
            control.consumer.rows(0, t[:1], out[:1])
        chunk = WATCHED_STEPS if control.watch is not None and control.watch.ends_runs else CHUNK_STEPS
        while i < n and failure is None:
            budget = min(chunk, max_steps - steps)
            if budget <= 0:
                failure = exhausted()
                break
            if control.deadline is not None and time.monotonic() > control.deadline:
                failure = timeout_message(control, now())
                break
            times, window = t[base:hi], out[: hi - base] if streamed else out[base:hi]
            start = now()
            status, local, taken = advance(times, window, i - base, budget)
            steps += taken
            done = base + local
            # (the predicates' Python functions: a compiled call here would add a compile to a run's start)
            if needs_whole_chunks.py_func(status, taken, done > i, budget, chunk):
                chunk = CHUNK_STEPS
                continue
            if status == 0 and integrator_time is not None and pace_judged.py_func(taken, budget, chunk, steps, max_steps):
                failure = stall_message(start, now(), taken, float(t[n - 1]), max_steps - steps, max_steps)
            if status != 0:
                valid = _valid_rows(window, local)  # a kernel may have written non-finite rows before it stopped
                failure = _failure_words(faults.take(), explain_fault) or describe_failure(status, times, window, valid)
                done = base + valid
            elif taken == 0 and done == i:  # the rest of the budget is less than the next sample needs
                failure = exhausted()
            stop = _watched(control, i, t[i:done], window[i - base : done - base])
            if stop is not None:
                done, failure, ended = i + stop.keep, stop.failure, True
            if streamed and done > i:
                control.consumer.rows(i, t[i:done], window[i - base : done - base])
            i = done
            if progress is not None:
                progress(i, n)
            if failure is not None or ended:
                break
            if i == hi < n:  # window full: its last row starts the next one
                if streamed:
                    out[0] = window[hi - base - 1]
                base, hi = hi - 1, min(n, hi + WINDOW)
    except KeyboardInterrupt:
        failure, interrupted = interrupts.stopped_at(t[i - 1]), True
    state = out[: i - base] if streamed else out
    return Solution(t=t, state=state, valid=i, steps=steps, failure=failure, interrupted=interrupted)


def _watched(control: RunControl, start: int, t: np.ndarray, state: np.ndarray) -> Stop | None:
    """The watch's verdict on new rows (None: no watch, no rows, or go on)."""
    if control.watch is None or state.shape[0] == 0:
        return None
    return control.watch.rows(start, t, state)


def stall_message(t_from: float, t_to: float, taken: int, t_end: float, steps_left: int, max_steps: int) -> str | None:
    """Why an adaptive run cannot finish, judged after a whole chunk of ``CHUNK_STEPS`` with steps
    left in the budget (else the budget's own message says it): at the
    chunk's pace ((t_to − t_from) / taken per step) the rest of the span needs more than
    ``STALL_FACTOR`` times the steps left in ``solver.max_steps`` (a step size collapsed at a
    singular or chattering load, or an absurd scene); None while it can."""
    needed = stall_needs(t_from, t_to, taken, t_end, steps_left)
    if needed == 0.0:
        return None
    pace = (t_to - t_from) / taken
    return (f"no progress: {taken:,} steps advanced t only from {t_from:.9g} s to {t_to:.9g} s (mean step {pace:.3g} s); "
            f"the remaining {t_end - t_to:.6g} s would take ~{needed:.2g} steps, beyond solver.max_steps = {max_steps:,} "
            "(a load that is singular or switches back and forth there, a stiff scene, or tolerances too tight)")


def _failure_words(fault: faults.Fault | None, explain_fault: Callable[[faults.Fault], str] | None) -> str | None:
    """The words of a compiled load's fault, if one stopped the kernel; a Ctrl-C that a Python
    torque caught inside the kernel is raised here (when SIGINT has no Python handler to do it)."""
    if fault is None:
        return None
    if fault.kind == faults.INTERRUPTED:
        raise KeyboardInterrupt
    return explain_fault(fault) if explain_fault is not None else None


def evaluate_in_windows(t: np.ndarray, evaluate: Callable[[np.ndarray], np.ndarray], progress: ProgressCallback | None) -> Solution:
    """For methods that evaluate a closed form at any times (no stepping): ``evaluate(times)``
    returns the (len(times), 8) states.  Whole runs evaluate all samples at once; streamed runs
    window by window (bounded memory), with Ctrl-C and the wall-clock limit checked between
    windows.  Evaluation stops at the first non-finite state."""
    control = current_control()
    n = t.shape[0]
    step = WINDOW if control.consumer is not None else n
    state = np.empty((0, STATE_SIZE))
    i, failure, interrupted = 0, None, False
    try:
        while i < n:
            if control.deadline is not None and time.monotonic() > control.deadline and i > 0:
                failure = timeout_message(control, t[i - 1])
                break
            stop = min(n, i + step)
            state = evaluate(t[i:stop])
            valid = _valid_rows(state, state.shape[0])
            watched = _watched(control, i, t[i : i + valid], state[:valid])
            if watched is not None:  # (the initial state is kept, as a stepping run keeps it)
                valid, failure = max(watched.keep, 1 if i == 0 else 0), watched.failure
            if control.consumer is not None and valid:
                control.consumer.rows(i, t[i : i + valid], state[:valid])
            i += valid
            if progress is not None:
                progress(i, n)
            if watched is not None:
                state = state[:valid]
                break
            if valid < state.shape[0]:
                failure = f"exact solution not finite at t = {t[i]:.9g} s"
                state = state[:valid]
                break
    except KeyboardInterrupt:
        failure, interrupted = interrupts.stopped_at(t[max(i, 1) - 1]), True
    if control.consumer is not None:
        state = state[max(0, state.shape[0] - WINDOW) :]
    return Solution(t=t, state=state, valid=i, failure=failure, interrupted=interrupted)


def _valid_rows(out: np.ndarray, i: int) -> int:
    """Rows [0, i) written by the kernel, cut at the first one ``state_status`` refuses."""
    valid = valid_rows(out[:i])
    return int(np.argmin(valid)) if not valid.all() else i


def adaptive_failure_message(status: int, t_now: float, times: np.ndarray, state: np.ndarray, i: int) -> str:
    """Why an adaptive method stopped: its step fell below the floating-point resolution at
    ``t_now`` (STEP_TOO_SMALL), or the state was refused (``state_failure_message``)."""
    if status == STEP_TOO_SMALL:
        return step_floor_message(f"at t = {t_now:.9g} s")
    return state_failure_message(status, times, state, i)


def step_floor_message(where: str) -> str:
    """An adaptive step fell below the floating-point resolution ``where`` ("at t = … s")."""
    return f"step size fell below the floating-point resolution {where} (the solution is singular or the tolerances too tight)"


def budget_message(max_steps: int, t_now: float) -> str:
    """``solver.max_steps`` ran out at ``t_now``."""
    return f"step budget of {max_steps:,} steps exhausted at t = {t_now:.9g} s (raise solver.max_steps)"


def state_failure_message(status: int, t: np.ndarray, state: np.ndarray, i: int) -> str:
    """Why ``state_status`` refused the state after row i − 1 of ``state`` (its last valid one)."""
    return state_failure_after(status, float(t[i - 1]), float(t[min(i, t.shape[0] - 1)]), state[i - 1])


def state_failure_after(status: int, t_valid: float, t_next: float, last: np.ndarray) -> str:
    """Where and why a run stopped on a state that ``state_status`` refused (``status``), from
    the last valid state ``last`` (at ``t_valid``) and the next sample time."""
    between = f"between t = {t_valid:.9g} s and t = {t_next:.9g} s"
    if status == ATTITUDE_LOST:
        return (f"the attitude is lost {between}: |Λ| left the range where Λ/|Λ| can be computed (~1.5e-154 to ~1.3e154; "
                f"|Λ| = {np.linalg.norm(last[0:4]):.3g} at the last valid sample, 1 at the start); this method's step does not keep |Λ| "
                "at this rate of turn: take a smaller solver.step, or a method that keeps |Λ| (rkmk4, dmv, splitting)")
    return (
        f"state became non-finite {between}; "
        f"last valid state: Λ = {np.array2string(last[0:4], precision=6)}, ω = {np.array2string(last[4:7], precision=6)} rad/s "
        "(step too large for this scene, or the motion itself diverges)"
    )
