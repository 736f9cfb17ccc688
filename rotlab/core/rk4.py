"""Classical fixed-step Runge–Kutta 4 (the seeds' baseline), without renormalisation:

    k1 = f(t, y), k2 = f(t + h/2, y + h k1/2), k3 = f(t + h/2, y + h k2/2), k4 = f(t + h, y + h k3)
    y ← y + h (k1 + 2 k2 + 2 k3 + k4) / 6

stepped by the shared time loop (``rotlab.core.time_loop``: equal steps per sample interval,
split at load breakpoints, k4 at the breakpoint's left limit).
"""

from __future__ import annotations

from typing import NamedTuple

from numba import njit

from rotlab.core.dynamics import STATE_SIZE, rhs_llvm_inlined
from rotlab.core.time_loop import advance


@njit(cache=True, forceinline=True)
def rk4_step(t, h, t_last, y, model, work):
    """One RK4 step of size h from t; the last stage at ``t_last`` (t + h, or its left limit)."""
    k1, k2, k3, k4, tmp = work
    n = STATE_SIZE
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


class RK4(NamedTuple):
    """The scheme of ``rk4_step`` (``rotlab.core.time_loop``)."""


RK4.step = rk4_step


@njit(cache=True)
def rk4_advance(y, times, out, i_start, substeps, max_steps, model):
    """``rotlab.core.time_loop.advance`` with RK4 steps."""
    return advance(RK4(), y, times, out, i_start, substeps, max_steps, model)
