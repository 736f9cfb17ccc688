"""Loads compiled to arrays for the kernels (principal body frame), and the scene's ``Model``:
the one value every kernel receives (``rotlab.core.torques`` reads its load fields).

Each load kind compiles itself (``rotlab.scene.load_kinds``) into one of the load groups: forces,
torque terms, tables, damping, formula loads (``Expressions``); a Python torque passed to
``rotlab.simulate`` is a group of its own (``rotlab.scene.user_torque``).  Columns are named in
``rotlab.core.torques`` (F_*, T_*, TB_*, EX_*).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np

from rotlab.config import models as cfg
from rotlab.core import opcodes
from rotlab.core.dynamics import euler_coefficients
from rotlab.core.model import Drives, Expressions, Model
from rotlab.core.quaternion import from_matrix, rotate_to_space_array
from rotlab.core.torques import (
    BODY, EX_COLUMNS, EX_OFF, EX_ON, EX_PROGRAMS, EX_RATE, F_COLUMNS, F_FORCE, F_POINT,
    T_AMP, T_COLUMNS, T_OFF, T_OFFSET, T_ON, T_W, TB_COLUMNS, TB_OFF, TB_ON,
)
from rotlab.scene.load_kinds import Compiling, drive_formula, kind_of
from rotlab.scene.programs import ProgramBuilder
from rotlab.scene.user_torque import UserTorque



class LoadArrays(NamedTuple):
    """Every load of a scene as arrays, empty groups included (see ``Model`` for the kernels)."""

    forces: np.ndarray  # (n, 6): [p (body, m), F (space, N)]
    terms: np.ndarray  # (n, 11): [frame, on, off, offset(3), amplitude(3), w, phase]
    tables: np.ndarray  # (n, 5): [frame, on, off, first row, stop row] into table_t / table_v
    table_t: np.ndarray  # (m,)
    table_v: np.ndarray  # (m, 3)
    damping: float  # k, N·m·s
    expressions: Expressions | None
    user: UserTorque | None = None
    formula_names: tuple[tuple[str, str, str], ...] = ()  # per expression row: what each component is, for failures
    user_function: Callable | None = None  # the Python function behind ``user``, for its failures
    drives: Drives | None = None  # driven rotors (``compile_loads``'s ``rotors``)


def build_model(loads: LoadArrays, moments: np.ndarray, like: Model | None = None, rotors: np.ndarray | None = None) -> Model:
    """The kernels' view of ``loads``: absent groups as None, so that a kernel specialises on the
    groups a scene has; with ``like``, the groups ``like`` has are present (empty where ``loads``
    has none) and the others None, so that the model has ``like``'s numba type (one load of a
    scene, evaluated by the specialisation compiled for the scene's model: the loads' torque,
    which has no rotors' term); ``rotors``: the gyrostat's h (principal frame), or None."""
    has = (lambda group, present: present) if like is None else (lambda group, present: getattr(like, group) is not None)
    has_tables = has("tables", len(loads.tables) > 0)
    expressions = loads.expressions
    if expressions is None and has("expressions", False):
        expressions = _no_expressions(moments)
    return Model(
        euler=euler_coefficients(moments),
        breaks=breakpoints(loads),
        forces=loads.forces if has("forces", len(loads.forces) > 0) else None,
        terms=loads.terms if has("terms", len(loads.terms) > 0) else None,
        tables=loads.tables if has_tables else None,
        table_t=loads.table_t if has_tables else None,
        table_v=loads.table_v if has_tables else None,
        damping=loads.damping if has("damping", loads.damping > 0.0) else None,
        expressions=expressions,
        user=loads.user,
        rotors=None if rotors is None else np.asarray(rotors, dtype=float),
        drives=None if like is not None else loads.drives,
    )


def _no_expressions(moments: np.ndarray) -> Expressions:
    """An ``Expressions`` with no rows (its programs are never called)."""
    eye = np.eye(3)
    return Expressions(np.zeros((0, EX_COLUMNS)), np.zeros((0, 3), dtype=np.int64), np.zeros(0), eye, from_matrix(eye),
                       np.asarray(moments, dtype=float), 1, 0, 0)


def compile_loads(body: cfg.Body, loads: Sequence[cfg.Load], axes: np.ndarray, moments: np.ndarray, user: UserTorque | None = None,
                  user_function: Callable | None = None, rotors: Sequence[cfg.Rotor] = ()) -> LoadArrays:
    """Turn a scenario's loads on ``body`` into arrays, each by its kind's declaration
    (``rotlab.scene.load_kinds``); body-frame vectors are rotated by Pᵀ = ``axes.T`` into the
    principal frame (space-frame vectors are unchanged).  The driven ones of ``rotors`` add their
    drives' formulas after the loads' (``Drives``)."""
    programs = ProgramBuilder()
    c = Compiling(body, axes, programs)
    for index, load in enumerate(loads):
        kind_of(load).compile(load, index, c, _component_names(index, load))
    offset = len(programs.rows)
    driven = [(k, rotor) for k, rotor in enumerate(rotors) if rotor.torque is not None]
    for k, rotor in driven:
        program, window = drive_formula(rotor)
        what = f"= {rotor.torque!r}" if isinstance(rotor.torque, str) else "(pd_control)"
        up = rotor.unit_up() if isinstance(rotor.torque, str) else np.array([0.0, 0.0, 1.0])
        programs.add(program, BODY, window, up=up, names=(f"rotors[{k}].torque {what}", "", ""))
    every = programs.build(axes, moments)
    expressions = every if every is None or not driven else (every._replace(rows=every.rows[:offset]) if offset else None)
    drives = None if not driven else Drives(every._replace(rows=every.rows[offset:]), offset, np.array(  # type: ignore[union-attr]
        [axes.T @ r.unit_axis() for _, r in driven]))
    return LoadArrays(
        forces=np.array(c.forces, dtype=float).reshape(-1, F_COLUMNS),
        terms=np.array(c.terms, dtype=float).reshape(-1, T_COLUMNS),
        tables=np.array(c.tables, dtype=float).reshape(-1, TB_COLUMNS),
        table_t=np.array(c.table_t, dtype=float),
        table_v=np.array(c.table_v, dtype=float).reshape(-1, 3),
        damping=float(c.damping),
        expressions=expressions,
        user=user,
        formula_names=tuple(programs.names),
        user_function=user_function,
        drives=drives,
    )


def _component_names(index: int, load: cfg.Load) -> tuple[str, str, str]:
    """What each component of a load compiled to a formula is, as a failure message names it:
    ``loads[0].torque[1] = "t**(-1)"`` for an expression, ``loads[2] (pd_control) torque x`` else."""
    texts = getattr(load, "torque", None) or getattr(load, "force", None)
    if isinstance(load, cfg.Expression) and texts is not None:
        key = "torque" if load.torque is not None else "force"
        return tuple(f"loads[{index}].{key}[{c}] = {texts[c]!r}" for c in range(3))  # type: ignore[return-value]
    quantity = "force" if isinstance(load, cfg.Force) else "torque"
    return tuple(f"loads[{index}] ({load.type}) {quantity} {axis}" for axis in "xyz")  # type: ignore[return-value]


def loads_key(loads: LoadArrays) -> tuple | None:
    """The loads as hashable values (arrays as bytes); None when a load is not plain numbers
    (a Python torque)."""
    key = tuple(x.tobytes() if isinstance(x, np.ndarray) else x for x in loads)
    try:
        hash(key)
    except TypeError:
        return None
    return key


def breakpoints(loads: LoadArrays) -> np.ndarray:
    """Sorted times where a load switches or kinks (window edges, table knots): an adaptive
    method ends its steps there instead of stepping over a short pulse."""
    times = [loads.terms[:, [T_ON, T_OFF]].ravel(), loads.tables[:, [TB_ON, TB_OFF]].ravel(), loads.table_t, _expression_windows(loads).ravel()]
    all_times = np.concatenate(times) if any(len(x) for x in times) else np.zeros(0)
    return np.unique(all_times[np.isfinite(all_times)])


def shortest_window(loads: LoadArrays) -> float:
    """The shortest time a windowed load or a table segment acts (inf when none)."""
    windows = _expression_windows(loads)
    spans = [loads.terms[:, T_OFF] - loads.terms[:, T_ON], loads.tables[:, TB_OFF] - loads.tables[:, TB_ON], windows[:, 1] - windows[:, 0]]
    if len(loads.table_t) > 1:
        knots = np.diff(loads.table_t)
        spans.append(knots[knots > 0])  # segments within tables (consecutive tables concatenate)
    values = np.concatenate(spans) if spans else np.zeros(0)
    return float(np.min(values)) if values.size else float("inf")


def _expression_windows(loads: LoadArrays) -> np.ndarray:
    """(n, 2) [on, off] of the expression loads."""
    if loads.expressions is None:
        return np.zeros((0, 2))
    return loads.expressions.rows[:, [EX_ON, EX_OFF]]


def has_switches(loads: LoadArrays) -> bool:
    """True when an expression load (or a rotor's drive) uses abs, sign, min or max (``pd_control`` included)
    on an argument that varies with the time or the state: a torque that jumps or kinks where no
    breakpoint marks it.  A fixed step runs across such a switch at low order, whatever its probe
    measured between switches.  ``abs(k)`` or ``max(k, 0.01)`` of constants never switches."""
    groups = [ex for ex in (loads.expressions, loads.drives.ex if loads.drives is not None else None) if ex is not None]
    return any(_switches(ex.code[int(start):int(end)])
               for ex in groups for row in ex.rows for start, end in row[EX_PROGRAMS:].reshape(-1, 2))


_SWITCHES = (opcodes.ABS, opcodes.SIGN, opcodes.MIN, opcodes.MAX)


def _switches(code: np.ndarray) -> bool:
    """Whether the postfix program ``code`` (rows opcode, argument, …) applies a switch to an
    argument that depends on an input (t, ω, Λ, γ, L): a stack of "varies" flags, CONST false,
    VAR true, an operation's result varying when an argument does."""
    varies: list[bool] = []
    for opcode in code[:, 0]:
        if opcode in (opcodes.CONST, opcodes.VAR):
            varies.append(opcode == opcodes.VAR)
            continue
        arguments = [varies.pop()] if opcode < opcodes.FIRST_BINARY else [varies.pop(), varies.pop()]
        if opcode in _SWITCHES and any(arguments):
            return True
        varies.append(any(arguments))
    return False


def formula_rows(loads: LoadArrays) -> int:
    """Rows of the formula loads' programs (operations and leaves, and the auxiliary series
    ``taylor`` forms for some operations): what a step's work on the formulas scales with
    (``rotlab.methods.cost``)."""
    programs = loads.expressions
    return 0 if programs is None else int(programs.code.shape[0] + programs.aux)


def active_forces(loads: LoadArrays) -> np.ndarray:
    """Rows of ``loads.forces`` that can exert a torque (non-zero arm and force)."""
    arms, forces = _points(loads.forces), _force_vectors(loads.forces)
    return loads.forces[(np.linalg.norm(arms, axis=1) > 0.0) & (np.linalg.norm(forces, axis=1) > 0.0)]


def has_nonconservative(loads: LoadArrays) -> bool:
    """True when some load does work that no potential accounts for."""
    terms_active = bool(np.any(loads.terms[:, T_OFFSET:T_AMP + 3] != 0.0))
    tables_active = bool(np.any(loads.table_v != 0.0))
    return (terms_active or tables_active or loads.damping > 0.0 or loads.expressions is not None or loads.user is not None
            or loads.drives is not None)  # a driven rotor's drive works on the body


def torque_scale(loads: LoadArrays) -> float:
    """A rough upper bound of |M| (N·m) at unit ω, for choosing time scales."""
    scale = float(np.sum(np.linalg.norm(_points(loads.forces), axis=1) * np.linalg.norm(_force_vectors(loads.forces), axis=1)))
    terms = loads.terms
    scale += float(np.sum(np.linalg.norm(terms[:, T_OFFSET:T_OFFSET + 3], axis=1) + np.linalg.norm(terms[:, T_AMP:T_AMP + 3], axis=1)))
    if loads.table_v.size:
        scale += float(np.max(np.linalg.norm(loads.table_v, axis=1)))
    return scale


def load_rates(loads: LoadArrays) -> np.ndarray:
    """The angular frequencies (rad/s) the loads vary at: torque terms' w, formula loads' orbit rates."""
    rates = [np.abs(loads.terms[:, T_W])]
    if loads.expressions is not None:
        rates.append(np.abs(loads.expressions.rows[:, EX_RATE]))
    return np.concatenate(rates)


def potential(loads: LoadArrays, unit_q: np.ndarray) -> np.ndarray:
    """V = −Σ F · (R p) of the constant space-frame forces (the only loads with a potential) at
    the orientations ``unit_q`` (..., 4), principal frame."""
    v = np.zeros(unit_q.shape[:-1])
    for row in loads.forces:
        arm = rotate_to_space_array(unit_q, np.broadcast_to(row[F_POINT:F_POINT + 3], unit_q.shape[:-1] + (3,)))
        v -= np.einsum("...j,j->...", arm, row[F_FORCE:F_FORCE + 3])  # (no BLAS: see rotlab.trajectory._rows_times)
    return v


def _points(forces: np.ndarray) -> np.ndarray:
    return forces[:, F_POINT:F_POINT + 3]


def _force_vectors(forces: np.ndarray) -> np.ndarray:
    return forces[:, F_FORCE:F_FORCE + 3]
