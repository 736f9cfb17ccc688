"""Loads compiled to arrays for the kernels (principal body frame), and the scene's ``Model``:
the one value every kernel receives (``rotlab.core.torques`` reads its load fields).

Torque on the body, body components (R = R(Λ) body → space):

* constant space-frame force F at body point p:  M = p × (Rᵀ F)          (conservative,
  potential V = −F · (R p); gravity is F = m g at p = r_c)
* torque terms: M(t) = offset + amplitude · sin(w t + phase) inside [on, off), in the body frame
  or, for space-frame terms, M = Rᵀ M(t)                                    (work W)
* tables: piecewise-linear M(t) through (t_k, M_k), zero outside [t_0, t_n) ∩ [on, off)  (work W)
* damping: M = −k ω                                                         (work W)
* expressions: components are programs (``rotlab.config.expressions``) of t, ω, Λ, γ, L in the
  user's body frame; a torque, or a force at a body point; body or space frame   (work W).
  ``pd_control``, ``gravity_gradient``, ``quadratic_drag`` and windowed space-frame forces
  compile to expressions.

Work of the non-conservative loads: Ẇ = M_nc · ω, so that T + V − W is invariant.

Adding a load kind: its pydantic model (``rotlab.config.models``), its compilation here (to
an existing group, an expression formula, or a new group), and — for a new group only — its
torque in ``rotlab.core.torques`` (and its Taylor series there, if ``taylor`` supports it).
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import numpy as np

from rotlab.config import expressions as formulas
from rotlab.scene import formulas as generated
from rotlab.config import models as cfg
from rotlab.core import opcodes
from rotlab.core.dynamics import euler_coefficients
from rotlab.core.expressions import aux_rows
from rotlab.core.torques import EX_COLUMNS, EX_FORCE, EX_FRAME, EX_OFF, EX_ON, EX_POINT, EX_PROGRAMS, EX_RATE, EX_UP, EX_UP2

BODY, SPACE = 0.0, 1.0
UNNAMED = ("formula x", "formula y", "formula z")  # what a failure calls a formula built without names


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
    fn: int  # address of the compiled programs (``rotlab.scene.formulas``): fn(load, component, inputs…)


def _user_signature():
    from numba import types

    f = types.float64
    return f(f, f, f, f, f, f, f, f, types.int64)


USER_SIGNATURE = _user_signature()  # (t, λ0..λ3, ω0..ω2, component) → M_component


class UserTorque(NamedTuple):
    """A Python function compiled by numba, fn(t, q, omega) → (Mx, My, Mz): q = Λ (4,) and omega
    (3,) in the user's body frame, M in ``frame`` (BODY: the user's body axes, SPACE)."""

    fn: Any  # numba cfunc of USER_SIGNATURE
    frame: float
    axes: np.ndarray  # (3, 3) principal axes in the user's body frame
    axes_q: np.ndarray  # (4,) Λ of axes


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


def build_model(loads: LoadArrays, moments: np.ndarray) -> Model:
    """The kernels' view of ``loads``: absent groups as None."""
    has_tables = len(loads.tables) > 0
    return Model(
        euler=euler_coefficients(moments),
        breaks=breakpoints(loads),
        forces=loads.forces if len(loads.forces) else None,
        terms=loads.terms if len(loads.terms) else None,
        tables=loads.tables if has_tables else None,
        table_t=loads.table_t if has_tables else None,
        table_v=loads.table_v if has_tables else None,
        damping=loads.damping if loads.damping > 0.0 else None,
        expressions=loads.expressions,
        user=loads.user,
    )


class ProgramBuilder:
    """Expression loads being compiled: rows, concatenated code and constants."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.code: list[tuple[int, int, int]] = []
        self.aux = 0
        self.consts: list[float] = []
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
                    self.code.append((opcode, len(self.consts), 0))
                    self.consts.append(arg)
                else:
                    self.code.append((opcode, int(arg), self.aux))
                    self.aux += aux_rows(opcode, int(arg))
            row[EX_PROGRAMS + 2 * k + 1] = len(self.code)
            self.depth = max(self.depth, depth)
        self.rows.append(row)
        self.programs.append([program for program, _ in programs])
        self.names.append(names)

    def formulas(self, texts: list[str], constants: dict[str, float], frame: float, window: tuple[float, float], **kw) -> None:
        self.add([formulas.parse_formula(text, constants) for text in texts], frame, window, **kw)

    def build(self, axes: np.ndarray, moments: np.ndarray) -> Expressions | None:
        if not self.rows:
            return None
        return Expressions(np.array(self.rows), np.array(self.code, dtype=np.int64).reshape(-1, 3),
                           np.array(self.consts, dtype=float), np.ascontiguousarray(axes, dtype=float),
                           _quaternion_of(axes), np.asarray(moments, dtype=float), self.depth, self.aux,
                           generated.compiled(self.programs).address)


def _quaternion_of(axes: np.ndarray) -> np.ndarray:
    from rotlab.core.quaternion import from_matrix

    return np.asarray(from_matrix(axes), dtype=float)


def compile_loads(scenario: cfg.Scenario, axes: np.ndarray, moments: np.ndarray, user: UserTorque | None = None,
                  user_function: Callable | None = None) -> LoadArrays:
    """Turn the scenario's loads into arrays; body-frame vectors are rotated by Pᵀ = ``axes.T``
    into the principal frame (space-frame vectors are unchanged)."""
    to_principal = axes.T
    forces: list[np.ndarray] = []
    terms: list[np.ndarray] = []
    tables: list[list[float]] = []
    table_t: list[float] = []
    table_v: list[np.ndarray] = []
    programs = ProgramBuilder()
    damping = 0.0

    def body_vector(v: tuple[float, float, float]) -> np.ndarray:
        return to_principal @ np.asarray(v, dtype=float)

    def frame_vector(frame: str, v: tuple[float, float, float]) -> np.ndarray:
        return body_vector(v) if frame == "body" else np.asarray(v, dtype=float)

    def window(w: cfg.Window | None) -> tuple[float, float]:
        return (-np.inf, np.inf) if w is None else (w.on, w.off)

    for index, load in enumerate(scenario.loads):
        if isinstance(load, cfg.Gravity):
            mass = scenario.body.mass or 0.0
            forces.append(np.concatenate([body_vector(scenario.body.center_of_mass), mass * np.asarray(load.g)]))
        elif isinstance(load, cfg.Force) and load.frame == "space" and load.window is None:
            forces.append(np.concatenate([body_vector(load.point), np.asarray(load.value, dtype=float)]))
        elif isinstance(load, cfg.Force) and load.frame == "space":  # switched on and off: does work
            programs.formulas([repr(float(v)) for v in load.value], {}, SPACE, window(load.window), point=body_vector(load.point), names=_component_names(index, load))
        elif isinstance(load, cfg.Force):  # body-frame force: a constant follower torque p × F
            moment = np.cross(body_vector(load.point), body_vector(load.value))
            terms.append(_term(BODY, window(load.window), moment, np.zeros(3), 0.0, 0.0))
        elif isinstance(load, cfg.Torque):
            frame = BODY if load.frame == "body" else SPACE
            terms.append(_term(frame, window(load.window), frame_vector(load.frame, load.value), np.zeros(3), 0.0, 0.0))
        elif isinstance(load, cfg.HarmonicTorque):
            frame = BODY if load.frame == "body" else SPACE
            offset = frame_vector(load.frame, load.offset)
            amplitude = frame_vector(load.frame, load.amplitude)
            if load.angular_frequency == 0.0:  # a constant: fold into the offset
                offset, amplitude = offset + amplitude * np.sin(load.phase), np.zeros(3)
            terms.append(_term(frame, window(load.window), offset, amplitude, load.angular_frequency, load.phase))
        elif isinstance(load, cfg.TorqueTable):
            frame = BODY if load.frame == "body" else SPACE
            first = len(table_t)
            table_t.extend(load.times)
            table_v.extend(frame_vector(load.frame, v) for v in load.values)
            tables.append([frame, *window(load.window), first, len(table_t)])
        elif isinstance(load, cfg.Damping):
            damping += load.coefficient
        elif isinstance(load, cfg.Expression):
            frame = BODY if load.frame == "body" else SPACE
            point = None if load.point is None else body_vector(load.point)
            up = np.asarray(load.up, dtype=float)
            programs.add(load.programs(), frame, window(load.window), point=point, up=up / np.linalg.norm(up), names=_component_names(index, load))
        elif isinstance(load, cfg.PDControl):
            programs.formulas(*_pd_control(load), BODY, window(load.window), names=_component_names(index, load))
        elif isinstance(load, cfg.QuadraticDrag):  # −c |ω| ω
            texts = [f"-c*sqrt(omega[0]**2 + omega[1]**2 + omega[2]**2)*omega[{i}]" for i in range(3)]
            programs.formulas(texts, {"c": load.coefficient}, BODY, window(load.window), names=_component_names(index, load))
        elif isinstance(load, cfg.GravityGradient):
            vertical = np.asarray(load.vertical, dtype=float) / np.linalg.norm(load.vertical)
            normal = np.asarray(load.orbit_normal, dtype=float) / np.linalg.norm(load.orbit_normal)
            programs.formulas(*_gravity_gradient(load, _user_inertia(scenario.body)), BODY, (-np.inf, np.inf),
                              up=vertical, up2=np.cross(normal, vertical), rate=load.orbit_rate, names=_component_names(index, load))
    return LoadArrays(
        forces=np.array(forces, dtype=float).reshape(-1, 6),
        terms=np.array(terms, dtype=float).reshape(-1, 11),
        tables=np.array(tables, dtype=float).reshape(-1, 5),
        table_t=np.array(table_t, dtype=float),
        table_v=np.array(table_v, dtype=float).reshape(-1, 3),
        damping=float(damping),
        expressions=programs.build(axes, moments),
        user=user,
        formula_names=tuple(programs.names),
        user_function=user_function,
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


def user_torque(fn: Callable, frame: str, axes: np.ndarray) -> UserTorque:
    """``fn(t, q, omega) -> M`` compiled by numba (a plain Python function is jitted, with bounds
    checks) and typed for (float, float64[4], float64[3]); ``InputError`` naming why when numba
    cannot compile it or M is not three real numbers (a tuple, a list or a 1-D array).

    The kernels receive it as a C callback (``numba.cfunc``) of one fixed signature
    (t, Λ, ω, component) → M_component: its type is the same for every function, so the kernels
    stay compiled and cached on disk (a jitted function as a kernel argument would recompile
    them for each function and write its type into their cache index).  The callback never
    raises (a cfunc can only print and swallow an exception): when ``fn`` raises, returns other
    than 3 values, or a value that is not finite, it records a fault (``rotlab.core.faults``)
    and returns NaN, so the run stops and says why; it also honours Ctrl-C between calls."""
    import numba

    from rotlab.errors import InputError

    if frame not in ("body", "space"):
        raise InputError("frame", f"must be \"body\" or \"space\", not {frame!r}")
    if not callable(fn):
        raise InputError("torque", f"must be a function fn(t, q, omega) -> (Mx, My, Mz), not {type(fn).__name__}")
    name = getattr(fn, "__name__", "torque")
    jitted = fn if isinstance(fn, numba.core.registry.CPUDispatcher) else numba.njit(boundscheck=True)(fn)
    args = (numba.types.float64, numba.types.float64[::1], numba.types.float64[::1])
    try:
        jitted.compile(args)
        returned = jitted.overloads[args].signature.return_type
    except numba.core.errors.NumbaError as exc:
        raise InputError("torque", f"numba cannot compile {name}(t, q, omega): {_numba_reason(exc)}") from None
    except Exception as exc:  # noqa: BLE001 - numba's typing can raise anything the function's globals do
        raise InputError("torque", f"numba cannot compile {name}(t, q, omega): {type(exc).__name__}: {exc}"[:300]) from None
    problem = _return_problem(returned)
    if problem:
        raise InputError("torque", f"{name}(t, q, omega) must return 3 real numbers (Mx, My, Mz) as a tuple, list or array; it returns {problem}")
    return UserTorque(_callback(jitted), BODY if frame == "body" else SPACE, np.ascontiguousarray(axes, dtype=float), _quaternion_of(axes))


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
    """The C callback of a typed Python torque (``user_torque``): M_k at (t, Λ, ω), or NaN and a
    fault; the values are those ``rotlab.core.faults.record`` keeps (user's body frame)."""
    import numba

    from rotlab.core import faults

    @numba.cfunc(USER_SIGNATURE)
    def callback(t, q0, q1, q2, q3, w0, w1, w2, k):  # pragma: no cover - runs compiled
        if faults.interrupt_requested():
            return np.nan
        try:
            value = jitted(t, np.array([q0, q1, q2, q3]), np.array([w0, w1, w2]))
        except Exception:  # noqa: BLE001 - numba catches what the function raised, without its type
            faults.record(faults.CALLABLE_RAISED, 0, k, t, w0, w1, w2, q0, q1, q2, q3, 0.0)
            return np.nan
        if len(value) != 3:
            faults.record(faults.CALLABLE_SHAPE, 0, k, t, w0, w1, w2, q0, q1, q2, q3, float(len(value)))
            return np.nan
        mx, my, mz = value
        m = float(mx) if k == 0 else (float(my) if k == 1 else float(mz))
        if not np.isfinite(m):
            faults.record(faults.CALLABLE_NOT_FINITE, 0, k, t, w0, w1, w2, q0, q1, q2, q3, 0.0)
        return m

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


def _user_inertia(body: cfg.Body) -> np.ndarray:
    """The inertia tensor in the user's body frame."""
    if body.principal_moments is not None:
        return np.diag(np.asarray(body.principal_moments, dtype=float))
    return np.asarray(body.inertia_tensor, dtype=float)


def _pd_control(load: cfg.PDControl) -> tuple[list[str], dict[str, float]]:
    """M_i = sat(−kp sgn(δ₀) δ_i − kd ω_i), δ = Λ̃_target ∘ Λ:
    δ₀ = τ₀λ₀ + τ·λ,  δ_v = τ₀ λ_v − λ₀ τ_v − τ_v × λ_v  (τ the target)."""
    constants = {"a0": load.target[0], "a1": load.target[1], "a2": load.target[2], "a3": load.target[3],
                 "kp": load.kp, "kd": load.kd}
    d0 = "(a0*q[0] + a1*q[1] + a2*q[2] + a3*q[3])"
    delta = ["(a0*q[1] - q[0]*a1 - (a2*q[3] - a3*q[2]))",
             "(a0*q[2] - q[0]*a2 - (a3*q[1] - a1*q[3]))",
             "(a0*q[3] - q[0]*a3 - (a1*q[2] - a2*q[1]))"]
    texts = [f"-kp*sign({d0})*{d} - kd*omega[{i}]" for i, d in enumerate(delta)]
    if load.max_torque is not None:
        constants["limit"] = load.max_torque
        texts = [f"max(-limit, min(limit, {text}))" for text in texts]
    return texts, constants


def _gravity_gradient(load: cfg.GravityGradient, inertia: np.ndarray) -> tuple[list[str], dict[str, float]]:
    """M = 3 n² γ × (I γ), γ = gamma (the local vertical, user's body frame)."""
    constants = {"k": 3.0 * load.orbit_rate**2, **{f"I{i}{j}": float(inertia[i, j]) for i in range(3) for j in range(3)}}
    ig = [f"(I{i}0*gamma[0] + I{i}1*gamma[1] + I{i}2*gamma[2])" for i in range(3)]
    texts = [f"k*(gamma[{(i + 1) % 3}]*{ig[(i + 2) % 3]} - gamma[{(i + 2) % 3}]*{ig[(i + 1) % 3]})" for i in range(3)]
    return texts, constants


def _term(frame: float, window: tuple[float, float], offset: np.ndarray, amplitude: np.ndarray, w: float, phase: float) -> np.ndarray:
    return np.array([frame, window[0], window[1], *offset, *amplitude, w, phase], dtype=float)


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
    times = [loads.terms[:, 1:3].ravel(), loads.tables[:, 1:3].ravel(), loads.table_t, _expression_windows(loads).ravel()]
    all_times = np.concatenate(times) if any(len(x) for x in times) else np.zeros(0)
    return np.unique(all_times[np.isfinite(all_times)])


def shortest_window(loads: LoadArrays) -> float:
    """The shortest time a windowed load or a table segment acts (inf when none)."""
    windows = _expression_windows(loads)
    spans = [loads.terms[:, 2] - loads.terms[:, 1], loads.tables[:, 2] - loads.tables[:, 1], windows[:, 1] - windows[:, 0]]
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
    """True when an expression load uses abs, sign, min or max (``pd_control`` included): a
    torque that jumps or kinks where no breakpoint marks it.  A fixed step runs across such a
    switch at low order, whatever its probe measured between switches."""
    if loads.expressions is None:
        return False
    return bool(np.isin(loads.expressions.code[:, 0], [opcodes.ABS, opcodes.SIGN, opcodes.MIN, opcodes.MAX]).any())


def active_forces(loads: LoadArrays) -> np.ndarray:
    """Rows of ``loads.forces`` that can exert a torque (non-zero arm and force)."""
    f = loads.forces
    return f[(np.linalg.norm(f[:, :3], axis=1) > 0.0) & (np.linalg.norm(f[:, 3:], axis=1) > 0.0)]


def has_nonconservative(loads: LoadArrays) -> bool:
    """True when some load does work that no potential accounts for."""
    terms_active = bool(np.any(loads.terms[:, 3:9] != 0.0))
    tables_active = bool(np.any(loads.table_v != 0.0))
    return terms_active or tables_active or loads.damping > 0.0 or loads.expressions is not None or loads.user is not None


def torque_scale(loads: LoadArrays) -> float:
    """A rough upper bound of |M| (N·m) at unit ω, for choosing time scales."""
    f = loads.forces
    scale = float(np.sum(np.linalg.norm(f[:, :3], axis=1) * np.linalg.norm(f[:, 3:], axis=1)))
    scale += float(np.sum(np.linalg.norm(loads.terms[:, 3:6], axis=1) + np.linalg.norm(loads.terms[:, 6:9], axis=1)))
    if loads.table_v.size:
        scale += float(np.max(np.linalg.norm(loads.table_v, axis=1)))
    return scale
