"""The driver shared by the time-stepping methods: it calls a compiled kernel in chunks of
steps, so Python runs once per chunk (progress bar, Ctrl-C, failure reporting), never per step.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from rotlab.core.dynamics import STATE_SIZE
from rotlab.methods.base import ProgressCallback, Solution

# a chunk of kernel work returns (status, next sample index, steps taken in the chunk)
Chunk = Callable[[int, int], tuple[int, int, int]]

CHUNK_STEPS = 1 << 18


def initial_state(q0: np.ndarray, omega0: np.ndarray) -> np.ndarray:
    y = np.zeros(STATE_SIZE)
    y[0:4] = q0
    y[4:7] = omega0
    return y


def run_chunks(
    t: np.ndarray,
    out: np.ndarray,
    advance: Chunk,
    max_steps: int,
    progress: ProgressCallback | None,
    describe_failure: Callable[[int, int], str],
) -> Solution:
    """Call ``advance(i, budget)`` until every sample is written, a failure or the step budget.

    ``describe_failure(status, i)`` words a non-zero status at sample index i.
    A KeyboardInterrupt ends the run cleanly, keeping the samples written so far.
    """
    i, steps, failure, interrupted = 1, 0, None, False
    try:
        while i < t.shape[0]:
            budget = min(CHUNK_STEPS, max_steps - steps)
            if budget <= 0:
                failure = f"step budget of {max_steps:,} steps exhausted at t = {t[i - 1]:.9g} s (raise solver.max_steps)"
                break
            status, i, taken = advance(i, budget)
            steps += taken
            if progress is not None:
                progress(i, t.shape[0])
            if status != 0:
                failure = describe_failure(status, i)
                break
    except KeyboardInterrupt:
        failure, interrupted = f"interrupted by the user at t = {t[i - 1]:.9g} s", True
    valid = i if failure is None else _valid_rows(out, i)
    return Solution(t=t, state=out, valid=valid, steps=steps, failure=failure, interrupted=interrupted)


def _valid_rows(out: np.ndarray, i: int) -> int:
    """Rows [0, i) written by the kernel, cut at the first non-finite one."""
    finite = np.all(np.isfinite(out[:i]), axis=1)
    return int(np.argmin(finite)) if not finite.all() else i


def adaptive_failure_message(step_too_small: bool, t_now: float, t: np.ndarray, i: int, state: np.ndarray) -> str:
    """Why an adaptive method stopped: its step fell below the floating-point resolution at
    ``t_now``, or the state became non-finite (see ``nonfinite_message``)."""
    if step_too_small:
        return f"step size fell below the floating-point resolution at t = {t_now:.9g} s (the solution is singular or the tolerances too tight)"
    return nonfinite_message(t, i, state)


def nonfinite_message(t: np.ndarray, i: int, state: np.ndarray) -> str:
    """Where and why a run blew up, naming the last valid state."""
    last = state[i - 1]
    return (
        f"state became non-finite between t = {t[i - 1]:.9g} s and t = {t[min(i, t.shape[0] - 1)]:.9g} s; "
        f"last valid state: Λ = {np.array2string(last[0:4], precision=6)}, ω = {np.array2string(last[4:7], precision=6)} rad/s "
        "(step too large for this scene, or the motion itself diverges)"
    )
