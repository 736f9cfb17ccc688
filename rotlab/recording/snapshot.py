"""``rotlab snapshot``: a PNG of the Rerun viewer itself showing a recording at time T.

A headless viewer (``rerun --headless --renderer vulkan``) is started on a free local port and
driven through ``rerun.experimental.ViewerClient``: open the file, wait until the viewer reports
nothing left loading, set the time cursor, then take frames until two consecutive frames are
identical (the data is drawn, plots have auto-ranged, start-up notices have faded) and keep that
frame.  A small recording is shot as soon as the viewer settles, a large one waits as long as
it takes to load (up to ``SETTLE_LIMIT``).  Works for run and sweep recordings (any recording
on the ``sim_time`` timeline).  Without a GPU this needs Mesa's software Vulkan driver (Debian:
mesa-vulkan-drivers, libvulkan1).
"""

from __future__ import annotations

import glob
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

from rotlab.errors import InputError, RunFailure
from rotlab.recording import layout

SOFTWARE_VULKAN = "/usr/share/vulkan/icd.d/lvp_icd*.json"
SETTLE_LIMIT = 120.0  # s: give up waiting for a still frame after this long
CONNECT_SECONDS = 30.0
POLL_SECONDS = 0.2
NOTICE_SECONDS = 5.0  # s after start-up: the viewer's start-up notices have faded (with a margin)


def parse_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise InputError("--size", f"'{text}' is not WIDTHxHEIGHT, e.g. 1600x900") from None
    if not (320 <= width <= 7680 and 240 <= height <= 4320):
        raise InputError("--size", f"{width}x{height} is outside 320x240 … 7680x4320")
    return width, height


def rerun_executable() -> str:
    beside = Path(sys.executable).with_name("rerun")
    found = str(beside) if beside.exists() else shutil.which("rerun")
    if not found:
        raise RunFailure("the `rerun` command (from rerun-sdk) is not on PATH")
    return found


def vulkan_environment() -> dict[str, str]:
    """The environment for the viewer: Mesa's software Vulkan driver unless one is chosen."""
    env = dict(os.environ)
    if "VK_ICD_FILENAMES" not in env:
        software = sorted(glob.glob(SOFTWARE_VULKAN))
        if software:
            env["VK_ICD_FILENAMES"] = software[0]
        elif not glob.glob("/usr/share/vulkan/icd.d/*.json"):
            raise RunFailure("no Vulkan driver found: install Mesa's software renderer (Debian: mesa-vulkan-drivers libvulkan1)")
    return env


def recording_span(path: Path) -> tuple[float, float]:
    """(first, last) time (s) of any temporal data on the ``sim_time`` timeline."""
    import pyarrow as pa
    from rerun.chunk import RrdReader

    low = high = None
    for chunk in RrdReader(str(path)).stream().filter(is_static=False).to_chunks():
        batch = chunk.to_record_batch()
        if layout.TIMELINE not in batch.schema.names or not batch.num_rows:
            continue
        ns = batch.column(layout.TIMELINE).cast(pa.int64()).to_numpy()
        low = ns.min() if low is None else min(low, ns.min())
        high = ns.max() if high is None else max(high, ns.max())
    if low is None:
        raise ValueError("no data on the sim_time timeline")
    return float(low) * 1e-9, float(high) * 1e-9


def snapshot(recording: Path, output: Path, at: float | None, size: tuple[int, int], settle_limit: float = SETTLE_LIMIT) -> Path:
    """Write a PNG of the viewer showing ``recording`` at time ``at`` (s; None: the end)."""
    from rerun.experimental import ViewerClient

    from rotlab.recording.writer import check_output_path

    if not recording.is_file():
        raise InputError(str(recording), "no such recording")
    check_output_path(output)
    try:
        start, end = recording_span(recording)
    except Exception:
        raise InputError(str(recording), "not a rotlab recording (no data on the sim_time timeline)") from None
    if at is not None and not start <= at <= end:
        raise InputError("--time", f"{at:g} s is outside the recording's span [{start:g}, {end:g}] s")
    port = _free_port()
    started = time.monotonic()
    viewer = subprocess.Popen(
        [rerun_executable(), "--headless", "--renderer", "vulkan", "--window-size", f"{size[0]}x{size[1]}",
         "--port", str(port), "--hide-welcome-screen"],
        env=vulkan_environment(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        start_new_session=True,  # `rerun` is a wrapper that starts the viewer as a child: end the group
    )
    tmp = output.with_name(f".{output.stem}.{os.getpid()}.tmp.png")
    try:
        client = _connect(ViewerClient, port, viewer)
        try:
            client.open(str(recording.resolve()))
            _wait_loaded(client, settle_limit)
            client.set_time(layout.TIMELINE, duration=end if at is None else at, play_state="paused")
            tmp.write_bytes(_still_frame(client, started + NOTICE_SECONDS, settle_limit))
        except RunFailure:
            raise
        except Exception as exc:  # the viewer's gRPC errors: report, don't trace back
            raise RunFailure(f"the headless viewer failed: {type(exc).__name__}: {exc}") from None
        if not tmp.exists():
            raise RunFailure("the viewer did not write a screenshot")
        os.replace(tmp, output)
    finally:
        tmp.unlink(missing_ok=True)
        _stop(viewer)
    return output


def _stop(viewer: subprocess.Popen, grace: float = 10.0) -> None:
    """End the viewer and every process it started (its process group): SIGTERM, then SIGKILL
    for whatever is left after ``grace`` seconds."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(viewer.pid, sig)
        except ProcessLookupError:
            break
        deadline = time.monotonic() + grace
        while time.monotonic() < deadline:
            viewer.poll()  # reap the direct child
            try:
                os.killpg(viewer.pid, 0)  # anyone left in the group?
            except ProcessLookupError:
                return
            time.sleep(0.1)
    viewer.poll()


def _wait_loaded(client, limit: float) -> None:
    """Poll the viewer until it reports nothing left loading and an active recording."""
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        state = client.get_state()
        if not state.loading and state.active_recording is not None:
            return
        time.sleep(POLL_SECONDS)
    raise RunFailure(f"the viewer was still loading the recording after {limit:g} s")


def _still_frame(client, not_before: float, limit: float) -> bytes:
    """Frames until two consecutive ones, the second taken after ``not_before`` (monotonic s),
    are identical (drawn and settled); that frame (PNG)."""
    deadline = time.monotonic() + limit
    previous = client.take_screenshot()
    while time.monotonic() < deadline:
        time.sleep(POLL_SECONDS)
        frame = client.take_screenshot()
        if frame == previous and time.monotonic() >= not_before:
            return frame
        previous = frame
    raise RunFailure(f"the viewer did not settle on a still frame within {limit:g} s")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _connect(client_type, port: int, viewer: subprocess.Popen):
    deadline = time.monotonic() + CONNECT_SECONDS
    while time.monotonic() < deadline:
        if viewer.poll() is not None:
            tail = (viewer.stderr.read() or b"").decode(errors="replace").strip().splitlines()[-1:] if viewer.stderr else []
            raise RunFailure(f"the headless viewer exited ({viewer.returncode}): {' '.join(tail) or 'no message'}")
        try:
            client = client_type.connect(f"rerun+http://127.0.0.1:{port}/proxy")
            client.get_state()
            return client
        except Exception:
            time.sleep(0.2)
    raise RunFailure(f"the headless viewer did not answer within {CONNECT_SECONDS:g} s")
