"""Instruction set of compiled load expressions (plain Python: the parser in
``rotlab.config.expressions`` and the compiled interpreters in ``rotlab.core.expressions``
both read it).

A program is a postfix sequence of (opcode, argument) rows evaluated on a stack:
CONST pushes constant[arg], VAR pushes input[arg]; a unary op replaces the top, a binary op
pops b then replaces a by op(a, b).  POWI raises the top to the integer power arg (|arg| ≤
``MAX_INTEGER_POWER``).
"""

Program = list[tuple[int, float]]  # (opcode, argument) rows; a CONST's argument the constant itself

CONST, VAR = 0, 1
NEG, SIN, COS, TAN, EXP, LOG, SQRT, ABS, TANH, SIGN, POWI = 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12
ADD, SUB, MUL, DIV, POW, ATAN2, MIN, MAX = 20, 21, 22, 23, 24, 25, 26, 27

LIBRARY = frozenset({SIN, COS, TAN, EXP, LOG, TANH, POW, ATAN2})  # a library function's value: its last bit may differ between libms (a GPU's libdevice)

UNARY_FUNCTIONS = {"sin": SIN, "cos": COS, "tan": TAN, "exp": EXP, "log": LOG, "sqrt": SQRT, "abs": ABS, "tanh": TANH, "sign": SIGN}
BINARY_FUNCTIONS = {"atan2": ATAN2, "min": MIN, "max": MAX}
FIRST_BINARY = ADD
MAX_INTEGER_POWER = 16

# inputs of a program, user body frame: t, ω (3), Λ (4), γ (3), L (3)
INPUTS = {"t": (0, 1), "omega": (1, 3), "q": (4, 4), "gamma": (8, 3), "L": (11, 3)}
N_INPUTS = 14
ALL_COMPONENTS = -1  # a component argument of the generated function: a load's three values at once (rotlab.scene.formulas)
