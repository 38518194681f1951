"""Marker tracks that grow one frame at a time: :class:`GrowingTracks`.

Each sensor's markers are tracked incrementally with the offline tracker
(:class:`~liquidtouch.tracking.track.MarkerTracker`: the same detection, the same
steps), into preallocated arrays that double when full, so adding a frame
costs the tracking step and a row copy. :meth:`GrowingTracks.snapshot` is a
:class:`~liquidtouch.tracking.tracks.MarkerTracks` of the frames so far, what the
offline :func:`~liquidtouch.signal.tactile_signal` takes: at the end of a stream
the tracks equal :func:`~liquidtouch.tracking.tracks.track_markers`' on the same frames.
"""

from __future__ import annotations

import math

import numpy as np

from liquidtouch.errors import VideoError
from liquidtouch.tracking.detect import as_grey
from liquidtouch.tracking.track import MarkerTracker
from liquidtouch.tracking.tracks import MAX_FRAMES, MarkerTracks

#: frames preallocated at the start (grows by doubling): 20 s at 30 fps
INITIAL_FRAMES = 600


class GrowingTracks:
    """One sensor's tracks so far; :meth:`add` a frame, :meth:`snapshot` the tracks."""

    def __init__(self, sensor: str) -> None:
        self.sensor = sensor
        self.start_s = float("nan")  # the first frame's time on the shared clock [s]
        self.tracker = MarkerTracker()
        self.n = 0
        self.t = np.zeros(INITIAL_FRAMES)
        self.positions: np.ndarray | None = None
        self.first: np.ndarray | None = None
        self.given_reference: np.ndarray | None = None  # positions given, not tracked

    def add(self, t_s: float, image: np.ndarray) -> np.ndarray:
        """Track the markers into the frame at ``t_s`` [s]; return their positions (N, 2) [px].

        Raises :class:`VideoError` for a timestamp not after the previous one, a
        frame of another size, or more than ``MAX_FRAMES`` frames;
        :class:`~liquidtouch.errors.MarkerError` when the first frame shows too few markers.
        """
        t_s = float(t_s)
        if not np.isfinite(t_s) or (self.n and t_s <= self.t[self.n - 1]):
            raise VideoError(
                f"{self.sensor}: frame {self.n} has timestamp {t_s:.6g} s; timestamps must be "
                "finite and increase strictly"
            )
        if self.n >= MAX_FRAMES:
            raise VideoError(f"{self.sensor}: more than {MAX_FRAMES} frames; stop the stream")
        if self.first is None:
            self.start_s = t_s
            self.first = as_grey(image)
            row = self.tracker.start(self.first).copy()
            self.positions = np.zeros((INITIAL_FRAMES, len(row), 2))
        else:
            if np.shape(image)[:2] != self.first.shape:
                raise VideoError(
                    f"{self.sensor}: frame {self.n} is {np.shape(image)[:2]} but the first "
                    f"frame is {self.first.shape} (height, width)"
                )
            row = self.tracker.step(image)
        if self.n == len(self.t):  # full: double (amortised O(1) per frame)
            self.t = np.concatenate([self.t, np.zeros_like(self.t)])
            self.positions = np.concatenate([self.positions, np.zeros_like(self.positions)])
        self.t[self.n] = t_s
        self.positions[self.n] = row
        self.n += 1
        return row

    def add_positions(self, t_s: float, positions: np.ndarray) -> np.ndarray:
        """Add marker positions (N, 2) [px] tracked elsewhere, at ``t_s`` [s] (no image)."""
        t_s = float(t_s)
        row = np.asarray(positions, dtype=float)
        if not np.isfinite(t_s) or (self.n and t_s <= self.t[self.n - 1]):
            raise VideoError(
                f"{self.sensor}: frame {self.n} has timestamp {t_s:.6g} s; timestamps must be "
                "finite and increase strictly"
            )
        if self.positions is None:
            self.start_s = t_s
            self.positions = np.zeros((INITIAL_FRAMES, len(row), 2))
            self.given_reference = row.copy()
        if self.n == len(self.t):
            self.t = np.concatenate([self.t, np.zeros_like(self.t)])
            self.positions = np.concatenate([self.positions, np.zeros_like(self.positions)])
        self.t[self.n] = t_s
        self.positions[self.n] = row
        self.n += 1
        return row

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

    def snapshot(self) -> MarkerTracks:
        """The tracks of the frames so far (copies: the tracker goes on)."""
        positions = self.positions[: self.n].copy()
        return MarkerTracks(
            t=self.t[: self.n].copy(),
            positions=positions,
            valid=np.isfinite(positions).all(axis=2),
            reference=self.reference,
            sensor=self.sensor,
            spacing_px=self.tracker.spacing_px if self.first is not None else float("nan"),
            diameter_px=float(self.tracker.diameter_px) if self.first is not None else math.nan,
            first_frame=self.first,
            start_s=self.start_s,
        )
