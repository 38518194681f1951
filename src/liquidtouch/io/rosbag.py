"""ROS bags → one image folder per image topic, with the frames' timestamps.

:func:`import_bag` (needs the optional ``rosbags`` package: ``pip install
'liquidtouch[ros]'``) writes the ``sensor_msgs/Image`` (``mono8``, ``rgb8``,
``bgr8``, ``rgba8``, ``bgra8``, ``8UC1``, ``8UC3``, ``8UC4``, ``yuv422``/``uyvy``,
``yuyv``) and ``sensor_msgs/CompressedImage`` (JPEG, PNG) topics of a ROS 1
``.bag`` or a ROS 2 bag (directory, ``.db3`` or ``.mcap``) as one image folder
per topic with a ``timestamps.csv`` of the message header stamps.

Formats: ``docs/formats.md`` ("Imported recordings").
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liquidtouch._core import atomic
from liquidtouch._core.checks import check_times
from liquidtouch.errors import DatasetError
from liquidtouch.io.frame_times import TIMESTAMPS_NAME
from liquidtouch.io.image_size import check_frame_size, check_image_bytes
from liquidtouch.tracking.clock import fit_frame_period
from liquidtouch.tracking.tracks import MAX_FRAMES, check_frame_count

ROS_HINT = "pip install 'liquidtouch[ros]'"
IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
TIME_SOURCES = ("header", "bag")
_SKIP_TOPIC_PARTS = frozenset(
    {"image_raw", "image", "image_color", "image_mono", "image_rect", "raw", "compressed"}
)


@dataclass(frozen=True)
class BagTopic:
    """One image topic imported from a bag: its folder, frame count and nominal rate."""

    topic: str
    folder: str
    frames: int
    fps: float
    msgtype: str


def _rosbags():
    """The rosbags modules; :class:`DatasetError` with the install hint when it is missing."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise DatasetError(
            f"reading ROS bags needs the optional rosbags package: {ROS_HINT}"
        ) from None
    return AnyReader, Stores, get_typestore


def topic_sensor_names(topics: Sequence[str]) -> list[str]:
    """Sensor names for image topics: the parts that tell them apart.

    ``/gelsight/left/image_raw``, ``/gelsight/right/image_raw`` → ``left``,
    ``right``; one topic: its last part that is not ``image_raw``, ``compressed``
    and the like (``/gelsight/left/image_raw`` → ``left``).
    """
    parts = [[p for p in t.strip("/").split("/") if p] for t in topics]
    common = set.intersection(*(set(p) for p in parts)) if len(parts) > 1 else set()
    names = []
    for topic, items in zip(topics, parts, strict=True):
        kept = [p for p in items if p not in common and p.lower() not in _SKIP_TOPIC_PARTS]
        if len(topics) == 1:
            kept = kept[-1:]
        name = "_".join(kept) or "_".join(items) or "image"
        names.append("".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in name) or topic)
    if len(set(names)) < len(names):
        names = ["_".join(p) or f"topic{k}" for k, p in enumerate(parts)]
    return names


def bag_image_topics(bag: str | os.PathLike[str]) -> dict[str, str]:
    """``{topic: message type}`` of the image topics of a ROS 1 or ROS 2 bag."""
    with _opened_bag(Path(bag)) as reader:
        return {c.topic: c.msgtype for c in reader.connections if c.msgtype in IMAGE_TYPES}


@contextlib.contextmanager
def _opened_bag(path: Path) -> Iterator[object]:
    """An open rosbags ``AnyReader`` of ``path``; :class:`DatasetError` if it cannot be read."""
    AnyReader, Stores, get_typestore = _rosbags()
    if not path.exists():
        raise DatasetError(f"bag {path} does not exist")
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    except Exception as exc:  # rosbags raises its own errors, and OSError/KeyError on junk
        raise DatasetError(
            f"cannot read bag {path}: {exc}; give a ROS 1 .bag file or a ROS 2 bag "
            "(its directory, or its .db3/.mcap file)"
        ) from None
    try:
        yield reader
    finally:
        reader.close()


def import_bag(
    bag: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    topics: Sequence[str] = (),
    names: Sequence[str] | None = None,
    time_source: str = "header",
    on_message: Callable[..., None] | None = None,
) -> list[BagTopic]:
    """Write each image topic of ``bag`` as an image folder ``out_dir/<name>/`` with timestamps.

    ``topics``: the image topics to import (default: every ``sensor_msgs/Image``
    and ``CompressedImage`` topic of the bag). ``names``: the folder (sensor)
    names, one per topic (default :func:`topic_sensor_names`). Raw images are
    written as PNG (colour kept), compressed ones as the JPEG or PNG bytes they
    hold (each decoded once to check it). ``timestamps.csv`` has ``t_s`` (seconds
    from the earliest frame of all topics) and ``stamp_ns`` (the absolute stamp)
    per image. ``time_source``: ``"header"`` (the messages' ``header.stamp``,
    the capture time) or ``"bag"`` (the time the recorder received them).
    Raises :class:`~liquidtouch.errors.DatasetError` for a missing or bad bag or
    topic, an unsupported encoding, or stamps that do not increase.
    """
    import cv2

    if time_source not in TIME_SOURCES:
        raise DatasetError(f"unknown time source {time_source!r}; choose header or bag")
    out_dir = Path(out_dir)
    path = Path(bag)
    with _opened_bag(path) as reader:
        available = {c.topic: c.msgtype for c in reader.connections}
        images = sorted(t for t, m in available.items() if m in IMAGE_TYPES)
        topics = list(topics) or images
        if not topics:
            raise DatasetError(
                f"bag {path} has no sensor_msgs/Image or CompressedImage topic (its topics: "
                f"{', '.join(sorted(available)) or 'none'})"
            )
        if len(set(topics)) < len(topics):
            raise DatasetError("a topic is given twice; give each sensor's topic once")
        for topic in topics:
            if topic not in available:
                raise DatasetError(
                    f"bag {path} has no topic {topic}; its image topics are "
                    f"{', '.join(images) or 'none'}"
                )
            if available[topic] not in IMAGE_TYPES:
                raise DatasetError(
                    f"topic {topic} carries {available[topic]}, not sensor_msgs/Image or "
                    "sensor_msgs/CompressedImage"
                )
        names = list(names) if names is not None else topic_sensor_names(topics)
        if len(names) != len(topics):
            raise DatasetError(f"{len(names)} sensor names for {len(topics)} topics")
        writers = {
            t: _TopicWriter(out_dir / n, t, available[t])
            for t, n in zip(topics, names, strict=True)
        }
        connections = [c for c in reader.connections if c.topic in writers]
        for connection, bag_ns, raw in reader.messages(connections=connections):
            writer = writers[connection.topic]
            try:
                msg = reader.deserialize(raw, connection.msgtype)
            except Exception as exc:  # a damaged message
                raise DatasetError(
                    f"bag {path}: message {writer.count} of {connection.topic} cannot be "
                    f"decoded: {exc}"
                ) from None
            stamp = msg.header.stamp
            header_ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
            writer.add(msg, header_ns if time_source == "header" else int(bag_ns), cv2)
            if on_message is not None:
                on_message()
    origin = min((w.stamps[0] for w in writers.values() if w.stamps), default=0)
    return [w.finish(origin, time_source) for w in writers.values()]


class _TopicWriter:
    """Writes one topic's images into its folder and collects their stamps."""

    def __init__(self, folder: Path, topic: str, msgtype: str) -> None:
        self.folder, self.topic, self.msgtype = folder, topic, msgtype
        self.stamps: list[int] = []
        self.shape: tuple[int, ...] | None = None
        self.count = 0
        folder.mkdir(parents=True, exist_ok=False)

    def add(self, msg: object, stamp_ns: int, cv2: object) -> None:
        index = self.count
        if index >= MAX_FRAMES:  # what extract tracks per sensor, before writing more
            check_frame_count(index + 1, f"topic {self.topic}", DatasetError)
        if self.stamps:  # from the first stamp: seconds since 1970 would keep only 0.2 µs
            check_times(
                (np.array([self.stamps[-1], stamp_ns], dtype=np.int64) - self.stamps[0]) / 1e9,
                f"topic {self.topic}: the message stamps (unset or duplicated header stamps: use "
                "`time_source` bag, the recording time)",
                DatasetError,
                first=index - 1,
            )
        if self.msgtype.endswith("/CompressedImage"):
            data, suffix, shape = _compressed(msg, self.topic, index, cv2)
            (self.folder / f"{index:06d}{suffix}").write_bytes(data)
        else:
            image = _raw_image(msg, self.topic, index, cv2)
            shape = image.shape[:2]
            ok, encoded = cv2.imencode(".png", image)  # type: ignore[attr-defined]
            if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
                raise DatasetError(f"topic {self.topic}: message {index} cannot be saved as PNG")
            (self.folder / f"{index:06d}.png").write_bytes(encoded.tobytes())
        if self.shape is not None and shape != self.shape:
            raise DatasetError(
                f"topic {self.topic}: message {index} is {shape[1]}x{shape[0]} but the first "
                f"is {self.shape[1]}x{self.shape[0]}; all images of a sensor must have one size"
            )
        self.shape = shape
        self.stamps.append(stamp_ns)
        self.count += 1

    def finish(self, origin_ns: int, time_source: str) -> BagTopic:

        check_frame_count(self.count, f"topic {self.topic}", DatasetError)
        if time_source == "header" and self.stamps[0] == 0:
            raise DatasetError(
                f"topic {self.topic}: the header stamps are unset (0); use `time_source` bag"
            )
        lines = ["t_s,stamp_ns"]
        lines += [f"{(s - origin_ns) / 1e9:.9f},{s}" for s in self.stamps]
        atomic.write_text(self.folder / TIMESTAMPS_NAME, "\n".join(lines) + "\n")
        fps = fit_frame_period((np.asarray(self.stamps) - self.stamps[0]) / 1e9).fps
        return BagTopic(self.topic, self.folder.name, self.count, fps, self.msgtype)


_CHANNELS = {
    "mono8": 1,
    "8uc1": 1,
    "bgr8": 3,
    "rgb8": 3,
    "8uc3": 3,
    "bgra8": 4,
    "rgba8": 4,
    "8uc4": 4,
}
_YUV = {"yuv422": "UYVY", "uyvy": "UYVY", "yuv422_yuy2": "YUY2", "yuyv": "YUY2"}


def _raw_image(msg: object, topic: str, index: int, cv2: object) -> np.ndarray:
    """A ``sensor_msgs/Image`` as a uint8 grey or BGR array."""
    encoding = str(msg.encoding).strip().lower()  # type: ignore[attr-defined]
    height, width, step = int(msg.height), int(msg.width), int(msg.step)  # type: ignore[attr-defined]
    data = np.asarray(msg.data, dtype=np.uint8).ravel()  # type: ignore[attr-defined]
    where = f"topic {topic}: message {index}"
    channels = 2 if encoding in _YUV else _CHANNELS.get(encoding)
    if channels is None:
        raise DatasetError(
            f"{where} has encoding {msg.encoding!r}; liquidtouch reads 8-bit images "  # type: ignore[attr-defined]
            f"({', '.join([*_CHANNELS, *_YUV])}); convert the topic first"
        )
    check_frame_size(width, height, where, DatasetError)
    if step < width * channels or data.size < height * step:
        raise DatasetError(
            f"{where}: {data.size} bytes do not hold a {width}x{height} {encoding} image "
            f"(step {step})"
        )
    rows = data[: height * step].reshape(height, step)[:, : width * channels]
    image = rows.reshape(height, width, channels) if channels > 1 else rows
    if encoding in _YUV:
        code = getattr(cv2, f"COLOR_YUV2BGR_{_YUV[encoding]}")
        return cv2.cvtColor(np.ascontiguousarray(image), code)  # type: ignore[attr-defined]
    if encoding.startswith("rgb"):
        image = image[:, :, 2::-1]
    elif channels == 4:
        image = image[:, :, :3]
    return np.ascontiguousarray(image)


def _compressed(
    msg: object, topic: str, index: int, cv2: object
) -> tuple[bytes, str, tuple[int, ...]]:
    """The bytes, file suffix and (height, width) of a ``sensor_msgs/CompressedImage``."""
    data = np.asarray(msg.data, dtype=np.uint8).ravel()  # type: ignore[attr-defined]
    raw = data.tobytes()
    if raw.startswith(b"\xff\xd8"):
        suffix = ".jpg"
    elif raw.startswith(b"\x89PNG"):
        suffix = ".png"
    else:
        raise DatasetError(
            f"topic {topic}: message {index} (format {msg.format!r}) is neither JPEG nor PNG"  # type: ignore[attr-defined]
        )
    check_image_bytes(raw, f"topic {topic}: message {index}", DatasetError)  # before decoding
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)  # type: ignore[attr-defined]
    if image is None or image.dtype != np.uint8:
        raise DatasetError(
            f"topic {topic}: message {index} is not a decodable 8-bit {suffix[1:].upper()} image"
        )
    return raw, suffix, image.shape[:2]
