"""From marker tracks to the 1-D tactile signal ``u(t)``: resample, low-pass, select, PCA.

1. **Clock**: all sensors are resampled (linear interpolation) onto one
   uniform clock at the median frame interval of the first sensor, starting at
   0 and ending at the earliest last frame. Real sensors jitter and drop frames.
2. **Gaps**: a marker lost in more than ``max_lost_fraction`` of the frames, or
   for longer than ``max_gap_s`` at a stretch, is not used; shorter gaps are
   interpolated. Markers cut by the image border in the first frame are not
   used either (their centroid sees only part of the blob).
3. **Low-pass**: zero-phase Butterworth (``sosfiltfilt``), 3 Hz by default.
4. **Selection**: the ``n_markers`` markers (across all sensors) with the
   largest motion, ``sqrt(var x + var y)`` of the filtered displacement.
5. **PCA**: their x, y displacements form a ``2·n``-D vector per frame; the
   first principal component (of the time-centred data) gives ``u(t)`` [px].

**Sign convention**: the component's weight with the largest magnitude is
positive (as scikit-learn's ``svd_flip``), so the same motion always gives the
same sign of ``u``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from liquidtouch.errors import MarkerError, SignalError
from liquidtouch.tracking.tracks import MarkerTracks

MIN_SELECTED = 2


@dataclass
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
    """

    t: np.ndarray
    u: np.ndarray
    explained_variance: float
    markers: list[tuple[str, int]]
    weights: np.ndarray
    fps: float
    motion: np.ndarray
    lowpass_hz: float | None = 3.0

    @property
    def n_markers(self) -> int:
        return len(self.markers)


def uniform_clock(t: np.ndarray, end_s: float | None = None) -> tuple[np.ndarray, float]:
    """A uniform clock from 0 at the median interval of timestamps ``t`` [s]: (times, fps)."""
    t = np.asarray(t, dtype=float)
    if t.size < 2 or not np.all(np.diff(t) > 0):
        raise SignalError("frame timestamps must be increasing with at least 2 frames")
    step = float(np.median(np.diff(t)))
    end = float(t[-1] if end_s is None else end_s) - float(t[0])
    n = int(np.floor(end / step + 1e-6)) + 1
    return np.arange(n) * step, 1.0 / step


def resample_displacement(
    tracks: MarkerTracks,
    t_uniform: np.ndarray,
    max_lost_fraction: float = 0.05,
    max_gap_s: float = 0.25,
) -> tuple[np.ndarray, np.ndarray]:
    """Displacement (T, N, 2) [px] on ``t_uniform`` and which markers are usable (N,).

    Unusable markers (too often or too long lost, cut by the border) get zeros.
    """
    t = tracks.t - tracks.t[0]
    valid = tracks.valid
    disp = tracks.displacement
    n = tracks.n_markers
    usable = valid.mean(axis=0) >= 1.0 - max_lost_fraction
    usable &= _longest_gap_s(t, valid) <= max_gap_s
    usable &= ~_cut_by_border(tracks)
    out = np.zeros((t_uniform.size, n, 2))
    for i in np.flatnonzero(usable):
        ok = valid[:, i]
        for axis in range(2):
            out[:, i, axis] = np.interp(t_uniform, t[ok], disp[ok, i, axis])
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


def lowpass(x: np.ndarray, fps: float, cutoff_hz: float = 3.0, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` along axis 0 (``sosfiltfilt``)."""
    from scipy.signal import butter, sosfiltfilt

    nyquist = 0.5 * fps
    if not 0 < cutoff_hz < nyquist:
        raise SignalError(
            f"low-pass cut-off {cutoff_hz} Hz must lie between 0 and the Nyquist "
            f"frequency {nyquist:.3g} Hz of a {fps:.3g} fps recording"
        )
    sos = butter(order, cutoff_hz, fs=fps, output="sos")
    padlen = 3 * (2 * len(sos) + 1)
    if x.shape[0] <= padlen:
        raise SignalError(
            f"only {x.shape[0]} frames; at least {padlen + 1} are needed to filter the motion"
        )
    return sosfiltfilt(sos, x, axis=0)


def first_component(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """PCA of (T, D) data: (scores (T,), weights (D,), explained variance fraction)."""
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
    lowpass_hz: float | None = 3.0,
    n_markers: int = 16,
    max_lost_fraction: float = 0.05,
    max_gap_s: float = 0.25,
) -> TactileSignal:
    """The tactile signal ``u(t)`` from the tracks of one or more sensors (module docstring)."""
    if not tracks:
        raise MarkerError("no marker tracks given")
    t_uniform, fps = uniform_clock(tracks[0].t, end_s=min(tr.t[-1] - tr.t[0] for tr in tracks))
    blocks, names = [], []
    for tr in tracks:
        disp, usable = resample_displacement(tr, t_uniform, max_lost_fraction, max_gap_s)
        blocks.append(disp[:, usable])
        names.extend((tr.sensor, int(i)) for i in np.flatnonzero(usable))
    motion = np.concatenate(blocks, axis=1)
    if motion.shape[1] < MIN_SELECTED:
        raise MarkerError(
            f"only {motion.shape[1]} markers were tracked well enough (lost in at most "
            f"{max_lost_fraction:.0%} of frames); at least {MIN_SELECTED} are needed"
        )
    if lowpass_hz is not None:
        motion = lowpass(motion, fps, lowpass_hz)
    score = np.sqrt(motion.var(axis=0).sum(axis=1))
    chosen = np.argsort(-score, kind="stable")[:n_markers]
    chosen_motion = motion[:, chosen]
    u, weights, explained = first_component(chosen_motion.reshape(len(t_uniform), -1))
    return TactileSignal(
        t=t_uniform,
        u=u,
        explained_variance=explained,
        markers=[names[i] for i in chosen],
        weights=weights.reshape(-1, 2),
        fps=fps,
        motion=chosen_motion,
        lowpass_hz=lowpass_hz,
    )
