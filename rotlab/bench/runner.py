"""Measurements: work-precision records, kernel throughput, recording throughput, `rotlab run`
wall time (cold and warm), and the long-run energy error of the splitting methods.

Timing rules (every figure):
* wall time = median of repeats of the call that turns (scene, sample times, setting) into the
  states at the sample times: ``Method.solve`` for rotlab, ``solve_ivp`` / the Python RK4 loop for
  the peers.  Building the scene and the diagnostics afterwards are not timed on either side.
* rotlab: the first call of every run is a warm-up (numba compilation or loading from the on-disk
  cache, Decimal set-up of the exact solutions) and is not counted; ``compile_seconds`` = first
  call − median.  Peers compile nothing: each scipy method and the RK4 loop is warmed up once on a
  tiny problem, then every call counts.
* repeats: ``repeats`` calls, more (up to 50, within ~0.2 s) for sub-millisecond runs, fewer
  (down to 1) when one call takes longer than the record budget; ``repeats`` in each record.
* a series (one method, settings from loose to tight) stops once its error is below
  ``stop_error``, stops improving (the reference's floor), or a call exceeds the run budget.
"""

from __future__ import annotations

import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

from rotlab.bench import peers as peer_mod
from rotlab.bench.problems import (
    CONFIGS,
    ENERGY,
    KOVALEVSKAYA,
    STATE,
    Problem,
    Reference,
    energy_error,
    kovalevskaya_error,
    norm_error,
    reference_solution,
    state_error,
)

THRESHOLD = 1e-10  # the error at which rotlab and scipy are compared
LEAD_THRESHOLDS = (1e-10, 1e-13)  # where rotlab's best is compared with its own dop853
DEPENDENCIES = ("numpy", "scipy.linalg.cython_blas", "numba", "rerun", "pydantic", "typer")  # what `rotlab run` imports (SciPy: numba's linear algebra)


@dataclass
class Options:
    quick: bool = False
    repeats: int = 5
    run_budget: float = 3.0  # s: a series stops after a call this long
    record_budget: float = 5.0  # s: total time spent on the repeats of one record
    stop_error: float = 3e-14  # a series stops once below this error (below 1e-13: the dop853 lead there)
    fast_total: float = 0.2  # s: sub-4-ms runs are repeated up to 50 times within this
    decades_per_point: float = 1.0  # fixed-step series: error decades between points (order p)
    log: Callable[[str], None] = lambda line: None

    @classmethod
    def make(cls, quick: bool, repeats: int | None, log: Callable[[str], None] = lambda line: None) -> Options:
        if quick:
            return cls(quick=True, repeats=repeats or 3, run_budget=0.25, record_budget=0.5, stop_error=3e-14, fast_total=0.05,
                       decades_per_point=2.0, log=log)
        return cls(quick=False, repeats=repeats or 5, log=log)


@dataclass
class Record:
    """One run of one method at one setting on one problem (a work-precision point)."""

    problem: str
    method: str  # rotlab method (orders as "splitting-4"), or a peer: "scipy:DOP853", "seed:rk4-renormalised"
    setting: str  # "rtol=1e-10", "h=0.01", "-" (exact)
    max_error: float | None  # the problem's metric (see rotlab.bench.problems)
    seconds: float  # median wall time of the repeats
    kind: str = "work-precision"
    side: str = "rotlab"  # rotlab | scipy | seed
    metric: str = STATE
    series: str = ""  # method with order, for plots
    order: int | None = None
    step: float | None = None
    rtol: float | None = None
    repeats: int = 0
    compile_seconds: float = 0.0
    steps: int | None = None
    rhs_evaluations: int | None = None
    omega_error: float | None = None
    attitude_error: float | None = None
    energy_error: float | None = None
    norm_error: float | None = None
    failure: str | None = None
    reference: str = ""
    load_average: float | None = None  # 1-minute load average when the record was taken (shared machines)
    chosen: str | None = None  # `auto` only: the method, order and step it ran, from its reason

    def to_json(self) -> dict[str, Any]:
        return {k: _finite_or_none(v) for k, v in asdict(self).items()}


def _finite_or_none(v: Any) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


# --- timing ---------------------------------------------------------------------------------------


def timed(fn: Callable[[], Any], options: Options, warm_up: bool) -> tuple[Any, float, float, int]:
    """(result, median seconds, compile seconds, repeats) — see the module docstring."""
    started = time.perf_counter()
    result = fn()
    first = time.perf_counter() - started
    samples: list[float] = [] if warm_up else [first]
    wanted = options.repeats
    if first < 0.004:
        wanted = max(wanted, min(50, int(options.fast_total / max(first, 1e-6))))
    elif first * wanted > options.record_budget:
        wanted = max(1, int(options.record_budget / first))
    while len(samples) < wanted:
        started = time.perf_counter()
        result = fn()
        samples.append(time.perf_counter() - started)
    median = statistics.median(samples)
    return result, median, (max(0.0, first - median) if warm_up else 0.0), len(samples)


# --- work precision -------------------------------------------------------------------------------


@dataclass
class Series:
    """One curve: a method (and order) over settings from loose to tight."""

    method: str
    side: str
    settings: list[dict[str, Any]]
    run: Callable[[dict[str, Any]], tuple[np.ndarray, int | None, int | None, str | None, str | None]]
    order: int | None = None
    fixed_step: bool = False
    extra: dict[str, Any] = field(default_factory=dict)


def _tolerances(lo: int, hi: int, quick: bool) -> list[float]:
    exps = list(range(lo, hi + 1))
    if quick:
        exps = exps[::2] if exps[-1] in exps[::2] else exps[::2] + [exps[-1]]
    return [10.0 ** -k for k in exps]


def _substeps(scene, t: np.ndarray, order: int, decades: float, max_points: int = 40) -> list[int]:
    """Steps per sample interval: from ~1.5 rad of rotation per step (at most one step per
    sample interval), ×10^(decades/p) per point (``decades`` of error between points for an
    order-p method)."""
    interval = float(t[1] - t[0])
    rate = scene.rate_scale or 1.0 / float(t[-1] - t[0])
    n0 = max(1, math.ceil(interval * rate / 1.5))
    factor = 10.0 ** (decades / order)
    out: list[int] = []
    x = float(n0)
    while len(out) < max_points:
        n = max(math.ceil(x - 1e-9), out[-1] + 1 if out else 1)
        out.append(n)
        x *= factor
    return out


def rotlab_series(scene, t: np.ndarray, options: Options) -> list[Series]:
    from rotlab.methods.base import Settings
    from rotlab.methods.registry import METHODS, get_method

    interval = float(t[1] - t[0])
    out: list[Series] = []
    for name in METHODS:
        method = get_method(name)
        if method.unsupported(scene):
            continue
        if name == "exact":
            out.append(Series("exact", "rotlab", [{"label": "-"}], _rotlab_runner(method, scene, t, lambda s: Settings())))
        elif method.adaptive:  # tolerance-driven: dop853, taylor (to 1e-15: the 1e-13 lead)
            settings = [{"label": f"rtol={r:.0e}", "rtol": r} for r in _tolerances(6, 15, options.quick)]
            out.append(Series(name, "rotlab", settings,
                              _rotlab_runner(method, scene, t, lambda s: Settings(rtol=s["rtol"], atol=s["rtol"] * 1e-2, max_steps=10**10))))
        else:
            orders = method.orders or (None,)
            for order in orders:
                p = order if order is not None else method.order_of_accuracy
                settings = [{"label": f"h={interval / n:.4g}", "step": interval / n, "substeps": n} for n in _substeps(scene, t, p, options.decades_per_point)]
                label = name if order is None else f"{name}-{order}"
                out.append(Series(label, "rotlab", settings,
                                  _rotlab_runner(method, scene, t, lambda s, o=order: Settings(step=s["step"], order=o, max_steps=10**12)),
                                  order=p, fixed_step=True))
    settings = [{"label": f"rtol={r:.0e}", "rtol": r} for r in _tolerances(6, 13, options.quick)]
    out.append(Series("auto", "rotlab", settings, _auto_runner(scene, t)))
    return out


def _rotlab_runner(method, scene, t, settings_of):
    def run(setting: dict[str, Any]):
        solution = method.solve(scene, t, settings_of(setting), None)
        state = solution.state[:, :7] if solution.valid == t.shape[0] else np.full((t.shape[0], 7), np.nan)
        return state, solution.steps or None, solution.rhs_evaluations or None, solution.failure, None

    return run


def _auto_runner(scene, t):
    """``auto`` as a user runs it: ``choose_method`` and the solve, both timed.  The untimed
    warm-up call makes the choice; the timed calls find it in the API's cache of choices, as a loop
    over ``rotlab.simulate`` does (the cost of a fresh choice is in the ``overhead`` section)."""
    from rotlab.api import CHOICES
    from rotlab.methods.base import Settings
    from rotlab.methods.choose import choose_method

    def run(setting: dict[str, Any]):
        settings = Settings(rtol=setting["rtol"], atol=setting["rtol"] * 1e-2, max_steps=10**10)
        method, why, settings = choose_method(scene, "auto", settings, t, CHOICES)
        solution = method.solve(scene, t, settings, None)
        state = solution.state[:, :7] if solution.valid == t.shape[0] else np.full((t.shape[0], 7), np.nan)
        chosen = why.split(",")[0].removeprefix("auto: ")
        return state, solution.steps or None, solution.rhs_evaluations or None, solution.failure, chosen

    return run


def peer_series(scene, t: np.ndarray, options: Options) -> list[Series]:
    out: list[Series] = []
    ranges = {"RK45": (4, 12), "DOP853": (6, 13), "LSODA": (4, 12), "Radau": (4, 12)}
    if options.quick:  # Radau left out: its runs are by far the slowest
        ranges = {"RK45": (6, 12), "DOP853": (6, 12), "LSODA": (6, 12)}
    for method in ranges:
        lo, hi = ranges[method]
        settings = [{"label": f"rtol={r:.0e}", "rtol": r} for r in _tolerances(lo, hi, options.quick)]

        def run(setting, method=method):
            sol = peer_mod.solve_scipy(method, scene, t, setting["rtol"], setting["rtol"] * 1e-2)
            return sol.state, None, sol.rhs_evaluations, sol.failure, None

        out.append(Series(f"scipy:{method}", "scipy", settings, run))
    interval = float(t[1] - t[0])
    settings = [{"label": f"h={interval / n:.4g}", "step": interval / n, "substeps": n} for n in _substeps(scene, t, 4, options.decades_per_point)]

    def run_seed(setting):
        sol = peer_mod.solve_seed_rk4(scene, t, setting["substeps"])
        return sol.state, sol.steps, sol.rhs_evaluations, sol.failure, None

    out.append(Series(peer_mod.SEED_RK4, "seed", settings, run_seed, order=4, fixed_step=True))
    return out


def warm_up_peers() -> None:
    """Import and run every peer once on a tiny free body, so no record pays for it."""
    from rotlab.config import parse_scenario
    from rotlab.scene.scene import build_scene

    scene = build_scene(parse_scenario({"body": {"principal_moments": [1.0, 2.0, 2.5]}, "initial": {"omega": [1.0, 0.1, 0.1]},
                                        "time": {"end": 1.0, "samples": 3}}))
    t = np.linspace(0.0, 1.0, 3)
    for method in peer_mod.SCIPY_METHODS:
        peer_mod.solve_scipy(method, scene, t, 1e-6, 1e-8)
    peer_mod.solve_seed_rk4(scene, t, 2)


def make_evaluator(problem: Problem, scene, reference: Reference) -> Callable[[np.ndarray], dict[str, float | None]]:
    conservative = not scene.has_work
    up = scene.field_direction if scene.field_direction is not None else np.array([0.0, 0.0, 1.0])

    def evaluate(state: np.ndarray) -> dict[str, float | None]:
        out: dict[str, float | None] = {"omega_error": None, "attitude_error": None}
        err = math.inf
        if reference.state is not None:
            err, omega, attitude = state_error(state, reference.state)
            out.update(omega_error=omega, attitude_error=attitude)
        out["energy_error"] = energy_error(scene, state) if conservative else None
        out["norm_error"] = norm_error(state)
        if problem.metric == STATE:
            out["max_error"] = err
        elif problem.metric == ENERGY:
            out["max_error"] = out["energy_error"]
        elif problem.metric == KOVALEVSKAYA:
            out["max_error"] = kovalevskaya_error(state, problem.kovalevskaya_nu, up)
        return out

    return evaluate


def run_problem(problem: Problem, options: Options, include_peers: bool = True) -> tuple[list[Record], Reference]:
    """All series on one problem: rotlab methods that apply, then the peers."""
    from rotlab.scene.scene import build_scene

    scenario = problem.scenario()
    scene = build_scene(scenario)
    t = scenario.time.sample_times()
    reference = reference_solution(problem, scene, t)
    check = f" (check vs {reference.check_how}: {reference.check:.2g})" if reference.check is not None else ""
    options.log(f"[{problem.name}] {problem.title}; reference: {reference.how}{check}")
    evaluate = make_evaluator(problem, scene, reference)
    series = rotlab_series(scene, t, options) + (peer_series(scene, t, options) if include_peers else [])
    records: list[Record] = []
    for s in series:
        records.extend(sweep(problem, s, evaluate, options, reference))
    return records, reference


def sweep(problem: Problem, series: Series, evaluate, options: Options, reference: Reference) -> Iterator[Record]:
    """Run ``series`` setting by setting (see the module docstring for the stopping rules).

    When rotlab's ``exact`` is itself the reference, its error against the reference is ~0 by
    construction: its record (and ``auto``'s, when it runs exact) shows instead the distance to the independent check solution
    (``Reference.check``), a conservative figure (it includes the check solution's own error)."""
    best = math.inf
    stalled = 0
    from rotlab.errors import InputError

    for k, setting in enumerate(series.settings):
        try:
            (state, steps, evals, failure, chosen), seconds, compile_s, repeats = timed(lambda: series.run(setting), options, warm_up=series.side == "rotlab")
        except InputError as exc:  # e.g. a fixed step beyond the method's stability limit: refused, not run
            options.log(f"  {series.method:24} {setting['label']:>14}  refused: {exc}")
            continue
        metrics = evaluate(state)
        err = metrics.pop("max_error")
        runs_exact = series.method == "exact" or (chosen or "").startswith("exact")  # auto may run exact too
        if runs_exact and reference.uses_exact and reference.check is not None and err is not None:
            err = max(err, reference.check)
        record = Record(
            problem=problem.name, method=series.method, setting=setting["label"], max_error=err, seconds=seconds,
            side=series.side, metric=problem.metric, series=series.method, order=series.order,
            step=setting.get("step"), rtol=setting.get("rtol"), repeats=repeats, compile_seconds=compile_s,
            steps=steps, rhs_evaluations=evals, failure=failure, reference=reference.how, load_average=_load(), chosen=chosen, **metrics,
        )
        options.log(f"  {series.method:24} {setting['label']:>14}  error {_fmt(err):>9}  {seconds:.3g} s ×{repeats}" + (f"  → {chosen}" if chosen else ""))
        yield record
        if err is not None and math.isfinite(err):
            if err <= options.stop_error:
                return
            # no progress: at the reference's / rounding's floor, or the error grows with the work
            # (not for auto: its error moves in steps when it switches method or order)
            stalled = stalled + 1 if series.method != "auto" and ((err > 0.5 * best and best < 1e-8) or (err > best and best < 1e-4)) else 0
            best = min(best, err)
            if stalled >= 2:
                return
        if seconds > options.run_budget:
            return
        if series.fixed_step and k + 1 < len(series.settings):  # do not start a run far beyond the budget
            ratio = series.settings[k + 1]["substeps"] / setting["substeps"]
            if seconds * ratio > 3.0 * options.run_budget:
                return


def _load() -> float | None:
    try:
        return round(os.getloadavg()[0], 2)
    except (AttributeError, OSError):
        return None


def _fmt(x: float | None) -> str:
    return "—" if x is None or not math.isfinite(x) else f"{x:.2e}"


# --- ratios from the work-precision data ---------------------------------------------------------


def _crossing_time(points: list[tuple[float, float]], threshold: float) -> float | None:
    """Seconds at error = threshold along one series (points in setting order), log-log
    interpolation between the last point above and the first point at or below the threshold;
    the first point's time if it is already below."""
    prev = None
    for sec, err in points:
        if err is None or not math.isfinite(err) or err <= 0.0:
            prev = None
            continue
        if err <= threshold:
            if prev is None:
                return sec
            s0, e0 = prev
            x = (math.log(threshold) - math.log(e0)) / (math.log(err) - math.log(e0))
            return math.exp(math.log(s0) + x * (math.log(sec) - math.log(s0)))
        prev = (sec, err)
    return None


def best_at(records: list[Record], threshold: float = THRESHOLD) -> dict[str, Any] | None:
    """Fastest measured run with max_error ≤ threshold, and the fastest log-log interpolated
    crossing of the threshold over the series of ``records``."""
    reaching = [r for r in records if r.max_error is not None and math.isfinite(r.max_error) and r.max_error <= threshold]
    by_series: dict[str, list[Record]] = {}
    for r in records:
        by_series.setdefault(r.series, []).append(r)
    crossings = [(t, name) for name, rs in by_series.items() if (t := _crossing_time([(r.seconds, r.max_error) for r in rs], threshold)) is not None]
    if not reaching:
        best_err = min((r for r in records if r.max_error is not None and math.isfinite(r.max_error)), key=lambda r: r.max_error, default=None)
        return None if best_err is None else {"reached": False, "best_error": best_err.max_error, "method": best_err.method,
                                               "setting": best_err.setting, "seconds": best_err.seconds}
    fastest = min(reaching, key=lambda r: r.seconds)
    t_interp, s_interp = min(crossings) if crossings else (fastest.seconds, fastest.series)
    return {"reached": True, "method": fastest.method, "setting": fastest.setting, "seconds": fastest.seconds,
            "max_error": fastest.max_error, "interpolated_seconds": t_interp, "interpolated_method": s_interp}


def ratios(records: list[Record], threshold: float = THRESHOLD) -> list[dict[str, Any]]:
    """Per problem: rotlab's best vs scipy's best (any method; and DOP853 alone), at max error ≤
    threshold, measured and interpolated; also rotlab without ``exact`` (time-stepping only), and
    ``auto`` (which is not counted in rotlab's best: it runs one of the other methods) against
    rotlab's best and scipy's best."""
    out = []
    problems = list(dict.fromkeys(r.problem for r in records if r.kind == "work-precision"))
    for name in problems:
        rs = [r for r in records if r.problem == name and r.kind == "work-precision"]
        sides = {
            "rotlab": best_at([r for r in rs if r.side == "rotlab" and r.method != "auto"], threshold),
            "rotlab_stepping": best_at([r for r in rs if r.side == "rotlab" and r.method not in ("exact", "auto")], threshold),
            "auto": best_at([r for r in rs if r.method == "auto"], threshold),
            "scipy": best_at([r for r in rs if r.side == "scipy"], threshold),
            "scipy_dop853": best_at([r for r in rs if r.method == "scipy:DOP853"], threshold),
            "seed": best_at([r for r in rs if r.side == "seed"], threshold),
        }
        row: dict[str, Any] = {"kind": "ratio", "problem": name, "threshold": threshold, "metric": rs[0].metric, **sides}
        for a, b in (("rotlab", "scipy"), ("rotlab", "scipy_dop853"), ("rotlab_stepping", "scipy"), ("rotlab", "seed"), ("auto", "scipy"),
                     ("rotlab", "auto")):
            x, y = sides[a], sides[b]
            key = f"{a}_vs_{b}"
            if x and y and x["reached"] and y["reached"]:
                row[key] = y["seconds"] / x["seconds"]
                row[key + "_interpolated"] = y["interpolated_seconds"] / x["interpolated_seconds"]
            else:
                row[key] = None
                row[key + "_interpolated"] = None
        out.append(row)
    return out


def leads(records: list[Record], thresholds: tuple[float, ...] = LEAD_THRESHOLDS) -> list[dict[str, Any]]:
    """Per problem and threshold: rotlab's own ``dop853`` (the stand-in for a compiled DOP853:
    docs/benchmarks.md) against rotlab's best other method and against ``auto``, at max error ≤
    threshold; lead = dop853's time / the other's (measured; log-log interpolated)."""
    out = []
    problems = list(dict.fromkeys(r.problem for r in records if r.kind == "work-precision"))
    for name in problems:
        rs = [r for r in records if r.problem == name and r.kind == "work-precision" and r.side == "rotlab"]
        for threshold in thresholds:
            sides = {
                "dop853": best_at([r for r in rs if r.method == "dop853"], threshold),
                "best": best_at([r for r in rs if r.method not in ("dop853", "auto")], threshold),
                "auto": best_at([r for r in rs if r.method == "auto"], threshold),
            }
            row: dict[str, Any] = {"kind": "lead", "problem": name, "threshold": threshold, "method": "dop853", "setting": "-",
                                   "max_error": None, "seconds": None, **sides}
            for other in ("best", "auto"):
                x, y = sides[other], sides["dop853"]
                ok = bool(x and y and x["reached"] and y["reached"])
                row[f"lead_{other}"] = y["seconds"] / x["seconds"] if ok else None
                row[f"lead_{other}_interpolated"] = y["interpolated_seconds"] / x["interpolated_seconds"] if ok else None
            out.append(row)
    return out


# --- per-call overhead ----------------------------------------------------------------------------


def call_overhead(options: Options, configs: list[Path] | None = None, samples: int = 201) -> list[dict[str, Any]]:
    """What ``rotlab.simulate`` adds to the integration: for each shipped config with ``samples``
    samples, the medians of ``simulate(scenario)`` (scene, choice, solve, trajectory), the scene
    + a fresh (uncached) choice + ``Method.solve``, ``Method.solve`` alone and the fresh choice
    alone, timed interleaved (one of each per round).  ``simulate`` itself finds auto's choice in
    its cache after the warm-up, as a loop over it does."""
    import rotlab
    from rotlab.methods.base import Settings
    from rotlab.methods.choose import auto_choice, choose_method
    from rotlab.scene.scene import build_scene

    if configs is None:
        configs = sorted(CONFIGS.glob("*.toml"))
    rounds = 15 if options.quick else 41
    rows = []
    for config in configs:
        sc = rotlab.load(config)
        sc = sc.model_copy(update={"time": sc.time.model_copy(update={"sample_rate": None, "samples": samples})})
        scene = build_scene(sc)
        t = sc.time.sample_times()
        s = sc.solver
        settings = Settings.of(s)
        method, _, chosen = choose_method(scene, s.method, settings, t)  # the config's method (sweep_flip.toml: rk4)
        rotlab.simulate(sc)  # warm-up: kernels loaded, lazy imports done

        def fresh_choice(fresh):
            return auto_choice(fresh, settings, t) if s.method == "auto" else choose_method(fresh, s.method, settings, t)

        def choose_and_solve():
            fresh = build_scene(sc)
            m, _, st = fresh_choice(fresh)
            return m.solve(fresh, t, st, None)

        calls = {"simulate": lambda: rotlab.simulate(sc), "scene+choose+solve": choose_and_solve,
                 "solve": lambda: method.solve(scene, t, chosen, None), "choose": lambda: fresh_choice(scene)}
        samples_s: dict[str, list[float]] = {k: [] for k in calls}
        for _ in range(rounds):
            for key, fn in calls.items():
                started = time.perf_counter()
                fn()
                samples_s[key].append(time.perf_counter() - started)
        med = {k: statistics.median(v) for k, v in samples_s.items()}
        rows.append({"kind": "overhead", "problem": config.name, "method": method.name, "setting": f"{samples} samples", "max_error": None,
                     "seconds": med["simulate"], "simulate_seconds": med["simulate"], "solve_seconds": med["solve"],
                     "pipeline_seconds": med["scene+choose+solve"], "choose_seconds": med["choose"],
                     "overhead_seconds": med["simulate"] - med["solve"], "repeats": rounds, "load_average": _load()})
        options.log(f"  overhead {config.name}: simulate {med['simulate'] * 1e6:.0f} µs, solve {med['solve'] * 1e6:.0f} µs, "
                    f"choose {med['choose'] * 1e6:.0f} µs")
    return rows


# --- throughput -----------------------------------------------------------------------------------


def kernel_throughput(options: Options, steps: int = 1_000_000) -> list[dict[str, Any]]:
    """Single-body steps per second on a free asymmetric body, I = (1, 1.6, 2.2), ω₀ = (1, 0.5, 1.5):
    every rotlab method that steps, through ``Method.solve`` (1001 samples, h = 1e-3 for the
    fixed-step methods, rtol 1e-10 for the adaptive ones: the driver's Python work is once per 2¹⁸ steps,
    negligible here), and the peers on the same body (10³ steps)."""
    from rotlab.config import parse_scenario
    from rotlab.methods.base import Settings
    from rotlab.methods.registry import METHODS, get_method
    from rotlab.scene.scene import build_scene

    if options.quick:
        steps = min(steps, 200_000)
    scene = build_scene(parse_scenario({"body": {"principal_moments": [1.0, 1.6, 2.2]}, "initial": {"omega": [1.0, 0.5, 1.5]}, "time": {"end": 1.0}}))
    t = np.linspace(0.0, steps * 1e-3, 1001)
    rows: list[dict[str, Any]] = []
    for name in METHODS:
        method = get_method(name)
        if name == "exact" or method.unsupported(scene):
            continue
        if method.adaptive:
            settings = [(name, Settings(rtol=1e-10, atol=1e-12, max_steps=10**12), "rtol=1e-10")]
        else:
            settings = [(name if o is None else f"{name}-{o}", Settings(step=1e-3, order=o, max_steps=10**12), "h=1e-3")
                        for o in (method.orders or (None,))]
        for label, setting, text in settings:
            solution, sec, compile_s, n = timed(lambda: method.solve(scene, t, setting, None), options, warm_up=True)
            rows.append(_throughput_row(label, "rotlab", solution.steps + solution.rejected_steps, sec, compile_s, n, text))

    t_peer = np.linspace(0.0, 1.0, 11)
    warm_up_peers()
    result, sec, _, n = timed(lambda: peer_mod.solve_seed_rk4(scene, t_peer, 100), options, warm_up=False)
    rows.append(_throughput_row(peer_mod.SEED_RK4, "seed", result.steps, sec, 0.0, n, "h=1e-3"))
    t_peer = np.linspace(0.0, 100.0, 11)
    result, sec, _, n = timed(lambda: peer_mod.solve_scipy("DOP853", scene, t_peer, 1e-10, 1e-12), options, warm_up=False)
    row = _throughput_row("scipy:DOP853", "scipy", result.rhs_evaluations // 12, sec, 0.0, n, "rtol=1e-10")
    row["note"] = f"steps ≈ nfev/12 = {result.rhs_evaluations}/12"
    rows.append(row)
    return rows


def _throughput_row(method: str, side: str, steps: int, sec: float, compile_s: float, repeats: int, setting: str) -> dict[str, Any]:
    return {"kind": "throughput", "problem": "free body I = (1, 1.6, 2.2)", "method": method, "side": side, "setting": setting,
            "max_error": None, "seconds": sec, "steps": int(steps), "steps_per_second": steps / sec, "ns_per_step": 1e9 * sec / steps,
            "compile_seconds": compile_s, "repeats": repeats, "load_average": _load()}


def recording_throughput(options: Options) -> dict[str, Any]:
    """Rows per second of ``write_recording`` (full layout): the Lagrange top, 10⁵ samples (10⁴ with --quick)."""
    import rotlab
    from rotlab.recording.writer import write_recording

    rate = 100.0 if options.quick else 1000.0
    sc = rotlab.load(CONFIGS / "lagrange.toml", method="rk4")
    sc = sc.model_copy(update={"time": sc.time.model_copy(update={"end": 100.0, "sample_rate": rate, "samples": None})})
    traj = rotlab.simulate(sc)
    n = int(traj.t.shape[0])
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.rrd"
        _, sec, compile_s, repeats = timed(lambda: write_recording(traj, path), options, warm_up=True)
        size = path.stat().st_size
    return {"kind": "recording", "problem": "configs/lagrange.toml, 100 s", "method": "write_recording", "setting": f"{n} samples",
            "max_error": None, "seconds": sec, "rows": n, "rows_per_second": n / sec, "bytes_per_sample": size / n, "repeats": repeats}


def run_timing(options: Options, configs: list[Path] | None = None, cold_repeats: int | None = None) -> list[dict[str, Any]]:
    """Wall time of ``rotlab run CONFIG -q`` in a subprocess, end to end (interpreter start,
    imports, run, recording): cold = NUMBA_CACHE_DIR a fresh empty directory; warm = the same
    directory again, after the cold run filled it."""
    if configs is None:
        configs = [CONFIGS / "lagrange.toml"] if options.quick else sorted(CONFIGS.glob("*.toml"))
    cold_n = cold_repeats or (1 if options.quick else 3)
    warm_n = options.repeats
    rows = []
    floor_cmd = [sys.executable, "-c", "import " + ", ".join(DEPENDENCIES)]
    for config in configs:
        cold, warm = [], []
        with tempfile.TemporaryDirectory() as tmp:
            for k in range(cold_n):
                cache = Path(tmp) / f"numba-cache-{k}"
                cache.mkdir()
                cold.append(_run_once(config, Path(tmp), cache))
            floor = []
            for _ in range(warm_n):  # interleaved: the floor is measured beside every warm run
                warm.append(_run_once(config, Path(tmp), cache))
                floor.append(_timed_process(floor_cmd, dict(os.environ), Path(tmp)))
        row = {"kind": "run-timing", "problem": config.name, "method": "rotlab run", "setting": "-q", "max_error": None,
               "seconds": statistics.median(warm), "warm_seconds": statistics.median(warm), "cold_seconds": statistics.median(cold),
               "floor_seconds": statistics.median(floor), "warm_over_floor_seconds": statistics.median(w - f for w, f in zip(warm, floor)),
               "warm_all": warm, "cold_all": cold, "floor_all": floor, "floor_command": " ".join(["python", "-c", repr(floor_cmd[2])]),
               "command": f"rotlab run configs/{config.name} -o OUT.rrd -q", "load_average": _load()}
        options.log(f"  rotlab run {config.name}: cold {row['cold_seconds']:.2f} s, warm {row['warm_seconds']:.2f} s, "
                    f"floor (import of the dependencies) {row['floor_seconds']:.2f} s")
        rows.append(row)
    return rows


def _run_once(config: Path, workdir: Path, cache: Path) -> float:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    cmd = [sys.executable, "-m", "rotlab", "run", str(config), "-o", str(workdir / "out.rrd"), "-q"]
    return _timed_process(cmd, env, workdir)


def _timed_process(cmd: list[str], env: dict[str, str], workdir: Path) -> float:
    started = time.perf_counter()
    done = subprocess.run(cmd, env=env, cwd=workdir, capture_output=True, text=True)
    seconds = time.perf_counter() - started
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({done.returncode}): {done.stderr.strip()}")
    return seconds


# --- long runs: energy error of the splitting methods -------------------------------------------


def energy_windows(options: Options, steps: int = 10_000_000, windows: int = 10, h: float = 0.05, chunk: int = 200_000) -> list[dict[str, Any]]:
    """Relative energy error of the splitting methods (orders 2/4/6/8; dmv-2 and rk4 for contrast)
    over ``steps`` steps of the GNI free body at step ``h``, checked after EVERY step: the max
    |ΔH|/H₀ in each of ``windows`` equal windows of the run and over the whole run.  The kernels
    are called directly, ``chunk`` samples at a time (one step per sample), so nothing of size
    ``steps`` is stored."""
    from rotlab.bench.problems import get_problems
    from rotlab.methods.registry import get_method
    from rotlab.methods.stepping import initial_state
    from rotlab.scene.scene import build_scene

    if options.quick:
        steps = min(steps, 1_000_000)
    (problem,) = get_problems(["gni"])
    scene = build_scene(problem.scenario())
    model = scene.model
    moments = scene.moments
    per_window = steps // windows
    chunk = min(chunk, per_window)
    runs = [("splitting", o) for o in get_method("splitting").orders] + [("dmv", 2), ("rk4", None)]
    rows = []
    for name, order in runs:
        method = get_method(name)
        extra = method.extra_args(scene, order if order is not None else method.order_of_accuracy)
        y = initial_state(scene)
        h0 = 0.5 * float(np.sum(moments * y[4:7] ** 2))
        maxima = []
        started = time.perf_counter()
        t_now = 0.0
        for _ in range(windows):
            worst = 0.0
            done = 0
            while done < per_window:
                n = min(chunk, per_window - done)
                times = t_now + h * np.arange(n + 1)
                out = np.empty((n + 1, 8))
                status, _, _ = method.kernel(y, times, out, 1, 1, 10 * n, model, *extra)
                if status != 0:
                    raise RuntimeError(f"{name} failed in the long run")
                w = out[1:, 4:7]
                energy = 0.5 * (moments[0] * w[:, 0] ** 2 + moments[1] * w[:, 1] ** 2 + moments[2] * w[:, 2] ** 2)
                worst = max(worst, float(np.max(np.abs(energy - h0))) / h0)
                t_now = float(times[-1])
                done += n
            maxima.append(worst)
        seconds = time.perf_counter() - started
        label = name if order is None else f"{name}-{order}"
        rows.append({"kind": "energy-window", "problem": "gni", "method": label, "setting": f"h={h:g}, {steps:.0e} steps",
                     "max_error": max(maxima), "seconds": seconds, "windows": maxima, "steps": steps, "step": h,
                     "final_time": t_now, "last_over_first_window": maxima[-1] / maxima[0] if maxima[0] > 0 else None})
        options.log(f"  {label:12} max |ΔH|/H over {steps:.0e} steps: {max(maxima):.2e}  (windows " + ", ".join(f"{m:.1e}" for m in maxima) + ")")
    return rows
