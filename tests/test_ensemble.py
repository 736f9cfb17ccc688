"""The ensemble kernels (``rotlab.ensemble``): every case's states are its single run's, bit for
bit, for every method with an ensemble kernel; the observables reduced as it runs equal those a
sweep computes from the stored trajectory; a sweep's results grow as cases finish and keep a
bounded set of series."""

from __future__ import annotations

import copy
import csv
import itertools
import math
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from rotlab.config.loader import parse_scenario, read_toml
from rotlab.ensemble.block import run_block
from rotlab.methods.base import Settings
from rotlab.methods.registry import get_method
from rotlab.scene.scene import build_scene
from rotlab.sweep.cases import Case, expand
from rotlab.sweep.results import Results, parameter_names
from rotlab.sweep.runner import COMPARED_CASES, compared_cases, outcomes_of, plan, run_cases
from tests.conftest import CONFIGS

CASES = 5
METHOD_SCENES = [  # (config, time.end, method, solver changes)
    ("sweep_flip.toml", 12.0, "rk4", {"step": 1e-3}),
    ("sweep_flip.toml", 12.0, "splitting", {"step": 1e-3}),
    ("sweep_flip.toml", 12.0, "rkmk4", {"step": 1e-3}),
    ("sweep_flip.toml", 12.0, "dmv", {"step": 5e-3, "order": 8}),
    ("sweep_flip.toml", 12.0, "dop853", {}),
    ("sweep_flip.toml", 12.0, "taylor", {}),
    ("sweep_flip.toml", 90.0, "dop853", {}),  # 18,001 samples: past a run's first window (stepping.WINDOW), where steps end
    ("sweep_flip.toml", 90.0, "taylor", {}),
    ("sweep_flip.toml", 12.0, "rk4", {}),  # the step from each case's own probe
    ("lagrange.toml", 1.0, "rk4", {"step": 1e-4}),
    ("lagrange.toml", 1.0, "splitting", {}),
    ("lagrange.toml", 1.0, "dop853", {}),
    ("lagrange.toml", 1.0, "taylor", {"order": 12}),
    ("general.toml", 1.0, "rkmk4", {"step": 1e-3}),
    ("general.toml", 1.0, "dop853", {}),
    ("general.toml", 1.0, "taylor", {}),
    ("gyrostat.toml", 20.0, "rk4", {"step": 1e-2}),  # L = I ω + h in the drifts
    ("gyrostat.toml", 20.0, "dop853", {}),
    ("gyrostat.toml", 20.0, "taylor", {}),
]


def _scenes(config: str, end: float, method: str, changes: dict, **sections: object) -> list:
    raw = {**read_toml(CONFIGS / config), **sections}
    raw.pop("sweep", None)
    raw["time"]["end"] = end
    raw["solver"] = {**{k: v for k, v in raw.get("solver", {}).items() if k in ("rtol", "atol")}, "method": method, **changes}
    rng = np.random.default_rng(7)
    scenes = []
    for _ in range(CASES):
        case = copy.deepcopy(raw)
        case["initial"]["omega"] = [float(w + 0.05 * rng.normal()) for w in raw["initial"]["omega"]]
        scenes.append(build_scene(parse_scenario(case, source=config)))
    return scenes


@pytest.mark.parametrize("config, end, method, changes", METHOD_SCENES, ids=[f"{c}-{m}-{'-'.join(map(str, x.values()))}" for c, _, m, x in METHOD_SCENES])
def test_each_case_of_an_ensemble_is_its_single_run_and_reports_its_observables(config, end, method, changes):
    """States at every sample identical to the case run alone (``np.array_equal``), the same step
    count, and the observables of the stored-trajectory report (``outcomes_of``): the flip period
    and max nutation to 1e-13 relative, each invariant's max drift to 1e-15 (in units of its scale)."""
    block = _assert_each_case_is_its_single_run(_scenes(config, end, method, changes), method)
    assert any(np.isfinite(block.flip_period)) or config != "sweep_flip.toml"  # the flip is measured where there is one


@pytest.mark.parametrize("config", ["lagrange.toml", "gyrostat.toml", "sweep_flip.toml"])
def test_the_cpus_blocked_observables_are_the_gpus_sample_by_sample_bit_for_bit(config):
    """``observe._fold_blocks`` (the CPU: columns in blocks of 64, vectorised) folds what
    ``_fold_samples`` (a GPU's loop, run here on the CPU) folds, bit for bit: windows of every
    length around a block's edge, a window opening the case, a row whose ω overflows the
    energy (inf), a row with ω exactly 0 (c = 0: no crossing on either side of it), reversals of
    c = a·ω at every sample across the blocks' and the windows' edges."""
    from rotlab.api import simulate
    from rotlab.ensemble import observe as ob
    from rotlab.ensemble.block import case_inputs, shared_inputs

    scene = _scenes(config, 2.0, "dop853", {}, time={"end": 2.0, "sample_rate": 200})[0]
    rows = np.ascontiguousarray(simulate(scene.scenario, check=False)._state[:, :8])
    times = scene.scenario.time.sample_times()
    rows[150, 4:7] = 1e200  # finite, its products not
    rows[151, 4:7] = 0.0
    rows[60:200:2, 4:7] *= -1.0  # a reversal at every sample there, across the edges of blocks and windows
    shared, applies, forces = shared_inputs(scene)
    k = ob.constants_of(case_inputs([scene], [None])[0], shared, applies)
    cuts = [0, 1, 2, 63, 64, 65, 129, 150, 152, 300, rows.shape[0]]
    blocked = samples = None
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        opening = (0.0, math.nan, math.nan, 1.0, 0.0, 0.0) + (0.0,) * len(ob.INVARIANTS)
        blocked = ob._fold_blocks(times, rows, lo, hi, lo == 0, k, forces, opening if lo == 0 else blocked)
        samples = ob._fold_samples(times, rows, lo, hi, lo == 0, k, forces, opening if lo == 0 else samples)
        assert np.array_equal(np.array(blocked), np.array(samples), equal_nan=True), (lo, hi)
    assert any(math.isinf(x) for x in blocked)  # the overflowing row reached the folds
    assert blocked[0] >= 130  # the reversals


FORMULA_LOADS = [{"type": "expression", "frame": "body", "constants": {"k": 2e-5},  # a damping in the body, a pulse fixed in space
                  "torque": ["-k*omega[0]", "-k*omega[1]*(1 + 0.5*sin(t))", "-k*omega[2]"]},
                 {"type": "expression", "frame": "space", "torque": ["0", "1e-5*exp(-t)", "0"]}]


@pytest.mark.parametrize("method, changes", [("rk4", {"step": 1e-3}), ("dop853", {}), ("taylor", {})], ids=["rk4", "dop853", "taylor"])
def test_formula_loads_run_in_the_ensemble_each_case_its_single_run(method, changes):
    """Formula loads (compiled expressions, body and space frames) in the parallel kernels: each
    case's states, steps and observables those of its run alone (the bounds of the test above)."""
    _assert_each_case_is_its_single_run(_scenes("sweep_flip.toml", 12.0, method, changes, loads=FORMULA_LOADS), method)


def _assert_each_case_is_its_single_run(scenes: list, method: str):
    """The ensemble's block of ``scenes``, each case checked against its run alone."""
    from rotlab import api

    m = get_method(method)
    settings = Settings.of(scenes[0].scenario.solver)
    t = scenes[0].scenario.time.sample_times()
    block = run_block(scenes, m, settings, t, list(range(CASES)), 1, [None] * CASES)
    alone = [api.run_scene(scene, plan=(m, "alone", settings, t)) for scene in scenes]
    report = outcomes_of([(Case(k, {}), traj, 0.0) for k, traj in enumerate(alone)])
    for k, (traj, outcome) in enumerate(zip(alone, report)):
        kept_t, states = block.kept[k]
        assert traj.stats.failure is None and block.failure[k] is None
        assert np.array_equal(kept_t, traj.t) and np.array_equal(states, traj._state)
        assert block.steps[k] == traj.stats.steps and block.valid[k] == t.shape[0]
        for name in ("flip_period_s", "max_nutation_deg"):
            ours = {"flip_period_s": block.flip_period[k], "max_nutation_deg": block.max_nutation_deg[k]}[name]
            theirs = outcome.observables[name]
            assert (np.isnan(ours) and np.isnan(theirs)) or abs(ours - theirs) <= 1e-13 * abs(theirs)
        assert set(block.max_drift) == set(outcome.drift)
        for name, value in outcome.drift.items():
            assert abs(block.max_drift[name][k] - value) <= 1e-15, name
    return block


def test_a_case_the_step_cannot_take_is_an_error_and_the_others_run(write):
    """rk4 at h = 1e-3 s is unstable for |ω| = 1e4 rad/s (h·ω > 2.8): that case is refused with
    the single run's one-line message; the other case runs in the same kernel call."""
    text = ('[body]\nprincipal_moments = [1.0, 2.0, 3.0]\n[initial]\nomega = [0.1, 1.0, 0.1]\n[time]\nend = 1.0\nsample_rate = 50\n'
            '[solver]\nmethod = "rk4"\nstep = 1e-3\n[sweep]\n[sweep.parameters]\n"initial.omega[1]" = [1.0, 1.0e4]\n')
    run = run_cases(plan(write("s.toml", text)))
    assert run.how.startswith("ensemble kernels (rk4")
    good, bad = run.outcomes
    assert good.status == "pass" and good.steps == 1000
    assert bad.status == "error" and bad.message.startswith("solver.step: 0.001 s is too large to be stable")


def test_a_case_refused_before_stepping_is_worded_alike_by_the_kernels_and_by_workers(write):
    """A step budget the span exceeds refuses each case before it steps: the ensemble's row and the
    workers' (``--timeout``) give the same status, method and message (the workers' used to add
    the exception's class name, ``InputError: ``, and leave the method empty)."""
    text = ('[body]\nprincipal_moments = [1.0e-4, 2.0e-4, 2.8e-4]\n[initial]\nomega = [0.01, 10.0, 0.01]\n[time]\nend = 20.0\n'
            'sample_rate = 20\n[solver]\nmethod = "rk4"\nstep = 1e-3\nmax_steps = 5000\n[sweep]\n[sweep.parameters]\n'
            '"initial.omega[0]" = [0.1, 0.5]\n')
    p = plan(write("s.toml", text))
    kernels, workers = run_cases(p), run_cases(p, timeout=1000.0)
    assert kernels.how.startswith("ensemble kernels") and not workers.how.startswith("ensemble kernels")
    for a, b in zip(kernels.outcomes, workers.outcomes):
        assert (a.status, a.method, a.message) == (b.status, b.method, b.message) == ("error", "rk4", a.message)
        assert a.message.startswith("solver.max_steps: rk4 needs 2e+04 steps")


def test_cases_are_made_when_asked_in_the_grids_product_order(write):
    text = ('[body]\nprincipal_moments = [1.0, 2.0, 3.0]\n[initial]\nomega = [0.1, 1.0, 0.1]\n[time]\nend = 1.0\n[sweep]\nseed = 5\nsamples = 3\n'
            '[sweep.parameters]\n"initial.omega[0]" = [0.1, 0.2]\n"initial.omega[1]" = [1.0, 2.0, 3.0]\n'
            '"initial.omega[2]" = { normal = [0.0, 0.1] }\n')
    p = plan(write("s.toml", text))
    cases = expand(p.base.sweep)
    points = list(itertools.product([0.1, 0.2], [1.0, 2.0, 3.0]))
    assert len(cases) == 18 and [c.index for c in cases] == list(range(18))
    for case in cases:
        assert (case.values["initial.omega[0]"], case.values["initial.omega[1]"]) == points[case.index // 3]
        draw = np.random.default_rng([5, case.index]).normal(0.0, 0.1)
        assert case.values["initial.omega[2]"] == float(draw)
    assert cases[-1] == cases[17] and cases[16:] == [cases[16], cases[17]]


def test_only_the_compared_cases_keep_series_and_the_table_is_in_case_order(write):
    text = ('[body]\nprincipal_moments = [1.0, 2.0, 3.0]\n[initial]\nomega = [0.1, 1.0, 0.1]\n[time]\nend = 0.2\nsample_rate = 50\n'
            '[solver]\nmethod = "rk4"\nstep = 1e-3\n[sweep]\nsamples = 130\n[sweep.parameters]\n"initial.omega[0]" = { uniform = [0.0, 0.2] }\n')
    p = plan(write("s.toml", text))
    results = Results(parameter_names(p.cases[0].values), [])
    run = run_cases(p, on_outcomes=results.add)
    assert run.outcomes == [] and len(results) == 130
    assert sorted(o.index for o in results.compared) == sorted(compared_cases(130)) and len(results.compared) == COMPARED_CASES
    assert all(o.t is not None and o.t[-1] == 0.2 for o in results.compared)
    rows = results.table(results.in_case_order())
    assert [r[0] for r in rows] == list(range(130)) and {r[results.header.index("status")] for r in rows} == {"pass"}


def test_a_killed_sweep_keeps_the_rows_of_the_cases_that_finished(write, tmp_path):
    """results.partial.csv grows block by block; SIGKILL mid-sweep leaves whole rows there (each
    parses, with every column); an earlier results.csv is left as it was."""
    text = ('[body]\nprincipal_moments = [1.0e-4, 2.0e-4, 2.8e-4]\n[initial]\nomega = [0.01, 10.0, 0.01]\n[time]\nend = 5.0\n'
            'sample_rate = 200\n[solver]\nmethod = "rk4"\nstep = 1e-3\n[sweep]\nsamples = 3000\n'
            '[sweep.parameters]\n"initial.omega[2]" = { uniform = [-0.05, 0.05] }\n')
    config = write("big.toml", text)
    out = tmp_path / "out"
    out.mkdir()
    (out / "results.csv").write_text("an earlier sweep's results\n")
    process = subprocess.Popen([sys.executable, "-m", "rotlab", "sweep", str(config), "-o", str(out)],
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    results = out / "results.partial.csv"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and process.poll() is None:
        if results.exists() and len(results.read_text().splitlines()) > 65:
            break
        time.sleep(0.05)
    assert process.poll() is None, "the sweep ended before it could be killed: make it longer"
    process.send_signal(signal.SIGKILL)
    process.wait()
    rows = list(csv.reader(results.open()))
    header, body = rows[0], rows[1:]
    assert 64 <= len(body) < 3000
    assert all(len(r) == len(header) for r in body) and [int(r[0]) for r in body] == list(range(len(body)))
    assert {r[header.index("status")] for r in body} == {"pass"}
    assert (out / "results.csv").read_text() == "an earlier sweep's results\n"


def test_compare_asks_for_cases_and_jobs_sets_the_kernels_threads(cli, write):
    text = ('[body]\nprincipal_moments = [1.0, 2.0, 3.0]\n[initial]\nomega = [0.1, 1.0, 0.1]\n[time]\nend = 0.2\nsample_rate = 50\n'
            '[solver]\nmethod = "rk4"\nstep = 1e-3\n[sweep]\nsamples = 130\n[sweep.parameters]\n"initial.omega[0]" = { uniform = [0.0, 0.2] }\n')
    config = write("s.toml", text)
    p = plan(config)
    results = Results(parameter_names(p.cases[0].values), [])
    run_cases(p, on_outcomes=results.add, compared=compared_cases(130, [4, 7]))
    assert {o.index for o in results.compared} == set(compared_cases(130)) | {4, 7}
    one = cli("sweep", str(config), "-o", "one", "-j", "1", "--compare", "4,7")
    two = cli("sweep", str(config), "-o", "two", "-j", "2")
    assert one.exit_code == two.exit_code == 0
    assert "rk4, 1 thread over cases" in one.stdout and "rk4, 2 threads over cases" in two.stdout
    assert _without_seconds("one") == _without_seconds("two")  # the threads change no number
    refused = cli("sweep", str(config), "-o", "three", "--compare", "130")
    assert refused.exit_code == 2 and refused.stderr.strip() == "rotlab: error: --compare: case 130 is not in this sweep: its cases are 0 … 129"
    assert not Path("three").exists()  # refused before any file is made


def _without_seconds(outdir: str) -> list[list[str]]:
    rows = list(csv.reader(open(f"{outdir}/results.csv")))
    drop = rows[0].index("seconds")
    return [r[:drop] + r[drop + 1:] for r in rows]


EVENTS = [{"name": "flip", "when": "omega[1]", "direction": "falling"},
          {"name": "cross", "when": "omega[1] - 5", "record": ["omega[2]", "t"]},
          {"name": "pole", "when": "1/(omega[1] - 5)"}]  # changes sign through ±∞ where "cross" crosses 0: no occurrence
EVENT_METHODS = [("rk4", {"step": 1e-3}), ("splitting", {"step": 1e-3}), ("rkmk4", {"step": 1e-3}), ("dmv", {"step": 5e-3, "order": 8}),
                 ("dop853", {}), ("taylor", {})]


def _event_block(method: str, changes: dict, events: list[dict], end: float = 12.0):
    """(scenes, block result, each scene run alone) of CASES sweep_flip cases with ``events``."""
    from rotlab import api

    scenes = _scenes("sweep_flip.toml", end, method, changes, events=events)
    m, settings, t = get_method(method), Settings.of(scenes[0].scenario.solver), scenes[0].scenario.time.sample_times()
    block = run_block(scenes, m, settings, t, list(range(CASES)), 1, [None] * CASES)
    return scenes, block, [api.run_scene(scene, plan=(m, "alone", settings, t)) for scene in scenes]


@pytest.mark.parametrize("method, changes", EVENT_METHODS, ids=[m for m, _ in EVENT_METHODS])
def test_events_in_the_ensemble_are_those_of_each_case_run_alone(method, changes):
    """Each event's count, first time and mean interval in every case equal, bit for bit, those of
    the case run alone (the same crossings, the same Brent root on the same local solution); a
    sign change through a pole counts nowhere; the states are unchanged by the events."""
    from rotlab.events import observables

    _, block, alone = _event_block(method, changes, EVENTS)
    for k, traj in enumerate(alone):
        expected = observables(traj.events)
        assert {column: float(values[k]) for column, values in block.events.items()}.keys() == expected.keys()
        for column, value in expected.items():
            ours = float(block.events[column][k])
            assert ours == value or (math.isnan(ours) and math.isnan(value)), (column, ours, value)
        assert traj.events["flip"].count >= 1 and traj.events["cross"].count >= 1 and traj.events["pole"].count == 0
        kept_t, states = block.kept[k]
        assert block.failure[k] is None and np.array_equal(states, traj._state)


def test_no_kernel_is_compiled_again_for_a_constant_argument():
    """numba compiles a function that compiled code calls with a constant integer
    (``Literal[int](1)``) apart from its int64 specialisation: ``dop853_advance`` and
    ``taylor_advance`` (from their local solutions, which locate events) and the ensemble's
    ``scan_call`` were each compiled twice for every model type, 10-25 s each on 2 cores.  After
    located events under both methods, alone and in the ensemble, none of them (nor the ensemble's
    ``_start_whole``) has a specialisation for a constant integer in its on-disk cache index, which
    holds what any process compiled (a kernel loaded from the cache compiles none of its callees
    in this one)."""
    from numba import types

    from rotlab.core.dop853 import dop853_advance
    from rotlab.core.taylor import taylor_advance
    from rotlab.ensemble.event_scan import scan_call
    from rotlab.ensemble.kernels import _start_whole

    for method, changes in EVENT_METHODS[-2:]:
        _, block, alone = _event_block(method, changes, EVENTS[:1], end=6.0)
        assert all(traj.events["flip"].count >= 1 for traj in alone) and np.all(block.events["event_flip_count"] >= 1)
    for kernel in (dop853_advance, taylor_advance, scan_call, _start_whole):
        signatures = [key[0] for key in kernel._cache._cache_file._load_index()]  # (signature, target, code): every one cached
        constants = [sig for sig in signatures if any(isinstance(arg, types.IntegerLiteral) for arg in sig)]
        assert signatures and not constants, (kernel, constants)


@pytest.mark.parametrize("method, changes", EVENT_METHODS, ids=[m for m, _ in EVENT_METHODS])
def test_a_terminal_event_ends_each_case_as_it_ends_its_single_run(method, changes):
    """A terminal event (the second flip, each case at its own time, beside a counting event) ends
    each case as it ends its run alone: the same samples kept and the state at the event last, bit
    for bit; the same steps (the same calls: ``WATCHED_STEPS``); the same events, observables
    (flip period and nutation to 1e-13 relative, drifts to 1e-15) and "ended by"."""
    from rotlab.events import observables

    events = [{"name": "flip", "when": "omega[1]", "direction": "falling", "terminal": True, "count": 2},
              {"name": "cross", "when": "omega[0]"}]
    scenes, block, alone = _event_block(method, changes, events, end=40.0)
    report = outcomes_of([(Case(k, {}), traj, 0.0) for k, traj in enumerate(alone)])
    ends = set()
    for k, (traj, outcome) in enumerate(zip(alone, report)):
        kept_t, states = block.kept[k]
        assert traj.stats.failure is None and block.failure[k] is None and block.status[k] == 0
        assert np.array_equal(kept_t, traj.t) and np.array_equal(states, traj._state)
        assert block.valid[k] == traj.t.shape[0] < scenes[k].scenario.time.sample_times().shape[0]
        assert traj.t[-1] == block.events["event_flip_first_s"][k] + block.events["event_flip_interval_s"][k] or traj.events["flip"].count == 2
        assert block.steps[k] == traj.stats.steps and block.details[k]["ended by"] == traj.stats.details["ended by"]
        for column, value in observables(traj.events).items():
            ours = float(block.events[column][k])
            assert ours == value or (math.isnan(ours) and math.isnan(value)), column
        for name, ours in (("flip_period_s", block.flip_period[k]), ("max_nutation_deg", block.max_nutation_deg[k])):
            theirs = outcome.observables[name]
            assert (np.isnan(ours) and np.isnan(theirs)) or abs(ours - theirs) <= 1e-13 * abs(theirs), name
        for name, value in outcome.drift.items():
            assert abs(block.max_drift[name][k] - value) <= 1e-15, name
        ends.add(float(traj.t[-1]))
    assert len(ends) == len(alone)  # each case ended at its own time


FAULTS = {  # events whose formula is not finite somewhere: the case stops there, as its single run
    "at a sample": [{"name": "flip", "when": "omega[1]"}, {"name": "s", "when": "sqrt(2.3 - t) - 0.1"}],
    "in a record": [{"name": "flip", "when": "omega[1]", "record": ["log(t - 5)"]}],
    "between samples": [{"name": "b", "when": "sqrt(omega[1] + 9.9)"}],
    "at the first sample": [{"name": "z", "when": "log(t)"}],
}


@pytest.mark.parametrize("method, changes", [EVENT_METHODS[0], EVENT_METHODS[4], EVENT_METHODS[5]], ids=["rk4", "dop853", "taylor"])
@pytest.mark.parametrize("where", list(FAULTS))
def test_an_event_formula_that_is_not_finite_stops_the_case_as_it_stops_its_single_run(method, changes, where):
    """The same message (naming the event, the formula and the time), the same samples kept, bit
    for bit, and the same events counted before the stop."""
    from rotlab.events import observables

    scenes, block, alone = _event_block(method, changes, FAULTS[where])
    for k, traj in enumerate(alone):
        assert traj.stats.failure is not None and block.failure[k] == traj.stats.failure
        assert block.valid[k] == traj.t.shape[0] < scenes[k].scenario.time.sample_times().shape[0]
        assert block.steps[k] == traj.stats.steps  # (the same calls of its kernel: it stops after the same one)
        kept_t, states = block.kept[k]
        assert np.array_equal(kept_t, traj.t) and np.array_equal(states, traj._state)
        for column, value in observables(traj.events).items():
            ours = float(block.events[column][k])
            assert ours == value or (math.isnan(ours) and math.isnan(value)), column


def test_a_sweep_with_events_runs_in_the_ensemble_kernels_on_either_device_terminal_events_too(write):
    from rotlab.sweep.runner import ensemble_plan_or_why

    text = ('[body]\nprincipal_moments = [1.0e-4, 2.0e-4, 2.8e-4]\n[initial]\nomega = [0.01, 10.0, 0.01]\n[time]\nend = 8.0\n'
            '[solver]\nmethod = "rk4"\nstep = 1e-3\n[sweep]\n[sweep.parameters]\n"initial.omega[0]" = [0.01, 0.02]\n'
            '[[events]]\nname = "flip"\nwhen = "omega[1]"\ndirection = "falling"\n')
    p = plan(write("s.toml", text))
    run = run_cases(p)
    assert run.how.startswith("ensemble kernels (rk4") and all(o.observables["event_flip_count"] >= 1 for o in run.outcomes)
    assert ensemble_plan_or_why(p, "cuda").device == "cuda"
    terminal = plan(write("t.toml", text + "terminal = true\n"))
    assert ensemble_plan_or_why(terminal).method_name == "rk4"
    ended = run_cases(terminal)
    assert ended.how.startswith("ensemble kernels (rk4") and all(o.observables["event_flip_count"] == 1 for o in ended.outcomes)
    never = run_cases(plan(write("n.toml", text + "terminal = true\ncount = 9223372036854775808\n")))  # (beyond int64: never reached)
    assert [o.observables["event_flip_count"] for o in never.outcomes] == [o.observables["event_flip_count"] for o in run.outcomes]


@pytest.mark.parametrize("method, changes", [("rk4", {"step": 1e-3}), ("dop853", {})], ids=["rk4", "dop853"])
def test_a_formula_load_that_is_not_finite_stops_its_case_with_its_single_runs_words(method, changes):
    """The torque's formula turns NaN at a different time in each case: each case stops there with
    the samples, steps and message (naming the formula, the time and the state) of its run alone."""
    from rotlab import api

    loads = [{"type": "expression", "frame": "body", "torque": ["0", "0", "1e-6*sqrt(2.2 - t + 0.1*omega[0])"]}]
    scenes = _scenes("sweep_flip.toml", 5.0, method, changes, loads=loads)
    m, settings, t = get_method(method), Settings.of(scenes[0].scenario.solver), scenes[0].scenario.time.sample_times()
    block = run_block(scenes, m, settings, t, list(range(CASES)), 1, [None] * CASES)
    for k, scene in enumerate(scenes):
        traj = api.run_scene(scene, plan=(m, "alone", settings, t))
        assert traj.stats.failure.startswith("loads[0].torque[2] = '1e-6*sqrt(2.2 - t + 0.1*omega[0])' is not finite at t = 2.")
        assert block.failure[k] == traj.stats.failure and block.steps[k] == traj.stats.steps
        assert np.array_equal(block.kept[k][1], traj._state)


def test_a_detumbling_monte_carlo_runs_in_the_ensemble_kernels_on_the_cpu_and_the_gpu(write):
    """The B-dot law is a formula load (``bdot_detumbling``): a sweep over the tumble runs in the
    ensemble kernels, and may run on a GPU (which interprets the formulas' ``formula_table``:
    ``tests/test_loads.py``)."""
    from rotlab.sweep.runner import ensemble_plan_or_why

    text = (CONFIGS / "detumbling.toml").read_text().replace("end = 6000.0", "end = 300.0").replace("samples = 6001", "samples = 301")
    p = plan(write("d.toml", text + '\n[sweep]\n[sweep.parameters]\n"initial.omega_deg[0]" = [3.0, 5.0]\n'))
    run = run_cases(p)
    assert run.how.startswith("ensemble kernels (dop853") and [o.status for o in run.outcomes] == ["pass", "pass"]
    assert not isinstance(ensemble_plan_or_why(p, "cuda"), str)


def test_an_unexpected_error_in_one_cases_validation_costs_that_case_not_its_block(write, monkeypatch):
    """(CPython 3.11's ast.parse, called from two Dask task threads at once, raised SystemError in
    one case and lost its whole 4,096-case task; formulas are now parsed one at a time, and any
    such error is the case's own "error" outcome, as case by case.)"""
    import rotlab.scene.scene as scene_module
    from rotlab.sweep.runner import ensemble_plan, run_ensemble_chunk

    text = ('[body]\nprincipal_moments = [1.0, 2.0, 3.0]\n[initial]\nomega = [0.1, 1.0, 0.1]\n[time]\nend = 0.2\nsample_rate = 50\n'
            '[solver]\nmethod = "rk4"\nstep = 1e-3\n[sweep]\n[sweep.parameters]\n"initial.omega[0]" = [0.1, 0.2, 0.3]\n')
    p = plan(write("s.toml", text))
    build = scene_module.build_scene

    def flaky(scenario):
        if scenario.initial.omega[0] == 0.2:
            raise SystemError("AST constructor recursion depth mismatch")
        return build(scenario)

    monkeypatch.setattr(scene_module, "build_scene", flaky)
    outcomes = run_ensemble_chunk(p.raw, p.base, p.source, list(p.cases), ensemble_plan(p), None)
    assert [o.status for o in outcomes] == ["pass", "error", "pass"]
    assert outcomes[1].message == "SystemError: AST constructor recursion depth mismatch"


@pytest.mark.parametrize("method", ["dop853", "taylor"])
def test_an_adaptive_case_that_cannot_finish_stops_as_its_single_run_stops(method):
    """A torque that switches sign with ω_x chatters about ω_x = 0 and the adaptive step
    collapses: each case stops after its first whole chunk of steps whose pace cannot finish
    (``stall_needs``), with its single run's message (where, the pace, the steps it would take)
    and steps, instead of grinding through solver.max_steps in the kernel."""
    from rotlab import api

    loads = [{"type": "expression", "frame": "body", "torque": ["-1e-5*sign(omega[0])", "0", "0"]}]
    scenes = _scenes("sweep_flip.toml", 10.0, method, {"rtol": 1e-10}, loads=loads,
                     time={"end": 10.0, "sample_rate": 10}, initial={"omega": [0.01, 0.0, 0.0]})
    m, settings, t = get_method(method), Settings.of(scenes[0].scenario.solver), scenes[0].scenario.time.sample_times()
    block = run_block(scenes, m, settings, t, list(range(CASES)), 1, [None] * CASES)
    for k, scene in enumerate(scenes):
        traj = api.run_scene(scene, plan=(m, "alone", settings, t))
        assert traj.stats.failure is not None and block.failure[k] == traj.stats.failure
        assert block.steps[k] == traj.stats.steps and block.valid[k] == traj.t.shape[0] < t.shape[0]


def test_a_case_whose_quaternion_collapses_stops_as_its_run_alone(write):
    """rk4 (no renormalisation) far past its stable step drives |Λ| towards 0 (exactly 0 within
    3 s, before: NaN attitudes, a "pass", and a ZeroDivisionError inside the parallel kernel
    before that).  Every case stops where its run alone stops, at the first state whose |Λ| is
    below ~1.5e-154 (``state_status``), with the same words, samples and observables; the
    third case keeps |Λ| and passes in both."""
    from rotlab import api

    text = ('[body]\nprincipal_moments = [1.0e-4, 2.0e-4, 2.8e-4]\n[initial]\nomega = [0.01, 0.01, 0.0]\n'
            '[[loads]]\ntype = "torque"\nframe = "body"\nvalue = [0.0, 0.0, 1.0]\n[time]\nend = 3.0\nsample_rate = 100\n'
            '[solver]\nmethod = "rk4"\nstep = 4e-4\n')
    base = read_toml(write("collapse.toml", text))
    scenes = []
    for wz in (0.0, 2000.0, -6000.0):
        case = copy.deepcopy(base)
        case["initial"]["omega"][2] = wz
        scenes.append(build_scene(parse_scenario(case, source="collapse.toml")))
    m, t = get_method("rk4"), scenes[0].scenario.time.sample_times()
    settings = Settings.of(scenes[0].scenario.solver)
    block = run_block(scenes, m, settings, t, [0, 1, 2], 1, [None] * 3)
    alone = [api.run_scene(scene, plan=(m, "alone", settings, t)) for scene in scenes]
    report = outcomes_of([(Case(k, {}), traj, 0.0) for k, traj in enumerate(alone)])
    assert [traj.stats.failure is not None and "the attitude is lost" in traj.stats.failure for traj in alone] == [True, True, False]
    assert block.failure == [traj.stats.failure for traj in alone]
    assert np.all(np.linalg.norm(np.concatenate([traj._state[:, :4] for traj in alone]), axis=1) >= 1.49e-154)
    for k, (traj, outcome) in enumerate(zip(alone, report)):
        assert block.valid[k] == traj.t.shape[0] and np.array_equal(block.kept[k][1], traj._state)
        assert block.max_nutation_deg[k] == outcome.observables["max_nutation_deg"]
        assert all(block.max_drift[name][k] == value for name, value in outcome.drift.items())
    assert block.valid[0] < t.shape[0] and block.valid[1] < t.shape[0] and block.valid[2] == t.shape[0]


def test_a_sweep_whose_quaternion_collapses_records_it_without_a_numpy_warning(cli, write, tmp_path):
    """The comparison recording keeps the collapsing cases' valid samples (NumPy printed
    "RuntimeWarning: divide by zero" to the user's terminal when their Λ reached 0, in a sweep
    that passed); the two cases fail (exit 1), the third passes."""
    text = ('[body]\nprincipal_moments = [1.0e-4, 2.0e-4, 2.8e-4]\n[initial]\nomega = [0.01, 0.01, 0.0]\n'
            '[[loads]]\ntype = "torque"\nframe = "body"\nvalue = [0.0, 0.0, 1.0]\n[time]\nend = 3.0\nsample_rate = 100\n'
            '[solver]\nmethod = "rk4"\nstep = 4e-4\n[sweep.parameters]\n"initial.omega[2]" = [0.0, 2000.0, -6000.0]\n')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = cli("sweep", str(write("collapse.toml", text)), "--outdir", str(tmp_path / "out"))
    assert result.exit_code == 1, result.stderr
    rows = list(csv.DictReader((tmp_path / "out" / "results.csv").open()))
    assert [r["status"] for r in rows] == ["fail", "fail", "pass"] and "the attitude is lost" in rows[0]["message"]
    assert (tmp_path / "out" / "collapse_sweep.rrd").exists()
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in caught]
