"""Measure the constants of ``auto``'s cost model (``rotlab/methods/cost.py``) and print them.

    python benchmarks/fit_cost_model.py [--repeats N]

Every figure is a median of repeated ``Method.solve`` calls (warm numba cache, first call not
counted).  Costs are modelled as

    seconds = per_call + per_step · steps + per_sample · samples

per_call from a one-step, two-sample run; per_step from runs of one scene at two step counts
(a least-squares line); per_sample from one step per sample against 11 samples.  What is measured:

* ``exact``: set-up (2 samples) and the cost per sample (20 001 samples), for an asymmetric free
  body, an axisymmetric free body and the Lagrange top (configs/lagrange.toml);
* ``dmv``: the cost per step as a function of h·Ω (its implicit rotation iterates more at large
  steps), GNI body, order 10 (every order costs the same per step);
* ``splitting`` (orders 2–8) and ``rk4``: per step, on a free body and under gravity
  (``rk4`` also with every load kind: configs/general.toml);
* ``taylor``: per step as a + b N² (orders 8–24) on a free body, under gravity and with every load
  kind, and per sample;
* the one-time cost of a method's first call in a process, with the kernels in numba's on-disk
  cache: numba's own first use (its target context imports its numpy and BLAS support: ``init``)
  and loading each kernel (``load``), from fresh subprocesses that run two methods in turn;
* ``dop853``: per step on a free body, under gravity and with every load kind, per call and per
  sample; its median rotation per step at rtol 1e-10 over the bench problems and, per load kind,
  the largest ratio of its max error to rtol there (at rtol 1e-10, atol 1e-12; over the problems
  with a reference that it follows, error < 1e-3; near a separatrix divided by the amplification);
* formula loads: the cost per program row (``rotlab.scene.loads.formula_rows``) of a ``rk4`` step,
  a ``dop853`` step and a ``taylor`` step (a + b N²), the slope over four satellite loads of
  51–1155 rows (quadratic drag, gravity gradient, a magnetic dipole, B-dot detumbling);
* the error constants C of the fixed-step methods, err ≈ C (hΩ)^p ΩT, from each method's own
  tolerance probe on every bench problem it applies to (the largest C is kept: the a priori step
  is then never longer than the probe's), and the rotation per ``taylor`` step at the Jorba–Zou
  order (the median over the bench problems).

``--only`` measures some groups (printing their keys alone).  The printed dictionary is pasted into ``rotlab/methods/cost.py`` (``CONSTANTS``) together with the
date and the load average of the run.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np

from rotlab.bench.problems import CONFIGS, all_problems
from rotlab.config import load_scenario, parse_scenario
from rotlab.core.taylor import default_order
from rotlab.methods.base import Settings
from rotlab.methods.registry import get_method
from rotlab.scene.scene import build_scene


def median_time(fn, repeats: int) -> float:
    fn()
    samples = []
    for _ in range(repeats):
        started = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - started)
    return statistics.median(samples)


def scene_of(data: dict):
    return build_scene(parse_scenario(data))


FREE = {"body": {"principal_moments": [1.0, 1.6, 2.2]}, "initial": {"omega": [1.0, 0.5, 1.5]}, "time": {"end": 1.0}}
AXI = {"body": {"principal_moments": [2.0, 2.0, 3.0]}, "initial": {"omega": [0.3, -0.2, 1.5]}, "time": {"end": 1.0}}
HEAVY = {"body": {"principal_moments": [1.0, 1.5, 2.0], "mass": 1.0, "center_of_mass": [0.05, 0.1, 0.25]},
         "initial": {"omega": [1.0, 0.5, 6.0], "euler_313": [0.0, 0.5, 0.0]},
         "loads": [{"type": "gravity", "g": [0.0, 0.0, -9.81]}], "time": {"end": 1.0}}


SATELLITE = {"body": {"principal_moments": [0.03, 0.035, 0.01]},
             "initial": {"omega_deg": [5.0, -4.0, 3.5], "euler_313_deg": [20.0, 40.0, 10.0]}, "time": {"end": 1.0}}
FORMULA_LOADS = ({"type": "quadratic_drag", "coefficient": 1e-4}, {"type": "gravity_gradient", "orbit_rate": 0.0011},
                 {"type": "magnetic_dipole", "dipole": [0.05, 0.0, 0.02]}, {"type": "bdot_detumbling", "gain": 2e5, "max_dipole": 0.2})


def fit_line(xs: list[float], ys: list[float]) -> tuple[float, float]:
    """(intercept, slope) by least squares."""
    a = np.vstack([np.ones(len(xs)), np.asarray(xs, float)]).T
    (c0, c1), *_ = np.linalg.lstsq(a, np.asarray(ys, float), rcond=None)
    return float(c0), float(c1)


def per_step(method, scene, settings_of, step_counts, repeats, samples=11) -> tuple[float, float]:
    """(per call, per step) from solves over spans with the given step counts, ``samples`` samples."""
    xs, ys = [], []
    for n in step_counts:
        s, span = settings_of(n)
        t = np.linspace(0.0, span, samples)
        solution = method.solve(scene, t, s, None)
        xs.append(solution.steps)
        ys.append(median_time(lambda: method.solve(scene, t, s, None), repeats))
    return fit_line(xs, ys)


def exact_costs(repeats: int) -> dict:
    exact = get_method("exact")
    out = {}
    lagrange = build_scene(load_scenario(CONFIGS / "lagrange.toml"))
    for key, scene in (("exact_asymmetric", scene_of(FREE)), ("exact_axisymmetric", scene_of(AXI)), ("exact_lagrange", lagrange)):
        small, big = np.linspace(0.0, 10.0, 2), np.linspace(0.0, 10.0, 20001)
        t_small = median_time(lambda: exact.solve(scene, small, Settings(), None), repeats)
        t_big = median_time(lambda: exact.solve(scene, big, Settings(), None), max(3, repeats // 3))
        out[key] = {"per_call": t_small, "per_sample": (t_big - t_small) / 19999}
    return out


def dmv_costs(repeats: int) -> dict:
    """Per step at h·Ω = x: fitted as a + b / (−ln x) (the iterations of the implicit rotation)."""
    dmv = get_method("dmv")
    (gni,) = [p for p in all_problems() if p.name == "gni"]
    scene = build_scene(gni.scenario())
    rate = scene.rate_scale
    xs, ys = [], []
    for x in (0.005, 0.02, 0.05, 0.1, 0.2, 0.35, 0.5):
        h = x / rate
        steps = 4000
        t = np.linspace(0.0, steps * h, 11)
        s = Settings(step=h, order=10)
        sec = median_time(lambda: dmv.solve(scene, t, s, None), repeats)
        xs.append(1.0 / -math.log(x))
        ys.append(sec / steps)
    a, b = fit_line(xs, ys)
    call = tiny_call(dmv, scene, Settings(step=0.01, order=10), repeats)
    return {"dmv": {"per_call": call, "per_step_a": a, "per_step_b": b, "per_sample": per_sample(dmv, scene, Settings(step=0.01, order=10), repeats)}}


def tiny_call(method, scene, settings, repeats) -> float:
    """The fixed cost of a call: one step, two samples."""
    t = np.array([0.0, settings.step])
    return median_time(lambda: method.solve(scene, t, settings, None), 4 * repeats)


def per_sample(method, scene, settings, repeats, steps=4000) -> float:
    """Extra cost of a sample: one step per sample interval against 11 samples, same steps."""
    span = settings.step * steps
    few, many = np.linspace(0.0, span, 11), np.linspace(0.0, span, steps + 1)
    return (median_time(lambda: method.solve(scene, many, settings, None), repeats)
            - median_time(lambda: method.solve(scene, few, settings, None), repeats)) / (steps - 10)


def fixed_step_costs(repeats: int) -> dict:
    out = {}
    general = build_scene(load_scenario(CONFIGS / "general.toml"))
    for name, orders in (("splitting", (2, 4, 6, 8)), ("rk4", (None,))):
        method = get_method(name)
        for order in orders:
            label = name if order is None else f"{name}-{order}"
            scenes = [("free", scene_of(FREE)), ("forces", scene_of(HEAVY))] + ([("loads", general)] if name == "rk4" else [])
            for kind, scene in scenes:
                h = 1e-4
                _, step = per_step(method, scene, lambda n: (Settings(step=h, order=order, max_steps=10**9), h * n), (2000, 20000), repeats)
                out.setdefault(label, {})[kind] = step
            out[label]["per_call"] = tiny_call(method, scene_of(FREE), Settings(step=1e-3, order=order), repeats)
            out[label]["per_sample"] = per_sample(method, scene_of(FREE), Settings(step=1e-3, order=order), repeats)
    return out


def taylor_costs(repeats: int) -> dict:
    """Per step = a + b N² for each scene kind, and the per-sample cost of the dense output."""
    taylor = get_method("taylor")
    general = build_scene(load_scenario(CONFIGS / "general.toml"))
    out = {}
    for kind, scene in (("free", scene_of(FREE)), ("forces", scene_of(HEAVY)), ("loads", general)):
        xs, ys = [], []
        for order in (8, 12, 16, 20, 24):
            s = Settings(rtol=1e-10, atol=1e-12, order=order)
            _, step = per_step(taylor, scene, lambda n, s=s: (s, 2.0 * n / scene.rate_scale), (100, 400), repeats)
            xs.append(order * order)
            ys.append(step)
        a, b = fit_line(xs, ys)
        out[kind] = {"a": a, "b": b}
    out["per_call"], out["per_sample"] = adaptive_call_and_sample(taylor, Settings(rtol=1e-10, atol=1e-12), repeats, repeats)
    return out


def adaptive_call_and_sample(method, settings, repeats, call_repeats) -> tuple[float, float]:
    """(per call, per sample) of an adaptive method on the free body: a 1 ms two-sample run, and
    20,001 against 11 samples over 50 s (the same steps)."""
    scene = scene_of(FREE)
    tiny = median_time(lambda: method.solve(scene, np.array([0.0, 1e-3]), settings, None), call_repeats)
    few, many = np.linspace(0.0, 50.0, 11), np.linspace(0.0, 50.0, 20001)
    t_few = median_time(lambda: method.solve(scene, few, settings, None), repeats)
    t_many = median_time(lambda: method.solve(scene, many, settings, None), repeats)
    return tiny, (t_many - t_few) / 19990


def dop853_costs(repeats: int) -> dict:
    """Per step (free, forces, loads), per call and per sample, at rtol 1e-10."""
    dop853 = get_method("dop853")
    general = build_scene(load_scenario(CONFIGS / "general.toml"))
    s = Settings(rtol=1e-10, atol=1e-12, max_steps=10**9)
    out = {}
    for kind, scene in (("free", scene_of(FREE)), ("forces", scene_of(HEAVY)), ("loads", general)):
        _, out[kind] = per_step(dop853, scene, lambda n, scene=scene: (s, 0.3 * n / scene.rate_scale), (400, 4000), repeats)
    out["per_call"], out["per_sample"] = adaptive_call_and_sample(dop853, s, repeats, 4 * repeats)
    return out


def formula_costs(repeats: int) -> dict:
    """The cost per program row of a step of rk4, dop853 and taylor (a + b N²): slopes over the
    satellite's formula loads (their intercepts, the satellite's own base cost, are not kept:
    the model's base is each method's "loads" cost, general.toml's mix of load kinds)."""
    rk4, dop853, taylor = get_method("rk4"), get_method("dop853"), get_method("taylor")
    rows, rk4_steps, dop853_steps, taylor_a, taylor_b = [], [], [], [], []
    for load in FORMULA_LOADS:
        scene = scene_of({**SATELLITE, "loads": [load]})
        rate = scene.rate_scale
        rows.append(scene.formula_rows)
        h = 0.01 / rate
        rk4_steps.append(per_step(rk4, scene, lambda n: (Settings(step=h, max_steps=10**9), h * n), (2000, 16000), repeats)[1])
        s = Settings(rtol=1e-10, atol=1e-12, max_steps=10**9)
        dop853_steps.append(per_step(dop853, scene, lambda n: (s, 0.3 * n / rate), (200, 1600), repeats)[1])
        orders, steps = (8, 12, 16, 20), []
        for order in orders:
            so = Settings(rtol=1e-10, atol=1e-12, order=order)
            steps.append(per_step(taylor, scene, lambda n, so=so: (so, 2.0 * n / rate), (50, 300), repeats)[1])
        a, b = fit_line([n * n for n in orders], steps)
        taylor_a.append(a)
        taylor_b.append(b)
    return {"rk4": fit_line(rows, rk4_steps)[1], "dop853": fit_line(rows, dop853_steps)[1],
            "taylor": {"a": fit_line(rows, taylor_a)[1], "b": fit_line(rows, taylor_b)[1]}}


def dop853_accuracy() -> dict:
    """The median rotation per dop853 step at rtol 1e-10 over the bench problems, and per load kind
    the largest max error / (rtol · amplification) among those with a reference it follows."""
    from rotlab.bench.problems import reference_solution, state_error
    from rotlab.methods.choose import work_of

    dop853 = get_method("dop853")
    radians, ratios = [], {"free": 0.0, "forces": 0.0, "loads": 0.0}
    for problem in all_problems():
        scene = build_scene(problem.scenario())
        t = problem.scenario().time.sample_times()
        solution = dop853.solve(scene, t, Settings(rtol=1e-10, atol=1e-12, max_steps=10**9), None)
        work = work_of(scene, t)
        if solution.steps:
            radians.append(work.radians / solution.steps)
        reference = reference_solution(problem, scene, t)
        if reference.state is None:
            continue
        error = state_error(solution.state, reference.state)[0]
        if error < 1e-3:
            ratios[work.loads] = max(ratios[work.loads], error / (1e-10 * work.amplification))
    return {"dop853_radians_per_step": statistics.median(radians), "dop853_radians_per_step_range": (min(radians), max(radians)),
            "dop853_error_ratio": ratios}


def error_constants() -> dict:
    """C of err ≈ C (hΩ)^p ΩT from each fixed-step method's probe on every bench problem (the
    largest), and the median rotation per taylor step at the Jorba–Zou order, rtol 1e-10."""
    constants: dict[str, float] = {}
    taylor_rad: list[float] = []
    taylor = get_method("taylor")
    for problem in all_problems():
        scene = build_scene(problem.scenario())
        t = problem.scenario().time.sample_times()
        span, rate = float(t[-1] - t[0]), scene.rate_scale
        for name, orders in (("dmv", (8, 10, 12)), ("splitting", (2, 4, 6, 8)), ("rk4", (None,))):
            method = get_method(name)
            if method.unsupported(scene):
                continue
            for order in orders:
                p = order or method.order_of_accuracy
                h = method.step_for_tolerance(scene, t, 1e-10, p)
                if h * rate > 0.99 * 20.0 / 40.0:  # at the probe's own cap (h ≤ probe span / 40): no information
                    continue
                label = name if order is None else f"{name}-{order}"
                constants[label] = max(constants.get(label, 0.0), 1e-10 / ((h * rate) ** p * rate * span))
        solution = taylor.solve(scene, t, Settings(rtol=1e-10, atol=1e-12), None)
        taylor_rad.append(rate * span / solution.steps)
    return {"error_constants": constants, "taylor_radians_per_step": statistics.median(taylor_rad),
            "taylor_radians_per_step_range": (min(taylor_rad), max(taylor_rad)), "taylor_order": default_order(1e-10)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9)
    groups = {"exact": exact_costs, "dmv": dmv_costs, "fixed-step": fixed_step_costs,
              "taylor": lambda r: {"taylor": taylor_costs(r)}, "dop853": lambda r: {"dop853": dop853_costs(r)},
              "formulas": lambda r: {"formula_row": formula_costs(r)}, "dop853-accuracy": lambda r: dop853_accuracy(),
              "error-constants": lambda r: error_constants()}
    parser.add_argument("--only", nargs="+", choices=list(groups), default=list(groups), help="the groups to measure (all by default)")
    args = parser.parse_args()
    started = time.perf_counter()
    print(f"# 1-min load average at start: {os.getloadavg()[0]:.2f}")
    result = {}
    for name in args.only:
        result.update(groups[name](args.repeats))
    print("CONSTANTS = {")
    for key, value in result.items():
        print(f"    {key!r}: {_fmt(value)},")
    print("}")
    print(f"# {time.perf_counter() - started:.0f} s; 1-min load average at the end: {os.getloadavg()[0]:.2f}")


def _fmt(value):
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k!r}: {_fmt(v)}" for k, v in value.items()) + "}"
    if isinstance(value, tuple):
        return "(" + ", ".join(_fmt(v) for v in value) + ")"
    if isinstance(value, float):
        return f"{value:.3g}"
    return repr(value)


if __name__ == "__main__":
    main()
