"""Formula programs as one float64 array, for ``rotlab.core.expressions.run_program`` (a GPU's way
to evaluate them: it cannot call the CPU's compiled function, ``rotlab.scene.formulas``, which is
made from the same programs).

Layout: table[0] = W, the programs per load (the widest load's count: a load's three components,
an event's ``when`` and ``record`` formulas); for load k and component c, table[1 + 2 (W k + c)]
its first entry and table[2 + 2 (W k + c)] its instruction count; then each instruction as
(opcode, value): a CONST's constant itself, another's integer argument (an exact float)."""

from __future__ import annotations

import numpy as np

from rotlab.core.model import Expressions, Model
from rotlab.core.opcodes import CONST, Program
from rotlab.core.torques import EX_PROGRAMS

LOAD_COMPONENTS = 3  # programs an expression row indexes (a load's three components; a drive's one)


def formula_table(loads: list[list[Program]]) -> np.ndarray:
    """The programs of each load, in the generated function's load order (module docstring)."""
    width = max((len(programs) for programs in loads), default=1)
    index = np.zeros(1 + 2 * width * len(loads))
    index[0] = width
    ops: list[float] = []
    for k, programs in enumerate(loads):
        for c, program in enumerate(programs):
            index[1 + 2 * (width * k + c)] = index.shape[0] + len(ops)
            index[2 + 2 * (width * k + c)] = len(program)
            for opcode, arg in program:
                ops += [float(opcode), float(arg)]
    return np.concatenate([index, np.array(ops, dtype=np.float64)])


def expression_programs(ex: Expressions) -> list[list[Program]]:
    """The programs of each row of ``ex`` (``rotlab.scene.programs.ProgramBuilder``'s encoding read back:
    a row's component c is ``code[first:end]``, its CONST arguments indexes of ``consts``)."""
    loads = []
    for row in ex.rows:
        programs = []
        for c in range(LOAD_COMPONENTS):
            first, end = int(row[EX_PROGRAMS + 2 * c]), int(row[EX_PROGRAMS + 2 * c + 1])
            programs.append([(int(opcode), float(ex.consts[arg]) if opcode == CONST else float(arg)) for opcode, arg, _ in ex.code[first:end]])
        loads.append(programs)
    return loads


def model_formula_table(model: Model) -> tuple[np.ndarray, int] | None:
    """The table of a model's formulas — its loads', then its driven rotors' (the generated
    function's load order: ``Drives.offset``) — and the deepest one's stack; None without formulas."""
    programs = [ex for ex in (model.expressions, model.drives.ex if model.drives is not None else None) if ex is not None]
    if not programs:
        return None
    return formula_table([p for ex in programs for p in expression_programs(ex)]), max(ex.depth for ex in programs)
