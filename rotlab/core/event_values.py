"""Event formulas on states (``rotlab.events``): the value of one compiled formula at each row
of a state array, from the inputs an expression load sees (``torques.expression_inputs``: t, ω,
Λ, γ, L in the user's body frame) through the same generated function (``call_formulas``)."""

from __future__ import annotations

from numba import njit

from rotlab.core.expressions import call_formulas
from rotlab.core.torques import expression_inputs


@njit(cache=True)
def formula_values(fn, rows, k, component, t, states, axes, axes_q, moments, out):
    """out[i] = formula ``component`` of event ``k`` at (t[i], states[i]) (principal frame);
    ``rows[k]`` holds the event's ``up`` direction as an expression load's row does."""
    for i in range(t.shape[0]):
        x = expression_inputs(t[i], states[i], rows, k, axes, axes_q, moments)
        out[i] = call_formulas(fn, k, component, x)
