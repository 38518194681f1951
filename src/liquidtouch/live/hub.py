"""What the live view shows, shared between the estimator and the web page: :class:`LiveHub`.

The estimator's thread publishes updates (:meth:`LiveHub.publish`, one
JSON-able dict per refresh, keys in ``docs/formats.md``, "Live updates") and
each sensor's newest frame with its markers (:meth:`LiveHub.publish_frame`);
the web server (:mod:`liquidtouch.live.web`) reads them for any number of
browsers. A browser that connects late gets the history of updates first (so
its plots are complete), then the new ones, then the end (:meth:`LiveHub.close`).

Each update carries only what is new of the signal u(t) (:class:`SignalDeltas`): the
samples since the previous update (with a short overlap: the zero-phase low-pass moves
the newest ones) and the current fit, decimated; a snapshot of the kept signal when the
decay clock or the signal's basis changed, and for a browser that connects late or
missed updates. So an update's size does not grow with the stream.

Memory is bounded: past ``max_updates`` the history is thinned (every other
update dropped, the first and the newest kept, so the plots still span the
whole trial), the signal is kept over the last :data:`SIGNAL_KEEP_S` with the last
:data:`KEPT_DELTAS` deltas, and each sensor keeps only its newest frame. A
frame is encoded to JPEG, with its marker displacement arrows drawn, only
when a browser asks, and at most every :data:`FRAME_INTERVAL_S` per sensor.
"""

from __future__ import annotations

import json
import math
import threading
import time
from bisect import bisect_right
from collections import OrderedDict
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


#: seconds of the signal u(t) the page keeps and a late browser's snapshot carries [s]
SIGNAL_KEEP_S = 60.0
#: a delta resends the page's newest samples of this span [s]: the zero-phase low-pass
#: changes the last ~0.3 s of the signal as frames come (``liquidtouch.live.refresh.EDGE_S``)
OVERLAP_S = 0.5
#: before the overlap, the page's samples over this span [s] must agree with the new signal
#: (else its basis changed: a new window's PCA, another decay clock) or a snapshot is sent
CHECK_S = 2.0
#: agreement: the rms difference under this fraction of the page's signal's std
AGREE_REL = 0.02
#: a change of the decay clock's zero larger than this is a new clock [s]
ORIGIN_TOL_S = 0.1
#: the fitted curve is sent at most this many points
MAX_FIT_POINTS = 400
#: the signal's deltas kept for browsers that are a few updates behind (others get a snapshot)
KEPT_DELTAS = 64


def _floats(values: object) -> np.ndarray:
    """``values`` (a list with None, an array) as a float array; None → NaN."""
    if values is None:
        return np.zeros(0)
    out = np.array([math.nan if v is None else v for v in values] if isinstance(values, list)
                   else values, dtype=float).reshape(-1)  # fmt: skip
    return out


def _rounded(values: np.ndarray, decimals: int) -> list[float | None]:
    """JSON-ready list: rounded to ``decimals`` (the plot needs no more), NaN → None."""
    return jsonable(np.round(values, decimals))  # type: ignore[return-value]


class SignalDeltas:
    """What browsers have of the signal u(t), and the delta that brings them to a new one.

    :meth:`delta` takes an update's whole signal (``t_s`` on the decay clock [s], ``u``
    [px], ``fit`` [px] on the same ``t_s``, NaN where not fitted) and returns the JSON-ready
    ``signal`` of the update: only the newest samples (``from_t_s``: the page replaces its
    samples from there on), or a snapshot (``from_t_s`` null) when the decay clock or the
    signal's basis changed; the fitted curve decimated to :data:`MAX_FIT_POINTS`, left out
    when unchanged. :meth:`snapshot` is the whole kept signal, for a browser that missed
    updates. Everything kept is bounded by :data:`SIGNAL_KEEP_S`.
    """

    def __init__(self, keep_s: float = SIGNAL_KEEP_S) -> None:
        self.keep_s = float(keep_s)
        self.origin_s = math.nan
        self.t = np.zeros(0)
        self.u = np.zeros(0)
        self.fit: dict[str, object] | None = None

    def delta(self, signal: dict, origin_s: float) -> dict[str, object]:
        """The ``signal`` payload of an update whose decay clock starts at ``origin_s`` [s]."""
        t, u = _floats(signal.get("t_s")), _floats(signal.get("u"))
        fit = _floats(signal.get("fit"))
        if len(u) != len(t):
            t, u = np.zeros(0), np.zeros(0)
        if len(fit) != len(t):
            fit = np.full(t.shape, np.nan)
        ok = np.isfinite(t)
        t, u, fit = t[ok], u[ok], fit[ok]
        if t.size:
            recent = t >= t[-1] - self.keep_s
            t, u, fit = t[recent], u[recent], fit[recent]
        fitted = np.isfinite(fit)
        step = max(1, math.ceil(int(fitted.sum()) / MAX_FIT_POINTS))
        fit_payload = (
            {"t_s": _rounded(t[fitted][::step], 4), "u": _rounded(fit[fitted][::step], 5)}
            if fitted.any()
            else None
        )
        from_s = self._append_from(t, u, origin_s)
        if from_s is None:
            self.t, self.u = t, u
        else:
            older = self.t < from_s
            self.t = np.concatenate([self.t[older], t[t >= from_s]])
            self.u = np.concatenate([self.u[older], u[t >= from_s]])
            if self.t.size:
                recent = self.t >= self.t[-1] - self.keep_s
                self.t, self.u = self.t[recent], self.u[recent]
        self.origin_s = origin_s
        out: dict[str, object] = {
            "from_t_s": None if from_s is None else round(from_s, 4),
            "t_s": _rounded(t if from_s is None else t[t >= from_s], 4),
            "u": _rounded(u if from_s is None else u[t >= from_s], 5),
        }
        if from_s is None or fit_payload != self.fit:
            out["fit"] = fit_payload
        self.fit = fit_payload
        return out

    def _append_from(self, t: np.ndarray, u: np.ndarray, origin_s: float) -> float | None:
        """Where the new signal replaces the page's [s, decay clock]; None: replace it all."""
        same_clock = abs(origin_s - self.origin_s) <= ORIGIN_TOL_S  # False when either NaN
        if not (same_clock and self.t.size and t.size):
            return None
        # half a sample before one of the new signal: the page drops its samples from there
        # (a refresh's clock may be shifted by a fraction of a sample from the last one's)
        first = int(np.searchsorted(t, float(self.t[-1]) - OVERLAP_S))
        if not 1 <= first < len(t):
            return None
        from_s = float(t[first] - 0.5 * (t[first] - t[first - 1]))
        check = (self.t >= from_s - CHECK_S) & (self.t < from_s)
        check &= (self.t >= t[0]) & (self.t <= t[-1])
        if check.sum() < 3:
            return None
        mine = self.u[check]
        theirs = np.interp(self.t[check], t, u)
        scale = float(np.nanstd(self.u)) or 1.0
        rms = float(np.sqrt(np.nanmean((theirs - mine) ** 2)))
        return from_s if rms <= AGREE_REL * scale else None

    def snapshot(self) -> dict[str, object]:
        """The whole kept signal as a ``signal`` payload (``from_t_s`` null)."""
        return {
            "from_t_s": None,
            "t_s": _rounded(self.t, 4),
            "u": _rounded(self.u, 5),
            "fit": self.fit,
        }


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


def _origin_s(update: dict) -> float:
    """The decay clock's zero on the stream's clock [s]: ``elapsed_s - t_s`` (NaN unknown)."""
    elapsed, t_s = update.get("elapsed_s"), update.get("t_s")
    if isinstance(elapsed, int | float) and isinstance(t_s, int | float):
        return float(elapsed) - float(t_s)
    return math.nan


def _with_signal(text: str, signal: str | None) -> str:
    """An update's JSON ``text`` with ``"signal": signal`` added (unchanged when None)."""
    if signal is None:
        return text
    return f'{text[:-1]}{"," if text != "{}" else ""}"signal":{signal}}}'


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
        self._signals = SignalDeltas()  # the signal as browsers that kept up have it
        self._deltas: OrderedDict[int, str] = OrderedDict()  # seq -> its signal delta (JSON)
        self._evicted = 0  # the newest seq whose delta is no longer kept
        self._last_seq = 0
        self._closed = False
        self._frames: dict[str, _Frame] = {}

    # -- producer side ---------------------------------------------------------------------

    def publish(self, update: dict) -> None:
        """Add one update (a JSON-able dict; numpy values and NaN are converted).

        Its ``signal`` (``t_s``, ``u``, ``fit``: the whole current signal) is kept as what
        browsers need to catch up: the delta from the previous one
        (:class:`SignalDeltas`). Ignored once the hub is closed.
        """
        if not isinstance(update, dict):
            raise TypeError(f"an update is a dict, got {type(update).__name__}")
        update = dict(update)
        signal = update.pop("signal", None)
        update = jsonable(update)
        text = json.dumps(update, allow_nan=False, separators=(",", ":"))
        origin = _origin_s(update)
        with self._changed:
            if self._closed:
                return
            self._last_seq += 1
            self._seq.append(self._last_seq)
            self._text.append(text)
            if isinstance(signal, dict):
                delta = self._signals.delta(signal, origin)
                self._deltas[self._last_seq] = json.dumps(
                    delta, allow_nan=False, separators=(",", ":")
                )
                while len(self._deltas) > KEPT_DELTAS:
                    self._evicted = self._deltas.popitem(last=False)[0]
            if len(self._seq) > self.max_updates:
                keep = sorted({*range(0, len(self._seq) - 1, 2), len(self._seq) - 1})
                self._seq = [self._seq[i] for i in keep]
                self._text = [self._text[i] for i in keep]
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

        A reader that saw every update up to ``seq`` gets each update's signal delta; one
        that missed some (a late browser, a reconnect after the history was thinned or the
        deltas dropped) gets the updates without signals and the whole kept signal (a
        snapshot, bounded) on the newest. Both are read together: when ``closed`` is true
        and the list is empty, the reader has seen every update.
        """
        with self._changed:
            start = bisect_right(self._seq, seq)
            items = list(zip(self._seq[start:], self._text[start:], strict=True))
            if not items:
                return items, self._closed
            caught_up = items[0][0] == seq + 1 and items[-1][0] - seq == len(items)
            if caught_up and seq >= self._evicted:
                items = [(s, _with_signal(t, self._deltas.get(s))) for s, t in items]
            elif self._deltas:
                snapshot = json.dumps(self._signals.snapshot(), allow_nan=False)
                items[-1] = (items[-1][0], _with_signal(items[-1][1], snapshot))
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
