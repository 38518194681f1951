"""Rendered GelSight frames written as each recording format writes them.

The recorder's own FFV1 (Matroska) and PNG writers, grey or colour, and H.264 in MP4 as
the simulator writes it (libx264 ``ultrafast`` CRF 20, yuv420p), with and without x264's
quantisation dead zone; the frames a simulated trial renders to. Shared by
``benchmarks/acquire/record_formats.py`` (encode speed, λ bias per format) and
``benchmarks/extraction/codec_bias.py`` (λ bias per codec).
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

from liquidtouch.acquire.cameras import Frame
from liquidtouch.acquire.recording import Ffv1Writer, PngWriter
from liquidtouch.sim.encode import PTS_RATE_HZ, X264_PARAMS
from liquidtouch.sim.gelsight import sensor_scene
from liquidtouch.sim.render import iter_frames, make_background
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import SimulatedTrial

#: the simulator's sensor profile the frames are rendered for (640 × 480 at 30 fps)
SENSOR = "default"


class X264Writer:
    """H.264 in MP4 via PyAV, as ``liquidtouch.sim.encode.encode_video`` writes it."""

    def __init__(self, path: Path, fps: float, x264_params: str) -> None:
        self.path = path
        self.entry = path.name
        self.container = av.open(str(path), mode="w")
        self.stream = self.container.add_stream("libx264", rate=Fraction(fps).limit_denominator())
        self.stream.pix_fmt = "yuv420p"
        self.stream.time_base = Fraction(1, PTS_RATE_HZ)
        self.stream.codec_context.time_base = Fraction(1, PTS_RATE_HZ)
        self.stream.codec_context.thread_count = 1
        options = {"preset": "ultrafast", "crf": "20"}
        if x264_params:
            options["x264-params"] = x264_params
        self.stream.options = options
        self.started = False

    def write(self, rgb: np.ndarray, t_s: float) -> None:
        if not self.started:
            self.stream.height, self.stream.width = rgb.shape[:2]
            self.started = True
        yuv = cv2.cvtColor(rgb, cv2.COLOR_RGB2YUV_I420)
        frame = av.VideoFrame.from_numpy_buffer(yuv, format="yuv420p")
        frame.pts = round(t_s * PTS_RATE_HZ)
        frame.time_base = Fraction(1, PTS_RATE_HZ)
        for packet in self.stream.encode(frame):
            self.container.mux(packet)

    def close(self) -> None:
        for packet in self.stream.encode():
            self.container.mux(packet)
        self.container.close()


class RecorderFormat:
    """The recorder's own FFV1 / PNG writer for one sensor, grey or colour."""

    def __init__(self, kind: str, directory: Path, name: str, fps: float, grey: bool) -> None:
        if kind == "ffv1":
            self.writer = Ffv1Writer(directory, name, 0.0)
            self.writer.fps_hint = fps
        else:
            self.writer = PngWriter(directory, name, 0.0)
        self.grey = grey
        self.index = 0

    @property
    def entry(self) -> str:
        return self.writer.entry

    def write(self, rgb: np.ndarray, t_s: float) -> None:
        code = cv2.COLOR_RGB2GRAY if self.grey else cv2.COLOR_RGB2BGR
        image = cv2.cvtColor(rgb, code)
        self.writer.write(Frame("s", self.index, t_s, image), image)
        self.index += 1

    def close(self) -> None:
        self.writer.close()


def make_writer(
    fmt: str, directory: Path, name: str, fps: float, *, grey: bool = True
) -> RecorderFormat | X264Writer:
    """An encoder of ``fmt`` for sensor ``name`` in ``directory``: ``write(rgb, t_s)``, ``close()``;
    ``entry`` is the file or folder it writes."""
    if fmt in ("ffv1", "png"):
        return RecorderFormat(fmt, directory, name, fps, grey)
    params = X264_PARAMS if fmt == "x264 no dead zone" else ""
    return X264Writer(directory / f"{name}.mp4", fps, params)


def render_sensors(
    trial: SimulatedTrial, seed: int, sensor: str = SENSOR
) -> tuple[list[list[np.ndarray]], np.ndarray, float]:
    """The two sensors' RGB frames (lists), timestamps [s] and frame rate [Hz] of ``trial``,
    as the simulator renders them for ``sensor`` (seeded by ``seed``)."""
    profile = get_sensor_profile(sensor)
    scene = sensor_scene(trial.loads, profile, np.random.default_rng(seed))
    sensors = []
    for s in range(2):
        sensor_rng = np.random.default_rng([seed, s + 1])
        frames = iter_frames(
            scene.positions_px[s],
            profile,
            sensor_rng,
            background=make_background(profile, sensor_rng),
            contact_center_px=scene.geometry.center_px[s],
            contact_radius_px=float(scene.geometry.radius_px[s]),
            contact_offsets_px=scene.offsets_px[s],
        )
        sensors.append([frame.copy() for frame in frames])  # the renderer reuses its buffer
    return sensors, scene.timestamps_s, profile.fps
