"""The ensemble on a GPU (``rotlab.ensemble.gpu``, ``rotlab sweep --device cuda``).

Without a GPU (CI) the GPU kernels run in numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, set
before numba is imported: each check runs in a subprocess): the same kernel source, threads run
as Python calling the CPU's compiled functions.  So these tests pin the GPU path's logic — one
sample interval per fixed-step call, dop853's batches of sample grids, the observables, the kept
samples — against the CPU ensemble, bit for bit; the figures and the compiled device code come
from a real GPU (benchmarks/bench_gpu.py, docs/benchmarks.md).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests.conftest import CONFIGS

ROOT = Path(__file__).resolve().parents[1]
SIMULATOR = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1"}
NO_GPU = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}


def _python(code: str, env: dict, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=env, cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout)


def _rotlab(args: list[str], env: dict, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rotlab", *args], env=env, cwd=cwd, capture_output=True, text=True, timeout=600)


def test_every_gpu_method_gives_the_cpu_ensembles_numbers_bit_for_bit():
    """rk4, rkmk4, dmv and dop853 on four scenes (free body near the intermediate axis, heavy top,
    general loads, gyrostat): status, samples, steps, evaluations, flip period, nutation, every
    max drift, the kept samples (every 3rd, cases 0 and 4) and the failures are ``np.array_equal``
    to the CPU ensemble's; dop853's sample grids in batches of 2 cases (3 launches for 5 cases)."""
    result = _python("""
        import numpy as np
        from rotlab.ensemble import gpu
        from rotlab.ensemble.block import run_block
        from rotlab.methods.base import Settings
        from rotlab.methods.registry import get_method
        from tests.test_ensemble import _scenes

        RUNS = [("sweep_flip.toml", 3.0, "rk4", {"step": 1e-3}), ("sweep_flip.toml", 3.0, "dmv", {"step": 5e-3, "order": 8}),
                ("sweep_flip.toml", 3.0, "dop853", {}), ("lagrange.toml", 0.5, "rk4", {"step": 1e-4}),
                ("lagrange.toml", 0.5, "dop853", {}), ("general.toml", 0.5, "rkmk4", {"step": 1e-3}),
                ("general.toml", 0.5, "dop853", {}), ("gyrostat.toml", 4.0, "rk4", {"step": 1e-2}), ("gyrostat.toml", 4.0, "dop853", {})]
        FIELDS = ("status", "valid", "steps", "rejected", "evaluations", "flip_period", "reversals", "max_nutation_deg")
        for config, end, method, changes in RUNS:
            scenes = _scenes(config, end, method, changes)
            t = scenes[0].scenario.time.sample_times()
            gpu.SIMULATED_MEMORY = 2 * t.shape[0] * 8 * 8 / gpu.MEMORY_FRACTION  # two cases' grids a launch
            args = (scenes, get_method(method), Settings.of(scenes[0].scenario.solver), t, [0, 4], 3, [None] * len(scenes))
            cpu, cuda = run_block(*args), run_block(*args, device="cuda")
            assert all(np.array_equal(getattr(cpu, f), getattr(cuda, f), equal_nan=True) for f in FIELDS), (config, method)
            assert cpu.max_drift.keys() == cuda.max_drift.keys() and all(np.array_equal(cpu.max_drift[k], cuda.max_drift[k]) for k in cpu.max_drift)
            assert cpu.kept.keys() == cuda.kept.keys() == {0, 4}
            assert all(np.array_equal(cpu.kept[k][0], cuda.kept[k][0]) and np.array_equal(cpu.kept[k][1], cuda.kept[k][1]) for k in cpu.kept)
            assert cpu.failure == cuda.failure
            print(config, method, "identical", t.shape[0])
    """, SIMULATOR)
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stdout.count("identical") == 9


def test_a_case_that_blows_up_on_the_gpu_stops_where_it_does_on_the_cpu():
    """A heavy top whose spin overflows (ω₀ = 1e200 rad/s: ω² is not finite) stops at its first sample
    with the CPU's failure message, its last valid state kept; its neighbours are unaffected."""
    result = _python("""
        import numpy as np
        from rotlab.ensemble.block import run_block
        from rotlab.methods.base import Settings
        from rotlab.methods.registry import get_method
        from tests.test_ensemble import _scenes

        for method, changes in (("rk4", {"step": 1e-4}), ("dop853", {})):
            scenes = _scenes("lagrange.toml", 0.2, method, changes)
            bad = scenes[2].state0.copy()
            bad[4:7] = 1e200
            scenes[2].__dict__["state0"] = bad  # (a cached property)
            t = scenes[0].scenario.time.sample_times()
            args = (scenes, get_method(method), Settings.of(scenes[0].scenario.solver), t, [2], 1, [None] * 5)
            cpu, cuda = run_block(*args), run_block(*args, device="cuda")
            assert cuda.failure == cpu.failure and cuda.failure[2] is not None and cuda.failure[1] is None, cuda.failure
            assert np.array_equal(cuda.valid, cpu.valid) and cuda.valid[2] == 1 and cuda.valid[1] == t.shape[0]
            assert np.array_equal(cuda.kept[2][1][-1], bad)
            print(method, cuda.failure[2])
    """, SIMULATOR)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "rk4" in result.stdout and "dop853" in result.stdout


def test_events_on_the_gpu_are_the_cpu_ensembles_bit_for_bit():
    """A scene's events on the (simulated) GPU, rk4 and dop853: located (two events, one with
    ``record`` formulas), a ``when`` that turns non-finite mid-run, a ``record`` formula that is
    not finite at its event, a ``when`` not finite at the first sample, a terminal event: every
    event column, the samples made, the last states, the kept samples (a terminal event's state
    last) and the failure messages ``np.array_equal`` to the CPU ensemble's; no cached function
    specialised on a Python function object."""
    result = _python("""
        import numpy as np
        from rotlab.ensemble.block import run_block
        from rotlab.methods.base import Settings
        from rotlab.methods.registry import get_method
        from tests.test_ensemble import _scenes

        SETS = {"located": [{"name": "flip", "when": "omega[1]", "direction": "falling", "record": ["omega[0]", "t*q[0]"]},
                            {"name": "up", "when": "omega[2] - 0.005", "direction": "both"}],
                "when stops": [{"name": "flip", "when": "omega[1]", "direction": "falling"},
                               {"name": "late", "when": "sqrt(omega[0] + 1.0 - t) - 10", "direction": "both"}],
                "record stops": [{"name": "flip", "when": "omega[1]", "direction": "falling", "record": ["log(1.3 - t)"]}],
                "first sample": [{"name": "never", "when": "log(-omega[1])"}],
                "terminal": [{"name": "flip", "when": "omega[1]", "direction": "falling", "terminal": True},
                             {"name": "cross", "when": "omega[0]"}]}
        for method, changes in (("rk4", {"step": 1e-3}), ("dop853", {})):
            for name, events in SETS.items():
                scenes = _scenes("sweep_flip.toml", 3.0, method, changes, events=events)
                t = scenes[0].scenario.time.sample_times()
                args = (scenes, get_method(method), Settings.of(scenes[0].scenario.solver), t, [0, 4], 3, [None] * len(scenes))
                cpu, cuda = run_block(*args), run_block(*args, device="cuda")
                assert cpu.events.keys() == cuda.events.keys() and len(cpu.events) == 3 * len(events)
                assert all(np.array_equal(cpu.events[k], cuda.events[k], equal_nan=True) for k in cpu.events), name
                assert np.array_equal(cpu.valid, cuda.valid) and cpu.failure == cuda.failure, name
                assert np.array_equal(cpu.last, cuda.last) and np.array_equal(cpu.status, cuda.status), name
                assert all(np.array_equal(cpu.kept[k][j], cuda.kept[k][j]) for k in (0, 4) for j in (0, 1)), name
                stopped = sum(f is not None for f in cuda.failure)
                assert stopped == {"located": 0, "when stops": 5, "record stops": 3, "first sample": 5, "terminal": 0}[name], (name, cuda.failure)
                assert name != "terminal" or (np.all(cuda.valid < t.shape[0]) and [d["ended by"] for d in cuda.details] == [d["ended by"] for d in cpu.details])
                assert name != "located" or np.all(cuda.events["event_flip_count"] == 1)
                print(method, name, "identical")
        # the cached functions the GPU path reaches are keyed on names, not on Python function objects (their disk
        # cache entries would pile up, unusable by later processes, until numba failed to save it: ReferenceError)
        from numba import types
        from rotlab.ensemble.event_scan import scan_events
        assert scan_events.signatures and not any(isinstance(a, types.Dispatcher) for sig in scan_events.signatures for a in sig)
    """, SIMULATOR)
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stdout.count("identical") == 10


def _small_sweep(tmp_path: Path, extra: str = "") -> Path:
    text = (CONFIGS / "sweep_flip.toml").read_text().replace("end = 20.0", "end = 1.0")
    path = tmp_path / "small.toml"
    path.write_text(text + extra)
    return path


def test_a_sweep_on_the_simulated_gpu_writes_the_cpu_sweeps_results(tmp_path):
    """``rotlab sweep --device cuda``, with an event: results.csv (the event's columns among
    them) byte for byte the CPU sweep's; the terminal says where the cases ran."""
    config = _small_sweep(tmp_path, '\n[[events]]\nname = "half_turn"\nwhen = "q[0]"\nrecord = ["omega[1]"]\n')
    gpu = _rotlab(["sweep", str(config), "--device", "cuda", "-o", str(tmp_path / "gpu")], SIMULATOR, tmp_path)
    cpu = _rotlab(["sweep", str(config), "-o", str(tmp_path / "cpu")], NO_GPU, tmp_path)
    assert gpu.returncode == 0 and cpu.returncode == 0, gpu.stderr + cpu.stderr
    assert (tmp_path / "gpu" / "results.csv").read_bytes() == (tmp_path / "cpu" / "results.csv").read_bytes()
    assert "event_half_turn_count" in (tmp_path / "gpu" / "results.csv").read_text().splitlines()[0]
    assert "one thread per case on the GPU" in gpu.stdout


def test_without_a_gpu_cuda_is_refused_in_one_line_and_nothing_is_written(tmp_path):
    """No GPU: ``--device cuda`` and ``[sweep] device = "cuda"`` each exit 2 with one line naming
    the option or key; no output directory is made (never a silent CPU run)."""
    config = _small_sweep(tmp_path)
    asked = _rotlab(["sweep", str(config), "--device", "cuda", "-o", str(tmp_path / "a")], NO_GPU, tmp_path)
    in_file = config
    in_file.write_text(in_file.read_text().replace("samples = 4", "samples = 4\ndevice = \"cuda\""))
    from_file = _rotlab(["sweep", str(in_file), "-o", str(tmp_path / "b")], NO_GPU, tmp_path)
    for result, where in ((asked, "--device"), (from_file, "sweep.device")):
        assert result.returncode == 2, result.stdout + result.stderr
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"rotlab: error: {where}: no CUDA GPU found"), lines
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


@pytest.mark.parametrize("args, change, message", [
    (["--device", "tpu"], None, "--device: must be cpu or cuda (got 'tpu')"),
    (["--device", "cuda", "--timeout", "5"], None, "--device: cuda runs the cases together in one kernel: not with --timeout"),
    (["--device", "cuda", "--dask", "tcp://127.0.0.1:1"], None, "--device: cuda runs on this machine's GPU: not with --dask"),
    (["--device", "cuda"], ('method = "rk4"', 'method = "taylor"'), "method 'taylor' has no GPU kernel"),
    (["--device", "cuda"], ("[sweep.parameters]", "[sweep.parameters]\n\"body.principal_moments[0]\" = [1.0e-4, 1.1e-4]"),
     "only initial conditions may vary"),
])
def test_what_the_gpu_cannot_run_is_refused_in_one_line(tmp_path, args, change, message):
    """With a (simulated) GPU: a device other than cpu/cuda, --timeout or --dask with cuda, a
    method without a GPU kernel, a sweep that is not over initial states: exit 2, one line."""
    config = _small_sweep(tmp_path)
    if change is not None:
        text = config.read_text()
        assert change[0] in text
        config.write_text(text.replace(change[0], change[1], 1))
    result = _rotlab(["sweep", str(config), *args, "-o", str(tmp_path / "out")], SIMULATOR, tmp_path)
    assert result.returncode == 2, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], lines
    assert not (tmp_path / "out").exists()


def test_a_broken_cuda_set_up_and_a_method_without_a_gpu_kernel_are_refused_in_one_line(tmp_path):
    """No simulator: a driver path that does not exist (numba.cuda's import raises) is "no usable
    CUDA GPU"; a taylor sweep is refused for its method before the GPU is looked for."""
    config = _small_sweep(tmp_path)
    broken = _rotlab(["sweep", str(config), "--device", "cuda", "-o", str(tmp_path / "a")],
                     {**NO_GPU, "NUMBA_CUDA_DRIVER": "/nonexistent/libcuda.so"}, tmp_path)
    config.write_text(config.read_text().replace('method = "rk4"', 'method = "taylor"'))
    taylor = _rotlab(["sweep", str(config), "--device", "cuda", "-o", str(tmp_path / "b")], NO_GPU, tmp_path)
    for result, message in ((broken, "--device: no usable CUDA GPU"), (taylor, "method 'taylor' has no GPU kernel")):
        lines = result.stderr.strip().splitlines()
        assert result.returncode == 2 and len(lines) == 1 and message in lines[0], result.stderr[-2000:]
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_auto_choosing_a_method_without_a_gpu_kernel_says_so(tmp_path):
    """``auto`` at rtol 1e-6 chooses taylor for the flip sweep: the refusal names auto's choice and
    the methods to give instead."""
    config = _small_sweep(tmp_path)
    text = config.read_text()
    config.write_text(text.replace('method = "rk4"', 'method = "auto"\nrtol = 1e-6').replace("step = ", "# step = "))
    result = _rotlab(["sweep", str(config), "--device", "cuda", "-o", str(tmp_path / "out")], SIMULATOR, tmp_path)
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and "auto chose" in lines[0] and "give solver.method, one of rk4" in lines[0], lines


def test_the_api_honours_the_files_device_and_a_gpu_failure_is_one_line(tmp_path):
    """``run_cases(plan(file))`` with ``[sweep] device = "cuda"`` and no GPU raises the
    ``InputError`` naming sweep.device (never a silent CPU run); in the simulator, a CUDA error in
    the kernel call (here: out of memory, raised by hand) ends ``rotlab sweep`` with one line, exit 1."""
    config = _small_sweep(tmp_path)
    config.write_text(config.read_text().replace("samples = 4", 'samples = 4\ndevice = "cuda"', 1))
    api = _python(f"""
        from rotlab.errors import InputError
        from rotlab.sweep.runner import plan, run_cases
        try:
            run_cases(plan({str(config)!r}))
        except InputError as exc:
            print("refused:", exc)
    """, NO_GPU)
    assert "refused: sweep.device: no CUDA GPU found" in api.stdout, api.stdout + api.stderr
    failing = _python(f"""
        import sys
        from rotlab.ensemble import gpu
        def out_of_memory(*args, **kwargs):
            raise MemoryError("cuMemAlloc results in CUDA_ERROR_OUT_OF_MEMORY")
        gpu.fixed_step_ensemble = out_of_memory
        from rotlab.cli import main
        sys.argv = ["rotlab", "sweep", {str(config)!r}, "-o", {str(tmp_path / "out")!r}]
        main()
    """, SIMULATOR)
    lines = failing.stderr.strip().splitlines()
    assert failing.returncode == 1 and len(lines) == 1, failing.stderr[-2000:]
    assert lines[0] == "rotlab: error: the GPU run failed: MemoryError: cuMemAlloc results in CUDA_ERROR_OUT_OF_MEMORY", lines


def test_the_gpu_benchmark_runs_without_rotlabs_other_dependencies():
    """benchmarks/bench_gpu.py in the simulator: every row's steps and last states equal the CPU's
    run alone, and it imported neither pydantic, rerun nor typer (a bare GPU machine has none), nor
    rotlab's configuration models (its formula row parses a formula with the parser alone).  On
    the numba cache of the rotlab it imports (run from the repository's root: the checkout's, the
    installed one in a development install), not one of its own: the kernels other tests compiled
    there load.  Loading a kernel's cache index unpickles every type in it, so each is declared
    where numpy alone is imported (a Python torque's ``UserTorque`` in ``rotlab.core.model``); an
    index written before it moved there names the configuration's module, and fails this once."""
    result = _python("""
        import runpy, sys
        sys.argv = ["bench_gpu.py", "--cases", "2", "--dop853-cases", "2", "--check", "2", "--repeats", "1"]
        runpy.run_path("benchmarks/bench_gpu.py", run_name="__main__")
        loaded = sorted(m for m in ("pydantic", "rerun", "typer", "rotlab.config.models", "rotlab.scene.scene") if m in sys.modules)
        print("loaded:", loaded)
    """, SIMULATOR)
    assert result.returncode == 0, result.stderr[-3000:]
    rows = [line for line in result.stdout.splitlines() if line.startswith(("| rk4", "| dmv", "| dop853"))]
    assert len(rows) == 4 and any(line.startswith("| rk4-formula") for line in rows) and all(line.rstrip().endswith("| yes | yes |") for line in rows), result.stdout
    assert "loaded: []" in result.stdout


def test_the_kernels_are_compiled_for_the_cpus_rounding(monkeypatch):
    """A GPU computes the CPU's bits (measured on an H100: rk4, dmv, rkmk4 0 ulp over 1,000 steps,
    docs/benchmarks.md) only if NVVM is told ``-fma=0`` (its default fuses a·b + c into one
    rounding) and generates the code itself: with link-time optimisation, nvJitLink would (and
    ``cuda.jit``'s decorator form silently drops ``lto=False``, so ``_jit`` must not use it)."""
    from numba import config
    from numba.cuda.cudadrv import nvvm

    from rotlab.ensemble import gpu

    monkeypatch.setattr(config, "ENABLE_CUDASIM", False)
    seen: list[dict] = []
    monkeypatch.setattr(nvvm, "compile_ir", lambda llvmir, **options: seen.append(options) or b"")
    with gpu._compiling():
        nvvm.compile_ir("ir", opt=3, arch="compute_90")
    nvvm.compile_ir("ir", opt=3)  # outside: untouched
    assert seen == [{"fma": False, "opt": 3, "arch": "compute_90"}, {"opt": 3}]
    monkeypatch.setattr(gpu, "FUSED_MULTIPLY_ADD", True)
    with gpu._compiling():
        nvvm.compile_ir("ir", fastmath=False)
    assert seen[-1] == {"fma": True, "fastmath": False}

    def kernel(a):
        pass

    assert gpu._jit(kernel).targetoptions["lto"] is False
    monkeypatch.setattr(gpu, "MAX_REGISTERS", 128)  # (bench_gpu.py --max-registers)
    assert gpu._jit(kernel).targetoptions["max_registers"] == 128


def test_a_gpu_result_that_is_not_the_cpus_stops_the_sweep_in_one_line(tmp_path):
    """Each GPU call's cases 0, b/3, 2b/3 and b − 1 are run again on the CPU (``cross_check``):
    a device result that is not the CPU's (here one case's last state corrupted by hand after the
    kernel, Λ = 0, as dop853 without its stages left it on an H100 and an H200) ends ``rotlab
    sweep`` with one line naming the sweep's case, exit 1; the same sweep uncorrupted passes (the
    simulator's GPU is the CPU bit for bit)."""
    config = _small_sweep(tmp_path)
    failing = _python(f"""
        import sys
        from rotlab.ensemble import gpu
        run = gpu.fixed_step_ensemble
        def corrupted(*args):
            run(*args)
            args[18][4, :4] = 0.0  # ``last`` of the block's case 4 (of 12: one call): Λ = 0, as the device gave
        gpu.fixed_step_ensemble = corrupted
        from rotlab.cli import main
        sys.argv = ["rotlab", "sweep", {str(config)!r}, "--device", "cuda", "-o", {str(tmp_path / "out")!r}]
        main()
    """, SIMULATOR)
    lines = failing.stderr.strip().splitlines()
    assert failing.returncode == 1 and len(lines) == 1, failing.stderr[-2000:]
    assert lines[0].startswith("rotlab: error: the GPU's result for case 4 differs from the CPU's (last state [0, 0, 0, 0, "), lines
    assert lines[0].endswith("run this sweep on the CPU (--device cpu)"), lines
    assert not (tmp_path / "out" / "results.csv").exists()


def test_a_gpu_implementation_declared_after_cuda_is_enabled_is_registered(monkeypatch):
    """A device session's scripts enabled CUDA (``targets.enable_cuda``) before importing
    ``rotlab.core.dop853``: its GPU-only stages (``gpu_overload``) were never registered for the
    device, which compiled the CPU's placeholder instead (no stages: PTX with 910 double
    multiplications instead of 3,068) and ran dop853 from a zero state.  An implementation declared
    after ``enable_cuda`` is registered at once, as ``overload``'s are; before it, by ``enable_cuda``."""
    from numba import config

    from rotlab.core import targets

    registered: list[tuple] = []
    monkeypatch.setattr(targets, "_register_cuda", lambda func, options, impl: registered.append((func, impl)))
    monkeypatch.setattr(targets, "_GPU_ONLY", [])
    monkeypatch.setattr(targets, "_FOR_CUDA", [])
    monkeypatch.setattr(config, "ENABLE_CUDASIM", False)

    def before(): ...
    def after(): ...
    def on_the_gpu(): ...

    monkeypatch.setattr(targets, "_cuda_enabled", False)
    targets.gpu_overload(before)(on_the_gpu)
    assert registered == []
    monkeypatch.setattr(targets, "_cuda_enabled", True)  # (what enable_cuda does, without numba-cuda's registry)
    targets.gpu_overload(after)(on_the_gpu)
    assert registered == [(after, on_the_gpu)]
    monkeypatch.setattr(targets, "_cuda_enabled", False)
    targets.enable_cuda()
    assert registered[1:] == [(before, on_the_gpu), (after, on_the_gpu)]
