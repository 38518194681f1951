"""Does ``liquidtouch live`` cost the same after 10 minutes as after 1? A soak test.

    python benchmarks/live_soak.py [--minutes 10] [--fps 30] [--out DIR]

Two simulated cameras (the rig's :class:`~liquidtouch.sim.rig.mjpeg.MjpegServer` on
127.0.0.1, in a process of their own) stream synthetic GelSight Mini frames at ``--fps``:
marker dots drawn where :func:`~liquidtouch.sim.protocol_scene.protocol_scene` puts
them (mirin, 25 mm: grasp, lift, push, 13 s hold, lowering, release), the protocol
repeated back to back. The real command line, ``liquidtouch live URL URL --serve
127.0.0.1:0 --json --max-duration S``, runs in a third process, and a plain SSE
client reads its ``/stream`` as a browser would (and fetches each sensor's frame at
5 Hz, as the page does). Every second the live process's CPU time and RSS are read
from ``/proc``; its JSON lines give each update's ``lag_s``; the SSE client counts the
bytes of each ``update`` event.

Prints one row per minute (CPU %, RSS, median lag, mean bytes per update) and minute 1
against the last minute (must differ by < 20 %), and writes ``soak.json`` to ``--out``.
``--minutes 1`` is the smoke test.
"""

from __future__ import annotations

import argparse
import http.client
import json
import logging
import math
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np

logger = logging.getLogger(__name__)

#: the quantities compared between minute 1 and the last minute, and their table headers
COMPARED = {
    "cpu_percent": "CPU [%]",
    "rss_mb": "RSS [MB]",
    "lag_s": "lag median [s]",
    "bytes_per_update": "bytes/update",
}
#: largest allowed relative difference between minute 1 and the last minute
MAX_CHANGE = 0.20
#: frames the SSE client fetches per sensor per second (the page asks ≤ 10 Hz)
FRAME_FETCH_HZ = 5.0
#: marker dot radius [px] on the 320 × 240 frames
DOT_RADIUS_PX = 4


# --- the cameras (a process of their own) ------------------------------------------------


def marker_frames(fps: float):
    """``frame(t_s, sensor)``: a grey 240 × 320 frame of the repeated protocol at ``t_s`` [s]."""
    import cv2

    from liquidtouch.sim.protocol_scene import protocol_scene

    scene = protocol_scene("mirin", height_mm=25, seed=1)
    period = float(scene.t[-1] - scene.t[0]) + float(np.median(np.diff(scene.t)))
    yy, xx = np.mgrid[0:240, 0:320]
    background = (150 + 60 * xx / 320 + 20 * np.sin(yy / 40)).astype(np.uint8)
    shift = 4  # OpenCV fixed-point fraction bits: sub-pixel dots

    def frame(t_s: float, sensor: int) -> np.ndarray:
        local = (t_s % period) + float(scene.t[0])
        k = min(int(np.searchsorted(scene.t, local)), len(scene.t) - 1)
        j = max(k - 1, 0)
        w = 0.0 if k == j else (local - scene.t[j]) / (scene.t[k] - scene.t[j])
        points = (1 - w) * scene.positions[sensor, j] + w * scene.positions[sensor, k]
        image = background.copy()
        for x, y in np.rint(points * (1 << shift)).astype(int):
            cv2.circle(image, (int(x), int(y)), DOT_RADIUS_PX << shift, 40, -1, cv2.LINE_AA, shift)
        return image

    return frame, period


def serve_cameras(fps: float) -> None:
    """Run two MJPEG cameras until stdin closes; print their URLs as one JSON line."""
    from liquidtouch.sim.rig.mjpeg import MjpegServer

    frame, period = marker_frames(fps)
    t0 = time.monotonic()
    servers = [
        MjpegServer(lambda t_s, s=s: frame(t_s - t0, s), fps=fps, quality=90, timed=True)
        for s in (0, 1)
    ]
    for server in servers:
        server.start()
    print(json.dumps({"urls": [s.url for s in servers], "period_s": period}), flush=True)
    sys.stdin.read()  # until the parent closes it
    for server in servers:
        server.stop()


# --- the measurement ---------------------------------------------------------------------


def proc_sample(pid: int) -> tuple[float, float]:
    """(CPU time [s], RSS [MB]) of process ``pid`` from /proc."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    ticks = os.sysconf("SC_CLK_TCK")
    cpu = (int(fields[11]) + int(fields[12])) / ticks
    rss = 0.0
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            rss = int(line.split()[1]) / 1024
    return cpu, rss


class SseReader(threading.Thread):
    """Reads ``/stream`` like a browser: records (monotonic time, bytes) of each update."""

    def __init__(self, url: str) -> None:
        super().__init__(daemon=True, name="sse-reader")
        self.url = url
        self.updates: list[tuple[float, int]] = []
        self.sensors: set[str] = set()
        self.ended = threading.Event()

    def run(self) -> None:
        parts = urlsplit(self.url)
        conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=60)
        conn.request("GET", "/stream")
        response = conn.getresponse()
        event = ""
        try:
            while True:
                line = response.readline()
                if not line:
                    break
                text = line.decode("utf-8").rstrip("\n")
                if text.startswith("event: "):
                    event = text[7:]
                elif text.startswith("data: "):
                    if event == "update":
                        self.updates.append((time.monotonic(), len(line)))
                    elif event == "frames":
                        self.sensors.update(json.loads(text[6:]))
                    elif event == "end":
                        break
        except OSError as exc:
            logger.warning("the event stream broke off: %s", exc)
        finally:
            conn.close()
            self.ended.set()


def fetch_frames(url: str, reader: SseReader, stop: threading.Event) -> None:
    """Fetch each sensor's newest frame at FRAME_FETCH_HZ until ``stop``, as the page does."""
    parts = urlsplit(url)
    while not stop.wait(1.0 / FRAME_FETCH_HZ):
        for sensor in list(reader.sensors):
            try:
                conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=10)
                conn.request("GET", f"/frame/{sensor}.jpg")
                conn.getresponse().read()
                conn.close()
            except OSError:
                pass


def run_soak(minutes: float, fps: float) -> dict:
    """Run the soak (module docstring); per-minute rows and the run's facts."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    cameras = subprocess.Popen(
        [sys.executable, __file__, "--serve-cameras", "--fps", str(fps)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        info = json.loads(cameras.stdout.readline())
        duration_s = 60.0 * minutes
        command = [
            sys.executable, "-c", "from liquidtouch.cli import run; run()", "live",
            *info["urls"], "--serve", "127.0.0.1:0", "--json",
            "--max-duration", f"{duration_s:g}",
        ]  # fmt: skip
        live = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
        )
        url = None
        for line in live.stderr:  # "serving the live view at http://..."
            found = re.search(r"(http://\S+/)", line)
            if found:
                url = found.group(1)
                break
        if url is None:
            raise RuntimeError("liquidtouch live did not start serving")
        threading.Thread(target=lambda: [None for _ in live.stderr], daemon=True).start()
        reader = SseReader(url)
        reader.start()
        stop = threading.Event()
        threading.Thread(target=fetch_frames, args=(url, reader, stop), daemon=True).start()
        updates: list[tuple[float, dict]] = []

        def read_updates() -> None:
            for line in live.stdout:
                updates.append((time.monotonic(), json.loads(line)))

        lines = threading.Thread(target=read_updates, daemon=True)
        lines.start()
        t0 = time.monotonic()
        samples: list[tuple[float, float, float]] = []  # (wall [s], cpu [s], rss [MB])
        while live.poll() is None:
            try:
                samples.append((time.monotonic() - t0, *proc_sample(live.pid)))
            except (OSError, IndexError):
                break
            time.sleep(1.0)
        lines.join(30)
        stop.set()
        reader.ended.wait(30)
    finally:
        cameras.stdin.close()
        cameras.wait(30)
    return summarise(samples, updates, reader.updates, t0, minutes, info)


def summarise(samples, updates, sse, t0: float, minutes: float, info: dict) -> dict:
    """Per-minute CPU %, mean RSS, median lag and mean bytes per update."""
    wall = np.array([s[0] for s in samples])
    cpu = np.array([s[1] for s in samples])
    rss = np.array([s[2] for s in samples])
    lag_t = np.array([t - t0 for t, u in updates if not u.get("final")])
    lags = np.array([u.get("lag_s") or math.nan for t, u in updates if not u.get("final")])
    sse_t = np.array([t - t0 for t, _ in sse])
    sse_b = np.array([b for _, b in sse], dtype=float)
    rows = []
    for m in range(math.ceil(minutes)):
        lo, hi = 60.0 * m, 60.0 * (m + 1)
        inside = (wall >= lo) & (wall < hi)
        if inside.sum() < 2:
            continue
        w, c = wall[inside], cpu[inside]
        in_lag = (lag_t >= lo) & (lag_t < hi)
        in_sse = (sse_t >= lo) & (sse_t < hi)
        rows.append(
            {
                "minute": m + 1,
                "cpu_percent": 100.0 * (c[-1] - c[0]) / (w[-1] - w[0]),
                "rss_mb": float(rss[inside].mean()),
                "lag_s": float(np.nanmedian(lags[in_lag])) if in_lag.any() else math.nan,
                "bytes_per_update": float(sse_b[in_sse].mean()) if in_sse.any() else math.nan,
                "updates": int(in_sse.sum()),
            }
        )
    final = updates[-1][1] if updates else {}
    return {
        "minutes": minutes,
        "rows": rows,
        "final": {k: final.get(k) for k in ("stopped_because", "segments", "frames", "timing")},
        "protocol_period_s": info["period_s"],
    }


def table(result: dict) -> str:
    """Markdown: one row per minute, then minute 1 against the last and the verdict."""
    head = "| minute | " + " | ".join(COMPARED.values()) + " | updates |"
    lines = [head, "|" + "---|" * (len(COMPARED) + 2)]
    for row in result["rows"]:
        cells = [f"{row[k]:.3g}" if k != "bytes_per_update" else f"{row[k]:.0f}" for k in COMPARED]
        lines.append(f"| {row['minute']} | " + " | ".join(cells) + f" | {row['updates']} |")
    first, last = result["rows"][0], result["rows"][-1]
    changes = {k: (last[k] - first[k]) / first[k] for k in COMPARED}
    lines.append(
        f"| change {first['minute']}→{last['minute']} | "
        + " | ".join(f"{100 * v:+.0f} %" for v in changes.values())
        + " | |"
    )
    ok = all(abs(v) < MAX_CHANGE for v in changes.values())
    lines.append("")
    lines.append(f"within ±{100 * MAX_CHANGE:.0f} %: {'yes' if ok else 'NO'}")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0, help="soak length [min]")
    parser.add_argument("--fps", type=float, default=30.0, help="each camera's frame rate [Hz]")
    parser.add_argument("--out", type=Path, default=None, help="write soak.json here")
    parser.add_argument("--serve-cameras", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.serve_cameras:
        serve_cameras(args.fps)
        return
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    result = run_soak(args.minutes, args.fps)
    print(table(result))
    print(f"final: {json.dumps(result['final'])[:600]}")
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        (args.out / "soak.json").write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
