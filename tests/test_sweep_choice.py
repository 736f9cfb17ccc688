"""A sweep over initial states runs one method, chosen once for its most demanding case.

Bounds: every case's ω within 10·rtol of its exact solution (auto's contract, relative to the
case's largest |ω| component), and each case equal, bit for bit, to the case run alone with the
sweep's method and settings.
"""

from __future__ import annotations

import numpy as np

import rotlab
from rotlab.methods.base import Settings
from rotlab.methods.choose import ensemble_choice, work_of, worst_work
from rotlab.scene.scene import build_scene
from rotlab.sweep.cases import case_scenario
from rotlab.sweep.runner import plan, run_cases
from rotlab.sweep.shared_choice import case_omegas, shared_choice

RTOL = 1e-8
# a free asymmetric body; 400 cases of ω₀ from slow to fast, among them spins of (1e-4, ~1, 1e-4)
# about the intermediate axis, near the separatrix (where a stepping method's error is amplified);
# with this many cases a worker's share of loading a numba kernel is small, and auto steps
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
samples = 40
[sweep.parameters]
"initial.omega[0]" = [1e-4, 0.05, 0.3, 1.0, 3.0]
"initial.omega[2]" = [1e-4, 0.2]
"initial.omega[1]" = {{ uniform = [0.9, 1.1] }}
"""
# whole vectors, one of them no vector of three (an invalid case)
VECTORS = SWEEP.split("[sweep]")[0] + """[sweep.parameters]
"initial.omega" = [[0.05, 1.0, 0.2], [3.0, 1.0, 1e-4], [1.0, 2.0]]
"""


def test_a_sweep_over_initial_states_steps_with_one_method_that_meets_rtol_in_every_case(write):
    """Every case runs the stepping method chosen for the sweep (said in ``how``), and its ω is
    within 10·rtol of the case's exact solution, near the separatrix too."""
    p = plan(write("s.toml", SWEEP))
    run = run_cases(p, jobs=1)
    assert "only initial states vary, one method for all cases" in run.how and "made for the most demanding" in run.how
    assert {o.status for o in run.outcomes} == {"pass"} and len({o.method for o in run.outcomes}) == 1
    assert run.outcomes[0].method != "exact"  # a stepping method: the bound below is not met trivially
    worst = 0.0
    for outcome, case in zip(run.outcomes, p.cases):
        exact = rotlab.simulate(case_scenario(p.raw, p.base, case, p.source), method="exact")
        error = np.max(np.abs(outcome.omega - exact.omega)) / np.max(np.abs(exact.omega))
        worst = max(worst, error)
    assert worst <= 10 * RTOL


def test_a_case_that_is_invalid_is_reported_and_the_rest_run_with_the_sweeps_method(write):
    p = plan(write("s.toml", VECTORS))
    *valid, invalid = run_cases(p, jobs=2).outcomes
    assert invalid.status == "error" and "initial.omega" in invalid.message
    assert [o.status for o in valid] == ["pass", "pass"] and len({o.method for o in valid}) == 1


def test_each_case_is_the_case_run_alone_with_the_sweeps_method(write):
    """A case of the sweep can be reproduced alone: ``rotlab.simulate`` with the sweep's method,
    order and tolerances gives the same ω series to the last bit (with one worker or two)."""
    p = plan(write("s.toml", SWEEP))
    choice = shared_choice(p)
    assert choice == shared_choice(p)  # made from the cases alone: the same every time
    one, two = run_cases(p, jobs=1), run_cases(p, jobs=2)
    s = choice.settings
    for case, a, b in zip(p.cases, one.outcomes, two.outcomes):
        alone = rotlab.simulate(case_scenario(p.raw, p.base, case, p.source), overrides={
            "solver.method": choice.method, "solver.rtol": s.rtol, "solver.atol": s.atol, "solver.order": s.order, "solver.step": s.step})
        assert a.method == b.method == choice.method
        np.testing.assert_array_equal(a.omega, alone.omega)
        np.testing.assert_array_equal(b.omega, alone.omega)


def test_the_choice_is_made_for_the_fastest_spin_and_the_closest_approach_to_the_separatrix(write):
    """The cost model sees the largest rate scale, error floor and amplification among the
    cases' initial spins; the choice then equals the one for the case that has all three."""
    p = plan(write("s.toml", SWEEP))
    scene = build_scene(p.base)
    t = p.base.time.sample_times()
    omegas, fastest = case_omegas(p, scene.axes)
    assert len(omegas) == 400 and p.cases[fastest].values["initial.omega[0]"] == 3.0
    works = [work_of(scene, t, omega) for omega in omegas]
    worst = worst_work(scene, t, omegas)
    assert worst.rate == max(w.rate for w in works) and worst.floor == max(w.floor for w in works)
    assert worst.amplification == max(w.amplification for w in works) > 10.0  # the separatrix case
    settings = Settings(rtol=RTOL, atol=RTOL * 1e-2)
    spins = np.array([[0.05, 1.0, 0.2], [3.0, 1.0, 0.2]])
    both = ensemble_choice(scene, "auto", settings, t, spins, 100)
    fast = ensemble_choice(scene, "auto", settings, t, spins[1:], 100)
    assert (both[0].name, both[2]) == (fast[0].name, fast[2])
    near = ensemble_choice(scene, "auto", settings, t, np.vstack([spins, [[1e-4, 1.0, 1e-4]]]), 100)
    assert near[0].name == "exact" or near[2].rtol < fast[2].rtol  # a tighter method for the separatrix case
    assert ensemble_choice(scene, "taylor", settings, t, spins, 100)[1] == "requested in the scenario or on the command line"
