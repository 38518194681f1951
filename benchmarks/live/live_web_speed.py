"""What serving the live view costs: a frame with its arrows, and an update's delivery.

    python benchmarks/live/live_web_speed.py OUT_DIR

- Frames: the median time of one served frame (``LiveHub.frame_jpeg``: zoom,
  arrows, JPEG) against a plain JPEG of the same grey frame (baseline, same
  run), for the Mini (320×240, shown zoomed ×2) and the default (640×480) sensor.
- Updates: publish-to-received time of 100 updates at 20 Hz (each with a
  400-sample signal) over the real server on 127.0.0.1, read as a browser reads
  the stream; against the estimator's refresh period.

Prints markdown tables for ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import threading
import time
from pathlib import Path

import numpy as np


def _median_ms(times_s: list[float]) -> float:
    return 1e3 * float(np.median(times_s))


def frame_speed(out: Path, repeats: int = 40) -> list[tuple[str, float, float]]:
    """Per-request cost of a frame [ms]: (sensor, plain JPEG of the grey frame, with arrows).

    The frame is the first of a simulated trial per sensor profile; the markers move
    by up to 2 px at random (the arrows' length does not change the cost much).
    """
    import cv2

    import liquidtouch as lt
    from liquidtouch.io.frames import iter_video
    from liquidtouch.live.hub import JPEG_QUALITY, LiveHub
    from liquidtouch.tracking.detect import detect_markers

    rows = []
    trial = lt.simulate_trial("water", height_mm=25.0, seed=1, duration_s=3.0)
    for sensor in ("mini", "default"):
        trial_dir = lt.write_trial(trial, out / f"speed-{sensor}", sensor=sensor)
        video = sorted(trial_dir.glob("*.mp4"))[0]
        _, image = next(iter_video(video))
        reference = detect_markers(image).positions
        rng = np.random.default_rng(0)
        hub = LiveHub(frame_interval_s=0.0)
        plain, arrows = [], []
        for _ in range(repeats):
            started = time.perf_counter()
            cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
            plain.append(time.perf_counter() - started)
            moved = reference + rng.uniform(-2, 2, reference.shape)
            hub.publish_frame("left", image, reference, moved)
            started = time.perf_counter()
            hub.frame_jpeg("left")
            arrows.append(time.perf_counter() - started)
        name = f"{sensor} {image.shape[1]}×{image.shape[0]}, {len(reference)} markers"
        rows.append((name, _median_ms(plain), _median_ms(arrows)))
    return rows


def delivery_latency(n: int = 100, rate_hz: float = 20.0, points: int = 400) -> list[float]:
    """Publish-to-received times [s] of ``n`` updates (each with a signal of ``points``
    samples) over the real server on 127.0.0.1, read as a browser reads the stream."""
    import http.client
    from urllib.parse import urlsplit

    from liquidtouch.live.hub import LiveHub
    from liquidtouch.live.web import start_server

    hub = LiveHub()
    received: dict[int, float] = {}
    signal = {"t_s": np.linspace(-1, 5, points), "u": np.sin(np.arange(points)), "fit": None}
    with start_server(hub) as server:
        parts = urlsplit(server.url)

        def read() -> None:
            connection = http.client.HTTPConnection(parts.hostname, parts.port, timeout=30)
            connection.request("GET", "/stream")
            response = connection.getresponse()
            while True:
                line = response.readline()
                if not line or line.startswith(b"event: end"):
                    break
                if line.startswith(b"id: "):
                    received[int(line[4:])] = time.monotonic()
            connection.close()

        reader = threading.Thread(target=read)
        reader.start()
        deadline = time.monotonic() + 10
        while server.readers < 1 and time.monotonic() < deadline:
            time.sleep(0.01)
        sent = []
        for i in range(n):
            sent.append(time.monotonic())
            hub.publish({"t_s": 0.05 * i, "decay_rate": 0.2, "signal": signal})
            time.sleep(1.0 / rate_hz)
        hub.close()
        reader.join(30)
    return [received[i + 1] - sent[i] for i in range(n) if i + 1 in received]


def speed(out: Path) -> None:
    """Print the serving costs as markdown tables (for benchmarks/RESULTS.md)."""
    from liquidtouch.live.estimator import REFRESH_S

    out.mkdir(parents=True, exist_ok=True)
    print("| frame | plain JPEG [ms] | JPEG with arrows (served) [ms] | ratio |")
    print("|---|---|---|---|")
    for name, plain, arrows in frame_speed(out):
        print(f"| {name} | {plain:.2f} | {arrows:.2f} | {arrows / plain:.2f} |")
    latency = delivery_latency()
    p50, p95 = np.percentile(latency, [50, 95]) * 1e3
    print()
    print(
        "| updates | received | median [ms] | p95 [ms] | max [ms] "
        f"| p95 / refresh period ({REFRESH_S} s) |"
    )
    print("|---|---|---|---|---|---|")
    print(
        f"| 100 at 20 Hz, 400-sample signal | {len(latency)} | {p50:.1f} | {p95:.1f} | "
        f"{1e3 * max(latency):.1f} | {p95 / 1e3 / REFRESH_S:.3f} |"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", nargs="?", type=Path, default=Path("live-speed"),
                        help="where the simulated trials are written")  # fmt: skip
    speed(parser.parse_args().out_dir)
