"""A sweep over initial states runs one method, chosen once for its most demanding case.

Bounds: every case's ω within 10·rtol of its exact solution (auto's contract, relative to the
case's largest |ω| component), and each case equal, bit for bit, to the case run alone with the
sweep's method and settings.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import rotlab
from rotlab.errors import InputError
from rotlab.methods.base import Settings
from rotlab.methods.choose import ACCURACY_FACTOR, ensemble_choice, work_of, worst_work
from rotlab.scene.scene import build_scene
from rotlab.sweep.cases import case_scenario
from rotlab.sweep.runner import plan, run_cases
from rotlab.sweep.shared_choice import case_omegas, shared_choice

RTOL = 1e-8
# a free asymmetric body; 450 cases of ω₀ from slow to fast, among them spins of (1e-4, ~1, 1e-4)
# about the intermediate axis, near the separatrix (where a stepping method's error is amplified),
# and (0, ~1, 0) on it (only the exact solution meets rtol there); with this many cases a
# worker's share of loading a numba kernel is small, and auto steps
SWEEP = f"""
title = "initial-state sweep"
[body]
principal_moments = [1.0, 2.0, 3.0]
[initial]
omega = [0.3, 1.0, 0.2]
[time]
end = 10.0
samples = 101
[solver]
method = "auto"
rtol = {RTOL}
[sweep]
seed = 5
samples = 25
[sweep.parameters]
"initial.omega[0]" = [0.0, 1e-4, 0.05, 0.3, 1.0, 3.0]
"initial.omega[2]" = [0.0, 1e-4, 0.2]
"initial.omega[1]" = {{ uniform = [0.9, 1.1] }}
"""
# whole vectors, and an attitude of which one is no attitude (the zero quaternion: an invalid case,
# of the right shape; a value of the wrong shape, no vector of three, is refused with the sweep)
VECTORS = SWEEP.split("[sweep]")[0] + """[sweep.parameters]
"initial.omega" = [[0.05, 1.0, 0.2], [3.0, 1.0, 1e-4], [1.0, 2.0, 0.5]]
"initial.quaternion" = [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]
"""


def _on_the_separatrix(case) -> bool:
    return case.values["initial.omega[0]"] == 0.0 and case.values["initial.omega[2]"] == 0.0


def test_a_sweep_over_initial_states_steps_with_one_method_that_meets_rtol_in_every_case(write):
    """Every case runs the stepping method chosen for the sweep (said in ``how``, with its
    settings), but for the spins on the separatrix, which choose their own (exact); each case's
    ω is within 10·rtol of its exact solution, near the separatrix too."""
    p = plan(write("s.toml", SWEEP))
    run = run_cases(p, jobs=1)
    choice = shared_choice(p)
    assert f"only initial states vary, one method for the cases: {choice.label}" in run.how and "choose their own" in run.how
    assert {o.status for o in run.outcomes} == {"pass"}
    assert choice.method != "exact"  # a stepping method: the bound below is not met trivially
    assert choice.own >= {case.index for case in p.cases if _on_the_separatrix(case)}
    assert {o.method for o in run.outcomes if o.index not in choice.own} == {choice.method}
    assert {o.method for o in run.outcomes if o.index in choice.own} == {"exact"}
    worst = 0.0
    for outcome, case in zip(run.outcomes, p.cases):
        exact = rotlab.simulate(case_scenario(p.raw, p.base, case, p.source), method="exact")
        error = np.max(np.abs(outcome.omega - exact.omega)) / np.max(np.abs(exact.omega))
        worst = max(worst, error)
    assert worst <= 10 * RTOL


def test_a_case_that_is_invalid_is_reported_and_the_rest_run_with_the_sweeps_method(write):
    p = plan(write("s.toml", VECTORS))
    outcomes = run_cases(p, jobs=2).outcomes
    valid, invalid = outcomes[0::2], outcomes[1::2]  # (the last parameter varies fastest)
    assert all(o.status == "error" and "initial.quaternion" in o.message for o in invalid)
    assert [o.status for o in valid] == ["pass", "pass", "pass"] and len({o.method for o in valid}) == 1


def test_each_case_is_the_case_run_alone_with_the_sweeps_method(write):
    """A case of the sweep can be reproduced alone: ``rotlab.simulate`` with the method and
    settings the sweep's first line names gives the same ω series to the last bit (with one
    worker or two); a case that chose its own, with the file's settings."""
    p = plan(write("s.toml", SWEEP))
    choice = shared_choice(p)
    assert choice == shared_choice(p)  # made from the cases alone: the same every time
    one, two = run_cases(p, jobs=1), run_cases(p, jobs=2)
    s = choice.settings
    assert choice.label in one.how and (f"step {s.step!r} s" if s.step is not None else f"rtol {s.rtol!r}, atol {s.atol!r}") in choice.label
    for case, a, b in zip(p.cases, one.outcomes, two.outcomes):
        scenario = case_scenario(p.raw, p.base, case, p.source)
        changes = {} if case.index in choice.own else {
            "solver.method": choice.method, "solver.rtol": s.rtol, "solver.atol": s.atol, "solver.order": s.order, "solver.step": s.step}
        alone = rotlab.simulate(scenario, overrides=changes)
        assert a.method == b.method == alone.stats.method
        np.testing.assert_array_equal(a.omega, alone.omega)
        np.testing.assert_array_equal(b.omega, alone.omega)


@pytest.mark.parametrize("parameters", [
    '"initial.omega[0]" = { uniform = [1.5, 2.4] }\n"initial.omega[02]" = [0.7, 0.8]\n',
    '"initial.omega" = { sphere = 2.0 }\n"body.principal_moments[1]" = [2.0, 2.2]\n',
])
def test_each_cases_spin_is_the_one_its_scenario_gets(write, parameters):
    """The choice reads each case's ω as validation does: components, written with any index
    spelling, or the whole vector."""
    text = SWEEP.split("[sweep]")[0] + "[sweep]\nseed = 2\nsamples = 20\n[sweep.parameters]\n" + parameters
    p = plan(write("s.toml", text))
    scene = build_scene(p.base)
    omegas, positions = case_omegas(p, scene.axes)
    expected = [build_scene(case_scenario(p.raw, p.base, case, p.source)).omega0 for case in p.cases]
    np.testing.assert_array_equal(omegas, np.array(expected)[positions])


@pytest.mark.parametrize("parameters, key, message", [
    ('"initial.omega" = { sphere = 10.0 }\n"initial.omega[1]" = [10.0, 1e-3]\n', "initial.omega[1]", "sets part of 'initial.omega'"),
    ('"initial.omega[2]" = [0.0, 0.01]\n"initial.omega" = [[1.0, 0.0, 0.0]]\n', "initial.omega[2]", "sets part of 'initial.omega'"),
    ('"initial.omega[2]" = [0.0]\n"initial.omega[02]" = [0.1]\n', "initial.omega[02]", "the same key as 'initial.omega[2]'"),
])
def test_a_value_swept_whole_and_in_parts_is_an_input_error(write, parameters, key, message):
    """One of the two silently overwrote the other (which one depended on their order and kind):
    cases were duplicates, or a grid was never used."""
    text = SWEEP.split("[sweep]")[0] + "[sweep]\nsamples = 4\n[sweep.parameters]\n" + parameters
    if "sphere" not in parameters:
        text = text.replace("samples = 4\n", "")
    with pytest.raises(InputError, match=rf"s\.toml: sweep\.parameters\.\"{re.escape(key)}\".*{re.escape(message)}"):
        plan(write("s.toml", text))


def test_the_choice_is_made_for_the_fastest_spin_and_the_closest_approach_to_the_separatrix(write):
    """The cost model sees the largest rate scale, error floor and amplification among the
    cases' initial spins, leaving out those on the separatrix (an error floor above 10·rtol);
    the choice is then the one for a case that has all three; with ``solver.order`` set (no
    exact solution to fall back on) and every spin on the separatrix, each case chooses its own."""
    p = plan(write("s.toml", SWEEP))
    scene = build_scene(p.base)
    t = p.base.time.sample_times()
    omegas, _ = case_omegas(p, scene.axes)
    limit = ACCURACY_FACTOR * RTOL
    works = [work_of(scene, t, omega) for omega in omegas]
    worst, within = worst_work(scene, t, omegas, floor_limit=limit)
    assert within.tolist() == [w.floor <= limit for w in works] and not within.all()
    kept = [w for w, keep in zip(works, within) if keep]
    assert (worst.rate, worst.floor, worst.amplification) == (max(w.rate for w in kept), max(w.floor for w in kept),
                                                              max(w.amplification for w in kept))
    assert worst.amplification > 10.0  # the (1e-4, ~1, 1e-4) spins
    settings = Settings(rtol=RTOL, atol=RTOL * 1e-2)
    spins = np.array([[0.05, 1.0, 0.2], [3.0, 1.0, 0.2]])
    both = ensemble_choice(scene, settings, t, worst_work(scene, t, spins)[0])
    fast = ensemble_choice(scene, settings, t, worst_work(scene, t, spins[1:])[0])
    assert (both[0].name, both[2]) == (fast[0].name, fast[2])
    ordered = plan(write("o.toml", SWEEP.replace('rtol = ', 'order = 12\nrtol = ').replace('[0.0, 1e-4, 0.05, 0.3, 1.0, 3.0]', '[0.0]')
                         .replace('[0.0, 1e-4, 0.2]', '[0.0]')))
    assert shared_choice(ordered) is None
