"""Events (``rotlab.events``) against closed forms: the intermediate-axis flip recurs at Jacobi's
period 4K(m)/λ (complete elliptic integral, mpmath at 30 digits), and a heavy symmetric top turns
back (θ̇ = 0) exactly at the roots of its cubic f(u) = (1 − u²)(2E' − 2mgl u)/A − (a − b u)²/A²
(u = cos θ, a = L·up, b = C ω₃).  Event times are located on each method's own local solution,
not on the samples: they hold with one sample every 0.2 s.  Also: directions, terminal events,
formulas that are not finite, bad input, sweeps and the recording."""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest

import rotlab
from rotlab.errors import InputError, RunFailure
from rotlab.method_names import METHOD_NAMES
from rotlab.recording.reader import read_series
from tests.conftest import CONFIGS

FLIP = {"name": "flip", "when": "omega[1]", "direction": "falling", "record": ["omega[0]", "omega[2]"]}
TURN = {"name": "turn", "when": "gamma[0]*omega[1] - gamma[1]*omega[0]", "record": ["gamma[2]"]}  # d(cos θ)/dt = (γ × ω)₃


def jacobi_period(moments, omega) -> float:
    """The period of ω's motion on its polhode, 4 K(m) / λ (Landau & Lifshitz §37), at 30 digits."""
    mp.mp.dps = 30
    A, B, C = (mp.mpf(repr(x)) for x in moments)
    w = [mp.mpf(repr(x)) for x in omega]
    L2 = (A * w[0]) ** 2 + (B * w[1]) ** 2 + (C * w[2]) ** 2
    T2 = A * w[0] ** 2 + B * w[1] ** 2 + C * w[2] ** 2
    if L2 / T2 > B:
        lam, m = mp.sqrt((C - B) * (L2 - T2 * A) / (A * B * C)), (B - A) * (T2 * C - L2) / ((C - B) * (L2 - T2 * A))
    else:
        lam, m = mp.sqrt((B - A) * (T2 * C - L2) / (A * B * C)), (C - B) * (L2 - T2 * A) / ((B - A) * (T2 * C - L2))
    return float(4 * mp.ellipk(m) / lam)


def flip_run(method: str, **overrides):
    return rotlab.simulate(CONFIGS / "dzhanibekov.toml", method=method, overrides={"events": [FLIP], **overrides})


@pytest.mark.parametrize("method", METHOD_NAMES)
def test_the_flip_recurs_at_jacobis_period_in_every_method(method):
    """Falling zeros of ω_y one period apart: exact to 1e-13 (measured 7e-16), the stepping
    methods at rtol 1e-10 to 3e-9 (measured ≤ 1e-9: the error grows near the separatrix); the
    first time agrees with the closed form's to 5e-11 (measured ≤ 7e-12)."""
    period = jacobi_period((1e-4, 2e-4, 2.8e-4), (0.01, 10.0, 0.01))
    flips = flip_run(method).events["flip"]
    assert flips.count == 5
    error = np.max(np.abs(flips.intervals() - period)) / period
    assert error <= (1e-13 if method == "exact" else 3e-9), error
    reference = flip_run("exact").events["flip"]
    assert abs(flips.t[0] - reference.t[0]) <= 5e-11 * reference.t[0]
    assert np.all(flips.values[:, 0] < 0.0) and not flips.rising.any()  # the record: ω_x at each falling zero
    assert np.array_equal(flips.omega[:, [0, 2]], flips.values)  # the state there (user's body frame), the record's source
    assert np.all(np.abs(flips.omega[:, 1]) <= 1e-9 * np.linalg.norm(flips.omega, axis=1))
    assert np.allclose(np.linalg.norm(flips.quaternion, axis=1), 1.0, atol=1e-9)


@pytest.mark.parametrize("method", ["exact", "dop853", "taylor", "rk4", "dmv"])
def test_event_times_come_from_the_local_solution_not_the_samples(method):
    """Five samples a second (ω_y turns over in ~0.3 s): linear interpolation of the samples would
    be off by ~1e-2 s; the local solution gives the same times as at 200 samples a second."""
    dense, sparse = flip_run(method), flip_run(method, **{"time.sample_rate": 5})
    assert sparse.events["flip"].count == dense.events["flip"].count
    assert np.max(np.abs(sparse.events["flip"].t - dense.events["flip"].t)) <= 1e-8


def lagrange_turning_points() -> np.ndarray:
    """The roots u₁ < u₂ in [−1, 1] of the top's cubic f(u) (module docstring), configs/lagrange.toml."""
    mp.mp.dps = 30
    A, C, mgl = mp.mpf("1.1e-3"), mp.mpf("5e-4"), mp.mpf("0.5") * mp.mpf("9.81") * mp.mpf("0.04")
    u0 = mp.cos(mp.radians(25))
    w3 = mp.mpf(150)
    b = C * w3  # L along the symmetry axis
    a = b * u0  # L·up: at rest in precession, only the spin contributes
    energy = mgl * u0  # E' = ½A(ω₁² + ω₂²) + mgl γ₃, ω₁ = ω₂ = 0
    # f(u) A² = A (1 − u²)(2E' − 2 mgl u) − (a − b u)²: coefficients of u³ … u⁰
    coefficients = [2 * A * mgl, -(2 * A * energy) - b * b, -(2 * A * mgl) + 2 * a * b, 2 * A * energy - a * a]
    roots = sorted(float(mp.re(r)) for r in mp.polyroots(coefficients, maxsteps=200, extraprec=60) if abs(mp.im(r)) < 1e-20 and -1 <= mp.re(r) <= 1)
    return np.array(roots)


@pytest.mark.parametrize("method", ["exact", "taylor", "dop853", "splitting"])
def test_a_heavy_top_turns_back_at_the_roots_of_its_cubic(method):
    """cos θ at every θ̇ = 0 is a root of f(u): to 1e-9 (measured ≤ 2e-11 for taylor and dop853)."""
    u1, u2 = lagrange_turning_points()
    traj = rotlab.simulate(CONFIGS / "lagrange.toml", method=method, overrides={"events": [TURN], "time.end": 2.0})
    turns = traj.events["turn"]
    assert turns.count >= 20
    cos_theta = turns.values[:, 0]
    nearest = np.where(np.abs(cos_theta - u1) < np.abs(cos_theta - u2), u1, u2)
    assert np.max(np.abs(cos_theta - nearest)) <= 1e-9
    assert set(np.round(nearest, 12)) == {round(u1, 12), round(u2, 12)}  # both turning points are met
    top = turns.rising  # γ₃ = cos θ rises through its minimum and falls through its maximum, in turn
    assert np.all(top[1:] != top[:-1])


def test_directions_split_the_occurrences_and_alternate():
    both = flip_run("exact", events=[{**FLIP, "direction": "both"}]).events["flip"]
    rising = flip_run("exact", events=[{**FLIP, "direction": "rising"}]).events["flip"]
    falling = flip_run("exact").events["flip"]
    assert both.count == rising.count + falling.count
    assert np.array_equal(np.sort(np.r_[rising.t, falling.t]), both.t)
    assert np.all(both.rising[1:] != both.rising[:-1])


@pytest.mark.parametrize("method", ["rk4", "dop853", "exact"])
def test_a_terminal_event_ends_the_run_at_its_count(method):
    event = {"name": "stop", "when": "omega[1]", "terminal": True, "count": 3}
    ref = flip_run(method, events=[{"name": "stop", "when": "omega[1]"}]).events["stop"]
    traj = flip_run(method, events=[event])
    stop = traj.events["stop"]
    assert stop.count == 3 and np.array_equal(stop.t, ref.t[:3])
    assert traj.t[-1] == stop.t[-1] and np.all(np.diff(traj.t) > 0)
    assert abs(traj.omega[-1, 1]) <= 1e-9 * np.linalg.norm(traj.omega[-1])  # the last state is on the event
    assert "event 'stop' (occurrence 3)" in traj.stats.details["ended by"]
    assert traj.ok


def test_events_leave_the_run_itself_unchanged():
    """The watch only reads the samples: the states are bit for bit those of a run without events."""
    for method in ("rk4", "dop853", "taylor"):
        plain = rotlab.simulate(CONFIGS / "dzhanibekov.toml", method=method)
        watched = flip_run(method)
        assert np.array_equal(plain.quaternion, watched.quaternion) and np.array_equal(plain.omega, watched.omega)


def test_a_formula_that_is_not_finite_stops_the_run_naming_the_event():
    with pytest.raises(RunFailure, match=r"event 'bad': when = \"log\(omega\[1\]\)\" is not finite at t = 1\.67") as caught:
        flip_run("rk4", events=[{"name": "bad", "when": "log(omega[1])"}])
    kept = caught.value.trajectory
    assert np.all(kept.omega[:, 1] > 0.0) and kept.t[-1] < 1.68  # the valid samples, up to the first NaN
    for method in ("rk4", "dop853", "exact"):  # not finite at t0 itself: the run ends there, without a step
        with pytest.raises(RunFailure, match=r"event 'bad': when = \"log\(-omega\[1\]\)\" is not finite at t = 0 s") as first:
            flip_run(method, events=[{"name": "bad", "when": "log(-omega[1])"}])
        assert first.value.trajectory.t.shape[0] == 1 and first.value.trajectory.stats.steps == 0
    with pytest.raises(RunFailure, match=r"event 'r': record\[0\] = \"sqrt\(omega\[0\]\)\" is not finite"):
        flip_run("dop853", events=[{"name": "r", "when": "omega[1]", "record": ["sqrt(omega[0])"]}])


@pytest.mark.parametrize(("event", "key", "words"), [
    ({"name": "x", "when": "omega[3]"}, "events[0].when", "column 7"),
    ({"name": "x", "when": "omga[1]"}, "events[0].when", "only omega[i]"),
    ({"name": "x", "when": "omega[1]", "record": ["q[4]"]}, "events[0].record[0]", "index 0 … 3"),
    ({"name": "x", "when": "omega[1]", "count": 2}, "events[0].count", "terminal = true"),
    ({"name": "x y", "when": "omega[1]"}, "events[0].name", "plain identifier"),
    ({"name": "x", "when": "omega[1]", "direction": "up"}, "events[0].direction", "rising"),
])
def test_bad_events_are_one_line_errors_naming_the_key(event, key, words):
    with pytest.raises(InputError) as caught:
        rotlab.load(CONFIGS / "dzhanibekov.toml", overrides={"events": [event]})
    assert key in str(caught.value) and words in str(caught.value) and "\n" not in str(caught.value)


def test_two_events_of_one_name_are_refused():
    with pytest.raises(InputError, match=r"events\[1\]\.name: event name 'flip' is used twice"):
        rotlab.load(CONFIGS / "dzhanibekov.toml", overrides={"events": [FLIP, FLIP]})


def test_run_prints_the_events_and_records_them(cli, write, tmp_path):
    text = (CONFIGS / "dzhanibekov.toml").read_text().replace("#:schema ./scenario.schema.json", "")
    text += '\n[[events]]\nname = "flip"\nwhen = "omega[1]"\ndirection = "falling"\nrecord = ["omega[0]", "omega[2]"]\n'
    write("flip.toml", text)
    result = cli("run", "flip.toml", "-o", "flip.rrd")
    assert result.exit_code == 0, result.output
    expected = flip_run("exact").events["flip"]
    assert f"event    flip: 5 occurrences, first at t = {expected.t[0]:.12g} s" in result.stdout
    t, values = read_series(tmp_path / "flip.rrd", "/events/flip")
    assert np.allclose(t, expected.t, atol=1e-9) and np.allclose(values, expected.values, rtol=1e-9)


def test_a_terminal_event_ends_a_streamed_run_too(cli, write, tmp_path):
    text = (CONFIGS / "dzhanibekov.toml").read_text().replace("#:schema ./scenario.schema.json", "")
    write("stop.toml", text + '\n[[events]]\nname = "stop"\nwhen = "omega[1]"\nterminal = true\ncount = 2\n')
    result = cli("run", "stop.toml", "-o", "stop.rrd")
    assert result.exit_code == 0, result.output
    t, _ = read_series(tmp_path / "stop.rrd", "/body/omega")
    expected = flip_run("exact", events=[{"name": "stop", "when": "omega[1]"}]).events["stop"].t[1]
    assert abs(t[-1] - expected) <= 1e-9 and "2 occurrences" in result.stdout


def test_a_sweep_reports_each_cases_events(cli, write, tmp_path):
    text = (CONFIGS / "sweep_flip.toml").read_text().replace("#:schema ./scenario.schema.json", "").replace("samples = 4 ", "samples = 1 ")
    write("sweep.toml", text + '\n[[events]]\nname = "flip"\nwhen = "omega[1]"\ndirection = "falling"\n')
    result = cli("sweep", "sweep.toml", "-o", "out", "-j", "1")
    assert result.exit_code == 0, result.output
    import csv

    rows = list(csv.DictReader((tmp_path / "out" / "results.csv").open()))
    assert len(rows) == 3
    for row in rows:
        overrides = {"initial.omega[0]": float(row["initial.omega[0]"]), "initial.omega[2]": float(row["initial.omega[2]"])}
        flips = rotlab.simulate(tmp_path / "sweep.toml", overrides=overrides).events["flip"]
        assert int(row["event_flip_count"]) == flips.count
        assert float(row["event_flip_first_s"]) == pytest.approx(flips.t[0], rel=1e-12)
        assert float(row["event_flip_interval_s"]) == pytest.approx(flips.intervals().mean(), rel=1e-12)
    from rotlab.recording.reader import entity_paths

    drawn = entity_paths(tmp_path / "out" / "sweep_sweep.rrd")  # each event column drawn against each parameter
    assert {"/results/initial_omega_0/event_flip_first_s/cases", "/results/initial_omega_0/event_flip_count/cases"} <= drawn


def test_a_terminal_event_stops_the_stepping_soon_after_it():
    """The watch sees the rows every ``WATCHED_STEPS`` steps at most: the run ends ≤ that many
    steps past the event (5,000 steps to t = 5 s at h = 1e-3, over a span of 80 s)."""
    from rotlab.methods.stepping import WATCHED_STEPS

    traj = flip_run("rk4", **{"solver.step": 1e-3, "time.end": 80.0, "time.sample_rate": 10.0},
                    events=[{"name": "stop", "when": "t - 5", "terminal": True}])
    assert traj.t[-1] == 5.0 and 5000 <= traj.stats.steps <= 5000 + WATCHED_STEPS


def test_a_sign_change_through_a_pole_is_not_an_event():
    """1/(ω_y − c) changes sign where ω_y crosses c, through ±∞: no occurrence; the same crossing
    written as ω_y − c is one."""
    pole = flip_run("dop853", events=[{"name": "pole", "when": "1/(omega[1] - 5)"}, {"name": "root", "when": "omega[1] - 5"}]).events
    assert pole["pole"].count == 0 and pole["root"].count >= 8


def test_a_root_at_the_start_of_its_sample_interval_is_an_occurrence():
    """log(8.194 − t) is 0 at t = 7.194 s, a sample time at 500 samples/s: Brent's root lands on
    the interval's start, τ = 0 (the state there is the sample's own; it raised KeyError before)."""
    traj = flip_run("rk4", **{"solver.step": 1e-3, "time.sample_rate": 500.0, "time.end": 8.0},
                    events=[{"name": "lg", "when": "log(8.194 - t)"}])
    assert traj.events["lg"].count == 1 and abs(traj.events["lg"].t[0] - 7.194) <= 1e-12


@pytest.mark.parametrize("method", ["dop853", "taylor", "rk4", "rkmk4"])
def test_a_root_on_a_sample_time_is_found_by_every_method_alone_and_in_the_ensemble(method):
    """sin(π t) is 0 at t = 1 s, a sample at 100 samples/s: located at its interval's start, the
    local solution runs over no time.  dop853's starting step divided by that empty span: a
    ZeroDivisionError traceback (found by a review).  Now one occurrence at t = 1 s (to 1e-12),
    alone and in the ensemble kernels alike."""
    from rotlab.ensemble.block import run_block
    from rotlab.methods.base import Settings
    from rotlab.methods.registry import get_method
    from rotlab.scene.scene import build_scene

    scenario = rotlab.load(CONFIGS / "dzhanibekov.toml", method=method, overrides={
        "time.end": 1.5, "time.sample_rate": 100.0, "events": [{"name": "tick", "when": "sin(pi*t)"}]})
    traj = rotlab.simulate(scenario)
    assert traj.events["tick"].count == 1 and abs(traj.events["tick"].t[0] - 1.0) <= 1e-12
    block = run_block([build_scene(scenario)], get_method(method), Settings.of(scenario.solver), scenario.time.sample_times(), [0], 1, [None])
    assert block.failure[0] is None and block.events["event_tick_count"][0] == 1
    assert block.events["event_tick_first_s"][0] == traj.events["tick"].t[0]


def test_a_fixed_step_run_a_terminal_event_may_end_is_not_refused_for_its_whole_spans_steps():
    """rk4 at h = 1 ms over dzhanibekov.toml's 30 s needs 30,000 steps, beyond max_steps = 10,000:
    refused before stepping without a terminal event, but a terminal flip ends the run at
    t = 1.67 s, so it runs; a fifth flip, which the budget does not reach, stops the run on its
    budget with the valid samples kept. Alone and in the ensemble kernels alike."""
    from rotlab.ensemble.block import run_block
    from rotlab.methods.base import Settings
    from rotlab.methods.registry import get_method
    from rotlab.scene.scene import build_scene

    budget = {"solver.step": 1e-3, "solver.max_steps": 10000}
    with pytest.raises(rotlab.InputError, match=r"solver\.max_steps: rk4 needs 3e\+04 steps"):
        rotlab.simulate(CONFIGS / "dzhanibekov.toml", method="rk4", overrides=budget)
    for count, ok in ((1, True), (5, False)):
        flip = {"name": "flip", "when": "omega[1]", "direction": "falling", "terminal": True, "count": count}
        scenario = rotlab.load(CONFIGS / "dzhanibekov.toml", method="rk4", overrides={**budget, "events": [flip]})
        traj = rotlab.simulate(scenario, check=False)
        assert traj.ok == ok
        if ok:
            assert "event 'flip' (occurrence 1)" in traj.stats.details["ended by"] and 1.6 < traj.t[-1] < 1.7
        else:
            assert traj.stats.failure == "step budget of 10,000 steps exhausted at t = 10 s (raise solver.max_steps)"
            assert traj.t[-1] == 10.0 and traj.stats.steps == 10000 and traj.events["flip"].count == 2
        block = run_block([build_scene(scenario)], get_method("rk4"), Settings.of(scenario.solver), scenario.time.sample_times(), [0], 1, [None])
        assert block.failure[0] == traj.stats.failure and block.steps[0] == traj.stats.steps
        assert np.array_equal(block.kept[0][1], traj._state)


def test_a_run_a_terminal_event_ends_is_not_judged_by_its_whole_spans_pace():
    """A heavy top at rtol 1e-13 steps ~1 ms: over its 1,000-s span that pace needs ~10⁶ steps,
    beyond solver.max_steps = 30,000, which stopped it after its first 4,096 steps ("no progress")
    though its terminal event ends it at t = 6.3 s, 7,891 steps in. Not judged while a terminal
    event may end the run, it ends there, alone and in the ensemble kernels alike."""
    from rotlab.config.loader import parse_scenario
    from rotlab.ensemble.block import run_block
    from rotlab.methods.base import Settings
    from rotlab.methods.registry import get_method
    from rotlab.scene.scene import build_scene

    raw = {"body": {"principal_moments": [1.1e-3, 1.1e-3, 5.0e-4], "mass": 0.5, "center_of_mass": [0.0, 0.0, 0.04]},
           "initial": {"omega": [0.0, 0.0, 150.0], "euler_313_deg": [0.0, 25.0, 0.0]},
           "loads": [{"type": "gravity", "g": [0.0, 0.0, -9.81]}], "time": {"end": 1000.0, "sample_rate": 2},
           "solver": {"method": "dop853", "rtol": 1e-13, "atol": 1e-16, "max_steps": 30000},
           "events": [{"name": "turn", "when": "gamma[0]*omega[1] - gamma[1]*omega[0]", "direction": "rising", "terminal": True}]}
    scenario = parse_scenario(raw)
    traj = rotlab.simulate(scenario)
    assert traj.ok and "event 'turn' (occurrence 1)" in traj.stats.details["ended by"] and 6.0 < traj.t[-1] < 6.6
    assert 4096 < traj.stats.steps < 30000
    scene = build_scene(scenario)
    block = run_block([scene], get_method("dop853"), Settings.of(scenario.solver), scenario.time.sample_times(), [0], 1, [None])
    assert block.failure[0] is None and block.steps[0] == traj.stats.steps and np.array_equal(block.kept[0][1], traj._state)
