"""Run a block of cases — scenes of one body and loads from different initial states — through
the method's ensemble kernel (``rotlab.ensemble.kernels``) and return what each case reports:
status, samples made, steps, failure, observables, max drift of each invariant, its events'
sweep columns (``rotlab.ensemble.event_scan``), and the samples of the cases asked for (every
``stride``-th, and the last valid one).

Each case's step is its own, derived as its single run derives it (``solver.step`` or its probe),
so each case's states are those of the case run alone (tests/test_ensemble.py: bit for bit).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numba import parallel_chunksize

from rotlab.checks import period_of
from rotlab.core.kernel_status import ATTITUDE_LOST, NONFINITE, OK, STALLED
from rotlab.ensemble import observe as ob
from rotlab.ensemble.cross_check import GpuDisagreement, checked_cases, disagreement, library_calls
from rotlab.ensemble.event_scan import BETWEEN_FAULT, FAULT_COLUMNS, FAULT_EVENT, FAULT_FORMULA, FAULT_KIND, FAULT_T0, FAULT_T1, \
    FOUND_COLUMNS, NO_FAULT, TERMINAL, EventInputs
from rotlab.ensemble.method_calls import call_for_method
from rotlab.errors import InputError, RunFailure, first_line
from rotlab.methods.base import Settings
from rotlab.methods.stepping import CHUNK_STEPS, budget_message, stall_message, state_failure_after, step_floor_message
from rotlab.scene.scene import Scene
from rotlab.trajectory import reference_of, runs_of

if TYPE_CHECKING:
    from rotlab.events import CompiledEvents


def _dop853(scene: Scene, method, settings: Settings, t: np.ndarray, y0: np.ndarray, counters: np.ndarray, clocks: np.ndarray,
            inputs: tuple, events: tuple, outputs: tuple, device: str = "cpu") -> dict:
    head = (y0, t, settings.rtol, settings.atol, settings.max_steps, CHUNK_STEPS)
    if device == "cuda":
        from rotlab.ensemble.gpu import dop853_ensemble

        dop853_ensemble(*head, scene.model, counters, clocks, *inputs, *events, *outputs)
    else:
        from rotlab.ensemble.kernels import dop853_ensemble, parallel_model, thread_grids

        dop853_ensemble(*head, *parallel_model(scene.model), thread_grids(t.shape[0]), counters, clocks, *inputs, *events, *outputs)
    return {"rtol": settings.rtol, "atol": settings.atol}


def _taylor(scene: Scene, method, settings: Settings, t: np.ndarray, y0: np.ndarray, counters: np.ndarray, clocks: np.ndarray,
            inputs: tuple, events: tuple, outputs: tuple, device: str = "cpu") -> dict:
    from rotlab.ensemble.kernels import parallel_model, taylor_ensemble, thread_grids

    order = method.checked_order(settings)
    taylor_ensemble(y0, t, order, settings.rtol, settings.atol, settings.max_steps, CHUNK_STEPS, *parallel_model(scene.model),
                    thread_grids(t.shape[0]), *method.constants(scene), counters, clocks, *inputs, *events, *outputs)
    return {"order": order, "rtol": settings.rtol, "atol": settings.atol}


# adaptive methods with an ensemble kernel, each run as its single run is (fixed-step ones all have one):
# run(scene, method, settings, t, y0, counters, clocks, (case, shared, applies, forces), (events, found, fault),
# (status, valid, last, acc, keep, stride, kept, kept_t, kept_count), device=…) → the run's details
ADAPTIVE_KERNELS = {"dop853": _dop853, "taylor": _taylor}
# the methods whose kernels compile for an NVIDIA GPU (``rotlab.ensemble.gpu``; splitting's and taylor's
# return arrays from compiled functions, which a GPU device function cannot)
GPU_METHODS = ("rk4", "rkmk4", "dmv", "dop853")


def has_ensemble_kernel(method: object) -> bool:
    """``method`` (a catalog entry) runs in the ensemble kernels."""
    return getattr(method, "stepping", None) == "fixed" or getattr(method, "name", None) in ADAPTIVE_KERNELS


def unsupported_scene(scene: Scene) -> str | None:
    """Why ``scene`` cannot run in a parallel ensemble kernel (None when it can): a Python
    ``torque=`` function is not compiled into it, and driven rotors add state columns."""
    if scene.loads.user is not None:
        return "a Python torque function cannot run in the parallel ensemble kernel"
    if scene.loads.drives is not None:
        return "a driven rotor's momentum is a state column the ensemble kernels do not carry"
    return None


@dataclass
class BlockResult:
    """What each of B cases reports (arrays of B rows; see the module docstring)."""

    status: np.ndarray  # kernel status (0: OK)
    valid: np.ndarray  # samples made
    steps: np.ndarray  # accepted steps
    rejected: np.ndarray  # rejected steps (adaptive)
    evaluations: np.ndarray  # right-hand side evaluations
    failure: list[str | None]
    details: list[dict[str, object]]
    last: np.ndarray  # (B, 8): each case's last valid state (principal frame)
    flip_period: np.ndarray  # s, NaN where fewer than MIN_REVERSALS
    reversals: np.ndarray
    max_nutation_deg: np.ndarray
    max_drift: dict[str, np.ndarray]  # invariant → max |relative drift| (the scene's invariants)
    events: dict[str, np.ndarray]  # sweep column (``rotlab.events.observable_names``) → its value in each case
    kept: dict[int, tuple[np.ndarray, np.ndarray]]  # case → (times, states (n, 8)) of the kept samples
    checked_seconds: float = 0.0  # of a GPU call: the CPU's re-run of some of its cases (``_check_on_the_cpu``)


def case_inputs(scenes: list[Scene], given_axes: list[str | None]) -> np.ndarray:
    """``observe``'s per-case columns (B, CASE_COLUMNS) from each case's first sample: the flip
    axis row (``rotlab.observables.flip_axes``), e and d (``reference_axes``), the reference
    values of the drifts (``rotlab.trajectory.reference_of``)."""
    from rotlab.observables import flip_axes, reference_axes

    scene = scenes[0]
    y0 = np.array([s.state0 for s in scenes])
    t0 = scene.scenario.time.sample_times()[:1]
    first = runs_of(scene, t0, y0[:, None, :])
    axis = flip_axes(first, given_axes)
    e, d = reference_axes(first)
    ref = reference_of(scene, y0)
    case = np.zeros((len(scenes), ob.CASE_COLUMNS))
    case[:, ob.CASE_FLIP:ob.CASE_FLIP + 3] = scene.axes[axis]
    case[:, ob.CASE_E:ob.CASE_E + 3] = np.einsum("bj,jk->bk", e, scene.axes)  # R(Λ_user) e = R(Λ_P) Pᵀ e
    case[:, ob.CASE_D:ob.CASE_D + 3] = d
    case[:, ob.CASE_H0] = ref.invariant_energy[:, 0]
    case[:, ob.CASE_SCALE] = ref.energy_scale[:, 0]
    case[:, ob.CASE_L0:ob.CASE_L0 + 3] = ref.L_p[:, 0]
    case[:, ob.CASE_LS0:ob.CASE_LS0 + 3] = ref.L_space[:, 0]
    case[:, ob.CASE_LNORM] = ref.L_norm[:, 0]
    return case


def shared_inputs(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(shared columns, which invariants apply, the force rows of the potential) of the scene."""
    shared = np.zeros(ob.SHARED_COLUMNS)
    shared[ob.SHARED_MOMENTS:ob.SHARED_MOMENTS + 3] = scene.moments
    if scene.field_direction is not None:
        shared[ob.SHARED_UP:ob.SHARED_UP + 3] = scene.field_direction
    if scene.symmetry_axis is not None:
        shared[ob.SHARED_SYMMETRY:ob.SHARED_SYMMETRY + 3] = scene.symmetry_axis
    if scene.rotor_momentum is not None:
        shared[ob.SHARED_ROTORS:ob.SHARED_ROTORS + 3] = scene.rotor_momentum
    applies = np.array([name in scene.invariants for name in ob.INVARIANTS], dtype=np.bool_)
    forces = np.ascontiguousarray(scene.loads.forces, dtype=float) if scene.has_potential else np.zeros((0, 6))
    return shared, applies, forces


MAX_COUNT = 2**53  # a terminal event's count as the kernels hold it (its occurrences are counted in float64; a count beyond is never reached)


def event_inputs(scene: Scene) -> tuple[EventInputs | None, CompiledEvents | None]:
    """The scene's events for the kernels (``rotlab.ensemble.event_scan``; None without events)
    and the compiled events they point to (to be kept alive while the kernels run)."""
    from rotlab.events import DIRECTIONS, compile_events

    compiled = compile_events(scene)
    if compiled is None:
        return None, None
    specs = compiled.specs
    rates_only = np.zeros((len(specs), 1 + max(len(spec.record) for spec in specs)), dtype=np.bool_)
    for k, flags in enumerate(compiled.rates_only):
        rates_only[k, :len(flags)] = flags
    return EventInputs(compiled.fn, compiled.consts, compiled.rows, compiled.axes, compiled.axes_q, compiled.moments,
                       np.array([DIRECTIONS[spec.direction] for spec in specs], dtype=np.int64),
                       np.array([len(spec.record) for spec in specs], dtype=np.int64), rates_only,
                       np.array([min(spec.count, MAX_COUNT) if spec.terminal else 0 for spec in specs], dtype=np.int64), compiled.table,
                       compiled.depth), compiled


def ended_by(compiled: CompiledEvents, fault: np.ndarray) -> str:
    """What ended a case a terminal event stopped (``fault``): its single run's words."""
    from rotlab.events import ended_by_message

    return ended_by_message(compiled.specs[int(fault[FAULT_EVENT])], float(fault[FAULT_T0]))


def event_failure(compiled: CompiledEvents, fault: np.ndarray) -> str:
    """The message of a case's ``fault`` row (``rotlab.ensemble.event_scan``): its single run's."""
    from rotlab.events import not_finite_between_message, not_finite_message

    kind, spec = int(fault[FAULT_KIND]), compiled.specs[int(fault[FAULT_EVENT])]
    if kind == BETWEEN_FAULT:
        return not_finite_between_message(spec, float(fault[FAULT_T0]), float(fault[FAULT_T1]))
    return not_finite_message(spec, int(fault[FAULT_FORMULA]), float(fault[FAULT_T0]))


def event_observables(compiled: CompiledEvents | None, found: np.ndarray, ran: np.ndarray) -> dict[str, np.ndarray]:
    """Each sweep column of the events (``rotlab.events.observed``) in each case (NaN where a
    case did not run)."""
    from rotlab.events import OBSERVED, observed

    columns: dict[str, np.ndarray] = {}
    for k, spec in enumerate(compiled.specs if compiled is not None else ()):
        values = np.array([observed(int(c), first, last) if r else (np.nan,) * len(OBSERVED)
                           for (c, first, last), r in zip(found[:, k].tolist(), ran)], dtype=float).reshape(-1, len(OBSERVED))
        columns.update({f"event_{spec.name}_{what}": values[:, m] for m, what in enumerate(OBSERVED)})
    return columns


def gpu_unavailable() -> str | None:
    """Why the ensemble cannot run on a GPU here (one line), or None when it can (``rotlab.ensemble.gpu``)."""
    try:
        from rotlab.ensemble import gpu
    except ImportError as exc:
        return f"numba's CUDA target is missing ({exc}): `pip install 'rotlab[cuda]'`"
    except Exception as exc:  # numba.cuda's set-up failing on this machine (a bad NUMBA_CUDA_DRIVER, …)
        return f"no usable CUDA GPU ({first_line(exc, typed=True)})"
    return gpu.unavailable()


def unsupported_on_gpu(method: object) -> str | None:
    """Why ``method`` (a catalog entry) cannot run on the GPU (None when it can)."""
    name = getattr(method, "name", method)
    if name in GPU_METHODS:
        return None
    return f"method {name!r} has no GPU kernel: choose one of {', '.join(GPU_METHODS)} (solver.method), or run without --device cuda"


@contextmanager
def _gpu_errors(device: str) -> Iterator[None]:
    """On the GPU, an error of CUDA's (out of memory, a failed launch or compilation) as a one-line
    ``RunFailure`` (``gpu.failure``); an ``InputError`` as it is."""
    if device != "cuda":
        yield
        return
    try:
        yield
    except (InputError, RunFailure, KeyboardInterrupt):
        raise
    except Exception as exc:
        from rotlab.ensemble.gpu import failure

        raise RunFailure(failure(exc)) from exc


def run_block(scenes: list[Scene], method, settings: Settings, t: np.ndarray, keep: list[int], stride: int,
              given_axes: list[str | None], device: str = "cpu", cross_check: bool = True) -> BlockResult | InputError:
    """Every scene of ``scenes`` (one body and loads) with ``method`` at ``settings`` over the sample
    times ``t``; the samples of cases ``keep`` (positions in ``scenes``) kept every ``stride``-th;
    on ``device`` "cpu" (every core numba may use) or "cuda" (``rotlab.ensemble.gpu``; some of its
    cases run again on the CPU and compared, ``rotlab.ensemble.cross_check``, unless ``cross_check``
    is False: for a diagnosis comparing the devices themselves, benchmarks/gpu_agreement.py).
    A fixed step that a case cannot take is that case's failure; an input error that concerns
    every case (an order the method does not offer) is returned."""
    from rotlab.ensemble import kernels

    b, n = len(scenes), t.shape[0]
    scene = scenes[0]
    case = case_inputs(scenes, given_axes)
    shared, applies, forces = shared_inputs(scene)
    events, compiled = event_inputs(scene)
    found = np.zeros((b, len(compiled.specs) if compiled is not None else 0, FOUND_COLUMNS))
    fault = np.zeros((b, FAULT_COLUMNS))
    y0 = np.array([s.state0 for s in scenes])
    status, valid = np.zeros(b, dtype=np.int64), np.zeros(b, dtype=np.int64)
    last, acc = y0.copy(), np.zeros((b, ob.ACC_COLUMNS))
    clocks = np.zeros((b, 3))  # an adaptive case's integrator time, and a stalled chunk's start and steps (``kernels.dop853_case``)
    where = np.full(b, -1, dtype=np.int64)
    where[keep] = np.arange(len(keep))
    rows = math.ceil(n / stride) + 1
    kept, kept_t = np.zeros((max(1, len(keep)), rows, 8)), np.zeros((max(1, len(keep)), rows))
    kept_count = np.zeros(b, dtype=np.int64)
    failure: list[str | None] = [None] * b
    if method.adaptive:
        counters = np.zeros((b, 3), dtype=np.int64)
        try:
            with parallel_chunksize(1), _gpu_errors(device):  # (cases of unequal cost: each thread takes the next case)
                run = ADAPTIVE_KERNELS[method.name](scene, method, settings, t, y0, counters, clocks, (case, shared, applies, forces),
                                                   (events, found, fault), (status, valid, last, acc, where, stride, kept, kept_t, kept_count),
                                                   device=device)
        except InputError as exc:
            return exc
        steps, rejected, evaluations = counters[:, 0].copy(), counters[:, 1].copy(), counters[:, 2].copy()
        details = [run] * b
    else:
        try:
            order = method.order(settings)
        except InputError as exc:
            return exc
        substeps, details = np.zeros(b, dtype=np.int64), []
        for k, s in enumerate(scenes):
            try:
                substeps[k], details_k = _substeps(method, s, t, settings, order)
                details.append(details_k)
            except InputError as exc:
                failure[k] = str(exc)
                details.append({})
        steps = np.zeros(b, dtype=np.int64)
        inputs, outputs = (case, shared, applies, forces), (status, valid, steps, last, acc, where, stride, kept, kept_t, kept_count)
        if device == "cuda":
            from rotlab.ensemble import gpu

            with _gpu_errors(device):
                gpu.fixed_step_ensemble(method.kernel, method.name, y0, t, substeps, settings.max_steps, scene.model, method.kernel_args(scene, order),
                                        *inputs, events, found, fault, *outputs)
        else:
            with parallel_chunksize(1):
                call_for_method(kernels.fixed_step_ensemble, method.name, y0, t, substeps, settings.max_steps, *kernels.parallel_model(scene.model),
                                kernels.thread_grids(min(n, kernels.WINDOW + 1)), method.kernel_args(scene, order), *inputs, events, found, fault,
                                *outputs)
        rejected = np.zeros(b, dtype=np.int64)
        evaluations = steps * method.evaluations_per_step(scene, order)
        clocks[:, 0] = t[np.maximum(valid, 1) - 1]  # (a fixed step's run ends at a sample)
    for k in range(b):
        if failure[k] is not None:
            continue
        if fault[k, FAULT_KIND] == TERMINAL:  # its last sample is the state at the event (its rows after, made in the same call, are not)
            status[k] = OK
            details[k] = {**details[k], "ended by": ended_by(compiled, fault[k])}
        elif fault[k, FAULT_KIND] != NO_FAULT:  # (before a non-finite state: the event's formula stopped the case first)
            failure[k] = event_failure(compiled, fault[k])
        elif status[k] in (NONFINITE, ATTITUDE_LOST):
            formula = _formula_fault(method, scenes[k], t, settings) if status[k] == NONFINITE else None
            failure[k] = formula or state_failure_after(int(status[k]), float(t[valid[k] - 1]), float(t[min(valid[k], n - 1)]), last[k])
        elif status[k] == STALLED:
            failure[k] = stall_message(clocks[k, 1], clocks[k, 0], int(clocks[k, 2]), float(t[n - 1]),
                                       settings.max_steps - int(steps[k] + rejected[k]), settings.max_steps)
        elif status[k] != OK:
            failure[k] = step_floor_message(f"at t = {clocks[k, 0]:.9g} s")
        elif valid[k] < n:
            failure[k] = budget_message(settings.max_steps, float(clocks[k, 0]))
    ran = valid > 0
    folded = ob.max_drifts(acc, case)
    drift = {name: np.where(ran, folded[:, k], np.nan) for k, name in enumerate(ob.INVARIANTS) if applies[k]}
    reversals = acc[:, ob.ACC_REVERSALS].astype(np.int64)  # (0 where a case did not run: no period)
    period = period_of(acc[:, ob.ACC_FIRST], acc[:, ob.ACC_LAST], reversals)
    nutation = np.where(ran, np.degrees(np.arccos(np.where(ran, acc[:, ob.ACC_MIN_COS], 1.0))), np.nan)
    kept_rows = {k: (kept_t[where[k], :kept_count[k]].copy(), kept[where[k], :kept_count[k]].copy()) for k in keep if ran[k]}
    result = BlockResult(status, valid, steps, rejected, evaluations, failure, details, last, period, reversals, nutation, drift,
                         event_observables(compiled, found, ran), kept_rows)
    if device == "cuda" and cross_check:
        started = time.perf_counter()
        _check_on_the_cpu(result, scenes, method, settings, t, given_axes)
        result.checked_seconds = time.perf_counter() - started
    return result


def _check_on_the_cpu(result: BlockResult, scenes: list[Scene], method, settings: Settings, t: np.ndarray,
                      given_axes: list[str | None]) -> None:
    """A GPU block's ``checked_cases`` run again on the CPU; ``GpuDisagreement`` where one's
    result is not the GPU's (``rotlab.ensemble.cross_check``)."""
    positions = checked_cases(len(scenes))
    cpu = run_block([scenes[k] for k in positions], method, settings, t, [], 1, [given_axes[k] for k in positions])
    if isinstance(cpu, InputError):  # (the GPU ran these cases: the CPU takes them)
        raise cpu
    found = disagreement(result, cpu, positions)
    if found is not None:
        from rotlab.events import compile_events

        compiled = compile_events(scenes[0])
        raise GpuDisagreement(*found, library_calls(scenes[0].model, method.name, compiled.programs if compiled is not None else []))


def _formula_fault(method, scene: Scene, t: np.ndarray, settings: Settings) -> str | None:
    """The words of a case whose state became non-finite in a scene with formula loads: its
    single run's, which name the formula that did it, the time and the state (compiled formulas
    report a fault in one process-wide record, ``rotlab.core.faults``, which the ensemble's
    threads share: the case is run again alone, to its stop, with the same steps)."""
    if scene.loads.expressions is None:
        return None
    return method.solve(scene, t, settings, None).failure


def _substeps(method, scene: Scene, t: np.ndarray, settings: Settings, order: int) -> tuple[int, dict[str, object]]:
    """``method.sampling`` of ``scene``; an ``InputError`` where its single run would refuse, or
    would cut a sample interval into pieces (more than ``CHUNK_STEPS`` steps: not an ensemble's case)."""
    substeps, details = method.sampling(scene, t, settings, order)
    if substeps > CHUNK_STEPS:
        raise InputError("solver.step", f"{substeps:,} steps per sample interval: run this case alone (rotlab run) or sample more often")
    return substeps, details
