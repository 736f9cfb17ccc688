"""Load formulas written by users: parsed by a whitelist over Python's ``ast`` (user text is never
evaluated) into a postfix program of ``rotlab.core.opcodes``.

Grammar: numbers; ``t``; ``omega[i]``, ``gamma[i]``, ``L[i]`` (i = 0, 1, 2) and ``q[i]``
(i = 0..3); named constants (and ``pi``); ``+ - * / **`` (the exponent a constant, |p| ≤ 64);
unary ``-`` and ``+``; the functions sin cos tan exp log sqrt abs tanh sign (one argument) and
atan2 min max (two).  Anything else — other names, attributes, calls, subscripts, lambdas,
comprehensions, comparisons, strings — is refused with the column of the fault.
"""

from __future__ import annotations

import ast
import math
import threading
from functools import lru_cache

from rotlab.core import opcodes as op

MAX_LENGTH = 2000  # characters in one formula
MAX_NODES = 400  # syntax-tree nodes in one formula
MAX_DEPTH = 32  # nesting of operations (and the evaluation stack)
MAX_EXPONENT = 64.0
VARIABLES = tuple(op.INPUTS)
BUILTIN_CONSTANTS = {"pi": math.pi}
ALLOWED = ("numbers, t, omega[i], q[i], gamma[i], L[i], named constants, + - * / **, "
           + " ".join([*op.UNARY_FUNCTIONS, *op.BINARY_FUNCTIONS]))

Program = list[tuple[int, float]]  # (opcode, argument): CONST carries its value, VAR its input index


class Named(float):
    """A CONST's value that a named constant gave (``name``): read from the generated function's
    argument, one slot per name of a load (``rotlab.scene.formulas.Slots``), so that a sweep over
    it shares the function."""

    name: str

    def __new__(cls, value: float, name: str) -> Named:
        named = super().__new__(cls, value)
        named.name = name
        return named

    def __reduce__(self) -> tuple:  # (pickled and copied with its name)
        return Named, (float(self), self.name)


class Written(float):
    """A CONST's value written in the formula's text (a number, or ``pi``), not a named constant:
    part of the formula's operations, so the generated source writes it as a literal (the
    compiler folds 2·x into x + x, and a sweep cannot vary it); a named constant is read from the
    function's argument (``rotlab.scene.formulas.operations``)."""


class FormulaError(ValueError):
    """A formula that is not in the grammar; ``column`` is 1-based (0: the formula as a whole)."""

    def __init__(self, column: int, message: str) -> None:
        super().__init__(f"column {column}: {message}" if column else message)
        self.column = column
        self.message = message


def check_constant_name(name: str) -> None:
    """A constant must be an identifier that shadows no variable, function or built-in constant."""
    if not name.isidentifier() or name.startswith("_"):
        raise FormulaError(0, f"constant name '{name}' must be a plain identifier (letters, digits, _; not starting with _)")
    if name in op.INPUTS or name in op.UNARY_FUNCTIONS or name in op.BINARY_FUNCTIONS or name in BUILTIN_CONSTANTS:
        raise FormulaError(0, f"constant name '{name}' is taken by a variable, function or built-in constant: rename it")


# one ast.parse at a time: CPython 3.11's conversion of the parsed tree to Python objects keeps its
# recursion depth per interpreter, and two threads parsing at once (a Dask worker's two tasks of
# sweep cases) raise "SystemError: AST constructor recursion depth mismatch"
_PARSING = threading.Lock()


def parse_formula(text: str, constants: dict[str, float], max_nodes: int = MAX_NODES) -> tuple[Program, int]:
    """(postfix program, stack depth it needs) of ``text``; ``FormulaError`` when it is not
    in the grammar (module docstring).  ``max_nodes``: a load kind's own formulas (not a
    user's) may be longer."""
    if not isinstance(text, str):
        raise FormulaError(0, f"must be a formula in a string, found {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise FormulaError(0, f"formula of {len(text):,} characters is beyond the limit of {MAX_LENGTH}: split it with named constants")
    if not text.strip():
        raise FormulaError(0, "empty formula: write a formula (0 for a value that is always zero)")
    code: Program = []
    depth = _emit(_tree(text.strip(), max_nodes).body, {**BUILTIN_CONSTANTS, **constants}, code, 0)
    return code, depth


@lru_cache(maxsize=1024)
def _tree(text: str, max_nodes: int) -> ast.Expression:
    """The syntax tree of ``text`` within ``max_nodes`` nodes, parsed once per text (the cases of a
    sweep over a constant parse the same formulas; ``_emit`` only reads the tree)."""
    try:
        with _PARSING:
            tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise FormulaError(exc.offset or 0, f"syntax error ({exc.msg})") from None
    except (RecursionError, MemoryError, ValueError):
        raise FormulaError(0, f"formula nested too deeply (limit {MAX_DEPTH} levels)") from None
    if sum(1 for _ in ast.walk(tree)) > max_nodes:
        raise FormulaError(0, f"formula has more than {max_nodes} terms: split it with named constants")
    return tree


def _col(node: ast.AST) -> int:
    return getattr(node, "col_offset", -1) + 1


def _number(node: ast.AST, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise FormulaError(_col(node), f"{value!r} is not a number")
    try:
        x = float(value)
    except OverflowError:
        raise FormulaError(_col(node), "number too large for a double") from None
    if not math.isfinite(x):
        raise FormulaError(_col(node), "number is not finite")
    return x


def _emit(node: ast.AST, constants: dict[str, float], code: Program, level: int) -> int:
    """Append the postfix code of ``node``; return the stack depth it needs."""
    if level > MAX_DEPTH:
        raise FormulaError(_col(node), f"formula nested too deeply (limit {MAX_DEPTH} levels)")
    if isinstance(node, ast.Constant):
        code.append((op.CONST, Written(_number(node, node.value))))
        return 1
    if isinstance(node, ast.Name):
        if node.id in constants:
            value = constants[node.id]
            code.append((op.CONST, Written(value) if node.id in BUILTIN_CONSTANTS else Named(value, node.id)))
            return 1
        if node.id == "t":
            code.append((op.VAR, float(op.INPUTS["t"][0])))
            return 1
        if node.id in op.INPUTS:
            size = op.INPUTS[node.id][1]
            raise FormulaError(_col(node), f"'{node.id}' is a vector: use one component, {node.id}[0] … {node.id}[{size - 1}]")
        raise FormulaError(_col(node), f"unknown name '{node.id}': use {ALLOWED}, or define it under constants")
    if isinstance(node, ast.Subscript):
        return _component(node, code)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        depth = _emit(node.operand, constants, code, level + 1)
        if isinstance(node.op, ast.USub):
            code.append((op.NEG, 0.0))
        return depth
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
        return _power(node, constants, code, level)
    binary = {ast.Add: op.ADD, ast.Sub: op.SUB, ast.Mult: op.MUL, ast.Div: op.DIV}
    if isinstance(node, ast.BinOp) and type(node.op) in binary:
        left = _emit(node.left, constants, code, level + 1)
        right = _emit(node.right, constants, code, level + 1)
        code.append((binary[type(node.op)], 0.0))
        return max(left, right + 1)
    if isinstance(node, ast.Call):
        return _call(node, constants, code, level)
    what = type(node).__name__
    raise FormulaError(_col(node), f"{what} is not allowed in a formula (allowed: {ALLOWED})")


def _component(node: ast.Subscript, code: Program) -> int:
    if not (isinstance(node.value, ast.Name) and node.value.id in op.INPUTS and node.value.id != "t"):
        raise FormulaError(_col(node), "only omega[i], q[i], gamma[i] and L[i] may be indexed")
    first, size = op.INPUTS[node.value.id]
    index = node.slice
    if not (isinstance(index, ast.Constant) and type(index.value) is int and 0 <= index.value < size):
        raise FormulaError(_col(index), f"{node.value.id}[…] takes an index 0 … {size - 1} written as a number")
    code.append((op.VAR, float(first + index.value)))
    return 1


def _exponent(node: ast.AST, constants: dict[str, float]) -> float:
    """A constant exponent: a number or a named constant, optionally negated."""
    sign = 1.0
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        sign = -1.0 if isinstance(node.op, ast.USub) else 1.0
        node = node.operand
    if isinstance(node, ast.Constant):
        value = _number(node, node.value)
    elif isinstance(node, ast.Name) and node.id in constants:
        value = constants[node.id]
    else:
        raise FormulaError(_col(node), "the exponent of ** must be a number or a named constant")
    if abs(value) > MAX_EXPONENT:
        raise FormulaError(_col(node), f"exponent {sign * value:g} is beyond ±{MAX_EXPONENT:g}")
    return sign * value


def _power(node: ast.BinOp, constants: dict[str, float], code: Program, level: int) -> int:
    exponent = _exponent(node.right, constants)
    depth = _emit(node.left, constants, code, level + 1)
    if exponent == int(exponent) and abs(exponent) <= op.MAX_INTEGER_POWER:
        code.append((op.POWI, exponent))
        return depth
    code.append((op.CONST, exponent))
    code.append((op.POW, 0.0))
    return max(depth, 2)


def _call(node: ast.Call, constants: dict[str, float], code: Program, level: int) -> int:
    name = node.func.id if isinstance(node.func, ast.Name) else None
    if name is None or (name not in op.UNARY_FUNCTIONS and name not in op.BINARY_FUNCTIONS):
        shown = name if name is not None else type(node.func).__name__
        raise FormulaError(_col(node), f"'{shown}' is not a function of formulas (allowed: {ALLOWED})")
    if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
        raise FormulaError(_col(node), f"{name}() takes plain positional arguments")
    arity = 1 if name in op.UNARY_FUNCTIONS else 2
    if len(node.args) != arity:
        raise FormulaError(_col(node), f"{name}() takes {arity} argument{'s' if arity > 1 else ''}, found {len(node.args)}")
    depth = 0
    for k, arg in enumerate(node.args):
        depth = max(depth, k + _emit(arg, constants, code, level + 1))
    code.append(((op.UNARY_FUNCTIONS if arity == 1 else op.BINARY_FUNCTIONS)[name], 0.0))
    return depth
