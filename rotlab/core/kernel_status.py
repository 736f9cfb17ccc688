"""What the kernels share: their status codes, the one rule a state must meet to be stored
(``state_status``: every component finite and |Λ|² a normal double, so that Λ/|Λ| is an
attitude), the end of a sample interval (``end_sample``: the state stored, or why not) and
``WINDOW``, the samples per kernel call of a run (an adaptive method's steps stop at each
window's end, so every caller that must reproduce a run uses it).

Each kernel keeps its own time loop.  A loop written once around a per-method step (a scheme
class whose step numba inlines, ``rk4`` and ``rkmk4`` sharing it) gave the same steps, bit for
bit, but made a step on a scene with loads 30–70% slower (configs/general.toml, ``rk4``; its
machine code keeps more calls out of line than the kernel's own loop).
"""

from __future__ import annotations

import math
import sys

import numpy as np
from numba import njit

from rotlab.core.dynamics import all_finite, store_row

OK, NONFINITE, ATTITUDE_LOST = 0, 1, 2  # a kernel's status (NONFINITE, ATTITUDE_LOST: ``state_status``)
STEP_TOO_SMALL = 3  # an adaptive kernel's step fell below the floating-point resolution of t
STALLED = 4  # an adaptive run's pace cannot reach its end (``stall_needs``; its driver's verdict, not a kernel's)
NORM2_MIN, NORM2_MAX = sys.float_info.min, sys.float_info.max  # |Λ|² outside [DBL_MIN, DBL_MAX]: Λ/|Λ| is not computable
STALL_FACTOR = 10  # an adaptive run whose pace needs this many times the steps it has left stops (``stall_needs``)
WINDOW = 1 << 14  # samples per window when streaming (8 doubles each: 1 MB)
CHUNK_STEPS = 1 << 18  # steps per kernel call of a run (``rotlab.methods.stepping.run_chunks``)
# steps per kernel call while a watch that may end the run sees the rows (a terminal event): the run
# ends at most this many steps past it; a call's budget ends between two steps, so the steps are the same
WATCHED_STEPS = 1 << 12


@njit(cache=True, forceinline=True)
def state_status(y):
    """Whether a state may be stored: NONFINITE when a component of y is not finite,
    ATTITUDE_LOST when |Λ|² = Σ y[0:4]² lies outside [DBL_MIN, DBL_MAX] (|Λ| below ~1.5e-154
    or above ~1.3e154: Λ/|Λ| underflows or overflows, the attitude is lost — a method whose step
    does not keep |Λ| drove it there, as rk4's |R(i·h|ω|/2)| < 1 does over many steps), else OK.
    ``valid_rows`` is the same rule over an array's rows, in NumPy."""
    if not all_finite(y):
        return NONFINITE
    norm2 = y[0] * y[0] + y[1] * y[1] + y[2] * y[2] + y[3] * y[3]
    if not NORM2_MIN <= norm2 <= NORM2_MAX:
        return ATTITUDE_LOST
    return OK


@njit(cache=True, forceinline=True)
def end_sample(y, out, i):
    """out[i] ← y when ``state_status(y)`` is OK, else that status (out[i] untouched)."""
    status = state_status(y)
    if status == OK:
        store_row(out, i, y)
    return status


@njit(cache=True)
def first_invalid_row(rows, start, stop):
    """The first row in [start, stop) that ``state_status`` refuses, else ``stop`` (an adaptive
    kernel that stops may have written dense-output rows past its last valid state)."""
    for i in range(start, stop):
        if state_status(rows[i]) != OK:
            return i
    return stop


def valid_rows(rows: np.ndarray) -> np.ndarray:
    """``state_status(row) == OK`` for each row of ``rows``, in NumPy (for the Python side:
    exact solutions' windows, a stopped kernel's window, the Lyapunov flow's states)."""
    q = rows[:, :4]
    with np.errstate(over="ignore", invalid="ignore"):
        norm2 = q[:, 0] * q[:, 0] + q[:, 1] * q[:, 1] + q[:, 2] * q[:, 2] + q[:, 3] * q[:, 3]  # (``state_status``'s order)
    return np.all(np.isfinite(rows), axis=1) & (norm2 >= NORM2_MIN) & (norm2 <= NORM2_MAX)


@njit(cache=True)
def needs_whole_chunks(status, taken, progressed, budget, chunk):
    """A call of ``chunk`` steps that made no sample, nothing failing: a sample interval needs
    more steps than ``WATCHED_STEPS``, and the run's calls take ``CHUNK_STEPS`` from then on."""
    return status == OK and taken == 0 and not progressed and budget == chunk < CHUNK_STEPS


@njit(cache=True)
def pace_judged(taken, budget, chunk, steps, max_steps):
    """Whether a call's pace may be judged (``stall_needs``): it took a whole chunk of
    ``CHUNK_STEPS`` steps and the run has steps left (a shorter call ended at its window or its
    budget).  A run that a terminal event may end (calls of ``WATCHED_STEPS``) is not judged: it
    may end long before the span does, so the span's steps are not what it needs."""
    return taken >= budget == chunk == CHUNK_STEPS and steps < max_steps


@njit(cache=True)
def stall_needs(t_from, t_to, taken, t_end, steps_left):
    """After a whole chunk of ``taken`` steps that advanced t from ``t_from`` to ``t_to``: the
    steps the rest of the span to ``t_end`` needs at that pace, when it is more than
    ``STALL_FACTOR`` times ``steps_left`` (the run cannot finish: a step size collapsed at a
    singular or chattering load); 0 while it can finish."""
    pace = (t_to - t_from) / taken
    needed = (t_end - t_to) / pace if pace > 0.0 else math.inf
    return needed if needed > STALL_FACTOR * steps_left else 0.0
