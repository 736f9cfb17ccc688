"""Classical fixed-step Runge–Kutta 4 (the seeds' baseline), without renormalisation.

    k1 = f(t, y), k2 = f(t + h/2, y + h k1/2), k3 = f(t + h/2, y + h k2/2), k4 = f(t + h, y + h k3)
    y ← y + h (k1 + 2 k2 + 2 k3 + k4) / 6
Each sample interval [t_{i−1}, t_i] is split into ``substeps`` equal steps, so samples fall on
steps exactly.  A step that contains a load breakpoint (a window edge or table knot, see
``rotlab.scene.loads.breakpoints``) is split there: the part ending at the breakpoint sees the
loads' left limit, the next part starts from the right limit, so a switching load does not cost
RK4 its order.
"""

from __future__ import annotations

from numba import njit

from rotlab.core.dynamics import count_at_or_below, next_piece, rhs_llvm_inlined, state_size
from rotlab.core.kernel_status import OK, end_sample
from rotlab.core.targets import work_vector



@njit(cache=True)
def rk4_advance(y, times, out, i_start, substeps, max_steps, model):
    """Advance ``y`` (the state at ``times[i_start − 1]``) sample by sample, writing ``out[i]``.

    Stops after at most ``max_steps`` steps (at a sample).  Returns (status, next sample index,
    steps taken, partial steps at breakpoints included); on another status than OK
    (``state_status``) the returned index is the sample whose interval failed.  ``model``: the
    scene's ``rotlab.scene.loads.Model`` (its ``breaks``: sorted load breakpoints, may be empty).
    """
    n = state_size(model)  # (8; more with driven rotors)
    k1 = work_vector(n)
    k2 = work_vector(n)
    k3 = work_vector(n)
    k4 = work_vector(n)
    tmp = work_vector(n)
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
                h = end - t
                rhs_llvm_inlined(t, y, k1, model)
                for m in range(n):
                    tmp[m] = y[m] + 0.5 * h * k1[m]
                rhs_llvm_inlined(t + 0.5 * h, tmp, k2, model)
                for m in range(n):
                    tmp[m] = y[m] + 0.5 * h * k2[m]
                rhs_llvm_inlined(t + 0.5 * h, tmp, k3, model)
                for m in range(n):
                    tmp[m] = y[m] + h * k3[m]
                rhs_llvm_inlined(t_last, tmp, k4, model)
                for m in range(n):
                    y[m] += h / 6.0 * (k1[m] + 2.0 * (k2[m] + k3[m]) + k4[m])
                steps += 1
                t = end
        status = end_sample(y, out, i)
        if status != OK:
            return status, i, steps
        i += 1
    return OK, i, steps
