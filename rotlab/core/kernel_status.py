"""What the kernels share: their status codes, the end of a sample interval (``end_sample``: the
state stored, or NONFINITE) and ``WINDOW``, the samples per kernel call of a run (an adaptive
method's steps stop at each window's end, so every caller that must reproduce a run uses it).

Each kernel keeps its own time loop.  A loop written once around a per-method step (a scheme
class whose step numba inlines, ``rk4`` and ``rkmk4`` sharing it) gave the same steps, bit for
bit, but made a step on a scene with loads 30–70% slower (configs/general.toml, ``rk4``; its
machine code keeps more calls out of line than the kernel's own loop).
"""

from __future__ import annotations

import math

from numba import njit

from rotlab.core.dynamics import all_finite, store_row

OK, NONFINITE = 0, 1  # a kernel's status
STALLED = 4  # an adaptive run's pace cannot reach its end (``stall_needs``; its driver's verdict, not a kernel's)
STALL_FACTOR = 10  # an adaptive run whose pace needs this many times the steps it has left stops (``stall_needs``)
WINDOW = 1 << 14  # samples per window when streaming (8 doubles each: 1 MB)


@njit(cache=True, forceinline=True)
def end_sample(y, out, i):
    """out[i] ← y when every component is finite (OK), else NONFINITE (out[i] untouched)."""
    if not all_finite(y):
        return NONFINITE
    store_row(out, i, y)
    return OK


@njit(cache=True)
def pace_judged(taken, budget, chunk, steps, max_steps):
    """Whether a call's pace may be judged (``stall_needs``): it took a whole chunk of steps and
    the run has steps left (a shorter call ended at its window or its budget)."""
    return taken >= budget == chunk and steps < max_steps


@njit(cache=True)
def stall_needs(t_from, t_to, taken, t_end, steps_left):
    """After a whole chunk of ``taken`` steps that advanced t from ``t_from`` to ``t_to``: the
    steps the rest of the span to ``t_end`` needs at that pace, when it is more than
    ``STALL_FACTOR`` times ``steps_left`` (the run cannot finish: a step size collapsed at a
    singular or chattering load); 0 while it can finish."""
    pace = (t_to - t_from) / taken
    needed = (t_end - t_to) / pace if pace > 0.0 else math.inf
    return needed if needed > STALL_FACTOR * steps_left else 0.0
