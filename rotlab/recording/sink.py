"""Where a recording goes: a file, live viewers, or both — the one place that writes bytes.

The file.  Rerun encodes the stream (its ``FileSink``) into a pipe, not into the file: a pump
thread copies the pipe into a temporary file beside the target with ``os.write``, so every
write is checked.  A write error (disk full, file system gone) is remembered, the pump keeps
draining the pipe (Rerun never blocks on it, so nothing can hang), and the writer raises
``RunFailure`` at its next chunk.  When the stream ends, the finished file is verified before
the atomic rename:

* the size on disk equals the bytes Rerun produced;
* the RRD stream footer is there: the last 32 bytes are
  ``[footer offset u64][footer length u64][crc u32]["RRF2FOOT"][version u32]`` (little endian)
  and offset + length + 32 = file size;
* Rerun's own reader decodes the footer's manifest and finds this recording.

(``rerun rrd verify`` is no substitute: it exits 0 on an empty or truncated file.)  A failed
run's temporary file is removed and an existing file at the target is never touched.

Live viewers (``--spawn``, ``--connect``, ``--serve-web``) are Rerun's own gRPC sinks on a
second stream with the same recording id: the same data, the same blueprint.  That stream is fed
by a thread of its own (``_LiveFeed``): a viewer that stops reading blocks Rerun's gRPC sink
(sends and flushes alike, for ever, and Ctrl-C cannot reach a thread blocked there), and only
that thread waits.  A viewer that falls more than ``LIVE_BEHIND`` chunks behind is given up for
the rest of the run; the file never waits for a viewer.  ``--serve-web`` streams to a ``rerun
--serve-web --bind …`` child process, which serves the web viewer and holds the run for it, on
loopback unless asked otherwise.  A viewer that is not there when the run starts (no answer,
no display, a port in use) is left out at once, and ``unreached`` says so.
"""

from __future__ import annotations

import os
import queue
import subprocess
import threading
import uuid
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

from rotlab.errors import RunFailure, first_line

FOOTER_MAGIC = b"RRF2FOOT"
STREAM_FOOTER_BYTES = 32
PIPE_READ = 1 << 20
FLUSH_TIMEOUT = 120.0  # s: Rerun's encoder drains into our pump, which never blocks: a safety net only
LIVE_TIMEOUT = 10.0  # s: at the end, how long the live viewers get to take the rest
LIVE_BEHIND = 8  # chunks (flushes) a live viewer may lag behind the file before it is given up


LOOPBACK = "127.0.0.1"


def port_in_use(host: str, port: int) -> bool:
    """Whether ``host:port`` is taken (a listening socket of another program); OSError when
    ``host`` is no address of this machine."""
    import errno
    import socket

    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as probe:
        try:
            probe.bind((host, port))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                return True
            raise
    return False


def listening(url: str, wait: float) -> bool:
    """Whether something accepts connections at a viewer's gRPC URL (rerun+http://HOST:PORT/…)
    within ``wait`` seconds."""
    import socket
    import time
    from urllib.parse import urlsplit

    parts = urlsplit(url.replace("rerun+", "", 1))
    host, port = parts.hostname or "127.0.0.1", parts.port or 9876
    deadline = time.monotonic() + wait
    while True:
        try:
            with socket.create_connection((host, port), timeout=0.5):
                return True
        except OSError:
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.1)


def _start_web_server(live: LiveOptions) -> subprocess.Popen:
    """The ``rerun`` executable serving the web viewer and the run's data, both on ``live.bind``:
    Rerun's Python calls (``GrpcServerSink``'s host aside, ``serve_web_viewer`` has none) would
    listen on every interface.  The binary itself, not the ``rerun`` script that would start it as
    a child of its own: it dies with this process (Linux ``PR_SET_PDEATHSIG``), and in a process
    group of its own, which ``_stop_web_server`` ends whole."""
    import shutil
    import sys

    try:
        import rerun_cli  # the package rerun-sdk installs the binary with

        binary: Path | None = Path(rerun_cli.__file__).with_name("rerun")
    except ImportError:
        binary = None
    executable = str(binary) if binary is not None and binary.exists() else shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
    argv = [executable, "--serve-web", "--bind", live.bind, "--port", str(live.grpc_port), "--web-viewer-port", str(live.web_port or 9090)]
    return subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            preexec_fn=_die_with_parent, start_new_session=True)


def _die_with_parent() -> None:
    """In a child, before exec: SIGKILL it when this process exits (Linux; elsewhere nothing)."""
    import ctypes
    import signal

    try:
        ctypes.CDLL(None).prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


CONNECT_WAIT = 2.0  # s: how long --connect's viewer gets to answer before the run goes to the file alone
SPAWN_WAIT = 15.0  # s: how long a spawned viewer gets to start listening (a software renderer is slow)


@dataclass(frozen=True)
class LiveOptions:
    """Live sinks, Rerun's way: spawn a viewer, connect to one, or serve the web viewer."""

    spawn: bool = False
    connect: str | None = None  # gRPC URL, e.g. rerun+http://127.0.0.1:9876/proxy
    serve_web: bool = False
    web_port: int | None = None
    grpc_port: int = 9876
    bind: str = LOOPBACK  # the address --serve-web's servers listen on: this machine only, unless asked

    def check_bind(self) -> None:
        """``InputError`` unless ``bind`` is an address of this machine (--serve-web listens there)."""
        from rotlab.errors import InputError

        try:
            port_in_use(self.bind, 0)
        except OSError as exc:
            raise InputError(f"--bind {self.bind}", f"cannot listen there ({exc}): give an address of this machine, e.g. 127.0.0.1") from None

    def busy_port(self) -> str | None:
        """The first of --serve-web's ports that another program holds, as an option (None: both free)."""
        for option, number in (("--port", self.grpc_port), ("--web-port", self.web_port or 9090)):
            if port_in_use(self.bind, number):
                return f"{option} {number}"
        return None

    @property
    def local_host(self) -> str:
        """Where this machine reaches --serve-web's servers."""
        return LOOPBACK if self.bind in ("0.0.0.0", "::", "") else self.bind

    @property
    def local_url(self) -> str:
        """The gRPC URL of the viewer rotlab starts: --spawn's, or --serve-web's data server."""
        return f"rerun+http://{self.local_host}:{self.grpc_port}/proxy"

    @property
    def any(self) -> bool:
        return self.spawn or self.connect is not None or self.serve_web


class _Pump(threading.Thread):
    """Copies the pipe into the temporary file with checked writes; drains after an error."""

    def __init__(self, read_fd: int, target_fd: int) -> None:
        super().__init__(name="rotlab-rrd-pump", daemon=True)
        self.read_fd, self.target_fd = read_fd, target_fd
        self.written = 0
        self.error: OSError | None = None

    def run(self) -> None:
        while True:
            data = os.read(self.read_fd, PIPE_READ)
            if not data:
                break
            if self.error is None:
                try:
                    view = memoryview(data)
                    while view:
                        n = os.write(self.target_fd, view)
                        self.written += n
                        view = view[n:]
                except OSError as exc:  # keep draining so that Rerun's writer never blocks
                    self.error = exc
        os.close(self.read_fd)


class _LiveFeed(threading.Thread):
    """Calls the live stream's methods in this thread, in order, from a queue: the run only
    queues.  ``flush()`` marks the end of a chunk; past ``LIVE_BEHIND`` chunks not yet delivered
    the feed gives up (``given_up`` says why) and drops what comes after."""

    def __init__(self, rec: rr.RecordingStream) -> None:
        super().__init__(name="rotlab-live-feed", daemon=True)
        self.rec = rec
        self.calls: queue.SimpleQueue = queue.SimpleQueue()
        self.behind = 0  # chunks queued and not yet flushed to the viewers
        self.lock = threading.Lock()
        self.given_up: str | None = None

    def submit(self, method: str, *args, **kwargs) -> None:
        if self.given_up is None:
            self.calls.put((method, args, kwargs))

    def flush(self) -> None:
        """End of a chunk: queue a flush (started, not waited for), or give up if too far behind."""
        with self.lock:
            if self.given_up is None and self.behind >= LIVE_BEHIND:
                self.given_up = f"the live viewer fell {LIVE_BEHIND} chunks behind (stopped reading?): streaming to it stopped"
            if self.given_up is not None:
                return
            self.behind += 1
        self.calls.put(("flush", (), {"timeout_sec": 0.0}))

    def run(self) -> None:
        while (call := self.calls.get()) is not None:
            method, args, kwargs = call
            try:
                getattr(self.rec, method)(*args, **kwargs)
            except Exception as exc:  # noqa: BLE001 — the viewer is gone: the file does not depend on it
                with self.lock:
                    self.given_up = self.given_up or f"the live viewer failed ({exc}): streaming to it stopped"
            if method == "flush":
                with self.lock:
                    self.behind -= 1

    def finish(self, timeout: float) -> bool:
        """Deliver what is queued within ``timeout`` s, then end the thread; False if the viewers
        did not take it in time (the thread is then left waiting on them)."""
        self.calls.put(("flush", (), {"timeout_sec": timeout}))
        self.calls.put(None)
        self.join(timeout + 1.0)
        if self.is_alive() and self.given_up is None:
            self.given_up = f"the live viewer did not take the end of the run in {timeout:g} s"
        return not self.is_alive()


class _Tee:
    """Logs to the file's stream (directly) and the live viewers' (through their feed), either
    of which may be absent."""

    def __init__(self, file_rec: rr.RecordingStream | None, feed: _LiveFeed | None) -> None:
        self.file_rec, self.feed = file_rec, feed

    def log(self, *args, **kwargs) -> None:
        self._both("log", args, kwargs)

    def send_columns(self, entity_path: str, indexes: list, columns: object, **kwargs) -> None:
        """Rerun's ``send_columns`` on both streams; a chunk with no rows is not sent: its time
        range is the whole timeline, and Rerun 0.41's viewer panics drawing its time panel
        (``AbsoluteTimeRange { min: TimeInt::MIN, max: TimeInt::MAX }``: the file does not open)."""
        if any(len(index.as_arrow_array()) == 0 for index in indexes):
            return
        self._both("send_columns", (entity_path, indexes, columns), kwargs)

    def send_blueprint(self, *args, **kwargs) -> None:
        self._both("send_blueprint", args, kwargs)

    def _both(self, method: str, args: tuple, kwargs: dict) -> None:
        if self.file_rec is not None:
            getattr(self.file_rec, method)(*args, **kwargs)
        if self.feed is not None:
            self.feed.submit(method, *args, **kwargs)


class RecordingSink:
    """The recording's streams and sinks.  Use ``rec`` to log; ``drain()`` after each chunk;
    ``close(path)`` to finish, verify and rename; ``abort()`` to drop the file.

    The file and the live viewers get separate Rerun streams with the same recording id, so a
    slow, unreachable or killed viewer can neither stall the file's back-pressure nor its end:
    the live stream is never waited for longer than ``LIVE_TIMEOUT``."""

    def __init__(self, target: Path | None, live: LiveOptions | None = None, application_id: str = "rotlab") -> None:
        self.target = target
        self.live = live or LiveOptions()
        self.recording_id = str(uuid.uuid4())
        self._file_rec = self._live_rec = None
        self._feed: _LiveFeed | None = None
        self.unreached: str | None = None  # a viewer asked for that is not there (the run goes on without it)
        self._web_server: subprocess.Popen | None = None
        if self.live.spawn:
            self._spawn_viewer()
        self._drop_absent_viewers()
        if target is not None:
            self._file_rec = rr.RecordingStream(application_id, recording_id=self.recording_id)
            self._file_rec.set_log_time_enabled(False)
        if self.live.any:
            self._live_rec = rr.RecordingStream(application_id, recording_id=self.recording_id)
            self._live_rec.set_log_time_enabled(False)
            self._feed = _LiveFeed(self._live_rec)
        self.rec = _Tee(self._file_rec, self._feed)
        self.tmp: Path | None = None
        self._pump: _Pump | None = None
        self._write_fd: int | None = None
        self._target_fd: int | None = None
        self.web_url: str | None = None
        self._closed = False
        if target is not None:
            self.tmp = target.with_name(f".{target.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
            self._target_fd = os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            read_fd, self._write_fd = os.pipe()
            self._pump = _Pump(read_fd, self._target_fd)
            self._pump.start()

    def _drop_absent_viewers(self) -> None:
        """A viewer of --connect that does not answer, one --spawn started that never listens (no
        display), or --serve-web on a port in use, is left out before anything is sent to it, and
        ``unreached`` says so: Rerun would retry for 20 s, print its own log lines and report
        nothing, or raise a traceback."""
        if self.live.spawn and not listening(self.live.local_url, SPAWN_WAIT):
            self.unreached = f"--spawn: the Rerun viewer did not start listening on port {self.live.grpc_port} within {SPAWN_WAIT:g} s (no display?)"
            self.live = replace(self.live, spawn=False)
        busy = self.live.busy_port() if self.live.serve_web else None
        if busy is not None:
            self.unreached = f"--serve-web: {busy} is in use by another program (choose another), so no web viewer"
            self.live = replace(self.live, serve_web=False)
        if self.live.serve_web:
            self._web_server = _start_web_server(self.live)
            if not listening(self.live.local_url, SPAWN_WAIT):
                self._stop_web_server()
                self.unreached = f"--serve-web: the Rerun web viewer server did not start within {SPAWN_WAIT:g} s"
                self.live = replace(self.live, serve_web=False)
        if self.live.connect is not None and not listening(self.live.connect, CONNECT_WAIT):
            self.unreached = f"--connect: no viewer answers at {self.live.connect}"
            self.live = replace(self.live, connect=None)

    def _spawn_viewer(self) -> None:
        """Start a Rerun viewer listening on the gRPC port (before any work: a missing viewer is
        a one-line error, not a lost run)."""
        import shutil
        import sys

        executable = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))
        try:
            rr.spawn(port=self.live.grpc_port, connect=False, hide_welcome_screen=True, executable_path=executable)
        except Exception as exc:  # noqa: BLE001 — Rerun raises RuntimeError/OSError with a long help text
            raise RunFailure(f"--spawn: could not start the Rerun viewer ({first_line(exc)})") from None

    def open(self, blueprint: rrb.Blueprint) -> None:
        """Attach every sink (file pipe and live viewers) with the default ``blueprint``."""
        if self._file_rec is not None:
            self._file_rec.set_sinks(rr.FileSink(f"/dev/fd/{self._write_fd}"), default_blueprint=blueprint)
        if self._live_rec is None:
            return
        sinks: list = []
        if self.live.spawn:
            sinks.append(rr.GrpcSink(self.live.local_url))
        if self.live.connect is not None:
            sinks.append(rr.GrpcSink(self.live.connect))
        if self.live.serve_web:
            sinks.append(rr.GrpcSink(self.live.local_url))
            self.web_url = f"http://{self.live.local_host}:{self.live.web_port or 9090}/?url={self.live.local_url}"
        assert self._feed is not None
        # in the feed's thread, like every live call: attaching a sink flushes the stream into it,
        # which waits for ever on a viewer that accepted the connection and never reads
        self._feed.submit("set_sinks", *sinks, default_blueprint=blueprint)
        self._feed.submit("send_blueprint", blueprint, make_active=True)
        self._feed.start()

    def update_blueprint(self, blueprint: rrb.Blueprint) -> None:
        """Replace the default layout (the final one, from the whole run: plot ranges that the
        first chunk alone could not know) in the file and in live viewers."""
        self.rec.send_blueprint(blueprint, make_active=True, make_default=True)

    def drain(self) -> None:
        """Wait until Rerun has encoded what was sent to the file and the pump has taken it:
        back-pressure, so that memory holds one chunk, not a backlog that grows with the run."""
        if self._file_rec is not None:
            self._file_rec.flush(timeout_sec=FLUSH_TIMEOUT)
        if self._feed is not None:
            self._feed.flush()  # queued: never waits for a viewer
        self.check()

    @property
    def watched(self) -> bool:
        """Do live viewers take the run as it goes (then the writer sends what it collects often)?"""
        return self.live.any

    @property
    def live_problem(self) -> str | None:
        """Why the live viewers stopped receiving the run (None while they keep up)."""
        return None if self._feed is None else self._feed.given_up

    def check(self) -> None:
        """Raise ``RunFailure`` if a write to the file has failed (disk full, …)."""
        if self._pump is not None and self._pump.error is not None:
            raise RunFailure(f"could not write the recording {self.target}: {self._pump.error.strerror or self._pump.error}")

    def _finish_stream(self) -> None:
        """Flush Rerun's encoder, end the stream (footer) and wait for the pump to drain it."""
        if self._closed:
            return
        self._closed = True
        feed = self._feed
        if feed is not None and feed.is_alive() and feed.given_up is None and feed.finish(LIVE_TIMEOUT):
            self._live_rec.disconnect()  # delivered; a feed still waiting on a viewer is left to it
        self._stop_web_server()
        if self._file_rec is None:
            return
        try:
            self._file_rec.flush(timeout_sec=FLUSH_TIMEOUT)
        finally:
            self._file_rec.disconnect()
            if self._write_fd is not None:
                os.close(self._write_fd)
            if self._pump is not None:
                self._pump.join(FLUSH_TIMEOUT)
            if self._target_fd is not None:
                os.close(self._target_fd)

    def close(self, path: Path | None = None) -> Path | None:
        """End the stream; verify the file and rename it to ``path`` (default: the target).
        On any failure the temporary file is removed and ``RunFailure`` raised."""
        try:
            self._finish_stream()
            if self.tmp is None:
                return None
            if self._pump is not None and self._pump.is_alive():
                raise RunFailure(f"could not write the recording {self.target}: the file system did not take the data in {FLUSH_TIMEOUT:g} s")
            self.check()
            self._verify()
            final = path or self.target
            assert final is not None
            os.replace(self.tmp, final)
            return final
        except (OSError, RuntimeError) as exc:
            self._remove_tmp()
            raise RunFailure(f"could not write the recording {path or self.target}: {exc}") from None
        except BaseException:
            self._remove_tmp()
            raise

    def abort(self) -> None:
        """Drop everything: end the stream and remove the temporary file (never the target)."""
        try:
            self._finish_stream()
        except Exception:  # noqa: BLE001 — the run already failed; the file goes anyway
            pass
        self._remove_tmp()

    def _stop_web_server(self) -> None:
        """End --serve-web's server (it holds the run for the browser, so it lives until the end)."""
        import signal

        server, self._web_server = self._web_server, None
        if server is None:
            return
        for signum in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(server.pid, signum)  # its group: a wrapper script's child too
            except ProcessLookupError:
                break
            try:
                server.wait(timeout=5.0)
                break
            except subprocess.TimeoutExpired:
                continue

    def _remove_tmp(self) -> None:
        if self.tmp is not None:
            self.tmp.unlink(missing_ok=True)

    def _verify(self) -> None:
        assert self.tmp is not None and self._pump is not None
        verify_rrd(self.tmp, expected_size=self._pump.written, recording_id=self.recording_id)


def verify_rrd(path: Path, expected_size: int | None = None, recording_id: str | None = None) -> None:
    """Raise ``RunFailure`` unless ``path`` is a complete RRD stream (see the module docstring)."""
    size = path.stat().st_size
    if expected_size is not None and size != expected_size:
        raise RunFailure(f"recording {path} is {size:,} bytes on disk, {expected_size:,} were written")
    if size < STREAM_FOOTER_BYTES:
        raise RunFailure(f"recording {path} is incomplete ({size} bytes)")
    with open(path, "rb") as f:
        f.seek(size - STREAM_FOOTER_BYTES)
        tail = f.read(STREAM_FOOTER_BYTES)
    offset, length = int.from_bytes(tail[0:8], "little"), int.from_bytes(tail[8:16], "little")
    if tail[20:28] != FOOTER_MAGIC or offset + length + STREAM_FOOTER_BYTES != size:
        raise RunFailure(f"recording {path} is incomplete: no RRD footer at its end")
    from rerun.chunk import RrdReader

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # "no footer/manifest" is a warning in Rerun's reader
        try:
            reader = RrdReader(path)
            stores = reader.recordings()
            ids = [s.recording_id for s in stores]
            if recording_id is not None and recording_id not in ids:
                raise RunFailure(f"recording {path} does not hold this run's recording (found {ids})")
            reader.store(store=stores[ids.index(recording_id)] if recording_id in ids else None)
        except RunFailure:
            raise
        except Exception as exc:  # noqa: BLE001 — Rerun's reader raises RuntimeError/ValueError/warnings
            raise RunFailure(f"recording {path} does not read back: {exc}") from None
