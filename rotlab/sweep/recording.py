"""The recording that compares a sweep's cases (Rerun writing lives under ``rotlab.recording``).

Entities
    /compare/omega_x|omega_y|omega_z/case_<k>   ω body components of case k (rad/s)
    /compare/energy_drift/case_<k>               log10 |relative drift of T + V − W|
    /results/<parameter>/<observable>            scatter: observable of each case against the
                                                 swept parameter (see ``rotlab.recording.scatter``)
    /sweep                                       the results table (Markdown)
Case k has the same colour everywhere (``style.ramp`` in the order of the first swept
parameter), so a line in a time plot and a point in a scatter plot are recognisably one case.
Every view's origin is an entity subtree that exists (tested: tests/test_visuals.py).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from rotlab.recording import scatter as sc
from rotlab.recording.layout import TIMELINE
from rotlab.recording.style import AXIS_TRACE, ramp
from rotlab.sweep.report import Table
from rotlab.sweep.runner import CaseOutcome

MAX_COMPARED = 50
LOG_FLOOR = 1e-17  # below double precision: drawn as −17
COMPONENTS = (("omega_x", "p = ω_x"), ("omega_y", "q = ω_y"), ("omega_z", "r = ω_z"))
OBSERVABLES = {  # table column → (plot title, transform of the value)
    "flip_period_s": ("flip period (s)", None),
    "max_nutation_deg": ("max nutation (deg)", None),
    "max_drift_energy": ("log10 max energy drift", "log10"),
    "seconds": ("wall time per case (s)", None),
}


def parameter_columns(results: Table) -> list[str]:
    """The swept parameter columns of the results table that vary and are numbers."""
    header, table = results
    first = header.index("status")
    out = []
    for k in range(1, first):
        values = [r[k] for r in table if isinstance(r[k], (int, float))]
        if len(set(values)) > 1:
            out.append(header[k])
    return out


def case_colors(results: Table) -> dict[int, tuple[int, int, int]]:
    """Case index → colour, ordered by the first varying parameter (then by case number)."""
    header, table = results
    params = parameter_columns(results)
    column = header.index(params[0]) if params else 0
    order = sorted(range(len(table)), key=lambda i: (_value(table[i][column]), table[i][0]))
    colors = ramp(len(order))
    return {int(table[i][0]): colors[rank] for rank, i in enumerate(order)}


def _value(cell: object) -> float:
    return float(cell) if isinstance(cell, (int, float)) else math.nan


def slug(name: str) -> str:
    """An entity-path part from a column name: 'initial.omega[0]' → 'initial_omega_0'."""
    return re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", name)).strip("_")


def plots(results: Table, colors: dict[int, tuple[int, int, int]]) -> dict[str, dict[str, sc.Scatter]]:
    """parameter → observable → scatter (observables undefined in every case are left out), in
    the cases' ``colors`` (``case_colors``)."""
    header, table = results
    point_colors = [colors[int(r[0])] for r in table]
    out: dict[str, dict[str, sc.Scatter]] = {}
    for param in parameter_columns(results):
        at = header.index(param)
        x = np.array([_value(r[at]) for r in table])
        views = {}
        for column, (_, transform) in OBSERVABLES.items():
            if column not in header:
                continue
            at = header.index(column)
            y = np.array([_value(r[at]) for r in table])
            if transform == "log10":
                with np.errstate(divide="ignore", invalid="ignore"):
                    y = np.log10(np.abs(y))
                y[~np.isfinite(y)] = np.nan
            drawn = sc.scatter(x, y, point_colors)
            if drawn is not None:
                views[column] = drawn
        out[param] = views
    return out


def blueprint(results: Table, shown: list[CaseOutcome], scatters: dict[str, dict[str, sc.Scatter]]):
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
    for param, views in scatters.items():
        if not views:
            continue
        result_tabs.append(rrb.Grid(
            *[rrb.Spatial2DView(origin=f"/results/{slug(param)}/{column}", name=f"{OBSERVABLES[column][0]} vs {param}",
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


def write_comparison(outcomes: list[CaseOutcome], results: Table, path: Path, title: str) -> Path:
    """One recording comparing up to ``MAX_COMPARED`` cases; ``results``: their results table
    (``rotlab.sweep.report.rows``).  Written as a run's recording is (``RecordingSink``: every
    write checked, the file verified, then renamed): a full disk is ``RunFailure``, with no
    temporary file left and an existing file untouched."""
    import rerun as rr

    from rotlab.recording.sink import RecordingSink
    from rotlab.recording.writer import check_output_path

    check_output_path(path)
    shown = [o for o in outcomes if o.t is not None][:MAX_COMPARED]
    header, table = results
    colors = case_colors(results)
    scatters = plots(results, colors)
    sink = RecordingSink(path, application_id="rotlab-sweep")
    try:
        sink.open(blueprint(results, shown, scatters))
        rec = sink.rec
        md = [f"# {title or 'sweep'}", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        md += ["| " + " | ".join(f"{v:.4g}" if isinstance(v, float) else str(v) for v in r) + " |" for r in table]
        rec.log("/sweep", rr.TextDocument("\n".join(md), media_type="text/markdown"), static=True)
        names = {int(r[0]): _case_name(header, r) for r in table}
        for o in shown:
            index = [rr.TimeColumn(TIMELINE, duration=np.round(o.t * 1e9).astype(np.int64).astype("timedelta64[ns]"))]
            style = rr.SeriesLines(names=[names[o.index]], colors=[colors[o.index]])
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


def _case_name(header: list[str], row: list[object]) -> str:
    params = [f"{h}={v:.3g}" if isinstance(v, float) else f"{h}={v}" for h, v in zip(header[1:header.index("status")], row[1:])]
    return f"case {row[0]}: " + ", ".join(params)
