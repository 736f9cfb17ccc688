"""A load evaluation that went wrong inside compiled code, recorded for the driver to report.

Compiled code cannot raise through a kernel: a numba ``cfunc`` that raises prints "Exception
ignored" and returns 0, and the run goes on with a wrong torque.  So a compiled load that fails
-- a formula whose value is not finite although its inputs are, a Python torque that raises,
returns the wrong number of values or a value that is not finite -- writes what happened into
the fault record and returns NaN.  The kernel then stops as for any non-finite state, and the
driver (``rotlab.methods.stepping.run_chunks``) takes the record to say which load failed, when
and why (``rotlab.scene.scene.Scene.explain_fault``).

The record is one process-wide float64 buffer that compiled code reaches through a linker
symbol (llvmlite's ``add_symbol``), not through an address baked into the code, so the functions
that write it stay cacheable on disk.  Its layout (the state as the load saw it, user's body frame):

    [kind, load, component, t, ω₀, ω₁, ω₂, λ₀, λ₁, λ₂, λ₃, detail]

A later fault overwrites an earlier one: the last fault before a kernel stops is its cause (a
rejected trial step of an adaptive method may leave one behind, which a run that succeeds never
reads).  Writes are not synchronised between threads; the record only words a failure.

``interrupt_requested`` lets a slow Python torque honour Ctrl-C: Python's signal handler runs
only between bytecodes, never inside a kernel, so the callback asks the interpreter
(``PyErr_CheckSignals``, which needs the GIL: kernels that call Python torques hold it) and,
when a handler raised, clears that exception, trips SIGINT again (``PyErr_SetInterrupt``) and
returns NaN: the kernel stops, and the KeyboardInterrupt is raised at the first bytecode after it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from llvmlite import binding as llvm
from llvmlite import ir
from numba import carray, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

NONE, FORMULA_NOT_FINITE, CALLABLE_NOT_FINITE, CALLABLE_RAISED, CALLABLE_SHAPE, INTERRUPTED = 0, 1, 2, 3, 4, 5
KIND, LOAD, COMPONENT, TIME, OMEGA, QUATERNION, DETAIL = 0, 1, 2, 3, 4, 7, 11
RECORD_SIZE = 12
_SYMBOL = "rotlab_fault_record"

RECORD = np.zeros(RECORD_SIZE)  # the buffer compiled code writes (module docstring)
llvm.add_symbol(_SYMBOL, RECORD.ctypes.data)


@dataclass(frozen=True)
class Fault:
    """What a compiled load reported: ``kind`` (the constants above), the expression load's
    index and component (formulas), the time and the state it saw (user's body frame), and a
    detail (the number of values a Python torque returned, for CALLABLE_SHAPE)."""

    kind: int
    load: int
    component: int
    t: float
    omega: tuple[float, float, float]
    quaternion: tuple[float, float, float, float]
    detail: float


def clear() -> None:
    """Forget any recorded fault (before a kernel call whose failure is to be explained)."""
    RECORD[:] = 0.0


def take() -> Fault | None:
    """The recorded fault, if any, and clear the record."""
    if RECORD[KIND] == NONE:
        return None
    r = RECORD.copy()
    clear()
    return Fault(int(r[KIND]), int(r[LOAD]), int(r[COMPONENT]), float(r[TIME]), tuple(r[OMEGA:OMEGA + 3]),
                 tuple(r[QUATERNION:QUATERNION + 4]), float(r[DETAIL]))


@intrinsic
def _record_pointer(typingctx):
    """float64* to the fault record, resolved by name when the code is linked."""
    sig = types.CPointer(types.float64)()

    def codegen(context, builder, signature, args):
        record = builder.module.globals.get(_SYMBOL)
        if record is None:
            record = ir.GlobalVariable(builder.module, ir.ArrayType(ir.DoubleType(), RECORD_SIZE), name=_SYMBOL)
            record.linkage = "external"
        return builder.bitcast(record, ir.DoubleType().as_pointer())

    return sig, codegen


@njit(cache=True, inline="always")
def all_finite8(t, w0, w1, w2, q0, q1, q2, q3):
    return math.isfinite(t + w0 + w1 + w2 + q0 + q1 + q2 + q3)


@njit(cache=True)
def record(kind, load, component, t, w0, w1, w2, q0, q1, q2, q3, detail):
    """Write a fault (module docstring) when the inputs t, ω, Λ are finite: a load that fails on
    a state that is already not finite is not the cause."""
    if not all_finite8(t, w0, w1, w2, q0, q1, q2, q3):
        return
    r = carray(_record_pointer(), RECORD_SIZE)
    r[KIND], r[LOAD], r[COMPONENT], r[TIME] = kind, load, component, t
    r[OMEGA], r[OMEGA + 1], r[OMEGA + 2] = w0, w1, w2
    r[QUATERNION], r[QUATERNION + 1], r[QUATERNION + 2], r[QUATERNION + 3] = q0, q1, q2, q3
    r[DETAIL] = detail


@njit(cache=True, inline="always")
def checked_formula(value, load, component, t, w0, w1, w2, q0, q1, q2, q3):
    """``value`` of an expression load's formula; recorded as a fault when it is not finite
    (``record``: when its inputs t, ω, Λ, user's body frame, are)."""
    if not math.isfinite(value):
        record(FORMULA_NOT_FINITE, load, component, t, w0, w1, w2, q0, q1, q2, q3, 0.0)
    return value


def _python_api(name: str, result: ir.Type):
    @intrinsic
    def call(typingctx):
        sig = (types.int32 if isinstance(result, ir.IntType) else types.void)()

        def codegen(context, builder, signature, args):
            fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(result, []), name)
            value = builder.call(fn, [])
            return value if isinstance(result, ir.IntType) else context.get_dummy_value()

        return sig, codegen

    return call


_check_signals = _python_api("PyErr_CheckSignals", ir.IntType(32))
_clear_error = _python_api("PyErr_Clear", ir.VoidType())
_set_interrupt = _python_api("PyErr_SetInterrupt", ir.VoidType())


@njit(cache=True)
def interrupt_requested():
    """True when a stop signal's Python handler raised (Ctrl-C, the executable's SIGTERM): the
    exception is cleared, SIGINT tripped again for the interpreter to raise after the kernel
    returns, and an INTERRUPTED fault recorded (module docstring).  Needs the GIL."""
    if _check_signals() == 0:
        return False
    _clear_error()
    _set_interrupt()
    r = carray(_record_pointer(), RECORD_SIZE)
    r[KIND] = INTERRUPTED
    return True
