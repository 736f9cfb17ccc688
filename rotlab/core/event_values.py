"""Event formulas on states (``rotlab.events``): the value of one compiled formula at each row
of a state array, from the inputs an expression load sees (``torques.expression_inputs``: t, ω,
Λ, γ, L in the user's body frame) through the same generated function (``call_formulas``)."""

from __future__ import annotations

import math

from numba import njit

from rotlab.core.expressions import call_formulas
from rotlab.core.state import P0
from rotlab.core.torques import _to_user, expression_inputs


@njit(cache=True)
def formula_values(fn, rows, k, component, t, states, axes, axes_q, moments, rates_only, out):
    """out[i] = formula ``component`` of event ``k`` at (t[i], states[i]) (principal frame);
    ``rows[k]`` holds the event's ``up`` direction as an expression load's row does.
    ``rates_only``: the formula reads only t and ω, so Λ, γ and L are not formed (0 in their places)."""
    for i in range(t.shape[0]):
        if rates_only:
            y = states[i]
            w0, w1, w2 = _to_user(axes, y[P0], y[P0 + 1], y[P0 + 2])
            x = (t[i], w0, w1, w2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        else:
            x = expression_inputs(t[i], states[i], rows, k, axes, axes_q, moments)
        out[i] = call_formulas(fn, k, component, x)


RISING, FALLING = 1, 2  # bits of an event's direction (both: 3)


@njit(cache=True)
def crossings(previous, g, direction, out):
    """The rows r where g crossed 0 from the row before (``previous`` before row 0) in
    ``direction`` (RISING: g_{r−1} < 0 ≤ g_r; FALLING: g_{r−1} > 0 ≥ g_r; both bits: either),
    written to ``out``; returns their count.  ``g`` is finite (``first_not_finite`` cuts it)."""
    count = 0
    before = previous
    for r in range(g.shape[0]):
        after = g[r]
        if ((direction & RISING) and before < 0.0 <= after) or ((direction & FALLING) and before > 0.0 >= after):
            out[count] = r
            count += 1
        before = after
    return count


@njit(cache=True)
def first_not_finite(g):
    """The first row of ``g`` that is not finite (its length when all are)."""
    for r in range(g.shape[0]):
        if not math.isfinite(g[r]):
            return r
    return g.shape[0]
