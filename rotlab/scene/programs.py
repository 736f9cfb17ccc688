"""Formula loads compiled: each load's programs parsed from its text (``rotlab.config.expressions``)
into one row of ``Expressions`` (columns ``rotlab.core.torques.EX_*``), their code and constants
concatenated, and the scene's generated function (``rotlab.scene.formulas``) made from them.
Imports no configuration model (pydantic): ``benchmarks/bench_gpu.py`` builds a formula load with it."""

from __future__ import annotations

import numpy as np

from rotlab.config import expressions as formulas
from rotlab.core import opcodes
from rotlab.core.expressions import aux_rows
from rotlab.core.model import Expressions
from rotlab.core.quaternion import from_matrix
from rotlab.core.torques import EX_COLUMNS, EX_FORCE, EX_FRAME, EX_OFF, EX_ON, EX_POINT, EX_PROGRAMS, EX_RATE, EX_UP, EX_UP2
from rotlab.scene import formulas as generated

UNNAMED = ("formula x", "formula y", "formula z")  # what a failure calls a formula built without names


class ProgramBuilder:
    """Expression loads being compiled: rows, concatenated code and constants."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.code: list[tuple[int, int, int]] = []
        self.aux = 0
        self.slots = generated.Slots()  # the constants as the generated function reads them (one slot per named constant)
        self.depth = 1
        self.programs: list[list[formulas.Program]] = []
        self.names: list[tuple[str, str, str]] = []

    def add(self, programs: list[tuple[formulas.Program, int]], frame: float, window: tuple[float, float],
            point: np.ndarray | None = None, up: np.ndarray = np.array([0.0, 0.0, 1.0]), up2: np.ndarray = np.zeros(3),
            rate: float = 0.0, names: tuple[str, str, str] = UNNAMED) -> None:
        """One expression load; ``names`` says what each component is (failure messages)."""
        row = np.zeros(EX_COLUMNS)
        row[EX_FRAME], row[EX_ON], row[EX_OFF] = frame, window[0], window[1]
        if point is not None:
            row[EX_FORCE] = 1.0
            row[EX_POINT:EX_POINT + 3] = point
        row[EX_UP:EX_UP + 3], row[EX_UP2:EX_UP2 + 3], row[EX_RATE] = up, up2, rate
        for k, (program, depth) in enumerate(programs):
            row[EX_PROGRAMS + 2 * k] = len(self.code)
            for opcode, arg in program:
                if opcode == opcodes.CONST:
                    self.code.append((opcode, self.slots.slot(len(self.programs), arg), 0))
                else:
                    self.code.append((opcode, int(arg), self.aux))
                    self.aux += aux_rows(opcode, int(arg))
            row[EX_PROGRAMS + 2 * k + 1] = len(self.code)
            self.depth = max(self.depth, depth)
        self.rows.append(row)
        self.programs.append([program for program, _ in programs])
        self.names.append(names)

    def formulas(self, texts: list[str], constants: dict[str, float], frame: float, window: tuple[float, float],
                 max_nodes: int = formulas.MAX_NODES, **kw) -> None:
        self.add([formulas.parse_formula(text, constants, max_nodes) for text in texts], frame, window, **kw)

    def build(self, axes: np.ndarray, moments: np.ndarray) -> Expressions | None:
        if not self.rows:
            return None
        return Expressions(np.array(self.rows), np.array(self.code, dtype=np.int64).reshape(-1, 3),
                           np.array(self.slots.values, dtype=float), np.ascontiguousarray(axes, dtype=float),
                           from_matrix(axes), np.asarray(moments, dtype=float), self.depth, self.aux,
                           generated.compiled(self.programs).address)
