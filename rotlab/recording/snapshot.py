"""``rotlab snapshot``: a PNG of the Rerun viewer itself showing a recording at time T.

A headless viewer (``rerun --headless --renderer vulkan``) is started on a free local port and
driven through ``rerun.experimental.ViewerClient``: open the file, set the time cursor, let the
viewer settle (start-up notices fade, plots auto-range), save a screenshot, quit.  Without a GPU
this needs Mesa's software Vulkan driver (Debian: mesa-vulkan-drivers, libvulkan1).
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
SETTLE_SECONDS = 9.0  # the viewer's start-up notices fade after ~8 s
CONNECT_SECONDS = 30.0


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
    from rotlab.recording.reader import read_series

    t, _ = read_series(path, layout.OMEGA)
    return float(t[0]), float(t[-1])


def snapshot(recording: Path, output: Path, at: float | None, size: tuple[int, int], settle: float = SETTLE_SECONDS) -> Path:
    """Write a PNG of the viewer showing ``recording`` at time ``at`` (s; None: the end)."""
    from rerun.experimental import ViewerClient

    from rotlab.recording.writer import check_output_path

    if not recording.is_file():
        raise InputError(str(recording), "no such recording")
    check_output_path(output)
    try:
        start, end = recording_span(recording)
    except Exception:
        raise InputError(str(recording), "not a rotlab recording (no /body/omega series)") from None
    if at is not None and not start <= at <= end:
        raise InputError("--time", f"{at:g} s is outside the recording's span [{start:g}, {end:g}] s")
    port = _free_port()
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
            client.set_time(layout.TIMELINE, duration=end if at is None else at, play_state="paused")
            time.sleep(settle)
            client.save_screenshot(str(tmp.resolve()))
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
