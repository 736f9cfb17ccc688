"""The one time loop of the kernels that step the right-hand side with equal steps (``rk4``,
``rkmk4``), and the sample ending every fixed-step kernel shares.

Each sample interval [t_{i−1}, t_i] is split into ``substeps`` equal steps, so samples fall on
steps exactly.  A step that contains a load breakpoint (a window edge or table knot, see
``rotlab.scene.loads.breakpoints``) is split there: the part ending at the breakpoint sees the
loads' left limit (its last stage at ``t_last``, just below the breakpoint), the next part
starts from the right limit, so a switching load does not cost the method its order.

A method supplies one step as a *scheme*: an empty ``NamedTuple`` class whose ``step`` attribute
is the compiled ``step(t, h, t_last, y, model, work)`` that advances y by h from t (``work``:
``WORK_ARRAYS`` scratch arrays of the state's size).  numba specialises ``advance`` on the
scheme's type (a class, so the specialisation is cached on disk like any other) and inlines the
step (``forceinline``): the loop is written once and each method's steps are its own.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.extending import overload

from rotlab.core.dynamics import STATE_SIZE, all_finite, count_at_or_below, next_piece, store_row

OK, NONFINITE = 0, 1  # a kernel's status
WORK_ARRAYS = 5  # scratch arrays a step may use (RK4: k1..k4 and the stage state)


def take_step(scheme, t, h, t_last, y, model, work):
    """``scheme``'s step (module docstring)."""
    raise NotImplementedError("compiled only")


@overload(take_step, inline="always")
def _take_step(scheme, t, h, t_last, y, model, work):
    step = scheme.instance_class.step
    return lambda scheme, t, h, t_last, y, model, work: step(t, h, t_last, y, model, work)


@njit(cache=True)
def advance(scheme, y, times, out, i_start, substeps, max_steps, model):
    """Advance ``y`` (the state at ``times[i_start − 1]``) sample by sample with ``scheme``'s steps,
    writing ``out[i]``.  Stops after at most ``max_steps`` steps (at a sample).  Returns (status,
    next sample index, steps taken): the steps count the pieces of a step split at a breakpoint;
    on NONFINITE the index is the sample whose interval failed.  ``model``: the scene's
    ``rotlab.scene.loads.Model`` (its ``breaks``: sorted load breakpoints, may be empty)."""
    n = STATE_SIZE
    work = (np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n))
    steps = 0
    i = i_start
    breaks = model.breaks
    b = count_at_or_below(breaks, times[i_start - 1])  # next breakpoint
    while i < times.shape[0] and steps + substeps <= max_steps:
        t0 = times[i - 1]
        h_nominal = (times[i] - t0) / substeps
        for j in range(substeps):
            t = t0 + j * h_nominal
            t_end = times[i] if j == substeps - 1 else t0 + (j + 1) * h_nominal
            while t < t_end:  # one step, or its pieces between breakpoints
                end, t_last, b = next_piece(t, t_end, breaks, b)
                take_step(scheme, t, end - t, t_last, y, model, work)
                steps += 1
                t = end
        if end_sample(y, out, i) != OK:
            return NONFINITE, i, steps
        i += 1
    return OK, i, steps


@njit(cache=True, forceinline=True)
def end_sample(y, out, i):
    """out[i] ← y when every component is finite (OK), else NONFINITE (out[i] untouched)."""
    if not all_finite(y):
        return NONFINITE
    store_row(out, i, y)
    return OK
