"""Faults in batch/sweep runs, with the installed CLI, real processes and real signals (issue 17,
items 4-7): a dead worker costs one case; SIGINT/SIGTERM stop promptly, orphan nothing and keep
the summary; a per-case time limit; an unwritable output directory is refused before any case."""

from __future__ import annotations

import json
import math
import operator
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rotlab.parallel import run_tasks
from tests.conftest import CONFIGS, VALID_BODY

psutil = pytest.importorskip("psutil")

QUICK = VALID_BODY + "[initial]\nomega = [1, 0.1, 0]\n[time]\nend = 1.0\nsample_rate = 10\n"
# 1e11 rk4 steps: hours of compiled work, far longer than any test waits (the tests stop it)
SLOW = (VALID_BODY + '[initial]\nomega = [1, 0.1, 0]\n[time]\nend = 100.0\nsample_rate = 10\n'
        '[solver]\nmethod = "rk4"\nstep = 1e-9\nmax_steps = 100_000_000_000\n')


def rotlab_command() -> list[str]:
    script = Path(sys.executable).with_name("rotlab")
    return [str(script)] if script.exists() else [sys.executable, "-m", "rotlab"]


@pytest.fixture
def suite(tmp_path) -> Path:
    """a_slow.toml (runs for minutes, started first) and two quick cases."""
    folder = tmp_path / "suite"
    folder.mkdir()
    (folder / "a_slow.toml").write_text(SLOW, encoding="utf-8")
    for name in ("b_quick.toml", "c_quick.toml"):
        (folder / name).write_text(QUICK, encoding="utf-8")
    return folder


@pytest.fixture
def batches():
    """Start ``Batch`` runs; whatever a failing test leaves running is killed at teardown."""
    started: list[Batch] = []

    def start(*args, **kwargs) -> Batch:
        started.append(Batch(*args, **kwargs))
        return started[-1]

    yield start
    for batch in started:
        if batch.proc.poll() is None:
            for p in batch.workers():
                p.kill()
            batch.proc.kill()
            batch.proc.wait()


class Batch:
    """`rotlab batch` in a subprocess whose output is read line by line as it comes."""

    def __init__(self, tmp_path: Path, *args: str, new_session: bool = False) -> None:
        self.outdir = tmp_path / "out"
        self.proc = subprocess.Popen([*rotlab_command(), "batch", *args, "-o", str(self.outdir)], cwd=tmp_path,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=new_session)
        self.lines: list[str] = []

    def wait_for_lines(self, prefix: str, count: int, limit: float = 120.0) -> None:
        """Read stdout until ``count`` lines start with ``prefix``; the batch must still be running."""
        deadline = time.monotonic() + limit
        while sum(line.startswith(prefix) for line in self.lines) < count:
            assert time.monotonic() < deadline, self.lines
            line = self.proc.stdout.readline()
            assert line, f"batch ended early: {self.lines} {self.proc.stderr.read()}"
            self.lines.append(line.rstrip("\n"))
        assert self.proc.poll() is None, "the lines came only at the end"

    def workers(self) -> list[psutil.Process]:
        return [p for p in psutil.Process(self.proc.pid).children(recursive=True)]

    def busy_worker(self) -> psutil.Process:
        """The worker running the slow case: the descendant computing now (most CPU time over the
        next second; total CPU time would pick a worker that spent longer compiling its cases)."""
        workers = self.workers()
        before = {p.pid: p.cpu_times().user for p in workers}
        time.sleep(1.0)
        return max(workers, key=lambda p: p.cpu_times().user - before[p.pid])

    def finish(self, limit: float = 60.0) -> tuple[int, str, str]:
        out, err = self.proc.communicate(timeout=limit)
        return self.proc.returncode, "\n".join(self.lines) + "\n" + out, err

    def summary(self) -> dict:
        return json.loads((self.outdir / "summary.json").read_text(encoding="utf-8"), parse_constant=_reject)


def _reject(name: str) -> None:
    raise ValueError(f"non-standard JSON constant {name}")


def _assert_gone(processes: list[psutil.Process]) -> None:
    gone, alive = psutil.wait_procs(processes, timeout=10)
    assert not alive, f"orphaned workers: {alive}"


def test_a_killed_worker_costs_only_its_case(tmp_path, suite, batches):
    """kill -9 of the worker running one case: that case is an error "worker died", the others
    were reported as they finished, and summary.json / junit.xml / the table are written."""
    batch = batches(tmp_path, str(suite), "-j", "2")
    batch.wait_for_lines("PASS", 2)  # reported while the slow case still runs
    victim = batch.busy_worker()
    victim.send_signal(signal.SIGKILL)
    code, out, err = batch.finish()
    assert code == 1, err
    assert "a_slow.toml: worker died (killed by SIGKILL)" in out
    assert "2 passed, 0 failed, 1 error" in out and "Traceback" not in err
    status = {Path(c["scenario"]).name: c["status"] for c in batch.summary()["cases"]}
    assert status == {"a_slow.toml": "error", "b_quick.toml": "pass", "c_quick.toml": "pass"}
    assert (batch.outdir / "junit.xml").is_file()
    assert sorted(p.name for p in batch.outdir.iterdir()) == ["b_quick.rrd", "c_quick.rrd", "junit.xml", "summary.json"]


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_stops_the_batch_promptly_and_keeps_the_summary(tmp_path, suite, batches, signum):
    """SIGINT or SIGTERM to the main process while a case computes: it stops within seconds
    (the running case is not waited for), terminates every worker, writes the summary of what
    finished and exits 128 + signal."""
    batch = batches(tmp_path, str(suite), "-j", "2")
    batch.wait_for_lines("PASS", 2)
    workers = batch.workers()
    assert workers
    sent = time.monotonic()
    batch.proc.send_signal(signum)
    code, out, err = batch.finish()
    assert time.monotonic() - sent < 10.0
    assert code == 128 + signum and "Traceback" not in err
    assert err.strip().splitlines() == [f"rotlab: batch stopped by {signal.Signals(signum).name}: wrote the summary of the cases that finished"]
    _assert_gone(workers)
    doc = batch.summary()
    assert doc["stopped_by"] == signal.Signals(signum).name and doc["passed"] == 2 and doc["cancelled"] == 1
    (slow,) = [c for c in doc["cases"] if c["scenario"].endswith("a_slow.toml")]
    assert slow["status"] == "cancelled" and "stopped while running" in slow["message"]


def test_ctrl_c_to_the_process_group_prints_no_worker_traceback(tmp_path, suite, batches):
    """Ctrl-C in a terminal signals the whole group (here twice): workers ignore it, the main
    process stops them once and writes the summary."""
    batch = batches(tmp_path, str(suite), "-j", "2", new_session=True)
    batch.wait_for_lines("PASS", 2)
    workers = batch.workers()
    os.killpg(batch.proc.pid, signal.SIGINT)
    time.sleep(0.05)
    os.killpg(batch.proc.pid, signal.SIGINT)  # pressed twice: the second is ignored while stopping
    code, out, err = batch.finish()
    assert code == 130
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    _assert_gone(workers)
    assert (batch.outdir / "summary.json").is_file() and (batch.outdir / "junit.xml").is_file()


def test_per_case_timeout(tmp_path, suite, batches):
    batch = batches(tmp_path, str(suite), "-j", "2", "--timeout", "15")
    code, out, err = batch.finish(limit=120)
    assert code == 1
    assert "ERROR     " in out and "a_slow.toml: timed out after 15 s" in out
    assert batch.summary()["passed"] == 2


def test_sweep_timeout_costs_one_case(tmp_path):
    """`rotlab sweep --timeout`: the slow case ends as an error, the other completes, results.csv is written."""
    config = tmp_path / "s.toml"
    config.write_text(SLOW.replace("end = 100.0", "end = 20.0") + '[sweep]\n[sweep.parameters]\n"solver.step" = [1e-3, 1e-8]\n', encoding="utf-8")
    done = subprocess.run([*rotlab_command(), "sweep", str(config), "-o", str(tmp_path / "out"), "--timeout", "15"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=180)
    assert done.returncode == 1, done.stderr
    assert "case 1: ERROR: timed out after 15 s" in done.stdout
    rows = (tmp_path / "out" / "results.csv").read_text().splitlines()
    assert len(rows) == 3 and ",pass," in rows[1] and ",error," in rows[2]


@pytest.fixture
def read_only_dir(tmp_path):
    """A read-only directory that root cannot write either: a read-only tmpfs mount (root), else
    a chmod 555 directory (non-root)."""
    target = tmp_path / "ro"
    target.mkdir()
    if os.geteuid() == 0:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(target)], capture_output=True, text=True)
        if done.returncode != 0:
            pytest.skip(f"cannot mount a read-only tmpfs as root: {done.stderr.strip()}")
        yield target
        subprocess.run(["umount", str(target)], check=True)
    else:
        target.chmod(0o555)
        yield target
        target.chmod(0o755)


@pytest.mark.parametrize("command", ["batch", "sweep"])
def test_unwritable_outdir_is_refused_before_any_case(tmp_path, suite, read_only_dir, command):
    target = suite if command == "batch" else CONFIGS / "sweep_flip.toml"
    started = time.monotonic()
    done = subprocess.run([*rotlab_command(), command, str(target), "-o", str(read_only_dir / "out")],
                          cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stdout == ""  # no case ran
    assert len(done.stderr.strip().splitlines()) == 1 and "--outdir" in done.stderr and "Read-only file system" in done.stderr
    assert time.monotonic() - started < 30.0  # the slow case would take minutes


def test_pool_reports_a_dead_worker_and_retries(tmp_path):
    """run_tasks alone: a task that kills its worker is that task's failure (or is retried);
    the other tasks return their values."""
    marker = tmp_path / "died-once"
    die_once = f"import os, pathlib\np = pathlib.Path({str(marker)!r})\nif not p.exists():\n    p.touch(); os._exit(9)"
    tasks = [(os._exit, 3), (math.sqrt, 16.0), (exec, die_once)]
    run = run_tasks(operator.call, tasks, jobs=2, retries=0, preload=())
    ends = {e.index: e for e in run.ends}
    assert ends[0].failure == "worker died (exit code 3)" and ends[1].result == 4.0
    assert ends[2].failure == "worker died (exit code 9)" and run.stopped is None
    marker.unlink()
    run = run_tasks(operator.call, tasks, jobs=2, retries=1, preload=())
    ends = {e.index: e for e in run.ends}
    assert ends[0].failure == "worker died (exit code 3) on each of 2 attempts" and ends[0].attempts == 2
    assert ends[2].failure is None and ends[2].attempts == 2  # died once, then ran


def test_dask_killed_worker_is_reported_per_case(tmp_path):
    """A task whose Dask workers keep dying ends as KilledWorker for that task only."""
    distributed = pytest.importorskip("dask.distributed")
    import dask

    from rotlab.cluster import run_on_dask

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
        with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
            run = run_on_dask(operator.call, [(os._exit, 1), (math.sqrt, 9.0)], cluster.scheduler_address)
    ends = {e.index: e for e in run.ends}
    assert ends[1].result == 3.0 and ends[1].failure is None
    assert ends[0].failure.startswith("worker died (KilledWorker")



def test_worker_killed_while_writing_leaves_no_temporary(tmp_path, batches):
    """kill -9 of the worker while it writes a 2-million-sample recording: the case is an error
    and the writer's half-written temporary is removed."""
    folder = tmp_path / "big"
    folder.mkdir()
    (folder / "big.toml").write_text(QUICK.replace("end = 1.0\nsample_rate = 10", "end = 20.0\nsample_rate = 100000"), encoding="utf-8")
    batch = batches(tmp_path, str(folder), "-j", "1")
    deadline = time.monotonic() + 120
    while not list(batch.outdir.glob(".big.rrd.*.tmp")):
        assert time.monotonic() < deadline and batch.proc.poll() is None, "the recording was never being written"
        time.sleep(0.05)
    (worker,) = [p for p in batch.workers() if "resource_tracker" not in " ".join(p.cmdline())]
    worker.send_signal(signal.SIGKILL)
    code, out, err = batch.finish()
    assert code == 1 and "big/big.toml: worker died (killed by SIGKILL)" in out
    assert sorted(p.name for p in batch.outdir.iterdir()) == ["junit.xml", "summary.json"]


def test_kill_9_of_the_main_process_orphans_no_worker(tmp_path, suite, batches):
    batch = batches(tmp_path, str(suite), "-j", "2")
    batch.wait_for_lines("PASS", 2)
    workers = batch.workers()
    batch.proc.kill()
    batch.proc.wait()
    _assert_gone(workers)


@pytest.mark.parametrize("blocker, timeout, failure", [
    ((os._exit, 7), None, "worker died (exit code 7)"),
    ((time.sleep, 30.0), 1.0, "timed out after 1 s (per-case --timeout)"),
])
def test_the_task_queued_behind_a_dying_or_stuck_one_runs_once(blocker, timeout, failure, monkeypatch):
    """Short tasks are handed out two at a time (the next one waits in the worker's pipe, so the
    worker never waits for the main process): when the running task kills its worker or times
    out, the queued one has not started; it goes back to the queue and runs once, on a new worker."""
    from rotlab import parallel

    held = []
    start = parallel._Pool.start

    def spy(pool, index, attempt, args):
        sent = start(pool, index, attempt, args)
        held.append(max(len(w.queue) for w in pool.workers))
        return sent

    monkeypatch.setattr(parallel._Pool, "start", spy)
    tasks = [(math.sqrt, float(i * i)) for i in range(20)] + [blocker] + [(math.sqrt, float(i * i)) for i in range(20, 40)]
    run = run_tasks(operator.call, tasks, jobs=1, timeout=timeout, preload=())
    ends = {e.index: e for e in run.ends}
    assert max(held) == 2  # the worker held a queued task
    assert ends[20].failure == failure
    assert sorted(ends) == list(range(41)) and all(e.attempts == 1 for e in ends.values())
    assert [ends[i].result for i in range(41) if i != 20] == [float(i) for i in range(40)]


def test_large_tasks_and_results_do_not_deadlock_the_pool():
    """A task is handed out early only when it is small: a 1 MB task sent to a worker that is
    writing a 1 MB result would block both ends (found by review: the pool hung after 8 tasks)."""
    code = ("from rotlab.parallel import run_tasks\n"
            "if __name__ == '__main__':\n"
            "    for jobs in (1, 2):\n"
            "        run = run_tasks(bytes, [(b'y' * (1 << 20),)] * 40, jobs, preload=())\n"
            "        print(len(run.ends), all(e.result == b'y' * (1 << 20) for e in run.ends))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.stdout.split() == ["40", "True", "40", "True"], done.stdout + done.stderr


def test_warm_workers_run_the_tasks_and_none_is_left_behind():
    """``WarmWorkers`` started before the tasks are known: run_tasks uses them (the tasks run in
    their processes), the one it does not need is stopped, a warm worker killed while it waited
    is replaced, and workers started for another function are not used."""
    from rotlab.parallel import WarmWorkers

    with WarmWorkers(operator.call, 3, preload=()) as warm:
        pids = [w.process.pid for w in warm.workers]
        os.kill(pids[0], signal.SIGKILL)  # dies before any task reaches it
        run = run_tasks(operator.call, [(math.sqrt, x) for x in (4.0, 9.0, 16.0, 25.0)], jobs=2, preload=(), warm=warm)
        assert sorted(e.result for e in run.ends) == [2.0, 3.0, 4.0, 5.0] and all(e.failure is None for e in run.ends)
        ran = {e.pid for e in run.ends}
        assert pids[1] in ran and pids[0] not in ran  # the live warm one worked; the dead one's place went to a new worker
    _assert_gone([p for p in (psutil.Process(pid) for pid in pids[1:] if psutil.pid_exists(pid))])
    with WarmWorkers(operator.call, 2, preload=()) as other:
        pids = [w.process.pid for w in other.workers]
        run = run_tasks(operator.pos, [(1,)], jobs=2, preload=(), warm=other)
        assert run.ends[0].result == 1 and run.ends[0].pid not in pids
    assert not any(psutil.pid_exists(pid) and psutil.Process(pid).status() != psutil.STATUS_ZOMBIE for pid in pids)


def test_a_bad_sweep_file_stops_the_workers_started_for_it(tmp_path):
    """``rotlab sweep`` starts its workers before it validates the file: a bad file is still one
    line and exit 2, quickly, and no worker outlives the command."""
    config = tmp_path / "bad.toml"
    config.write_text(QUICK + "[sweep]\nseed = 1\nsamples = 3\n[sweep.parameters]\n\"initial.omega[0]\" = { uniform = [0.1, 0.5] }\n"
                      "[solver]\nrtol = -1\n", encoding="utf-8")
    before = {p.pid for p in psutil.Process().children(recursive=True)}
    started = time.monotonic()
    done = subprocess.run([*rotlab_command(), "sweep", str(config), "-o", str(tmp_path / "out")], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2 and "rtol" in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert time.monotonic() - started < 30.0
    assert {p.pid for p in psutil.Process().children(recursive=True)} <= before
    assert not [p for p in psutil.process_iter(["cmdline"]) if p.info["cmdline"] and str(config) in " ".join(p.info["cmdline"])]
