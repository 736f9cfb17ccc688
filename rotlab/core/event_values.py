"""Event formulas on states (``rotlab.events``): the value of one compiled formula at each row
of a state array, from the inputs an expression load sees (``torques.expression_inputs``: t, ω,
Λ, γ, L in the user's body frame) through the same generated function (``call_formulas``)."""

from __future__ import annotations

import math

from numba import njit

from rotlab.core.expressions import call_formulas, constants_address
from rotlab.core.state import P0
from rotlab.core.torques import _to_user, expression_inputs


@njit(cache=True, inline="always")
def formula_value(fn, consts, rows, k, component, t, y, axes, axes_q, moments, rates_only):
    """Formula ``component`` of event ``k`` at (t, y) (principal frame); ``rows[k]`` holds the
    event's ``up`` direction as an expression load's row does.  ``rates_only``: the formula
    reads only t and ω, so Λ, γ and L are not formed (0 in their places)."""
    if rates_only:
        w0, w1, w2 = _to_user(axes, y[P0], y[P0 + 1], y[P0 + 2])
        x = (t, w0, w1, w2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    else:
        x = expression_inputs(t, y, rows, k, axes, axes_q, moments)
    return call_formulas(fn, constants_address(consts), k, component, x)


@njit(cache=True)
def formula_values(fn, consts, rows, k, component, t, states, axes, axes_q, moments, rates_only, out):
    """out[i] = ``formula_value`` at (t[i], states[i])."""
    for i in range(t.shape[0]):
        out[i] = formula_value(fn, consts, rows, k, component, t[i], states[i], axes, axes_q, moments, rates_only)


RISING, FALLING = 1, 2  # bits of an event's direction (both: 3)


@njit(cache=True, inline="always")
def crosses(before, after, direction):
    """g crossed 0 from ``before`` to ``after`` in ``direction`` (RISING: before < 0 ≤ after;
    FALLING: before > 0 ≥ after; both bits: either)."""
    return ((direction & RISING) != 0 and before < 0.0 <= after) or ((direction & FALLING) != 0 and before > 0.0 >= after)


@njit(cache=True)
def crossings(previous, g, direction, out):
    """The rows r where g crossed 0 from the row before (``previous`` before row 0) in
    ``direction`` (``crosses``), written to ``out``; returns their count.  ``g`` is finite (``first_not_finite`` cuts it)."""
    count = 0
    before = previous
    for r in range(g.shape[0]):
        after = g[r]
        if crosses(before, after, direction):
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
