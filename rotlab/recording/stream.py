"""The streaming pipeline's middle: rows of state from a method (``RowConsumer``) become chunks
of the run's diagnostics (``build_chunk``) and go to the ``RecordingWriter`` as they come.

Memory is bounded by ``FLUSH_ROWS`` (the chunk being converted) and the ``Thinned`` copy for the
static paths, whatever the run's length; the free heap the chunks leave is given back as the run
goes (``rotlab.heap.HeapTrimmer``).  The drifts are measured from the run's first sample
(``Reference``), the Euler angles unwrapped across chunks, and the maxima of the drifts kept for
the summary.
"""

from __future__ import annotations

import time

import numpy as np

from rotlab import interrupts
from rotlab.heap import HeapTrimmer
from rotlab.methods.compile_time import CompileClock
from rotlab.recording.writer import RecordingWriter, Thinned
from rotlab.scene.scene import Scene
from rotlab.trajectory import Reference, RunStats, RunSummary, build_chunk, reference_of

FLUSH_ROWS = 1 << 14  # rows converted together (the writer sends the state in chunks of writer.full_rate_chunk_rows)
FLUSH_SECONDS = 0.5  # ... or whatever has come in this long: a slow run is seen (and kept) as it goes


class ChunkStream:
    """A ``RowConsumer`` (see ``rotlab.methods.stepping``) that writes the run as it is produced."""

    def __init__(self, scene: Scene, stats: RunStats, writer: RecordingWriter, euler_angles: bool,
                 progress=None, total: int = 0, clock: CompileClock | None = None) -> None:
        self.scene, self.stats, self.writer, self.euler_angles = scene, stats, writer, euler_angles
        self.clock = CompileClock() if clock is None else clock  # numba's compile time, kept out of ``seconds``
        self.progress, self.total = progress, total
        self.pending_t: list[np.ndarray] = []
        self.pending_state: list[np.ndarray] = []
        self.pending = 0
        self.written = 0  # samples sent to the sink, all series
        self.reference: Reference | None = None
        self.previous_angles: np.ndarray | None = None
        self.drift = {name: 0.0 for name in scene.invariants}
        self.thinned = Thinned()
        self.first_time = self.last_time = 0.0
        self.seconds = 0.0  # spent converting and sending (not compiling)
        self.events: dict = {}  # the run's events (``rotlab.events``), set when it ends
        self.flushed_at = time.monotonic()
        self.heap = HeapTrimmer()  # the chunks' temporaries leave free pages in glibc's heap: give them back

    def rows(self, start: int, t: np.ndarray, state: np.ndarray) -> None:
        self.pending_t.append(t.copy())
        self.pending_state.append(state.copy())
        self.pending += t.shape[0]
        if self.pending >= FLUSH_ROWS or time.monotonic() - self.flushed_at > FLUSH_SECONDS:
            self.flush()

    def flush(self) -> None:
        """Convert and send the pending rows, whole: Ctrl-C (or SIGTERM) is held while a chunk is
        converted and written (a short block) and raised after it, so the file and ``written`` agree."""
        if not self.pending:
            return
        with interrupts.deferred():
            self._flush()

    def _flush(self) -> None:
        started = self._started()
        self.flushed_at = time.monotonic()
        t, state = np.concatenate(self.pending_t), np.concatenate(self.pending_state)
        self.pending_t, self.pending_state, self.pending = [], [], 0
        start = self.written
        with np.errstate(over="ignore", invalid="ignore"):
            if self.reference is None:
                self.reference = reference_of(self.scene, state[0])
                self.first_time = float(t[0])
            chunk = build_chunk(self.scene, self.stats, t, state, self.reference, self.euler_angles, self.previous_angles)
            for name, values in chunk.invariants.items():
                finite = values[np.isfinite(values)]
                worst = float(np.max(np.abs(finite))) if finite.size else 0.0
                self.drift[name] = max(self.drift[name], worst if finite.size == values.size else float("inf"))
        self.thinned.add(start, t, state)
        self.writer.write(chunk, start)
        if chunk.euler_angles is not None:
            self.previous_angles = chunk.euler_angles[-1].copy()
        self.written += t.shape[0]
        self.last_time = float(t[-1])
        self.heap.trim()
        self._stopped(started)
        if self.progress is not None:
            self.progress.written(self.written, self.total)

    def summary(self) -> RunSummary:
        return RunSummary(self.scene, self.stats, self.written, self.first_time, self.last_time, dict(self.drift), self.events)

    def finish(self) -> RunSummary:
        """Send what is pending, then the static part from the thinned run; returns the summary."""
        with interrupts.deferred():  # the pending rows and the writer's collected ones (counted in ``written``) go out whole
            self.flush()
            self.writer.send_full_rate()
        started = self._started()
        summary = self.summary()
        t, state = self.thinned.arrays()
        # with its Euler angles when the run has them: the final layout is built from these samples,
        # and without them it had no θ, ψ or spin-rate plot (a heavy top's nutation)
        thinned = build_chunk(self.scene, self.stats, t, state, self.reference, self.euler_angles, None) if t.shape[0] else None
        self.writer.finish(summary, thinned)
        self._stopped(started)
        return summary

    def _started(self) -> tuple[float, float]:
        return time.perf_counter(), self.clock.seconds

    def _stopped(self, started: tuple[float, float]) -> None:
        """Add the time since ``started`` to ``seconds``, less what numba spent compiling in it."""
        wall, compiling = started
        self.seconds += max(0.0, (time.perf_counter() - wall) - (self.clock.seconds - compiling))
