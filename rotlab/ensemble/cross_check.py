"""A GPU block's results checked against the CPU's: a few of its cases run again by the CPU's
ensemble kernels, compared before any of the block's numbers are reported.

The GPU kernels are the CPU's source compiled for the device without fused multiply–adds, so a
case's numbers are meant to be the CPU's bit for bit; a call of a library function (``sin``,
``cos``: a harmonic torque, ``rkmk4``'s exponential map, a formula's functions) may differ in
its last bit, which a long or chaotic run amplifies. Device code can be wrong where numba's CUDA
simulator, and so the tests, cannot see it (the simulator runs the CPU's compiled functions): a
device session once ran ``dop853`` with its stages missing, a GPU-only implementation left
unregistered (``targets.gpu_overload``, fixed), and got states that were garbage from the first
sample (docs/benchmarks.md, "The GPU"). So each block's cases ``checked_cases`` are run again on
the CPU: the status and the samples made must be equal, the last valid state and the observables,
the events' counts and times among them, within ``TOLERANCE`` (relative to their scale; the
drifts, already relative, and the events' times, absolutely up to 1). A
disagreement stops the run (``GpuDisagreement``: one line, exit 1) instead of reporting the
device's numbers; the line says whether the call computes a library function (``library_calls``),
whose last bit a chaotic motion can carry past the tolerance, besides wrong kernels.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from rotlab.core.opcodes import LIBRARY, Program
from rotlab.core.torques import T_W
from rotlab.errors import RunFailure

TOLERANCE = 1e-6  # far above a library function's last bit carried through a run, far below a wrong one


class Reported(Protocol):  # ``rotlab.ensemble.block.BlockResult``'s fields compared here
    status: np.ndarray
    valid: np.ndarray
    last: np.ndarray
    flip_period: np.ndarray
    max_nutation_deg: np.ndarray
    max_drift: dict[str, np.ndarray]
    events: dict[str, np.ndarray]


class GpuDisagreement(RunFailure):
    """The GPU's result for the block's case ``position`` is not the CPU's (``disagreement``);
    ``library``: what in the call computes a library function (``library_calls``), or None."""

    def __init__(self, position: int, what: str, library: str | None = None) -> None:
        super().__init__(message(f"case {position} of the block", what, library))
        self.position, self.what, self.library = position, what, library

    def __reduce__(self):  # (picklable across Dask workers)
        return (type(self), (self.position, self.what, self.library))


def message(case: str, what: str, library: str | None) -> str:
    """One line: which case, what differs, and the causes it may have: the device's code, and
    where the call computes a library function, that function's last bit, amplified by the motion."""
    cause = ("the GPU kernels are wrong for this scene" if library is None else
             f"the GPU kernels are wrong for this scene, or {library}, which may differ in its last bit on the GPU, "
             f"was amplified by this motion")
    return f"the GPU's result for {case} differs from the CPU's ({what}): {cause}; run this sweep on the CPU (--device cpu)"


def library_calls(model, method_name: str, event_programs: list[list[Program]] = ()) -> str | None:
    """What a GPU call computes with a library function, whose last bit may differ from the C
    library's (None: only correctly rounded operations, so the CPU's bits are expected): a
    harmonic torque's ``sin``, ``rkmk4``'s ``sin`` and ``cos``, a formula's (a load's, or one of
    the events' ``event_programs``) ``sin``, ``exp``, … (``opcodes.LIBRARY``)."""
    calls = []
    if model.terms is not None and np.any(model.terms[:, T_W] != 0.0):
        calls.append("a harmonic torque's sin")
    if method_name == "rkmk4":
        calls.append("rkmk4's sin and cos")
    if model.expressions is not None and any(int(opcode) in LIBRARY for opcode in model.expressions.code[:, 0]):
        calls.append("a formula load's library functions")
    if any(opcode in LIBRARY for programs in event_programs for program in programs for opcode, _ in program):
        calls.append("an event formula's library functions")
    return " and ".join(calls) or None


def checked_cases(b: int) -> list[int]:
    """The positions, in a block of ``b`` cases, of those run again on the CPU: the first, the
    last and two between (fixed by b: the same sweep checks the same cases)."""
    return sorted({0, b // 3, (2 * b) // 3, b - 1})


def disagreement(gpu: Reported, cpu: Reported, positions: list[int]) -> tuple[int, str] | None:
    """(position, what differs) of the first checked case whose GPU result is not its CPU result
    (``cpu`` holds the cases ``positions`` of ``gpu``, in that order), or None."""
    for j, k in enumerate(positions):
        if gpu.status[k] != cpu.status[j] or gpu.valid[k] != cpu.valid[j]:
            return k, f"status {gpu.status[k]} against {cpu.status[j]}, {gpu.valid[k]} samples against {cpu.valid[j]}"
        state = relative_difference(gpu.last[k], cpu.last[j], float(np.max(np.abs(cpu.last[j]))))
        if not state <= TOLERANCE:
            return k, f"last state {_vector(gpu.last[k])} against {_vector(cpu.last[j])}, relative difference {state:.1e}"
        observables = {"flip period": (gpu.flip_period[k], cpu.flip_period[j], abs(cpu.flip_period[j])),
                       "max nutation": (gpu.max_nutation_deg[k], cpu.max_nutation_deg[j], max(abs(cpu.max_nutation_deg[j]), 1.0)),
                       **{f"max {name} drift": (gpu.max_drift[name][k], cpu.max_drift[name][j], max(abs(cpu.max_drift[name][j]), 1.0))
                          for name in cpu.max_drift},
                       **{name: (gpu.events[name][k], cpu.events[name][j], max(abs(cpu.events[name][j]), 1.0)) for name in cpu.events}}
        for name, (a, b, scale) in observables.items():
            if not relative_difference(a, b, scale) <= TOLERANCE:
                return k, f"{name} {a:.9g} against {b:.9g}"
    return None


def relative_difference(a, b, scale: float) -> float:
    """max |a − b| / scale over the finite entries (∞ where the entries that are not finite are
    not the same: NaN against NaN is the same, +∞ against −∞ is not; 0 where they are equal)."""
    a, b = np.atleast_1d(np.asarray(a, dtype=float)), np.atleast_1d(np.asarray(b, dtype=float))
    if not (np.array_equal(np.isfinite(a), np.isfinite(b)) and np.array_equal(a[~np.isfinite(b)], b[~np.isfinite(b)], equal_nan=True)):
        return math.inf
    finite = np.isfinite(b)
    difference = float(np.max(np.abs(a[finite] - b[finite]), initial=0.0))
    return 0.0 if difference == 0.0 else difference / scale if scale > 0.0 else math.inf


def _vector(v: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in v) + "]"
