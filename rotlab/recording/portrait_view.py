"""The phase portrait in the recording (``rotlab.phase_portrait``).

Torque-free body with three different moments: a 3D view of the angular momentum in the body
frame (user's axes), on its sphere |L| = L₀ — the family of polhodes (``PORTRAIT_POLHODES``,
``POLHODE_LEVELS`` energy levels around each stable axis), the separatrices through the unstable
axis, the six equilibria ±L₀ along the principal axes (labelled by their moment: "min", "mid"
(unstable), "max"), the run's own path and its point at the time cursor.
Lagrange top: the effective potential along the motion, U(θ(t)) beside the constant E' (the
top turns where they meet; the gap is ½ A θ̇²), and the turning points θ₁, θ₂ from the cubic
on the θ plot; the run report gives the nutation period and mean precession, exact and fast-top.
"""

from __future__ import annotations

import math

import numpy as np
import rerun as rr

from rotlab.phase_portrait import POLHODE_LEVELS, lagrange_top, polhodes
from rotlab.recording import layout, style
from rotlab.scene.scene import TORQUE_FREE, Scene
from rotlab.trajectory import Trajectory

PATH_RADIUS = rr.components.Radius.ui_points(1.5)
CURVE_RADIUS = rr.components.Radius.ui_points(0.75)
EQUILIBRIUM_RADIUS = rr.components.Radius.ui_points(5.0)


def has_polhodes(scene: Scene) -> bool:
    """A torque-free body with three different moments: its polhodes are drawn."""
    return scene.kind == TORQUE_FREE and len({float(m) for m in scene.moments}) == 3


def log_polhodes(rec: rr.RecordingStream, traj: Trajectory) -> None:
    """The static part of the torque-free portrait (module docstring), from the samples of ``traj``."""
    if not (has_polhodes(traj.scene) and traj.t.shape[0]):
        return
    scene = traj.scene
    L0 = float(np.linalg.norm(traj.L_body[0]))
    if not (L0 > 0.0 and math.isfinite(L0)):
        return
    axes = np.asarray(scene.axes, dtype=float)  # r_U = axes r_P
    curves, separatrices = polhodes(np.asarray(scene.moments, dtype=float), L0)
    rec.log(layout.PORTRAIT_POLHODES, rr.LineStrips3D([c @ axes.T for c in curves], colors=[style.POLHODE],
                                                      radii=CURVE_RADIUS), static=True)
    rec.log(layout.PORTRAIT_SEPARATRICES, rr.LineStrips3D([c @ axes.T for c in separatrices], colors=[style.SEPARATRIX],
                                                          radii=CURVE_RADIUS), static=True)
    rank = np.argsort(np.argsort(scene.moments))  # 0: the smallest moment
    names = ["min", "mid", "max"]
    points = np.concatenate([L0 * axes.T, -L0 * axes.T])
    labels = [names[r] for r in rank] * 2
    colors = [style.SEPARATRIX if names[r] == "mid" else style.FIELD for r in rank] * 2
    rec.log(layout.PORTRAIT_EQUILIBRIA, rr.Points3D(points, labels=labels, colors=colors, radii=EQUILIBRIUM_RADIUS), static=True)
    rec.log(layout.PORTRAIT_PATH, rr.LineStrips3D([traj.L_body], colors=[style.L], radii=PATH_RADIUS), static=True)
    rec.log(layout.PORTRAIT_NOW, rr.Points3D.from_fields(colors=[style.L], radii=EQUILIBRIUM_RADIUS), static=True)


def send_now(rec: rr.RecordingStream, traj: Trajectory, index: list, rows: slice) -> None:
    """The portrait's point at each visual sample: L in the body frame."""
    if has_polhodes(traj.scene):
        rec.send_columns(layout.PORTRAIT_NOW, index, rr.Points3D.columns(positions=traj.L_body[rows]))


def top_series(traj: Trajectory, degrees: bool) -> dict[str, tuple[np.ndarray, list[str]]]:
    """A Lagrange top's U(θ(t)) and E' (J), and its turning points on the θ plot (deg or rad)."""
    top = lagrange_top(traj.scene)
    if top is None or traj.gamma is None:
        return {}
    axis = np.asarray(traj.scene.axes, dtype=float) @ np.asarray(traj.scene.symmetry_axis, dtype=float)  # e in the user's axes
    theta = np.arccos(np.clip(traj.gamma @ axis, -1.0, 1.0))
    n = traj.t.shape[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        potential = top.potential(theta)
    out = {layout.TOP_POTENTIAL: (np.column_stack([potential, np.full(n, top.energy)]), ["U(θ)", "E′"])}
    if traj.euler_angles is not None:
        turning = np.degrees(top.turning_points()) if degrees else np.array(top.turning_points())
        out[layout.EULER_THETA_TURNING] = (np.tile(turning, (n, 1)), ["θ₁", "θ₂"])
    return out


def top_report(scene: Scene) -> list[str]:
    """The run report's lines on a Lagrange top's reduced motion (empty for another scene)."""
    top = lagrange_top(scene)
    if top is None:
        return []
    theta1, theta2 = np.degrees(top.turning_points())
    period = top.nutation_period()
    return ["", "## The top's motion in θ (from its integrals)", "", "| quantity | exact | fast top |", "|---|---|---|",
            f"| turning points θ₁, θ₂ | {theta1:.6g}°, {theta2:.6g}° | – |",
            f"| nutation frequency | {2.0 * math.pi / period:.6g} rad/s (period {period:.6g} s) | C ω₃ / A = {top.fast_nutation_frequency:.6g} rad/s |",
            f"| mean precession rate | {_or_undefined(top.mean_precession_rate(), 'rad/s')} | m g l / (C ω₃) = {top.fast_precession_rate:.6g} rad/s |",
            "", f"U(θ) = (p_ψ − C ω₃ cos θ)² / (2 A sin² θ) + m g l cos θ with p_ψ = {top.p_psi:.6g} kg·m²/s, ω₃ = {top.spin:.6g} rad/s; "
            f"E′ = {top.energy:.6g} J. The plot \"Effective potential\" shows U(θ(t)) under E′: the top turns where they meet."]


def _or_undefined(value: float, unit: str) -> str:
    return f"{value:.6g} {unit}" if math.isfinite(value) else "undefined (the axis reaches the vertical)"


POLHODE_NOTE = (f"L in the body frame on its sphere, of radius L₀ = the run's angular momentum; {POLHODE_LEVELS} polhodes around each stable axis "
                "(orange, dim), the separatrices through the intermediate axis (red), the equilibria ±L₀ along the principal axes "
                "(min, mid (unstable), max moment), the run's path and its point now (violet)")
