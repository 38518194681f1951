"""Writing RGB frames as an H.264 MP4 with exact per-frame timestamps (PyAV, libx264).

**Why no quantisation dead zone** (``X264_PARAMS``): x264 rounds small residuals
to zero with a dead zone (``deadzone-inter`` 21 and ``deadzone-intra`` 11 with
the ``ultrafast`` preset, which has no trellis). In a P-frame a marker that moves
by a few hundredths of a pixel per frame changes the image by less than that dead
zone, so the decoded marker stays put until the accumulated motion is large
enough: a stick-slip measurement whose gain falls as the oscillation dies out
(tracked/true ≈ 0.97 at 1.4 px, ≈ 0.83 below 0.15 px). The fitted decay rate
of the slosh came out 15–22 % too high at CRF 20 (the same trials from the raw,
unencoded frames: within 1 %; ``benchmarks/extraction/video_chain_accuracy.py``). Without
the dead zone the videos are ~5× larger (≈ 3.7 MB per 13 s 640 × 480 sensor video)
but keep the sub-pixel motion, as a measurement recording must. A lower CRF
alone is worse per byte (CRF 16: +5 % at the same size).
"""

from __future__ import annotations

from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path

import numpy as np

from liquidtouch._core.atomic import atomic_path
from liquidtouch.errors import LiquidTouchError

PTS_RATE_HZ = 90_000
"""Time base of the videos' timestamps (1/90000 s)."""
X264_PARAMS = "deadzone-inter=0:deadzone-intra=0"
"""libx264 options of the simulator's videos (module docstring: why). ``""`` = x264's defaults."""


def encode_video(
    path: Path,
    frames: Iterable[np.ndarray],
    timestamps_s: np.ndarray,
    fps: float,
    *,
    crf: int = 20,
    preset: str = "ultrafast",
    threads: int = 1,
    x264_params: str = X264_PARAMS,
) -> None:
    """Write RGB uint8 ``frames`` as an H.264 (yuv420p) MP4 at ``path``, atomically.

    Each frame's PTS is its timestamp in a 1/90000 s time base, so decoding
    gives ``timestamps_s`` back; ``fps`` is the nominal rate written in the stream.
    ``x264_params`` are extra libx264 options (``key=value:...``; default
    :data:`X264_PARAMS`, no quantisation dead zone).
    """
    import av
    import cv2

    timestamps_s = np.asarray(timestamps_s, dtype=float)
    pts = np.round(timestamps_s * PTS_RATE_HZ).astype(np.int64)
    if len(pts) and np.any(np.diff(pts) <= 0):
        raise LiquidTouchError("frame timestamps must be strictly increasing")
    time_base = Fraction(1, PTS_RATE_HZ)
    with atomic_path(path) as tmp:
        container = av.open(str(tmp), mode="w")
        try:
            stream = container.add_stream("libx264", rate=Fraction(fps).limit_denominator(1000))
            stream.pix_fmt = "yuv420p"
            stream.time_base = time_base
            stream.codec_context.time_base = time_base
            stream.codec_context.thread_count = threads
            options = {"preset": preset, "crf": str(crf)}
            if x264_params:
                options["x264-params"] = x264_params
            stream.options = options
            count = 0
            for i, rgb in enumerate(frames):
                if i >= len(pts):
                    raise LiquidTouchError("more frames than timestamps")
                if i == 0:
                    stream.height, stream.width = rgb.shape[:2]
                yuv = cv2.cvtColor(rgb, cv2.COLOR_RGB2YUV_I420)
                # wraps the fresh I420 array without a copy (a new array every frame)
                frame = av.VideoFrame.from_numpy_buffer(yuv, format="yuv420p")
                frame.pts = int(pts[i])
                frame.time_base = time_base
                for packet in stream.encode(frame):
                    container.mux(packet)
                count += 1
            for packet in stream.encode():
                container.mux(packet)
        finally:
            container.close()
        if count != len(pts):
            raise LiquidTouchError(f"got {count} frames for {len(pts)} timestamps")
