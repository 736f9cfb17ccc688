"""Entity paths and the default blueprint: the recording's stable contract (SPEC).

Timeline ``sim_time`` (duration).  Vectors name their frame in the path or the series names.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import rerun.blueprint as rrb

TIMELINE = "sim_time"

BODY = "/world/body"  # Transform3D: Λ (body → space); shape and body axes below it
BODY_SHAPE = "/world/body/shape"
BODY_AXES = "/world/body/axes"
BODY_ARM = "/world/body/arm"  # fixed point → centre of mass
ROTOR_MOMENTUM = "/rotors/momentum"  # J Ω of each driven rotor, N·m·s, every sample (the state's last columns)
ROTOR_TORQUE = "/rotors/torque"  # u, each driven rotor's drive torque, N·m
ROTOR_SPEED = "/rotors/speed"  # Ω of each driven rotor whose inertia is given, relative to the body, rpm
ROTORS = "/world/body/rotors"  # a gyrostat's wheels (static, body frame): /rotors/wheels (discs on their axes), /rotors/shafts
BODY_POLHODE = "/world/body/polhode"  # torque-free: tip of scaled ω in the body frame
AXIS_PATH = "/world/axis_path"  # static: path of the reference-axis tip (symmetry axis, else the spin axis)
AXIS_TIP = "/world/axis_tip"  # the tip at each sample (drawn over the trailing window: the recent trace)
FIELD = "/world/gravity"  # direction of the uniform field
HERPOLHODE = "/world/herpolhode"  # torque-free: tip of scaled ω in space
INVARIABLE_PLANE = "/world/invariable_plane"  # torque-free: plane ⊥ L carrying the herpolhode
OMEGA_ARROW = "/world/omega"  # space frame, scaled
L_ARROW = "/world/L"  # space frame, scaled
QUATERNION = "/body/quaternion"  # [q0, q1, q2, q3], float64
OMEGA = "/body/omega"  # body frame, rad/s
L_SPACE = "/world/L_space"  # space frame, kg·m²/s
ENERGY = "/energy"  # J
INVARIANTS = "/invariants"  # /invariants/<name>: relative drift
INVARIANTS_LOG = "/invariants_log10"  # /invariants_log10/<name>: log10 |relative drift| (plotted)
EULER_ANGLES = "/euler_angles"  # (ψ, θ, φ) rad
INFO = "/info"  # TextDocument: scenario, method, run statistics
SCENARIO = "/scenario"  # static TextDocument: the validated scenario as JSON, {"scenario": …, "python_torque": bool} (`rotlab export`)
WORK = "/body/work"  # J, W = ∫ M_nc·ω dt of the non-conservative loads, every sample (where loads do work): the state's last column
# extensions (#13): readable Euler angles, trails, Poinsot's energy ellipsoid, loads
EULER_THETA = "/euler/theta"  # θ nutation (deg where the scenario uses degrees, else rad)
EULER_PSI = "/euler/psi"  # ψ precession wrapped to one turn
EULER_SPIN_RATE = "/euler/spin_rate"  # dφ/dt (deg/s where the scenario uses degrees, else rad/s)
LABELS_3D = "/world/labels"  # every 3D label (ω, L, g, loads, x, y, z) just beyond its arrow's tip, space frame;
#                              a label that would overlap another in the default view is NaN (not drawn)
HERPOLHODE_TRAIL = "/world/herpolhode_trail"  # torque-free: the same for the herpolhode
POLHODE_TRAIL = "/world/body/polhode_trail"  # torque-free: the same for the polhode (body frame)
ENERGY_ELLIPSOID = "/world/body/energy_ellipsoid"  # torque-free: x·Ix = s²·2T, fixed in the body
LOADS_3D = "/world/loads"  # /world/loads/<symbol>: one arrow per load at its point (space frame)
LOAD_TORQUE_BODY = "/loads/torque_body"  # [M1, M2, M3] of the non-conservative loads, body frame
LOAD_TORQUE_SPACE = "/loads/torque_space"  # the same, space frame
LOAD_POWER = "/loads/power"  # P = M·ω of the non-conservative loads, W
EVENTS = "/events"  # /events/<name>: at each occurrence, the ``record`` values (else the occurrence number), markers
EVENTS_3D = "/world/events"  # /world/events/<name>: the reference-axis tip at each occurrence (static, space frame)
SECTIONS = "/sections"  # /sections/<name>: Poincaré section, (record[0], record[1]) of every occurrence (static)
PORTRAIT = "/phase"  # torque-free: the phase portrait, L in the body frame (user's axes), kg·m²/s
PORTRAIT_POLHODES = "/phase/polhodes"  # static: polhodes of several energies on the sphere |L| = L₀
PORTRAIT_SEPARATRICES = "/phase/separatrices"  # static: through the intermediate axis
PORTRAIT_EQUILIBRIA = "/phase/equilibria"  # static: ±L₀ along each principal axis, labelled min / mid / max moment
PORTRAIT_PATH = "/phase/path"  # static: the run's L (body frame)
PORTRAIT_NOW = "/phase/now"  # L at each visual sample
TOP_POTENTIAL = "/top/potential"  # Lagrange top: [U(θ(t)), E′] J, the effective potential along the motion and its level
EULER_THETA_TURNING = "/euler/theta/turning"  # Lagrange top: the turning points [θ₁, θ₂] from the cubic, drawn on the θ plot
TRAILS = (AXIS_TIP, HERPOLHODE_TRAIL, POLHODE_TRAIL)  # drawn over the trailing window
PLOT_ORDER = (OMEGA, L_SPACE, EULER_THETA, EULER_PSI, EULER_SPIN_RATE, TOP_POTENTIAL, ENERGY, INVARIANTS_LOG, ROTOR_SPEED,
              ROTOR_MOMENTUM, ROTOR_TORQUE, LOAD_TORQUE_BODY, LOAD_TORQUE_SPACE, LOAD_POWER)  # the plots' reading order: the layout's grid, `rotlab plot`'s figure

LEGEND_HEADROOM = 0.45  # a plot with a legend of up to 3 lines gets this fraction of its data span above the data
LEGEND_LINE_HEADROOM = 0.22  # ... and this much more for each further line (general.toml's 5 energies covered T+V−W)


def plot_range(values: np.ndarray, legend_lines: int, min_span: float = 0.0) -> tuple[float, float] | None:
    """A y range for a plot: the data (widened to ``min_span``), plus room above it for a legend
    of ``legend_lines`` lines (0: none) in the top corner, so that the legend never covers a line."""
    finite = values[np.isfinite(values)]
    if not finite.size:
        return None
    low, high = float(finite.min()), float(finite.max())
    span = max(high - low, min_span, 1e-300)
    if high - low < span:
        middle = 0.5 * (low + high)
        low, high = middle - 0.5 * span, middle + 0.5 * span
    headroom = LEGEND_HEADROOM + LEGEND_LINE_HEADROOM * max(0, legend_lines - 3) if legend_lines else 0.05
    return low - 0.05 * span, high + headroom * span


@dataclass(frozen=True)
class Plot:
    """One time-series view: its title, its entities and whether it needs a legend."""

    name: str
    origin: str
    legend: bool
    y_range: tuple[float, float] | None = None
    contents: tuple[str, ...] = ()


MOTION, ENERGY_TAB, EVENTS_TAB, RECENT_TAB = "Motion", "Energy and loads", "Events", "Motion, recent"
MAX_PLOTS_ONE_TAB = 6  # up to a 2 × 3 grid in one tab; more: motion and energy in two tabs


def plots(series: dict[str, tuple[np.ndarray, list[str]]], angle_unit: str, min_energy_span: float,
          min_momentum_span: float = 0.0, load_prefixes: dict[str, str] | None = None) -> dict[str, list[Plot]]:
    """The plots of a run by tab (``MOTION``, ``ENERGY_TAB``), in reading order; only those
    whose entities exist in ``series``.  A constant energy, or L, is drawn flat in a range of at
    least ``min_energy_span`` (J), ``min_momentum_span`` (kg·m²/s), not as its rounding magnified.
    ``load_prefixes``: the SI prefix of the loads' torque and power plots ("torque", "power"; the
    series are in those units)."""
    torque, power = ((load_prefixes or {}).get(k, "") for k in ("torque", "power"))
    def rng(entity: str, legend: bool, min_span: float = 0.0):
        return plot_range(series[entity][0], len(series[entity][1]) if legend else 0, min_span) if entity in series else None

    motion = [
        Plot("ω body (rad/s)", OMEGA, True, rng(OMEGA, True)),
        Plot("L space (kg·m²/s)", L_SPACE, True, rng(L_SPACE, True, min_momentum_span)),
    ]
    if EULER_THETA in series:
        motion += [Plot(f"θ nutation ({angle_unit})", EULER_THETA, False, rng(EULER_THETA, False)),
                   Plot(f"ψ precession, one turn ({angle_unit})", EULER_PSI, False, rng(EULER_PSI, False)),
                   Plot(f"dφ/dt spin rate ({angle_unit}/s)", EULER_SPIN_RATE, False, rng(EULER_SPIN_RATE, False))]
    if TOP_POTENTIAL in series:
        motion.append(Plot("Effective potential along the motion (J)", TOP_POTENTIAL, True, rng(TOP_POTENTIAL, True)))
    out: list[Plot] = []
    energy_names = series[ENERGY][1]
    out.append(Plot("Energy (J)", ENERGY, len(energy_names) > 1,
                    rng(ENERGY, len(energy_names) > 1, min_energy_span)))
    logs = tuple(e for e in series if e.startswith(INVARIANTS_LOG + "/"))
    if logs:
        values = np.column_stack([series[e][0][:, 0] for e in logs])
        out.append(Plot("Invariant drift, log10 |relative|", INVARIANTS_LOG, True, plot_range(values, len(logs))))
    if ROTOR_SPEED in series:
        out.append(Plot("Driven rotors' speed Ω (rpm)", ROTOR_SPEED, True, rng(ROTOR_SPEED, True)))
    if ROTOR_MOMENTUM in series and (ROTOR_SPEED not in series or len(series[ROTOR_SPEED][1]) < len(series[ROTOR_MOMENTUM][1])):
        out.append(Plot("Driven rotors' momentum J Ω (N·m·s)", ROTOR_MOMENTUM, True, rng(ROTOR_MOMENTUM, True)))  # some lack an inertia
    if ROTOR_TORQUE in series:
        out.append(Plot("Driven rotors' drive torque u (N·m)", ROTOR_TORQUE, True, rng(ROTOR_TORQUE, True)))
    if LOAD_TORQUE_BODY in series:
        out += [Plot(f"M of loads, body frame ({torque}N·m)", LOAD_TORQUE_BODY, True, rng(LOAD_TORQUE_BODY, True)),
                Plot(f"M of loads, space frame ({torque}N·m)", LOAD_TORQUE_SPACE, True, rng(LOAD_TORQUE_SPACE, True)),
                Plot(f"Power of loads ({power}W)", LOAD_POWER, False, rng(LOAD_POWER, False))]
    motion.sort(key=lambda p: PLOT_ORDER.index(p.origin))
    out.sort(key=lambda p: PLOT_ORDER.index(p.origin))
    if len(motion) + len(out) <= MAX_PLOTS_ONE_TAB:
        return {MOTION: motion + out}
    return {MOTION: motion, ENERGY_TAB: out}


def blueprint(groups: dict[str, list[Plot]], trail_seconds: float | None = None, active: str = MOTION,
              eye: tuple[np.ndarray, np.ndarray] | None = None, span: tuple[float, float] | None = None,
              events: list[rrb.View] | None = None, portrait: bool = False, recent: float | None = None) -> rrb.Blueprint:
    """The default layout: the 3D view (and the run panel as a tab) on the left, on the right the
    plots in tabs (``groups``), each a two-column grid; ``active`` is the tab shown first; ``eye``
    (position, look target) the 3D view's default camera (the one labels are laid out for).  Trails show the last ``trail_seconds`` before the time cursor
    (the whole paths stay, dimmed); legends sit in the top-right corner, above the data; the plots'
    time axis shows ``span`` (s: the whole run, not a window around the time cursor); ``events``:
    the views of the run's events, in a tab of their own (``EVENTS_TAB``); ``portrait``: the
    torque-free phase portrait's 3D view beside the body's; ``recent`` (s): the motion's plots over
    that window before the time cursor, in a tab of their own (``RECENT_TAB``)."""
    overrides = {}
    if trail_seconds is not None:
        window = rrb.VisibleTimeRange(TIMELINE, start=rrb.TimeRangeBoundary.cursor_relative(seconds=-trail_seconds),
                                      end=rrb.TimeRangeBoundary.cursor_relative())
        overrides = {trail: rrb.VisibleTimeRanges([window]) for trail in TRAILS}
    names = [name for name, plot_list in groups.items() if plot_list]
    tabs = [rrb.Grid(*[_view(p, span) for p in groups[name]], grid_columns=2, name=name) for name in names]
    if recent is not None:  # a long run: its motion over a window before the cursor, beside the whole run
        tabs.append(rrb.Grid(*[_view(p, recent=recent) for p in groups[MOTION]], grid_columns=2, name=RECENT_TAB))
        names.append(RECENT_TAB)
    if events:
        tabs.append(rrb.Grid(*events, grid_columns=2, name=EVENTS_TAB))
        names.append(EVENTS_TAB)
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Tabs(
                rrb.Spatial3DView(origin="/world", name="Body (space frame)", overrides=overrides,
                                  eye_controls=None if eye is None else rrb.EyeControls3D(
                                      position=eye[0], look_target=eye[1], eye_up=[0.0, 0.0, 1.0])),
                *([rrb.Spatial3DView(origin=PORTRAIT, name="Phase portrait (L, body frame)")] if portrait else []),
                rrb.TextDocumentView(origin=INFO, name="Run"),
            ),
            rrb.Tabs(*tabs, active_tab=names.index(active) if active in names else 0),
            column_shares=[1, 1],
        ),
        collapse_panels=True,
    )




TIME_MARGIN = 0.04  # the time axis runs this fraction of the span past the end: the last tick's label ("+10s") fits


def whole_span(span: tuple[float, float] | None) -> rrb.TimeAxis | None:
    """A plot's time axis over ``span`` (s), not a window around the time cursor, and a margin
    (``TIME_MARGIN``) after it, so that the label of a tick at the run's end is not cut."""
    return None if span is None else rrb.TimeAxis(view_range=rrb.TimeRange(
        start=rrb.TimeRangeBoundary.absolute(seconds=span[0]),
        end=rrb.TimeRangeBoundary.absolute(seconds=span[1] + TIME_MARGIN * (span[1] - span[0]))))


def _view(p: Plot, span: tuple[float, float] | None = None, recent: float | None = None) -> rrb.TimeSeriesView:
    """A plot over the whole ``span``, or over the ``recent`` seconds before the time cursor."""
    whole = whole_span(span) if recent is None else rrb.TimeAxis(view_range=rrb.TimeRange(
        start=rrb.TimeRangeBoundary.cursor_relative(seconds=-recent), end=rrb.TimeRangeBoundary.cursor_relative()))
    return rrb.TimeSeriesView(
        origin=p.origin, name=p.name if recent is None else f"{p.name}, last {recent:.3g} s", axis_x=whole,
        plot_legend=rrb.PlotLegend(corner="RightTop", visible=p.legend),
        axis_y=None if p.y_range is None else rrb.ScalarAxis(range=p.y_range),
    )
