"""``rotlab.ensemble.cross_check``: when a GPU block's case is the CPU's, and what is reported when not."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from rotlab.core import opcodes
from rotlab.core.torques import T_W
from rotlab.ensemble.cross_check import TOLERANCE, checked_cases, disagreement, library_calls, message


def _result(b: int, last: np.ndarray | None = None, **changes) -> SimpleNamespace:
    state = np.tile([0.6, 0.0, 0.8, 0.0, 0.01, 10.0, -0.02, 0.0], (b, 1)) if last is None else last
    fields = dict(status=np.zeros(b, dtype=np.int64), valid=np.full(b, 401), last=state,
                  flip_period=np.full(b, 4.5), max_nutation_deg=np.full(b, 179.7),
                  max_drift={"energy": np.full(b, 5e-12), "quaternion_norm": np.full(b, 2e-12)},
                  events={"event_flip_count": np.full(b, 3.0), "event_flip_first_s": np.full(b, 1.25)})
    fields.update(changes)
    return SimpleNamespace(**fields)


def _cpu_of(gpu: SimpleNamespace, positions: list[int]) -> SimpleNamespace:
    return SimpleNamespace(status=gpu.status[positions], valid=gpu.valid[positions], last=gpu.last[positions].copy(),
                           flip_period=gpu.flip_period[positions], max_nutation_deg=gpu.max_nutation_deg[positions],
                           max_drift={k: v[positions] for k, v in gpu.max_drift.items()},
                           events={k: v[positions].copy() for k, v in gpu.events.items()})


def test_the_checked_cases_are_the_first_the_last_and_two_between():
    assert checked_cases(1) == [0]
    assert checked_cases(2) == [0, 1]
    assert checked_cases(12) == [0, 4, 8, 11]
    assert checked_cases(4096) == [0, 1365, 2730, 4095]


def test_equal_results_and_differences_within_the_tolerance_pass():
    gpu = _result(12, flip_period=np.full(12, math.nan))  # NaN against NaN: no flip on either device
    positions = checked_cases(12)
    cpu = _cpu_of(gpu, positions)
    assert disagreement(gpu, cpu, positions) is None
    cpu.last[1, 5] *= 1 + 0.5 * TOLERANCE  # a library function's last bit carried through a run
    cpu.max_drift["energy"][2] += 0.5 * TOLERANCE
    assert disagreement(gpu, cpu, positions) is None


def test_each_kind_of_difference_names_the_case_and_what_differs():
    positions = checked_cases(12)
    gpu = _result(12)
    cpu = _cpu_of(gpu, positions)
    gpu.last[4, :4] = 0.0  # the garbage an H100 gave (dop853, general.toml)
    assert disagreement(gpu, cpu, positions) == (4, "last state [0, 0, 0, 0, 0.01, 10, -0.02, 0] against "
                                                    "[0.6, 0, 0.8, 0, 0.01, 10, -0.02, 0], relative difference 8.0e-02")
    gpu = _result(12)
    gpu.last[8, 5] = math.inf  # not finite where the CPU's is
    assert disagreement(gpu, cpu, positions)[0] == 8
    gpu = _result(12, valid=np.array([401] * 11 + [17]), status=np.array([0] * 11 + [1]))
    assert disagreement(gpu, cpu, positions) == (11, "status 1 against 0, 17 samples against 401")
    gpu = _result(12, flip_period=np.array([4.5] * 11 + [math.nan]))
    assert disagreement(gpu, cpu, positions) == (11, "flip period nan against 4.5")
    gpu = _result(12)
    gpu.max_drift["quaternion_norm"][0] = 3e-6
    assert disagreement(gpu, cpu, positions) == (0, "max quaternion_norm drift 3e-06 against 2e-12")
    gpu = _result(12)
    gpu.max_nutation_deg[4] = 179.7 * (1 + 10 * TOLERANCE)
    assert disagreement(gpu, cpu, positions)[0] == 4
    gpu = _result(12)
    gpu.events["event_flip_count"][11] = 2.0  # an occurrence the CPU found and the GPU did not
    assert disagreement(gpu, cpu, positions) == (11, "event_flip_count 2 against 3")
    gpu = _result(12)
    gpu.events["event_flip_first_s"][0] = 1.25 + 10 * TOLERANCE
    assert disagreement(gpu, cpu, positions)[0] == 0
    gpu, cpu.last[2, 5] = _result(12), -math.inf  # (case 8) not finite on both, but not the same
    gpu.last[8, 5] = math.inf
    assert disagreement(gpu, cpu, positions)[0] == 8


def test_a_drift_is_compared_relative_to_itself_above_one():
    """A diverging case's drift (1e12) a last bit apart is the same drift; 1e-12 against 2e-6 is not."""
    positions = checked_cases(12)
    gpu = _result(12)
    gpu.max_drift["energy"][:] = 1e12
    cpu = _cpu_of(gpu, positions)
    cpu.max_drift["energy"][1] = 1e12 * (1 + 2.0 ** -52)
    assert disagreement(gpu, cpu, positions) is None
    gpu.max_drift["energy"][0], cpu.max_drift["energy"][0] = 2e-6, 1e-12
    assert disagreement(gpu, cpu, positions) == (0, "max energy drift 2e-06 against 1e-12")


def test_what_calls_a_library_function_on_the_gpu_is_named_in_the_message():
    """A harmonic torque (``sin``), rkmk4 (``sin``, ``cos``) and a formula's library functions (a
    load's, an event's) may part from the CPU in the last bit, which a chaotic motion amplifies:
    their disagreement says so; any other is the kernels'."""
    from rotlab.config.loader import load_scenario
    from rotlab.scene.scene import build_scene
    from tests.conftest import CONFIGS

    general, lagrange = (build_scene(load_scenario(CONFIGS / name)).model for name in ("general.toml", "lagrange.toml"))
    assert library_calls(general, "dop853") == "a harmonic torque's sin"
    assert library_calls(lagrange, "rk4") is None
    assert library_calls(lagrange, "rkmk4") == "rkmk4's sin and cos"
    steady = SimpleNamespace(terms=general.terms.copy(), expressions=None)
    steady.terms[:, T_W] = 0.0  # constant torques: no sin is called
    assert library_calls(steady, "rk4") is None
    detumbling = build_scene(load_scenario(CONFIGS / "detumbling.toml")).model  # B-dot: products, sums, min and max of the field's cos and sin
    assert library_calls(detumbling, "rk4") == "a formula load's library functions"
    damped = SimpleNamespace(terms=None, expressions=SimpleNamespace(code=np.array([[opcodes.VAR, 1, 0], [opcodes.CONST, 0, 0], [opcodes.MUL, 0, 0]])))
    assert library_calls(damped, "rk4") is None  # −k ω: correctly rounded operations alone
    assert library_calls(lagrange, "dop853", [[[(opcodes.VAR, 1)], [(opcodes.VAR, 0), (opcodes.EXP, 0)]]]) == "an event formula's library functions"
    assert library_calls(lagrange, "dop853", [[[(opcodes.VAR, 1), (opcodes.CONST, 2.0), (opcodes.DIV, 0)]]]) is None
    assert message("case 7", "status 1 against 0", None) == (
        "the GPU's result for case 7 differs from the CPU's (status 1 against 0): the GPU kernels are wrong for this scene; "
        "run this sweep on the CPU (--device cpu)")
    assert message("case 7", "x", "a harmonic torque's sin").endswith(  # (both causes: a difference cannot say which it has)
        "(x): the GPU kernels are wrong for this scene, or a harmonic torque's sin, which may differ in its last bit on the GPU, "
        "was amplified by this motion; run this sweep on the CPU (--device cpu)")
