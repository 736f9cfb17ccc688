"""Python API for notebooks and scripts — the same objects the CLI uses.

    >>> import rotlab
    >>> traj = rotlab.simulate("configs/lagrange.toml")
    >>> traj.t, traj.quaternion, traj.omega, traj.L_space, traj.total
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping

from rotlab import interrupts
from rotlab.config import load_scenario, parse_scenario
from rotlab.config.models import Scenario
from rotlab.errors import Interrupted, RunFailure, valid_samples
from rotlab.methods.base import ProgressCallback, Settings
from rotlab.methods.choose import Choices, choose_method
from rotlab.methods.compile_time import compile_clock
from rotlab.scene.scene import Scene, build_scene
from rotlab.trajectory import RunStats, RunSummary, Trajectory, build_trajectory

import numpy as np

if TYPE_CHECKING:
    from rotlab.events import EventWatch
    from rotlab.methods.base import Method
    from rotlab.progress import StreamProgress
    from rotlab.recording.sink import RecordingSink

Plan = tuple["Method", str, Settings, "np.ndarray"]  # (method, why it runs, its settings, the sample times)

CHOICES = Choices()  # auto's choices, kept by their inputs for every run of this process (a pure function's memo)


def load(
    path: str | Path, *, method: str | None = None, duration: float | None = None, overrides: Mapping[str, Any] | None = None
) -> Scenario:
    """Read and validate a scenario file.  ``method``, ``duration`` (s: end = start + duration)
    and ``overrides`` ({"initial.omega": [0, 0, 50], "loads[0].value[2]": 1.0}) change the file's
    values and are validated like them."""
    changes = dict(overrides or {})
    if method is not None:
        changes["solver.method"] = method
    return load_scenario(path, changes, duration=duration)


def simulate(
    scenario: Scenario | str | Path,
    *,
    method: str | None = None,
    duration: float | None = None,
    overrides: Mapping[str, Any] | None = None,
    check: bool = True,
    progress: ProgressCallback | None = None,
    torque: Callable | None = None,
    frame: str = "body",
) -> Trajectory:
    """Run a scenario (object or file path) and return its ``Trajectory`` (user's frames).

    ``method``, ``duration`` (s) and ``overrides`` ({"initial.omega[2]": 50.0, ...}) change the
    scenario and are validated as in the file (``InputError`` naming the key).  A run that
    stops early (non-finite state, step budget, Ctrl-C) raises ``RunFailure`` (``Interrupted``
    for Ctrl-C) with the valid part in ``exc.trajectory``; with ``check=False`` it is returned
    instead, with ``traj.ok`` False and the reason in ``traj.stats.failure``.
    ``torque``: an extra load, a function fn(t, q, omega) -> (Mx, My, Mz) of the time, Λ and ω
    (user's body frame), M in ``frame`` ("body" or "space"), compiled by numba."""
    scenario = scenario_of(scenario, method=method, duration=duration, overrides=overrides)
    traj = run_scene(build_scene(scenario, torque=torque, frame=frame), progress=progress)
    if check and not traj.ok:
        stopped = Interrupted if traj.stats.interrupted else RunFailure
        raise stopped(f"run stopped: {traj.stats.failure}; {valid_samples(traj.t.shape[0], 'exc.trajectory')}", trajectory=traj)
    return traj


def scenario_of(scenario: Scenario | str | Path, *, method: str | None = None, duration: float | None = None,
                overrides: Mapping[str, Any] | None = None) -> Scenario:
    """The scenario of a file or a ``Scenario``, with ``method``, ``duration`` and ``overrides``
    applied and validated as in the file (the object itself when there are none)."""
    if not isinstance(scenario, Scenario):
        return load(scenario, method=method, duration=duration, overrides=overrides)
    if method is None and duration is None and not overrides:
        return scenario
    changes = dict(overrides or {})
    if method is not None:
        changes["solver.method"] = method
    raw = scenario.model_dump(mode="json", exclude_unset=True)
    return parse_scenario(raw, source=scenario.title or "scenario", overrides=changes, duration=duration)


def save(path: str | Path, traj: Trajectory) -> Path:
    """Write ``traj`` as the Rerun recording ``rotlab run`` writes (numpy's argument order,
    like ``np.save``): a temporary file, verified and renamed when complete.  Returns the path."""
    from rotlab.recording.writer import write_recording

    return write_recording(traj, path)


def show(traj: Trajectory, width: int | None = None, height: int | None = None):
    """The Rerun viewer in a Jupyter notebook, showing ``traj`` as ``rotlab run``'s recording does
    (the cell's output: ``rotlab.show(traj)``; needs ``pip install 'rotlab[notebook]'``).  Beside
    ``save``, not a ``Trajectory`` method: a run's data knows nothing of the recording."""
    from rotlab.recording.notebook_view import show as widget

    return widget(traj, width, height)


def run_scene(scene: Scene, progress: ProgressCallback | None = None, plan: Plan | None = None) -> Trajectory:
    """Run ``scene`` whole: every sample in memory (the Python API).  ``plan``: the method, why,
    settings and sample times decided already (a sweep's one choice for all its cases), else
    ``_plan``'s."""
    from rotlab.methods.stepping import controlled, current_control

    chosen, reason, settings, t = _plan(scene) if plan is None else plan
    with compile_clock() as compiling:  # numba compile / cache load, reported apart from integration
        started = time.perf_counter()
        watch = _event_watch(scene, chosen, t, settings)
        with controlled(replace(current_control(), watch=watch)):
            solution = chosen.solve(scene, t, settings, progress)
        seconds = time.perf_counter() - started
    stats = _stats(chosen, reason, solution, seconds, compiling.seconds)
    if watch is None:
        return build_trajectory(scene, solution, stats, euler_angles=scene.scenario.output.euler_angles)
    if watch.final is not None:  # a terminal event ended the run: its state is the last sample
        n = solution.valid
        solution.t = np.append(solution.t[:n], watch.final[0])
        solution.state = np.concatenate([solution.state[:n], watch.final[1][None, :]])
        solution.valid = n + 1
        stats.details = {**stats.details, "ended by": watch.ended_by}
    traj = build_trajectory(scene, solution, stats, euler_angles=scene.scenario.output.euler_angles)
    traj.events = watch.logs()
    return traj


def _event_watch(scene: Scene, chosen: Method, t: np.ndarray, settings: Settings) -> EventWatch | None:
    """The watch that finds the scene's events on ``chosen``'s local solution (None without events)."""
    from rotlab.events import EventWatch, compile_events

    compiled = compile_events(scene)
    return None if compiled is None else EventWatch(compiled, lambda: chosen.local_solution(scene, t, settings))


def stream_scene(scene: Scene, sink: RecordingSink, progress: StreamProgress | None = None,
                 timeout: float | None = None) -> tuple[RunSummary, float]:
    """Run ``scene`` streamed into ``sink`` (``rotlab run``): chunks are converted and written as
    the method produces them, so memory does not grow with the run.  The derived and visual
    series keep every k-th sample (k from ``[output] visual_samples``).  Stops cleanly on Ctrl-C,
    a failure or ``timeout`` (wall-clock seconds), keeping what was written; the sink is left
    open for the caller to close (to the target or the partial path) or abort.
    Returns the summary and the seconds spent converting and writing."""
    from rotlab import compile_apart
    from rotlab.methods.stepping import RunControl, controlled, timeout_message
    from rotlab.recording.stream import ChunkStream
    from rotlab.recording.writer import RecordingWriter, full_rate_chunk_rows

    chosen, reason, settings, t = _plan(scene, lazy_times=True)
    n = t.shape[0]
    stride = max(1, -(-n // scene.scenario.output.visual_samples))
    stats = RunStats(method=chosen.name, reason=reason, steps=0, rejected_steps=0, rhs_evaluations=0, seconds=0.0)
    deadline = None if timeout is None else time.monotonic() + timeout
    announce = None if progress is None else progress.compiling
    # numba compiles (or loads) the method's kernel and the writer's; that time is kept apart from both
    with compile_clock(announce=announce) as compiling:
        try:
            apart = compile_apart.prepare(scene, chosen, settings, announce, deadline) if n >= compile_apart.LONG_RUN else None
        except KeyboardInterrupt:  # Ctrl-C while a child compiled the kernels (it is killed): nothing was run
            apart = compile_apart.Outcome(True, 0.0, interrupted=True)
        writer = RecordingWriter(sink, stride=stride, chunk_rows=full_rate_chunk_rows(n))
        stream = ChunkStream(scene, stats, writer, scene.scenario.output.euler_angles, progress, n, clock=compiling)
        watch = _event_watch(scene, chosen, t, settings)
        control = RunControl(consumer=stream, deadline=deadline, timeout=timeout, watch=watch)
        if apart is not None and (apart.timed_out or apart.interrupted):  # stopped before the first sample
            start = scene.scenario.time.start
            stats.failure = interrupts.stopped_at(start) if apart.interrupted else timeout_message(control, start)
            stats.failure += " (while a child process compiled the kernels)"
            stats.interrupted = apart.interrupted
            return stream.summary(), 0.0
        with controlled(control):
            started, compiled_before = time.perf_counter(), compiling.seconds  # the rehearsal's cache loads came before
            solution = chosen.solve(scene, t, settings, progress)
            seconds = time.perf_counter() - started - stream.seconds  # integration + its compiling
        compiling.released()  # nothing compiles now; a compile cut short by Ctrl-C never announced its end
        final = _stats(chosen, reason, solution, seconds, compiling.seconds - compiled_before)
        vars(stats).update(vars(final))  # the chunks hold this object: the report sees the final figures
        if watch is not None:
            if watch.final is not None:  # a terminal event ended the run: its state is the last sample
                stream.rows(solution.valid, np.array([watch.final[0]]), watch.final[1][None, :])
                stats.details = {**stats.details, "ended by": watch.ended_by}
            stream.events = watch.logs()
        stats.details = {**stats.details, "visual series": f"every {stride} samples" if stride > 1 else "every sample"}
        try:
            summary = stream.finish()
        except KeyboardInterrupt:  # Ctrl-C while the last chunk and the static part were sent
            stats.failure, stats.interrupted = interrupts.stopped_at(stream.last_time), True
            summary = stream.summary()
        stats.compile_seconds = compiling.seconds  # the writer's static part may have compiled too
        if apart is not None and apart.seconds:
            stats.compile_seconds += apart.seconds
            stats.details = {**stats.details, "kernels": "compiled in a child process" if apart.compiled_apart else "compiled in this process (a child process could not)"}
    if stats.interrupted or summary.samples < solution.valid:  # Ctrl-C, maybe inside the writer: say what was kept
        stats.failure, stats.interrupted = interrupts.stopped_at(summary.end), True
    return summary, stream.seconds


def record(scene: Scene, sink: RecordingSink, progress: StreamProgress | None = None, timeout: float | None = None,
           before_close: Callable[[], None] | None = None) -> tuple[RunSummary, float, Path | None]:
    """``stream_scene`` into ``sink``, then finish the file: verified and renamed to the target,
    or to ``NAME.partial.rrd`` when the run stopped early (an existing recording is never
    replaced by an incomplete one).  On an error the temporary file is removed.  Returns the
    summary, the seconds spent writing and the file written (None without one, or when no sample was sent).
    ``before_close``: runs between the end of the run and the end of the stream (``--serve-web``
    keeps serving there until Ctrl-C), unless a Ctrl-C stopped the run: one Ctrl-C ends both."""
    from rotlab.interrupts import deferred
    from rotlab.recording.writer import partial_path

    try:
        try:
            run, writing = stream_scene(scene, sink, progress, timeout)
        finally:
            if progress is not None:
                progress.close()
        if before_close is not None and not run.stats.interrupted:  # (after a Ctrl-C: that one ends the stream too)
            before_close()
        if run.stats.failure and run.samples == 0:  # stopped before the first sample was sent: no file at all
            sink.abort()
            return run, writing, None
        with deferred(deliver=False):  # the file is finished whole, Ctrl-C or not
            final = sink.close(partial_path(sink.target) if run.stats.failure and sink.target is not None else None)
    except BaseException:
        sink.abort()
        raise
    return run, writing, final


def _plan(scene: Scene, lazy_times: bool = False) -> Plan:
    """(method, why, settings, sample times); ``lazy_times``: a ``SampleTimes`` (no array)."""
    from rotlab.methods.stepping import SampleTimes

    s, time_ = scene.scenario.solver, scene.scenario.time
    t = SampleTimes(time_.start, time_.end, time_.sample_count) if lazy_times else time_.sample_times()
    settings = Settings.of(s)
    chosen, reason, settings = choose_method(scene, s.method, settings, t, CHOICES)
    return chosen, reason, settings, t


def _stats(chosen, reason: str, solution, seconds: float, compile_seconds: float) -> RunStats:
    """Run statistics; ``seconds`` includes the ``compile_seconds`` of numba, reported apart."""
    return RunStats(
        method=chosen.name,
        reason=reason,
        steps=solution.steps,
        rejected_steps=solution.rejected_steps,
        rhs_evaluations=solution.rhs_evaluations,
        seconds=max(seconds - compile_seconds, 0.0),
        compile_seconds=compile_seconds,
        failure=solution.failure,
        interrupted=solution.interrupted,
        details=solution.details,
    )
