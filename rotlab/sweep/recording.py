"""The recording that compares a sweep's cases (Rerun writing lives under ``rotlab.recording``).

Entities
    /compare/omega_x|omega_y|omega_z/case_<k>   ω body components of case k (rad/s)
    /compare/energy_drift/case_<k>               log10 |relative drift of T + V − W|
    /results/<parameter>/<observable>            scatter: observable (``scatter_columns``: events' too) of each case against the
                                                 swept parameter (see ``rotlab.recording.scatter``)
    /sweep                                       the results table (Markdown)
Bounded whatever the number of cases: series of ``COMPARED_CASES`` cases spread evenly over the
sweep and any asked for (``--compare``: ``rotlab.sweep.runner.compared_cases``), scatters of at most
``MAX_SCATTER`` cases, a table of at most ``MAX_TABLE`` rows.
Case k has the same colour everywhere (``style.ramp_color`` in the order of the first swept
parameter), so a line in a time plot and a point in a scatter plot are recognisably one case.
Every view's origin is an entity subtree that exists (tested: tests/test_visuals.py).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from rotlab.recording import scatter as sc
from rotlab.events import OBSERVED
from rotlab.recording.layout import TIMELINE
from rotlab.recording.style import AXIS_TRACE, ramp_color
from rotlab.sweep.results import Results
from rotlab.sweep.runner import CaseOutcome

MAX_SCATTER = 20_000  # cases drawn in each scatter (evenly spread over the sweep), and ...
MAX_TABLE = 500  # ... rows in its Markdown table (the compared and the failing cases first)
LOG_FLOOR = 1e-17  # below double precision: drawn as −17
COMPONENTS = (("omega_x", "p = ω_x"), ("omega_y", "q = ω_y"), ("omega_z", "r = ω_z"))
OBSERVABLES = {  # table column → (plot title, transform of the value)
    "flip_period_s": ("flip period (s)", None),
    "max_nutation_deg": ("max nutation (deg)", None),
    "max_drift_energy": ("log10 max energy drift", "log10"),
    "seconds": ("wall time per case (s)", None),
}


EVENT_TITLES = dict(zip(OBSERVED, ("{name}: occurrences", "{name}: first time (s)", "{name}: mean interval (s)")))


def scatter_columns(results: Results) -> dict[str, tuple[str, str | None]]:
    """The columns drawn against each parameter: ``OBSERVABLES`` and each event's
    (``rotlab.events.observables``), column → (plot title, transform)."""
    out = dict(OBSERVABLES)
    for column in results.observables:
        if column.startswith("event_"):
            for what, title in EVENT_TITLES.items():
                if column.endswith("_" + what):
                    out[column] = (title.format(name=column[len("event_"):-len(what) - 1]), None)
    return out


def parameter_columns(results: Results) -> list[str]:
    """The swept parameter columns that vary (finite values)."""
    out = []
    for name in results.params:
        values = results.column(name)
        values = values[np.isfinite(values)]
        if values.size and np.any(values != values[0]):
            out.append(name)
    return out


def case_colors(results: Results, rows: np.ndarray) -> list[tuple[int, int, int]]:
    """The colour of each of ``rows``: its rank among all cases by the first varying parameter (then
    by case number) on the violet → yellow ramp."""
    params = parameter_columns(results)
    case = results.column("case")
    key = results.column(params[0]) if params else case.astype(float)
    order = np.lexsort((case, np.nan_to_num(key, nan=np.inf)))
    rank = np.empty(order.shape[0], dtype=np.int64)
    rank[order] = np.arange(order.shape[0])
    top = max(order.shape[0] - 1, 1)
    return [ramp_color(r / top) for r in rank[rows].tolist()]


def drawn_rows(results: Results) -> np.ndarray:
    """The rows drawn in the scatters: every case, or ``MAX_SCATTER`` spread evenly over the cases (in case order)."""
    order = results.in_case_order()
    if order.shape[0] <= MAX_SCATTER:
        return order
    return order[np.unique(np.linspace(0, order.shape[0] - 1, MAX_SCATTER).round().astype(np.int64))]


def slug(name: str) -> str:
    """An entity-path part from a column name: 'initial.omega[0]' → 'initial_omega_0'."""
    return re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", name)).strip("_")


def plots(results: Results, rows: np.ndarray, colors: list[tuple[int, int, int]]) -> dict[str, dict[str, sc.Scatter]]:
    """parameter → observable → scatter of ``rows`` (observables undefined in every case are left
    out), in the cases' ``colors``."""
    out: dict[str, dict[str, sc.Scatter]] = {}
    for param in parameter_columns(results):
        x = results.column(param)[rows]
        views = {}
        for column, (_, transform) in scatter_columns(results).items():
            if column not in results.header:
                continue
            y = results.column(column)[rows].astype(float)
            if transform == "log10":
                with np.errstate(divide="ignore", invalid="ignore"):
                    y = np.log10(np.abs(y))
                y[~np.isfinite(y)] = np.nan
            drawn = sc.scatter(x, y, colors)
            if drawn is not None:
                views[column] = drawn
        out[param] = views
    return out


def blueprint(results: Results, shown: list[CaseOutcome], scatters: dict[str, dict[str, sc.Scatter]]):
    import rerun.blueprint as rrb

    spin = _spin_component(shown)
    omega_tabs = rrb.Tabs(
        *[rrb.TimeSeriesView(origin=f"/compare/{entity}", name=f"{label} per case (rad/s)", plot_legend=rrb.PlotLegend(visible=False))
          for entity, label in COMPONENTS],
        active_tab=spin,
    )
    first = parameter_columns(results)
    colour_note = f" (colour: {first[0]}, violet low → yellow high)" if first else ""
    time_column = rrb.Vertical(
        omega_tabs,
        rrb.TimeSeriesView(origin="/compare/energy_drift", name=f"log10 |energy drift| per case{colour_note}",
                           plot_legend=rrb.PlotLegend(visible=False)),
        row_shares=[3, 2],
    )
    result_tabs = []
    titles = scatter_columns(results)
    for param, views in scatters.items():
        if not views:
            continue
        result_tabs.append(rrb.Grid(
            *[rrb.Spatial2DView(origin=f"/results/{slug(param)}/{column}", name=f"{titles[column][0]} vs {param}",
                                visual_bounds=rrb.VisualBounds2D(x_range=s.bounds[0], y_range=s.bounds[1]))
              for column, s in views.items()],
            grid_columns=2, name=f"vs {param}",
        ))
    result_tabs.append(rrb.TextDocumentView(origin="/sweep", name="Table"))
    return rrb.Blueprint(rrb.Horizontal(time_column, rrb.Tabs(*result_tabs), column_shares=[1, 1]), collapse_panels=True)


def _spin_component(shown: list[CaseOutcome]) -> int:
    """The ω component that varies most across the shown cases (the interesting tab)."""
    spread = np.zeros(3)
    for o in shown:
        spread = np.maximum(spread, np.ptp(o.omega, axis=0))
    return int(np.argmax(spread)) if shown else 0


def table_rows(results: Results, shown: list[CaseOutcome]) -> np.ndarray:
    """The rows of the recording's Markdown table: every case, or the compared and the failing
    ones first and then the others in case order, ``MAX_TABLE`` in all (in case order)."""
    order = results.in_case_order()
    if order.shape[0] <= MAX_TABLE:
        return order
    case = results.column("case")
    first = np.flatnonzero(np.isin(case, [o.index for o in shown]))
    chosen = np.unique(np.concatenate([first, results.failing()[:MAX_TABLE]]))[:MAX_TABLE]
    rest = order[~np.isin(order, chosen)][: MAX_TABLE - chosen.shape[0]]
    picked = np.concatenate([chosen, rest])
    return picked[np.argsort(case[picked], kind="stable")]


def write_comparison(results: Results, path: Path, title: str) -> Path:
    """One recording comparing the cases that kept their series (``results.compared``) and scattering every case's observables (up to ``MAX_SCATTER``).  Written as
    a run's recording is (``RecordingSink``: every write checked, the file verified, then
    renamed): a full disk is ``RunFailure``, with no temporary file left and an existing file untouched."""
    import rerun as rr

    from rotlab.recording.sink import RecordingSink
    from rotlab.recording.writer import check_output_path

    check_output_path(path)
    shown = sorted(results.compared, key=lambda o: o.index)
    order = results.in_case_order()
    positions = np.searchsorted(results.column("case")[order], [o.index for o in shown])
    row_of = dict(zip([o.index for o in shown], order[positions].tolist()))  # (the shown cases' rows only)
    shown_colors = dict(zip([o.index for o in shown], case_colors(results, np.array([row_of[o.index] for o in shown], dtype=np.int64))))
    drawn = drawn_rows(results)
    scatters = plots(results, drawn, case_colors(results, drawn))
    header = results.header
    listed = table_rows(results, shown)
    sink = RecordingSink(path, application_id="rotlab-sweep")
    try:
        sink.open(blueprint(results, shown, scatters))
        rec = sink.rec
        md = [f"# {title or 'sweep'}", ""]
        if listed.shape[0] < len(results):
            md += [f"{listed.shape[0]} of {len(results):,} cases (those compared and those that did not pass first): every case is in results.csv.", ""]
        md += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        table = results.table(listed)
        md += ["| " + " | ".join(f"{v:.4g}" if isinstance(v, float) else str(v) for v in r) + " |" for r in table]
        rec.log("/sweep", rr.TextDocument("\n".join(md), media_type="text/markdown"), static=True)
        for o in shown:
            index = [rr.TimeColumn(TIMELINE, duration=np.round(o.t * 1e9).astype(np.int64).astype("timedelta64[ns]"))]
            style = rr.SeriesLines(names=[_case_name(results, row_of[o.index])], colors=[shown_colors[o.index]])
            for k, (entity, _) in enumerate(COMPONENTS):
                rec.log(f"/compare/{entity}/case_{o.index}", style, static=True)
                rec.send_columns(f"/compare/{entity}/case_{o.index}", index, rr.Scalars.columns(scalars=o.omega[:, k]))
            rec.log(f"/compare/energy_drift/case_{o.index}", style, static=True)
            with np.errstate(divide="ignore"):
                log_drift = np.log10(np.maximum(np.abs(o.energy_drift), LOG_FLOOR))
            rec.send_columns(f"/compare/energy_drift/case_{o.index}", index, rr.Scalars.columns(scalars=log_drift))
            sink.drain()  # a case at a time: a full disk is found at the case that meets it
        for param, views in scatters.items():
            for column, s in views.items():
                base = f"/results/{slug(param)}/{column}"
                rec.log(f"{base}/cases", rr.Points2D(s.points, colors=s.colors, radii=[0.018]), static=True)
                rec.log(f"{base}/axes", rr.LineStrips2D(s.axes, colors=[sc.AXIS_COLOR], radii=[0.003]), static=True)
                rec.log(f"{base}/ticks", rr.Points2D(s.tick_positions, labels=s.tick_labels, radii=[0.0],
                                                     colors=[AXIS_TRACE]), static=True)
        final = sink.close()
    except BaseException:
        sink.abort()
        raise
    assert final is not None
    return final


def _case_name(results: Results, row: int) -> str:
    params = [f"{p}={v:.3g}" for p in results.params if np.isfinite(v := float(results.column(p)[row]))]
    return f"case {int(results.column('case')[row])}: " + ", ".join(params)
