"""What the 3D view and the plots show beyond the state: the visual part of a run recording.

``log_static``     the scene, once: body shape and axes, whole paths (dim), the field, Poinsot's
                   construction (invariable plane, herpolhode, polhode and the energy ellipsoid
                   ω·Iω = 2T fixed in the body, drawn at the ω-arrow scale s: semi-axes
                   s·√(2T/I_k), so it touches the plane at the tip of s·ω), styles of every
                   series and arrow (``style``: one colour language, short 3D labels).
``send_chunk``     the temporal visuals of a slice of samples: trails (axis tip, herpolhode,
                   polhode; drawn over a trailing window by the blueprint), load arrows.
``derived_series`` plotted series computed from a slice: readable Euler angles (θ; ψ wrapped to
                   one turn; the rates ψ̇, φ̇), the loads' torque (body and space) and power.
Everything works on a slice of samples (no whole-trajectory pass), except ``log_static`` which
takes the (possibly thinned) whole run for its paths.

Euler-angle rates from ω (body, 3-1-3):  ψ̇ = (p sin φ + q cos φ)/sin θ,
θ̇ = p cos φ − q sin φ,  φ̇ = r − ψ̇ cos θ  (undefined at sin θ = 0: NaN there).
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from rotlab.core import quaternion as quat
from rotlab.recording import labels, layout, loads_view, style
from rotlab.recording.geometry import decimate
from rotlab.recording.shapes import primitives, rotor_wheels
from rotlab.trajectory import Trajectory

DIM = 0.35  # whole paths: this fraction of their colour; the trailing window is drawn bright
MIN_LABELLED = 0.05  # body sizes: a shorter load arrow (a load that is off) carries no label
LABEL_BEYOND = 1.08  # a label sits this far along its arrow (tip = 1)
FIELD_LABEL = 1.2  # body sizes along "up": the middle of the field's arrow, where its label is
AXES_LENGTH, L_LENGTH, OMEGA_LENGTH = 1.25, 1.55, 1.85  # body sizes: tips apart when ω ∥ L ∥ an axis
TRAIL_PERIODS = 3.0
RECENT_PERIODS, RECENT_SAMPLES, RECENT_SHARE = 12.0, 200, 0.25  # the recent plots' window (``recent_window``)
SINGULAR_SIN = 1e-9
LOAD_LENGTH = 0.9  # body sizes: the largest load arrow (of the loads' own bound)


def drawn(vectors: np.ndarray, scale: float, design: float) -> np.ndarray:
    """(n, 3) ``vectors`` × ``scale`` as drawn: linear up to the ``design`` length (the longest of
    the run's first chunk, which set ``scale``), beyond it design·(1 + ½ tanh(ln(ℓ/design))): a
    vector that outgrows the first chunk's still grows, up to 1.5 × ``design``, and stays in the
    view (the plots carry its magnitude)."""
    scaled = vectors * scale
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        length = np.linalg.norm(scaled, axis=1, keepdims=True)
        longer = length > design
        ratio = np.where(longer, length, design) / design
        return np.where(longer, scaled / np.where(longer, length, 1.0) * design * (1.0 + 0.5 * np.tanh(np.log(ratio))), scaled)


def degrees_wanted(scene) -> bool:
    """Plots in degrees when the scenario speaks degrees (an ``_deg`` key)."""
    return scene.scenario.initial.euler_313_deg is not None


def dim(color: style.Color) -> style.Color:
    return (round(DIM * color[0]), round(DIM * color[1]), round(DIM * color[2]))


def motion_period(t: np.ndarray, omega: np.ndarray) -> float:
    """The period of the body's fastest motion (s): the shorter of one turn 2π/max|ω| and the
    period of the most varying ω component (twice the mean spacing of its crossings of its mean);
    the span itself when neither is seen."""
    span = float(t[-1] - t[0])
    k = int(np.argmax(np.std(omega, axis=0)))
    centred = omega[:, k] - np.mean(omega[:, k])
    crossings = np.nonzero(np.sign(centred[:-1]) * np.sign(centred[1:]) < 0)[0]
    period = 2.0 * float(np.mean(np.diff(t[crossings]))) if crossings.size >= 3 else span
    fastest = float(np.max(np.linalg.norm(omega, axis=1)))
    if np.isfinite(fastest) and fastest > 0.0:
        period = min(period, 2.0 * np.pi / fastest)
    return period


def trail_window(t: np.ndarray, omega: np.ndarray) -> float:
    """The trailing window (s): ``TRAIL_PERIODS`` periods of the body's fastest motion
    (``motion_period``), within [span/20, span/6]."""
    if t.shape[0] < 3:
        return float(t[-1] - t[0]) if len(t) else 1.0
    span = float(t[-1] - t[0])
    return float(np.clip(TRAIL_PERIODS * motion_period(t, omega), span / 20, span / 6))


def recent_window(t: np.ndarray, omega: np.ndarray) -> float | None:
    """The plots' recent window (s): ``RECENT_PERIODS`` periods of the fastest motion, at least
    ``RECENT_SAMPLES`` samples long; None unless that is under ``RECENT_SHARE`` of the run (a
    shorter run's whole-run plots show the detail)."""
    if t.shape[0] < 3:
        return None
    span = float(t[-1] - t[0])
    window = max(RECENT_PERIODS * motion_period(t, omega), RECENT_SAMPLES * span / (t.shape[0] - 1))
    return window if window < RECENT_SHARE * span else None


def euler_series(traj: Trajectory) -> dict[str, tuple[np.ndarray, list[str]]]:
    """θ; ψ wrapped to (−180°, 180°] (or (−π, π]); the spin rate φ̇ (deg/s or rad/s)."""
    if traj.euler_angles is None:
        return {}
    psi, theta, phi = traj.euler_angles.T
    p, q, r = traj.omega.T
    sin_theta = np.sin(theta)
    with np.errstate(divide="ignore", invalid="ignore"):
        psi_dot = np.where(np.abs(sin_theta) > SINGULAR_SIN, (p * np.sin(phi) + q * np.cos(phi)) / sin_theta, np.nan)
    phi_dot = r - psi_dot * np.cos(theta)
    wrapped = np.angle(np.exp(1j * psi))
    unit = np.degrees if degrees_wanted(traj.scene) else (lambda x: x)
    return {
        layout.EULER_THETA: (unit(theta)[:, None], ["θ"]),
        layout.EULER_PSI: (unit(wrapped)[:, None], ["ψ"]),
        layout.EULER_SPIN_RATE: (unit(phi_dot)[:, None], ["dφ/dt"]),
    }


def rotor_series(traj: Trajectory) -> dict[str, tuple[np.ndarray, list[str]]]:
    """The driven rotors' momenta J Ω and drive torques u, one series per rotor (none without)."""
    if traj.rotor_momenta is None:
        return {}
    from rotlab.config.models import RPM
    from rotlab.core.torques import drive_torques

    driven = traj.scene.scenario.driven_rotors()
    names = [style.drawable(f"h {name}") for name, _ in driven]
    torques = np.zeros(traj.rotor_momenta.shape)
    drive_torques(traj.t, traj._state, traj.scene.model, torques)
    out = {layout.ROTOR_MOMENTUM: (traj.rotor_momenta, names), layout.ROTOR_TORQUE: (torques, [n.replace("h ", "u ", 1) for n in names])}
    known = [k for k, (_, rotor) in enumerate(driven) if rotor.inertia is not None]
    if known:  # the speeds of those whose inertia is given
        out[layout.ROTOR_SPEED] = (traj.rotor_speeds[:, known] / RPM, [names[k].replace("h ", "Ω ", 1) for k in known])
    return out


SUBMULTIPLES = ((1.0, ""), (1e3, "m"), (1e6, "µ"), (1e9, "n"), (1e12, "p"))  # (factor, SI prefix) for small plotted values


def plot_unit(values: np.ndarray) -> tuple[float, str]:
    """(factor, SI prefix) that brings the largest finite |value| to at least 1 (at most p): a plot
    of tiny values in readable ticks (Rerun labels 1e-6 "0.000 001", and a 1e-5 range gets one
    tick).  Values of 1 or more, or none, keep the base unit."""
    finite = np.abs(values[np.isfinite(values)])
    largest = float(finite.max()) if finite.size else 0.0
    for factor, prefix in SUBMULTIPLES:
        if largest * factor >= 1.0:
            return factor, prefix
    return SUBMULTIPLES[-1] if largest > 0.0 else SUBMULTIPLES[0]


def load_units(traj: Trajectory) -> dict[str, tuple[float, str]]:
    """``plot_unit`` of the loads' torque (both frames) and power (empty without loads), from what
    is known however the run is cut into chunks: the run's first sample (``traj``'s, which starts
    the run) and the loads' own bound at its |ω₀| (``torque_bound``; times |ω₀| for the power)."""
    first = load_series(traj, rows=np.array([0]))
    if not first:
        return {}
    w0 = float(np.linalg.norm(traj.omega[0]))
    bound = torque_bound(traj, w0)
    torque = np.append(first[layout.LOAD_TORQUE_BODY][0], bound)
    power = np.append(first[layout.LOAD_POWER][0], bound * w0)
    return {"torque": plot_unit(torque), "power": plot_unit(power)}


def load_series(traj: Trajectory, rows: np.ndarray | None = None,
                units: dict[str, tuple[float, str]] | None = None) -> dict[str, tuple[np.ndarray, list[str]]]:
    """The torque of the non-conservative loads (body and space frame) and its power M·ω, at
    ``rows`` (all samples when None), in N·m and W times the ``units`` factors (``load_units``)."""
    views = [v for v in loads_view.load_views(traj.scene) if not v.conservative]
    if not views:
        return {}
    rows = np.arange(traj.t.shape[0]) if rows is None else rows
    q_p, w_p = loads_view.principal_state(traj.scene, traj.quaternion[rows], traj.omega[rows])
    total_p = sum(loads_view.torques(traj.scene, v, traj.t[rows], q_p, w_p) for v in views)
    body = total_p @ traj.scene.axes.T  # user's body frame
    unit_q = q_p / np.linalg.norm(q_p, axis=1, keepdims=True)
    space = quat.rotate_to_space_array(unit_q, total_p)
    power = np.einsum("ij,ij->i", total_p, w_p)
    if units:
        body, space, power = body * units["torque"][0], space * units["torque"][0], power * units["power"][0]
    return {
        layout.LOAD_TORQUE_BODY: (body, ["M_x", "M_y", "M_z"]),  # body axes x, y, z (load numbers are M1, F1 … in 3D)
        layout.LOAD_TORQUE_SPACE: (space, ["M_X", "M_Y", "M_Z"]),
        layout.LOAD_POWER: (power[:, None], ["P"]),
    }


def series_colors(entity: str, names: list[str]) -> list[style.Color] | None:
    """The colour language for one plotted entity (None: the viewer's default)."""
    if entity in (layout.OMEGA, layout.L_SPACE, layout.LOAD_TORQUE_BODY, layout.LOAD_TORQUE_SPACE):
        return style.XYZ
    if entity == layout.ENERGY:
        return [style.ENERGY[n] for n in names]
    if entity.startswith((layout.INVARIANTS + "/", layout.INVARIANTS_LOG + "/")):
        return [style.INVARIANT.get(entity.rsplit("/", 1)[1], style.FIELD)]
    if entity in (layout.ROTOR_MOMENTUM, layout.ROTOR_SPEED, layout.ROTOR_TORQUE):  # rotor k: one hue in every plot
        return [style.HUES[k % len(style.HUES)] for k in range(len(names))]
    if entity == layout.TOP_POTENTIAL:
        return [style.ENERGY["V"], style.ENERGY["T+V"]]
    if entity == layout.EULER_THETA_TURNING:
        return [style.SEPARATRIX, style.SEPARATRIX]
    single = {layout.EULER_THETA: style.ENERGY["T+V−W"], layout.EULER_PSI: style.ENERGY["V"],
              layout.EULER_SPIN_RATE: style.L, layout.LOAD_POWER: style.LOAD}
    if entity in single:
        return [single[entity]]
    return None


def log_static(rec: rr.RecordingStream, traj: Trajectory, views) -> None:
    """The static scene (see module docstring); ``views`` is the writer's display bundle."""
    shape, size, geo = views.shape, views.shape.size, views.geometry
    drawn = primitives(traj.scene.scenario.body, size)
    if not drawn:  # a body given by its moments: its equivalent uniform ellipsoid
        rec.log(layout.BODY_SHAPE, rr.Ellipsoids3D(half_sizes=[shape.half_sizes], centers=[shape.center],
                                                   quaternions=[rr.Quaternion(xyzw=xyzw(shape.orientation))],
                                                   colors=[style.BODY], fill_mode="solid"), static=True)
    for kind, fields in drawn.items():  # a body given by its geometry: as it is
        archetype = {"box": rr.Boxes3D, "cylinder": rr.Cylinders3D, "ball": rr.Ellipsoids3D}[kind]
        rec.log(f"{layout.BODY_SHAPE}/{kind}", archetype(**fields, colors=[style.BODY], fill_mode="solid"), static=True)
    rotors = traj.scene.scenario.rotors
    if rotors:  # a gyrostat: each wheel a disc on its shaft from the fixed point
        wheels = rotor_wheels(rotors, size)
        rec.log(f"{layout.ROTORS}/wheels", rr.Cylinders3D(centers=wheels["centers"], lengths=wheels["lengths"], radii=wheels["radii"],
                                                         quaternions=[rr.Quaternion(xyzw=xyzw(q)) for q in wheels["quaternions"]],
                                                         colors=[style.ROTOR], fill_mode="solid"), static=True)
        rec.log(f"{layout.ROTORS}/shafts", rr.LineStrips3D([[np.zeros(3), c] for c in wheels["centers"]], colors=[style.ROTOR]), static=True)
    rec.log(layout.BODY_AXES, rr.Arrows3D(vectors=np.eye(3) * AXES_LENGTH * size, colors=style.XYZ), static=True)
    texts, colors = label_style(traj)
    rec.log(layout.LABELS_3D, rr.Points3D.from_fields(radii=[0.0], colors=colors, labels=[style.label_3d(s) for s in texts]), static=True)
    r_c = np.asarray(traj.scene.scenario.body.centre(), dtype=float)
    if np.any(r_c != 0.0):
        rec.log(layout.BODY_ARM, rr.LineStrips3D([[np.zeros(3), r_c]], colors=[style.ARM]), static=True)
    rec.log(layout.AXIS_PATH, rr.LineStrips3D([decimate(geo.axis_tips)], colors=[dim(style.AXIS_TRACE)], radii=[0.002 * size]), static=True)
    rec.log(layout.AXIS_TIP, rr.Points3D.from_fields(colors=[style.AXIS_TRACE], radii=[0.006 * size]), static=True)
    if geo.field_up is not None:
        rec.log(layout.FIELD, rr.Arrows3D(vectors=[-geo.field_up * 0.8 * size], origins=[geo.field_up * 1.6 * size],
                                          colors=[style.FIELD]), static=True)
    if geo.invariable_plane is not None:
        _log_poinsot(rec, traj, views)
    for entity, (_, names) in views.series.items():
        colors = series_colors(entity, names)
        # min-max per pixel, not the mean: a motion faster than a pixel of the whole run (a top's
        # nutation over minutes) shows as the band it sweeps, not as its average, a flat line
        rec.log(entity, rr.SeriesLines(names=[style.check_text(n) for n in names], colors=colors, aggregation_policy="minmax"),
                static=True)
    for entity, color in ((layout.OMEGA_ARROW, style.OMEGA), (layout.L_ARROW, style.L)):
        rec.log(entity, rr.Arrows3D.from_fields(colors=[color], radii=[0.012 * size]), static=True)
    for view in loads_view.load_views(traj.scene):
        rec.log(f"{layout.LOADS_3D}/{view.symbol}/arrow", rr.Arrows3D.from_fields(colors=[style.LOAD], radii=[0.01 * size]), static=True)


def label_style(traj: Trajectory) -> tuple[list[str], list[style.Color]]:
    """The 3D labels in priority order (``labels.declutter``) and their colours: the field's
    (static, drawn at its arrow), ω, L, each load, the body axes."""
    texts, colors = (["g"], [style.FIELD]) if traj.scene.field_direction is not None else ([], [])
    texts += ["ω", "L"]
    colors += [style.OMEGA, style.L]
    for view in loads_view.load_views(traj.scene):
        texts.append(view.symbol)
        colors.append(style.LOAD)
    return texts + ["x", "y", "z"], colors + style.XYZ


def _log_poinsot(rec: rr.RecordingStream, traj: Trajectory, views) -> None:
    size, geo, s = views.shape.size, views.geometry, views.omega_scale
    plane = geo.invariable_plane
    rec.log(layout.INVARIABLE_PLANE, rr.Boxes3D(
        half_sizes=[[plane.half_size, plane.half_size, 1e-3 * plane.half_size]], centers=[plane.center],
        quaternions=[rr.Quaternion(xyzw=xyzw(quat.between([0.0, 0.0, 1.0], plane.normal)))],
        colors=[(90, 90, 140, 90)], fill_mode="solid"), static=True)
    rec.log(layout.HERPOLHODE, rr.LineStrips3D([geo.herpolhode], colors=[dim(style.OMEGA)], radii=[0.002 * size]), static=True)
    rec.log(layout.BODY_POLHODE, rr.LineStrips3D([geo.polhode], colors=[dim(style.OMEGA)], radii=[0.002 * size]), static=True)
    for entity in (layout.HERPOLHODE_TRAIL, layout.POLHODE_TRAIL):
        rec.log(entity, rr.Points3D.from_fields(colors=[style.OMEGA], radii=[0.006 * size]), static=True)
    center, half_sizes, orientation = energy_ellipsoid(traj, s)
    rec.log(layout.ENERGY_ELLIPSOID, rr.Ellipsoids3D(half_sizes=[half_sizes], centers=[center],
                                                     quaternions=[rr.Quaternion(xyzw=xyzw(orientation))],
                                                     colors=[dim(style.OMEGA)], fill_mode="majorwireframe"), static=True)


def reach(traj: Trajectory, views) -> float:
    """The farthest a drawn thing gets from the fixed point (m): arrows, the field, the body and,
    torque-free, the energy ellipsoid and the invariable plane."""
    size = views.shape.size
    out = max(OMEGA_LENGTH, L_LENGTH, 1.6 if views.geometry.field_up is not None else 0.0) * size
    plane = views.geometry.invariable_plane
    if plane is not None and len(traj.t):
        out = max(out, float(np.max(energy_ellipsoid(traj, views.omega_scale)[1])),
                  float(np.hypot(np.linalg.norm(plane.center), plane.half_size)))
    return out


def energy_ellipsoid(traj: Trajectory, scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centre, semi-axes, orientation Λ in the user's body frame) of x·I x = scale²·2T, the
    inertia (energy) ellipsoid on which the tip of scale·ω moves."""
    two_t = 2.0 * float(traj.kinetic[0])
    return np.zeros(3), scale * np.sqrt(two_t / traj.scene.moments), traj.scene.axes_quaternion


def send_chunk(rec: rr.RecordingStream, traj: Trajectory, views, rows: slice, ns: np.ndarray) -> None:
    """The temporal visuals of samples ``rows`` (times ``ns[rows]``): trails, load arrows and
    the labels, decluttered for the default camera (``labels``)."""
    index = [rr.TimeColumn(layout.TIMELINE, duration=ns[rows])]
    if views.geometry.invariable_plane is not None:
        s = views.omega_scale
        rec.send_columns(layout.HERPOLHODE_TRAIL, index, rr.Points3D.columns(positions=views.omega_space[rows] * s))
        rec.send_columns(layout.POLHODE_TRAIL, index, rr.Points3D.columns(positions=traj.omega[rows] * s))
    n = rows.stop - rows.start
    size = views.shape.size
    anchors: list[tuple[str, np.ndarray]] = []
    if views.geometry.field_up is not None:
        anchors.append(("g", np.broadcast_to(views.geometry.field_up * FIELD_LABEL * size, (n, 3))))
    anchors += [("ω", views.omega_arrow[rows] * LABEL_BEYOND), ("L", views.L_arrow[rows] * LABEL_BEYOND)]
    loads = _load_arrows(traj, views, rows)
    for symbol, (_, _, _, anchor) in loads.items():
        anchors.append((symbol, _fill(anchor, loads[symbol][0])))
    axes = quat.to_matrix(views.unit_q[rows]) * (AXES_LENGTH * LABEL_BEYOND * size)  # columns: body axes in space
    anchors += [(name, axes[:, :, k]) for k, name in enumerate("xyz")]
    placed = labels.declutter(anchors, *labels.camera(reach(traj, views)))
    positions = np.stack(placed, axis=1)  # (n, labels, 3) in ``label_style`` order
    rec.send_columns(layout.LABELS_3D, index, rr.Points3D.columns(positions=positions.reshape(-1, 3)).partition([len(placed)] * n))
    for symbol, (picked, origins, vectors, _) in loads.items():
        load_index = [rr.TimeColumn(layout.TIMELINE, duration=ns[rows.start + picked])]
        rec.send_columns(f"{layout.LOADS_3D}/{symbol}/arrow", load_index, rr.Arrows3D.columns(vectors=vectors[picked], origins=origins[picked]))


def _fill(anchor: np.ndarray, picked: np.ndarray) -> np.ndarray:
    """A load's label anchors at every row of the chunk: each evaluated row's value held until
    the next (rows before the first take the first), as the viewer holds the arrow."""
    if not picked.size:
        return anchor
    source = picked[np.clip(np.searchsorted(picked, np.arange(anchor.shape[0]), side="right") - 1, 0, picked.size - 1)]
    return anchor[source]


def _load_arrows(traj: Trajectory, views, rows: slice) -> dict[str, tuple[np.ndarray, ...]]:
    """symbol → (indices into the chunk where the load is evaluated (every ``sample_stride``-th
    sample of the run), origins, vectors, label anchors): (n, 3) space-frame arrays, scaled, NaN
    where the load is not evaluated; the label anchor is NaN too where the load is off (its arrow
    shorter than ``MIN_LABELLED``)."""
    load_list = loads_view.load_views(traj.scene)
    n = rows.stop - rows.start
    stride = loads_view.sample_stride(traj.scene)
    picked = np.nonzero((np.arange(rows.start, rows.stop) % stride) == 0)[0]
    if not picked.size:  # no evaluated row in this chunk: the loads keep their arrows, labels not placed
        nan = np.full((n, 3), np.nan)
        return {view.symbol: (picked, nan, nan, nan) for view in load_list}
    at = rows.start + picked
    unit_q = views.unit_q[at]
    q_p, w_p = loads_view.principal_state(traj.scene, traj.quaternion[at], traj.omega[at])
    out = {}
    for view in load_list:
        if view.kind == "force":
            origins = quat.rotate_to_space_array(unit_q, np.broadcast_to(view.point, (len(at), 3)))
            force = np.broadcast_to(view.force, (len(at), 3))
            vectors = force if view.force_frame == "space" else quat.rotate_to_space_array(unit_q, force)
            vectors = vectors * views.load_scales["force"]
        else:
            torque_p = loads_view.torques(traj.scene, view, traj.t[at], q_p, w_p)
            vectors = drawn(quat.rotate_to_space_array(q_p / np.linalg.norm(q_p, axis=1, keepdims=True), torque_p), views.load_scales["torque"],
                            LOAD_LENGTH * views.shape.size)
            origins = np.zeros_like(vectors)
        full_o, full_v = np.full((n, 3), np.nan), np.full((n, 3), np.nan)
        full_o[picked], full_v[picked] = origins, vectors
        anchor = full_o + full_v * LABEL_BEYOND
        anchor[np.linalg.norm(full_v, axis=1) < MIN_LABELLED * views.shape.size] = np.nan  # a load that is off: no label
        out[view.symbol] = (picked, full_o, full_v, anchor)
    return out


def load_scales(traj: Trajectory, size: float) -> dict[str, float]:
    """Arrow length per N (forces) and per N·m (torques): the largest of each kind ``LOAD_LENGTH`` body sizes
    (torques from the loads' own bound at unit ω, see ``scene.loads.torque_scale``)."""
    forces = [np.linalg.norm(v.force) for v in loads_view.load_views(traj.scene) if v.kind == "force"]
    biggest_force = max(forces, default=0.0)
    biggest_torque = torque_bound(traj, float(np.max(np.linalg.norm(traj.omega, axis=1), initial=0.0)))
    return {"force": LOAD_LENGTH * size / biggest_force if biggest_force > 0 else 1.0,
            "torque": LOAD_LENGTH * size / biggest_torque if biggest_torque > 0 else 1.0}


def torque_bound(traj: Trajectory, omega: float) -> float:
    """The largest of the torque loads' own bounds at |ω| = ``omega`` (``scene.loads.torque_scale``,
    plus damping × |ω|; formula loads are not bounded there: 0 for them)."""
    from rotlab.scene.loads import torque_scale

    return max((torque_scale(v.arrays) + v.arrays.damping * omega for v in loads_view.load_views(traj.scene) if v.kind == "torque"),
               default=0.0)


def xyzw(q: np.ndarray) -> np.ndarray:
    """Rerun's quaternion order (x, y, z, w) from scalar-first (w, x, y, z)."""
    return np.roll(q, -1, axis=-1)
