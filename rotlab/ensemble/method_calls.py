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
        (``local_solver`` makes it from Python; ``LocalScratch`` is the scratch it writes)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import types

from rotlab.core.dynamics import store_vector
from rotlab.core.targets import overload


class LocalScratch(NamedTuple):
    """What ``local_state`` writes (``rotlab.ensemble.event_scan.EventScratch`` has these too)."""

    y: np.ndarray  # (state,) the local solution
    grid: np.ndarray  # (2,)
    out: np.ndarray  # (2, state)
    counters: np.ndarray  # (3,) int64 (discarded)


def local_scratch(width: int) -> LocalScratch:
    return LocalScratch(np.zeros(width), np.zeros(2), np.zeros((2, width)), np.zeros(3, dtype=np.int64))


def local_solver(method, scene, t: np.ndarray, settings) -> tuple:
    """``local_state``'s ``solver`` for ``method`` (a ``Method`` with an ensemble kernel) on
    ``scene`` over the sample times ``t`` at ``settings``: the run's own steps, as its kernels
    take them (``Method.local_solution``)."""
    if method.name == "dop853":
        return settings.rtol, settings.atol, settings.max_steps
    if method.name == "taylor":
        return (method.checked_order(settings), settings.rtol, settings.atol, settings.max_steps, *method.constants(scene))
    order = method.order(settings)
    substeps, _ = method.sampling(scene, t, settings, order)
    return substeps, method.kernel_args(scene, order)


_ENTRIES: dict[tuple, object] = {}  # (function, method, argument types) → its compiled entry


def call_for_method(function, method: str, *args: object) -> object:
    """``function(method, *args)`` for a compiled ``function`` whose first argument names a method
    (``literally``).  A call through the dispatcher with a string types the whole function before
    ``literally`` asks for the literal's specialization (~0.1 s a call): after the first call of
    each (function, method, argument types), the specialization's compiled entry is called
    directly (numba's ``Dispatcher.overloads``; the dispatcher again should it be missing)."""
    key = _key(function, method, args)
    if key in _ENTRIES:
        return _ENTRIES[key](method, *args)
    result = function(method, *args)
    _remember(key)
    return result


def entry_for_method(function, method: str, *args: object) -> Callable[..., object]:
    """What ``call_for_method`` calls for arguments of the types of ``args``, to be called as
    ``entry(method, *args)`` again and again (typing the arguments costs ~0.5 ms for a model).
    When new, it is compiled by running ``function(method, *args)`` once: give arguments that do
    no work."""
    key = _key(function, method, args)
    if key not in _ENTRIES:
        function(method, *args)
        _remember(key)
    return _ENTRIES.get(key, function)


def _key(function, method: str, args: tuple) -> tuple:
    from numba import typeof

    return function, method, tuple(typeof(a) for a in args)


def _remember(key: tuple) -> None:
    function, method, arg_types = key
    for signature, compiled in getattr(function, "overloads", {}).items():
        if signature[0] == types.literal(method) and tuple(signature[1:]) == arg_types:
            _ENTRIES[key] = compiled.entry_point


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
