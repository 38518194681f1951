"""From marker tracks to the 1-D tactile signal ``u(t)``: resample, low-pass, select, PCA.

1. **Clock**: all sensors are resampled (linear interpolation; a cubic spline across
   dropped frames, :func:`interpolate_frames`) onto one
   uniform clock over the time they all recorded. Each sensor's frame ``k`` is at
   ``start_s + t[k] - t[0]`` on the trial's shared clock
   (:attr:`MarkerTracks.start_s`, from the recorder's ``sensor_start_s``; 0 for
   videos given on their own, which are then aligned on their first frames). The
   clock starts at the first frame of the sensor that started last and steps at
   that sensor's frame period fitted to all its timestamps
   (:func:`~liquidtouch.clock.frame_period`, :mod:`liquidtouch.clock` says why).
2. **Gaps**: a marker lost in more than ``max_lost_fraction`` of the frames, or
   for longer than ``max_gap_s`` at a stretch, is not used; shorter gaps are
   interpolated. Markers cut by the image border in the first frame are not
   used either (their centroid sees only part of the blob). **Frames that never
   came** (a camera stall, dropped frames) are not invented: a clock sample
   inside a stretch without frames longer than half the period of the low-pass
   cut-off, at most 3 Hz (:func:`~liquidtouch.lowpass_filter.max_bridged_gap_s`: the
   low-passed slosh is then sampled below its Nyquist rate; 0.17 s) is *not observed*; shorter
   stretches (a dropped frame or a few) are interpolated.
3. **Low-pass**: zero-phase Butterworth (``sosfiltfilt``, :mod:`liquidtouch.lowpass_filter`),
   :data:`~liquidtouch.lowpass_filter.DEFAULT_LOWPASS_HZ`
   (4 Hz) by default, run on each contiguous stretch of observed samples on its own
   (a stretch too short to filter is dropped too), so no filter output mixes in a gap; an end of a
   stretch at a gap is continued by linear prediction for the filter's settling
   (:func:`~liquidtouch.linear_prediction.predict_edges`), and the continuation dropped.
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
from dataclasses import dataclass

import numpy as np

from liquidtouch._core.checks import as_number
from liquidtouch._core.numbers import fixed, number
from liquidtouch.clock import check_times, finite_array, uniform_clock
from liquidtouch.errors import MarkerError, SignalError
from liquidtouch.lowpass_filter import (
    DEFAULT_LOWPASS_HZ,
    lowpass_observed,
    max_bridged_gap_s,
    observed_samples,
)
from liquidtouch.tracking.tracks import MarkerTracks

__all__ = [
    "TactileSignal",
    "check_signal_options",
    "first_component",
    "resample_displacement",
    "tactile_signal",
]

#: fewest usable markers (over all sensors) a signal is built from
MIN_SELECTED = 2


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


def resample_displacement(
    tracks: MarkerTracks,
    t_uniform: np.ndarray,
    max_lost_fraction: float = 0.05,
    max_gap_s: float = 0.25,
    bridged_s: float = math.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """Displacement (T, N, 2) [px] on ``t_uniform`` and which markers are usable (N,).

    ``t_uniform`` [s] is on the sensor's own clock from its first frame
    (``tracks.t - tracks.t[0]``). Unusable markers (too often or too long lost,
    cut by the border) get zeros. Across dropped frames the motion is a cubic
    spline through the frames around them (:func:`interpolate_frames`; no spline
    spans a step over ``bridged_s`` [s]).
    """
    _check_gap_limits(max_lost_fraction, max_gap_s)
    t = tracks.t - tracks.t[0]
    valid = tracks.valid
    disp = tracks.displacement
    n = tracks.n_markers
    usable = valid.mean(axis=0) >= 1.0 - max_lost_fraction
    usable &= _longest_gap_s(t, valid) <= max_gap_s
    usable &= ~_cut_by_border(tracks)
    out = np.zeros((t_uniform.size, n, 2))
    whole = usable & valid.all(axis=0)  # one spline for all of them
    if whole.any():
        out[:, whole] = interpolate_frames(t, disp[:, whole], t_uniform, bridged_s)
    for i in np.flatnonzero(usable & ~whole):
        ok = valid[:, i]
        out[:, i] = interpolate_frames(t[ok], disp[ok, i], t_uniform, bridged_s)
    return out, usable


def interpolate_frames(
    t_frames: np.ndarray, values: np.ndarray, t_out: np.ndarray, bridged_s: float = math.inf
) -> np.ndarray:
    """``values`` (F, ...) at frame times ``t_frames`` [s] read at times ``t_out`` [s].

    Linear between consecutive frames (held constant outside them); across dropped
    frames (a step of two frame periods or more, as :func:`~liquidtouch.clock.frame_period`
    counts them) a cubic spline (not-a-knot) through the run of at least 4 frames
    without a step over ``bridged_s`` [s] around them. Cubic there: at 15-18 fps a
    dropped frame or three leave ~0.1-0.16 s between frames, a quarter of a 2 Hz
    slosh period, and a straight line across it cuts a peak by up to half the
    amplitude (the spline: a few per cent); the low-pass does not undo that, and λ
    moved by 5-15 %. Linear elsewhere, so a recording without drops gives the same
    signal as before (the model choice is sensitive to small changes of u).
    """
    from scipy.interpolate import CubicSpline

    flat = values.reshape(len(t_frames), -1)
    out = np.column_stack([np.interp(t_out, t_frames, c) for c in flat.T])
    if t_frames.size < 4:
        return out.reshape((t_out.size, *values.shape[1:]))
    steps = np.diff(t_frames)
    dropped = np.flatnonzero(np.rint(steps / np.median(steps)) > 1)
    breaks = np.flatnonzero(steps > bridged_s) + 1
    k = np.searchsorted(t_frames, t_out, side="right") - 1  # the step each time is in
    for run in np.split(np.arange(t_frames.size), breaks):
        inside_run = dropped[(dropped >= run[0]) & (dropped < run[-1])]
        if run.size < 4 or inside_run.size == 0:
            continue
        across = np.isin(k, inside_run) & (t_out < t_frames[-1])
        if across.any():
            spline = CubicSpline(t_frames[run], flat[run], axis=0)
            out[across] = spline(t_out[across])
    return out.reshape((t_out.size, *values.shape[1:]))


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
    n_markers: int = 16,
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
    tracks = _check_tracks(tracks)
    check_signal_options(lowpass_hz, n_markers, max_lost_fraction, max_gap_s)
    reference, begin_s, end_s = common_span(tracks)
    t_ref = tracks[reference].t
    t_uniform, fps = uniform_clock(t_ref, end_s=float(t_ref[0]) + (end_s - begin_s))
    bridged_s = max_bridged_gap_s(lowpass_hz, fps)
    observed = np.ones(t_uniform.size, bool)
    blocks, names = [], []
    for tr in tracks:
        local = t_uniform + (begin_s - float(tr.start_s))  # on this sensor's own clock
        disp, usable = resample_displacement(tr, local, max_lost_fraction, max_gap_s, bridged_s)
        observed &= observed_samples(tr.t - tr.t[0], local, bridged_s)
        blocks.append(disp[:, usable])
        names.extend((tr.sensor, int(i)) for i in np.flatnonzero(usable))
    motion = np.concatenate(blocks, axis=1)
    if motion.shape[1] < MIN_SELECTED:
        raise MarkerError(
            f"only {motion.shape[1]} markers were tracked well enough (lost in at most "
            f"{max_lost_fraction:.0%} of frames); at least {MIN_SELECTED} are needed"
        )
    if lowpass_hz is not None:
        motion, observed = lowpass_observed(motion, observed, fps, lowpass_hz)
    if observed.sum() < 2:
        raise SignalError(
            "no stretch of the recording is long enough to filter: the frames come with "
            f"gaps over {bridged_s:.2g} s; check the camera's frame rate"
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
        gap_share=float(1.0 - observed.mean()),
    )


def check_signal_options(
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = 16,
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
