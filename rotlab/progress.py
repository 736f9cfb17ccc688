"""One progress display for a whole run — integration and writing — on stderr.

On a terminal: a transient rich bar (gone when the run ends) with samples written, rate and ETA,
how far the integration has got, and "compiling numba kernels" while numba compiles (long on a
first run, when nothing else moves).  Elsewhere (CI logs, pipes): a plain line on stdout at most
every ``LINE_EVERY`` seconds, none for runs shorter than that (stderr then carries only the
one-line error of a run that fails).
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

LINE_EVERY = 10.0  # s between lines when stderr is not a terminal
COMPILING = "compiling numba kernels (once)"


class StreamProgress:
    """``progress(done, total)`` is the integration's callback; ``written(done, total)`` the writer's."""

    def __init__(self, label: str, stream: TextIO | None = None, unit: str = "samples") -> None:
        self.label = label
        self.unit = unit  # what ``written`` counts: samples (a run), frames (an animation)
        self.stream = sys.stderr if stream is None else stream
        self.started = time.perf_counter()
        self.integrated = 0
        self.done = 0
        self.last_line = self.started
        self.terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.lines = sys.stdout if stream is None else stream  # where the plain lines go (not a terminal)
        self._bar = None
        self._task = None

    def __call__(self, done: int, total: int) -> None:
        self.integrated = done
        self._show(total)

    def written(self, done: int, total: int) -> None:
        self.done = done
        self.integrated = max(self.integrated, done)  # a streamed chunk is written before its window reports
        self._show(total)

    def compiling(self, active: bool) -> None:
        """numba started (True) or finished (False) compiling a kernel (``compile_clock``'s announce)."""
        if not self.terminal:
            return  # the summary reports the compile time; a line here would only interleave the log
        if self._bar is None:
            self._open(None)
        self._bar.update(self._task, description=f"{self.label} · {COMPILING}" if active else self.label)

    def _show(self, total: int) -> None:
        now = time.perf_counter()
        if self.terminal:
            if self._bar is None:
                if now - self.started < 0.3:
                    return
                self._open(total)
            self._bar.update(self._task, completed=self.done, total=total, integrated=f"{self.integrated:,}")
        elif now - self.last_line >= LINE_EVERY:
            self.last_line = now
            rate = self.done / max(now - self.started, 1e-9)
            eta = (total - self.done) / rate if rate > 0 else float("inf")
            left = f"about {eta:,.0f} s left" if eta < float("inf") else "time left unknown"
            integrated = f"; integrated {self.integrated:,}" if self.unit == "samples" else ""
            self.lines.write(f"{self.label}: {self.done:,} of {total:,} {self.unit} written ({100 * self.done / max(total, 1):.0f}%"
                             f"{integrated}), {rate:,.0f} {self.unit}/s, {left}\n")
            self.lines.flush()

    def _open(self, total: int | None) -> None:
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TaskProgressColumn, TextColumn, TimeRemainingColumn

        self._bar = Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TaskProgressColumn(),
            MofNCompleteColumn(),
            TextColumn("samples · integrated {task.fields[integrated]} ·" if self.unit == "samples" else f"{self.unit} ·"),
            _RateColumn() if self.unit == "samples" else TextColumn(""),
            TimeRemainingColumn(),
            console=Console(file=self.stream),
            transient=True,
        )
        self._task = self._bar.add_task(self.label, total=total, integrated="0")
        self._bar.start()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None


def _rate_column_class():
    from rich.progress import ProgressColumn
    from rich.text import Text

    class RateColumn(ProgressColumn):
        """Samples written per second (rich's own speed columns count bytes)."""

        def render(self, task) -> Text:
            speed = task.finished_speed or task.speed
            return Text("" if speed is None else f"{speed / 1e6:.2f} M/s", style="progress.data.speed")

    return RateColumn


def _RateColumn():  # noqa: N802 — built on first use: rich is imported only when a bar is shown
    return _rate_column_class()()
