"""``rotlab plot``: figures for a report from run recordings (one, or several overlaid: methods,
tolerances, parameters side by side) — the panels the viewer's layout shows (their titles carry the units: ``layout.plots``), drawn with matplotlib on a light
background, one subplot each, over a chosen time span; and each Poincaré section
(``/sections/<name>``) as a scatter of its points with its formulas on the axes.

The recording is the only input: the panels are the time-series views of its blueprints (a
streamed run sends its first chunk's and its final layout: the union, one panel per entity), the
series their entities' scalars (``read_series``), the legends their
static names.  A series longer than ``MAX_POINTS`` is drawn as its min–max envelope per bucket
(the band a fast nutation sweeps stays visible; the file stays small).  Optional dependency:
``pip install 'rotlab[plots]'``.
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rotlab.errors import InputError, RunFailure
from rotlab.recording import layout, style, visuals
from rotlab.recording.reader import entity_paths, query_matches, read_series, read_static, read_text, view_queries

FORMATS = (".pdf", ".svg", ".png")
MAX_POINTS = 4000  # per series drawn: longer ones become their min-max envelope
XYZ = ("#d62728", "#2ca02c", "#1f77b4")  # x, y, z (p, q, r) in red, green, blue, as in the viewer
LINE_STYLES = ("-", "--", ":", "-.")  # overlaid runs, in the order given


@dataclass(frozen=True)
class Panel:
    key: str  # what --panels names it by
    title: str  # with its unit
    origin: str  # entity path
    section: bool = False  # a Poincaré section (x-y scatter), not a time series


def panels(recording: Path) -> list[Panel]:
    """The recording's panels, in reading order: the final layout's plots, then the events' and sections'."""
    found: dict[str, Panel] = {}
    for name, origin, _ in view_queries(recording).values():  # both layouts a streamed run sends (its first chunk's, its end's)
        if origin.startswith(layout.SECTIONS + "/"):
            found[origin] = Panel("section_" + origin.rsplit("/", 1)[1], name, origin, section=True)
        elif origin in layout.PLOT_ORDER or origin.startswith(layout.EVENTS + "/"):
            key = "event_" + origin.rsplit("/", 1)[1] if origin.startswith(layout.EVENTS + "/") else origin.rsplit("/", 1)[1]
            found[origin] = Panel(key, name, origin)

    def rank(panel: Panel) -> tuple[int, str]:
        order = layout.PLOT_ORDER
        return (order.index(panel.origin) if panel.origin in order else len(order) + panel.section, panel.origin)

    return sorted(found.values(), key=rank)


def plot(recordings: list[Path], output: Path, keys: list[str] | None = None, start: float | None = None, end: float | None = None,
         size: tuple[float, float] | None = None) -> tuple[Path, list[Panel]]:
    """Write the figure of ``keys`` (None: every panel) over [start, end] s to ``output``
    (.pdf, .svg or .png, by its name; ``size`` in inches); several recordings are overlaid
    (one line style each, named by file).  Returns the path and the panels drawn."""
    if output.suffix.lower() not in FORMATS:
        raise InputError("--output", f"'{output.name}': give a name ending in {', '.join(FORMATS)}")
    for recording in recordings:
        if not recording.is_file():
            raise InputError(str(recording), "no such recording")
    plt = pyplot("rotlab plot")
    from rotlab.recording.writer import check_output_path

    check_output_path(output, tuple(recordings))
    runs = [_Run.read(recording, len(recordings) > 1) for recording in recordings]
    for run in runs:
        if not run.first < run.last:
            raise InputError(str(run.path), f"it holds the sample at t = {run.first:g} s only: nothing to draw over time (a run stopped at its start)")
    span = _span(min(r.first for r in runs), max(r.last for r in runs), start, end)
    available: dict[str, Panel] = {}
    for run in runs:
        available.update({p.key: p for p in run.panels if p.key not in available})
    chosen = _chosen(list(available.values()), keys)
    columns = 1 if len(chosen) <= 3 else 2
    rows = math.ceil(len(chosen) / columns)
    figure = plt.figure(figsize=size or (7.5 * columns, 2.6 * rows + 0.6), layout="constrained")
    figure.suptitle(_title(recordings[0]) if len(runs) == 1 else "Comparison: " + ", ".join(r.label for r in runs))
    for k, panel in enumerate(chosen):
        ax = figure.add_subplot(rows, columns, k + 1)
        for style_index, run in enumerate(runs):
            if panel.key not in {p.key for p in run.panels}:
                continue
            if panel.section:
                _section(ax, run, panel, span)
            else:
                own = next(p for p in run.panels if p.key == panel.key)
                _series(ax, run, panel, span, LINE_STYLES[style_index % len(LINE_STYLES)], _unit_factor(panel, own, run))
        _finish(ax, panel, span, len(runs))
    tmp = output.with_name(f".{output.stem}.{os.getpid()}.tmp{output.suffix}")
    try:
        figure.savefig(tmp, format=output.suffix.lower()[1:], dpi=150)
        os.replace(tmp, output)
    except OSError as exc:
        raise RunFailure(f"could not write {output}: {exc.strerror or exc}") from None
    finally:
        plt.close(figure)
        tmp.unlink(missing_ok=True)
    return output, chosen


@dataclass(frozen=True)
class _Run:
    """One recording to draw: its panels, entities and span; ``label`` prefixes its series when overlaid."""

    path: Path
    label: str
    panels: list[Panel]
    entities: set[str]
    first: float
    last: float

    @classmethod
    def read(cls, path: Path, overlaid: bool) -> _Run:
        try:
            with warnings.catch_warnings():  # Rerun's reader warns about a damaged file before failing on it
                warnings.simplefilter("ignore")
                t, _ = read_series(path, layout.OMEGA)
                found = panels(path)
        except Exception:
            raise InputError(str(path), "not a complete rotlab run recording (no /body/omega series: another file, or cut short)") from None
        return cls(path, path.stem if overlaid else "", found, entity_paths(path), float(t[0]), float(t[-1]))

    def name(self, series: str) -> str:
        return f"{self.label}: {series}" if self.label else series


def pyplot(command: str):
    """matplotlib's pyplot on the Agg backend (files, no display), or a ``RunFailure`` naming
    ``command`` and the optional extra that brings it."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise RunFailure(f"`{command}` needs matplotlib: pip install 'rotlab[plots]'") from None
    return plt


def _span(first: float, last: float, start: float | None, end: float | None) -> tuple[float, float]:
    low, high = first if start is None else start, last if end is None else end
    for key, value in (("--from", start), ("--to", end)):
        if value is not None and not first <= value <= last:
            raise InputError(key, f"{value:g} s is outside the recording's span [{first:g}, {last:g}] s")
    if not low < high:
        raise InputError("--to", f"the span [{low:g}, {high:g}] s is empty: --to must be after --from")
    return low, high


def _chosen(available: list[Panel], keys: list[str] | None) -> list[Panel]:
    if not keys:
        return available
    by_key = {p.key: p for p in available}
    unknown = [k for k in keys if k not in by_key]
    if unknown:
        raise InputError("--panels", f"no panel '{unknown[0]}' in this recording: choose from {', '.join(by_key)}")
    return [by_key[k] for k in keys]


def _title(recording: Path) -> str:
    try:
        first = read_text(recording, layout.INFO).splitlines()[0]
    except (KeyError, IndexError):
        return recording.stem
    return first.lstrip("# ").strip() or recording.stem


def _unit_factor(panel: Panel, own: Panel, run: _Run) -> float:
    """What takes ``run``'s values of a panel (its title ``own``) to the figure's unit (``panel``'s
    title: the first recording's): the unit in the titles' last parentheses, equal or differing
    by an SI prefix of ``visuals.SUBMULTIPLES`` (the loads' plots choose theirs per run)."""
    unit, theirs = _unit(panel.title), _unit(own.title)
    if unit == theirs:
        return 1.0
    for factor, prefix in visuals.SUBMULTIPLES:
        for their_factor, their_prefix in visuals.SUBMULTIPLES:
            if unit.startswith(prefix) and theirs.startswith(their_prefix) and unit[len(prefix):] == theirs[len(their_prefix):]:
                return factor / their_factor
    raise InputError(str(run.path), f"its '{own.title}' is in {theirs}, the first recording's in {unit}: overlay runs whose plots share units")


def _unit(title: str) -> str:
    return title.rsplit("(", 1)[1].rstrip(")") if title.endswith(")") and "(" in title else ""


def _series(ax, run: _Run, panel: Panel, span: tuple[float, float], line_style: str, factor: float = 1.0) -> None:
    """Every scalar entity the panel's view shows, its series named as in the viewer, its values
    times ``factor`` (``_unit_factor``)."""
    points = panel.origin.startswith(layout.EVENTS + "/")
    vectors = visuals.series_colors(panel.origin, []) is style.XYZ  # x, y, z components: red, green, blue, as in the viewer
    drawn = 0  # the panel's series so far: the same colour for the same series of every run
    for entity in sorted(query_matches(["$origin/**"], panel.origin, run.entities)):
        try:
            t, values = read_series(run.path, entity)
        except KeyError:
            continue
        keep = (t >= span[0]) & (t <= span[1])
        t, values = t[keep], values[keep] * factor
        for j, name in enumerate(_names(run.path, entity, values.shape[1])):
            color = XYZ[j] if vectors else f"C{drawn % 10}"
            drawn += 1
            if points:  # an event's markers: the first series' label counts the occurrences drawn (within the span)
                label = run.name(f"{name} ({t.shape[0]:,} in the span)" if j == 0 else name)
                ax.plot(t, values[:, j], "o", ms=3, label=label, color=color, fillstyle="full" if line_style == "-" else "none")
            else:
                ax.plot(*envelope(t, values[:, j]), line_style, lw=0.8, label=run.name(name), color=color)


def _section(ax, run: _Run, panel: Panel, span: tuple[float, float]) -> None:
    """The section's points (record[0], record[1]) of the occurrences within the span."""
    name = panel.origin.rsplit("/", 1)[1]
    xy = np.asarray(read_static(run.path, panel.origin, "Points2D:positions"), dtype=float).reshape(-1, 2)
    t, _ = read_series(run.path, f"{layout.EVENTS}/{name}")
    keep = (t >= span[0]) & (t <= span[1]) if t.shape[0] == xy.shape[0] else np.ones(xy.shape[0], dtype=bool)
    formulas = _names(run.path, f"{layout.EVENTS}/{name}", 2)
    ax.plot(xy[keep, 0], xy[keep, 1], ".", ms=3, label=run.name(f"{int(keep.sum())} points"))
    ax.set_xlabel(formulas[0])
    ax.set_ylabel(formulas[1])


def _finish(ax, panel: Panel, span: tuple[float, float], runs: int) -> None:
    """Title, axes, grid and the legend of a panel drawn from every run."""
    if panel.section:
        ax.set_title(f"Poincaré section {panel.origin.rsplit('/', 1)[1]}", fontsize=10)
    else:  # (an event's view names its whole count: the span's is in the legend)
        ax.set_title(f"event {panel.origin.rsplit('/', 1)[1]}" if panel.origin.startswith(layout.EVENTS + "/") else panel.title, fontsize=10)
        ax.set_xlabel("t (s)")
        ax.set_xlim(*span)
    ax.grid(alpha=0.3)
    ax.ticklabel_format(axis="y", useOffset=False)  # a near-constant series (an invariant) shows its values, not an offset
    if len(ax.get_lines()) > 1 or panel.section or panel.origin.startswith(layout.EVENTS + "/"):
        ax.legend(fontsize=8, loc="best")


def _names(recording: Path, entity: str, count: int) -> list[str]:
    """The series names the viewer shows for ``entity`` (its static SeriesLines or SeriesPoints names)."""
    for component in ("SeriesLines:names", "SeriesPoints:names"):
        try:
            names = [str(n) for n in read_static(recording, entity, component)]
        except KeyError:
            continue
        if len(names) >= count:
            return names[:count]
    return [entity.rsplit("/", 1)[1] + (f"[{j}]" if count > 1 else "") for j in range(count)]


def envelope(t: np.ndarray, y: np.ndarray, limit: int = MAX_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """(t, y) itself, or when longer than ``limit`` its envelope: per bucket of consecutive
    samples, the minimum and the maximum in their time order (2 points a bucket, ≤ ``limit``)."""
    n = t.shape[0]
    if n <= limit:
        return t, y
    buckets = limit // 2
    edges = np.linspace(0, n, buckets + 1).astype(np.int64)
    where_low = np.array([a + int(np.argmin(y[a:b])) for a, b in zip(edges[:-1], edges[1:])])
    where_high = np.array([a + int(np.argmax(y[a:b])) for a, b in zip(edges[:-1], edges[1:])])
    first = where_low <= where_high
    index = np.column_stack([np.where(first, where_low, where_high), np.where(first, where_high, where_low)]).ravel()
    return t[index], y[index]
