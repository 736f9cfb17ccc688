"""Reports of a benchmark run: terminal tables, JSON, work-precision PNG plots (matplotlib,
optional: imported only when plots are asked for)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from rotlab.bench.runner import DEPENDENCIES, THRESHOLD, Record


def runner_dependencies() -> tuple[str, ...]:
    return DEPENDENCIES


def _e(x: float | None) -> str:
    return "—" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.2e}"


def _s(x: float | None) -> str:
    if x is None:
        return "—"
    if x < 1e-3:
        return f"{x * 1e6:.0f} µs"
    if x < 1.0:
        return f"{x * 1e3:.3g} ms"
    return f"{x:.3g} s"


def work_precision_table(records: list[Record], problem: str, title: str = "", reference: str = "") -> str:
    rs = [r for r in records if r.problem == problem]
    metric = rs[0].metric if rs else ""
    lines = [f"== {problem}: {title}", f"   metric: {metric}; reference: {reference}"] if title else [f"== {problem}"]
    lines.append(f"   {'method':24} {'setting':>12} {'max error':>10} {'time':>10} {'×':>3} {'compile':>8} {'steps':>10} {'f evals':>10} {'|ΔH|/H':>9} {'||Λ|-1|':>9}")
    for r in rs:
        fail = f"  ({r.failure[:60]})" if r.failure else (f"  → {r.chosen}" if r.chosen else "")
        lines.append(
            f"   {r.method:24} {r.setting:>12} {_e(r.max_error):>10} {_s(r.seconds):>10} {r.repeats:>3} {r.compile_seconds:8.2f} "
            f"{'' if r.steps is None else r.steps:>10} {'' if r.rhs_evaluations is None else r.rhs_evaluations:>10} "
            f"{_e(r.energy_error):>9} {_e(r.norm_error):>9}{fail}"
        )
    return "\n".join(lines)


def _side(best: dict[str, Any] | None) -> str:
    if best is None:
        return "no runs"
    if not best["reached"]:
        return f"not reached (best {_e(best['best_error'])}: {best['method']} {best['setting']}, {_s(best['seconds'])})"
    return f"{best['method']} {best['setting']} {_s(best['seconds'])} (interp. {_s(best['interpolated_seconds'])})"


def _ratio(row: dict[str, Any], key: str, pattern: str = "{:,.0f}× (interp. {:,.0f}×)", invert: bool = False) -> str:
    """A measured ratio and its interpolated twin (``key`` + "_interpolated"), or "—"."""
    x, y = row.get(key), row.get(key + "_interpolated")
    if x is None:
        return "—"
    return pattern.format(1.0 / x, 1.0 / y) if invert else pattern.format(x, y)


def ratio_table(rows: list[dict[str, Any]]) -> str:
    if not rows:
        return ""
    threshold = rows[0]["threshold"]
    lines = [f"== speed-up at max error ≤ {threshold:g}: fastest run reaching it on each side (and the log-log interpolated time at exactly {threshold:g})"]
    for row in rows:
        lines.append(f"   {row['problem']} ({row['metric']}):")
        lines.append(f"      rotlab best       {_side(row['rotlab'])}")
        lines.append(f"      rotlab stepping   {_side(row['rotlab_stepping'])}")
        lines.append(f"      auto              {_side(row['auto'])}")
        lines.append(f"      scipy best        {_side(row['scipy'])}")
        lines.append(f"      scipy DOP853      {_side(row['scipy_dop853'])}")
        lines.append(f"      seed RK4          {_side(row['seed'])}")
        lines.append(f"      rotlab/scipy: {_ratio(row, 'rotlab_vs_scipy')}   rotlab/scipy DOP853: {_ratio(row, 'rotlab_vs_scipy_dop853')}   "
                     f"stepping/scipy: {_ratio(row, 'rotlab_stepping_vs_scipy')}   rotlab/seed: {_ratio(row, 'rotlab_vs_seed')}")
        lines.append(f"      auto/scipy: {_ratio(row, 'auto_vs_scipy')}   auto's time / rotlab best's: {_ratio(row, 'rotlab_vs_auto', '{:.2f} (interp. {:.2f})', invert=True)}")
    return "\n".join(lines)


def headline_table(ratio_rows: list[dict[str, Any]], lead_rows: list[dict[str, Any]]) -> str:
    """One line per problem at one threshold: rotlab's fastest run reaching it, and how many times
    faster it is than scipy's fastest and than rotlab's own dop853 (a compiled DOP853); ``auto``'s
    time and its lead over dop853.  Measured ratios (``ratio_table``, ``lead_table``: the details)."""
    if not ratio_rows:
        return ""
    threshold = ratio_rows[0]["threshold"]
    leads = {r["problem"]: r for r in lead_rows if r["threshold"] == threshold}
    lines = [f"== rotlab at max error ≤ {threshold:g}: its fastest run reaching it, and the other's time / rotlab's",
             f"   {'problem':20} {'rotlab best':>36}  {'vs scipy best':>13}  {'vs dop853':>9}  {'auto':>9}  {'auto vs dop853':>14}"]
    for row in ratio_rows:
        lead = leads.get(row["problem"], {})
        vs_scipy = "—" if row.get("rotlab_vs_scipy") is None else f"{row['rotlab_vs_scipy']:,.0f}×"
        vs_dop = "—" if lead.get("lead_best") is None else f"{lead['lead_best']:.2f}×"
        auto_lead = "—" if lead.get("lead_auto") is None else f"{lead['lead_auto']:.2f}×"
        lines.append(f"   {row['problem']:20} {_short(row['rotlab']):>36}  {vs_scipy:>13}  {vs_dop:>9}  {_short(row['auto'], False):>9}  {auto_lead:>14}")
    return "\n".join(lines)


def lead_table(rows: list[dict[str, Any]]) -> str:
    """rotlab's best other method and ``auto`` against rotlab's own dop853 at each threshold."""
    if not rows:
        return ""
    thresholds = list(dict.fromkeys(r["threshold"] for r in rows))
    lines = ["== lead over rotlab's dop853 (a compiled DOP853): dop853's time / the other's, at max error ≤ threshold "
             "(fastest run reaching it; log-log interpolated in parentheses)",
             f"   {'problem':20} {'threshold':>9}  {'dop853':>30}  {'rotlab best (not dop853)':>44}  {'lead':>16}  {'auto':>12}  {'lead':>16}"]
    for threshold in thresholds:
        for r in (x for x in rows if x["threshold"] == threshold):
            lines.append(f"   {r['problem']:20} {threshold:>9.0e}  {_short(r['dop853']):>30}  {_short(r['best'], True):>44}  "
                         f"{_lead(r, 'lead_best'):>16}  {_short(r['auto'], False):>12}  {_lead(r, 'lead_auto'):>16}")
    return "\n".join(lines)


def _short(best: dict[str, Any] | None, name: bool = True) -> str:
    if best is None:
        return "no runs"
    if not best["reached"]:
        return f"not reached (best {_e(best['best_error'])})"
    return (f"{best['method']} {best['setting']} " if name else "") + _s(best["seconds"])


def _lead(row: dict[str, Any], key: str) -> str:
    return _ratio(row, key, "{:.2f}× ({:.2f}×)")


def overhead_table(rows: list[dict[str, Any]]) -> str:
    if not rows:
        return ""
    lines = [f"== per-call overhead of rotlab.simulate ({rows[0]['setting']}; medians of {rows[0]['repeats']} interleaved rounds)",
             f"   {'config':20} {'method':8} {'solve':>10} {'choose':>10} {'scene+choose+solve':>19} {'simulate':>10} {'simulate − solve':>17}"]
    for r in rows:
        lines.append(f"   {r['problem']:20} {r['method']:8} {_s(r['solve_seconds']):>10} {_s(r['choose_seconds']):>10} "
                     f"{_s(r['pipeline_seconds']):>19} {_s(r['simulate_seconds']):>10} {_s(r['overhead_seconds']):>17}")
    return "\n".join(lines)


def throughput_table(rows: list[dict[str, Any]], recording: dict[str, Any] | None) -> str:
    lines = []
    if rows:
        lines.append(f"== single-body throughput, {rows[0]['problem']} (kernel time, median)")
        lines.append(f"   {'method':24} {'setting':>11} {'steps':>10} {'time':>10} {'ns/step':>9} {'M steps/s':>10} {'compile':>8}")
        for r in rows:
            lines.append(f"   {r['method']:24} {r['setting']:>11} {r['steps']:>10} {_s(r['seconds']):>10} {r['ns_per_step']:9.1f} "
                         f"{r['steps_per_second'] / 1e6:10.3f} {r['compile_seconds']:8.2f}" + (f"  ({r['note']})" if r.get("note") else ""))
    if recording:
        lines.append(f"== recording: {recording['rows']:,} samples of the full layout in {_s(recording['seconds'])}: "
                     f"{recording['rows_per_second'] / 1e6:.2f} M rows/s, {recording['bytes_per_sample']:.0f} B/sample")
    return "\n".join(lines)


def run_timing_table(rows: list[dict[str, Any]]) -> str:
    lines = ["== `rotlab run CONFIG -q` end to end (subprocess): cold = empty NUMBA_CACHE_DIR, warm = cache filled (medians); "
             "floor = `python -c 'import " + ", ".join(runner_dependencies()) + "'`, run beside each warm run"]
    for r in rows:
        floor = f"   floor {r['floor_seconds']:6.2f} s   warm − floor {r['warm_over_floor_seconds']:6.2f} s" if "floor_seconds" in r else ""
        lines.append(f"   {r['problem']:20} cold {r['cold_seconds']:6.2f} s   warm {r['warm_seconds']:6.2f} s{floor}")
    return "\n".join(lines)


def energy_table(rows: list[dict[str, Any]]) -> str:
    if not rows:
        return ""
    lines = [f"== energy error over {rows[0]['steps']:.0e} steps, GNI free body, h = {rows[0]['step']:g}: max |ΔH|/H₀ checked after every step, "
             f"per {len(rows[0]['windows'])}th of the run"]
    for r in rows:
        lines.append(f"   {r['method']:12} max {_e(r['max_error'])}  windows: " + " ".join(_e(w) for w in r["windows"]) + f"   ({r['seconds']:.1f} s)")
    return "\n".join(lines)


def write_json(path: Path, records: list[Record], extra: list[dict[str, Any]]) -> None:
    """A list of objects: every work-precision record (problem, method, setting, max_error, seconds, ...),
    then the ratio, throughput, recording, run-timing and energy-window objects (``kind`` says which)."""
    items = [r.to_json() for r in records] + [_clean(x) for x in extra]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(items, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")


def _clean(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_clean(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def write_plots(directory: Path, records: list[Record], titles: dict[str, str]) -> list[Path]:
    """One work-precision PNG per problem: max error against wall time, log-log; rotlab solid,
    scipy dashed, the seeds' RK4 dotted; a line at the comparison threshold."""
    try:
        import matplotlib
    except ImportError:
        raise RuntimeError("--plots needs matplotlib, which is not a rotlab dependency: pip install matplotlib (or pip install 'rotlab[plots]')") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory.mkdir(parents=True, exist_ok=True)
    paths = []
    for problem in dict.fromkeys(r.problem for r in records):
        rs = [r for r in records if r.problem == problem and r.max_error is not None and math.isfinite(r.max_error) and r.max_error > 0]
        if not rs:
            continue
        fig, ax = plt.subplots(figsize=(8.5, 6.0))
        series = list(dict.fromkeys(r.series for r in rs))
        tab20 = plt.get_cmap("tab20")
        ours = [tab20(i) for i in (*range(0, 20, 2), *range(1, 20, 2)) if i not in (14, 15)]  # no greys: they are scipy's
        theirs = ["#555555", "#b8860b", "#8b0000", "#4b0082", "#000000"]
        k_ours = k_theirs = 0
        for name in series:
            pts = [r for r in rs if r.series == name]
            side = pts[0].side
            if side == "rotlab":
                color = ours[k_ours % len(ours)]
                k_ours += 1
            else:
                color = theirs[k_theirs % len(theirs)]
                k_theirs += 1
            style = {"rotlab": "-", "scipy": "--", "seed": ":"}[side]
            marker = "*" if name == "exact" else ("o" if side == "rotlab" else "s")
            ax.plot([r.seconds for r in pts], [r.max_error for r in pts], style, marker=marker, ms=9 if name == "exact" else 4,
                    color=color, label=name, lw=1.6 if side == "rotlab" else 1.3)
        ax.axhline(THRESHOLD, color="0.5", lw=0.8, ls="-.")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time, s (median of repeats, compile excluded)")
        ax.set_ylabel({"state": "max error (ω relative, attitude)", "energy": "max |ΔH|/H₀",
                       "kovalevskaya": "max |K − K₀|/K₀"}.get(rs[0].metric, "max error"))
        ax.set_title(f"{problem}: {titles.get(problem, '')}", fontsize=9)
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7, ncol=2, loc="best")
        fig.tight_layout()
        path = directory / f"wp_{problem.replace(':', '_')}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
