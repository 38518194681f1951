"""What the live view shows, shared between the estimator and the web page: :class:`LiveHub`.

The estimator's thread publishes updates (:meth:`LiveHub.publish`, one
JSON-able dict per refresh, keys in ``docs/formats.md``, "Live updates") and
each sensor's newest frame with its markers (:meth:`LiveHub.publish_frame`);
the web server (:mod:`liquidtouch.live.web`) reads them for any number of
browsers. A browser that connects late gets the history of updates first (so
its plots are complete), then the new ones, then the end (:meth:`LiveHub.close`).

Memory is bounded: past ``max_updates`` the history is thinned (every other
update dropped, the first and the newest kept, so the plots still span the
whole trial), only the newest update with a ``signal`` keeps it (the plot of
u(t) needs only the current one), and each sensor keeps only its newest frame. A
frame is encoded to JPEG, with its marker displacement arrows drawn, only
when a browser asks, and at most every :data:`FRAME_INTERVAL_S` per sensor.
"""

from __future__ import annotations

import json
import math
import threading
import time
from bisect import bisect_right
from dataclasses import dataclass

import cv2
import numpy as np

#: updates kept for late browsers before the history is thinned
MAX_UPDATES = 2000
#: the shortest time between two JPEG encodings of one sensor's frame [s] (~10 Hz)
FRAME_INTERVAL_S = 0.1
#: displacement arrows are drawn this many times their length, so that sub-pixel motion shows
ARROW_SCALE = 5.0
#: arrow colour (BGR): green, seen on the grey gel and the dark markers alike
ARROW_BGR = (0, 220, 0)
#: arrow line width [px]
ARROW_PX = 2
#: arrows shorter than this get no head [px]
HEAD_MIN_PX = 4.0
#: frames narrower than this are shown zoomed ×2, so that the arrows have room [px]
ZOOM_BELOW_PX = 480
_SHIFT = 4  # fractional bits of OpenCV's fixed-point coordinates
JPEG_QUALITY = 80


def jsonable(value: object) -> object:
    """``value`` with numpy scalars/arrays as Python numbers/lists and NaN/inf as ``None``."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [jsonable(v) for v in (value.tolist() if isinstance(value, np.ndarray) else value)]
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if value is None or isinstance(value, str):
        return value
    return str(value)


def draw_arrows(
    image: np.ndarray,
    reference_px: np.ndarray | None,
    positions_px: np.ndarray | None,
    *,
    scale: float = ARROW_SCALE,
    zoom: int = 1,
) -> np.ndarray:
    """A BGR copy of ``image``, ``zoom`` times larger, with an arrow per marker.

    ``reference_px`` and ``positions_px`` are (N, 2) x, y [px] in ``image``; each
    arrow starts at the reference and is the displacement times ``scale``.
    Markers with a NaN coordinate are left out; arrows shorter than
    :data:`HEAD_MIN_PX` (on the zoomed image) get no head.
    """
    bgr = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image.copy()
    if zoom > 1:
        bgr = cv2.resize(bgr, None, fx=zoom, fy=zoom, interpolation=cv2.INTER_LINEAR)
    if reference_px is None or positions_px is None:
        return bgr
    start = np.asarray(reference_px, dtype=float).reshape(-1, 2)
    end = np.asarray(positions_px, dtype=float).reshape(-1, 2)
    n = min(len(start), len(end))
    start, end = start[:n], end[:n]
    ok = np.isfinite(start).all(axis=1) & np.isfinite(end).all(axis=1)
    shaft = zoom * scale * (end[ok] - start[ok])
    start = zoom * (start[ok] + 0.5) - 0.5  # pixel centres stay pixel centres when zoomed
    end = start + shaft
    if not len(start):
        return bgr
    # each head: two barbs, the shaft turned back by ±30°, a third of its length (≤ 10 px)
    length = np.hypot(shaft[:, 0], shaft[:, 1])
    headed = length >= HEAD_MIN_PX
    back = -shaft[headed] / length[headed, None] * np.minimum(length[headed, None] / 3, 10.0)
    cos, sin = math.cos(math.pi / 6), math.sin(math.pi / 6)
    tips = end[headed]
    lines = [np.stack([start, end], axis=1)]
    for c, s in ((cos, sin), (cos, -sin)):
        barb = np.column_stack([c * back[:, 0] - s * back[:, 1], s * back[:, 0] + c * back[:, 1]])
        lines.append(np.stack([tips, tips + barb], axis=1))
    # sub-pixel end points: OpenCV takes fixed-point coordinates with SHIFT fractional bits
    segments = np.rint(np.concatenate(lines) * (1 << _SHIFT)).astype(np.int32)
    cv2.polylines(bgr, list(segments), False, ARROW_BGR, ARROW_PX, cv2.LINE_AA, _SHIFT)
    return bgr


def _points(points: np.ndarray | None) -> np.ndarray | None:
    """A float copy of marker positions as (N, 2), or None."""
    return None if points is None else np.array(points, dtype=float).reshape(-1, 2)


@dataclass
class _Frame:
    image: np.ndarray
    reference_px: np.ndarray | None
    positions_px: np.ndarray | None
    version: int
    jpeg: bytes | None = None
    jpeg_version: int = -1
    encoded_at: float = -math.inf  # time.monotonic() of the encoding [s]


class LiveHub:
    """Thread-safe store of the live updates and each sensor's newest frame.

    ``max_updates`` bounds the history kept for late browsers (thinned past it);
    ``frame_interval_s`` is the shortest time between two encodings of a sensor's frame [s].
    """

    def __init__(
        self, *, max_updates: int = MAX_UPDATES, frame_interval_s: float = FRAME_INTERVAL_S
    ) -> None:
        if max_updates < 2:
            raise ValueError(f"max_updates must be at least 2, got {max_updates}")
        self.max_updates = int(max_updates)
        self.frame_interval_s = float(frame_interval_s)
        self._changed = threading.Condition()
        self._seq: list[int] = []  # sequence number of each kept update, increasing
        self._text: list[str] = []  # its JSON without ``signal``
        self._signal: tuple[int, str] | None = None  # (seq, full JSON) of the newest with one
        self._last_seq = 0
        self._closed = False
        self._frames: dict[str, _Frame] = {}

    # -- producer side ---------------------------------------------------------------------

    def publish(self, update: dict) -> None:
        """Add one update (a JSON-able dict; numpy values and NaN are converted).

        Ignored once the hub is closed.
        """
        update = jsonable(update)
        if not isinstance(update, dict):
            raise TypeError(f"an update is a dict, got {type(update).__name__}")
        has_signal = update.get("signal") is not None
        full = json.dumps(update, allow_nan=False, separators=(",", ":")) if has_signal else None
        update.pop("signal", None)
        text = json.dumps(update, allow_nan=False, separators=(",", ":"))
        with self._changed:
            if self._closed:
                return
            self._last_seq += 1
            self._seq.append(self._last_seq)
            self._text.append(text)
            if full is not None:
                self._signal = (self._last_seq, full)
            if len(self._seq) > self.max_updates:
                keep = {*range(0, len(self._seq) - 1, 2), len(self._seq) - 1}
                if self._signal is not None:  # the update that carries the newest signal stays
                    keep.add(bisect_right(self._seq, self._signal[0]) - 1)
                self._seq = [self._seq[i] for i in sorted(keep)]
                self._text = [self._text[i] for i in sorted(keep)]
            self._changed.notify_all()

    def publish_frame(
        self,
        sensor: str,
        image: np.ndarray,
        reference_px: np.ndarray | None = None,
        positions_px: np.ndarray | None = None,
    ) -> None:
        """Make ``image`` (grey or BGR uint8) the newest frame of ``sensor``.

        ``reference_px`` and ``positions_px``: the markers' reference and current
        positions (N, 2) x, y [px] for the displacement arrows. Copied: the caller
        may reuse its buffers.
        """
        image = np.asarray(image)
        if image.dtype != np.uint8 or image.ndim not in (2, 3):
            raise ValueError(
                f"a frame is a grey or BGR uint8 image, got {image.dtype} {image.shape}"
            )
        frame = _Frame(image.copy(), _points(reference_px), _points(positions_px), 1)
        with self._changed:
            old = self._frames.get(sensor)
            if old is not None:
                frame.version = old.version + 1
                frame.jpeg, frame.jpeg_version, frame.encoded_at = (
                    old.jpeg,
                    old.jpeg_version,
                    old.encoded_at,
                )
            self._frames[sensor] = frame

    def close(self) -> None:
        """End the stream: browsers get the updates so far, then the end."""
        with self._changed:
            self._closed = True
            self._changed.notify_all()

    # -- consumer side ---------------------------------------------------------------------

    @property
    def closed(self) -> bool:
        return self._closed

    def updates_since(self, seq: int) -> tuple[list[tuple[int, str]], bool]:
        """The kept updates after sequence number ``seq`` as (seq, JSON), and whether closed.

        Both are read together: when ``closed`` is true and the list is empty,
        the reader has seen every update.
        """
        with self._changed:
            start = bisect_right(self._seq, seq)
            items = list(zip(self._seq[start:], self._text[start:], strict=True))
            if self._signal is not None:
                items = [(s, self._signal[1] if s == self._signal[0] else t) for s, t in items]
            return items, self._closed

    def wait(self, seq: int, timeout_s: float = 1.0) -> bool:
        """Block until an update after ``seq`` or the close, at most ``timeout_s`` [s].

        Returns whether one came.
        """
        with self._changed:
            return self._changed.wait_for(
                lambda: self._closed or self._last_seq > seq, timeout=timeout_s
            )

    def _versions(self) -> dict[str, int]:
        return {name: frame.version for name, frame in self._frames.items()}

    def frame_versions(self) -> dict[str, int]:
        """``{sensor: version}``: the version grows with every published frame."""
        with self._changed:
            return self._versions()

    def frame_jpeg(self, sensor: str) -> bytes | None:
        """The newest frame of ``sensor`` as JPEG with its arrows; None for an unknown sensor.

        Encoded at most every ``frame_interval_s`` per sensor; in between, the
        last encoding is returned.
        """
        with self._changed:
            frame = self._frames.get(sensor)
            if frame is None:
                return None
            now = time.monotonic()
            fresh = frame.jpeg_version == frame.version
            if frame.jpeg is not None and (fresh or now - frame.encoded_at < self.frame_interval_s):
                return frame.jpeg
            # the frame's arrays are never changed after publish: encode outside the lock
            image, reference, positions, version = (
                frame.image,
                frame.reference_px,
                frame.positions_px,
                frame.version,
            )
        ok, jpeg = cv2.imencode(
            ".jpg",
            draw_arrows(
                image, reference, positions, zoom=2 if image.shape[1] < ZOOM_BELOW_PX else 1
            ),
            [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY],
        )
        if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
            return None
        data = jpeg.tobytes()
        with self._changed:
            current = self._frames.get(sensor)
            if current is not None and current.jpeg_version < version:
                current.jpeg, current.jpeg_version, current.encoded_at = data, version, now
        return data
