"""Write a run to Rerun: columns sent in chunks (``send_columns``, never one ``log`` per
sample) through one ``RecordingSink`` (``rotlab.recording.sink``: checked writes, verified
file, atomic rename, live viewers).

``RecordingWriter`` takes a run chunk by chunk (``write``) as it is produced, so a streamed run
holds only the current chunk and what it collects.  Every ``send_columns`` is one chunk in the
file, and Rerun's file encoder keeps ~2 kB per chunk sent (the footer's manifest) until the file
ends, and builds the footer from it then: a run's chunk count sets its last memory peak (10⁸
samples in chunks of 16,384 rows: ~28,000 chunks, ~60 MB).  So each part is collected into
chunks of many rows before it is sent, and, while live viewers watch, sent at least every
``SEND_SECONDS`` (they keep up):

* the state and the invariants (``full_rate``), at every sample: ``full_rate_chunk_rows`` rows
  a chunk (their columns alone are collected: ~80 B a row);
* the derived and visual series (pose, arrows, axis tip, log drifts, |Λ| − 1, Euler angles, L in
  space), at every ``stride``-th sample: ``VISUAL_ROWS`` rows a chunk, fewer, since their
  conversion (labels, geometry) holds far more per row.

The static part is written twice: at the start (so that a live viewer has the body and the
layout at once) and at the end, from a thinned copy of the run (``Thinned``: at most
MAX_PATH_POINTS samples) for the paths and the run report.
"""

from __future__ import annotations

import json
import math
import os
import stat
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr

from rotlab import invariants
from rotlab.core.quaternion import rotate_to_space_array
from rotlab.errors import InputError, RunFailure
from rotlab.recording import labels, layout, portrait_view, visuals
from rotlab.recording.events_view import event_views, log_events
from rotlab.recording.geometry import MAX_PATH_POINTS, Geometry, scene_geometry
from rotlab.recording.report import run_report
from rotlab.recording.shapes import Ellipsoid, equivalent_ellipsoid
from rotlab.recording.sink import RecordingSink
from rotlab.events import EventLog
from rotlab.trajectory import RunSummary, Trajectory, concatenate

CHUNK_ROWS = 1 << 14  # full-rate rows per chunk (send_columns call): Rerun's fixed cost per call spread thin
LONG_CHUNK_ROWS = 1 << 16  # ... in a run of more than LONG_RUN samples (``full_rate_chunk_rows``)
LONG_RUN = 30_000_000  # samples
VISUAL_ROWS = 4096  # visual rows converted and sent together: their conversion (labels, geometry) holds far more per row than the state's
SEND_SECONDS = 0.5  # while live viewers watch, collected rows are sent at least this often (they keep up)
LOG_FLOOR = 1e-17  # log10 of a zero drift is drawn at −17 (below double precision)
FULL_RATE = (layout.QUATERNION, layout.OMEGA, layout.WORK, layout.ROTOR_MOMENTUM)  # every sample: the state, and the invariants' drifts (``full_rate``)


def check_output_path(path: Path, inputs: tuple[Path, ...] = ()) -> None:
    """Fail early (before a long run) when the output cannot be written: it must be (or become) a
    regular file that is not one of ``inputs``, with a name the file system takes, in a directory
    we can write in (a file is actually created and removed beside it: permission bits say
    little when running as root)."""
    where = f"output {path}" if _printable(path) else f"output {os.fsdecode(path)!r}"
    try:
        os.fsencode(path).decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(where, "the name is not valid UTF-8: choose a plain name with -o") from None
    parent = path.parent if str(path.parent) else Path(".")
    try:
        max_name = os.pathconf(parent, "PC_NAME_MAX") if parent.is_dir() else 255
    except (OSError, ValueError):
        max_name = 255
    if len(os.fsencode(path.name)) + 32 > max_name:  # the temporary file's name adds ".", the pid and a tag
        raise InputError(where, f"the name is too long for the file system ({len(os.fsencode(path.name))} bytes; "
                                f"at most {max_name - 32}): choose a shorter name with -o")
    try:
        existing = os.stat(path)
    except FileNotFoundError:
        existing = None
    except OSError as exc:
        raise InputError(where, f"cannot be used ({exc.strerror}): choose another path with -o") from None
    if existing is not None:
        if stat.S_ISDIR(existing.st_mode):
            raise InputError(where, f"is a directory: give a file name ending in {path.suffix or '.rrd'}")
        if not stat.S_ISREG(existing.st_mode):
            raise InputError(where, f"is not a regular file (a device, FIFO or socket): give a file name ending in {path.suffix or '.rrd'}")
        for source in inputs:
            if source.exists() and os.path.samefile(path, source):
                raise InputError(where, f"is the input {source}: give another name with -o")
    if not parent.is_dir():
        raise InputError(where, f"directory {parent} does not exist: create it or choose another path")
    probe = parent / f".{path.name}.{os.getpid()}.probe"
    try:
        probe.touch(exist_ok=False)
        probe.unlink()
    except OSError as exc:
        raise InputError(where, f"cannot write in {parent} ({exc.strerror}): choose another path with -o") from None


# Bytes per sample in the file (LZ4-compressed columns, measured by benchmarks/bench_stream.py):
# the full-rate series, and the visual series per sample they keep.
FULL_RATE_BYTES = 140.0
VISUAL_BYTES = 320.0
WRITE_RATE = 0.5e6  # samples per second, full layout (same source, on a loaded machine: the estimate errs long)


def estimated_bytes(samples: int, visual_samples: int) -> float:
    """The recording's size: every sample of the state and invariants, ≤ ``visual_samples`` of the rest."""
    return samples * FULL_RATE_BYTES + min(samples, visual_samples) * VISUAL_BYTES


def check_size(scenario, max_megabytes: float) -> None:
    """Refuse (before any work) a run whose recording would exceed ``max_megabytes``, saying
    how large and how long it would be and how to proceed."""
    n, visual = scenario.time.sample_count, scenario.output.visual_samples
    size = estimated_bytes(n, visual)
    if size > max_megabytes * 1e6:
        raise InputError(
            "output.max_megabytes",
            f"the recording would take about {size / 1e6:,.0f} MB ({n:,} samples; writing alone ≈ {n / WRITE_RATE:,.0f} s), "
            f"more than the limit of {max_megabytes:g} MB: to proceed pass --max-megabytes {math.ceil(size / 1e6 * 1.1)} "
            "(or set [output] max_megabytes), or lower time.sample_rate",
        )


def _printable(path: Path) -> bool:
    return str(path).isprintable()


def full_rate_chunk_rows(samples: int) -> int:
    """Full-rate rows per chunk in a run of ``samples``.  Fewer, larger chunks leave Rerun less
    to keep per chunk (the footer's manifest), but a larger chunk in flight holds more at once:
    16,384-row chunks peak lower up to ~2·10⁷ samples (283 against 292 MB), 65,536-row chunks at
    10⁸ (298 against 314 MB; docs/benchmarks.md, "Streaming")."""
    return LONG_CHUNK_ROWS if samples > LONG_RUN else CHUNK_ROWS


def partial_path(path: Path) -> Path:
    """Where the valid part of an incomplete run goes: ``name.partial.rrd`` beside ``path``."""
    return path.with_name(f"{path.stem}.partial{path.suffix or '.rrd'}")


def write_recording(traj: Trajectory, path: str | Path, chunk_rows: int | None = None) -> Path:
    """Write a whole ``traj`` to ``path`` atomically (every series at every sample); returns the path."""
    path = Path(path)
    check_output_path(path)
    sink = RecordingSink(path)
    try:
        writer = RecordingWriter(sink, stride=1, chunk_rows=chunk_rows)
        writer.write(traj, 0)
        writer.finish(traj.summary(), traj)
        final = sink.close()
    except (OSError, RuntimeError) as exc:  # Rerun's encoder or the file system
        sink.abort()
        raise RunFailure(f"could not write the recording {path}: {exc}") from None
    except BaseException:
        sink.abort()
        raise
    assert final is not None
    return final


class RecordingWriter:
    """Writes consecutive chunks of one run (``Trajectory`` objects of successive samples)."""

    def __init__(self, sink: RecordingSink, stride: int = 1, chunk_rows: int | None = None) -> None:
        chunk_rows = CHUNK_ROWS if chunk_rows is None else chunk_rows
        self.sink, self.rec, self.stride, self.chunk_rows = sink, sink.rec, max(1, int(stride)), chunk_rows
        self.scales: Scales | None = None  # fixed by the first chunk
        self.energy: tuple[float, float] | None = None
        self.full = FullRateRows(chunk_rows)  # full-rate samples not sent yet
        self.visual: list[Trajectory] = []  # visual samples not sent yet
        self.visual_rows = 0
        self.visual_chunk_rows = min(chunk_rows, VISUAL_ROWS)
        self.send_seconds = SEND_SECONDS if sink.watched else math.inf  # a file alone: whole chunks only
        self.sent_at = time.monotonic()

    def _start(self, first: Trajectory) -> None:
        """Blueprint and static styling from the first chunk (a live viewer shows them at once)."""
        views = _views(first)
        self.scales = (views.omega_scale, views.L_scale, views.load_scales, views.load_units)
        self.sink.open(run_blueprint(first, views))
        _write_static(self.rec, first, views, first.summary())

    def write(self, chunk: Trajectory, start: int) -> None:
        """Send the samples ``start, start + 1, …`` of ``chunk``; raises ``RunFailure`` if the file
        could not take the previous ones."""
        self.sink.check()
        if not chunk.t.shape[0]:
            return
        with np.errstate(over="ignore", invalid="ignore"):  # display-only float32 casts of a run that blew up
            if self.scales is None:
                self._start(chunk)
            self._collect_full_rate(chunk)
            picked = np.arange((-start) % self.stride, chunk.t.shape[0], self.stride)
            if picked.size:
                self.visual.append(chunk if self.stride == 1 else chunk.take(picked))
                self.visual_rows += picked.size
            if time.monotonic() - self.sent_at >= self.send_seconds:  # live viewers: all that is collected goes out
                self.send_full_rate()
                self._send_visual()
                self.sent_at = time.monotonic()
            elif self.visual_rows >= self.visual_chunk_rows:
                self._send_visual()
        self.sink.drain()

    def _collect_full_rate(self, chunk: Trajectory) -> None:
        """Add ``chunk``'s full-rate samples; whole full-rate chunks go out as they fill (rows that
        make a whole chunk by themselves go out without being copied)."""
        series, n, taken = full_rate_series(chunk), chunk.t.shape[0], 0
        while taken < n:
            whole = not self.full.count and n - taken >= self.chunk_rows
            rows = slice(taken, taken + self.chunk_rows if whole else n)
            part = {entity: values[rows] for entity, values in series.items()}
            if whole:
                self._send(chunk.t[rows], part)
                taken += self.chunk_rows
            else:
                taken += self.full.add(chunk.t[rows], part)
                if self.full.is_full:
                    self.send_full_rate()

    def send_full_rate(self) -> None:
        """Send the collected full-rate samples."""
        if self.full.count:
            self._send(*self.full.taken())

    def _send(self, t: np.ndarray, series: dict[str, np.ndarray]) -> None:
        """One chunk per entity; long chunks (``LONG_CHUNK_ROWS``) each encoded before the next is
        sent (``drain``: Rerun holds one at a time; for the short ones that wait costs more time
        than it saves memory)."""
        _write_full_rate(self.rec, t, series, drain=self.sink.drain if self.chunk_rows > CHUNK_ROWS else None)

    def _send_visual(self) -> None:
        """Send the collected visual samples (one chunk per entity per ``VISUAL_ROWS``)."""
        if self.visual:
            thin = concatenate(self.visual)
            _write_visual(self.rec, thin, _views(thin, self.scales), self.visual_chunk_rows)
        self.visual, self.visual_rows = [], 0

    def finish(self, summary: RunSummary, thinned: Trajectory | None) -> None:
        """The samples still collected, then the static part again, from the whole run: paths,
        Poinsot construction, run report."""
        self.sink.check()
        with np.errstate(over="ignore", invalid="ignore"):
            self.send_full_rate()
            self._send_visual()
        if thinned is None or not thinned.t.shape[0]:
            return
        with np.errstate(over="ignore", invalid="ignore"):
            if self.scales is None:
                self._start(thinned)
            views = _views(thinned, self.scales)
            self.sink.update_blueprint(run_blueprint(thinned, views, summary.events))  # plot ranges from the whole run
            _write_static(self.rec, thinned, views, summary)
            log_events(self.rec, summary.events, views.geometry.axis_body, visuals.AXES_LENGTH * views.shape.size)  # on the axis trace


class Thinned:
    """At most MAX_PATH_POINTS samples of a run (t and principal-frame state), every k-th with
    k doubling as the run grows: the static paths of a run of any length.  The end of a run
    computes every series of the layout for these samples at once (``finish``), so their number
    sets the run's last memory peak: hence the cap of MAX_PATH_POINTS."""

    def __init__(self, limit: int = MAX_PATH_POINTS) -> None:
        self.limit, self.every = limit, 1
        self.t: list[np.ndarray] = []
        self.state: list[np.ndarray] = []
        self.count = 0

    def add(self, start: int, t: np.ndarray, state: np.ndarray) -> None:
        first = (-start) % self.every
        self.t.append(t[first :: self.every].copy())
        self.state.append(state[first :: self.every].copy())
        self.count += self.t[-1].shape[0]
        if self.count > self.limit:
            t_all, s_all = self.arrays()
            self.t, self.state = [t_all[::2]], [s_all[::2]]  # the kept samples are multiples of 2·every
            self.count, self.every = self.t[0].shape[0], 2 * self.every

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.t:
            return np.zeros(0), np.zeros((0, 8))
        return np.concatenate(self.t), np.concatenate(self.state)


def run_blueprint(traj: Trajectory, views: _Views, events: dict[str, EventLog] | None = None):
    """The layout for this run: its plots (``layout.plots``), the trails' window and the views of
    its ``events``."""
    all_series = views.series
    energy = all_series[layout.ENERGY][0]
    finite = np.abs(energy[np.isfinite(energy)])
    min_energy_span = 0.02 * float(finite.max()) if finite.size else 0.0  # a constant energy is drawn flat
    own = np.abs(traj.omega @ traj.inertia)  # |I ω| (user's frame): a total L of zero (a slew by wheels from rest) is drawn flat
    min_momentum_span = 0.02 * float(np.max(own[np.isfinite(own)], initial=0.0))
    unit = "deg" if visuals.degrees_wanted(traj.scene) else "rad"
    window = visuals.trail_window(traj.t, traj.omega) if len(traj.t) else None
    recent = visuals.recent_window(traj.t, traj.omega) if len(traj.t) else None
    prefixes = {name: prefix for name, (_, prefix) in views.load_units.items()}
    groups = layout.plots(all_series, unit, min_energy_span, min_momentum_span, prefixes)
    active = layout.ENERGY_TAB if traj.scene.has_work else layout.MOTION  # loads at work: show them first
    if events and any(len(log.record) >= 2 for log in events.values()):  # a Poincaré section: the reason for the run
        active = layout.EVENTS_TAB
    time_ = traj.scene.scenario.time  # the whole span the run is asked for, known from its first chunk on
    span = (time_.start, time_.end)
    return layout.blueprint(groups, window, active, labels.camera(visuals.reach(traj, views)), span=span,
                            events=event_views(events, span) if events else None, portrait=portrait_view.has_polhodes(traj.scene),
                            recent=recent)


def series(traj: Trajectory, load_units: dict[str, tuple[float, str]] | None = None) -> dict[str, tuple[np.ndarray, list[str]]]:
    """Every time series of the layout: entity → ((N, k) float64 values, k series names), the
    loads' in ``load_units`` (``visuals.load_units``).  Names are short symbols (the plot titles
    carry units and frames)."""
    q = traj.quaternion
    out: dict[str, tuple[np.ndarray, list[str]]] = {
        layout.QUATERNION: (q, ["q0", "q1", "q2", "q3"]),
        layout.OMEGA: (traj.omega, ["p", "q", "r"]),
        layout.L_SPACE: (traj.L_space, ["L_X", "L_Y", "L_Z"]),
    }
    energy, names = [traj.kinetic], ["T"]
    if traj.potential is not None:
        energy += [traj.potential, traj.total]
        names += ["V", "T+V"]
    if traj.work is not None:
        energy += [traj.work, traj.total - traj.work]
        names += ["W", "H"]
    out[layout.ENERGY] = (np.column_stack(energy), [ENERGY_LABELS[n] for n in names])
    for name, drift in traj.invariants.items():
        out[f"{layout.INVARIANTS}/{name}"] = (drift[:, None], [INVARIANT_LABELS.get(name, name)])
        with np.errstate(divide="ignore"):
            magnitude = np.log10(np.maximum(np.abs(drift), LOG_FLOOR))
        out[f"{layout.INVARIANTS_LOG}/{name}"] = (magnitude[:, None], [INVARIANT_LABELS.get(name, name)])
    if traj.euler_angles is not None:
        out[layout.EULER_ANGLES] = (traj.euler_angles, ["ψ", "θ", "φ"])
    out.update(visuals.euler_series(traj))
    out.update(portrait_view.top_series(traj, visuals.degrees_wanted(traj.scene)))
    out.update(visuals.load_series(traj, units=load_units))
    out.update(visuals.rotor_series(traj))
    return out


ENERGY_LABELS = {"T": "T", "V": "V", "T+V": "T+V", "W": "W", "H": "T+V−W"}
INVARIANT_LABELS = invariants.LABELS  # one table of invariants (``rotlab.invariants``)


@dataclass(frozen=True)
class _Views:
    """What the static and temporal parts share: computed once per recording."""

    shape: Ellipsoid
    unit_q: np.ndarray  # (N, 4) normalised, for display
    omega_space: np.ndarray  # (N, 3)
    omega_scale: float  # arrow length per rad/s
    L_scale: float  # arrow length per kg·m²/s
    omega_arrow: np.ndarray  # (N, 3) the ω and L arrows as drawn (``visuals.drawn``), space frame
    L_arrow: np.ndarray
    geometry: Geometry
    series: dict[str, tuple[np.ndarray, list[str]]]  # every time series: see ``series``
    load_scales: dict[str, float]  # arrow length per N and per N·m
    load_units: dict[str, tuple[float, str]]  # the load plots' (factor, prefix): torque, power


Scales = tuple[float, float, dict[str, float], dict[str, tuple[float, str]]]  # ω, L, load arrow lengths per unit; the load plots' units


def _views(traj: Trajectory, scales: Scales | None = None) -> _Views:
    """Display quantities of ``traj``; ``scales`` (arrows: ω, L, loads; the load plots' units
    ``visuals.load_units``) as given, else from ``traj``."""
    shape = equivalent_ellipsoid(traj.scene.scenario.body)
    unit_q = traj.quaternion / np.linalg.norm(traj.quaternion, axis=1, keepdims=True)
    omega_space = rotate_to_space_array(unit_q, traj.omega)
    omega_scale, L_scale, load_scales, load_units = scales or (_arrow_scale(omega_space, visuals.OMEGA_LENGTH * shape.size),
                                                               _arrow_scale(traj.L_space, visuals.L_LENGTH * shape.size),
                                                               visuals.load_scales(traj, shape.size),
                                                               visuals.load_units(traj))
    geometry = scene_geometry(traj, unit_q, omega_space, omega_scale, reach=visuals.AXES_LENGTH * shape.size)
    arrows = (visuals.drawn(omega_space, omega_scale, visuals.OMEGA_LENGTH * shape.size),
              visuals.drawn(traj.L_space, L_scale, visuals.L_LENGTH * shape.size))
    return _Views(shape, unit_q, omega_space, omega_scale, L_scale, *arrows, geometry, series(traj, load_units), load_scales, load_units)


def _write_static(rec: rr.RecordingStream, traj: Trajectory, views: _Views, summary: RunSummary) -> None:
    visuals.log_static(rec, traj, views)
    portrait_view.log_polhodes(rec, traj)
    scales = {"ω": (views.omega_scale, "m per rad/s"), "L": (views.L_scale, "m per kg·m²/s"),
              "F": (views.load_scales["force"], "m per N"), "M": (views.load_scales["torque"], "m per N·m")}
    rec.log(layout.INFO, rr.TextDocument(run_report(summary, scales), media_type="text/markdown"), static=True)
    scenario = {"scenario": traj.scene.scenario.model_dump(mode="json", exclude_unset=True), "python_torque": traj.scene.loads.user is not None}
    rec.log(layout.SCENARIO, rr.TextDocument(json.dumps(scenario), media_type="text/plain"), static=True)


def full_rate(entity: str) -> bool:
    """Is ``entity`` written at every sample: the state and the invariants' drifts (not the
    drifts in ``invariants.THINNED``)?"""
    if entity in FULL_RATE:
        return True
    parent, _, name = entity.rpartition("/")
    return parent == layout.INVARIANTS and name not in invariants.THINNED


def full_rate_series(traj: Trajectory) -> dict[str, np.ndarray]:
    """The ``full_rate`` series of ``traj`` (state and drifts): entity → (N, k) values."""
    full = {layout.QUATERNION: traj.quaternion, layout.OMEGA: traj.omega}
    if traj.work is not None:
        full[layout.WORK] = traj.work[:, None]
    if traj.rotor_momenta is not None:
        full[layout.ROTOR_MOMENTUM] = traj.rotor_momenta
    full.update({entity: drift[:, None] for name, drift in traj.invariants.items() if full_rate(entity := f"{layout.INVARIANTS}/{name}")})
    return full


class FullRateRows:
    """Up to ``rows`` samples of the ``full_rate`` series, copied into columns allocated once per
    chunk (no per-flush copies held, nothing concatenated).  The columns handed out (``taken``)
    belong to the caller from then on: they are never written again, whatever holds them (Rerun
    0.41's ``Scalars.columns`` and ``TimeColumn`` copy what they are given, measured; nothing in
    its API promises it)."""

    def __init__(self, rows: int) -> None:
        self.rows, self.count = rows, 0
        self.t: np.ndarray | None = None
        self.values: dict[str, np.ndarray] = {}

    @property
    def is_full(self) -> bool:
        return self.count == self.rows

    def add(self, t: np.ndarray, series: dict[str, np.ndarray]) -> int:
        """Copy the first rows of ``t`` and ``series`` that fit; returns how many."""
        if self.t is None:
            self.t = np.empty(self.rows)
            self.values = {entity: np.empty((self.rows, values.shape[1])) for entity, values in series.items()}
        n = min(t.shape[0], self.rows - self.count)
        rows = slice(self.count, self.count + n)
        self.t[rows] = t[:n]
        for entity, values in series.items():
            self.values[entity][rows] = values[:n]
        self.count += n
        return n

    def taken(self) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """The collected samples; the next ``add`` starts new columns."""
        assert self.t is not None
        n, t, values = self.count, self.t, self.values
        self.count, self.t, self.values = 0, None, {}
        return t[:n], {entity: column[:n] for entity, column in values.items()}


def _write_full_rate(rec: rr.RecordingStream, t: np.ndarray, full: dict[str, np.ndarray], drain=None) -> None:
    """The ``full_rate`` series ``full`` (``full_rate_series``) at the times ``t``: one chunk per
    entity, ``drain()`` after each when given."""
    index = [rr.TimeColumn(layout.TIMELINE, duration=_nanoseconds(t))]
    for entity, values in full.items():
        rec.send_columns(entity, index, rr.Scalars.columns(scalars=values))
        if drain is not None:
            drain()


def _write_visual(rec: rr.RecordingStream, traj: Trajectory, views: _Views, chunk_rows: int) -> None:
    """The derived and visual series (everything not ``full_rate``) at the samples of ``traj``."""
    ns = _nanoseconds(traj.t)
    vectors = {
        layout.OMEGA_ARROW: views.omega_arrow,
        layout.L_ARROW: views.L_arrow,
    }
    thin = {entity: values for entity, (values, _) in views.series.items() if not full_rate(entity)}
    for rows in _slices(traj.t.shape[0], chunk_rows):
        index = [rr.TimeColumn(layout.TIMELINE, duration=ns[rows])]
        rec.send_columns(layout.BODY, index, rr.Transform3D.columns(quaternion=visuals.xyzw(views.unit_q[rows])))
        rec.send_columns(layout.AXIS_TIP, index, rr.Points3D.columns(positions=views.geometry.axis_tips[rows]))
        portrait_view.send_now(rec, traj, index, rows)
        for entity, values in vectors.items():
            rec.send_columns(entity, index, rr.Arrows3D.columns(vectors=values[rows]))
        for entity, values in thin.items():
            rec.send_columns(entity, index, rr.Scalars.columns(scalars=values[rows]))
        visuals.send_chunk(rec, traj, views, rows, ns)


def _nanoseconds(t: np.ndarray) -> np.ndarray:
    """Timeline values: round to the nanosecond (Rerun's float conversion truncates)."""
    return np.round(t * 1e9).astype(np.int64).astype("timedelta64[ns]")


def _slices(n: int, size: int) -> list[slice]:
    return [slice(start, min(start + size, n)) for start in range(0, n, size)]


def _arrow_scale(vectors: np.ndarray, length: float) -> float:
    """Factor that makes the longest finite arrow ``length`` long."""
    with np.errstate(over="ignore"):
        lengths = np.linalg.norm(vectors, axis=1)
    finite = lengths[np.isfinite(lengths)]
    longest = float(finite.max()) if finite.size else 0.0
    return length / longest if longest > 0.0 else 1.0

