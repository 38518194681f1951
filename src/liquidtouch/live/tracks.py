"""Marker tracks that grow one frame at a time over a bounded window: :class:`GrowingTracks`.

Each sensor's markers are tracked incrementally with the offline tracker
(:class:`~liquidtouch.tracking.track.MarkerTracker`: the same detection, the same
steps; on a markerless gel, found from the first frame, the flow tracker of
:mod:`liquidtouch.tracking.flow`), into preallocated arrays, so adding a frame costs
the tracking step and a row copy. Only the last :data:`WINDOW_S` of frames are kept for
the estimate (a ring-down of interest lasts at most ~30 s; the window also holds the push and
what came before it): when the arrays are full, frames older than the window are
dropped by moving the newer ones to the front (amortised O(1) per frame), else
the arrays double. Memory and the work of a refresh are bounded however long the
stream runs. :meth:`GrowingTracks.snapshot` is a
:class:`~liquidtouch.tracking.tracks.MarkerTracks` of the window, what the offline
:func:`~liquidtouch.signal.tactile_signal` takes: for a stream shorter than the
window the tracks equal :func:`~liquidtouch.tracking.tracks.track_markers`' on the
same frames.
"""

from __future__ import annotations

import math

import numpy as np

from liquidtouch._core.checks import check_times
from liquidtouch.errors import VideoError
from liquidtouch.tracking.detect import as_grey
from liquidtouch.tracking.flow import TextureError
from liquidtouch.tracking.gel import DEFAULT_TRACKING, check_tracking, gel_tracker
from liquidtouch.tracking.tracks import MarkerTracks

#: frames preallocated at the start (grows by doubling up to the window): 20 s at 30 fps
INITIAL_FRAMES = 600
#: stream time kept for the estimate [s]: the longest ring-down of interest (~30 s) with
#: the push and the rest before it
WINDOW_S = 60.0


class GrowingTracks:
    """One sensor's tracks over the last ``window_s`` [s]; :meth:`add` a frame,
    :meth:`snapshot` the tracks."""

    def __init__(
        self, sensor: str, window_s: float = WINDOW_S, tracking: str = DEFAULT_TRACKING
    ) -> None:
        if not 0 < float(window_s) <= math.inf:
            raise VideoError(f"window_s must be a time > 0 in seconds, got {window_s!r}")
        self.sensor = sensor
        self.window_s = float(window_s)
        self.start_s = float("nan")  # the first frame's time on the shared clock [s]
        self.tracking = check_tracking(tracking)  # "auto" until the first frame decides
        self.tracker = None
        self.waited = 0  # frames of a markerless gel without texture before the first
        self.n = 0  # frames in the arrays (the newest is at n - 1)
        self.total = 0  # frames added since the start
        self.t = np.zeros(INITIAL_FRAMES)
        self.positions: np.ndarray | None = None
        self.first: np.ndarray | None = None
        self.given_reference: np.ndarray | None = None  # positions given, not tracked

    def _check_time(self, t_s: float) -> None:
        pair = [self.t[self.n - 1], t_s] if self.n else [t_s]
        first = self.total + 1 - len(pair)
        check_times(pair, f"{self.sensor}: frame timestamps", VideoError, min_count=1, first=first)

    def add(self, t_s: float, image: np.ndarray) -> np.ndarray:
        """Track the markers into the frame at ``t_s`` [s]; return their positions (N, 2) [px].

        Raises :class:`VideoError` for a timestamp not after the previous one or a
        frame of another size; :class:`~liquidtouch.errors.MarkerError` when the first
        frame shows too few markers.
        """
        t_s = float(t_s)
        self._check_time(t_s)
        if self.first is None:
            try:
                self.tracker, row = gel_tracker(as_grey(image), self.tracking)
            except TextureError:
                # a markerless gel before the grasp shows nothing to track: the stream's
                # reference is the first frame with the contact's texture
                self.waited += 1
                return np.zeros((0, 2))
            self.start_s = t_s
            self.first = as_grey(image)
            self.tracking = self.tracker.tracking
            self.positions = np.zeros((INITIAL_FRAMES, len(row), 2))
        else:
            if np.shape(image)[:2] != self.first.shape:
                raise VideoError(
                    f"{self.sensor}: frame {self.total} is {np.shape(image)[:2]} but the first "
                    f"frame is {self.first.shape} (height, width)"
                )
            row = self.tracker.step(image)
        self._append(t_s, row)
        return row

    def add_positions(self, t_s: float, positions: np.ndarray) -> np.ndarray:
        """Add marker positions (N, 2) [px] tracked elsewhere, at ``t_s`` [s] (no image)."""
        t_s = float(t_s)
        row = np.asarray(positions, dtype=float)
        self._check_time(t_s)
        if self.positions is None:
            self.start_s = t_s
            self.positions = np.zeros((INITIAL_FRAMES, len(row), 2))
            self.given_reference = row.copy()
        self._append(t_s, row)
        return row

    def _append(self, t_s: float, row: np.ndarray) -> None:
        if self.n == len(self.t):  # full: drop what left the window, else double
            old = int(np.searchsorted(self.t[: self.n], t_s - self.window_s, side="left"))
            if old >= self.n // 2:  # at least half freed: each frame is moved O(1) times
                keep = self.n - old
                self.t[:keep] = self.t[old : self.n]
                self.positions[:keep] = self.positions[old : self.n]
                self.n = keep
            else:
                self.t = np.concatenate([self.t, np.zeros_like(self.t)])
                self.positions = np.concatenate([self.positions, np.zeros_like(self.positions)])
        self.t[self.n] = t_s
        self.positions[self.n] = row
        self.n += 1
        self.total += 1

    @property
    def reference(self) -> np.ndarray | None:
        """Marker positions in the first frame (N, 2) [px]; None before it."""
        if self.first is None:
            return self.given_reference
        return self.tracker.reference

    @property
    def last_t_s(self) -> float:
        """Timestamp of the newest frame on the shared clock [s] (NaN before any)."""
        return self.t[self.n - 1] if self.n else float("nan")

    @property
    def cut(self) -> bool:
        """Whether frames before the window were left out (the stream outgrew it)."""
        return self.total > self.n - self._first_in_window() if self.n else False

    def _first_in_window(self) -> int:
        newest = self.t[self.n - 1]
        return int(np.searchsorted(self.t[: self.n], newest - self.window_s, side="left"))

    def snapshot(self) -> MarkerTracks:
        """The tracks of the frames in the window (copies: the tracker goes on)."""
        first = self._first_in_window() if self.n else 0
        positions = self.positions[first : self.n].copy()
        return MarkerTracks(
            t=self.t[first : self.n].copy(),
            positions=positions,
            valid=np.isfinite(positions).all(axis=2),
            reference=self.reference,
            sensor=self.sensor,
            spacing_px=self.tracker.spacing_px if self.first is not None else float("nan"),
            diameter_px=float(self.tracker.diameter_px) if self.first is not None else math.nan,
            first_frame=self.first,
            start_s=float(self.t[first]) if self.n else self.start_s,
            tracking="flow" if self.tracking == "flow" else "markers",
        )
