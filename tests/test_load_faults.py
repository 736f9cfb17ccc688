"""A load that fails never ends in a success: every formula that is not finite, every Python
torque that raises, changes shape or returns a non-finite value stops the run in every method
that accepts it, naming the load, the time and what was wrong; a Python torque that numba
cannot type is an input error before any step; Ctrl-C reaches a slow Python torque; an
adaptive run whose steps collapse stops by itself."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time
import tomllib

import numpy as np
import pytest

import rotlab
from rotlab.config.loader import parse_scenario
from rotlab.errors import InputError, RunFailure
from rotlab.methods.registry import METHODS, get_method
from tests.conftest import VALID_BODY

FREE = VALID_BODY + "[initial]\nomega = [0.1, 0.2, 0.3]\n[time]\nend = 2.0\nsample_rate = 100\n"

# (formula for torque[1], the first time t* where it is not finite): each is finite on [0, t*)
SINGULAR_FORMULAS = [
    ("t**(-1)", 0.0),
    ("1/t", 0.0),
    ("log(t)", 0.0),
    ("(0.7 - t)**(-0.5)", 0.7),
    ("sqrt(1.25 - t)", 1.25),
    ("log(1.5 - t)", 1.5),
]


def _load(text: str, method: str = "auto"):
    return parse_scenario(tomllib.loads(text), source="test.toml", overrides={"solver.method": method})


def _scenario(formula: str, method: str):
    return _load(FREE + f'[[loads]]\ntype = "expression"\nframe = "body"\ntorque = ["0", "{formula}", "0"]\n', method)


def _methods_accepting(scenario) -> list[str]:
    from rotlab.scene.scene import build_scene

    scene = build_scene(scenario)
    return [name for name in METHODS if get_method(name).unsupported(scene) is None]


@pytest.mark.parametrize("formula, singular_at", SINGULAR_FORMULAS)
def test_a_formula_that_is_not_finite_stops_every_method_that_runs_it(formula, singular_at, capfd):
    methods = _methods_accepting(_scenario(formula, "auto")) + ["auto"]
    assert {"rk4", "dop853", "taylor"} <= set(methods)
    for method in methods:
        with pytest.raises(RunFailure) as info:
            rotlab.simulate(_scenario(formula, method))
        message = str(info.value)
        # an adaptive method may never step past a singular point that its steps approach: then it
        # stops there, its step size collapsed, with no non-finite value to name
        collapsed = method in ("taylor", "dop853", "auto") and "step size fell below" in message
        assert f"loads[0].torque[1] = '{formula}'" in message or collapsed, (method, message)
        kept = info.value.trajectory
        assert kept.t[-1] <= singular_at + 1e-12 and np.all(np.isfinite(kept.omega)), method
        # the time named is where the formula failed: within a step of its singular point
        named = float(message.split(" at t = ")[1].split(" s")[0])
        assert singular_at <= named <= singular_at + 0.011, (method, message)
    err = capfd.readouterr().err
    assert "Exception ignored" not in err and "Traceback" not in err


def test_a_singular_formula_run_exits_1_with_one_line_and_keeps_the_valid_samples(cli, write, tmp_path):
    (tmp_path / "neg.rrd").write_bytes(b"a good recording")
    path = write("neg.toml", FREE + '[[loads]]\ntype = "expression"\nframe = "body"\ntorque = ["0", "sqrt(0.5 - t)", "0"]\n')
    result = cli("run", str(path), "-o", "neg.rrd", "-q")
    assert result.exit_code == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "loads[0].torque[1] = 'sqrt(0.5 - t)' is not finite at t = 0.5" in lines[0], result.stderr
    assert (tmp_path / "neg.rrd").read_bytes() == b"a good recording"
    assert (tmp_path / "neg.partial.rrd").exists()


def test_a_controller_load_is_named_by_its_kind():
    text = VALID_BODY + ("[initial]\nomega = [0.1, 0.2, 0.3]\n[time]\nend = 1.0\nsample_rate = 100\n"
                         '[[loads]]\ntype = "damping"\ncoefficient = 0.01\n'
                         '[[loads]]\ntype = "expression"\nframe = "space"\ntorque = ["0", "0", "log(0.25 - t)"]\n')
    with pytest.raises(RunFailure, match=r"loads\[1\]\.torque\[2\] = 'log\(0.25 - t\)' is not finite at t = 0\.25"):
        rotlab.simulate(_load(text, "dop853"))


@pytest.mark.parametrize("method", ["taylor", "rk4", "dop853"])
@pytest.mark.parametrize("frame", ["body", "space"])
def test_the_failing_component_is_named_not_a_neighbour_its_nan_reaches(method, frame):
    """taylor: the NaN of torque[1] enters the state's series and makes torque[2]'s higher
    coefficients NaN too; the fault named is still torque[1] at order 0."""
    text = FREE + (f'[[loads]]\ntype = "expression"\nframe = "{frame}"\n'
                   'torque = ["0.1*sin(t)", "0.05*omega[0]**2 - 0.01*t**(-2)", "exp(-t)*q[1]"]\n')
    with pytest.raises(RunFailure, match=r"loads\[0\]\.torque\[1\] = '0.05\*omega\[0\]\*\*2 - 0.01\*t\*\*\(-2\)' is not finite at t = 0 s"):
        rotlab.simulate(_load(text, method))


def _raises_late(t, q, omega):
    if t > 1.2345:
        raise ValueError("too late")
    return np.array([0.0, 0.1, 0.0])


def _shrinks(t, q, omega):
    if t > 0.5:
        return np.array([0.0, 0.1])
    return np.array([0.0, 0.1, 0.0])


def _out_of_bounds(t, q, omega):
    return (q[10], 0.0, 0.0)


def _not_finite_later(t, q, omega):
    return (np.sqrt(1.0 - t), 0.0, 0.0)


PYTHON_FAULTS = [  # (function, words in the message, the first time it fails)
    (_raises_late, "_raises_late(t, q, omega) raised ValueError: too late", 1.2345),
    (_shrinks, "_shrinks(t, q, omega) returned 2 values", 0.5),
    (_out_of_bounds, "_out_of_bounds(t, q, omega) raised IndexError: index 10 is out of bounds", 0.0),
    (_not_finite_later, "_not_finite_later(t, q, omega) returned a value that is not finite (M[0])", 1.0),
]


@pytest.mark.parametrize("fn, words, fails_at", PYTHON_FAULTS, ids=[f[0].__name__ for f in PYTHON_FAULTS])
@pytest.mark.parametrize("method", ["auto", "rk4", "rkmk4", "dop853"])
def test_a_python_torque_that_fails_stops_the_run(fn, words, fails_at, method, capfd):
    with pytest.raises(RunFailure) as info:
        rotlab.simulate(_load(FREE, method), torque=fn)
    message = str(info.value)
    assert words in message, message
    named = float(message.split(" at t = ")[1].split(" s")[0])
    assert fails_at <= named <= fails_at + 0.011, message
    assert "nan" not in message  # the state named is the finite one the function saw
    assert not info.value.trajectory.ok and info.value.trajectory.t[-1] <= fails_at + 1e-12
    err = capfd.readouterr().err
    assert "Exception ignored" not in err and "Traceback" not in err


@pytest.mark.parametrize("body, words", [
    ("return ('a', 'b', 'c')", "values of type"),
    ("return (1j, 0.0, 0.0)", "complex128"),
    ("return (0.0, 1.0)", "2 values"),
    ("return undefined_name(t)", "NameError: name 'undefined_name' is not defined"),
    ("return 1.0", "returns float64"),
])
def test_a_python_torque_numba_cannot_use_is_an_input_error(body, words):
    namespace: dict = {"np": np}
    exec(f"def torque(t, q, omega):\n    {body}\n", namespace)
    with pytest.raises(InputError, match="torque") as info:
        rotlab.simulate(_load(FREE), torque=namespace["torque"])
    assert words in str(info.value)


def test_mixed_integer_and_float_results_are_numbers():
    traj = rotlab.simulate(_load(FREE, "rk4"), torque=lambda t, q, omega: (0, 1, 0.0))
    free = rotlab.simulate(_load(FREE, "rk4"), torque=lambda t, q, omega: (0.0, 1.0, 0.0))
    assert traj.ok and np.array_equal(traj.omega, free.omega)


SLOW_TORQUE = textwrap.dedent("""
    import sys, time
    import numpy as np
    import rotlab
    from rotlab.errors import Interrupted

    def slow(t, q, omega):  # after t = 0.05 s, ~0.1-0.3 s a call: a kernel that never returns to Python for minutes
        s = 0.0
        for i in range(20_000_000 if t > 0.05 else 1):
            s += np.sin(i * 1e-9)
        return (0.0, s * 1e-12, 0.0)

    import tomllib
    from rotlab.config.loader import parse_scenario
    scenario = parse_scenario(tomllib.loads(sys.argv[1]), source="slow.toml", overrides={"solver.method": "dop853"})
    rotlab.simulate(scenario, torque=slow, duration=0.02)  # compiles slow and the kernels
    print("ready", flush=True)
    start = time.monotonic()
    from rotlab.compile_apart import compiling_refused
    try:
        with compiling_refused():  # a Ctrl-C must land in the slow function, not in a compile (numba may swallow it there)
            rotlab.simulate(scenario, torque=slow)
        print("finished")
    except Interrupted as exc:
        print(f"interrupted {time.monotonic() - start:.2f} {exc}")
""")


def test_ctrl_c_stops_a_slow_python_torque_within_one_call(tmp_path):
    # 90,001 samples: as the short run, in memory (from compile_apart.LONG_RUN on, a run streams, with kernels of its own)
    proc = subprocess.Popen([sys.executable, "-c", SLOW_TORQUE, FREE.replace("end = 2.0", "end = 900.0")],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    time.sleep(1.5)  # inside the kernel, in the slow function (compiled before "ready": the same function is not compiled again)
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    waited = time.monotonic() - sent
    assert out.startswith("interrupted") and "interrupted by the user" in out, (out, err)
    assert waited < 5.0, f"Ctrl-C took {waited:.1f} s"
    assert "Exception ignored" not in err and "Traceback" not in err


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_an_adaptive_run_whose_steps_collapse_stops_by_itself(method):
    """-k sgn(ω₀) slides on ω₀ = 0: the steps shrink to the switch and stay there."""
    text = FREE + '[[loads]]\ntype = "expression"\nframe = "body"\ntorque = ["-1.0*sign(omega[0])", "0", "0"]\n'
    start = time.monotonic()
    with pytest.raises(RunFailure, match="no progress|step size fell below") as info:
        rotlab.simulate(_load(text, method))
    assert time.monotonic() - start < 60.0
    assert info.value.trajectory.t[-1] == pytest.approx(0.09)  # the last sample before ω₀ reaches 0 (t ≈ 0.097 s)


def test_stall_rule_judges_the_pace_against_the_steps_left():
    from rotlab.core.kernel_status import STALL_FACTOR
    from rotlab.methods.stepping import stall_message

    assert stall_message(0.0, 1e-6, 1000, 10.0, 10**9, 10**9) is None  # 1e-9 s a step: 1e10 steps, 10× the budget: may still speed up
    words = stall_message(0.0, 1e-6, 1000, 10.0, 10**8 // STALL_FACTOR, 10**9)
    assert words is not None and "no progress" in words and "solver.max_steps = 1,000,000,000" in words
    assert "inf" in stall_message(0.5, 0.5, 1000, 1.0, 10**9, 10**9)  # no advance at all
