"""A method's compiled calls inside the ensemble kernels, the method named by a literal string
(``numba.literally`` in the CPU's kernels; a GPU kernel's name, ``gpu._scanner``): a kernel passed
as an argument would make every cached function it reaches keyed on a Python object, entries a
later process cannot use (they pile up in the disk cache, and once their objects are gone numba
fails to save it again: ``ReferenceError``).

    advance_of(method, y, times, rows, i, substeps, budget, model, extra)
        a fixed-step method's kernel (``rotlab.methods.fixed_step``), called with ``*extra``
    local_state(method, solver, model, y0, t0, t1, scratch)
        scratch.y ← the method's local solution Φ(y0, t0, t1) (``Method.local_solution``: the
        run's own steps from the state y0 at t0), ``solver`` its settings:
        fixed-step (substeps, extra); dop853 (rtol, atol, max_steps);
        taylor (order, rtol, atol, max_steps, c0, T, lever_force, flags)
"""

from __future__ import annotations

from numba import types

from rotlab.core.dynamics import store_vector
from rotlab.core.targets import overload


def advance_of(method, y, times, rows, i, substeps, budget, model, extra):
    """The kernel of the fixed-step method named ``method`` (a literal string), called with ``*extra``."""
    raise NotImplementedError("compiled code only")


@overload(advance_of)
def _advance_of(method, y, times, rows, i, substeps, budget, model, extra):
    if not isinstance(method, types.StringLiteral):
        return None
    from rotlab.methods.registry import get_method

    kernel = get_method(method.literal_value).kernel

    def call(method, y, times, rows, i, substeps, budget, model, extra):
        return kernel(y, times, rows, i, substeps, budget, model, *extra)

    return call


def local_state(method, solver, model, y0, t0, t1, scratch):
    """scratch.y ← Φ(y0, t0, t1) of the method named ``method`` (a literal string; module docstring)."""
    raise NotImplementedError("compiled code only")


@overload(local_state)
def _local_state(method, solver, model, y0, t0, t1, scratch):
    if not isinstance(method, types.StringLiteral):
        return None
    name = method.literal_value
    if name == "dop853":
        from rotlab.core.dop853 import dop853_local  # (SciPy's coefficients: imported when a kernel compiles)

        def dop853(method, solver, model, y0, t0, t1, scratch):
            store_vector(scratch.y, y0)
            rtol, atol, max_steps = solver
            dop853_local(scratch.y, t0, t1, scratch.grid, scratch.out, rtol, atol, max_steps, model, scratch.counters)

        return dop853
    if name == "taylor":
        from rotlab.core.taylor import taylor_local

        def taylor(method, solver, model, y0, t0, t1, scratch):
            store_vector(scratch.y, y0)
            order, rtol, atol, max_steps, c0, T, lever_force, flags = solver
            taylor_local(scratch.y, t0, t1, scratch.grid, scratch.out, order, rtol, atol, max_steps, model, c0, T, lever_force, flags,
                         scratch.counters)

        return taylor
    from rotlab.methods.registry import get_method

    return _fixed_step_local(get_method(name).kernel)


def _fixed_step_local(advance):
    """``local_state`` of the fixed-step kernel ``advance``: the run's substeps over [t0, t1]
    (``FixedStep.local_solution``)."""
    def fixed_step(method, solver, model, y0, t0, t1, scratch):
        store_vector(scratch.y, y0)
        scratch.grid[0], scratch.grid[1] = t0, t1
        substeps, extra = solver
        advance(scratch.y, scratch.grid, scratch.out, 1, substeps, substeps, model, *extra)

    return fixed_step
