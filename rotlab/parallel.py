"""Local worker processes for batch runs and sweeps: one task per worker at a time (a case, or a
chunk of a sweep's cases), so that a worker's death, a task's time limit or a signal costs only
that task (a sweep runs a chunk whose worker died again case by case: then only its culprit fails).

Workers are ``spawn``ed: forking a process that already runs threads (numba's parallel layer,
Rerun's writer) is unsafe, and a spawned worker is a child of the main process, so it can ask the
kernel to kill it when the main process dies (a ``forkserver`` child is the forkserver's, which
outlives a killed main process while any worker holds its pipe).  Each worker imports rotlab
once (``preload``) and then runs task after task.  ``WarmWorkers`` starts them before the
tasks are known, so that their start-up overlaps the main process's own (``rotlab sweep``).

``run_tasks`` hands each worker one task over its own pipe — and, while tasks are short (under
``PREFETCH_BELOW``), the next one too, which the worker starts without waiting for the main
process — and waits on every busy worker's pipe and process sentinel at once:

* a result arrives → reported through ``on_end`` at once (a line per finished case);
* the worker process dies (``kill -9``, out of memory, a crash in compiled code) → that task
  ends as ``worker died (…)`` (or is retried, ``retries`` times), the task queued behind it (not
  started) goes back to the queue, a fresh worker takes its place and every other task goes on
  (a worker that died before it began its task, e.g. killed while it waited, costs that task
  nothing, once: it goes back to the queue too);
* a task exceeds ``timeout`` seconds → its worker is killed, the task ends as ``timed out``;
* SIGINT or SIGTERM in the main process → pending tasks are cancelled, workers terminated
  (none is left behind), and ``run_tasks`` returns what finished with ``stopped`` set to the
  signal: the caller writes its summary of those and exits 128 + signal.

Workers ignore SIGINT (Ctrl-C to the process group stops the batch through the main process,
without a traceback from every worker) and ask the kernel (Linux ``PR_SET_PDEATHSIG``) to kill
them when the main process dies, so even ``kill -9`` of the main process orphans nothing that
keeps computing.
"""

from __future__ import annotations

import ctypes
import importlib
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from multiprocessing.connection import Connection, wait
from multiprocessing.reduction import ForkingPickler
from typing import Any, Callable, Sequence

from rotlab.heap import keep_heap

RUN_MODULES = ("rotlab.api", "rotlab.checks", "rotlab.recording.writer")  # what running a case imports
STARTED = "started"  # what a worker sends when it begins a task
KILL_GRACE = 2.0  # s between SIGTERM and SIGKILL when workers are stopped
PREFETCH_BELOW = 0.05  # s: while tasks take less, each worker is handed its next task in advance (``_Pool``)
PREFETCH_BYTES = 1 << 15  # ... if it pickles to no more than this (a pipe holds it without blocking)
PR_SET_PDEATHSIG = 1


@dataclass
class TaskEnd:
    index: int  # position in the task list
    result: Any = None  # the function's return value (None when ``failure`` is set)
    failure: str | None = None  # "worker died (killed by SIGKILL)", "timed out after 5 s", …
    attempts: int = 1
    seconds: float = 0.0  # wall time of the last attempt
    pid: int | None = None  # the worker process of the last attempt (local workers)


@dataclass
class TaskRun:
    ends: list[TaskEnd]  # in the order they finished
    stopped: int | None = None  # the signal that stopped the run (SIGINT, SIGTERM), else None
    running: dict[int, int] = field(default_factory=dict)  # task → worker pid, for tasks running when it stopped


class Stopped(Exception):
    """Raised in the main process by SIGINT/SIGTERM while tasks run."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def context() -> multiprocessing.context.BaseContext:
    return multiprocessing.get_context("spawn")


def run_tasks(fn: Callable[..., Any], tasks: Sequence[tuple], jobs: int, *, timeout: float | None = None,
              retries: int = 0, on_end: Callable[[TaskEnd], None] | None = None, preload: Sequence[str] = RUN_MODULES,
              warm: WarmWorkers | None = None) -> TaskRun:
    """Run ``fn(*task)`` for every task in at most ``jobs`` worker processes (module docstring).
    ``fn`` must be importable (module level) and should not raise: an exception it raises ends
    its task with the exception's text as the failure.  Each worker imports the ``preload``
    modules before its first task: a task's ``timeout`` runs from the moment its worker starts
    it, so a worker's start-up (imports) never counts against a case.  ``warm``: workers
    started earlier for this ``fn`` and ``preload``, used before new ones are started."""
    size = max(1, min(jobs, len(tasks)))
    pool = _Pool(fn, size, tuple(preload), warm.take(fn, preload, size) if warm is not None else [])
    pending: deque[tuple[int, int]] = deque((i, 1) for i in range(len(tasks)))  # (task, attempt)
    ends: list[TaskEnd] = []
    unbegun: set[int] = set()  # tasks whose worker died before it began them (said "started")

    def finish(end: TaskEnd) -> None:
        ends.append(end)
        if on_end is not None:
            on_end(end)

    with signals_raise_stopped():
        try:
            while pending or pool.busy():
                while pending and pool.has_room():
                    index, attempt = pending.popleft()
                    if not pool.start(index, attempt, tasks[index]):  # not now (see _Pool.start): after the wait below
                        pending.appendleft((index, attempt))
                        break
                for worker, event in pool.wait(timeout):
                    if worker.task is None:  # died while holding no task (killed from outside): replaced
                        pool.discard(worker)
                        continue
                    index, attempt, seconds, pid = worker.task, worker.attempt, worker.elapsed(time.monotonic()), worker.process.pid
                    if event == "result":
                        status, payload = worker.result
                        if status == "ok":
                            finish(TaskEnd(index, payload, None, attempt, seconds, pid))
                        else:
                            finish(TaskEnd(index, None, payload, attempt, seconds, pid))
                        pool.done(worker, seconds)
                        continue
                    pending.extendleft(reversed(pool.discard(worker)))  # the tasks queued behind it never started
                    if event == "died":
                        how = f"worker died ({_exit_text(worker.process.exitcode)})"
                        if worker.started is None and index not in unbegun:  # died before it began the task (a warm
                            unbegun.add(index)  # worker killed while it waited): once without an attempt's cost
                            pending.appendleft((index, attempt))
                        elif attempt <= retries:
                            pending.appendleft((index, attempt + 1))
                        else:
                            finish(TaskEnd(index, None, how + _attempts_text(attempt), attempt, seconds, pid))
                    else:  # timed out
                        finish(TaskEnd(index, None, f"timed out after {timeout:g} s (per-case --timeout)", attempt, seconds, pid))
            pool.close(kill=False)
        except Stopped as stop:
            running = {w.task: w.process.pid for w in pool.workers if w.task is not None}
            pool.close(kill=True)
            return TaskRun(ends, stop.signum, running)
        except BaseException:
            pool.close(kill=True)
            raise
    return TaskRun(ends, None)


def _attempts_text(attempts: int) -> str:
    return f" on each of {attempts} attempts" if attempts > 1 else ""


def _exit_text(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


_EXIT_AFTER_STOP = False


def exit_after_stop() -> None:
    """For a command that ends once its tasks are stopped: after a stop signal, further SIGINT
    and SIGTERM stay ignored, so the summary of what finished is written and the exit code is
    128 + the first signal (not a second Ctrl-C's KeyboardInterrupt during exit)."""
    global _EXIT_AFTER_STOP
    _EXIT_AFTER_STOP = True


class signals_noted:
    """SIGINT and SIGTERM noted in ``signum`` — the first one: a second signal (Ctrl-C pressed
    again) is ignored — for a loop to stop at its next safe point: nothing is raised into the
    code that runs, so no half-done step (a block's rows written but not counted, a case's
    validation) is cut.  ``signals_raise_stopped`` raises instead."""

    def __enter__(self) -> signals_noted:
        self.saved: dict[int, Any] = {}
        self.signum: int | None = None
        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                self.saved[signum] = signal.signal(signum, self._on_signal)
        return self

    def __exit__(self, *exc: object) -> None:
        for signum, handler in self.saved.items():
            signal.signal(signum, signal.SIG_IGN if self.signum is not None and _EXIT_AFTER_STOP else handler)

    def _on_signal(self, signum: int, frame: object) -> None:
        if self.signum is None:
            self.signum = signum


class signals_raise_stopped(signals_noted):
    """SIGINT and SIGTERM raise ``Stopped`` in the main thread while tasks run — once: a second
    signal while the workers are being stopped is ignored, so the summary of what finished is
    still written."""

    def _on_signal(self, signum: int, frame: object) -> None:
        if self.signum is None:
            self.signum = signum
            raise Stopped(signum)


@dataclass
class _Sent:
    """A task handed to a worker: the first in its queue runs, the next waits in the pipe."""

    index: int
    attempt: int
    sent: float  # time.monotonic() when sent
    started: float | None = None  # when the worker began it (its STARTED message)


class _Worker:
    def __init__(self, fn: Callable[..., Any], preload: tuple[str, ...]) -> None:
        self.conn, child = context().Pipe(duplex=True)
        self.process = context().Process(target=_serve, args=(fn, child, preload, os.getpid()), daemon=True)
        self.process.start()
        child.close()
        self.queue: deque[_Sent] = deque()  # tasks sent, in order: the head is running (or about to)
        self.result: Any = None
        self.told = False  # asked to stop (``tell_to_stop``)

    @property
    def task(self) -> int | None:
        """The task the worker runs (None: idle)."""
        return self.queue[0].index if self.queue else None

    @property
    def attempt(self) -> int:
        return self.queue[0].attempt

    @property
    def started(self) -> float | None:
        return self.queue[0].started if self.queue else None

    def elapsed(self, now: float) -> float:
        head = self.queue[0]
        return now - (head.started if head.started is not None else head.sent)

    def tell_to_stop(self, kill: bool) -> None:
        """SIGTERM (``kill``), or ask the worker to return after its tasks; does not wait."""
        if self.told:
            return
        self.told = True
        try:
            if kill:
                self.process.terminate()
            else:
                self.conn.send(None)  # finish: the worker returns
        except (OSError, ValueError):
            pass

    def stop(self, kill: bool) -> None:
        self.tell_to_stop(kill)
        self.process.join(KILL_GRACE)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()
        self.conn.close()


class WarmWorkers:
    """Workers started before their tasks are known, so that their start-up (spawn, imports) runs
    while the main process still imports and plans.  ``run_tasks`` takes as
    many as it needs when given the same ``fn`` and ``preload``; the others are stopped then,
    and every one left is stopped when the ``with`` block ends (an error or Ctrl-C in the
    planning included).  A warm worker that died waiting is replaced when its first task fails
    to reach it."""

    def __init__(self, fn: Callable[..., Any], count: int, preload: Sequence[str] = RUN_MODULES) -> None:
        self.fn, self.preload = fn, tuple(preload)
        self.workers: list[_Worker] = []
        self.stopping: list[_Worker] = []
        for _ in range(max(1, count)):
            self.workers.append(_Worker(fn, self.preload))

    def take(self, fn: Callable[..., Any], preload: Sequence[str], count: int) -> list[_Worker]:
        """Up to ``count`` workers for ``fn`` and ``preload`` (none for another function); the
        rest are told to stop."""
        taken = self.workers[:count] if fn is self.fn and tuple(preload) == self.preload else []
        self.release(keep=taken)
        return taken

    def release(self, keep: Sequence[_Worker] = ()) -> None:
        """Tell every worker not in ``keep`` to stop (killed: none has a task); ``close`` waits for them."""
        for worker in self.workers:
            if worker not in keep:
                worker.tell_to_stop(kill=True)
                self.stopping.append(worker)
        self.workers = []

    def close(self) -> None:
        self.release()
        for worker in self.stopping:
            worker.stop(kill=True)
        self.stopping = []

    def __enter__(self) -> WarmWorkers:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Pool:
    """Workers, each holding its running task and — while tasks are short — the next one, so
    that it starts that one as soon as it sends a result instead of waiting for the main process
    (a round trip, as long as a short case itself).  A queued task has not started:
    a worker's death or time-out puts it back in the queue without costing it an attempt."""

    def __init__(self, fn: Callable[..., Any], size: int, preload: tuple[str, ...], ready: list[_Worker]) -> None:
        self.fn, self.size, self.preload = fn, size, preload
        self.workers: list[_Worker] = []
        self.ready = list(ready)  # started already (``WarmWorkers``): used before new ones are started
        self.recent: deque[float] = deque(maxlen=8)  # seconds of the last tasks that finished

    def busy(self) -> bool:
        return any(w.queue for w in self.workers)

    def depth(self) -> int:
        """Tasks a worker may hold: 2 once the recent tasks all took under ``PREFETCH_BELOW`` s
        (a long task would keep the next one waiting while another worker is idle), else 1."""
        short = len(self.recent) == self.recent.maxlen and max(self.recent) < PREFETCH_BELOW
        return 2 if short else 1

    def has_room(self) -> bool:
        return len(self.workers) < self.size or any(len(w.queue) < self.depth() for w in self.workers)

    def start(self, index: int, attempt: int, args: tuple) -> bool:
        """Hand the task to the least busy worker (a new one while there are fewer than ``size``).
        False when it was not sent: that worker is busy and the task is larger than
        ``PREFETCH_BYTES`` (sent while the worker writes a large result, both would block), or the
        worker turns out to have died (its pipe is closed; ``wait`` reports it)."""
        if len(self.workers) < self.size and all(w.queue for w in self.workers):
            worker = self.ready.pop(0) if self.ready else _Worker(self.fn, self.preload)
            self.workers.append(worker)
        else:
            worker = min(self.workers, key=lambda w: len(w.queue))
        payload = ForkingPickler.dumps((index, args))  # what Connection.send writes; recv() reads it back
        if worker.queue and len(payload) > PREFETCH_BYTES:
            return False
        try:
            worker.conn.send_bytes(payload)
        except OSError:  # BrokenPipeError: it died running its task (or idle); ``wait`` reports it
            return False
        worker.queue.append(_Sent(index, attempt, time.monotonic()))
        return True

    def done(self, worker: _Worker, seconds: float) -> None:
        """The worker's running task has ended; the next in its queue is now its running task."""
        worker.queue.popleft()
        self.recent.append(seconds)

    def discard(self, worker: _Worker) -> list[tuple[int, int]]:
        """Stop ``worker`` (dead or timed out); returns its queued tasks that never started."""
        self.workers.remove(worker)
        worker.stop(kill=True)
        return [(sent.index, sent.attempt) for sent in list(worker.queue)[1:]]

    def wait(self, timeout: float | None) -> list[tuple[_Worker, str]]:
        """Block until a busy worker has a result, dies, or passes its deadline."""
        busy = [w for w in self.workers if w.queue]
        running = [w.started for w in busy if w.started is not None]
        limit = None
        if timeout is not None and running:
            limit = max(0.0, min(running) + timeout - time.monotonic())
        idle = [w.process.sentinel for w in self.workers if not w.queue]  # an idle worker can die too
        wait([obj for w in busy for obj in (w.conn, w.process.sentinel)] + idle, limit)
        events = [(w, "died") for w in self.workers if not w.queue and not w.process.is_alive()]
        for w in busy:
            result = self._receive(w)
            if result:
                events.append((w, "result"))
            elif not w.process.is_alive():
                w.process.join()
                events.append((w, "died"))
            elif timeout is not None and w.started is not None and time.monotonic() - w.started >= timeout:
                events.append((w, "timeout"))
        return events

    @staticmethod
    def _receive(w: _Worker) -> bool:
        """Read what ``w`` sent: "started" marks its running task's start; True when that task's
        result came (a result sent just before the worker died still counts)."""
        while w.conn.poll():
            try:
                message = w.conn.recv()
            except (EOFError, OSError):
                return False
            if message == STARTED:
                w.queue[0].started = time.monotonic()
                continue
            w.result = message
            return True
        return False

    def close(self, kill: bool) -> None:
        self.workers += self.ready  # warm workers no task reached
        self.ready = []
        for worker in self.workers:  # all at once (each takes a while to exit), then wait for each
            worker.tell_to_stop(kill)
        for worker in self.workers:
            worker.stop(kill)
        self.workers = []


def _serve(fn: Callable[..., Any], conn: Connection, preload: tuple[str, ...], parent: int) -> None:
    """Worker loop: run tasks from ``conn`` until told to stop (None) or the pipe closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent(parent)
    keep_heap()  # the tasks' NumPy temporaries reuse the heap instead of faulting in fresh pages
    from rotlab.withheld import withhold_pandas, withhold_scipy_linalg

    withhold_scipy_linalg()  # (rotlab.withheld)
    for module in preload:
        importlib.import_module(module)
    if "pyarrow" in sys.modules:  # it writes recordings, and holds no pandas objects (rotlab.withheld)
        withhold_pandas()
    while True:
        try:
            item = conn.recv()
        except (EOFError, OSError):
            return
        if item is None:  # done: every task's files are finished; skip the interpreter's teardown
            from rotlab.ending import leave

            leave(0)
        index, args = item
        conn.send(STARTED)
        try:
            reply = ("ok", fn(*args))
        except Exception as exc:  # fn should not raise; if it does, the task fails, the worker lives
            reply = ("raised", f"{type(exc).__name__}: {exc}")
        conn.send(reply)


def _die_with_parent(parent: int) -> None:
    """Linux: SIGKILL this worker when its parent (the main process) exits: no orphan computes on."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: workers still exit when their pipe closes
        return
    if os.getppid() != parent:  # the parent already died before prctl took effect
        os._exit(1)
