"""rotlab bench: the peers solve rotlab's equations, errors are measured correctly against the
references, records carry their JSON fields, ratios come from the work-precision data, and the
--quick command runs (on one problem, to stay fast)."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from typer.testing import CliRunner

import rotlab
from rotlab.bench import peers, runner
from rotlab.bench.problems import (
    CONFIGS,
    KROGH_M,
    get_problems,
    kovalevskaya_integral,
    krogh_scales,
    reference_solution,
    state_error,
)
from rotlab.core import quaternion as quat
from rotlab.core.dynamics import euler_coefficients, rhs
from rotlab.methods.base import Settings
from rotlab.methods.registry import get_method
from rotlab.scene.scene import build_scene

REQUIRED = ("problem", "method", "setting", "max_error", "seconds")


def _scene_of(name: str):
    (problem,) = get_problems([name])
    scenario = problem.scenario()
    return problem, build_scene(scenario), scenario.time.sample_times()


# --- peers: the same equations -------------------------------------------------------------------


@pytest.mark.parametrize("config", ["general.toml", "lagrange.toml", "euler.toml"])
def test_peer_rhs_is_rotlabs_rhs(config):
    """The peers' Python right-hand side equals rotlab's compiled one (every kind of load)."""
    scene = build_scene(rotlab.load(CONFIGS / config))
    f = peers.make_rhs(scene)
    rng = np.random.default_rng(3)
    for t in (0.5, 2.0, 3.0, 4.0, 5.5, 6.5, 9.0):
        y = np.zeros(8)
        q = rng.normal(size=4)
        y[:4] = q / np.linalg.norm(q)
        y[4:7] = 10.0 * rng.normal(size=3)
        dy = np.zeros(8)
        rhs(t, y, dy, scene.model)
        np.testing.assert_allclose(f(t, y[:7]), dy[:7], rtol=1e-13, atol=1e-13)


def test_scipy_dop853_agrees_with_exact_on_gni():
    _, scene, t = _scene_of("gni")
    exact = get_method("exact").solve(scene, t, Settings(), None).state
    sol = peers.solve_scipy("DOP853", scene, t, 1e-13, 1e-15)
    assert sol.failure is None and sol.rhs_evaluations > 0
    err, omega, attitude = state_error(sol.state, exact[:, :7])
    assert err < 1e-9


@pytest.mark.parametrize("method", peers.SCIPY_METHODS)
def test_every_scipy_peer_converges_on_krogh(method):
    problem, scene, t = _scene_of("krogh")
    ref = reference_solution(problem, scene, t).state
    loose = state_error(peers.solve_scipy(method, scene, t, 1e-5, 1e-7).state, ref)[0]
    tight = state_error(peers.solve_scipy(method, scene, t, 1e-9, 1e-11).state, ref)[0]
    assert tight < 1e-6 and tight < loose / 10


def test_seed_rk4_renormalises_and_is_fourth_order():
    problem, scene, t = _scene_of("krogh")
    ref = reference_solution(problem, scene, t).state
    coarse, fine = (peers.solve_seed_rk4(scene, t, n) for n in (2, 4))
    assert np.max(np.abs(np.linalg.norm(fine.state[:, :4], axis=1) - 1.0)) < 1e-15
    ratio = state_error(coarse.state, ref)[0] / state_error(fine.state, ref)[0]
    assert 12.0 < ratio < 20.0  # 2⁴ = 16
    assert fine.steps == 4 * (t.size - 1) and fine.rhs_evaluations == 4 * fine.steps


# --- problems and references ---------------------------------------------------------------------


def test_krogh_mapping_reproduces_sn_cn_dn():
    """Euler's equations with (A, B, C) = (2, 3, 1) and ω = diag(s) y are Krogh's system."""
    from scipy.special import ellipj

    s = krogh_scales()
    a, b, c = euler_coefficients(np.array([2.0, 3.0, 1.0]))[:3]
    assert a * s[1] * s[2] / s[0] == pytest.approx(1.0)
    assert b * s[2] * s[0] / s[1] == pytest.approx(-1.0)
    assert c * s[0] * s[1] / s[2] == pytest.approx(-KROGH_M)
    _, scene, t = _scene_of("krogh")
    np.testing.assert_allclose(scene.omega0, [0.0, s[1], s[2]])
    omega = get_method("exact").solve(scene, t, Settings(), None).state[:, 4:7]
    sn, cn, dn, _ = ellipj(t, KROGH_M)
    np.testing.assert_allclose(omega / s, np.column_stack([sn, cn, dn]), atol=1e-12)


def test_krogh_scales_refuse_unordered_moments():
    with pytest.raises(ValueError):
        krogh_scales((3.0, 2.0, 1.0))


def test_hnw_forcing_is_quarter_sin_squared():
    """The harmonic torque of hnw-eulr gives ω̇₃ = (A − B)/C p q + 0.25 sin² t on [3π, 4π) only."""
    _, scene, _ = _scene_of("hnw-eulr")
    f = peers.make_rhs(scene)
    y = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    for t in (1.0, 3.0 * np.pi + 0.3, 3.5 * np.pi, 4.0 * np.pi - 0.1, 4.0 * np.pi + 0.1, 15.0):
        expected = 0.25 * np.sin(t) ** 2 if 3.0 * np.pi <= t < 4.0 * np.pi else 0.0
        assert f(t, y)[6] == pytest.approx(expected, abs=1e-15)


def test_kovalevskaya_integral_is_conserved_and_sign_matters():
    problem, scene, t = _scene_of("kovalevskaya")
    state = get_method("dop853").solve(scene, t[:201], Settings(rtol=1e-12, atol=1e-14), None).state
    up = scene.field_direction
    k = kovalevskaya_integral(state, problem.kovalevskaya_nu, up)
    assert np.max(np.abs(k - k[0])) / k[0] < 1e-9
    wrong = kovalevskaya_integral(state, -problem.kovalevskaya_nu, up)
    assert np.max(np.abs(wrong - wrong[0])) / wrong[0] > 1e-2


def test_state_error_metric():
    rng = np.random.default_rng(0)
    q = rng.normal(size=(5, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = rng.normal(size=(5, 3))
    ref = np.hstack([q, w])
    assert state_error(ref, ref) == (0.0, 0.0, 0.0)
    flipped = ref.copy()
    flipped[2, :4] *= -1.0  # ±Λ is the same attitude
    assert state_error(flipped, ref)[0] == 0.0
    moved = ref.copy()
    moved[3, 4:7] += [1e-6, 0.0, 0.0]
    scale = np.max(np.linalg.norm(w, axis=1))
    assert state_error(moved, ref)[1] == pytest.approx(1e-6 / scale, rel=1e-6)
    turned = ref.copy()
    turned[1, :4] = quat.multiply_array(q[1], quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), 2e-6))
    assert state_error(turned, ref)[2] == pytest.approx(1e-6, rel=1e-5)  # |ΔΛ| ≈ angle / 2
    broken = ref.copy()
    broken[4, 0] = np.nan
    assert state_error(broken, ref)[0] == math.inf


def test_exact_reference_is_checked_and_exact_record_is_not_zero():
    """When exact is the reference, its record shows the distance to the independent check."""
    problem, scene, t = _scene_of("gni")
    ref = reference_solution(problem, scene, t)
    assert ref.uses_exact and ref.check is not None and ref.check < 1e-11
    options = runner.Options.make(quick=True, repeats=1)
    evaluate = runner.make_evaluator(problem, scene, ref)
    (series,) = [s for s in runner.rotlab_series(scene, t, options) if s.method == "exact"]
    (record,) = list(runner.sweep(problem, series, evaluate, options, ref))
    assert record.max_error >= ref.check > 0.0


# --- records, ratios, reports ----------------------------------------------------------------------


def test_records_have_json_fields_and_sane_values():
    problem, scene, t = _scene_of("krogh")
    options = runner.Options.make(quick=True, repeats=1)
    ref = reference_solution(problem, scene, t)
    evaluate = runner.make_evaluator(problem, scene, ref)
    series = [s for s in runner.rotlab_series(scene, t, options) if s.method in ("dop853", "rk4")]
    series += [s for s in runner.peer_series(scene, t, options) if s.method in ("scipy:DOP853", peers.SEED_RK4)]
    records = [r for s in series for r in runner.sweep(problem, s, evaluate, options, ref)]
    methods = {r.method for r in records}
    assert {"dop853", "rk4", "scipy:DOP853", "seed:rk4-renormalised"} <= methods
    for r in records:
        item = json.loads(json.dumps(r.to_json()))
        assert all(key in item for key in REQUIRED)
        assert item["seconds"] > 0.0 and item["repeats"] >= 1
        assert item["side"] == ("rotlab" if not r.method.startswith(("scipy:", "seed:")) else r.method.split(":")[0])
    dop = [r for r in records if r.method == "dop853"]
    assert dop[-1].max_error < dop[0].max_error  # tighter tolerance, smaller error


def _record(problem, method, side, err, sec, setting="s"):
    return runner.Record(problem=problem, method=method, setting=setting, max_error=err, seconds=sec, side=side, series=method)


def test_ratio_uses_fastest_run_reaching_threshold_and_log_log_interpolation():
    records = [
        _record("p", "fast", "rotlab", 1e-8, 1e-4), _record("p", "fast", "rotlab", 1e-12, 1e-3),
        _record("p", "exact", "rotlab", 1e-14, 5e-3),
        _record("p", "scipy:DOP853", "scipy", 1e-9, 1e-2), _record("p", "scipy:DOP853", "scipy", 1e-11, 1e-1),
        _record("p", "scipy:RK45", "scipy", 1e-6, 1.0),
    ]
    (row,) = runner.ratios(records, 1e-10)
    assert row["rotlab"]["method"] == "fast" and row["rotlab"]["seconds"] == 1e-3
    assert row["rotlab_vs_scipy"] == pytest.approx(1e-1 / 1e-3)
    # log-log: error 1e-8 → 1e-12 over 1e-4 → 1e-3 s crosses 1e-10 at 10^-3.5 s; scipy at 10^-1.5 s
    assert row["rotlab"]["interpolated_seconds"] == pytest.approx(10**-3.5)
    assert row["rotlab_vs_scipy_interpolated"] == pytest.approx(100.0)
    assert row["seed"] is None and row["rotlab_vs_seed"] is None
    (row,) = runner.ratios(records[:3] + records[5:], 1e-10)
    assert row["scipy"]["reached"] is False and row["rotlab_vs_scipy"] is None


def test_energy_windows_structure():
    options = runner.Options.make(quick=True, repeats=1)
    rows = runner.energy_windows(options, steps=20_000, windows=4, chunk=3000)
    names = [r["method"] for r in rows]
    assert "splitting-2" in names and "rk4" in names
    for r in rows:
        assert len(r["windows"]) == 4 and r["max_error"] == max(r["windows"])
        assert r["final_time"] == pytest.approx(20_000 * 0.05)
    split2 = next(r for r in rows if r["method"] == "splitting-2")
    assert split2["max_error"] < 1e-3


def test_run_timing_cold_and_warm(tmp_path):
    """`rotlab run` in a subprocess: the cold run fills the fresh NUMBA_CACHE_DIR it is given."""
    options = runner.Options.make(quick=True, repeats=1)
    (row,) = runner.run_timing(options, configs=[CONFIGS / "euler.toml"], cold_repeats=1)
    assert row["cold_seconds"] > 0.0 and row["warm_seconds"] > 0.0 and len(row["warm_all"]) == 1
    assert row["command"].startswith("rotlab run configs/euler.toml")


def test_bench_command_module_imports_nothing_heavy():
    code = "import sys, rotlab.bench.command; assert 'numpy' not in sys.modules and 'scipy' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_quick_command_on_one_problem(tmp_path):
    import typer

    from rotlab.bench.command import bench

    app = typer.Typer()
    app.command()(bench)
    out = tmp_path / "bench.json"
    args = ["--quick", "--problem", "krogh", "--only", "wp", "--repeats", "1", "--json", str(out)]
    try:
        import matplotlib  # noqa: F401

        args += ["--plots", str(tmp_path / "plots")]
        plots = True
    except ImportError:
        plots = False
    result = CliRunner().invoke(app, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    first_table = result.stdout.split("==", 1)[1]
    assert first_table.startswith(" rotlab at max error ≤ 1e-10") and "krogh" in first_table.split("\n\n")[0]  # the headline first
    assert "speed-up at max error" not in result.stdout and "h=" not in result.stderr  # details on request only
    detailed = CliRunner().invoke(app, args[:-2] + ["--details"] if plots else args + ["--details"], catch_exceptions=False)
    assert "speed-up at max error ≤ 1e-10" in detailed.stdout and "== krogh" in detailed.stdout
    items = json.loads(out.read_text())
    wp = [x for x in items if x["kind"] == "work-precision"]
    assert wp and all(all(k in x for k in REQUIRED) for x in wp)
    assert {x["method"] for x in wp} >= {"exact", "dop853", "scipy:DOP853", "scipy:LSODA", "seed:rk4-renormalised"}
    assert any(x["kind"] == "ratio" and x["problem"] == "krogh" for x in items)
    if plots:
        assert (tmp_path / "plots" / "wp_krogh.png").stat().st_size > 10_000


def test_command_refuses_unknown_problem_and_section():
    import typer

    from rotlab.bench.command import bench

    app = typer.Typer()
    app.command()(bench)
    result = CliRunner().invoke(app, ["--problem", "nope"])
    assert result.exit_code == 2 and "unknown problem" in result.output
    result = CliRunner().invoke(app, ["--only", "wp,nope"])
    assert result.exit_code == 2 and "unknown section" in result.output


def test_every_bench_problem_is_a_valid_scenario():
    """A bench problem that no longer validates would take its whole row out of ``rotlab bench``."""
    from rotlab.bench.problems import all_problems

    for problem in all_problems():
        assert problem.scenario().title or problem.name
