"""Load expressions (programs of ``rotlab.core.opcodes``) in the kernels.

Two ways to run a formula, each where it measured best (docs/benchmarks.md, "expression loads"):
* on numbers (rk4, rkmk4, dop853): generated source compiled to a numba ``cfunc`` of one fixed
  signature (``EXPRESSION_SIGNATURE``) — native speed; the kernels receive its address, an
  integer (the same type for every formula), so they stay compiled and cached on disk, and a
  new formula costs only its own small compilation (also cached on disk, keyed by a hash of its
  operations: its constants are an argument, so a new value of a gain costs none).  A stack
  interpreter over the code array would keep every kernel cached too, but dispatches every
  operation at every right-hand side, which makes even a simple load such as −k ω dominate the
  step; a jitted function as a kernel argument recompiles every kernel per formula and cannot be
  cached.
* in Taylor mode (taylor): interpreted, below — each coefficient costs a Cauchy product anyway.

``series_step`` runs a program in Taylor mode: each
instruction owns a row of a tape holding its Taylor coefficients, and coefficient k of every
row follows from coefficients ≤ k of its operands (w = f(u), series in τ = time − t):

    w = u ± v, c u:     w^[k] = u^[k] ± v^[k]
    w = u v:            w^[k] = Σ_{j=0..k} u^[j] v^[k−j]                          (Cauchy product)
    w = u / v:          w^[k] = (u^[k] − Σ_{j=1..k} v^[j] w^[k−j]) / v^[0]
    w = exp u:          w^[k] = (1/k) Σ_{j=1..k} j u^[j] w^[k−j]
    w = log u:          w^[k] = (u^[k] − (1/k) Σ_{j=1..k−1} j w^[j] u^[k−j]) / u^[0]
    s, c = sin u, cos u: s^[k] = (1/k) Σ j u^[j] c^[k−j],  c^[k] = −(1/k) Σ j u^[j] s^[k−j]
    w = tan u (tanh u): w^[k] = (1/k) Σ j u^[j] d^[k−j],  d = 1 ± w²  (+ for tan, − for tanh)
    w = √u:             w^[k] = (u^[k] − Σ_{j=1..k−1} w^[j] w^[k−j]) / (2 w^[0])
    w = u^a (a real):   w^[k] = Σ_{j=0..k−1} (a (k − j) − j) u^[k−j] w^[j] / (k u^[0])
    w = u^n (integer):  repeated Cauchy products (no division: u^[0] may be 0)
    w = atan2(y, x):    d = x² + y²,  k d^[0] w^[k] = Σ_{j=1..k} j (x^[k−j] y^[j] − y^[k−j] x^[j])
                                                   − Σ_{j=1..k−1} (k − j) d^[j] w^[k−j]
    abs, sign, min, max: the branch of the switching function s = u (abs, sign) or a − b (min,
    max) on the side of s^[0]; ``switch_limit`` ends a step where s changes sign, so that
    every step sees one smooth branch (the next one starts on the other side).
(Griewank & Walther, "Evaluating Derivatives", 2nd ed., §13.2, Table 13.2; Jorba & Zou 2005, §2.)
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from rotlab.core import opcodes as op
from rotlab.core.targets import gpu_overload, overload, work_vector

# numba sees the opcodes as compile-time constants
CONST, VAR, NEG, SIN, COS, TAN, EXP, LOG, SQRT, ABS, TANH, SIGN, POWI = (
    op.CONST, op.VAR, op.NEG, op.SIN, op.COS, op.TAN, op.EXP, op.LOG, op.SQRT, op.ABS, op.TANH, op.SIGN, op.POWI)
ADD, SUB, MUL, DIV, POW, ATAN2, MIN, MAX = op.ADD, op.SUB, op.MUL, op.DIV, op.POW, op.ATAN2, op.MIN, op.MAX
FIRST_BINARY = op.FIRST_BINARY


# The value of a program: ``rotlab.scene.formulas`` writes each scene's programs as the Python
# source of one numba ``cfunc`` of this signature, (load, component, c, out, x0 … x13) → value, with
# the helpers below for the operations that need a guard (``component`` = ``opcodes.ALL_COMPONENTS``: a
# load's three values written to ``out[0..2]``, ``call_load_formulas``); ``c`` points to the programs' constants
# (one slot per named constant: ``Expressions.consts``, ``rotlab.scene.formulas.Slots``), so
# programs that differ only in their constants (a sweep over a gain) share one compiled function.  Every scene's function has the
# same numba type, so the kernels that call it are compiled once and cached on disk; they call it
# through its address (``call_formulas``).


def _expression_signature():
    from numba import types

    f = types.float64
    return f(types.int64, types.int64, types.CPointer(f), types.CPointer(f), *([f] * op.N_INPUTS))


EXPRESSION_SIGNATURE = _expression_signature()


def _call(builder, addr, constants, load, component, out, values):
    """fn(load, component, consts, out, *inputs) for the cfunc at ``addr`` of EXPRESSION_SIGNATURE:
    a direct call through a C function pointer."""
    f64, i64 = ir.DoubleType(), ir.IntType(64)
    fnty = ir.FunctionType(f64, [i64, i64, f64.as_pointer(), f64.as_pointer()] + [f64] * op.N_INPUTS)
    return builder.call(builder.inttoptr(addr, fnty.as_pointer()), [load, component, builder.inttoptr(constants, f64.as_pointer()), out]
                        + [builder.extract_value(values, i) for i in range(op.N_INPUTS)])


@intrinsic
def _call_address(typingctx, address, consts, load, component, inputs):
    """fn(load, component, consts, NULL, *inputs) for the cfunc at ``address`` (an int64) of
    EXPRESSION_SIGNATURE, ``consts`` the address of its constants."""
    sig = types.float64(types.int64, types.int64, types.int64, types.int64, inputs)

    def codegen(context, builder, signature, args):
        addr, constants, load, component, values = args
        return _call(builder, addr, constants, load, component, ir.Constant(ir.DoubleType().as_pointer(), None), values)

    return sig, codegen


@intrinsic
def _call_address_3(typingctx, address, consts, load, inputs):
    """fn(load, opcodes.ALL_COMPONENTS, consts, out, *inputs) for the cfunc at ``address``: the load's
    three values, ``out`` three doubles on the caller's stack."""
    sig = types.UniTuple(types.float64, 3)(types.int64, types.int64, types.int64, inputs)

    def codegen(context, builder, signature, args):
        from numba.core import cgutils

        addr, constants, load, values = args
        out = cgutils.alloca_once(builder, ir.DoubleType(), size=3)
        _call(builder, addr, constants, load, ir.Constant(ir.IntType(64), op.ALL_COMPONENTS), out, values)
        three = [builder.load(builder.gep(out, [ir.Constant(ir.IntType(32), i)])) for i in range(3)]
        return context.make_tuple(builder, signature.return_type, three)

    return sig, codegen


@intrinsic
def _data_address(typingctx, array):
    def codegen(context, builder, signature, args):
        return builder.ptrtoint(context.make_array(signature.args[0])(context, builder, args[0]).data, ir.IntType(64))

    return types.int64(array), codegen


def constants_address(consts):
    """The address of the formulas' constants ``consts`` (``Expressions.consts``), an int64, as
    ``call_formulas`` takes them: an array passed to a compiled function costs a reference count
    (an atomic write) at each call, and the right-hand side calls ``expression_torque`` at every
    stage (the array: ~10 % of a formula load's step); an integer costs nothing.  The array must
    outlive the calls (the model holds it).  0 on a GPU, whose table holds the constants."""
    raise NotImplementedError("compiled code only")


@overload(constants_address, inline="always")
def _constants_address_cpu(consts):
    return lambda consts: _data_address(consts)


@gpu_overload(constants_address, inline="always")
def _constants_address_gpu(consts):
    return lambda consts: 0


def call_formulas(address, consts, load, component, inputs):
    """The value of the program of (``load``, ``component``) at ``inputs`` (a tuple of
    ``N_INPUTS`` floats), ``consts`` the address of its constants (``constants_address``).  On the
    CPU ``address`` is the scene's compiled programs (a cfunc of EXPRESSION_SIGNATURE,
    ``rotlab.scene.formulas``): the kernels see integers, the same types for every scene, and no
    Python object.  On a GPU it is the device address of the programs'
    ``rotlab.core.formula_table``, which ``run_program`` interprets, the constants in the table
    (the GPU cannot call the CPU's function)."""
    raise NotImplementedError("compiled code only")


@overload(call_formulas, inline="always")
def _call_formulas_cpu(address, consts, load, component, inputs):
    return lambda address, consts, load, component, inputs: _call_address(address, consts, load, component, inputs)


@gpu_overload(call_formulas, inline="always")
def _call_formulas_gpu(address, consts, load, component, inputs):
    from numba.cuda.extending import intrinsic as cuda_intrinsic

    @cuda_intrinsic
    def doubles_at(typingctx, address):  # the table: float64s from a device address
        from numba.cuda import types as cuda_types

        def codegen(context, builder, signature, args):
            return builder.inttoptr(args[0], ir.DoubleType().as_pointer())

        return cuda_types.CPointer(cuda_types.float64)(cuda_types.int64), codegen

    return lambda address, consts, load, component, inputs: run_program(doubles_at(address), load, component, inputs)


def call_load_formulas(address, consts, load, inputs):
    """(``call_formulas`` of the load's components 0, 1, 2) in one call: on the CPU the generated
    function computes the three together, so what they share (a magnetic field's cos(n t), its
    rotation) is computed once; on a GPU, three interpretations of the table."""
    raise NotImplementedError("compiled code only")


@overload(call_load_formulas, inline="always")
def _call_load_formulas_cpu(address, consts, load, inputs):
    return lambda address, consts, load, inputs: _call_address_3(address, consts, load, inputs)


@gpu_overload(call_load_formulas, inline="always")
def _call_load_formulas_gpu(address, consts, load, inputs):
    def three(address, consts, load, inputs):
        return (call_formulas(address, consts, load, 0, inputs), call_formulas(address, consts, load, 1, inputs),
                call_formulas(address, consts, load, 2, inputs))

    return three


# ``rotlab.core.formula_table``'s layout, which ``run_program`` reads
STACK = 40  # values on ``run_program``'s stack: above the deepest program the parser lets through
TABLE_OPS = 2  # the table's entries for one instruction: opcode, value


@njit(cache=True)
def run_program(table, load, component, inputs):
    """The value of a program of ``rotlab.core.formula_table`` (``table``: anything indexed by
    position, an array or a device pointer) at ``inputs``: the operations of the generated function
    (``rotlab.scene.formulas.source_of``), the same helpers, in the same order."""
    at = 1 + 2 * (int(table[0]) * load + component)
    first, count = int(table[at]), int(table[at + 1])
    stack = work_vector(STACK)
    top = -1
    for i in range(first, first + TABLE_OPS * count, TABLE_OPS):
        opcode, value = int(table[i]), table[i + 1]
        if opcode == CONST:
            top += 1
            stack[top] = value
        elif opcode == VAR:
            top += 1
            stack[top] = inputs[int(value)]
        elif opcode < FIRST_BINARY:
            stack[top] = _unary(opcode, int(value), stack[top])
        else:
            top -= 1
            stack[top] = _binary(opcode, stack[top], stack[top + 1])
    return stack[0]


@njit(cache=True, inline="always")
def _unary(opcode, n, a):
    if opcode == NEG:
        return -a
    if opcode == SIN:
        return math.sin(a)
    if opcode == COS:
        return math.cos(a)
    if opcode == TAN:
        return math.tan(a)
    if opcode == EXP:
        return math.exp(a)
    if opcode == LOG:
        return safe_log(a)
    if opcode == SQRT:
        return safe_sqrt(a)
    if opcode == ABS:
        return abs(a)
    if opcode == TANH:
        return math.tanh(a)
    if opcode == SIGN:
        return sign(a)
    return powi(a, n)  # POWI


@njit(cache=True, inline="always")
def _binary(opcode, a, b):
    if opcode == ADD:
        return a + b
    if opcode == SUB:
        return a - b
    if opcode == MUL:
        return a * b
    if opcode == DIV:
        return safe_div(a, b)
    if opcode == POW:
        return safe_pow(a, b)
    if opcode == ATAN2:
        return math.atan2(a, b)
    if opcode == MIN:
        return min(a, b)
    return max(a, b)  # MAX


@njit(cache=True)
def sign(x):
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@njit(cache=True)
def powi(x, n):
    """x^n for an integer n (|n| ≤ 16) by repeated squaring."""
    m = abs(n)
    r = 1.0
    b = x
    while m > 0:
        if m & 1:
            r *= b
        b *= b
        m >>= 1
    return safe_div(1.0, r) if n < 0 else r


@njit(cache=True)
def safe_log(x):
    return math.log(x) if x > 0.0 else (-np.inf if x == 0.0 else np.nan)


@njit(cache=True)
def safe_sqrt(x):
    return math.sqrt(x) if x >= 0.0 else np.nan


@njit(cache=True)
def safe_div(x, b):
    """x / b with IEEE results for b = 0 (numba would raise)."""
    if b != 0.0:
        return x / b
    return np.nan if x == 0.0 or x != x else math.copysign(np.inf, x) * math.copysign(1.0, b)


@njit(cache=True)
def safe_pow(x, b):
    """x^b for a real constant b: NaN for x < 0 (no complex results)."""
    if x > 0.0:
        return x**b
    if x == 0.0:
        return 0.0 if b > 0.0 else np.inf
    return np.nan


AUX = 2  # code column: the instruction's first auxiliary tape row, counted from code.shape[0]


def aux_rows(opcode: int, arg: int) -> int:
    """Auxiliary tape rows an instruction needs in Taylor mode (module docstring)."""
    if opcode in (SIN, COS, TAN, TANH, ATAN2, ABS, SIGN, MIN, MAX):
        return 1
    if opcode == POWI:
        return max(abs(arg) - 1, 0)
    return 0


SWITCH_A, SWITCH_B, SIDE, FORCED = 0, 1, 2, 3  # columns of a switching instruction's auxiliary row
IMMEDIATE = 1e-8  # a switch within this fraction of the step: the step starts on the other side


@njit(cache=True, inline="always")
def _switch(tape, x, a, b, s0):
    """Record the switching function s = row a − row b (b < 0: row a alone) and its side at τ = 0
    (the side ``switch_limit`` forced for this step, if any): −1, +1, or 0 when s⁽⁰⁾ = 0 exactly
    (sign gives 0 there; ``switch_limit`` forces the side s leaves 0 to, if it does in the step).
    A forced side holds for every formation of the step's series (two switches at t each force
    one, in turn), until ``release_forced`` at the next step."""
    tape[x, SWITCH_A] = a
    tape[x, SWITCH_B] = b
    tape[x, SIDE] = tape[x, FORCED] if tape[x, FORCED] != 0.0 else sign(s0)


@njit(cache=True)
def release_forced(tape):
    """Forget the sides ``switch_limit`` forced (at the start of a step; the column is a series
    coefficient in other rows, formed again before any use)."""
    if tape.shape[1] > FORCED:
        for x in range(tape.shape[0]):
            tape[x, FORCED] = 0.0


@njit(cache=True)
def switch_limit(code, start, stop, tape, order, h):
    """The step ≤ h that ends just past the first sign change in (0, h] of a switching function
    of ``code[start:stop]`` (abs, sign, min, max), from its series: 32 samples, then bisection.
    A change within ``IMMEDIATE`` · h means the step starts at the switch (the previous one
    ended there, the series' truncation put s⁽⁰⁾ on the old side): the other side is forced and
    −1 returned — the series must be formed again.  From s⁽⁰⁾ = 0 exactly (side 0) the change is
    s leaving 0, and the side forced is the one it leaves to; an s that stays 0 keeps side 0."""
    base = code.shape[0]
    full = h
    again = False
    for i in range(start, stop):
        o = code[i, 0]
        if o != ABS and o != SIGN and o != MIN and o != MAX:
            continue
        x = base + code[i, AUX]
        a, b, side = int(tape[x, SWITCH_A]), int(tape[x, SWITCH_B]), tape[x, SIDE]
        lo, hi = 0.0, -1.0
        for j in range(1, 33):
            tau = h * j / 32.0
            if _switched(side, _switch_value(tape, a, b, order, tau)):
                hi = tau
                break
            lo = tau
        if hi < 0.0:
            continue
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if mid <= lo or mid >= hi:
                break
            if _switched(side, _switch_value(tape, a, b, order, mid)):
                hi = mid
            else:
                lo = mid
        if hi < IMMEDIATE * full:
            tape[x, FORCED] = -side if side != 0.0 else sign(_switch_value(tape, a, b, order, hi))  # ≠ 0 there
            again = True
        else:
            h = min(h, hi)
    return -1.0 if again else h


@njit(cache=True, inline="always")
def _switched(side, value):
    """Whether s = ``value`` is past a switch from ``side``: on the other side, or off 0 for side 0."""
    return side * value < 0.0 if side != 0.0 else value != 0.0


@njit(cache=True, inline="always")
def _switch_value(tape, a, b, order, tau):
    s = 0.0
    for k in range(order, -1, -1):
        s = s * tau + (tape[a, k] - (tape[b, k] if b >= 0 else 0.0))
    return s


@njit(cache=True, inline="always")
def _over(a, b):
    """a / b, NaN where b = 0: a series through a singular point (√, log, a power or a division
    at 0) is not defined, and the run stops there as non-finite instead of raising."""
    return a / b if b != 0.0 else np.nan


@njit(cache=True, inline="always")
def _cauchy(tape, a, b, k):
    """Σ_{j=0..k} a^[j] b^[k−j] of tape rows a and b."""
    s = 0.0
    for j in range(k + 1):
        s += tape[a, j] * tape[b, k - j]
    return s


@njit(cache=True)
def _unary_series(o, arg, i, a, x, tape, k):
    """Coefficient k of row i = o(row a); x is the instruction's first auxiliary row."""
    u0 = tape[a, 0]
    if o == NEG:
        tape[i, k] = -tape[a, k]
    elif o == SIN or o == COS:
        s, c = (i, x) if o == SIN else (x, i)
        if k == 0:
            tape[s, 0] = math.sin(u0)
            tape[c, 0] = math.cos(u0)
        else:
            ss = sc = 0.0
            for j in range(1, k + 1):
                ss += j * tape[a, j] * tape[c, k - j]
                sc += j * tape[a, j] * tape[s, k - j]
            tape[s, k] = ss / k
            tape[c, k] = -sc / k
    elif o == TAN or o == TANH:
        sg = 1.0 if o == TAN else -1.0
        if k == 0:
            w0 = math.tan(u0) if o == TAN else math.tanh(u0)
            tape[i, 0] = w0
            tape[x, 0] = 1.0 + sg * w0 * w0
        else:
            acc = 0.0
            for j in range(1, k + 1):
                acc += j * tape[a, j] * tape[x, k - j]
            tape[i, k] = acc / k
            tape[x, k] = sg * _cauchy(tape, i, i, k)
    elif o == EXP:
        if k == 0:
            tape[i, 0] = math.exp(u0)
        else:
            acc = 0.0
            for j in range(1, k + 1):
                acc += j * tape[a, j] * tape[i, k - j]
            tape[i, k] = acc / k
    elif o == LOG:
        if k == 0:
            tape[i, 0] = math.log(u0) if u0 > 0.0 else (-np.inf if u0 == 0.0 else np.nan)
        else:
            acc = 0.0
            for j in range(1, k):
                acc += j * tape[i, j] * tape[a, k - j]
            tape[i, k] = _over(tape[a, k] - acc / k, u0)
    elif o == SQRT:
        if k == 0:
            tape[i, 0] = math.sqrt(u0) if u0 >= 0.0 else np.nan
        else:
            acc = 0.0
            for j in range(1, k):
                acc += tape[i, j] * tape[i, k - j]
            tape[i, k] = _over(tape[a, k] - acc, 2.0 * tape[i, 0])
    elif o == ABS or o == SIGN:
        if k == 0:
            _switch(tape, x, a, -1, u0)
        if o == ABS:
            tape[i, k] = tape[x, SIDE] * tape[a, k]
        else:  # the branch's sign, not sign(u⁽⁰⁾): a step that starts at the switch has u⁽⁰⁾ on the old side
            tape[i, k] = tape[x, SIDE] if k == 0 else 0.0
    elif o == POWI:
        m = abs(arg)
        if m == 0:
            tape[i, k] = 1.0 if k == 0 else 0.0
            return
        last = a  # row of u^j, j = 1 .. m (u^j for j ≥ 2 in rows x + j − 2)
        for j in range(2, m + 1):
            row = x + j - 2
            tape[row, k] = _cauchy(tape, last, a, k)
            last = row
        if arg > 0:
            tape[i, k] = tape[last, k]
        else:  # 1 / u^m
            acc = 1.0 if k == 0 else 0.0
            for j in range(1, k + 1):
                acc -= tape[last, j] * tape[i, k - j]
            tape[i, k] = _over(acc, tape[last, 0])


@njit(cache=True)
def _binary_series(o, i, a, b, x, tape, k):
    """Coefficient k of row i = o(row a, row b); x is the instruction's first auxiliary row."""
    if o == ADD:
        tape[i, k] = tape[a, k] + tape[b, k]
    elif o == SUB:
        tape[i, k] = tape[a, k] - tape[b, k]
    elif o == MUL:
        tape[i, k] = _cauchy(tape, a, b, k)
    elif o == DIV:
        acc = tape[a, k]
        for j in range(1, k + 1):
            acc -= tape[b, j] * tape[i, k - j]
        tape[i, k] = _over(acc, tape[b, 0])
    elif o == POW:  # the exponent is a constant: row b holds it at order 0
        e = tape[b, 0]
        u0 = tape[a, 0]
        if k == 0:
            tape[i, 0] = u0**e if u0 > 0.0 else (0.0 if u0 == 0.0 and e > 0.0 else np.nan)
        else:
            acc = 0.0
            for j in range(k):
                acc += (e * (k - j) - j) * tape[a, k - j] * tape[i, j]
            tape[i, k] = _over(acc, k * u0)
    elif o == ATAN2:  # a = y, b = x, aux d = x² + y²
        if k == 0:
            tape[i, 0] = math.atan2(tape[a, 0], tape[b, 0])
            tape[x, 0] = tape[a, 0] ** 2 + tape[b, 0] ** 2
        else:
            acc = 0.0
            for j in range(1, k + 1):
                acc += j * (tape[b, k - j] * tape[a, j] - tape[a, k - j] * tape[b, j])
            for j in range(1, k):
                acc -= (k - j) * tape[x, j] * tape[i, k - j]
            tape[i, k] = _over(acc, k * tape[x, 0])
            tape[x, k] = _cauchy(tape, a, a, k) + _cauchy(tape, b, b, k)
    elif o == MIN or o == MAX:  # s = a − b: min is b where s > 0, max is a there
        if k == 0:
            _switch(tape, x, a, b, tape[a, 0] - tape[b, 0])
        upper = tape[x, SIDE] > 0.0
        tape[i, k] = tape[a, k] if upper == (o == MAX) else tape[b, k]


@njit(cache=True)
def series_step(code, consts, start, stop, k, inputs, tape, stack):
    """Coefficient k of every instruction of ``code[start:stop]`` into ``tape`` (row = code
    index, auxiliary rows after ``code.shape[0]``), given coefficients < k already there and
    ``inputs`` = the inputs' coefficient k.  Returns the row of the program's value."""
    base = code.shape[0]
    sp = 0
    for i in range(start, stop):
        o = code[i, 0]
        arg = code[i, 1]
        if o == CONST:
            tape[i, k] = consts[arg] if k == 0 else 0.0
        elif o == VAR:
            tape[i, k] = inputs[arg]
        elif o < FIRST_BINARY:
            _unary_series(o, arg, i, stack[sp - 1], base + code[i, AUX], tape, k)
            sp -= 1
        else:
            _binary_series(o, i, stack[sp - 2], stack[sp - 1], base + code[i, AUX], tape, k)
            sp -= 2
        stack[sp] = i
        sp += 1
    return stack[0]
