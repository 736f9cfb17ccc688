"""`rotlab run --serve-web` in a real browser: Debian's headless Chromium, driven by Playwright,
loads Rerun's web viewer from the URL rotlab prints and shows the recording.

"Shows the recording" is read off the page's pixels: the body is drawn in ``style.BODY`` (a
shaded gold) and the space components of L in ``style.X_RED``/``style.Y_GREEN`` (sinusoids in
the L plot).  While the viewer starts (its wasm compiles for 10–30 s in software) or has the
layout but no data yet, the gold count is 0; with the recording shown it is ~8,900 at
1280 × 720 (and ~550–740 pixels of each L line).

Needs ``chromium`` on PATH (.ci/run installs Debian's package) and ``playwright`` (the test
extra); skipped with the reason when either is missing, unless ``ROTLAB_REQUIRE_BROWSER=1``
(set by .ci/run), which turns a missing browser into a failure.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from rotlab.recording import layout, style
from rotlab.recording.reader import read_series
from rotlab.recording.sink import verify_rrd
from tests.conftest import CONFIGS

BROWSER_FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]  # a closed network: no calls home
GOLD_SHOWN = 3000  # pixels of the body's colour when the recording is drawn (~8,900 seen; 0 before)
LINE_SHOWN = 300  # pixels of each L-plot line colour
PAGE_SECONDS = 150.0  # the wasm viewer compiles in software on a busy 2-core machine


def _browser() -> str:
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    try:
        import playwright  # noqa: F401
    except ImportError:
        chromium = None
    if chromium is None:
        why = "needs Debian's chromium and the playwright package (pip install '.[test]')"
        if os.environ.get("ROTLAB_REQUIRE_BROWSER") == "1":
            pytest.fail(f"ROTLAB_REQUIRE_BROWSER=1 but the browser test {why}")
        pytest.skip(why)
    return chromium


def _near(image: np.ndarray, colour: tuple[int, int, int], tolerance: int) -> np.ndarray:
    return np.all(np.abs(image - np.array(colour)) <= tolerance, axis=-1)


def shown(image: np.ndarray) -> dict[str, int]:
    """Pixel counts that say whether the recording is drawn: the shaded body (``style.BODY``,
    hue 44°, saturation 0.55, kept by shading), and the red and green lines of the L plot (right
    half of the page).  The orange badge and the ω arrow (hue 35°, saturation 0.88) do not count."""
    top, low = image.max(axis=-1), image.min(axis=-1)
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        hue = 60.0 * (g - b) / (r - low)  # degrees, where red is the largest component
        saturation = (top - low) / top
    gold = (r == top) & (b == low) & (top >= 90) & (hue >= 35) & (hue <= 52) & (saturation >= 0.3) & (saturation <= 0.75)
    right = image[:, image.shape[1] // 2 :]
    return {"body": int(gold.sum()), "L_X": int(_near(right, style.X_RED, 30).sum()),
            "L_Y": int(_near(right, style.Y_GREEN, 30).sum())}


def test_web_viewer_in_headless_chromium_shows_the_recording(tmp_path):
    chromium = _browser()
    from PIL import Image
    from playwright.sync_api import sync_playwright

    grpc, web = _free_port(), _free_port()
    proc = subprocess.Popen([sys.executable, "-m", "rotlab", "run", str(CONFIGS / "lagrange.toml"), "-o", "web.rrd", "--serve-web",
                             "--port", str(grpc), "--web-port", str(web)],
                            cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    counts: dict[str, int] = {}
    try:
        url = _served_url(proc)
        assert url.startswith(f"http://127.0.0.1:{web}/?url=rerun+http://127.0.0.1:{grpc}/proxy")
        with sync_playwright() as driver:
            browser = driver.chromium.launch(executable_path=chromium, args=BROWSER_FLAGS)
            try:
                page = browser.new_page(viewport={"width": 1280, "height": 720})
                page.goto(url, timeout=60_000)
                deadline = time.monotonic() + PAGE_SECONDS
                while time.monotonic() < deadline:
                    page.screenshot(path=str(tmp_path / "page.png"))
                    counts = shown(np.asarray(Image.open(tmp_path / "page.png").convert("RGB")).astype(int))
                    if counts["body"] >= GOLD_SHOWN and min(counts["L_X"], counts["L_Y"]) >= LINE_SHOWN:
                        break
                    time.sleep(1.0)
            finally:
                browser.close()
    finally:
        proc.send_signal(signal.SIGINT)  # --serve-web serves until Ctrl-C, then finishes the file
        _, err = proc.communicate(timeout=60)
    assert counts.get("body", 0) >= GOLD_SHOWN and min(counts["L_X"], counts["L_Y"]) >= LINE_SHOWN, (
        f"the page did not show the recording within {PAGE_SECONDS:.0f} s: {counts} (screenshot {tmp_path / 'page.png'})")
    assert proc.returncode == 0, err
    verify_rrd(tmp_path / "web.rrd")
    assert read_series(tmp_path / "web.rrd", layout.QUATERNION)[0].shape[0] == 2001


def test_the_pixel_check_tells_an_empty_viewer_from_a_shown_recording():
    """The check is not vacuous: a blank page and the viewer's bare layout (grey grid lines, no
    body) stay far below the thresholds; the body's own colour, shaded, counts."""
    page = np.full((720, 1280, 3), 255)
    page[100:110, :] = (200, 200, 200)  # grid lines
    page[30:40, 100:300] = (255, 160, 30)  # the orange badge
    assert shown(page)["body"] < 200
    for shade in (0.55, 0.8, 1.0):
        page[300:400, 200:300] = np.round(np.array(style.BODY) * shade)
    assert shown(page)["body"] >= GOLD_SHOWN


def _served_url(proc: subprocess.Popen) -> str:
    """The web viewer's URL, from the line `rotlab run --serve-web` prints."""
    assert proc.stderr is not None
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line and proc.poll() is not None:
            break
        found = re.search(r"(http://127\.0\.0\.1:\d+/\?url=\S+)", line)
        if found:
            return found.group(1)
    raise AssertionError(f"rotlab run --serve-web printed no URL (exit {proc.poll()})")


def _free_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _listening(port: int) -> set[str]:
    """The local addresses (hex, as /proc/net/tcp writes them) listening on ``port``."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        if not os.path.exists(table):
            continue
        for line in open(table).read().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            address, hex_port = local.split(":")
            if state == "0A" and int(hex_port, 16) == port:  # 0A: LISTEN
                found.add(address)
    return found


@pytest.mark.skipif(not os.path.exists("/proc/net/tcp"), reason="reads the listening sockets from /proc/net/tcp")
def test_serve_web_keeps_the_runs_data_on_this_machine(tmp_path):
    grpc, web = _free_port(), _free_port()
    proc = subprocess.Popen([sys.executable, "-m", "rotlab", "run", str(CONFIGS / "euler.toml"), "-o", "web.rrd", "--serve-web",
                             "--port", str(grpc), "--web-port", str(web)],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _served_url(proc)
        assert _listening(grpc) == {"0100007F"} and _listening(web) == {"0100007F"}  # 127.0.0.1 only, data and viewer
    finally:
        proc.send_signal(signal.SIGINT)  # --serve-web serves until Ctrl-C, then finishes the file
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    verify_rrd(tmp_path / "web.rrd")  # raises unless complete


def test_serve_web_on_a_busy_port_says_so_in_one_line_and_writes_the_file(cli, tmp_path):
    import socket

    with socket.socket() as holder:
        holder.bind(("127.0.0.1", 0))
        holder.listen()
        port = holder.getsockname()[1]
        result = cli("run", str(CONFIGS / "euler.toml"), "-o", "web.rrd", "--serve-web", "--port", str(port), "-q")
        alone = cli("run", str(CONFIGS / "euler.toml"), "--serve-web", "--port", str(port), "-q")
    assert result.exit_code == 0
    assert result.stderr.strip() == f"rotlab: --serve-web: --port {port} is in use by another program (choose another), so no web viewer: the run goes to web.rrd only"
    verify_rrd(tmp_path / "web.rrd")
    assert alone.exit_code == 1 and "nothing was run" in alone.stderr and len(alone.stderr.strip().splitlines()) == 1


def test_serve_web_refuses_an_address_of_another_machine(cli, tmp_path):
    result = cli("run", str(CONFIGS / "euler.toml"), "-o", "web.rrd", "--serve-web", "--bind", "192.0.2.1")
    assert result.exit_code == 2 and result.stderr.startswith("rotlab: error: --bind 192.0.2.1: cannot listen there")
    assert not (tmp_path / "web.rrd").exists()
