"""What a kernel receives of a scene, as one value: the ``Model`` (Euler coefficients, load
breakpoints, the load groups as arrays, each None when the scene has none), its formula
groups and a Python torque.  Built by ``rotlab.scene.loads.build_model``; read by
``rotlab.core.torques`` alone.  Plain NamedTuples of arrays: importing them needs numpy only
(``benchmarks/bench_gpu.py`` builds a model by hand on a machine without rotlab's other
dependencies)."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

USER_BUFFER = 10  # a Python torque's call buffer: Λ (4) and ω (3) in, M (3) out (``rotlab.scene.user_torque``)


class Expressions(NamedTuple):
    """Expression loads: one row each (columns ``rotlab.core.torques.EX_*``), their programs
    (``code`` rows (opcode, argument), CONST arguments index ``consts``) and the user's frame."""

    rows: np.ndarray  # (n, EX_COLUMNS)
    code: np.ndarray  # (m, 3) int64: opcode, argument, first auxiliary Taylor row
    consts: np.ndarray  # (c,)
    axes: np.ndarray  # (3, 3) principal axes in the user's body frame (r_U = axes r_P)
    axes_q: np.ndarray  # (4,) Λ of axes
    moments: np.ndarray  # (3,) principal moments
    depth: int  # the deepest program's stack
    aux: int  # auxiliary rows of the Taylor-mode tape (``rotlab.core.expressions.aux_rows``)
    fn: int  # address of the compiled programs (``rotlab.scene.formulas``): fn(load, component, consts, out, inputs…)


class Drives(NamedTuple):
    """A gyrostat's driven rotors: each one's drive torque u (N·m) as a formula — rows of the
    scene's programs after the loads' (component 0), sharing their code and compiled function —
    and its unit axis (principal frame).  Rotor j's momentum J Ω is the state's column
    ``STATE_SIZE + j``, and d(J Ω)/dt = u."""

    ex: Expressions  # one row per driven rotor
    offset: int  # rotor j's formula is the programs' load ``offset + j``
    axes: np.ndarray  # (n, 3) unit axes, principal frame


class UserTorque(NamedTuple):
    """A Python torque (``rotlab.scene.user_torque``): fn(t, q, omega) → (Mx, My, Mz) compiled by
    numba, q = Λ (4,) and omega (3,) in the user's body frame, M in ``frame`` (BODY: the user's
    body axes, SPACE).  Declared here, with the model, so that loading a kernel's cache index
    (which holds this type) imports numpy alone."""

    fn: Any  # numba cfunc of ``rotlab.scene.user_torque.USER_SIGNATURE``
    frame: float
    axes: np.ndarray  # (3, 3) principal axes in the user's body frame
    axes_q: np.ndarray  # (4,) Λ of axes


class Model(NamedTuple):
    """What a kernel needs of a scene, as one value: Euler coefficients, load breakpoints and
    the load groups, each None when the scene has none (it then compiles to nothing)."""

    euler: np.ndarray  # (6,) ``rotlab.core.dynamics.euler_coefficients``
    breaks: np.ndarray  # sorted load breakpoints (may be empty)
    forces: np.ndarray | None
    terms: np.ndarray | None
    tables: np.ndarray | None
    table_t: np.ndarray | None
    table_v: np.ndarray | None
    damping: float | None
    expressions: Expressions | None
    user: UserTorque | None
    rotors: np.ndarray | None = None  # (3,) the constant rotors' momentum h (principal frame): the gyrostatic torque h × ω
    drives: Drives | None = None  # driven rotors: their momenta are state columns 8, 9, … (``Drives``)
