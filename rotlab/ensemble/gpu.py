"""The ensemble kernels on an NVIDIA GPU (numba-cuda): one thread per case.

Each thread runs its case with the method's own compiled kernel — the same source as the CPU's,
compiled again for the device (``rotlab.core.targets``) — and reduces its observables on the
device (``rotlab.ensemble.observe``); only the kept cases' samples come back.  The calls mirror
``rotlab.ensemble.kernels`` argument for argument, so ``rotlab.ensemble.block`` runs a block on
either device.

* Fixed-step methods call their kernel once per sample interval (a fixed step starts each
  interval afresh, so the calls change no bit) on two rows of the thread's local memory: a case
  costs no device memory whatever its length.  A case that an event stops reports the steps to
  that interval (the CPU's, as its single run, those of the call the event falls in).
* ``dop853`` steps across samples and stops at the windows of its single run
  (``kernel_status.WINDOW``), as the CPU ensemble does (``kernels.dop853_case``): each case's
  whole sample grid lives in device memory, (n, 8) doubles, and the cases run in batches that fit
  ``MEMORY_FRACTION`` of the device's free memory.

The kernels are compiled without fused multiply–adds (NVVM's ``-fma=0``, and no link-time
optimisation, ``_jit``: numba-cuda's defaults contract a·b + c into one rounding, where the CPU's
kernels round the product and the sum apart), so the device does the CPU's IEEE operations in the
CPU's order: measured bit for bit on an H100 (docs/benchmarks.md).  What may still differ is a
library function's last bit (libdevice's ``sin``, ``exp``, … in a formula load, against the C
library's).  numba's CUDA simulator runs these kernels on the CPU's compiled
functions: there they are bit for bit (tests/test_gpu.py).

Importing this module imports numba-cuda (not rotlab's configuration, recording or CLI):
``benchmarks/bench_gpu.py`` runs it on a machine with numpy and numba-cuda alone.
"""

from __future__ import annotations

import sys
import threading
from contextlib import contextmanager

import numpy as np
from numba import config, cuda, njit, types

from rotlab.core import targets
from rotlab.core.dynamics import STATE_SIZE, store_row
from rotlab.core.expressions import STACK
from rotlab.core.formula_table import model_formula_table
from rotlab.core.kernel_status import OK
from rotlab.core.model import Model
from rotlab.errors import RunFailure, first_line
from rotlab.ensemble.event_scan import EventInputs, case_end, device_event_scratch, open_events, scan_events
from rotlab.ensemble.kernels import dop853_case, keep_samples, report_fixed_step, report_whole
from rotlab.ensemble.observe import ACC_COLUMNS, constants_of, observe_rows

THREADS = 64  # threads per block: the steppers keep their stages in registers and local memory
MEMORY_FRACTION = 0.5  # of the device's free memory, for dop853's sample grids
FUSED_MULTIPLY_ADD = False  # NVVM's -fma: True contracts a·b + c (faster, no longer the CPU's rounding)
MAX_REGISTERS: int | None = None  # per thread, for kernels made by ``_jit`` after it is set (None: ptxas's choice, 255 for dop853)
SIMULATED_MEMORY = 1 << 26  # bytes, the simulator's device memory (batches of a few cases: tests cover the batches)


def unavailable() -> str | None:
    """Why the GPU ensemble cannot run here (one line), or None when it can: a CUDA device, or
    numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, for tests)."""
    try:
        available = cuda.is_available()
    except Exception as exc:  # a driver that fails to load
        return f"no usable CUDA GPU ({type(exc).__name__}: {exc})"
    if not available:
        return ("no CUDA GPU found (numba.cuda.is_available() is false): run on the CPU (--device cpu), or on a machine with an "
                "NVIDIA GPU and `pip install 'rotlab[cuda]'`")
    try:
        targets.enable_cuda()
    except ImportError as exc:  # numba's own, older CUDA target: no ``numba.cuda.extending.overload``
        return f"numba-cuda is missing ({exc}): `pip install 'rotlab[cuda]'`"
    if not config.ENABLE_CUDASIM:
        from numba.cuda.cudadrv import nvvm

        if not nvvm.is_available():  # the compiler the kernels need (a driver alone runs no new kernel)
            return "a CUDA GPU but no NVVM, CUDA's compiler: `pip install 'rotlab[cuda]'` (numba-cuda[cu12] brings it)"
    return None


def failure(exc: Exception) -> str:
    """A CUDA error of a run (out of memory, a failed launch or compilation) in one line."""
    return f"the GPU run failed: {first_line(exc, typed=True)}"


class _NoneArguments:
    """numba-cuda prepares no argument of type None (a ``Model``'s absent load group): it is
    passed as the null pointer that numba's data model of None (an opaque pointer) expects."""

    def prepare_args(self, ty, val, stream=None, retr=None):
        if isinstance(ty, types.NoneType):
            return types.uint64, 0
        return ty, val


def _simulated_arrays(kernel):
    """Under numba's CUDA simulator a kernel runs as Python and its array arguments arrive wrapped
    (``FakeWithinKernelCUDAArray``), which the compiled functions it calls cannot take: each is
    passed as the NumPy array it wraps (an ``ArgHint`` of the simulator's own module)."""
    import importlib

    hint = importlib.import_module(type(kernel).__module__).ArgHint

    class Plain(hint):
        def to_device(self, retr, stream=0):
            return self.value

    class Unwrap:
        def prepare_args(self, ty, val, stream=0, retr=None):
            if isinstance(val, np.ndarray) and val.ndim > 0:
                return ty, Plain(val)
            inner = getattr(val, "_ary", None)  # a simulated device array
            return ty, (Plain(inner) if isinstance(inner, np.ndarray) else val)

    kernel.extensions = [Unwrap()]
    return kernel


_COMPILING = threading.Lock()
# The simulator runs a block's threads as Python threads and polls them in a loop that holds the
# GIL for a switch interval at a time (5 ms): at 0.5 ms its threads run 2.6× as much of the time
# (bench_gpu.py's rk4 row, 2 cases, loaded kernels: 10.7-10.9 -> 3.7-4.0 s, two alternating runs each).
SIMULATED_SWITCH_INTERVAL = 5e-4


@contextmanager
def _compiling():
    """Kernels compiled (on their first launch) in this block get ``-fma=<FUSED_MULTIPLY_ADD>``:
    numba-cuda passes NVVM no such option unless ``fastmath`` (which also flushes subnormals and
    approximates division and square roots), and NVVM's default is to fuse.  In numba's CUDA
    simulator, launches in this block run at ``SIMULATED_SWITCH_INTERVAL``."""
    if config.ENABLE_CUDASIM:
        with _COMPILING:  # (the interval is the process's: one block at a time, as below)
            previous = sys.getswitchinterval()
            sys.setswitchinterval(SIMULATED_SWITCH_INTERVAL)
            try:
                yield
            finally:
                sys.setswitchinterval(previous)
        return
    from numba.cuda.cudadrv import nvvm

    with _COMPILING:  # one block at a time: another thread's would restore the option midway
        compile_ir = nvvm.compile_ir

        def compile_with_fma_option(llvmir, **options):
            return compile_ir(llvmir, **{"fma": FUSED_MULTIPLY_ADD, **options})

        nvvm.compile_ir = compile_with_fma_option
        try:
            yield
        finally:
            nvvm.compile_ir = compile_ir


def _jit(kernel):
    """``cuda.jit`` whose None arguments are passed (see ``_NoneArguments``), compiled to PTX by
    NVVM (not link-time optimised: nvJitLink would generate the code itself, fusing
    multiply–adds whatever NVVM was told), with at most ``MAX_REGISTERS`` registers a thread;
    under the simulator, its arrays unwrapped."""
    if config.ENABLE_CUDASIM:
        return _simulated_arrays(cuda.jit(kernel))
    # (the decorator form drops lto: numba-cuda 0.30)
    return cuda.jit(kernel, extensions=[_NoneArguments()], lto=False, max_registers=MAX_REGISTERS)


def rebuild_kernels() -> None:
    """The kernels made again by ``_jit`` (after a change of ``MAX_REGISTERS``: a benchmark's)."""
    _FIXED.clear()
    _DOP853.clear()


_FIXED: dict[tuple, object] = {}  # (a fixed-step method's kernel, its name, events) → its CUDA kernel
_DOP853: dict[int, object] = {}  # events → dop853's CUDA kernel


def _scanner(method: str):
    """``scan_events`` for the method named ``method``, the name a literal (``method_calls``): a
    wrapper made per process (uncached, cheap); what it calls is cached under the name."""
    @njit
    def scan(solver, model, events, times, rows, stop, found, fault, watch):
        return scan_events(method, solver, model, events, times, rows, stop, found, fault, watch)

    return scan


def _fixed_step_kernel(advance, method: str, events_count: int):
    """The CUDA kernel that runs the fixed-step ``advance`` (``rotlab.methods.fixed_step``'s
    signature) of the method named ``method`` for every case of a scene with ``events_count``
    events: ``kernels.fixed_step_ensemble``'s outputs, one sample interval a call, each interval's
    events found after it is made."""
    kernel = _FIXED.get((advance, method, events_count))
    if kernel is not None:
        return kernel
    scan = _scanner(method)

    def fixed_step(y0, times, substeps, max_steps, model, extra, case, shared, applies, forces, events, found, fault, status, valid,
                   steps, last, acc, keep, stride, kept, kept_t, kept_count):
        b = cuda.grid(1)
        if b >= y0.shape[0] or substeps[b] <= 0:
            return
        n = times.shape[0]
        y = cuda.local.array(STATE_SIZE, types.float64)
        rows = cuda.local.array((2, STATE_SIZE), types.float64)
        folded = cuda.local.array(ACC_COLUMNS, types.float64)
        count = cuda.local.array(1, types.int64)
        watch = device_event_scratch(events_count)
        for m in range(STATE_SIZE):
            y[m] = y0[b, m]
        store_row(rows, 0, y)
        opened = open_events(events, times, rows, fault[b], watch)
        constants = constants_of(case[b], shared, applies)
        observe_rows(times, rows, 0, 1, True, constants, forces, folded)
        count[0] = 0
        if keep[b] >= 0:
            keep_samples(rows, times, 0, 1, 0, stride, kept[keep[b]], kept_t[keep[b]], count)
        code, i, taken = OK, 1, 0
        while i < n and opened == 1:
            code, j, done = advance(y, times[i - 1:i + 1], rows, 1, substeps[b], max_steps - taken, model, *extra)
            taken += done
            if code != OK or j == 1:  # non-finite (nothing stored), or the step budget cannot reach the sample
                break
            if scan((substeps[b], extra), model, events, times[i - 1:i + 1], rows, 2, found[b], fault[b], watch) == 1:
                break  # an event's formula is not finite, or a terminal event occurred: the case ends before this sample
            observe_rows(times[i - 1:i + 1], rows, 1, 2, False, constants, forces, folded)
            if keep[b] >= 0:
                keep_samples(rows, times[i - 1:i + 1], 1, 2, i - 1, stride, kept[keep[b]], kept_t[keep[b]], count)
            store_row(rows, 0, rows[1])
            i += 1
        y_end, t_end, samples = case_end(watch, fault[b], rows[0], times[i - 1], i, constants, forces, folded)
        report_fixed_step(b, code, samples, taken, y_end, t_end, folded, count, status, valid, steps, last, acc, keep, kept, kept_t,
                          kept_count)

    kernel = _FIXED[(advance, method, events_count)] = _jit(fixed_step)
    return kernel


def _dop853_kernel(events_count: int):
    """The CUDA kernel of ``kernels.dop853_ensemble`` for a scene with ``events_count`` events:
    cases first … first + len(grid) − 1, case b's samples in ``grid[b − first]``."""
    kernel = _DOP853.get(events_count)
    if kernel is not None:
        return kernel

    def dop853(first, y0, times, grid, rtol, atol, max_steps, chunk, model, counters, clocks, case, shared, applies, forces, events,
               found, fault, status, valid, last, acc, keep, stride, kept, kept_t, kept_count):
        b = first + cuda.grid(1)
        if b >= min(y0.shape[0], first + grid.shape[0]):
            return
        rows = grid[b - first]
        y = cuda.local.array(STATE_SIZE, types.float64)
        counted = cuda.local.array(3, types.int64)
        clock = cuda.local.array(3, types.float64)
        folded = cuda.local.array(ACC_COLUMNS, types.float64)
        count = cuda.local.array(1, types.int64)
        watch = device_event_scratch(events_count)
        for m in range(STATE_SIZE):
            y[m] = y0[b, m]
        for m in range(3):
            counted[m], clock[m] = 0, 0.0
        store_row(rows, 0, y)
        code, i = dop853_case(y, times, rows, rtol, atol, max_steps, chunk, model, counted, clock, events, found[b], fault[b], watch)
        store_row(counters, b, counted)
        store_row(clocks, b, clock)
        report_whole(b, code, i, rows, times, case, shared, applies, forces, status, valid, last, acc, keep, stride, kept, kept_t,
                     kept_count, folded, count, watch, fault[b])

    kernel = _DOP853[events_count] = _jit(dop853)
    return kernel


def blocks(cases: int) -> int:
    """Blocks of ``THREADS`` threads for one thread per case."""
    return max(1, (cases + THREADS - 1) // THREADS)


def _device_array(a: np.ndarray):
    """``a`` in device memory; an empty one (no forces, no events) of the same shape, uncopied:
    numba-cuda gives it a null pointer, which its kernels never read."""
    a = np.ascontiguousarray(a)
    if a.size == 0:
        return cuda.device_array(a.shape, dtype=a.dtype)
    return cuda.to_device(a)


def _to_device(arrays: dict[str, np.ndarray]) -> dict[str, object]:
    return {name: _device_array(a) for name, a in arrays.items()}


def _tuple_to_device(values: tuple) -> tuple:
    """A tuple (a ``Model``, a method's extra arguments) with its arrays in device memory, nested
    tuples included (the simulator's kernels take the NumPy arrays themselves)."""
    if config.ENABLE_CUDASIM:
        return values
    moved = (_device_array(v) if isinstance(v, np.ndarray) else (_tuple_to_device(v) if isinstance(v, tuple) else v) for v in values)
    return type(values)(*moved) if hasattr(values, "_fields") else tuple(moved)


def _model_to_device(model: Model) -> tuple[Model, object]:
    """``model`` in device memory (``_tuple_to_device``) and, where it has formulas (loads', or
    driven rotors'), its ``model_formula_table`` with it: ``fn``, the CPU function's address,
    becomes the table's device address, which the GPU's ``call_formulas`` interprets.  The table is
    returned too: it must outlive the kernel calls (the model holds only its address)."""
    formulas = None if config.ENABLE_CUDASIM else model_formula_table(model)
    if formulas is None:
        return _tuple_to_device(model), None
    _within_stack(formulas[1])
    table, address = _table_to_device(formulas[0])
    expressions = None if model.expressions is None else model.expressions._replace(fn=address)
    driven = None if model.drives is None else model.drives._replace(ex=model.drives.ex._replace(fn=address))
    return _tuple_to_device(model._replace(expressions=expressions, drives=driven)), table


def _events_to_device(events: EventInputs | None) -> tuple[EventInputs | None, object]:
    """A scene's events in device memory, ``fn`` the device address of their ``table``, which
    the GPU's ``call_formulas`` interprets (as ``_model_to_device``; the table returned too)."""
    if config.ENABLE_CUDASIM or events is None:
        return events, None
    _within_stack(events.depth)
    table, address = _table_to_device(events.table)
    return _tuple_to_device(events._replace(fn=address)), table


def _within_stack(depth: int) -> None:
    if depth > STACK:
        raise RunFailure(f"a formula needs a stack of {depth} values, beyond the GPU interpreter's {STACK}: run this sweep on the CPU")


def _table_to_device(table: np.ndarray) -> tuple[object, int]:
    """A ``formula_table`` in device memory, and its address."""
    on_device = cuda.to_device(table)
    return on_device, int(on_device.device_ctypes_pointer.value)


def _copy_back(device: dict[str, object], host: dict[str, np.ndarray]) -> None:
    for name, a in host.items():
        device[name].copy_to_host(a)


def fixed_step_ensemble(advance, method, y0, times, substeps, max_steps, model, extra, case, shared, applies, forces, events, found,
                        fault, status, valid, steps, last, acc, keep, stride, kept, kept_t, kept_count) -> None:
    """``kernels.fixed_step_ensemble`` on the GPU, for the fixed-step kernel ``advance`` (a
    ``@njit`` function: the CPU's kernels find it by name, which would import the method catalog,
    beyond ``bench_gpu.py``'s imports) of the method named ``method``; the outputs are written to
    the host arrays given."""
    targets.enable_cuda()
    inputs = _to_device({"y0": y0, "times": times, "substeps": substeps, "case": case, "shared": shared, "applies": applies,
                         "forces": forces, "keep": keep})
    outputs = {"found": found, "fault": fault, "status": status, "valid": valid, "steps": steps, "last": last, "acc": acc, "kept": kept,
               "kept_t": kept_t, "kept_count": kept_count}
    out = _to_device(outputs)
    device_model, table_in_use = _model_to_device(model)  # (the tables live until the results are copied back)
    device_events, events_table_in_use = _events_to_device(events)
    with _compiling():
        _fixed_step_kernel(advance, method, found.shape[1])[blocks(y0.shape[0]), THREADS](
            inputs["y0"], inputs["times"], inputs["substeps"], max_steps, device_model, _tuple_to_device(extra),
            inputs["case"], inputs["shared"], inputs["applies"], inputs["forces"], device_events, out["found"], out["fault"], out["status"],
            out["valid"], out["steps"], out["last"], out["acc"], inputs["keep"], stride, out["kept"], out["kept_t"], out["kept_count"])
    _copy_back(out, outputs)


def cases_per_batch(cases: int, samples: int) -> int:
    """How many ``dop853`` cases' sample grids fit ``MEMORY_FRACTION`` of the device's free memory."""
    free, _ = cuda.current_context().get_memory_info()
    free = min(free, SIMULATED_MEMORY) if config.ENABLE_CUDASIM else free  # (the simulator says ∞)
    return max(1, min(cases, int(free * MEMORY_FRACTION) // (samples * STATE_SIZE * 8)))


def dop853_ensemble(y0, times, rtol, atol, max_steps, chunk, model, counters, clocks, case, shared, applies, forces, events, found, fault,
                    status, valid, last, acc, keep, stride, kept, kept_t, kept_count) -> None:
    """``kernels.dop853_ensemble`` on the GPU (the outputs written to the host arrays given)."""
    targets.enable_cuda()
    inputs = _to_device({"y0": y0, "times": times, "case": case, "shared": shared, "applies": applies, "forces": forces, "keep": keep})
    outputs = {"counters": counters, "clocks": clocks, "found": found, "fault": fault, "status": status, "valid": valid, "last": last,
               "acc": acc, "kept": kept, "kept_t": kept_t, "kept_count": kept_count}
    out = _to_device(outputs)
    device_model, table_in_use = _model_to_device(model)  # (as ``fixed_step_ensemble``)
    device_events, events_table_in_use = _events_to_device(events)
    b, n = y0.shape[0], times.shape[0]
    batch = cases_per_batch(b, n)
    grid = cuda.device_array((batch, n, STATE_SIZE))
    kernel = _dop853_kernel(found.shape[1])
    with _compiling():
        for first in range(0, b, batch):
            kernel[blocks(min(batch, b - first)), THREADS](
                first, inputs["y0"], inputs["times"], grid, rtol, atol, max_steps, chunk, device_model, out["counters"], out["clocks"],
                inputs["case"], inputs["shared"], inputs["applies"], inputs["forces"], device_events, out["found"], out["fault"],
                out["status"], out["valid"], out["last"], out["acc"], inputs["keep"], stride, out["kept"], out["kept_t"], out["kept_count"])
    del grid
    _copy_back(out, outputs)
