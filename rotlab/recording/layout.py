"""Entity paths and the default blueprint: the recording's stable contract (SPEC).

Timeline ``sim_time`` (duration).  Vectors name their frame in the path or the series names.
"""

from __future__ import annotations

import rerun as rr
import rerun.blueprint as rrb

TIMELINE = "sim_time"

BODY = "/world/body"  # Transform3D: Λ (body → space); shape and body axes below it
BODY_SHAPE = "/world/body/shape"
BODY_AXES = "/world/body/axes"
BODY_ARM = "/world/body/arm"  # fixed point → centre of mass
BODY_POLHODE = "/world/body/polhode"  # torque-free: tip of scaled ω in the body frame
AXIS_PATH = "/world/axis_path"  # static: path of the symmetry-axis (or body z) tip
AXIS_TIP = "/world/axis_tip"  # the tip now
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


def blueprint(invariants: list[str], euler_angles: bool, energy_range: tuple[float, float] | None = None) -> rrb.Blueprint:
    """The default layout.  ``energy_range`` fixes the energy plot's axis (so that a constant
    energy is drawn flat, not zoomed onto its rounding noise)."""
    energy_axis = None if energy_range is None else rrb.ScalarAxis(range=energy_range)
    plots = [
        rrb.TimeSeriesView(origin=OMEGA, name="ω, body frame (rad/s)"),
        rrb.TimeSeriesView(origin=L_SPACE, name="L, space frame (kg·m²/s)"),
        rrb.TimeSeriesView(origin=ENERGY, name="Energy (J)", axis_y=energy_axis),
        rrb.TimeSeriesView(origin=INVARIANTS_LOG, name="Invariant drift, log10 |relative|"),
    ]
    if euler_angles:
        plots.append(rrb.TimeSeriesView(origin=EULER_ANGLES, name="Euler angles ψ, φ (rad)",
                                        overrides={EULER_ANGLES: rr.SeriesLines.from_fields(visible_series=[True, False, True])}))
        plots.append(rrb.TimeSeriesView(origin=EULER_ANGLES, name="Nutation θ (rad)",
                                        overrides={EULER_ANGLES: rr.SeriesLines.from_fields(visible_series=[False, True, False])}))
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Tabs(
                rrb.Spatial3DView(origin="/world", name="Body (space frame)"),
                rrb.TextDocumentView(origin=INFO, name="Run"),
            ),
            rrb.Vertical(*plots),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )
