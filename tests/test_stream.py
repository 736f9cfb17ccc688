"""The streamed `rotlab run`: the file equals the whole run sample for sample, memory is held
per chunk, and faults (full disk, hostile paths, wall-clock limit, Ctrl-C) lose nothing."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import rotlab
from rotlab import api
from rotlab.errors import RunFailure
from rotlab.methods import stepping
from rotlab.recording import layout, sink as sink_module, stream as stream_module
from rotlab.recording.reader import read_series
from rotlab.recording.sink import RecordingSink, verify_rrd
from rotlab.scene.scene import build_scene
from tests.conftest import CONFIGS, VALID_BODY

ROTLAB = [sys.executable, "-m", "rotlab"]


def _streamed(scenario, path: Path, monkeypatch, window: int = 97, flush_rows: int = 61):
    """Run ``scenario`` streamed to ``path`` with tiny windows and chunks (many of each)."""
    monkeypatch.setattr(stepping, "WINDOW", window)
    monkeypatch.setattr(stream_module, "FLUSH_ROWS", flush_rows)
    run, _, final = api.record(build_scene(scenario), RecordingSink(path))
    assert final == path
    return run


@pytest.mark.parametrize("config, method", [
    ("lagrange.toml", "exact"),  # evaluated per window at the same times
    ("euler.toml", "rk4"),  # fixed steps: windows change nothing
    ("general.toml", "taylor"),  # adaptive: steps end at each window's last sample, streamed or whole
    ("general.toml", "dop853"),
])
def test_streamed_file_equals_the_whole_run(config, method, tmp_path, monkeypatch):
    """Bit for bit, with tiny windows (97 samples) in both runs."""
    scenario = rotlab.load(CONFIGS / config, method=method, duration=3.0)
    scenario = scenario.model_copy(update={"output": scenario.output.model_copy(update={"euler_angles": True})})
    monkeypatch.setattr(stepping, "WINDOW", 97)
    whole = rotlab.simulate(scenario)
    run = _streamed(scenario, tmp_path / "s.rrd", monkeypatch)
    assert run.samples == whole.t.shape[0] and run.stats.failure is None
    t, q = read_series(tmp_path / "s.rrd", layout.QUATERNION)
    np.testing.assert_array_equal(t, np.round(whole.t * 1e9) * 1e-9)
    _, omega = read_series(tmp_path / "s.rrd", layout.OMEGA)
    _, angles = read_series(tmp_path / "s.rrd", layout.EULER_ANGLES)  # unwrapped across chunks
    np.testing.assert_array_equal(q, whole.quaternion)
    np.testing.assert_array_equal(omega, whole.omega)
    assert np.max(np.abs(angles - whole.euler_angles)) < 1e-12
    for name, drift in whole.invariants.items():  # measured from the run's first sample, not the chunk's
        _, streamed = read_series(tmp_path / "s.rrd", f"{layout.INVARIANTS}/{name}")
        np.testing.assert_allclose(streamed[:, 0], drift, rtol=0, atol=1e-12)
        assert run.drift[name] == pytest.approx(whole.max_drift()[name], rel=1e-6, abs=1e-13)


def test_the_cli_and_the_api_give_the_same_chaotic_run(cli, tmp_path):
    """A chaotic top magnifies any difference in the steps (λ ≈ 0.6 1/s over 600 s): `rotlab run`
    (streamed) and `rotlab.simulate` (whole) take the same steps, so their states and their
    Poincaré sections are identical."""
    result = cli("run", str(CONFIGS / "chaotic_top.toml"), "-o", "c.rrd")
    assert result.exit_code == 0, result.output
    whole = rotlab.simulate(CONFIGS / "chaotic_top.toml")
    _, omega = read_series(tmp_path / "c.rrd", layout.OMEGA)
    np.testing.assert_array_equal(omega, whole.omega)
    assert f"section: {whole.events['section'].count} occurrences" in result.stdout


def test_visual_series_are_thinned_and_the_state_is_not(tmp_path, monkeypatch):
    scenario = rotlab.load(CONFIGS / "lagrange.toml", duration=10.0)  # 2001 samples
    scenario = scenario.model_copy(update={"output": scenario.output.model_copy(update={"visual_samples": 100})})
    _streamed(scenario, tmp_path / "s.rrd", monkeypatch)
    t_state, _ = read_series(tmp_path / "s.rrd", layout.QUATERNION)
    t_pose, _ = read_series(tmp_path / "s.rrd", layout.BODY, "Transform3D:quaternion")
    t_log, _ = read_series(tmp_path / "s.rrd", f"{layout.INVARIANTS_LOG}/energy")
    t_energy, _ = read_series(tmp_path / "s.rrd", f"{layout.INVARIANTS}/energy")
    t_norm, norm = read_series(tmp_path / "s.rrd", f"{layout.INVARIANTS}/quaternion_norm")
    stride = -(-2001 // 100)
    assert t_state.shape[0] == 2001
    np.testing.assert_array_equal(t_pose, t_state[::stride])  # every stride-th sample, across chunks
    np.testing.assert_array_equal(t_log, t_state[::stride])
    np.testing.assert_array_equal(t_energy, t_state)  # the invariants: every sample
    np.testing.assert_array_equal(t_norm, t_state[::stride])  # |Λ| − 1, a function of Λ alone: visual rate
    _, q = read_series(tmp_path / "s.rrd", layout.QUATERNION)
    np.testing.assert_array_equal(norm[:, 0], (np.linalg.norm(q, axis=1) - 1.0)[::stride])  # recomputable from the file


def test_visual_samples_are_collected_into_few_chunks(tmp_path, monkeypatch):
    """The visual series of a long run go out in chunks of up to VISUAL_ROWS samples, not one per
    flush: Rerun keeps an entry per chunk in memory until the file's footer (a 10⁸-sample run held
    ~60 MB more when ~25 visual entities were sent with every flush).  Here ~21 flushes, and the
    visual samples (every 21st) arrive in one chunk per entity; the state (2,001 rows, fewer than
    CHUNK_ROWS) in one too."""
    from rerun.chunk import RrdReader

    from rotlab.recording import writer as writer_module

    monkeypatch.setattr(writer_module, "SEND_SECONDS", 1e9)  # only the row count (or the end) sends them
    scenario = rotlab.load(CONFIGS / "lagrange.toml", duration=10.0)  # 2001 samples
    scenario = scenario.model_copy(update={"output": scenario.output.model_copy(update={"visual_samples": 100})})
    _streamed(scenario, tmp_path / "s.rrd", monkeypatch)
    chunks: dict[str, int] = {}
    for chunk in RrdReader(str(tmp_path / "s.rrd")).stream().filter(is_static=False).to_chunks():
        chunks[str(chunk.entity_path)] = chunks.get(str(chunk.entity_path), 0) + 1
    assert chunks[layout.QUATERNION] == 1 and chunks[f"{layout.INVARIANTS}/energy"] == 1
    assert chunks[layout.BODY] == 1 and chunks[f"{layout.INVARIANTS_LOG}/energy"] == 1
    t_pose, _ = read_series(tmp_path / "s.rrd", layout.BODY, "Transform3D:quaternion")
    assert t_pose.shape[0] == -(-2001 // 21)


@pytest.mark.parametrize("long_run, chunks", [(2001, [500, 500, 500, 500, 1]), (2000, [700, 700, 601])])
def test_state_goes_out_in_whole_chunks_of_chunk_rows(long_run, chunks, tmp_path, monkeypatch):
    """Flushes of 61 rows are collected into full-rate chunks of CHUNK_ROWS (here 500) rows, or
    LONG_CHUNK_ROWS (700) in a run longer than LONG_RUN samples, the last one shorter; the file
    holds every sample, bit for bit those of the run written whole."""
    from rerun.chunk import RrdReader

    from rotlab.recording import writer as writer_module

    monkeypatch.setattr(writer_module, "CHUNK_ROWS", 500)
    monkeypatch.setattr(writer_module, "LONG_CHUNK_ROWS", 700)
    monkeypatch.setattr(writer_module, "LONG_RUN", long_run)
    monkeypatch.setattr(stepping, "WINDOW", 97)  # (the adaptive steps end at each window's last sample: the same windows in both runs)
    scenario = rotlab.load(CONFIGS / "general.toml", duration=10.0)  # 2001 samples
    whole = rotlab.simulate(scenario)
    _streamed(scenario, tmp_path / "s.rrd", monkeypatch)
    rows: dict[str, list[int]] = {}
    for chunk in RrdReader(str(tmp_path / "s.rrd")).stream().filter(is_static=False).to_chunks():
        rows.setdefault(str(chunk.entity_path), []).append(chunk.num_rows)
    for entity in (layout.QUATERNION, layout.OMEGA, layout.WORK, f"{layout.INVARIANTS}/energy"):
        assert rows[entity] == chunks, entity
    _, q = read_series(tmp_path / "s.rrd", layout.QUATERNION)
    _, work = read_series(tmp_path / "s.rrd", layout.WORK)
    np.testing.assert_array_equal(q, whole.quaternion)
    np.testing.assert_array_equal(work[:, 0], whole.work)


def test_collected_columns_handed_out_are_never_written_again():
    """``FullRateRows``: what ``taken`` returns belongs to the caller, its values kept through the
    next ``add``s."""
    from rotlab.recording.writer import FullRateRows

    rows = FullRateRows(500)
    t = np.arange(700.0)
    q = np.arange(2800.0).reshape(700, 4)
    assert rows.add(t, {"q": q}) == 500 and rows.is_full
    t1, v1 = rows.taken()
    assert rows.add(t[500:], {"q": q[500:]}) == 200 and not rows.is_full
    assert not np.shares_memory(t1, rows.t) and not np.shares_memory(v1["q"], rows.values["q"])
    np.testing.assert_array_equal(t1, t[:500])
    np.testing.assert_array_equal(v1["q"], q[:500])
    t2, v2 = rows.taken()
    np.testing.assert_array_equal(t2, t[500:])
    np.testing.assert_array_equal(v2["q"], q[500:])


def test_live_viewers_get_the_state_at_least_every_send_seconds(tmp_path, monkeypatch):
    """With a live viewer the collected rows go out on time, not only when CHUNK_ROWS have come
    (here every flush: SEND_SECONDS = 0); a file alone waits for whole chunks."""
    from rerun.chunk import RrdReader

    from rotlab.recording import writer as writer_module
    from rotlab.recording.sink import LiveOptions

    monkeypatch.setattr(writer_module, "SEND_SECONDS", 0.0)
    monkeypatch.setattr(stepping, "WINDOW", 97)
    monkeypatch.setattr(stream_module, "FLUSH_ROWS", 61)
    scenario = rotlab.load(CONFIGS / "lagrange.toml", duration=3.0)  # 601 samples
    rows: dict[bool, list[int]] = {}
    for live in (False, True):
        sink = RecordingSink(tmp_path / f"{live}.rrd")
        sink.live = LiveOptions(spawn=live)  # only whether a viewer watches: the file gets the same chunks
        api.record(build_scene(scenario), sink)
        chunks = RrdReader(str(tmp_path / f"{live}.rrd")).stream().filter(is_static=False).to_chunks()
        rows[live] = [chunk.num_rows for chunk in chunks if str(chunk.entity_path) == layout.QUATERNION]
    assert rows[False] == [601]
    assert len(rows[True]) >= 6 and max(rows[True]) <= 98 and sum(rows[True]) == 601  # one chunk a flush (a window of 97)


def test_sample_times_equal_linspace():
    for start, end, n in ((0.0, 49999.0, 9_999_801), (0.3, 10.7, 2001), (1e5, 1e5 + 1.0, 3)):
        lazy, full = stepping.SampleTimes(start, end, n), np.linspace(start, end, n)
        np.testing.assert_array_equal(lazy[0:n], full)
        np.testing.assert_array_equal(lazy[7 : n - 2], full[7 : n - 2])
        assert lazy[-1] == full[-1] and lazy[1] == full[1] and lazy.shape == full.shape


# --- the sink: checked writes, verification, atomic rename -------------------------------------

def test_write_error_is_a_run_failure_and_keeps_the_old_file(tmp_path, monkeypatch):
    """A fault-injecting os.write (ENOSPC after 200 kB) in the pump: the run fails with a clear
    line, the old recording stays, no temporary file is left."""
    target = tmp_path / "out.rrd"
    target.write_bytes(b"a good recording")
    real_write, written = os.write, [0]

    def full_disk(fd, data):
        if written[0] > 200_000:
            raise OSError(errno.ENOSPC, "No space left on device")
        written[0] += len(data)
        return real_write(fd, data)

    monkeypatch.setattr(sink_module.os, "write", full_disk)
    with pytest.raises(RunFailure, match="could not write the recording .*No space left on device"):
        _streamed(rotlab.load(CONFIGS / "euler.toml", duration=100.0), target, monkeypatch, window=4096, flush_rows=2048)
    assert target.read_bytes() == b"a good recording"
    assert [p.name for p in tmp_path.iterdir()] == ["out.rrd"]


@pytest.mark.parametrize("damage", ["empty", "truncated", "no footer"])
def test_verification_refuses_incomplete_files(damage, tmp_path):
    good = tmp_path / "good.rrd"
    from rotlab.recording.writer import write_recording

    write_recording(rotlab.simulate(rotlab.load(CONFIGS / "euler.toml", duration=1.0)), good)
    verify_rrd(good)
    data = good.read_bytes()
    bad = tmp_path / "bad.rrd"
    bad.write_bytes({"empty": b"", "truncated": data[: len(data) // 2], "no footer": data[:-32]}[damage])
    with pytest.raises(RunFailure, match="incomplete|does not read back"):
        verify_rrd(bad)


@pytest.fixture
def full_tmpfs(tmp_path):
    """A real 1 MB tmpfs (root only; skipped where mounting is refused)."""
    mount = tmp_path / "small"
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mount)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], check=False)


@pytest.mark.parametrize("duration", ["19.2", "40", "2000"])
def test_full_disk_on_a_real_tmpfs(full_tmpfs, duration, tmp_path):
    good = full_tmpfs / "out.rrd"
    subprocess.run(ROTLAB + ["run", str(CONFIGS / "euler.toml"), "-o", str(good), "--duration", "1", "-q"], check=True, timeout=120)
    before = good.read_bytes()
    done = subprocess.run(ROTLAB + ["run", str(CONFIGS / "euler.toml"), "-o", str(good), "--duration", duration],
                          capture_output=True, text=True, timeout=120)  # never hangs
    assert done.returncode == 1, done.stderr
    assert done.stderr.strip().splitlines() == [done.stderr.strip()] and "No space left on device" in done.stderr
    assert good.read_bytes() == before
    assert sorted(p.name for p in full_tmpfs.iterdir()) == ["out.rrd"]


# --- hostile output paths: refused before any work, exit 2, one line ---------------------------

def _run_cli(*args, cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([*ROTLAB, "run", *args], capture_output=True, cwd=cwd, timeout=timeout)


def test_output_that_is_the_config_is_refused(tmp_path):
    config = tmp_path / "c.toml"
    config.write_bytes((CONFIGS / "euler.toml").read_bytes())
    done = _run_cli(str(config), "-o", str(config), cwd=tmp_path)
    assert done.returncode == 2 and b"is the input" in done.stderr and done.stderr.count(b"\n") == 1
    assert config.read_bytes() == (CONFIGS / "euler.toml").read_bytes()


def test_special_files_are_never_replaced(tmp_path):
    fifo = tmp_path / "pipe.rrd"
    os.mkfifo(fifo)
    for target in (fifo, Path("/dev/null")):
        done = _run_cli(str(CONFIGS / "euler.toml"), "-o", str(target), cwd=tmp_path)
        assert done.returncode == 2 and b"not a regular file" in done.stderr and done.stderr.count(b"\n") == 1
    assert fifo.is_fifo() and Path("/dev/null").is_char_device()


def test_long_and_non_utf8_names_are_refused(tmp_path):
    for name in ("x" * 300 + ".rrd", b"caf\xe9.rrd"):
        args = [*ROTLAB, "run", str(CONFIGS / "euler.toml"), "-o"]
        done = subprocess.run([os.fsencode(a) for a in args] + [os.fsencode(name)], capture_output=True, cwd=tmp_path, timeout=120)
        assert done.returncode == 2, done.stderr
        assert done.stderr.count(b"\n") == 1 and b"Traceback" not in done.stderr
    assert list(tmp_path.iterdir()) == []


def test_size_estimate_asks_before_a_large_run(tmp_path):
    done = _run_cli(str(CONFIGS / "euler.toml"), "-o", "e.rrd", "--duration", "50", "--max-megabytes", "0.5", cwd=tmp_path)
    assert done.returncode == 2 and b"--max-megabytes" in done.stderr and not (tmp_path / "e.rrd").exists()
    done = _run_cli(str(CONFIGS / "euler.toml"), "-o", "e.rrd", "--duration", "50", "--max-megabytes", "5", "-q", cwd=tmp_path)
    assert done.returncode == 0 and (tmp_path / "e.rrd").exists()


# --- stopping: wall-clock limit, Ctrl-C, samples longer than a chunk ---------------------------

def _long_rk4(tmp_path: Path, step: str, rate: str = "1") -> Path:
    config = tmp_path / "long.toml"
    config.write_text(VALID_BODY + f"[initial]\nomega = [0.1, 2.0, 0.1]\n[time]\nend = 100000.0\nsample_rate = {rate}\n"
                      f'[solver]\nmethod = "rk4"\nstep = {step}\nmax_steps = 100000000000000\n')
    return config


def test_timeout_stops_inside_a_long_sample_and_keeps_the_valid_samples(tmp_path):
    """step 1e-7 s with one sample per second: 10⁷ steps per sample, far more than one chunk."""
    config = _long_rk4(tmp_path, "1e-7")
    started = time.monotonic()
    done = _run_cli(str(config), "-o", "long.rrd", "--timeout", "4", cwd=tmp_path)
    assert time.monotonic() - started < 60
    err = done.stderr.decode()
    assert done.returncode == 1 and "wall-clock limit of 4 s" in err and len(err.strip().splitlines()) == 1
    partial = tmp_path / "long.partial.rrd"
    verify_rrd(partial)
    assert not (tmp_path / "long.rrd").exists()


@pytest.mark.parametrize("config, extra, signum", [
    ("euler.toml", ["--duration", "40000"], signal.SIGINT),  # exact: evaluation, conversion and writing interleaved
    (None, [], signal.SIGINT),  # rk4 with long samples
    (None, [], signal.SIGTERM),  # kill, timeout(1), a cancelled CI job: the same, exit 143
])
def test_ctrl_c_keeps_the_valid_samples(config, extra, signum, tmp_path):
    path = CONFIGS / config if config else _long_rk4(tmp_path, "1e-6")
    proc = subprocess.Popen([*ROTLAB, "run", str(path), "-o", "out.rrd", "--max-megabytes", "10000", *extra],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    partial = tmp_path / "out.partial.rrd"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not any(p.name.endswith(".tmp") and p.stat().st_size > 100_000 for p in tmp_path.iterdir()):
        time.sleep(0.2)  # until samples are being written
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signum, err
    last = err.strip().splitlines()[-1]  # before it: at most the progress lines of a non-terminal
    assert last.startswith("rotlab: interrupted:") and "valid samples are in" in last and "Traceback" not in err
    assert ("stopped by SIGTERM at t =" if signum == signal.SIGTERM else "interrupted by the user at t =") in last
    verify_rrd(partial)
    t, q = read_series(partial, layout.QUATERNION)
    assert t.shape[0] > 1 and np.all(np.isfinite(q))
    assert not (tmp_path / "out.rrd").exists() and not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


# --- live viewing: a real headless Rerun receives the same recording as the file ---------------

def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_connected_viewer_receives_the_file_sample_for_sample(tmp_path):
    """`rerun --port P --save received.rrd` is a headless Rerun that takes a live stream; a run
    with -o and --connect sends the same samples to both."""
    from tests.test_robustness import _rerun

    port = _free_port()
    received = tmp_path / "received.rrd"
    viewer = subprocess.Popen([_rerun(), "--port", str(port), "--save", str(received)], cwd=tmp_path,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not received.exists():
            time.sleep(0.2)
        done = _run_cli(str(CONFIGS / "general.toml"), "-o", "file.rrd", "--connect", "--url",
                        f"rerun+http://127.0.0.1:{port}/proxy", "--duration", "30", "-q", cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        time.sleep(2.0)  # the viewer writes what it received
    finally:
        os.killpg(viewer.pid, signal.SIGKILL)
        viewer.wait(timeout=30)
    entities = [(layout.QUATERNION, "Scalars:scalars"), (layout.OMEGA, "Scalars:scalars"), (layout.ENERGY, "Scalars:scalars"),
                (f"{layout.INVARIANTS}/energy", "Scalars:scalars"), (layout.BODY, "Transform3D:quaternion")]
    for entity, component in entities:
        t_file, v_file = read_series(tmp_path / "file.rrd", entity, component)
        t_live, v_live = read_series(received, entity, component)
        assert t_file.shape[0] > 1000
        np.testing.assert_array_equal(t_live, t_file)
        np.testing.assert_array_equal(v_live, v_file)


def _ctrl_c(proc: subprocess.Popen) -> str:
    """Send Ctrl-C to ``proc`` and return its stderr once it has ended (killed, and the test failed,
    if it has not within 60 s: no process is left behind)."""
    proc.send_signal(signal.SIGINT)
    try:
        return proc.communicate(timeout=60)[1]
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise


def test_serve_web_serves_the_viewer_and_finishes_the_file_on_ctrl_c(tmp_path):
    import urllib.request

    grpc, web = _free_port(), _free_port()
    proc = subprocess.Popen([*ROTLAB, "run", str(CONFIGS / "lagrange.toml"), "-o", "web.rrd", "--serve-web", "--port", str(grpc),
                             "--web-port", str(web)], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    before = ""
    try:
        deadline, status = time.monotonic() + 60, None
        while time.monotonic() < deadline and status != 200:
            try:
                status = urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=2).status
            except OSError:
                time.sleep(0.3)
        assert status == 200
        while "serving the web viewer" not in before and proc.poll() is None:  # the run has ended: Ctrl-C now ends the serving
            before += proc.stderr.readline()
    finally:
        err = _ctrl_c(proc)
    err = before + err
    assert proc.returncode == 0, err
    assert f"http://127.0.0.1:{web}/?url=rerun+http://127.0.0.1:{grpc}/proxy" in err
    verify_rrd(tmp_path / "web.rrd")
    assert read_series(tmp_path / "web.rrd", layout.QUATERNION)[0].shape[0] == 2001


def test_one_ctrl_c_during_a_serve_web_run_stops_the_run_and_the_server(tmp_path):
    """Ctrl-C while the run is still going (a loaded machine, a long run): the run stops, keeps its
    valid samples in NAME.partial.rrd and the process ends; it used to go on serving until a
    second Ctrl-C."""
    grpc, web = _free_port(), _free_port()
    proc = subprocess.Popen([*ROTLAB, "run", str(CONFIGS / "euler.toml"), "-o", "web.rrd", "--serve-web", "--port", str(grpc),
                             "--web-port", str(web), "--duration", "200000", "--max-megabytes", "1e9", "-q"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not any(f.stat().st_size > 10 << 20 for f in tmp_path.glob(".web.rrd.*.tmp")):
            time.sleep(0.1)  # until the run has written 10 MB of its ~3 GB
    finally:
        err = _ctrl_c(proc)
    assert proc.returncode == 130, err
    assert "interrupted by the user" in err and "web.partial.rrd" in err and "serving" not in err
    verify_rrd(tmp_path / "web.partial.rrd")
    samples = read_series(tmp_path / "web.partial.rrd", layout.QUATERNION)[0].shape[0]
    assert 0 < samples < 20_000_001
    assert not (tmp_path / "web.rrd").exists()


def test_a_killed_viewer_does_not_stop_or_stall_the_file(tmp_path):
    """The viewer dies mid-stream: the run goes on, ends in time and the file is complete."""
    from tests.test_robustness import _rerun

    port = _free_port()
    viewer = subprocess.Popen([_rerun(), "--port", str(port), "--save", str(tmp_path / "received.rrd")], cwd=tmp_path,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    time.sleep(3.0)
    proc = subprocess.Popen([*ROTLAB, "run", str(CONFIGS / "euler.toml"), "-o", "file.rrd", "--connect", "--url",
                             f"rerun+http://127.0.0.1:{port}/proxy", "--duration", "20000", "-q"],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(4.0)
    os.killpg(viewer.pid, signal.SIGKILL)
    viewer.wait(timeout=30)
    out, err = proc.communicate(timeout=180)
    assert proc.returncode == 0, err
    t, _ = read_series(tmp_path / "file.rrd", layout.QUATERNION)
    assert t.shape[0] == 2_000_001


def test_a_viewer_that_stops_reading_does_not_stall_the_run(tmp_path):
    """A "viewer" that accepts the connection and never reads: Rerun's gRPC sink then blocks its
    sends and flushes for ever (Ctrl-C cannot reach a thread blocked there; before the live feed
    had its own thread this run hung).  The run goes on at full speed, gives the viewer up with
    one line, and the file has every sample."""
    import socket

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    port = server.getsockname()[1]
    held: list[socket.socket] = []

    def accept_and_never_read() -> None:
        while True:
            try:
                connection, _ = server.accept()
            except OSError:
                return
            connection.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
            held.append(connection)

    import threading

    threading.Thread(target=accept_and_never_read, daemon=True).start()
    try:
        started = time.monotonic()
        done = subprocess.run([*ROTLAB, "run", str(CONFIGS / "euler.toml"), "-o", "file.rrd", "--connect", "--url",
                               f"rerun+http://127.0.0.1:{port}/proxy", "--duration", "20000", "-q"],
                              cwd=tmp_path, capture_output=True, text=True, timeout=300)
        seconds = time.monotonic() - started
    finally:
        server.close()
        for connection in held:
            connection.close()
    assert done.returncode == 0, done.stderr
    assert "rotlab: the live viewer fell 8 chunks behind" in done.stderr and "the file has every sample" in done.stderr
    assert seconds < 120
    t, _ = read_series(tmp_path / "file.rrd", layout.QUATERNION)
    assert t.shape[0] == 2_000_001


def test_progress_is_a_transient_bar_on_a_terminal_and_lines_elsewhere(monkeypatch):
    import io

    from rotlab import progress as progress_module

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    monkeypatch.setattr(progress_module, "LINE_EVERY", 0.0)
    log = io.StringIO()
    bar = progress_module.StreamProgress("run.toml", stream=log)
    bar(500, 1000)
    bar.written(400, 1000)
    bar.close()
    assert "run.toml: 400 of 1,000 samples written (40%; integrated 500)" in log.getvalue()
    screen = Terminal()
    bar = progress_module.StreamProgress("run.toml", stream=screen)
    bar.started -= 1.0  # past the start-up delay
    bar(500, 1000)
    bar.written(400, 1000)
    assert bar._bar is not None  # a rich bar, drawn on the terminal
    bar.close()
    assert "samples written" not in screen.getvalue()  # no log lines on a terminal


def test_progress_lines_of_a_streamed_run_never_show_less_integrated_than_written(tmp_path, monkeypatch):
    """A streamed window's rows are written before the method reports the window: the lines
    said "integrated 0" while samples were already written.  Every line of a real streamed run
    (lines at every flush) has integrated >= written, and the last has both at N."""
    import io
    import re

    from rotlab import progress as progress_module

    monkeypatch.setattr(progress_module, "LINE_EVERY", 0.0)
    scenario = rotlab.load(CONFIGS / "euler.toml", method="rk4", duration=20.0, overrides={"solver.step": 1e-3})
    monkeypatch.setattr(stepping, "WINDOW", 1000)
    monkeypatch.setattr(stream_module, "FLUSH_ROWS", 700)
    log = io.StringIO()
    api.record(build_scene(scenario), RecordingSink(tmp_path / "run.rrd"), progress_module.StreamProgress("run", stream=log))
    lines = re.findall(r"([\d,]+) of ([\d,]+) samples written \(\d+%; integrated ([\d,]+)\)", log.getvalue())
    figures = [tuple(int(x.replace(",", "")) for x in line) for line in lines]
    n = scenario.time.sample_count
    assert len(figures) >= n // 700 and figures[-1] == (n, n, n)
    assert all(integrated >= written for written, _, integrated in figures)


@pytest.mark.parametrize("first_row_flushes", [False, True])
def test_ctrl_c_before_the_first_sample_is_sent_writes_no_file(first_row_flushes, tmp_path, monkeypatch):
    """Ctrl-C inside the first conversion (the fault campaign's SIGINT at ~0.9 s): nothing was sent,
    so no partial file (an empty one used to fail verification: exit 1), no temporary file, and an
    existing recording untouched.  ``first_row_flushes``: the first row alone is converted, as when
    the kernel took longer than FLUSH_SECONDS to load (a cold numba cache); the Ctrl-C there
    escaped the method's handler."""
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(stream_module, "build_chunk", interrupted)
    if first_row_flushes:
        monkeypatch.setattr(stream_module, "FLUSH_SECONDS", -1.0)
    target = tmp_path / "out.rrd"
    target.write_bytes(b"an earlier recording")
    scenario = rotlab.load(CONFIGS / "euler.toml", method="rk4", duration=0.1)
    run, _, final = api.record(build_scene(scenario), RecordingSink(target))
    assert final is None and run.samples == 0 and run.stats.interrupted
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.rrd"] and target.read_bytes() == b"an earlier recording"


def test_ctrl_c_while_a_chunk_is_written_keeps_that_chunk_whole(tmp_path, monkeypatch):
    """A Ctrl-C that lands while a chunk is converted and written is held until the chunk is in the
    sink, so the partial file holds exactly the samples the run reports (none lost mid-chunk)."""
    from rotlab.recording.writer import RecordingWriter

    original = RecordingWriter.write
    calls = []

    def write_then_interrupted(self, chunk, start):
        calls.append(start)
        if len(calls) == 2:
            os.kill(os.getpid(), signal.SIGINT)  # arrives inside the second chunk's write
        original(self, chunk, start)

    monkeypatch.setattr(RecordingWriter, "write", write_then_interrupted)
    monkeypatch.setattr(stepping, "WINDOW", 97)  # rows come in windows of 97 and are sent in chunks of ≥ 50
    monkeypatch.setattr(stream_module, "FLUSH_ROWS", 50)
    scenario = rotlab.load(CONFIGS / "euler.toml", method="rk4", duration=5.0)
    run, _, final = api.record(build_scene(scenario), RecordingSink(tmp_path / "out.rrd"))
    assert run.stats.interrupted and final == tmp_path / "out.partial.rrd"
    t, q = read_series(final, layout.QUATERNION)
    assert len(calls) == 2 and t.shape[0] == run.samples >= 100 and np.all(np.isfinite(q))


def test_ctrl_c_as_the_run_ends_keeps_every_sample_it_reports(tmp_path, monkeypatch):
    """A Ctrl-C that lands as the last rows are converted, while the writer still collects
    full-rate rows it has counted (a run shorter than a chunk: all of them), is held until those
    rows are sent: the partial file holds exactly the samples the run reports."""
    original = stream_module.ChunkStream.flush

    def flush_then_interrupted(self):
        original(self)
        os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(stream_module.ChunkStream, "flush", flush_then_interrupted)
    monkeypatch.setattr(stream_module, "FLUSH_ROWS", 1 << 30)  # one flush: the one that ends the run
    monkeypatch.setattr(stream_module, "FLUSH_SECONDS", 1e9)
    scenario = rotlab.load(CONFIGS / "euler.toml", method="rk4", duration=5.0)  # 1,001 samples
    run, _, final = api.record(build_scene(scenario), RecordingSink(tmp_path / "out.rrd"))
    assert run.stats.interrupted and final == tmp_path / "out.partial.rrd"
    t, q = read_series(final, layout.QUATERNION)
    assert t.shape[0] == run.samples == scenario.time.sample_count and np.all(np.isfinite(q))


def test_a_compile_inside_the_writer_is_reported_as_compiling_not_writing(tmp_path, monkeypatch):
    """The summary's parts (integration, compiling, writing) do not overlap: numba compiling a
    kernel while the writer runs (the load views' on a first run) is compile time, not writing."""
    from numba import njit

    from rotlab.recording.writer import RecordingWriter

    compiled: list[float] = []
    write = RecordingWriter.write

    def write_after_a_compile(self, chunk, start):
        if not compiled:
            @njit(cache=False)
            def fresh(n):
                s = 0.0
                for i in range(n):
                    s += np.sin(i * 0.1)
                return s

            started = time.perf_counter()
            fresh(3)
            compiled.append(time.perf_counter() - started)
        return write(self, chunk, start)

    monkeypatch.setattr(RecordingWriter, "write", write_after_a_compile)
    scenario = rotlab.load(CONFIGS / "euler.toml", method="exact")
    started = time.perf_counter()
    run, writing, final = api.record(build_scene(scenario), RecordingSink(tmp_path / "run.rrd"))
    wall = time.perf_counter() - started
    assert final == tmp_path / "run.rrd" and run.samples == scenario.time.sample_count
    assert run.stats.compile_seconds >= 0.9 * compiled[0]
    assert run.stats.seconds + run.stats.compile_seconds + writing <= wall  # nothing counted twice


def test_the_bar_says_when_numba_is_compiling():
    import io

    from rotlab import progress as progress_module

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    screen = Terminal()
    bar = progress_module.StreamProgress("run.toml", stream=screen)
    bar.compiling(True)  # at once, before any sample: a first run's compile is when nothing else moves
    assert bar._bar is not None and bar._bar.tasks[0].description == f"run.toml · {progress_module.COMPILING}"
    bar.compiling(False)
    assert bar._bar.tasks[0].description == "run.toml"
    bar.close()
    log = io.StringIO()
    bar = progress_module.StreamProgress("run.toml", stream=log)
    bar.compiling(True)
    bar.compiling(False)
    bar.close()
    assert log.getvalue() == ""  # not a terminal: the summary reports the compile time


def test_a_compile_cut_short_does_not_leave_the_clock_running(tmp_path, monkeypatch):
    """A Ctrl-C raised inside numba (the compiler-lock shield re-sends it there) can keep a
    compile's end from reaching the clock; the run then counted all later writing as compiling,
    and the summary showed a negative writing time (found by review).  The clock is closed once
    the method returns: writing keeps its time."""
    from numba.core import event

    from rotlab.methods.catalog.exact import Exact
    from rotlab.recording.writer import RecordingWriter

    solve, write = Exact.solve, RecordingWriter.write

    def solve_after_a_lost_end(self, *args):
        event.start_event("numba:compiler_lock")  # its end event never comes
        return solve(self, *args)

    def slow_write(self, chunk, start):
        time.sleep(0.3)
        return write(self, chunk, start)

    monkeypatch.setattr(Exact, "solve", solve_after_a_lost_end)
    monkeypatch.setattr(RecordingWriter, "write", slow_write)
    monkeypatch.setattr(stream_module, "FLUSH_ROWS", 1 << 30)  # one chunk, written after the method returns
    monkeypatch.setattr(stream_module, "FLUSH_SECONDS", 1e9)
    run, writing, _ = api.record(build_scene(rotlab.load(CONFIGS / "euler.toml", method="exact")), RecordingSink(tmp_path / "e.rrd"))
    assert writing >= 0.29 and run.stats.compile_seconds < 0.2


def test_the_thinned_copy_of_a_run_stays_within_max_path_points():
    """The end of a run computes every layout series of ``Thinned``'s samples at once, so their
    number bounds the run's last memory peak: at most MAX_PATH_POINTS, whatever the length,
    every k-th sample of the run from its first (k a power of two), in order."""
    from rotlab.recording.geometry import MAX_PATH_POINTS
    from rotlab.recording.writer import Thinned

    thinned, start, total = Thinned(), 0, 0
    for size in [16_384] * 300 + [5]:  # 4.9·10⁶ samples in flush-sized pieces
        t = np.arange(start, start + size, dtype=float)
        thinned.add(start, t, np.repeat(t[:, None], 8, axis=1))
        start += size
        total += size
        assert thinned.count <= MAX_PATH_POINTS
    t, state = thinned.arrays()
    assert MAX_PATH_POINTS // 2 < t.shape[0] <= MAX_PATH_POINTS
    assert t[0] == 0.0 and np.all(np.diff(t) == thinned.every) and thinned.every & (thinned.every - 1) == 0
    assert t[-1] > total - 1 - thinned.every and np.array_equal(state[:, 3], t)


@pytest.mark.parametrize("free_kb", [4, 64])  # the results tables do not fit / the comparison recording does not
def test_a_sweep_onto_a_full_disk_ends_like_a_run(full_tmpfs, free_kb):
    """Exit 1 with one line, no temporary file, the good old files untouched (it was twice a
    traceback and twice a hang, a temporary file left behind)."""
    outdir = full_tmpfs / "out"
    outdir.mkdir()
    (outdir / "results.csv").write_text("good old results\n")
    (outdir / "sweep_flip_sweep.rrd").write_bytes(b"a good old recording")
    filler = full_tmpfs / "filler"
    with filler.open("wb") as f:
        try:
            f.write(b"\0" * (1024 * 1024 - free_kb * 1024 - 8192))
        except OSError:
            pass
    done = subprocess.run(ROTLAB + ["sweep", str(CONFIGS / "sweep_flip.toml"), "-o", str(outdir)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 1, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "No space left on device" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr
    assert (outdir / "sweep_flip_sweep.rrd").read_bytes() == b"a good old recording"
    assert not [p.name for p in outdir.iterdir() if p.name.startswith(".")]
    if free_kb == 4:
        assert (outdir / "results.csv").read_text() == "good old results\n"


def test_connect_to_no_viewer_says_so_at_once_and_writes_the_file(tmp_path):
    """It took 20 s, printed Rerun's own log lines, and said the run was streamed (exit 0)."""
    url = f"rerun+http://127.0.0.1:{_free_port()}/proxy"
    started = time.monotonic()
    done = _run_cli(str(CONFIGS / "euler.toml"), "-o", "file.rrd", "--connect", "--url", url, cwd=tmp_path)
    assert time.monotonic() - started < 15.0
    assert done.returncode == 0, done.stderr
    assert done.stderr.decode().strip() == f"rotlab: --connect: no viewer answers at {url}: the run goes to file.rrd only"
    assert "  live " not in done.stdout.decode()  # the summary does not say the run was streamed
    verify_rrd(tmp_path / "file.rrd")


def test_connect_to_no_viewer_without_a_file_runs_nothing(tmp_path):
    url = f"rerun+http://127.0.0.1:{_free_port()}/proxy"
    done = _run_cli(str(CONFIGS / "euler.toml"), "--connect", "--url", url, cwd=tmp_path)
    assert done.returncode == 1
    assert done.stderr.decode().strip().splitlines() == [f"rotlab: error: --connect: no viewer answers at {url}, and no -o FILE was "
                                                "given: nothing was run (add -o run.rrd to keep the run in a file)"]
    assert list(tmp_path.iterdir()) == []


def test_a_batch_onto_a_full_disk_reports_each_case_and_leaves_no_temporary(full_tmpfs):
    outdir = full_tmpfs / "out"
    outdir.mkdir()
    with (full_tmpfs / "filler").open("wb") as f:
        try:
            f.write(b"\0" * (1024 * 1024 - 12 * 1024))
        except OSError:
            pass
    done = subprocess.run(ROTLAB + ["batch", str(CONFIGS / "euler.toml"), "-o", str(outdir)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 1 and "Traceback" not in done.stderr + done.stdout
    assert "could not write the recording" in done.stdout and "No space left on device" in done.stdout
    assert not [p.name for p in outdir.iterdir() if p.name.startswith(".") or p.suffix == ".rrd"]
