"""The ensemble on an NVIDIA GPU (``rotlab.ensemble.gpu``): body-steps/s and cases/s, and each
case's result against the same case run alone on the CPU.

    python benchmarks/bench_gpu.py [--cases 1048576] [--check 256] [--threads 32 64 128]
    python benchmarks/bench_gpu.py --fma   # kernels compiled with fused multiply-adds (faster; not the CPU's rounding)
    python benchmarks/bench_gpu.py --only dop853 --max-registers default 168 128   # register caps (occupancy against spills)
    NUMBA_ENABLE_CUDASIM=1 python benchmarks/bench_gpu.py --cases 8 --dop853-cases 8 --check 8   # on a machine without a GPU

Imports numpy, numba (with numba-cuda) and rotlab's kernel modules only — no configuration,
recording or CLI (no pydantic, rerun or typer) — so it runs as it is on a bare GPU machine.  The
models are built by hand:

* heavy asymmetric top: A, B, C = 2, 3, 4 g·m², m g = 0.5 N down at p = (0.01, 0.02, 0.05) m
  (body), ω₀ = (1, 2, 30) rad/s dispersed by 5% per case, Λ₀ = 1;
* free asymmetric body: the same moments, ω₀ = (0.1, 3, 0.1) rad/s (near the intermediate axis)
  dispersed by 5%.

Rows: ``rk4`` on the top (h = 1e-3 s, 1,000 steps a case, 11 samples), ``dmv`` order 8 on the free
body (h = 1e-3 s, 1,000 steps), ``rk4-formula``: ``rk4`` on the top with a formula load (``FORMULA``,
interpreted on the device; its ``sin`` is libdevice's, so its last bits may differ from the CPU's),
``dop853`` on the top (10 s at 10 samples/s, rtol 1e-10, atol
1e-12, its own steps: the mean is printed).  "kernel" times the kernel on device arrays
(``cuda.synchronize`` before and after, median of ``--repeats``); "end to end" times
``gpu.fixed_step_ensemble`` / ``gpu.dop853_ensemble`` with their copies to and from the device.
"max diff vs CPU" compares the first ``--check`` cases with each case run alone by the same
compiled kernel on the CPU (``difference``: last state relative to each component's scale, the
nutation's cosine, the flip times, the max relative drifts); the step counts must be equal.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from numba import config, cuda

from rotlab.core.dmv import dmv_advance, modified_coefficients
from rotlab.core.dynamics import euler_coefficients
from rotlab.core.model import Model
from rotlab.core.rk4 import rk4_advance
from rotlab.core.torques import BODY
from rotlab.ensemble import gpu, observe as ob
from rotlab.ensemble.kernels import dop853_case, report_whole

MOMENTS = np.array([2e-3, 3e-3, 4e-3])
FORCES = np.array([[0.01, 0.02, 0.05, 0.0, 0.0, -0.5]])  # [p (body, m), F (space, N)]
RTOL, ATOL = 1e-10, 1e-12
MAX_STEPS = 10**9


# a formula load on the top (body frame, N·m): damping with a harmonic term, interpreted on a GPU (``run_program``)
FORMULA = (["-k*omega[0] + a*sin(w*t)", "-k*omega[1]", "-k*omega[2]*q[0]"], {"k": 1e-5, "a": 1e-4, "w": 3.0})


def model_of(forces: np.ndarray | None, formula: bool = False) -> Model:
    return Model(euler_coefficients(MOMENTS), np.zeros(0), forces, None, None, None, None, None, formula_load() if formula else None, None)


def formula_load():
    """``FORMULA`` as the scene's ``Expressions`` (parsed and compiled as a scenario's are)."""
    from rotlab.scene.programs import ProgramBuilder

    builder = ProgramBuilder()
    builder.formulas(*FORMULA, BODY, (-np.inf, np.inf))
    return builder.build(np.eye(3), MOMENTS)


def initial_states(cases: int, omega: tuple[float, float, float], seed: int = 7) -> np.ndarray:
    y0 = np.zeros((cases, 8))
    y0[:, 0] = 1.0
    y0[:, 4:7] = np.array(omega) * (1.0 + 0.05 * np.random.default_rng(seed).standard_normal((cases, 3)))
    return y0


def observe_inputs(y0: np.ndarray, forces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``observe``'s per-case and shared columns for Λ₀ = 1 (so L_space₀ = L₀), z the flip axis,
    e = d = z, and which invariants apply (energy, |Λ|, and L·up under gravity, |L|, L_space without)."""
    L0 = y0[:, 4:7] * MOMENTS
    T0 = 0.5 * np.einsum("bi,bi->b", y0[:, 4:7], L0)
    V0 = -(forces[:, None, :3] * forces[:, None, 3:]).sum(axis=(0, 2)) if len(forces) else 0.0
    case = np.zeros((y0.shape[0], ob.CASE_COLUMNS))
    case[:, ob.CASE_FLIP + 2] = case[:, ob.CASE_E + 2] = case[:, ob.CASE_D + 2] = 1.0
    case[:, ob.CASE_H0] = T0 + V0
    case[:, ob.CASE_SCALE] = np.abs(T0 + V0)
    case[:, ob.CASE_L0:ob.CASE_L0 + 3] = case[:, ob.CASE_LS0:ob.CASE_LS0 + 3] = L0
    case[:, ob.CASE_LNORM] = np.linalg.norm(L0, axis=1)
    shared = np.zeros(ob.SHARED_COLUMNS)
    shared[ob.SHARED_MOMENTS:ob.SHARED_MOMENTS + 3] = MOMENTS
    shared[ob.SHARED_UP + 2] = 1.0
    gravity = len(forces) > 0
    applies = np.array([True, True, not gravity, not gravity, gravity, False])
    return case, shared, applies


class Outputs:
    """The ensemble's output arrays for ``cases`` cases (no case's samples kept)."""

    def __init__(self, cases: int) -> None:
        self.counters, self.clocks = np.zeros((cases, 3), dtype=np.int64), np.zeros((cases, 3))
        self.status, self.valid, self.steps = (np.zeros(cases, dtype=np.int64) for _ in range(3))
        self.last, self.acc = np.zeros((cases, 8)), np.zeros((cases, ob.ACC_COLUMNS))
        self.keep = np.full(cases, -1, dtype=np.int64)
        self.kept, self.kept_t, self.kept_count = np.zeros((1, 1, 8)), np.zeros((1, 1)), np.zeros(cases, dtype=np.int64)
        self.found, self.fault = np.zeros((cases, 0, 3)), np.zeros((cases, 5))  # (no events)

    def tail(self) -> tuple:
        return self.status, self.valid, self.last, self.acc, self.keep, 1, self.kept, self.kept_t, self.kept_count


def median_time(call, repeats: int) -> float:
    seconds = []
    for _ in range(repeats):
        cuda.synchronize()
        start = time.perf_counter()
        call()
        cuda.synchronize()
        seconds.append(time.perf_counter() - start)
    return float(np.median(seconds))


def cpu_alone(kind: str, y0, times, substeps, model, extra, case, shared, applies, forces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(last states, folded observables, steps) of each case run alone on the CPU by the same kernel."""
    b, n = y0.shape[0], times.shape[0]
    out = Outputs(b)
    for k in range(b):
        y, rows = y0[k].copy(), np.zeros((n, 8))
        rows[0] = y
        counted = np.zeros(3, dtype=np.int64)
        if kind == "dop853":
            code, i = dop853_case(y, times, rows, RTOL, ATOL, MAX_STEPS, 1 << 18, model, counted, np.zeros(3), None, out.found[k],
                                  out.fault[k], None)
        else:
            advance = dmv_advance if kind == "dmv" else rk4_advance
            code, i, counted[0] = advance(y, times, rows, 1, substeps, MAX_STEPS, model, *extra)
        report_whole(k, code, i, rows, times, case, shared, applies, forces, out.status, out.valid, out.last, out.acc, out.keep, 1,
                     out.kept, out.kept_t, out.kept_count, np.zeros(ob.ACC_COLUMNS), np.zeros(1, dtype=np.int64), None, out.fault[k])
        out.steps[k] = counted[0]
    return out.last, out.acc, out.steps


def difference(last: np.ndarray, acc: np.ndarray, cpu_last: np.ndarray, cpu_acc: np.ndarray, case: np.ndarray) -> float:
    """The largest of: |Δ state| / max |state| per component, |Δ cos ϑ_max|, |Δ t| / t of the first
    and last flip, and |Δ max relative drift| (each drift in units of its scale, ``observe.max_drifts``)."""
    scale = np.maximum(np.abs(cpu_last).max(axis=0), 1e-300)
    worst = float(np.max(np.abs(last - cpu_last) / scale))
    worst = max(worst, float(np.max(np.abs(acc[:, ob.ACC_MIN_COS] - cpu_acc[:, ob.ACC_MIN_COS]))))
    for column in (ob.ACC_FIRST, ob.ACC_LAST):
        a, b = acc[:, column], cpu_acc[:, column]
        if not np.array_equal(np.isnan(a), np.isnan(b)):
            return np.inf
        seen = ~np.isnan(b)
        if seen.any():
            worst = max(worst, float(np.max(np.abs(a[seen] - b[seen]) / np.abs(b[seen]))))
    return max(worst, float(np.max(np.abs(ob.max_drifts(acc, case) - ob.max_drifts(cpu_acc, case)))))


def registers_label(cap: int | None) -> str:
    return "" if cap is None else f" (≤ {cap} registers)"


def row(name: str, cases: int, steps: float, kernel_s: float, end_s: float, diff: float, same_steps: bool, identical: bool) -> None:
    print(f"| {name}{registers_label(gpu.MAX_REGISTERS)} | {gpu.THREADS} | {cases:,} | {steps:,.0f} | {kernel_s * 1e3:,.1f} | "
          f"{end_s * 1e3:,.1f} | {cases * steps / kernel_s / 1e9:,.2f} | {cases / kernel_s / 1e6:,.3f} | {diff:.1e} | "
          f"{'yes' if same_steps else 'NO'} | {'yes' if identical else 'no'} |")


def bench_fixed(kind: str, cases: int, check: int, repeats: int) -> None:
    top = kind != "dmv"
    forces = FORCES if top else np.zeros((0, 6))
    model = model_of(FORCES if top else None, formula=kind == "rk4-formula")
    advance = dmv_advance if kind == "dmv" else rk4_advance
    extra = (8, modified_coefficients(MOMENTS)) if kind == "dmv" else ()
    y0 = initial_states(cases, (1.0, 2.0, 30.0) if top else (0.1, 3.0, 0.1))
    times = np.linspace(0.0, 1.0, 11)
    substeps = np.full(cases, 100, dtype=np.int64)
    case, shared, applies = observe_inputs(y0, forces)
    out = Outputs(cases)
    call = lambda: gpu.fixed_step_ensemble(advance, "dmv" if kind == "dmv" else "rk4", y0, times, substeps, MAX_STEPS, model, extra, case, shared, applies, forces,  # noqa: E731
                                           None, out.found, out.fault, out.status, out.valid, out.steps, out.last, out.acc, out.keep, 1, out.kept, out.kept_t,
                                           out.kept_count)
    call()  # compiles
    end_to_end = median_time(call, repeats)
    d = {k: gpu._device_array(v) for k, v in dict(y0=y0, times=times, substeps=substeps, case=case, shared=shared, applies=applies,
                                                forces=forces, found=out.found, fault=out.fault, status=out.status, valid=out.valid, steps=out.steps, last=out.last,
                                                acc=out.acc, keep=out.keep, kept=out.kept, kept_t=out.kept_t,
                                                kept_count=out.kept_count).items()}
    kernel = gpu._fixed_step_kernel(advance, "dmv" if kind == "dmv" else "rk4", 0)
    device_model, table_in_use = gpu._model_to_device(model)  # (a formula load: its table's address in the model)
    launch = lambda: kernel[gpu.blocks(cases), gpu.THREADS](  # noqa: E731
        d["y0"], d["times"], d["substeps"], MAX_STEPS, device_model, gpu._tuple_to_device(extra), d["case"],
        d["shared"], d["applies"], d["forces"], None, d["found"], d["fault"], d["status"], d["valid"], d["steps"], d["last"], d["acc"], d["keep"], 1, d["kept"],
        d["kept_t"], d["kept_count"])
    with gpu._compiling():  # (a launch that compiled anew would get the same options)
        kernel_only = median_time(launch, repeats)
    k = min(check, cases)
    last, acc, steps = cpu_alone(kind, y0[:k], times, 100, model, extra, case[:k], shared, applies, forces)
    diff = difference(out.last[:k], out.acc[:k], last, acc, case[:k])
    row(kind, cases, float(np.mean(out.steps)), kernel_only, end_to_end, diff, np.array_equal(steps, out.steps[:k]),
        np.array_equal(last, out.last[:k]))


def bench_dop853(cases: int, check: int, repeats: int) -> None:
    model = model_of(FORCES)
    y0 = initial_states(cases, (1.0, 2.0, 30.0))
    times = np.linspace(0.0, 10.0, 101)
    case, shared, applies = observe_inputs(y0, FORCES)
    out = Outputs(cases)
    call = lambda: gpu.dop853_ensemble(y0, times, RTOL, ATOL, MAX_STEPS, 1 << 18, model, out.counters, out.clocks, case, shared, applies,  # noqa: E731
                                       FORCES, None, out.found, out.fault, *out.tail())
    call()
    end_to_end = median_time(call, repeats)
    d = {k: gpu._device_array(v) for k, v in dict(y0=y0, times=times, case=case, shared=shared, applies=applies, forces=FORCES,
                                                found=out.found, fault=out.fault, counters=out.counters, clocks=out.clocks, status=out.status, valid=out.valid, last=out.last, acc=out.acc,
                                                keep=out.keep, kept=out.kept, kept_t=out.kept_t, kept_count=out.kept_count).items()}
    grid = cuda.device_array((cases, times.shape[0], 8))
    launch = lambda: gpu._dop853_kernel(0)[gpu.blocks(cases), gpu.THREADS](  # noqa: E731
        0, d["y0"], d["times"], grid, RTOL, ATOL, MAX_STEPS, 1 << 18, gpu._tuple_to_device(model), d["counters"], d["clocks"], d["case"],
        d["shared"], d["applies"], d["forces"], None, d["found"], d["fault"], d["status"], d["valid"], d["last"], d["acc"], d["keep"], 1, d["kept"], d["kept_t"], d["kept_count"])
    with gpu._compiling():  # (a launch that compiled anew would get the same options)
        kernel_only = median_time(launch, repeats)
    k = min(check, cases)
    last, acc, steps = cpu_alone("dop853", y0[:k], times, 0, model, (), case[:k], shared, applies, FORCES)
    diff = difference(out.last[:k], out.acc[:k], last, acc, case[:k])
    row("dop853", cases, float(np.mean(out.counters[:, 0])), kernel_only, end_to_end, diff, np.array_equal(steps, out.counters[:k, 0]),
        np.array_equal(last, out.last[:k]))


def register_cap(text: str) -> int | None:
    return None if text == "default" else positive(text)


def positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer (got {text})")
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=positive, nargs="+", default=[1 << 20])
    parser.add_argument("--dop853-cases", type=positive, nargs="+", default=[1 << 18])
    parser.add_argument("--check", type=positive, default=256, help="cases compared with the CPU run alone")
    parser.add_argument("--threads", type=positive, nargs="+", default=[gpu.THREADS], help="threads per block to try")
    parser.add_argument("--repeats", type=positive, default=5)
    parser.add_argument("--only", nargs="+", default=["rk4", "dmv", "dop853", "rk4-formula"])
    parser.add_argument("--max-registers", type=register_cap, nargs="+", default=[None],
                        help="registers a thread to try (an integer, or default: ptxas's choice)")
    parser.add_argument("--fma", action="store_true", help="compile with fused multiply-adds (NVVM -fma=1; not the CPU's rounding)")
    args = parser.parse_args()
    gpu.FUSED_MULTIPLY_ADD = args.fma
    if config.ENABLE_CUDASIM:
        print("numba's CUDA simulator: the figures below are not a GPU's")
    else:
        device = cuda.get_current_device()
        print(f"device: {device.name.decode() if isinstance(device.name, bytes) else device.name}, "
              f"compute capability {device.compute_capability}, fused multiply-adds {'on' if args.fma else 'off'}")
    print("| method | threads/block | cases | steps/case | kernel ms | end to end ms | G body-steps/s (kernel) | M cases/s (kernel) "
          "| max diff vs CPU | same steps | last states identical |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for cap, threads in ((cap, threads) for cap in args.max_registers for threads in args.threads):
        gpu.THREADS = threads
        if cap != gpu.MAX_REGISTERS:
            gpu.MAX_REGISTERS = cap
            gpu.rebuild_kernels()
        for kind in ("rk4", "dmv", "rk4-formula"):
            if kind in args.only:
                for cases in args.cases:
                    bench_fixed(kind, cases, args.check, args.repeats)
        if "dop853" in args.only:
            for cases in args.dop853_cases:
                bench_dop853(cases, args.check, args.repeats)


if __name__ == "__main__":
    main()
