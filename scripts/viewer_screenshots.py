#!/usr/bin/env python3
"""Screenshots of a recording in the Rerun viewer at chosen moments, and how long the viewer
takes to open it: the rerun-sdk viewer of the reference venv, software rendering, no display.

Usage (with the venv's python, from the repository root):
    .venv-ref/bin/python scripts/viewer_screenshots.py REC.mcap OUTDIR NAME=WHEN... [--no-load]

WHEN is seconds of robot time from the recording's first message (95.5), or `log:TEXT` for
the first line of `rodlog log REC` containing TEXT, with an optional `+S` (`log:clamped+1`).
The README's pictures (the demo: the recalibration, the hook on the wire, the remove):
    .venv-ref/bin/python scripts/viewer_screenshots.py demo/demo.mcap viz/docs \\
        recalibration=log:self-calibration+1 hook=log:clamped: remove=log:remove unhook+4

Each picture: `rodlog view REC --until S -o NAME.rrd` (the viewer follows the newest data, so
it opens on that moment), a headless viewer (`rerun --headless --window-size 1280x800`) loads
it, and once two screenshots 3 s apart are identical (the recording is loaded and drawn) the
last one is kept as OUTDIR/NAME.png (2560x1600). The headless viewer is the GUI viewer's
egui app driven offscreen; under Xvfb the windowed viewer's `--screenshot-to` also shows a
start-up toast ("Surface width and height must be within the maximum supported texture
size") over the views, which this avoids.

Then the load time of the whole recording (OUTDIR/full.rrd, `rodlog view REC -o`), two ways:
* `screenshot_s`: the issue's measure, the wall time of
  `xvfb-run rerun full.rrd --window-size 1280x800 --screenshot-to shot.png` (the viewer
  quits 10 frames after start, loaded or not; needs xvfb-run);
* `loaded_s`: seconds until the headless viewer's screenshots stop changing (the time cursor,
  which follows the newest data, reached the end).
And the same for an empty recording (the floor on this machine). `--no-load` skips these.

Needs: target/release/rodlog (or RODLOG); a Vulkan rasteriser (apt-get install -y
mesa-vulkan-drivers; xvfb for `screenshot_s`). Prints one line per picture and measure.
"""

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

import rerun as rr
from rerun.experimental import ViewerClient

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RERUN = os.path.join(os.path.dirname(sys.executable), "rerun")
RODLOG = os.environ.get("RODLOG", os.path.join(ROOT, "target", "release", "rodlog"))
WINDOW = os.environ.get("WINDOW", "1280x800")
ENV = dict(os.environ, RERUN_ANALYTICS="0")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def seconds_of(rec: str, when: str) -> float:
    if not when.startswith("log:"):
        return float(when)
    text, extra = when[4:], 0.0
    if "+" in text:
        text, plus = text.rsplit("+", 1)
        extra = float(plus)
    log = subprocess.run([RODLOG, "log", rec], check=True, capture_output=True, text=True)
    for line in log.stdout.splitlines():
        if text in line:
            return float(line.split()[0]) + extra
    sys.exit(f"no line with {text!r} in `rodlog log {rec}`")


def view(rec: str, rrd: str, until: float | None = None) -> None:
    args = [RODLOG, "view", rec, "-o", rrd]
    if until is not None:
        args += ["--until", f"{until:.3f}"]
    subprocess.run(args, check=True, capture_output=True)


def headless_shots(rrd: str, png: str, timeout_s: float = 300.0) -> float:
    """Screenshots every 3 s until two are identical; keeps the last; returns the seconds from
    the viewer's start to the first of the two identical ones."""
    port = free_port()
    start = time.monotonic()
    viewer = subprocess.Popen(
        [RERUN, "--headless", "--window-size", WINDOW, "--port", str(port), rrd],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
        env=ENV,
    )
    try:
        client = None
        while client is None:
            if time.monotonic() - start > 60:
                sys.exit(f"the headless viewer did not listen on {port}")
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=1):
                    client = ViewerClient(f"rerun+http://127.0.0.1:{port}/proxy")
            except OSError:
                time.sleep(0.5)
        previous, previous_t = None, 0.0
        with tempfile.TemporaryDirectory() as tmp:
            n = 0
            while time.monotonic() - start < timeout_s:
                n += 1
                shot = os.path.join(tmp, f"{n}.png")
                t = time.monotonic() - start
                client.save_screenshot(shot)
                for _ in range(100):
                    if os.path.exists(shot) and os.path.getsize(shot) > 0:
                        break
                    time.sleep(0.1)
                time.sleep(0.5)  # the file is written whole
                data = open(shot, "rb").read()
                if previous is not None and data == previous:
                    shutil.copyfile(shot, png)
                    return previous_t
                previous, previous_t = data, t
                time.sleep(3.0)
        sys.exit(f"{rrd} was still changing after {timeout_s} s")
    finally:
        os.killpg(viewer.pid, signal.SIGINT)
        try:
            viewer.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(viewer.pid, signal.SIGKILL)


def screenshot_to(rrd: str, png: str) -> float:
    start = time.monotonic()
    subprocess.run(
        ["xvfb-run", "-a", "-s", "-screen 0 2800x1800x24", RERUN, rrd, "--port", "auto",
         "--window-size", WINDOW, "--screenshot-to", png],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=ENV,
    )
    if not os.path.exists(png):
        sys.exit(f"the viewer wrote no {png}")
    return time.monotonic() - start


def main() -> None:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) < 2:
        sys.exit(__doc__)
    rec, out, moments = args[0], args[1], args[2:]
    os.makedirs(out, exist_ok=True)
    for m in moments:
        name, when = m.split("=", 1)
        s = seconds_of(rec, when)
        rrd = os.path.join(out, f"{name}.rrd")
        view(rec, rrd, s)
        secs = headless_shots(rrd, os.path.join(out, f"{name}.png"))
        print(f"{name:<16} at {s:8.3f} s  {os.path.getsize(rrd):>12} B  loaded in {secs:5.1f} s")
        os.remove(rrd)
    if "--no-load" in sys.argv:
        return
    with tempfile.TemporaryDirectory() as tmp:
        empty = os.path.join(tmp, "empty.rrd")
        rr.init("rodlog", recording_id="empty")
        rr.save(empty)
        rr.log("world", rr.CoordinateFrame("map"), static=True)
        rr.disconnect()
        full = os.path.join(out, "full.rrd")
        view(rec, full)
        for label, f in [("empty", empty), ("full", full)]:
            shot = screenshot_to(f, os.path.join(tmp, f"{label}_shot.png"))
            loaded = headless_shots(f, os.path.join(tmp, f"{label}_loaded.png"))
            print(f"{label:<6} {os.path.getsize(f):>12} B  screenshot_s {shot:5.1f}  loaded_s {loaded:5.1f}")
        print(f"mcap   {os.path.getsize(rec):>12} B")
        os.remove(full)


if __name__ == "__main__":
    main()
