"""Maximal Lyapunov exponents (``rotlab.lyapunov_exponent``): ~0 for the integrable tops — Euler's free body,
Lagrange's and Kovalevskaya's heavy tops — where a deviation grows linearly, so that Σ ln s over
[T/4, T] is ln 4 (it is held to ln 4 + 0.6, and λ(T) to ≤ (that sum's start + ln 4 + 0.6)/T); a positive,
reproducible exponent for the asymmetric heavy top, cross-checked against two whole runs a small
distance apart (``divergence``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rotlab
from rotlab.lyapunov_exponent import divergence, lyapunov
from tests.conftest import CONFIGS


def log_growth(result) -> np.ndarray:
    """Σ ln s up to each sample: λ(t)·(t − t0)."""
    return result.history * (result.t - result.t[0] + result.interval)


@pytest.mark.parametrize(("config", "duration"), [("euler", 400.0), ("kovalevskaya", 400.0), ("lagrange", 40.0)])
def test_integrable_tops_have_a_zero_exponent_converging_as_log_t_over_t(config, duration):
    """Measured Σ ln s increments over [T/4, T]: euler 1.39, kovalevskaya 1.55, lagrange 1.27 (ln 4 = 1.39)."""
    result = lyapunov(CONFIGS / f"{config}.toml", duration=duration)
    growth = log_growth(result)
    quarter, whole = growth[growth.shape[0] // 4 - 1], growth[-1]
    assert whole - quarter <= np.log(4.0) + 0.6  # linear growth of the deviation, not exponential
    assert 0.0 <= result.exponent <= (quarter + np.log(4.0) + 0.6) / duration


def test_the_chaotic_top_has_a_positive_reproducible_exponent_matching_two_runs_divergence():
    """Measured over 600 s: λ = 0.63 1/s (tangent map, renormalised every 0.02 s) and 0.59 1/s (two
    whole runs reset every 5 s); held to agree within 15 %."""
    config = CONFIGS / "chaotic_top.toml"
    result = lyapunov(config)
    assert result.exponent > 0.3 and result.spread < 0.2 * result.exponent
    assert lyapunov(config).exponent == result.exponent  # the same input, the same number
    check = divergence(config)
    assert abs(check - result.exponent) <= 0.15 * result.exponent, (check, result.exponent)
    assert divergence(CONFIGS / "kovalevskaya.toml") < 0.05 * result.exponent  # and the cross-check tells the two apart


def test_a_closed_form_scene_is_measured_with_a_stepping_method(cli):
    result = rotlab.lyapunov(CONFIGS / "euler.toml", duration=20.0, overrides={"solver.method": "exact"})
    assert result.method.startswith("taylor at the scenario's tolerances") and result.t.shape[0] == 2000
    out = cli("lyapunov", str(CONFIGS / "chaotic_top.toml"), "--duration", "100", "--check")
    assert out.exit_code == 0, out.output
    assert "maximal Lyapunov exponent: " in out.stdout and "Lyapunov time 1/λ" in out.stdout and "cross-check" in out.stdout
    bad = cli("lyapunov", str(CONFIGS / "euler.toml"), "--set", "time.end=-1")
    assert bad.exit_code == 2 and "time.end" in bad.stderr


def test_the_api_functions_stay_functions_after_their_modules_are_imported():
    """``rotlab.stability`` and ``rotlab.lyapunov`` are functions, whatever was imported first (a
    module of the same name would replace them as attributes of the package)."""
    import subprocess
    import sys

    code = ("from rotlab.linear_stability import Stability\nfrom rotlab.lyapunov_exponent import divergence\nimport rotlab\n"
            "assert callable(rotlab.stability) and callable(rotlab.lyapunov), (rotlab.stability, rotlab.lyapunov)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr


def test_the_cross_check_restarts_from_the_attitude_when_the_method_does_not_keep_its_norm(write):
    """rk4 at h·|ω| = 2 shrinks |Λ| to 0.05 in one 5 s interval; the cross-check restarted the
    next interval from that Λ, which the scenario refuses ("|Λ| = 0.047 is not 1", exit 2 after
    the exponent was printed).  It now restarts from Λ/|Λ| and gives a number."""
    path = write("drift.toml", "[body]\nprincipal_moments = [0.010, 0.016, 0.022]\n[initial]\nomega = [0.1, 0.0, 200.0]\n"
                               "[time]\nend = 12.0\nsample_rate = 10\n[solver]\nmethod = \"rk4\"\nstep = 0.01\n")
    first = rotlab.simulate(path, duration=5.0)
    assert np.linalg.norm(first.quaternion[-1]) < 0.1  # (the raw Λ: its norm is not kept)
    assert math.isfinite(divergence(path))


def test_a_lost_attitude_stops_the_exponent_in_the_runs_words(write):
    """rk4 shrinks |Λ| below ~1.5e-154 at t ≈ 579 s: no exponent, with the words a run stops with
    (before: a number, computed from states without an attitude)."""
    from rotlab.errors import RunFailure

    path = write("lost.toml", "[body]\nprincipal_moments = [0.010, 0.016, 0.022]\n[initial]\nomega = [0.0, 0.0, 200.0]\n"
                              "[time]\nend = 700.0\nsample_rate = 10\n[solver]\nmethod = \"rk4\"\nstep = 0.01\n")
    with pytest.raises(RunFailure, match=r"^the attitude is lost between t = 579\.3 s and t = 579\.4 s: .*: no exponent$"):
        lyapunov(path)


@pytest.mark.parametrize(("method", "config"), [("rk4", "chaotic_top"), ("rkmk4", "chaotic_top"), ("dmv", "dzhanibekov"),
                                               ("splitting", "chaotic_top"), ("dop853", "chaotic_top"), ("taylor", "chaotic_top")])
def test_the_compiled_renormalisation_is_benettins_loop_over_the_methods_own_local_solution(method, config):
    """``lyapunov`` runs Benettin's loop compiled (``local_state`` of the method by name); written
    here in Python over ``Method.local_solution`` (what ``rotlab.events`` locates on), step by step
    as the module docstring states it, it gives the same λ(t) to 1e-13 relative and 1e-14 1/s (the
    sums' rounding: NumPy's dot products add in another order; measured ≤ 1.6e-14 relative), on
    the chaotic top over 3 s (dmv, for the torque-free body only: the Dzhanibekov flip)."""
    from rotlab.api import _plan
    from rotlab.scene.scene import build_scene

    scenario = rotlab.load(CONFIGS / f"{config}.toml", method=method, duration=3.0)
    result = lyapunov(scenario)
    scene = build_scene(scenario)
    chosen, _, settings, t = _plan(scene)
    flow = chosen.local_solution(scene, t, settings)
    scale = np.r_[np.ones(4), np.full(3, scene.rate_scale)]
    norm = lambda d: math.sqrt(float(np.sum((d[:7] / scale) ** 2)))  # noqa: E731

    def tangent(d, x):
        d = d.copy()
        d[:4] -= (d[:4] @ x[:4]) / (x[:4] @ x[:4]) * x[:4]
        d[7:] = 0.0
        return d

    x = scene.state0.copy()
    v = tangent(np.random.default_rng(20261126).standard_normal(x.shape[0]), x)
    v /= norm(v)
    total, history = 0.0, []
    for k in range(t.shape[0] - 1):
        after, neighbour = flow(x, t[k], t[k + 1]), flow(x + 1e-8 * v, t[k], t[k + 1])
        w = tangent((neighbour - after) / 1e-8, after)
        total += math.log(norm(w))
        history.append(total / (t[k + 1] - t[0]))
        x, v = after, w / norm(w)
    assert result.method.startswith(method) and result.exponent > 0.01
    np.testing.assert_allclose(result.history, history, rtol=1e-13, atol=1e-14)


def test_ctrl_c_stops_a_long_exponent_between_its_compiled_calls():
    """The compiled loop runs in calls of ~0.05 s, so Ctrl-C stops a long measurement at once
    (a first version ran all its intervals in one call: 24 s here, deaf to the signal)."""
    import os
    import signal
    import threading
    import time

    overrides = {"solver.method": "rk4", "solver.step": 1e-7, "solver.max_steps": 10**12}
    lyapunov(CONFIGS / "dzhanibekov.toml", duration=0.05, overrides=overrides)  # (compiled before the clock starts)
    timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGINT))  # (a thread: it runs when the loop lets go of the GIL, as a signal is handled)
    started = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            lyapunov(CONFIGS / "dzhanibekov.toml", duration=30.0, overrides=overrides)
    finally:
        timer.cancel()
    assert time.perf_counter() - started < 1.5


def test_a_terminal_event_does_not_lift_the_step_budgets_check(write):
    """Events are not evaluated by ``lyapunov``: a terminal one does not end it, so a fixed step
    whose span needs more than solver.max_steps is refused, as without the event."""
    from rotlab.errors import InputError

    flip = {"name": "flip", "when": "omega[1]", "direction": "falling", "terminal": True}
    with pytest.raises(InputError, match=r"solver\.max_steps: rk4 needs 3e\+04 steps"):
        lyapunov(CONFIGS / "dzhanibekov.toml", overrides={"solver.method": "rk4", "solver.step": 1e-3, "solver.max_steps": 10000,
                                                          "events": [flip]})
