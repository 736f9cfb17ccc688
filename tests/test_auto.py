"""``auto`` chooses by expected cost and still meets the requested accuracy.

Bounds: auto's max error ≤ 10·rtol against an exact solution (free bodies, the Lagrange top) or
dop853 at rtol 1e-14 (loaded scenes).  Only the choice and the error are tested here; nothing is
timed (the timings are in docs/benchmarks.md).
"""

from __future__ import annotations

import dataclasses

import subprocess
import sys

import numpy as np
import pytest

import rotlab
from rotlab.methods import cost
from rotlab.methods.base import Settings
from rotlab.methods.choose import candidates, choose_method, work_of
from rotlab.scene.scene import build_scene
from tests.conftest import CONFIGS
from tests.helpers import same_rotation_error


def _with(path, rtol: float, **time):
    sc = rotlab.load(path)
    updates = {"solver": sc.solver.model_copy(update={"rtol": rtol, "atol": rtol * 1e-2})}
    if time:
        updates["time"] = sc.time.model_copy(update=time)
    return sc.model_copy(update=updates)


def _warm(sc, *methods: str) -> None:
    """Load these methods' kernels in this process: auto then compares steady-state costs (a
    kernel's first use in a process is part of its cost: test_a_single_cli_run_of_a_lagrange_top_uses_exact)."""
    short = sc.model_copy(update={"time": sc.time.model_copy(update={"end": sc.time.start + 0.01, "sample_rate": None, "samples": 2})})
    for method in methods:
        rotlab.simulate(short, method=method)


def _error(traj, ref) -> float:
    omega = np.max(np.abs(traj.omega - ref.omega)) / np.max(np.abs(ref.omega))
    return max(float(omega), float(np.max(same_rotation_error(traj.quaternion, ref.quaternion))))


@pytest.mark.parametrize("rtol", [1e-6, 1e-10, 1e-13])
def test_auto_on_a_free_body_steps_and_meets_rtol(rtol):
    """euler.toml: 2001 samples over 20 s, where stepping is cheaper than exact's set-up and
    per-sample cost; the error against exact stays within 10·rtol."""
    sc = _with(CONFIGS / "euler.toml", rtol)
    _warm(sc, "taylor", "dmv", "rk4")
    auto, ref = rotlab.simulate(sc), rotlab.simulate(sc, method="exact")
    assert auto.stats.method in ("dmv", "taylor", "rk4")
    assert "least expected cost" in auto.stats.reason and "exact" in auto.stats.reason  # names what it compared
    assert _error(auto, ref) <= 10 * rtol


def test_auto_uses_exact_near_the_separatrix():
    """dzhanibekov.toml (m₁ = 1.4e-6): the stepping methods' rounding floor (~1e-9) is above
    10·rtol, so auto evaluates the exact solution and says why."""
    traj = rotlab.simulate(_with(CONFIGS / "dzhanibekov.toml", 1e-10))
    assert traj.stats.method == "exact" and "separatrix" in traj.stats.reason


def test_auto_near_the_separatrix_at_loose_rtol_tightens_the_stepper():
    """At rtol 1e-6 a stepper is cheaper than exact near the separatrix, run at a tolerance
    divided by the amplification there: error within 10·rtol of exact."""
    sc = _with(CONFIGS / "dzhanibekov.toml", 1e-6)
    _warm(sc, "taylor", "dmv", "rk4")
    auto, ref = rotlab.simulate(sc), rotlab.simulate(sc, method="exact")
    assert auto.stats.method != "exact"
    assert _error(auto, ref) <= 1e-5


def test_auto_with_an_order_on_the_separatrix_runs_in_few_steps():
    """A spin exactly about the intermediate axis (on the separatrix: the cost model's error
    floor is unbounded) with ``solver.order`` set, so no exact solution: auto's taylor tolerance
    stops at ``TAYLOR_MIN_TOLERANCE`` instead of rtol / amplification = 1e-303, which ran into the
    step budget (2·10⁸ steps, two minutes); the steady spin stays within 10·rtol of exact."""
    from rotlab.methods.choose import TAYLOR_MIN_TOLERANCE

    sc = _with(CONFIGS / "euler.toml", 1e-8)
    sc = sc.model_copy(update={"body": sc.body.model_copy(update={"principal_moments": (1.0, 2.0, 3.0)}),
                               "initial": sc.initial.model_copy(update={"omega": (0.0, 1.0, 0.0)}),
                               "solver": sc.solver.model_copy(update={"order": 16})})
    auto = rotlab.simulate(sc)
    assert auto.stats.method == "taylor" and auto.stats.steps < 1000
    assert auto.stats.details["rtol"] == TAYLOR_MIN_TOLERANCE
    ref = rotlab.simulate(sc.model_copy(update={"solver": sc.solver.model_copy(update={"order": None})}), method="exact")
    assert _error(auto, ref) <= 10 * 1e-8


@pytest.mark.parametrize("rtol", [1e-8, 1e-12])
def test_auto_on_the_lagrange_top_meets_rtol(rtol):
    sc = _with(CONFIGS / "lagrange.toml", rtol, end=2.0)
    _warm(sc, "taylor")
    auto, ref = rotlab.simulate(sc), rotlab.simulate(sc, method="exact")
    assert _error(auto, ref) <= 10 * rtol


@pytest.mark.parametrize("rtol", [1e-6, 1e-10])
def test_auto_with_gravity_meets_rtol_against_tight_dop853(rtol):
    """A heavy asymmetric top (conservative, no closed form): auto vs dop853 at rtol 1e-14."""
    sc = rotlab.load(CONFIGS / "lagrange.toml")
    body = sc.body.model_copy(update={"principal_moments": [2e-3, 2.6e-3, 1.1e-3]})
    sc = sc.model_copy(update={"body": body, "time": sc.time.model_copy(update={"end": 1.0}),
                               "solver": sc.solver.model_copy(update={"rtol": rtol, "atol": rtol * 1e-2})})
    _warm(sc, "taylor", "splitting", "rk4")
    auto = rotlab.simulate(sc)
    ref = rotlab.simulate(sc.model_copy(update={"solver": sc.solver.model_copy(update={"method": "dop853", "rtol": 1e-14, "atol": 1e-16})}))
    assert auto.stats.method != "exact"
    assert _error(auto, ref) <= 10 * rtol


def test_auto_choice_is_cached_by_its_inputs_and_reported():
    sc = rotlab.load(CONFIGS / "general.toml")
    _warm(sc, "taylor", "rk4")
    scene = build_scene(sc)
    t = sc.time.sample_times()
    first = choose_method(scene, "auto", Settings(rtol=1e-10), t)
    again = choose_method(build_scene(sc), "auto", Settings(rtol=1e-10), t)
    assert first[1] is again[1]  # the same reason object: a new scene of the same numbers hits the cache
    other = choose_method(scene, "auto", Settings(rtol=1e-6), t)
    assert other[1] is not first[1] and other[2].rtol == pytest.approx(1e-7)
    assert first[0].name == "taylor" and "non-conservative" in first[1]
    assert first[2].rtol == pytest.approx(1e-11)  # taylor's local tolerance is rtol / 10


def test_auto_respects_a_given_step_and_order():
    sc = rotlab.load(CONFIGS / "euler.toml", duration=1.0)
    stepped = sc.model_copy(update={"solver": sc.solver.model_copy(update={"step": 1e-3})})
    assert rotlab.simulate(stepped).stats.method == "dmv"
    ordered = sc.model_copy(update={"solver": sc.solver.model_copy(update={"order": 6})})
    traj = rotlab.simulate(ordered)
    assert traj.stats.details["order"] == 6


def test_cost_model_prefers_few_samples_for_exact_and_many_steps_for_dmv():
    """The model itself: exact's cost grows with the samples only, a stepper's with the span."""
    sc = rotlab.load(CONFIGS / "euler.toml")
    scene = build_scene(sc)
    short_dense = work_of(scene, np.linspace(0.0, 20.0, 2001))
    long_sparse = work_of(scene, np.linspace(0.0, 2e4, 11))
    by_method = lambda work: {e.method: e for e in candidates(scene, Settings(rtol=1e-10), work)}  # noqa: E731
    dense, sparse = by_method(short_dense), by_method(long_sparse)
    assert dense["exact"].seconds > dense["taylor"].seconds
    assert sparse["exact"].seconds < sparse["taylor"].seconds and sparse["exact"].seconds < sparse["dmv"].seconds
    assert cost.separatrix((1.0, 2.0, 3.0), (1.0, 0.0, 1.0), 10.0, 1.0)[0] < 1e-13  # far from the separatrix: no floor


def test_a_single_cli_run_of_a_lagrange_top_uses_exact(tmp_path):
    """In a fresh process no numba kernel has run: taylor would pay numba's first use (~0.3–1 s),
    exact takes milliseconds and needs no kernel, so a one-off `rotlab run` picks exact."""
    done = subprocess.run([sys.executable, "-m", "rotlab", "run", str(CONFIGS / "lagrange.toml"), "-o", str(tmp_path / "l.rrd")],
                          capture_output=True, text=True, check=True)
    assert "method   exact (auto: exact" in done.stdout and "loading their numba kernel" in done.stdout


def test_a_loop_of_runs_moves_to_a_stepper_once_loading_it_pays(tmp_path):
    """In a fresh process, repeated runs of one free body (euler.toml, 2001 samples: exact ~2 ms
    a run, taylor ~0.15 ms) start with exact and switch to a stepping method once the kernel's
    first use (0.3–1 s), shared among the runs made so far (the choice is revisited at 2^k runs:
    by run 1024 the share is ≤ 1 ms), costs less than exact's extra time."""
    code = (
        "import rotlab\n"
        f"sc = rotlab.load({str(CONFIGS / 'euler.toml')!r})\n"
        "methods = [rotlab.simulate(sc).stats.method for _ in range(1100)]\n"
        "print(methods[0], methods[-1])\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path)
    first, last = done.stdout.split()
    assert first == "exact" and last != "exact"


def test_a_process_told_to_expect_many_runs_steps_from_the_first(tmp_path):
    """A sweep worker knows how many cases it will run (``choose.expect_runs``): the kernel's
    first use is shared among them from the first case, so 2,000 runs of euler.toml start with
    the stepper that the loop above reaches only by its 1024th run."""
    code = (
        "import rotlab\n"
        "from rotlab.methods.choose import expect_runs\n"
        f"sc = rotlab.load({str(CONFIGS / 'euler.toml')!r})\n"
        "expect_runs(2000)\n"
        "print(rotlab.simulate(sc).stats.method)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path)
    assert done.stdout.split() != ["exact"]


def test_a_kernel_loaded_for_other_load_groups_is_not_counted_as_ready(tmp_path):
    """numba specialises a kernel on the scene's load groups: after general.toml's taylor
    (gravity, terms, tables, damping) the Lagrange top's taylor (gravity only) still has to be
    compiled or loaded.  auto counted the kernel as ready and picked taylor for the top
    (1.8 ms expected, 53 ms taken, seconds with an empty numba cache); it picks exact again."""
    code = (
        "import rotlab\n"
        "from rotlab.methods import choose\n"
        "from rotlab.scene.scene import build_scene\n"
        f"rotlab.simulate({str(CONFIGS / 'general.toml')!r}, method='taylor', duration=0.1)\n"
        f"top, heavy = (build_scene(rotlab.load(p)) for p in ({str(CONFIGS / 'lagrange.toml')!r}, {str(CONFIGS / 'general.toml')!r}))\n"
        "print(choose._kernel_ready('taylor', top), choose._kernel_ready('taylor', heavy))\n"
        f"print(rotlab.simulate({str(CONFIGS / 'lagrange.toml')!r}).stats.method)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path)
    assert done.stdout.split() == ["False", "True", "exact"]


def test_sweep_workers_are_told_their_share_of_the_cases(monkeypatch):
    from rotlab.sweep import runner

    p = runner.plan(CONFIGS / "sweep_flip.toml")
    p = dataclasses.replace(p, base=p.base.model_copy(update={"solver": p.base.solver.model_copy(update={"method": "auto"})}))
    seen = {}

    def record(fn, tasks, jobs, **kw):
        seen["tasks"], seen["jobs"] = tasks, jobs
        return runner.TaskRun([])

    monkeypatch.setattr(runner, "run_tasks", record)
    runner.run_cases(p, jobs=2)
    assert {task[4] for task in seen["tasks"]} == {-(-len(p.cases) // 2)}  # 12 cases on 2 workers: 6 each
    runner.run_cases(p, jobs=2, timeout=0.3)
    # not with a per-case --timeout: every new worker's first case would load the kernel, run out of
    # time, and its replacement likewise (found by review: 184 of 184 cases timed out)
    assert {task[4] for task in seen["tasks"]} == {0}


def test_taylor_loaded_for_gravity_alone_is_not_ready_for_gravity_with_a_space_torque(tmp_path):
    """taylor's kernel is specialised on the model's type and on whether a lone force goes through
    γ = Rᵀ F: gravity with a body-frame torque and gravity with a space-frame torque share their
    load groups but not their specialisation, so after the first the second is not counted as
    loaded (auto would otherwise expect no load or compile for it)."""
    base = {"body": {"principal_moments": [1.0, 1.5, 2.0], "mass": 1.0, "center_of_mass": [0.0, 0.0, 0.3]},
            "initial": {"omega": [0.1, 0.2, 5.0]}, "time": {"end": 0.5, "samples": 11}}
    body_torque = {**base, "loads": [{"type": "gravity"}, {"type": "torque", "frame": "body", "value": [0.0, 0.0, 0.01]}]}
    space_torque = {**base, "loads": [{"type": "gravity"}, {"type": "torque", "frame": "space", "value": [0.0, 0.0, 0.01]}]}
    code = (
        "import rotlab\n"
        "from rotlab.config import parse_scenario\n"
        "from rotlab.methods import choose\n"
        "from rotlab.scene.scene import build_scene\n"
        f"a, b = (parse_scenario(d) for d in ({body_torque!r}, {space_torque!r}))\n"
        "before = choose._kernel_ready('taylor', build_scene(a))\n"
        "rotlab.simulate(a, method='taylor')\n"
        "print(before, choose._kernel_ready('taylor', build_scene(a)), choose._kernel_ready('taylor', build_scene(b)))\n"
        "rotlab.simulate(b, method='taylor')\n"
        "print(choose._kernel_ready('taylor', build_scene(b)))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=tmp_path)
    assert done.stdout.split() == ["False", "True", "False", "True"]


@pytest.mark.parametrize("loads, fixed_step", [
    ([{"type": "pd_control", "kp": 0.05, "kd": 0.01, "target": [0.7071068, 0.0, 0.0, 0.7071068]}], False),
    ([{"type": "expression", "frame": "body", "torque": ["0.01*sign(t - 1.3)", "0", "0"]}], False),
    ([{"type": "expression", "frame": "body", "torque": ["0.01*min(omega[0], 0.1)", "0", "abs(q[1])*1e-3"]}], False),
    ([{"type": "expression", "frame": "body", "torque": ["0.01*sin(t)", "0", "-1e-3*omega[2]"]}], True),
])
def test_auto_considers_no_fixed_step_where_a_load_switches_with_no_breakpoint(loads, fixed_step):
    """A fixed step crosses a jump or kink of the torque (abs, sign, min, max; pd_control's
    sgn δ₀) at low order: in a fresh process auto chose rk4 (h = 1.25 ms) for a pd_control scene
    at rtol 1e-10 and was 1e-4 off.  Such scenes leave rk4 out and say why; smooth ones keep it."""
    from tests.helpers import scenario

    sc = scenario(body={"principal_moments": [0.01, 0.01, 0.02]}, initial={"omega": [0.3, -0.2, 5.0]}, loads=loads,
                  time={"end": 5.0, "sample_rate": 100})
    scene = build_scene(sc)
    t = sc.time.sample_times()
    offered = {e.method for e in candidates(scene, Settings(rtol=1e-10), work_of(scene, t))}
    assert ("rk4" in offered) == fixed_step
    _, why, _ = choose_method(scene, "auto", Settings(rtol=1e-10), t)
    assert ("no fixed-step method: a load switches" in why) != fixed_step
