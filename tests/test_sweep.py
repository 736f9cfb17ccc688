"""Sweeps: reproducible cases, ensemble kernel = per-case runs, Dask, failing cases reported."""

from __future__ import annotations

import csv
import re

import numpy as np
import pyarrow.parquet as pq
import pytest

import rotlab
from rotlab.config.paths import parse_key_path
from rotlab.sweep.cases import expand
from rotlab.sweep.runner import plan, run_sweep, run_sweep_case
from tests.conftest import CONFIGS, VALID_BODY

SWEEP = VALID_BODY + """
[initial]
omega = [0.1, 2.0, 0.1]
[time]
end = 2.0
sample_rate = 20
[solver]
method = "rk4"
step = 0.01
[sweep]
seed = 3
samples = 2
[sweep.parameters]
"initial.omega[0]" = [0.0, 0.5]
"initial.omega[2]" = { uniform = [-0.2, 0.2] }
"""


def test_parse_path():
    assert parse_key_path("loads[0].value[2]", "here") == ["loads", 0, "value", 2]
    assert parse_key_path("body.mass", "here") == ["body", "mass"]


def test_cases_are_grid_times_draws_and_reproducible(write):
    p = plan(write("s.toml", SWEEP))
    assert len(p.cases) == 4
    assert [c.values["initial.omega[0]"] for c in p.cases] == [0.0, 0.0, 0.5, 0.5]
    again = expand(p.base.sweep)
    assert [c.values for c in again] == [c.values for c in p.cases]
    rng = np.random.default_rng([3, 2])  # case 2 alone, from seed and number
    assert p.cases[2].values["initial.omega[2]"] == rng.uniform(-0.2, 0.2)
    assert p.scenarios[2].initial.omega == (0.5, 2.0, p.cases[2].values["initial.omega[2]"])


def test_cases_change_only_their_own_copy_of_the_document(write):
    """``apply`` copies only the tables along a case's paths: the file's document and every
    other case keep their values (each case validated to its own ω, the base to the file's)."""
    import copy

    from rotlab.config.loader import read_toml
    from rotlab.sweep.cases import apply

    path = write("s.toml", SWEEP)
    raw = read_toml(path)
    before = copy.deepcopy(raw)
    p = plan(path)
    docs = [apply(raw, p.base, case.values) for case in p.cases]
    assert raw == before
    for doc, case, scenario in zip(docs, p.cases, p.scenarios):
        assert "sweep" not in doc
        assert doc["initial"]["omega"] == [case.values["initial.omega[0]"], 2.0, case.values["initial.omega[2]"]]
        assert scenario.initial.omega == tuple(doc["initial"]["omega"])
    assert docs[0]["body"] is raw["body"]  # untouched tables are shared, not copied


@pytest.mark.parametrize("initial, parameters, invalid", [
    ("omega = [0.1, 2.0, 0.1]", '"initial.omega[0]" = [0.0, 0.5]\n"initial.omega[2]" = { uniform = [-0.2, 0.2] }', 0),
    ("", '"initial.omega" = { sphere = 3.0 }\n"initial.quaternion" = [[1, 0, 0, 0], [0.6, 0.8, 0, 0], [0.6, 0.6, 0, 0]]', 2),
    ("omega_deg = [5.0, 100.0, 5.0]\neuler_313_deg = [10, 20, 30]", '"initial.omega_deg[1]" = [90.0, 110.0]\n"initial.euler_313_deg[1]" = { uniform = [0, 40] }', 0),
    ("omega_rpm = [10, 20, 30]\naxis_angle = [0.1, 0.2, 0.3]", '"initial.axis_angle" = [[0.1, 0.2, 0.3], [0, 0, 0]]\n"initial.omega_rpm[2]" = { normal = [30, 1] }', 0),
    ("omega = [0.1, 2.0, 0.1]", '"initial.omega[1]" = [2.0, 1e29]\n"initial.quaternion" = [[1, 0, 0, 0], [2, 0, 0, 0]]\n"initial.omega[0]" = { normal = [0, 0.1] }', 4),
])
def test_a_case_over_initial_conditions_is_its_whole_document_validated(write, initial, parameters, invalid):
    """A case that sweeps initial conditions only has its [initial] table validated alone and
    shares the rest of the file's scenario (``initial_case``): every such case equals its whole
    document validated — fields, the keys the file set, its error's wording — and the shortcut
    is taken for every valid case."""
    from rotlab.config.loader import parse_scenario
    from rotlab.errors import InputError
    from rotlab.sweep.cases import apply, case_scenario, initial_case

    text = SWEEP.replace("[initial]\nomega = [0.1, 2.0, 0.1]\n", f"[initial]\n{initial}\n").split("[sweep.parameters]")[0]
    p = plan(write("s.toml", text + "[sweep.parameters]\n" + parameters + "\n"))
    outcomes = {"valid": 0, "invalid": 0}
    for case in p.cases:
        fast = case_scenario(p.raw, p.base, case, p.source)
        try:
            whole = parse_scenario(apply(p.raw, p.base, case.values), source=f"{p.source} case {case.index}")
        except InputError as exc:
            assert isinstance(fast, InputError) and str(fast) == str(exc)
            outcomes["invalid"] += 1
            continue
        assert initial_case(p.raw, p.base, case.values) is not None
        assert fast == whole and fast.model_fields_set == whole.model_fields_set and fast.sweep is None
        assert fast.model_dump() == whole.model_dump() and fast.model_dump(exclude_unset=True) == whole.model_dump(exclude_unset=True)
        outcomes["valid"] += 1
    assert outcomes == {"valid": len(p.cases) - invalid, "invalid": invalid}


def test_sphere_draw_has_the_magnitude(write):
    text = SWEEP.replace('"initial.omega[0]" = [0.0, 0.5]\n"initial.omega[2]" = { uniform = [-0.2, 0.2] }', '"initial.omega" = { sphere = 3.0 }')
    p = plan(write("s.toml", text))
    for s in p.scenarios:
        assert np.linalg.norm(s.initial.omega) == pytest.approx(3.0, rel=1e-14)


def test_ensemble_equals_individual_runs_bit_for_bit(write):
    p = plan(write("s.toml", SWEEP))
    outcomes, how = run_sweep(p)
    assert "ensemble" in how
    for case, scenario, outcome in zip(p.cases, p.scenarios, outcomes):
        single = rotlab.simulate(scenario)
        np.testing.assert_array_equal(outcome.omega, single.omega)
        assert outcome.drift == single.max_drift()


def test_sweep_cli_writes_tables_and_comparison(cli, write, tmp_path):
    path = write("s.toml", SWEEP)
    result = cli("sweep", str(path), "-o", "out")
    assert result.exit_code == 0, result.output
    with open(tmp_path / "out" / "results.csv") as f:
        table = list(csv.DictReader(f))
    assert len(table) == 4 and {r["status"] for r in table} == {"pass"}
    assert pq.read_table(tmp_path / "out" / "results.parquet").num_rows == 4
    assert (tmp_path / "out" / "s_sweep.rrd").stat().st_size > 0


def test_failing_case_is_reported_and_the_rest_complete(cli, write, tmp_path):
    text = SWEEP.replace('"initial.omega[0]" = [0.0, 0.5]', '"body.principal_moments[0]" = [1.0, 9.0]')  # 9 > 2 + 2.5
    result = cli("sweep", str(write("s.toml", text)), "-o", "out", "-j", "2")
    assert result.exit_code == 1
    assert "triangle inequality" in result.stdout and "2 passed, 2 failed" in result.stdout


def test_bad_sweep_key_is_bad_input(cli, write):
    text = SWEEP.replace('"initial.omega[0]"', '"initial.omgea[0]"')
    result = cli("sweep", str(write("s.toml", text)))
    assert result.exit_code == 2 and "initial.omgea" in result.stderr


def test_sweep_needs_samples_for_random_parameters(cli, write):
    result = cli("sweep", str(write("s.toml", SWEEP.replace("samples = 2\n", ""))))
    assert result.exit_code == 2 and "sweep.samples" in result.stderr


def test_dask_local_cluster_gives_the_same_results(write):
    distributed = pytest.importorskip("dask.distributed")
    text = SWEEP.replace('method = "rk4"', 'method = "dop853"')
    p = plan(write("s.toml", text))
    local = [run_sweep_case(c, s) for c, s in zip(p.cases, p.scenarios)]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        remote, how = run_sweep(p, dask_address=cluster.scheduler_address)
    assert "Dask" in how
    for a, b in zip(local, remote):
        assert a.index == b.index and a.status == b.status == "pass"
        np.testing.assert_array_equal(a.omega, b.omega)


def test_unreachable_dask_scheduler_is_bad_input(write, monkeypatch):
    pytest.importorskip("dask.distributed")
    from rotlab import cluster
    from rotlab.errors import InputError

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", "2s")

    p = plan(write("s.toml", SWEEP))
    with pytest.raises(InputError, match="cannot reach a Dask scheduler"):
        run_sweep(p, dask_address="tcp://127.0.0.1:9")


def test_shipped_sweep_config_validates():
    p = plan(CONFIGS / "sweep_flip.toml")
    assert len(p.cases) == 12


FORMULA = '[[loads]]\ntype = "expression"\nframe = "body"\nconstants = { k = 0.5, k2 = 0.0 }\ntorque = ["-k*omega[0]", "-k*omega[1] + k2", "-k*omega[2]"]\n'


@pytest.mark.parametrize(("key", "expected"), [("initial.omgea[0]", "unknown key 'omgea': did you mean 'omega'?"),
                                               ("bdy.mass", "unknown key 'bdy': did you mean 'body'?"),
                                               ("loads[0].value", "index [0] is out of range"),
                                               ("loads[0].constants.kk", "unknown key 'kk': did you mean 'k'?"),
                                               ("loads[0].constants.x", "unknown key 'x': give it in the file's constants (it gives k, k2) to sweep it"),
                                               ("loads[0].constants.k[0]", "'loads[0].constants.k' holds one value, not a list: remove [0]"),
                                               ("body.principal_moments[0][1]", "'body.principal_moments[0]' holds one value, not a list: remove [1]"),
                                               ("checks.max_drift.L_norm", "unknown key 'L_norm': give it in the file's max_drift (it gives none) to sweep it"),
                                               ("sweep.seed", "the sweep's own settings are not swept: sweep a key of the scenario"),
                                               ("initial[0]", "'initial' is a table, not a list: name one of its keys"),
                                               ("initial.omega.x", "'initial.omega' is a list: index it, e.g. initial.omega[0]"),
                                               ("body.principal_moments[0].x", "'body.principal_moments[0]' holds one value: remove .x"),
                                               ("initial.quaternion[0]", "has no value in the scenario to index into: give the whole vector")])
def test_unknown_sweep_keys_say_the_closest_key(write, key, expected):
    from rotlab.errors import InputError

    text = SWEEP.replace('"initial.omega[0]" = [0.0, 0.5]', f'"{key}" = [1.0, 2.0]')
    if "constants" in key:  # a formula's constants: keys of the user's own, which the base names
        text = text.replace("[sweep]", FORMULA + "[sweep]")
    with pytest.raises(InputError, match=re.escape(f's.toml: sweep.parameters."{key}": ')) as info:
        plan(write("s.toml", text))
    assert str(info.value).endswith(expected)


def test_config_without_sweep_points_to_an_existing_readme_section(write):
    from rotlab.errors import InputError
    from tests.conftest import ROOT

    with pytest.raises(InputError, match="no \\[sweep\\] section") as info:
        plan(write("s.toml", VALID_BODY + "[time]\nend = 1.0\n"))
    readme = ROOT / "README.md"
    if readme.is_file():  # the README's scenario table has the [sweep] row the message points to
        text = readme.read_text(encoding="utf-8")
        assert "## Scenario files" in text and "| `[sweep]` |" in text
    assert "'Scenario files'" in str(info.value)


# 20 cases (2 bodies × 10 draws), run by taylor: no ensemble kernel, a chunk of several cases per task
CHUNKED = (SWEEP.replace('method = "rk4"\nstep = 0.01', 'method = "taylor"\n[checks]\nmax_drift = { energy = 1e-8 }')
           .replace("seed = 3\nsamples = 2", "seed = 4\nsamples = 10")
           .replace('"initial.omega[0]" = [0.0, 0.5]', '"body.principal_moments[0]" = [1.5, 2.0]'))


def test_cases_reported_together_equal_each_case_reported_alone(write):
    """A worker's chunk of cases is reported with its runs stacked (one array per body and loads:
    here two bodies, and spins of 2 and 2000 rad/s: the fast ones stop on their step budget after
    6 of the 41 samples and are stacked apart from the rest): every case's ω series, drifts,
    observables and checks equal those of the case run and reported alone, to the last bit."""
    from rotlab.sweep.runner import run_sweep_cases

    text = CHUNKED.replace('"initial.omega[2]"', '"initial.omega[1]" = [2.0, 2000.0]\n"initial.omega[2]"')
    text = text.replace('method = "taylor"', 'method = "taylor"\nmax_steps = 400')
    p = plan(write("s.toml", text))
    together = run_sweep_cases(p.cases, p.scenarios)
    assert [o.index for o in together] == list(range(40))
    assert {(o.status, len(o.t)) for o in together} == {("pass", 41), ("fail", 6)}
    for case, scenario, outcome in zip(p.cases, p.scenarios, together):
        alone = run_sweep_case(case, scenario)
        np.testing.assert_array_equal(outcome.omega, alone.omega)
        np.testing.assert_array_equal(outcome.energy_drift, alone.energy_drift)
        assert (outcome.status, outcome.drift, outcome.checks, outcome.message) == (alone.status, alone.drift, alone.checks, alone.message)
        np.testing.assert_array_equal(list(outcome.observables.values()), list(alone.observables.values()))


def test_a_chunk_whose_worker_died_runs_again_case_by_case(write, monkeypatch):
    """Local workers take cases in chunks; when a chunk's worker dies, its cases run again one per
    task: the case that killed it (here: every task holding case 7 dies) is the only error."""
    from rotlab import parallel
    from rotlab.sweep import runner

    p = plan(write("s.toml", CHUNKED))
    tasks_seen: list[int] = []

    def pool(fn, tasks, jobs, **kw):
        ends = []
        for k, task in enumerate(tasks):
            tasks_seen.append(len(task[3]))
            if any(case.index == 7 for case in task[3]):
                ends.append(parallel.TaskEnd(k, None, "worker died (killed by SIGKILL)"))
            else:
                ends.append(parallel.TaskEnd(k, fn(*task)))
        return parallel.TaskRun(ends)

    monkeypatch.setattr(runner, "run_tasks", pool)
    run = runner.run_cases(p, jobs=1)
    size = runner.chunk_size(20, 1)
    assert size > 1 and tasks_seen == [size] * (20 // size) + [1] * size
    assert [o.status for o in run.outcomes] == ["pass"] * 7 + ["error"] + ["pass"] * 12
    assert run.outcomes[7].message == "worker died (killed by SIGKILL)"
    assert f"{size} cases a task" in run.how


@pytest.mark.parametrize("cases, failing", [(12, {3, 7}), (400, {5, 9, 300}), (400, set(range(0, 400, 5)))])
def test_the_terminal_shows_a_large_sweeps_failing_cases_only(cases, failing):
    """Up to ``TERMINAL_ROWS`` cases every row is printed; beyond, the rows and messages of (at
    most ``TERMINAL_ROWS``) cases that did not pass, and where the rest are."""
    from rotlab.sweep.report import TERMINAL_ROWS, terminal_table
    from rotlab.sweep.results import Results
    from rotlab.sweep.runner import CaseOutcome

    outcomes = [CaseOutcome(k, {"initial.omega[0]": 0.1 * k}, "fail" if k in failing else "pass", method="rk4",
                            message=f"case {k} broke a bound" if k in failing else "") for k in range(cases)]
    results = Results(["initial.omega[0]"], [])
    results.add(outcomes[::-1])  # (cases finish in any order: the table is in case order)
    lines = terminal_table(results, "1 local worker process").splitlines()
    table_rows = [line for line in lines[2:-1] if line.split()[0].isdigit()]
    messages = [line for line in lines if line.startswith("case ") and ": " in line]
    assert lines[-1] == f"{cases - len(failing)} passed, {len(failing)} failed"
    if cases <= TERMINAL_ROWS:
        assert [int(line.split()[0]) for line in table_rows] == list(range(cases))
        assert not any("not shown" in line for line in lines)
    else:
        shown = sorted(failing)[:TERMINAL_ROWS]
        assert [int(line.split()[0]) for line in table_rows] == shown
        assert f"({cases - len(failing):,} passing cases not shown: every case is in results.csv)" in lines
        more = len(failing) - TERMINAL_ROWS
        assert (f"(and {more:,} more cases that did not pass: see results.csv)" in lines) == (more > 0)
    assert messages == [f"case {k}: FAIL: case {k} broke a bound" for k in sorted(failing)[:TERMINAL_ROWS]]


def test_an_rk4_sweep_over_initial_states_with_a_formula_load_runs_and_names_its_failures(cli, write, tmp_path):
    """Formula loads run in the ensemble kernels (handed to the threads apart from the model: nested
    in it, numba's parallel loop refused it with a TypeError traceback); a formula that fails is
    named as the case's single run names it."""
    text = ('[body]\nprincipal_moments = [1.0e-4, 2.0e-4, 2.8e-4]\n[initial]\nomega = [0.01, 10.0, 0.01]\n'
            '[[loads]]\ntype = "expression"\nframe = "body"\ntorque = ["0", "1e-5*sqrt(omega[1] - 9.995)", "0"]\n'
            '[time]\nend = 2.0\nsample_rate = 100\n[solver]\nmethod = "rk4"\nstep = 1e-3\n'
            '[sweep]\n[sweep.parameters]\n"initial.omega[0]" = [0.001, 0.1]\n')
    result = cli("sweep", str(write("bad.toml", text)), "-o", "out")
    assert result.exit_code == 1 and "Traceback" not in result.stderr + result.stdout
    assert "ensemble kernels (rk4" in result.stdout
    rows = list(csv.DictReader((tmp_path / "out" / "results.csv").open()))
    assert [r["status"] for r in rows] == ["fail", "fail"]
    assert all("loads[0].torque[1] = '1e-5*sqrt(omega[1] - 9.995)' is not finite at t = " in r["message"] for r in rows)


def test_a_sweep_over_a_formulas_constants_runs_each_case_as_alone_with_one_compiled_function(cli, write, tmp_path, monkeypatch):
    """A formula's named constants (``loads[0].constants.k``) are sweep parameters, a grid or a
    random draw.  The cases' formulas differ in their constants only, so they share one generated
    function (before, a sweep over a gain compiled, and cached on disk, one function a case: 0.6 s
    each), which takes each case's constants: a case's row is its run alone, and −k ω written as
    a formula runs as the built-in damping of coefficient k does."""
    monkeypatch.setenv("ROTLAB_CACHE", str(tmp_path / "cache"))
    text = SWEEP.replace("[sweep]", FORMULA + "[sweep]").replace('"initial.omega[0]" = [0.0, 0.5]', '"loads[0].constants.k" = [0.05, 0.4]')
    text = text.replace('"initial.omega[2]" = { uniform = [-0.2, 0.2] }', '"loads[0].constants.k2" = { normal = [0.0, 0.1] }')
    path = write("s.toml", text)
    result = cli("sweep", str(path), "-o", "out", "-j", "1")
    assert result.exit_code == 0, result.stdout + result.stderr
    rows = list(csv.DictReader((tmp_path / "out" / "results.csv").open()))
    assert len(rows) == 4 and len({r["loads[0].constants.k2"] for r in rows}) == 4
    assert len(list((tmp_path / "cache" / "formulas").glob("*.py"))) == 1
    for row in rows:
        overrides = {key: float(row[key]) for key in ("loads[0].constants.k", "loads[0].constants.k2")}
        alone = rotlab.simulate(path, overrides=overrides)
        assert (int(row["steps"]), float(row["max_drift_quaternion_norm"])) == (alone.stats.steps, alone.max_drift()["quaternion_norm"])
    finals = []
    for k in (0.05, 0.4):  # k2 = 0: the formula is the built-in damping −k ω, each k its own (one shared function)
        formula = rotlab.simulate(path, overrides={"loads[0].constants.k": k, "loads[0].constants.k2": 0.0})
        builtin = rotlab.simulate(path, overrides={"loads[0]": {"type": "damping", "coefficient": k}})
        np.testing.assert_allclose(formula.omega, builtin.omega, rtol=0, atol=1e-14)
        finals.append(formula.omega[-1])
    assert np.linalg.norm(finals[1]) < 0.8 * np.linalg.norm(finals[0])


_STOP_DRIVER = """import os, signal, sys
import rotlab.scene.scene as scene
import rotlab.sweep.results as results
where, at = sys.argv[1], int(sys.argv[2])
calls = [0]

def stop_at(fn):
    def wrapped(*args, **kwargs):
        value = fn(*args, **kwargs)
        calls[0] += 1
        if calls[0] == at:
            os.kill(os.getpid(), signal.SIGINT)  # (its handler runs here, inside the step)
            sum(range(1000))
        return value
    return wrapped

if where == "rows":  # as a block's rows were just written to results.partial.csv, before they were counted
    results.Results._append_csv = stop_at(results.Results._append_csv)
elif where == "files":  # once results.csv and .parquet are written, every case finished (the recording next)
    import rotlab.sweep.report as report
    report.write_results = stop_at(report.write_results)
else:  # while a case's scene is built
    scene.build_scene = stop_at(scene.build_scene)
from rotlab.__main__ import entry
sys.argv = ["rotlab", "sweep", "s.toml", "-o", "out", "-j", "1"]
entry()
"""


@pytest.mark.parametrize("where, at", [("rows", 2), ("scene", 100)])
def test_ctrl_c_stops_an_ensemble_sweep_between_blocks_with_each_case_once(tmp_path, where, at):
    """Ctrl-C in the ensemble's loop is heard between blocks: wherever it lands — as a block's
    rows are written, as a case's scene is built — the sweep stops with exit 130, each case is one
    row (the finished blocks' "pass", the others "not finished"), and no case becomes an error
    of its own.  (Raised where it landed, it wrote a block's rows twice, or became that case's
    error and the sweep ran on to exit 1.)"""
    import subprocess
    import sys

    (tmp_path / "s.toml").write_text(SWEEP.replace("samples = 2", "samples = 200"), encoding="utf-8")
    (tmp_path / "driver.py").write_text(_STOP_DRIVER, encoding="utf-8")
    done = subprocess.run([sys.executable, "driver.py", where, str(at)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 130, done.stdout + done.stderr
    with (tmp_path / "out" / "results.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert sorted(int(row["case"]) for row in rows) == list(range(400))
    statuses = [row["status"] for row in rows]
    finished = statuses.count("pass")
    assert 64 <= finished < 400 and statuses.count("error") == 400 - finished
    assert all(row["message"].startswith("not finished (the sweep received SIGINT)") for row in rows if row["status"] == "error")

def test_ctrl_c_while_the_results_files_are_written_lets_them_finish(tmp_path):
    """Every case finished: a stop signal while results.csv, .parquet and the recording are
    written is held until they are (exit 130), not left with results.partial.csv alone."""
    import subprocess
    import sys

    (tmp_path / "s.toml").write_text(SWEEP.replace("samples = 2", "samples = 200"), encoding="utf-8")
    (tmp_path / "driver.py").write_text(_STOP_DRIVER, encoding="utf-8")
    done = subprocess.run([sys.executable, "driver.py", "files", "1"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode == 130, done.stdout + done.stderr
    with (tmp_path / "out" / "results.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert sorted(int(row["case"]) for row in rows) == list(range(400)) and all(row["status"] == "pass" for row in rows)
    assert pq.read_table(tmp_path / "out" / "results.parquet").num_rows == 400
    assert (tmp_path / "out" / "s_sweep.rrd").exists() and not (tmp_path / "out" / "results.partial.csv").exists()



def test_a_sweep_run_in_process_leaves_the_collector_as_it_found_it(cli, write):
    """`rotlab sweep` freezes the objects alive before its cases for their collections
    (``heap.objects_frozen``) and unfreezes them after: run in a caller's process, an object of
    the caller's in a reference cycle is still collected once dropped, and objects the caller
    froze itself stay frozen."""
    import gc
    import weakref

    class Cycle:
        def __init__(self) -> None:
            self.me = self

    held = Cycle()
    alive = weakref.ref(held)
    assert cli("sweep", str(write("s.toml", SWEEP)), "-o", "out").exit_code == 0
    assert gc.get_freeze_count() == 0
    del held
    gc.collect()
    assert alive() is None
    gc.freeze()  # a caller that froze objects itself keeps them frozen
    try:
        frozen = gc.get_freeze_count()
        assert frozen > 0 and cli("sweep", str(write("s.toml", SWEEP)), "-o", "out2").exit_code == 0
        assert gc.get_freeze_count() > frozen // 2  # (0 had the sweep unfrozen them; a few frozen objects die meanwhile)
    finally:
        gc.unfreeze()


def test_a_swept_initial_value_replaces_the_files_given_another_way_as_set_does(write):
    """A sweep sets a case's value as `--set` does (``loader.set_value``): a swept ω, or a
    component of it, replaces the file's ``omega_rpm`` (the other components the file's,
    converted), a swept quaternion the file's Euler angles; two swept keys that give one
    quantity two ways are refused (one would replace the other)."""
    import math

    from rotlab.config.loader import parse_scenario, read_toml
    from rotlab.errors import InputError

    rpm = math.pi / 30.0
    text = VALID_BODY + ("[initial]\nomega_rpm = [10, 20, 30]\neuler_313_deg = [10, 20, 30]\n[time]\nend = 1.0\n[solver]\nmethod = \"rk4\"\n"
                         "step = 0.001\n[sweep]\n[sweep.parameters]\n")
    p = plan(write("s.toml", text + '"initial.omega[0]" = [0.1, 0.2]\n"initial.quaternion" = [[0, 1, 0, 0]]\n'))
    for case, scenario in zip(p.cases, p.scenarios):
        assert scenario.initial.omega == pytest.approx((case.values["initial.omega[0]"], 20 * rpm, 30 * rpm), rel=1e-15)
        assert scenario.initial.quaternion == (0.0, 1.0, 0.0, 0.0) and scenario.initial.euler_313_deg is None
    alone = parse_scenario(read_toml(write("one.toml", text.split("[sweep]")[0])), overrides={"initial.omega[0]": 0.2,
                                                                                              "initial.quaternion": [0, 1, 0, 0]})
    assert alone.initial == p.scenarios[1].initial
    for swept, message in (('"initial.omega" = [[1, 2, 3]]\n"initial.omega_deg" = [[1, 2, 3]]', "the same quantity as 'initial.omega', given another way"),
                           ('"initial.omega" = [[1, 2, 3]]\n"initial.omega_rpm[1]" = [1.0]', "sets part of 'initial.omega', which is swept too")):
        with pytest.raises(InputError, match=re.escape(message)):
            plan(write("s.toml", text + swept + "\n"))
