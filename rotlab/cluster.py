"""Run tasks on an existing Dask cluster (``--dask tcp://HOST:PORT``) with the same contract as
``rotlab.parallel.run_tasks``: each task is reported as it finishes (``on_end``); a task whose
workers keep dying (Dask's ``KilledWorker``, after the scheduler's own retries) or that raises
ends as that task's failure while the others complete; SIGINT/SIGTERM cancel what is pending and
return what finished.  A running Dask task cannot be stopped from the client, so there is no
per-task time limit here (``--timeout`` is refused with ``--dask``)."""

from __future__ import annotations

import time
from typing import Any, Callable, Sequence

from rotlab.errors import InputError
from rotlab.parallel import Stopped, TaskEnd, TaskRun, signals_raise_stopped

CONNECT_TIMEOUT = "15s"


def connect(address: str):
    """A ``dask.distributed.Client`` for ``address``; every failure is a one-line input error."""
    try:
        from dask.distributed import Client
    except ImportError:
        raise InputError("--dask", "Dask is not installed: pip install 'rotlab[dask]'") from None
    try:
        return Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as exc:
        raise InputError("--dask", f"cannot reach a Dask scheduler at {address}: {exc}") from None
    except (ValueError, TypeError) as exc:
        raise InputError("--dask", f"not a scheduler address ({exc}): give tcp://HOST:PORT") from None


def run_on_dask(fn: Callable[..., Any], tasks: Sequence[tuple], address: str, *, retries: int = 0,
                on_end: Callable[[TaskEnd], None] | None = None) -> TaskRun:
    from dask.distributed import as_completed

    client = connect(address)
    ends: list[TaskEnd] = []
    started = time.monotonic()
    with client, signals_raise_stopped():
        futures = [client.submit(fn, *task, pure=False, retries=retries) for task in tasks]
        index_of = {f.key: i for i, f in enumerate(futures)}
        try:
            for future in as_completed(futures):
                index = index_of[future.key]
                try:
                    end = TaskEnd(index, future.result(), None, seconds=time.monotonic() - started)
                except Exception as exc:  # KilledWorker, a raising task: this task only
                    name = type(exc).__name__
                    what = "worker died" if name == "KilledWorker" else "task raised"
                    end = TaskEnd(index, None, f"{what} ({name}: {exc})", seconds=time.monotonic() - started)
                ends.append(end)
                if on_end is not None:
                    on_end(end)
        except Stopped as stop:
            client.cancel(futures)
            return TaskRun(ends, stop.signum)
    return TaskRun(ends, None)
