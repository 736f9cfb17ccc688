"""A Python function passed to ``rotlab.simulate(torque=...)`` as a load: compiled by numba,
typed before any step, and called by the kernels through one fixed C signature."""

from __future__ import annotations

import threading
import types as pytypes
from collections import OrderedDict
from typing import Any, Callable

import numpy as np

from rotlab.core.model import USER_BUFFER, UserTorque
from rotlab.core.quaternion import from_matrix
from rotlab.scene.load_kinds import frame_code


def _user_signature():
    from numba import types

    f = types.float64
    return types.void(f, types.CPointer(f))


USER_SIGNATURE = _user_signature()  # (t, [λ0..λ3, ω0..ω2, M (3,)]) → M written


def user_torque(fn: Callable, frame: str, axes: np.ndarray) -> UserTorque:
    """``fn(t, q, omega) -> M`` compiled by numba (a plain Python function is jitted, with bounds
    checks) and typed for (float, float64[4], float64[3]); ``InputError`` naming why when numba
    cannot compile it or M is not three real numbers (a tuple, a list or a 1-D array).

    The kernels receive it as a C callback (``numba.cfunc``) of one fixed signature (t, buffer)
    → None, called once per evaluation (the buffer: Λ and ω in, M out, ``USER_BUFFER``): its
    type is the same for every function, so the kernels stay compiled and cached on disk (a
    jitted function as a kernel argument would recompile them for each function and write its
    type into their cache index).  The callback never
    raises (a cfunc can only print and swallow an exception): when ``fn`` raises, returns other
    than 3 values, or a value that is not finite, it records a fault (``rotlab.core.faults``)
    and writes NaN, so the run stops and says why; it also honours Ctrl-C between calls.  The
    callback is kept for the next call with the same function (``_typed_callback``)."""
    from rotlab.errors import InputError

    if frame not in ("body", "space"):
        raise InputError("frame", f"must be \"body\" or \"space\", not {frame!r}")
    if not callable(fn):
        raise InputError("torque", f"must be a function fn(t, q, omega) -> (Mx, My, Mz), not {type(fn).__name__}")
    return UserTorque(_typed_callback(fn), frame_code(frame), np.ascontiguousarray(axes, dtype=float), from_matrix(axes))


_CALLBACKS: OrderedDict[Callable, tuple[tuple, Any]] = OrderedDict()  # fn → (its frozen inputs, callback)
_CALLBACKS_KEPT = 32  # the most recently used functions
_CALLBACKS_LOCK = threading.Lock()
_CONSTANT_MODULES = ("numpy", "math", "cmath", "numba")  # modules whose attributes a torque may read


def _typed_callback(fn: Callable) -> Any:
    """``fn`` typed and wrapped as a callback (``_callback``), compiled once per function and
    per value of what numba freezes into it (``_frozen_inputs``): calling ``rotlab.simulate``
    again with the same torque reuses the callback, and a changed global is compiled anew."""
    import numba

    from rotlab.errors import InputError

    frozen = _frozen_inputs(fn)
    with _CALLBACKS_LOCK:
        kept = _CALLBACKS.get(fn) if frozen is not None else None
        if kept is not None and kept[0] == frozen:
            _CALLBACKS.move_to_end(fn)
            return kept[1]
    name = getattr(fn, "__name__", "torque")
    args = (numba.types.float64, numba.types.float64[::1], numba.types.float64[::1])
    try:
        jitted = fn if isinstance(fn, numba.core.registry.CPUDispatcher) else numba.njit(boundscheck=True)(fn)
        jitted.compile(args)
        returned = jitted.overloads[args].signature.return_type
    except numba.core.errors.NumbaError as exc:
        raise InputError("torque", f"numba cannot compile {name}(t, q, omega): {_numba_reason(exc)}") from None
    except Exception as exc:  # noqa: BLE001 - numba's typing can raise anything the function's globals do
        raise InputError("torque", f"numba cannot compile {name}(t, q, omega): {type(exc).__name__}: {exc}"[:300]) from None
    problem = _return_problem(returned)
    if problem:
        raise InputError("torque", f"{name}(t, q, omega) must return 3 real numbers (Mx, My, Mz) as a tuple, list or array; it returns {problem}")
    callback = _callback(jitted)
    if frozen is not None and _frozen_inputs(fn) == frozen:  # (not when another thread changed a global meanwhile)
        with _CALLBACKS_LOCK:
            _CALLBACKS[fn] = (frozen, callback)
            _CALLBACKS.move_to_end(fn)
            while len(_CALLBACKS) > _CALLBACKS_KEPT:
                _CALLBACKS.popitem(last=False)
    return callback


class _Same:
    """A snapshot's part compared by identity (a code object, a module, a jitted or numpy function)."""

    __slots__ = ("obj",)

    def __init__(self, obj: Any) -> None:
        self.obj = obj

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Same) and other.obj is self.obj

    __hash__ = None  # type: ignore[assignment]


def _frozen_inputs(fn: Callable) -> tuple | None:
    """What numba freezes into a compiled ``fn``, as a comparable tuple: its code object, the
    values of the globals its code names (nested code included; for numpy, math, cmath and numba,
    the attributes it may read of them), of its closure's cells and of its defaults.  None when one
    of them has state that cannot be compared (a user's module or object, a plain function), and
    for a callable that is not a function: such a torque is compiled at every call.  A function
    the user jitted is its own key: numba froze its globals at its first compile."""
    import numba

    if isinstance(fn, numba.core.registry.CPUDispatcher):
        return ()
    if not isinstance(fn, pytypes.FunctionType):
        return None
    names: set[str] = set()
    codes = [fn.__code__]
    while codes:
        code = codes.pop()
        names.update(code.co_names)
        codes.extend(c for c in code.co_consts if isinstance(c, pytypes.CodeType))
    try:
        cells = tuple(cell.cell_contents for cell in fn.__closure__ or ())
    except ValueError:  # an empty cell
        return None
    named = sorted(names)
    bound = tuple(name for name in named if name in fn.__globals__)
    values = [fn.__globals__[name] for name in bound]
    attributes = [getattr(module, name) for module in values if isinstance(module, pytypes.ModuleType) and _constant(module)
                  for name in named if hasattr(module, name)]  # np.K = … after a compile is frozen too
    parts = [_frozen_value(v) for v in (*values, *cells, fn.__defaults__, fn.__kwdefaults__)]
    if any(part is None for part in parts):
        return None
    return (_Same(fn.__code__), bound, *parts, *(_frozen_value(a) or _Same(a) for a in attributes))


def _constant(obj: Any) -> bool:
    """Is ``obj`` a module of ``_CONSTANT_MODULES``, or defined in one?"""
    where = obj.__name__ if isinstance(obj, pytypes.ModuleType) else getattr(obj, "__module__", None)
    return isinstance(where, str) and where.split(".")[0] in _CONSTANT_MODULES


def _frozen_value(value: Any) -> tuple | None:
    """A comparable snapshot of a value numba freezes as a constant (None when it cannot be
    compared: see ``_frozen_inputs``).  Its type is part of it (1 and 1.0 compile differently),
    and a number is compared by its bits (-0.0 is not 0.0 to ``1/x`` or ``copysign``)."""
    import numba

    if value is None or isinstance(value, (bool, int, str, bytes)):
        return ("value", type(value), value)
    if isinstance(value, (float, complex, np.generic)):
        bits = np.asarray(value)
        return ("bits", type(value), bits.dtype, bits.tobytes())
    if isinstance(value, np.ndarray):
        return ("array", value.dtype, value.shape, value.flags.c_contiguous, value.flags.f_contiguous, value.tobytes())
    if isinstance(value, (tuple, list)):
        parts = [_frozen_value(v) for v in value]
        return None if any(p is None for p in parts) else (type(value), *parts)
    if isinstance(value, numba.core.registry.CPUDispatcher) or (isinstance(value, pytypes.ModuleType) or callable(value)) and _constant(value):
        return ("same", _Same(value))  # (an instance of their classes, such as a typed List, holds state: not cached)
    return None


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
    """The C callback of a typed Python torque (``user_torque``): M at (t, Λ, ω) written to its
    buffer (``USER_BUFFER``; q and omega are views of it, no copies), or NaN and a fault; the
    values are those ``rotlab.core.faults.record`` keeps (user's body frame)."""
    import numba

    from rotlab.core import faults

    @numba.cfunc(USER_SIGNATURE)
    def callback(t, buffer):  # pragma: no cover - runs compiled
        b = numba.carray(buffer, USER_BUFFER)
        q, omega, m = b[0:4], b[4:7], b[7:10]
        q0, q1, q2, q3, w0, w1, w2 = b[0], b[1], b[2], b[3], b[4], b[5], b[6]  # as called (fn may write into q, omega)
        m[:] = np.nan
        if faults.interrupt_requested():
            return
        try:
            value = jitted(t, q, omega)
        except Exception:  # noqa: BLE001 - numba catches what the function raised, without its type
            faults.record(faults.CALLABLE_RAISED, 0, 0, t, w0, w1, w2, q0, q1, q2, q3, 0.0)
            return
        if len(value) != 3:
            faults.record(faults.CALLABLE_SHAPE, 0, 0, t, w0, w1, w2, q0, q1, q2, q3, float(len(value)))
            return
        mx, my, mz = value
        m[0], m[1], m[2] = float(mx), float(my), float(mz)
        for k in range(3):
            if not np.isfinite(m[k]):
                faults.record(faults.CALLABLE_NOT_FINITE, 0, k, t, w0, w1, w2, q0, q1, q2, q3, 0.0)
                return

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
