"""A scene's formula programs as one float64 array, for ``rotlab.core.expressions.run_program``
(a GPU's way to evaluate them: it cannot call the CPU's compiled function, ``rotlab.scene.formulas``)."""

from __future__ import annotations

import numpy as np

from rotlab.core.expressions import COMPONENTS, CONST
from rotlab.core.torques import EX_PROGRAMS


def formula_table(rows: np.ndarray, code: np.ndarray, consts: np.ndarray) -> np.ndarray:
    """The programs of ``rows`` (expression rows, every load of the scene in the order of the
    generated function's load index: ``rotlab.scene.loads.ProgramBuilder``) as one float64 array
    for ``run_program``: for load k and component c, table[2 (COMPONENTS k + c)] its first entry
    and table[2 (COMPONENTS k + c) + 1] its instruction count; then each instruction as (opcode,
    value): a CONST's constant itself, another's integer argument (an exact float)."""
    index = np.zeros(2 * COMPONENTS * rows.shape[0])
    ops: list[float] = []
    for k in range(rows.shape[0]):
        for c in range(COMPONENTS):
            first, end = int(rows[k, EX_PROGRAMS + 2 * c]), int(rows[k, EX_PROGRAMS + 2 * c + 1])
            index[2 * (COMPONENTS * k + c)] = index.shape[0] + len(ops)
            index[2 * (COMPONENTS * k + c) + 1] = end - first
            for opcode, arg, _ in code[first:end]:
                ops += [float(opcode), float(consts[arg]) if opcode == CONST else float(arg)]
    return np.concatenate([index, np.array(ops, dtype=np.float64)])
