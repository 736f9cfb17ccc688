"""Many bodies per call: the same scene (inertia, loads) from N initial states, in parallel
over bodies (numba ``prange``), each body stepped by the ordinary RK4 kernel."""

from __future__ import annotations

from numba import njit, prange

from rotlab.core.dynamics import store_row
from rotlab.core.rk4 import rk4_advance


@njit(cache=True, parallel=True)
def rk4_ensemble(y0, times, out, substeps, max_steps, model, status, valid):
    """out[b] (samples × 8) for every initial state y0[b]; status[b], valid[b] per body."""
    for b in prange(y0.shape[0]):
        y = y0[b].copy()
        store_row(out[b], 0, y)
        code, i, _ = rk4_advance(y, times, out[b], 1, substeps, max_steps, model)
        status[b] = code
        valid[b] = i
