"""From marker tracks to the 1-D tactile signal ``u(t)``: resample, low-pass, select, PCA.

1. **Clock**: all sensors are read on one uniform clock over the time they all
   recorded. Each sensor's frame ``k`` is at ``start_s + t[k] - t[0]`` on the trial's
   shared clock (:attr:`MarkerTracks.start_s`, from the recorder's ``sensor_start_s``;
   0 for videos given on their own, which are then aligned on their first frames). The
   clock starts at the first frame of the sensor that started last and steps at
   that sensor's frame period fitted to all its timestamps
   (:func:`~liquidtouch.tracking.clock.frame_period`, :mod:`liquidtouch.tracking.clock` says why).
2. **Gaps**: a marker lost in more than ``max_lost_fraction`` of the frames, or
   for longer than ``max_gap_s`` at a stretch, is not used; a marker's shorter losses
   are bridged like dropped frames. Markers cut by the image border in the first frame
   are not used either (their centroid sees only part of the blob). **Frames that never
   came** (a camera stall, dropped frames) are not invented: a clock sample inside a
   stretch without frames longer than half the period of the low-pass cut-off, at most
   3 Hz (:func:`~liquidtouch.signal.lowpass.max_bridged_gap_s`: the low-passed slosh
   is then sampled below its Nyquist rate; 0.17 s), in any sensor, is *not observed*.
3. **Low-pass**: each sensor's motion is the low-pass of the frames that came, at
   their own times (:func:`~liquidtouch.signal.lowpass.lowpass_frames`, a smoother
   with the response of a zero-phase 4th-order Butterworth,
   :data:`~liquidtouch.signal.lowpass.DEFAULT_LOWPASS_HZ` (4 Hz) by default). A dropped
   frame or three leave no sample to invent: the smoother reads through them from the
   frames on both sides. Without a low-pass (``lowpass_hz=None``) the motion is read
   linearly between consecutive frames.
4. **Selection**: the ``n_markers`` markers (across all sensors) with the
   largest motion, ``sqrt(var x + var y)`` of the filtered displacement.
5. **PCA**: their x, y displacements form a ``2·n``-D vector per frame; the
   first principal component (of the time-centred data) gives ``u(t)`` [px].

The signal holds the observed samples only (``t`` is then uniform except for
its gaps) and reports ``gap_share``, the share of the clock's samples not observed.

**Sign convention**: the component's weight with the largest magnitude is
positive (as scikit-learn's ``svd_flip``), so the same motion always gives the
same sign of ``u``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from liquidtouch._core.checks import as_number, check_times, finite_array
from liquidtouch._core.numbers import fixed, number
from liquidtouch.errors import MarkerError, SignalError
from liquidtouch.signal.lowpass import (
    DEFAULT_LOWPASS_HZ,
    lowpass_frames,
    max_bridged_gap_s,
    observed_samples,
)
from liquidtouch.tracking.clock import frame_period, frame_times
from liquidtouch.tracking.tracks import MarkerTracks

__all__ = [
    "DEFAULT_N_MARKERS",
    "TactileSignal",
    "check_signal_options",
    "first_component",
    "resample_displacement",
    "tactile_signal",
]

#: fewest usable markers (over all sensors) a signal is built from
MIN_SELECTED = 2
#: markers u(t) is built from by default: the most moving (the paper's method). More
#: average more tracking noise but take in markers of small motion, which a lossy codec
#: freezes first (``benchmarks/RESULTS.md``, "pushes": λ on the validation's H.264 video)
DEFAULT_N_MARKERS = 16


@dataclass(repr=False)
class TactileSignal:
    """The tactile signal of one trial.

    Attributes
    ----------
    t : (T,) uniform sample times [s], starting at 0.
    u : (T,) first principal component of the chosen markers' motion [px].
    explained_variance : fraction of the chosen markers' motion variance in ``u``.
    markers : chosen markers as ``(sensor, marker index)``, most moving first.
    weights : (n, 2) PCA weights of each chosen marker's (x, y) motion (unit norm overall).
    fps : sample rate of ``t`` [Hz].
    motion : (T, n, 2) filtered displacement of the chosen markers [px].
    lowpass_hz : cut-off of the low-pass filter [Hz] (``None``: no filter).
    gap_share : share (0-1) of the uniform clock's samples that fell in gaps (not
        observed, not in ``t``; module docstring).

    Its repr is one short line: samples, rate, duration, markers, explained variance.
    """

    t: np.ndarray
    u: np.ndarray
    explained_variance: float
    markers: list[tuple[str, int]]
    weights: np.ndarray
    fps: float
    motion: np.ndarray
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ
    gap_share: float = 0.0

    def __repr__(self) -> str:
        n = len(self.t)
        duration = float(self.t[-1] - self.t[0]) if n > 1 else 0.0
        return (
            f"TactileSignal({n} samples, {number(self.fps, 3)} fps, {number(duration, 3)} s, "
            f"{self.n_markers} markers, explained_variance={fixed(self.explained_variance, 3)})"
        )

    @property
    def n_markers(self) -> int:
        return len(self.markers)


def common_span(tracks: Sequence[MarkerTracks]) -> tuple[int, float, float]:
    """Where the sensors all recorded, on the trial's shared clock (module docstring, 1).

    Returns ``(reference, begin_s, end_s)``: the index of the sensor that started
    last (the first such), and the first and last time [s] every sensor covers.
    """
    starts = [float(tr.start_s) for tr in tracks]
    ends = [s + float(tr.t[-1] - tr.t[0]) for s, tr in zip(starts, tracks, strict=True)]
    begin, end = max(starts), min(ends)
    if not end > begin:
        raise SignalError(
            "the sensors' recordings do not overlap in time (first frames at "
            + ", ".join(f"{tr.sensor} {s:.3f} s" for tr, s in zip(tracks, starts, strict=True))
            + "); give the videos of one recording"
        )
    return int(np.argmax(starts)), begin, end


def _covered_clock(t: np.ndarray, step: float, n_clock: int, max_gap_s: float) -> np.ndarray:
    """The samples ``j * step`` [s], ``0 <= j < n_clock``, of a uniform clock that frames at
    ``t`` [s] (from 0, increasing) cover: all but those inside a stretch without frames
    longer than ``max_gap_s`` [s]. Its size is bounded by the frames, not by the time
    they span (an hour's stall costs nothing)."""
    cut = np.flatnonzero(np.diff(t) > max_gap_s)
    starts, ends = t[np.r_[0, cut + 1]], t[np.r_[cut, t.size - 1]]
    low = np.clip(np.ceil(starts / step - 1e-6), 0, n_clock).astype(np.int64)
    high = np.clip(np.floor(ends / step + 1e-6), -1, n_clock - 1).astype(np.int64)
    counts = np.maximum(high - low + 1, 0)
    offsets = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return (np.repeat(low, counts) + offsets) * step


def resample_displacement(
    tracks: MarkerTracks,
    t_clock: np.ndarray,
    fps: float,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    max_lost_fraction: float = 0.05,
    max_gap_s: float = 0.25,
) -> tuple[np.ndarray, np.ndarray]:
    """Displacement (T, N, 2) [px] on the clock ``t_clock`` and which markers are usable (N,).

    ``t_clock`` [s] lies on a uniform lattice at ``fps`` [Hz] (it may skip samples: a
    stall), on the sensor's own clock from its first frame (``tracks.t - tracks.t[0]``).
    With a low-pass, it is the low-pass of the frames that came, at their own times
    (:func:`~liquidtouch.signal.lowpass.lowpass_frames`: nothing is interpolated first);
    without one, the motion is read linearly between consecutive frames. Samples in a
    gap get values too, or NaN where the low-pass has no estimate (a stall that splits
    the frames): the caller leaves them out
    (:func:`~liquidtouch.signal.lowpass.observed_samples`). A marker lost in some frames
    is read from the frames where it was found. Unusable markers (too often or too long
    lost, cut by the border) get zeros.
    """
    _check_gap_limits(max_lost_fraction, max_gap_s)
    t = tracks.t - tracks.t[0]
    valid = tracks.valid
    disp = tracks.displacement
    usable = valid.mean(axis=0) >= 1.0 - max_lost_fraction
    usable &= _longest_gap_s(t, valid) <= max_gap_s
    usable &= ~_cut_by_border(tracks)
    out = np.zeros((t_clock.size, tracks.n_markers, 2))
    whole = usable & valid.all(axis=0)  # read together, from every frame
    groups = [(np.flatnonzero(whole), np.ones(t.size, bool))] if whole.any() else []
    groups += [(np.array([i]), valid[:, i]) for i in np.flatnonzero(usable & ~whole)]
    for markers, frames in groups:
        t_seen, seen = t[frames], disp[frames][:, markers]
        if lowpass_hz is None:
            flat = seen.reshape(len(t_seen), -1)
            read = np.column_stack([np.interp(t_clock, t_seen, c) for c in flat.T])
            out[:, markers] = read.reshape(t_clock.size, -1, 2)
            continue
        out[:, markers] = lowpass_frames(t_seen, seen, t_clock, fps, lowpass_hz)
    return out, usable


def _longest_gap_s(t: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Longest time [s] each marker spends lost, between its surrounding valid frames."""
    longest = np.zeros(valid.shape[1])
    for i in np.flatnonzero(~valid.all(axis=0)):
        times = t[valid[:, i]]
        if times.size < 2:
            longest[i] = np.inf
            continue
        # A gap at the start or end counts up to the recording's edge.
        edges = np.concatenate([[t[0]], times, [t[-1]]])
        longest[i] = np.diff(edges).max()
    return longest


def _cut_by_border(tracks: MarkerTracks) -> np.ndarray:
    if tracks.first_frame is None or not np.isfinite(tracks.diameter_px):
        return np.zeros(tracks.n_markers, bool)
    height, width = tracks.first_frame.shape
    margin = 0.5 * tracks.diameter_px + 1.0
    x, y = tracks.reference.T
    return (x < margin) | (y < margin) | (x > width - 1 - margin) | (y > height - 1 - margin)


def first_component(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """PCA of (T, D) data: (scores (T,), weights (D,), explained variance fraction)."""
    x = finite_array(x, "the data for PCA", min_ndim=2)
    if x.ndim != 2 or x.shape[0] < 2 or x.shape[1] < 1:
        raise SignalError(f"PCA needs (samples >= 2, features >= 1) data, got shape {x.shape}")
    centred = x - x.mean(axis=0)
    _, singular, vt = np.linalg.svd(centred, full_matrices=False)
    weights = vt[0]
    weights = weights * np.sign(weights[np.argmax(np.abs(weights))])
    total = float(np.sum(singular**2))
    if total <= 0:
        raise SignalError("the markers do not move at all; nothing to extract")
    return centred @ weights, weights, float(singular[0] ** 2 / total)


def tactile_signal(
    tracks: Sequence[MarkerTracks],
    *,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = DEFAULT_N_MARKERS,
    max_lost_fraction: float = 0.05,
    max_gap_s: float = 0.25,
) -> TactileSignal:
    """The tactile signal ``u(t)`` from the tracks of one or more sensors (module docstring).

    Parameters
    ----------
    tracks : sequence of MarkerTracks
        One per sensor (distinct sensor names), e.g. from :func:`track_markers`.
    lowpass_hz : float or None
        Low-pass cut-off [Hz], below the Nyquist frequency; ``None``: no filter.
    n_markers : int
        How many of the most moving markers (over all sensors) to keep [≥ 1].
    max_lost_fraction : float
        A marker lost in more than this fraction of the frames is not used [0–1].
    max_gap_s : float
        A marker lost for longer than this at a stretch is not used [s, ≥ 0].

    Raises
    ------
    MarkerError
        No tracks, malformed tracks, duplicate sensor names, or too few usable markers.
    SignalError
        Bad timestamps, a knob out of range, too few frames, or no motion at all.
    """
    tracks = [_on_the_lattice(tr) for tr in _check_tracks(tracks)]
    check_signal_options(lowpass_hz, n_markers, max_lost_fraction, max_gap_s)
    reference, begin_s, end_s = common_span(tracks)
    t_ref = tracks[reference].t - tracks[reference].t[0]
    step = frame_period(t_ref)
    fps = 1.0 / step
    n_clock = int(np.floor((end_s - begin_s) / step + 1e-6)) + 1  # the uniform clock's samples
    bridged_s = max_bridged_gap_s(lowpass_hz, fps)
    t_uniform = _covered_clock(t_ref, step, n_clock, bridged_s)
    locals_s = [t_uniform + (begin_s - float(tr.start_s)) for tr in tracks]  # own clocks
    observed = np.ones(t_uniform.size, bool)
    for tr, local in zip(tracks, locals_s, strict=True):
        observed &= observed_samples(tr.t - tr.t[0], local, bridged_s)
    if observed.sum() < 2:
        raise SignalError(
            "almost no sample of the recording is observed: the frames come with "
            f"gaps over {bridged_s:.2g} s; check the camera's frame rate"
        )
    blocks, names = [], []
    for tr, local in zip(tracks, locals_s, strict=True):
        disp, usable = resample_displacement(
            tr, local, fps, lowpass_hz, max_lost_fraction, max_gap_s
        )
        blocks.append(disp[:, usable])
        names.extend((tr.sensor, int(i)) for i in np.flatnonzero(usable))
    motion = np.concatenate(blocks, axis=1)
    if motion.shape[1] < MIN_SELECTED:
        raise MarkerError(
            f"only {motion.shape[1]} markers were tracked well enough (lost in at most "
            f"{max_lost_fraction:.0%} of frames); at least {MIN_SELECTED} are needed"
        )
    observed &= np.isfinite(motion).all(axis=(1, 2))  # the low-pass's pieces too short to filter
    if observed.sum() < 2:
        raise SignalError(
            "almost no sample of the recording is observed: its stretches between long "
            "gaps are too short to filter; record without stalls"
        )
    motion = motion[observed]
    score = np.sqrt(motion.var(axis=0).sum(axis=1))
    chosen = np.argsort(-score, kind="stable")[:n_markers]
    chosen_motion = motion[:, chosen]
    u, weights, explained = first_component(chosen_motion.reshape(len(motion), -1))
    return TactileSignal(
        t=t_uniform[observed],
        u=u,
        explained_variance=explained,
        markers=[names[i] for i in chosen],
        weights=weights.reshape(-1, 2),
        fps=fps,
        motion=chosen_motion,
        lowpass_hz=lowpass_hz,
        gap_share=float(1.0 - observed.sum() / n_clock),
    )


def _on_the_lattice(tracks: MarkerTracks) -> MarkerTracks:
    """``tracks`` timed as the signal reads them (:func:`~liquidtouch.tracking.clock.frame_times`:
    stamps taken on delivery moved onto the camera's lattice), on the same shared clock."""
    t = frame_times(tracks.t)
    if t is tracks.t:
        return tracks
    return replace(tracks, t=t, start_s=float(tracks.start_s) + float(t[0] - tracks.t[0]))


def check_signal_options(
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = DEFAULT_N_MARKERS,
    max_lost_fraction: float = 0.05,
    max_gap_s: float = 0.25,
) -> None:
    """Check the knobs of :func:`tactile_signal` (before any tracking work); SignalError."""
    if isinstance(n_markers, bool) or not isinstance(n_markers, int | np.integer) or n_markers < 1:
        raise SignalError(
            f"n_markers must be a whole number >= 1 (markers to keep), got {n_markers!r}"
        )
    if lowpass_hz is not None and not 0 < as_number(lowpass_hz) < math.inf:
        raise SignalError(
            f"lowpass_hz must be a cut-off frequency > 0 in Hz, or None for no filter; "
            f"got {lowpass_hz!r}"
        )
    _check_gap_limits(max_lost_fraction, max_gap_s)


def _check_gap_limits(max_lost_fraction: float, max_gap_s: float) -> None:
    if not 0 <= as_number(max_lost_fraction) <= 1:
        raise SignalError(
            f"max_lost_fraction must be a fraction of the frames in [0, 1], "
            f"got {max_lost_fraction!r}"
        )
    if not as_number(max_gap_s) >= 0:
        raise SignalError(f"max_gap_s must be a duration >= 0 in seconds, got {max_gap_s!r}")


def _check_tracks(tracks: Sequence[MarkerTracks]) -> list[MarkerTracks]:
    """``tracks`` as a list of consistent :class:`MarkerTracks` with distinct sensor names."""
    if isinstance(tracks, MarkerTracks):
        raise MarkerError("tracks must be a list of MarkerTracks, one per sensor: pass [tracks]")
    try:
        tracks = list(tracks)
    except TypeError:
        raise MarkerError(f"tracks must be a list of MarkerTracks, got {tracks!r}") from None
    if not tracks:
        raise MarkerError("no marker tracks given; track at least one sensor video first")
    names = [getattr(tr, "sensor", None) for tr in tracks]
    for tr in tracks:
        if not isinstance(tr, MarkerTracks):
            raise MarkerError(
                f"expected MarkerTracks (from track_markers or load_tracks), "
                f"got {type(tr).__name__}"
            )
        t_shape, shapes = np.shape(tr.t), (np.shape(tr.positions), np.shape(tr.valid))
        n_frames = t_shape[0] if len(t_shape) == 1 else -1
        n = np.shape(tr.reference)[0] if np.ndim(tr.reference) == 2 else -1
        shapes += (np.shape(tr.reference),)
        if min(n_frames, n) < 0 or shapes != ((n_frames, n, 2), (n_frames, n), (n, 2)):
            raise MarkerError(
                f"{tr.sensor}: inconsistent tracks: t {np.shape(tr.t)}, positions {shapes[0]}, "
                f"valid {shapes[1]}, reference {shapes[2]}; expected (T,), (T, N, 2), (T, N), "
                "(N, 2)"
            )
        check_times(tr.t, f"{tr.sensor}: frame timestamps")
        if not math.isfinite(as_number(getattr(tr, "start_s", 0.0))):
            raise MarkerError(f"{tr.sensor}: start_s must be a finite time [s], got {tr.start_s!r}")
        if names.count(tr.sensor) > 1:
            raise MarkerError(
                f"two tracks are both named {tr.sensor!r}; give each sensor its own name"
            )
    return tracks
