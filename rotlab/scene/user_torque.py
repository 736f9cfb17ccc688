"""A Python function passed to ``rotlab.simulate(torque=...)`` as a load: compiled by numba,
typed before any step, and called by the kernels through one fixed C signature."""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import numpy as np

from rotlab.core.quaternion import from_matrix
from rotlab.scene.load_kinds import frame_code


def _user_signature():
    from numba import types

    f = types.float64
    return f(f, f, f, f, f, f, f, f, types.int64)


USER_SIGNATURE = _user_signature()  # (t, λ0..λ3, ω0..ω2, component) → M_component


class UserTorque(NamedTuple):
    """A Python function compiled by numba, fn(t, q, omega) → (Mx, My, Mz): q = Λ (4,) and omega
    (3,) in the user's body frame, M in ``frame`` (BODY: the user's body axes, SPACE)."""

    fn: Any  # numba cfunc of USER_SIGNATURE
    frame: float
    axes: np.ndarray  # (3, 3) principal axes in the user's body frame
    axes_q: np.ndarray  # (4,) Λ of axes


def user_torque(fn: Callable, frame: str, axes: np.ndarray) -> UserTorque:
    """``fn(t, q, omega) -> M`` compiled by numba (a plain Python function is jitted, with bounds
    checks) and typed for (float, float64[4], float64[3]); ``InputError`` naming why when numba
    cannot compile it or M is not three real numbers (a tuple, a list or a 1-D array).

    The kernels receive it as a C callback (``numba.cfunc``) of one fixed signature
    (t, Λ, ω, component) → M_component: its type is the same for every function, so the kernels
    stay compiled and cached on disk (a jitted function as a kernel argument would recompile
    them for each function and write its type into their cache index).  The callback never
    raises (a cfunc can only print and swallow an exception): when ``fn`` raises, returns other
    than 3 values, or a value that is not finite, it records a fault (``rotlab.core.faults``)
    and returns NaN, so the run stops and says why; it also honours Ctrl-C between calls."""
    import numba

    from rotlab.errors import InputError

    if frame not in ("body", "space"):
        raise InputError("frame", f"must be \"body\" or \"space\", not {frame!r}")
    if not callable(fn):
        raise InputError("torque", f"must be a function fn(t, q, omega) -> (Mx, My, Mz), not {type(fn).__name__}")
    name = getattr(fn, "__name__", "torque")
    jitted = fn if isinstance(fn, numba.core.registry.CPUDispatcher) else numba.njit(boundscheck=True)(fn)
    args = (numba.types.float64, numba.types.float64[::1], numba.types.float64[::1])
    try:
        jitted.compile(args)
        returned = jitted.overloads[args].signature.return_type
    except numba.core.errors.NumbaError as exc:
        raise InputError("torque", f"numba cannot compile {name}(t, q, omega): {_numba_reason(exc)}") from None
    except Exception as exc:  # noqa: BLE001 - numba's typing can raise anything the function's globals do
        raise InputError("torque", f"numba cannot compile {name}(t, q, omega): {type(exc).__name__}: {exc}"[:300]) from None
    problem = _return_problem(returned)
    if problem:
        raise InputError("torque", f"{name}(t, q, omega) must return 3 real numbers (Mx, My, Mz) as a tuple, list or array; it returns {problem}")
    return UserTorque(_callback(jitted), frame_code(frame), np.ascontiguousarray(axes, dtype=float), from_matrix(axes))


def _return_problem(returned) -> str | None:
    """Why numba's type of a Python torque's result is not three real numbers (None when it is:
    a tuple of 3 integers or floats, or a 1-D array or list of them, whose length is checked
    at each call)."""
    from numba import types

    def real(t) -> bool:
        return isinstance(t, (types.Integer, types.Float)) and not isinstance(t, types.Boolean)

    if isinstance(returned, types.BaseTuple):
        if len(returned) != 3:
            return f"{len(returned)} values"
        bad = [str(t) for t in returned if not real(t)]
        return f"values of type {', '.join(bad)}" if bad else None
    if isinstance(returned, types.Array) and returned.ndim == 1 or isinstance(returned, types.List):
        return None if real(returned.dtype) else f"an array of {returned.dtype}"
    return f"{returned}"


def _callback(jitted: Any) -> Any:
    """The C callback of a typed Python torque (``user_torque``): M_k at (t, Λ, ω), or NaN and a
    fault; the values are those ``rotlab.core.faults.record`` keeps (user's body frame)."""
    import numba

    from rotlab.core import faults

    @numba.cfunc(USER_SIGNATURE)
    def callback(t, q0, q1, q2, q3, w0, w1, w2, k):  # pragma: no cover - runs compiled
        if faults.interrupt_requested():
            return np.nan
        try:
            value = jitted(t, np.array([q0, q1, q2, q3]), np.array([w0, w1, w2]))
        except Exception:  # noqa: BLE001 - numba catches what the function raised, without its type
            faults.record(faults.CALLABLE_RAISED, 0, k, t, w0, w1, w2, q0, q1, q2, q3, 0.0)
            return np.nan
        if len(value) != 3:
            faults.record(faults.CALLABLE_SHAPE, 0, k, t, w0, w1, w2, q0, q1, q2, q3, float(len(value)))
            return np.nan
        mx, my, mz = value
        m = float(mx) if k == 0 else (float(my) if k == 1 else float(mz))
        if not np.isfinite(m):
            faults.record(faults.CALLABLE_NOT_FINITE, 0, k, t, w0, w1, w2, q0, q1, q2, q3, 0.0)
        return m

    return callback


def _numba_reason(exc: Exception) -> str:
    """The line of a numba error that says why (ANSI colours removed)."""
    import re

    lines = [re.sub(r"\x1b\[[0-9;]*m", "", line).strip() for line in str(exc).splitlines()]
    lines = [line for line in lines if line]
    keys = ("Untyped global name", "No implementation", "Unknown attribute", "Use of unsupported", "Cannot", "Invalid use", "non-precise type")
    why = next((line for line in lines if any(k in line for k in keys)), None)
    why = why or next((line for line in lines if re.match(r"[A-Za-z]+Error: ", line)), lines[0] if lines else "")
    return why[:300]
