"""``rotlab export``: a run recording's samples as a table — the columns and units of
``Trajectory.to_dataframe`` (``Trajectory.columns``), as CSV or Parquet.

The recording keeps the run's state at every sample (its times in whole nanoseconds: those of the
scenario's grid are taken from the grid) (``/body/quaternion``, ``/body/omega`` and,
where loads do work, ``/body/work``) and its validated scenario (``/scenario``); the scene is built
again from the scenario and every other column computed from the state, as the run computed it
(the state goes back to the principal frame and out again: equal to ~1 ulp where the body frame
is not principal).  A run with a Python ``torque=`` function cannot be rebuilt from its file (the
function is not in it): export it from Python with ``traj.to_dataframe()``.

CSV: a first line ``# units: name unit; …`` (``pandas.read_csv(path, comment="#")`` and
``numpy.genfromtxt`` skip it), then the header and one row per sample, every digit (``repr``).
Parquet: the units as JSON in the schema's metadata (key ``units``).  Written whole, atomically.
"""

from __future__ import annotations

import csv
import json
import os
import warnings
from pathlib import Path

import numpy as np

from rotlab.core import quaternion as quat
from rotlab.errors import InputError, RunFailure
from rotlab.recording import layout
from rotlab.recording.reader import read_series, read_text

FORMATS = (".csv", ".parquet")


def recorded_trajectory(recording: Path):
    """The ``Trajectory`` of a run recording, rebuilt from its scenario and state (module docstring)."""
    from rotlab.config.loader import parse_scenario
    from rotlab.scene.scene import build_scene
    from rotlab.trajectory import RunStats, Trajectory

    try:
        with warnings.catch_warnings():  # Rerun's reader warns about a damaged file before failing on it
            warnings.simplefilter("ignore")
            saved = json.loads(read_text(recording, layout.SCENARIO))
            t, q = read_series(recording, layout.QUATERNION)
            _, omega = read_series(recording, layout.OMEGA)
    except Exception:
        raise InputError(str(recording), "not a complete rotlab run recording with its scenario (another file, one cut short, or "
                                         "one written before /scenario was recorded: run it again with `rotlab run`)") from None
    if saved.get("python_torque"):
        raise InputError(str(recording), "this run had a Python torque function, which its file does not hold: "
                                         "export it from Python with traj.to_dataframe()")
    scene = build_scene(parse_scenario(saved["scenario"], source=str(recording)))
    t = _sample_times(scene.scenario.time.sample_times(), t)
    state = np.zeros((t.shape[0], scene.state0.shape[0]))
    state[:, 0:4] = q if scene.is_principal else quat.multiply_array(q, scene.axes_quaternion)  # Λ_P = Λ_U ∘ Λ_axes
    state[:, 4:7] = omega if scene.is_principal else omega @ scene.axes  # ω_P = axesᵀ ω_U
    if scene.has_work:
        _, work = read_series(recording, layout.WORK)
        state[:, 7] = work[:, 0]
    if scene.loads.drives is not None:  # the driven rotors' momenta, the state's last columns
        _, momenta = read_series(recording, layout.ROTOR_MOMENTUM)
        state[:, 8:] = momenta
    stats = RunStats(method="recorded", reason=f"read from {recording}", steps=0, rejected_steps=0, rhs_evaluations=0, seconds=0.0)
    return Trajectory(scene, stats, t, state, euler_angles=scene.scenario.output.euler_angles)


def _sample_times(grid: np.ndarray, recorded: np.ndarray) -> np.ndarray:
    """The run's own sample times: the timeline holds whole nanoseconds, so a recorded time within
    1 ns of the scenario's grid is that grid time; one that is not (a terminal event's) stays."""
    n = min(grid.shape[0], recorded.shape[0])
    out = recorded.copy()
    close = np.abs(grid[:n] - recorded[:n]) <= 1e-9
    out[:n][close] = grid[:n][close]
    return out


def export(recording: Path, output: Path) -> tuple[Path, int, int]:
    """Write the table of ``recording`` to ``output`` (.csv or .parquet); returns the path, the
    rows and the columns written."""
    suffix = output.suffix.lower()
    if suffix not in FORMATS:
        raise InputError("--output", f"'{output.name}': give a name ending in .csv or .parquet")
    if not recording.is_file():
        raise InputError(str(recording), "no such recording")
    from rotlab.recording.writer import check_output_path

    check_output_path(output, (recording,))
    columns = recorded_trajectory(recording).columns()
    tmp = output.with_name(f".{output.stem}.{os.getpid()}.tmp{suffix}")
    try:
        (_write_csv if suffix == ".csv" else _write_parquet)(tmp, columns)
        os.replace(tmp, output)
    except OSError as exc:
        raise RunFailure(f"could not write {output}: {exc.strerror or exc}") from None
    finally:
        tmp.unlink(missing_ok=True)
    return output, int(columns["t"][0].shape[0]), len(columns)


def _write_csv(path: Path, columns: dict[str, tuple[np.ndarray, str]]) -> None:
    names = list(columns)
    values = np.column_stack([columns[n][0] for n in names])
    with path.open("w", newline="", encoding="utf-8") as handle:
        handle.write("# units: " + "; ".join(f"{n} {columns[n][1]}" for n in names) + "\n")
        writer = csv.writer(handle)
        writer.writerow(names)
        for start in range(0, values.shape[0], 65536):  # rows as text a block at a time
            writer.writerows([[repr(float(v)) for v in row] for row in values[start:start + 65536]])


def _write_parquet(path: Path, columns: dict[str, tuple[np.ndarray, str]]) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    units = json.dumps({n: unit for n, (_, unit) in columns.items()}, ensure_ascii=False)
    table = pa.table({n: pa.array(np.ascontiguousarray(v, dtype=float)) for n, (v, _) in columns.items()})
    pq.write_table(table.replace_schema_metadata({"units": units}), path)
