"""Marker detection and sub-pixel tracking on GelSight images → :class:`MarkerTracks`.

The work is split by concept: :mod:`liquidtouch.tracking.detect` (find markers in
one image), :mod:`liquidtouch.tracking.centroid` (the sub-pixel centroid, one
definition everywhere, documented there) and :mod:`liquidtouch.tracking.track`
(frame-to-frame tracking). This module holds the result, :class:`MarkerTracks`,
the :func:`track_markers` loop and the ``.npz`` format, and re-exports the rest.

**Tracking** refines every marker on a window around its predicted position
(constant velocity) — no full-frame work per frame, all markers at once with
numpy (one strided window gather, three small matrix products; a window is
re-centred only for the markers that ended more than a pixel off). A marker is
flagged lost (``valid = False``, position NaN) when its centre leaves the
image, its blob (pixels above the weight threshold) shrinks below 0.3× or grows
beyond 3× its first-frame area (``area_change``), it lands more than half a
spacing from its prediction (``search_fraction``), or it comes within that
distance of another marker (two windows on one blob; the one that jumped is
dropped). A marker that fails gets
a second search at once, predicted from its neighbours' motion in this frame
(fast presses and releases). Lost markers are re-acquired by a full detection
(at most every few frames while any are lost), matched one-to-one to their
last positions with a KD-tree, gated at half the spacing measured in the first
frame.

Coordinates are pixels, ``x`` to the right and ``y`` down, pixel centres at
integers. The thresholds are named constants of the three modules, and the
ones worth tuning are keyword arguments of :func:`detect_markers` and
:func:`track_markers` (which passes detection knobs on).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from liquidtouch._core import atomic
from liquidtouch._core.checks import check_times
from liquidtouch._core.numbers import percent
from liquidtouch.errors import LiquidTouchError, MarkerError, OutputError, VideoError
from liquidtouch.tracking.detect import (
    as_grey,
)
from liquidtouch.tracking.track import (
    AREA_CHANGE,
    REACQUIRE_EVERY,
    SEARCH_FRACTION,
    MarkerTracker,
    marker_spacing,
)

#: track_markers fails when all markers are lost in more than this fraction of the frames
MAX_ALL_LOST_FRACTION = 0.1
#: Frames tracked per sensor at most: 20 min at 30 fps. A trial is a push and ~13 s of
#: ring-down; the tracks of a longer recording (frames × markers × 16 bytes) only cost memory.
MAX_FRAMES = 36_000
#: fewest frames of a sensor: a time axis needs two (``_core.checks.check_times``)
MIN_FRAMES = 2


def check_frame_count(n: int, what: str, error: type[LiquidTouchError] = VideoError) -> None:
    """Refuse (``error``) a sensor of fewer than :data:`MIN_FRAMES` or more than
    :data:`MAX_FRAMES` frames: what tracking takes, checked by ``extract`` as it reads the
    frames and by ``dataset add`` before it stores them."""
    if n > MAX_FRAMES:
        raise error(
            f"{what} holds {n} frames, more than the {MAX_FRAMES} tracked per sensor (a "
            "trial is the push and its ~15 s ring-down); trim the recording to that"
        )
    if n < MIN_FRAMES:
        raise error(
            f"{what} holds {n} frame(s); a sensor's recording needs at least {MIN_FRAMES} "
            "(a push and its ring-down: ~15 s)"
        )


__all__ = [
    "MAX_ALL_LOST_FRACTION",
    "MAX_FRAMES",
    "MIN_FRAMES",
    "MarkerTracks",
    "check_frame",
    "check_frame_count",
    "load_tracks",
    "run_tracker",
    "save_tracks",
    "save_tracks_csv",
    "track_markers",
    "tracks_format",
]


@dataclass(repr=False)
class MarkerTracks:
    """Tracked markers of one sensor video.

    Attributes
    ----------
    t : (T,) frame timestamps [s].
    positions : (T, N, 2) marker centres [px] (x, y); NaN where lost.
    valid : (T, N) bool, False where the marker was lost.
    reference : (N, 2) positions in the first frame [px].
    sensor : sensor name (``left``, ``right`` or the video's name).
    spacing_px : median nearest-neighbour marker distance in the first frame [px].
    diameter_px : median marker diameter [px].
    first_frame : the first (grey) image, when tracked from frames.
    start_s : time [s] of the first frame on the clock shared by all sensors of the
        trial (a recording's ``meta.json`` ``sensor_start_s``); 0 when unknown, and
        sensors are then aligned on their first frames. Frame ``k`` is at
        ``start_s + t[k] - t[0]`` on that clock.
    tracking : how the points were tracked: ``"markers"`` (printed markers) or ``"flow"``
        (a markerless gel's own image, :mod:`liquidtouch.tracking.flow`: the points are
        cells of its grid).

    Its repr is one short line: sensor, frames × markers and the valid share.
    """

    t: np.ndarray
    positions: np.ndarray
    valid: np.ndarray
    reference: np.ndarray
    sensor: str = "sensor"
    spacing_px: float = float("nan")
    diameter_px: float = float("nan")
    first_frame: np.ndarray | None = field(default=None, repr=False)
    start_s: float = 0.0
    tracking: str = "markers"

    def __repr__(self) -> str:
        valid = np.asarray(self.valid)
        share = percent(valid.mean(), 0) if valid.size else percent(None)
        points = "markers" if self.tracking == "markers" else f"{self.tracking} cells"
        return (
            f"MarkerTracks(sensor={self.sensor!r}, {len(self.t)} frames × "
            f"{self.n_markers} {points}, {share} valid)"
        )

    @property
    def n_markers(self) -> int:
        return int(self.reference.shape[0])

    @property
    def displacement(self) -> np.ndarray:
        """(T, N, 2) motion from the first frame [px]; NaN where lost."""
        return self.positions - self.reference[None]


def track_markers(
    frames: Iterable[tuple[float, np.ndarray]],
    sensor: str = "sensor",
    *,
    diameter_px: float | None = None,
    reacquire_every: int = REACQUIRE_EVERY,
    search_fraction: float = SEARCH_FRACTION,
    area_change: tuple[float, float] = AREA_CHANGE,
    on_frame: Callable[[int], None] | None = None,
    **detect_kwargs: Any,
) -> MarkerTracks:
    """Detect markers in the first frame and track them through ``frames`` of ``(t_s, image)``.

    Parameters
    ----------
    frames : iterable of (t_s, image)
        Timestamps [s] (finite, strictly increasing) and grey or colour images
        of one size, e.g. :func:`liquidtouch.io.frames.iter_frames`.
    sensor : str
        Name of the sensor (keys of the ``.npz`` file, marker labels).
    diameter_px : float, optional
        Marker diameter [px]; measured in the first frame when not given.
    reacquire_every : int
        Frames between re-detections of lost markers [frames, ≥ 1].
    search_fraction : float
        Search radius around each predicted position, as a fraction of the
        marker spacing [unitless, (0, 1]]; a marker found further away is lost.
    area_change : (low, high)
        A marker is lost when its blob area leaves ``low``–``high`` × its
        first-frame area [unitless].
    on_frame : callable, optional
        Called with the index of each frame once it is tracked (progress bars).
    **detect_kwargs
        Passed on to :func:`detect_markers` (``threshold_range``,
        ``min_area_px``, ``area_ratio``, ``min_fill``, ``max_aspect``).

    Raises
    ------
    MarkerError
        The first frame has no or too few markers, all markers are lost in more
        than a tenth of the frames, or a knob is out of range.
    VideoError
        No frames, timestamps not finite and increasing, or frames of different sizes.
    """
    if not isinstance(sensor, str) or not sensor:
        raise MarkerError(f"sensor must be a non-empty name such as 'left', got {sensor!r}")
    if on_frame is not None and not callable(on_frame):
        raise MarkerError(f"on_frame must be a function of the frame index, got {on_frame!r}")
    tracker = MarkerTracker(
        diameter_px=diameter_px,
        reacquire_every=reacquire_every,
        search_fraction=search_fraction,
        area_change=area_change,
        detect_kwargs=detect_kwargs,
    )
    times, positions, first = run_tracker(frames, tracker, sensor, on_frame)
    valid = np.isfinite(positions).all(axis=2)
    none_valid = ~valid.any(axis=1)
    if none_valid.mean() > MAX_ALL_LOST_FRACTION:
        raise MarkerError(
            f"{sensor}: all markers lost in {int(none_valid.sum())} of {len(positions)} frames; "
            "the gel may be out of view or the video too blurred"
        )
    return MarkerTracks(
        t=times,
        positions=positions,
        valid=valid,
        reference=tracker.reference,
        sensor=sensor,
        spacing_px=tracker.spacing_px,
        diameter_px=float(tracker.diameter_px),
        first_frame=first,
    )


def run_tracker(
    frames: Iterable,
    tracker: Any,
    sensor: str,
    on_frame: Callable[[int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frames through a tracker: the frame times [s], the positions (T × N × 2) [px] and
    the first frame in grey.

    ``frames`` as :func:`track_markers` takes them; ``tracker.start(grey)`` gives the
    first frame's points and ``tracker.step(image)`` each next frame's (markers or the
    cells of a markerless gel). Every frame is checked (:func:`check_frame`, one size,
    at most ``MAX_FRAMES``, at least two); ``on_frame(k)`` is called after frame ``k``.
    """
    times: list[float] = []
    rows: list[np.ndarray] = []
    first = None
    for k, item in enumerate(frames):
        if k >= MAX_FRAMES:
            check_frame_count(k + 1, sensor)
        t_s, image = check_frame(item, k, sensor, times[-1] if times else None)
        if k == 0:
            first = as_grey(image)
            rows.append(np.array(tracker.start(first), copy=True))
        else:
            if np.shape(image)[:2] != first.shape:
                raise VideoError(
                    f"{sensor}: frame {k} is {np.shape(image)[:2]} but the first frame is "
                    f"{first.shape} (height, width); give the frames of one video"
                )
            rows.append(tracker.step(image))
        times.append(t_s)
        if on_frame is not None:
            on_frame(k)
    check_frame_count(len(rows), sensor)
    return np.asarray(times), np.stack(rows), first


def check_frame(item: object, k: int, sensor: str, previous: float | None) -> tuple[float, Any]:
    """``(t_s, image)`` of frame ``k``, its timestamp checked against the previous one."""
    try:
        t_s, image = item  # type: ignore[misc]
        t_s = float(t_s)
    except (TypeError, ValueError):
        raise VideoError(
            f"{sensor}: frame {k} is not a (timestamp [s], image) pair; "
            "iterate liquidtouch.io.frames.iter_frames(source)"
        ) from None
    pair = [t_s] if previous is None else [previous, t_s]
    first = k + 1 - len(pair)
    check_times(pair, f"{sensor}: frame timestamps", VideoError, min_count=1, first=first)
    return t_s, image


def save_tracks(path: str | Path, tracks: list[MarkerTracks]) -> None:
    """Write tracks of one or more sensors to an ``.npz`` file (atomic, no pickle).

    Keys: ``sensors`` (names) and per sensor ``<name>/t``, ``<name>/positions``,
    ``<name>/valid``, ``<name>/reference`` and ``<name>/start_s`` (a 0-D float;
    files without it read as 0).
    """

    arrays: dict[str, np.ndarray] = {"sensors": np.array([tr.sensor for tr in tracks], dtype=str)}
    for tr in tracks:
        arrays[f"{tr.sensor}/t"] = tr.t
        arrays[f"{tr.sensor}/positions"] = tr.positions
        arrays[f"{tr.sensor}/valid"] = tr.valid
        arrays[f"{tr.sensor}/reference"] = tr.reference
        arrays[f"{tr.sensor}/start_s"] = np.float64(tr.start_s)
    with atomic.atomic_path(path) as tmp, open(tmp, "wb") as handle:
        np.savez_compressed(handle, **arrays)


def load_tracks(path: str | Path) -> list[MarkerTracks]:
    """Read tracks written by :func:`save_tracks`."""
    with np.load(path, allow_pickle=False) as data:
        return [
            MarkerTracks(
                t=data[f"{name}/t"],
                positions=data[f"{name}/positions"],
                valid=data[f"{name}/valid"],
                reference=data[f"{name}/reference"],
                sensor=str(name),
                spacing_px=marker_spacing(data[f"{name}/reference"]),
                start_s=float(data[f"{name}/start_s"]) if f"{name}/start_s" in data else 0.0,
            )
            for name in data["sensors"]
        ]


TRACKS_FORMATS = {".npz": "npz", ".csv": "csv"}
"""Tracks file formats by suffix: compressed NumPy archive, or long-format CSV."""
TRACKS_CSV_COLUMNS = ("t", "sensor", "marker", "x", "y", "valid")


def tracks_format(path: str | Path) -> str:
    """``"npz"`` or ``"csv"`` from the suffix of ``path``; OutputError for any other suffix."""

    suffix = Path(path).suffix.lower()
    if suffix not in TRACKS_FORMATS:
        raise OutputError(
            f"cannot write tracks to {path}: the suffix picks the format, "
            f"{' or '.join(TRACKS_FORMATS)} (got {suffix or 'none'!r})"
        )
    return TRACKS_FORMATS[suffix]


def save_tracks_csv(path: str | Path, tracks: list[MarkerTracks]) -> None:
    """Write tracks as one long-format CSV (atomic): one row per frame, sensor and marker.

    Columns :data:`TRACKS_CSV_COLUMNS`: ``t`` [s], ``sensor`` (name), ``marker``
    (index within the sensor, as in the ``.npz``), ``x``, ``y`` [px] (empty where
    lost) and ``valid`` (1, or 0 where lost); rows by sensor, frame, marker.
    """
    import pandas as pd

    parts = []
    for tr in tracks:
        n_frames, n_markers = tr.valid.shape
        parts.append(
            pd.DataFrame(
                {
                    "t": np.repeat(np.asarray(tr.t, dtype=float), n_markers),
                    "sensor": tr.sensor,
                    "marker": np.tile(np.arange(n_markers), n_frames),
                    "x": tr.positions[:, :, 0].ravel(),
                    "y": tr.positions[:, :, 1].ravel(),
                    "valid": tr.valid.ravel().astype(int),
                }
            )
        )
    table = (
        pd.concat(parts, ignore_index=True)
        if parts
        else pd.DataFrame(columns=list(TRACKS_CSV_COLUMNS))
    )
    atomic.write_text(path, table.to_csv(index=False, float_format="%.6f"))
