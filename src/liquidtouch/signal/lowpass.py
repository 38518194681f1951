"""The zero-phase low-pass of the marker motion, and how it runs across gaps.

:func:`lowpass` is a Butterworth low-pass run forwards and backwards (``sosfiltfilt``), at
:data:`DEFAULT_LOWPASS_HZ` unless asked otherwise, for signals sampled without gaps.

Frames that never came are not invented: :func:`lowpass_frames` is the same low-pass for
marker motion read at the frames that did come, at their own times. It is a penalised
least-squares (Whittaker-Henderson) smoother: the values ``x`` on a uniform clock that
minimise ``sum_j (y_j - (B x)_j)^2 + lam * |D^5 x|^2``, where ``B`` reads the clock's values
at each frame's time (linear between the two samples around it) and ``D^5`` takes fifth
differences. On a uniformly sampled signal its response is
``1 / (1 + lam (2 sin(pi f / fps))^10)``, and ``lam`` puts its half-power point at the
cut-off, like the 4th-order Butterworth run forwards and backwards
(:data:`SMOOTHER_ORDER` says how alike). Where frames are missing the data term simply has no
rows: the smoother bridges a dropped frame or three (at 15-18 fps, up to a quarter of a
slosh period) from the frames on both sides, without the straight line or spline that an
interpolate-then-filter chain would first have put there (and then filtered as if it had
been measured). A stretch without frames longer than :func:`max_bridged_gap_s` is a gap:
the smoother's values in it are not observed (:func:`observed_samples`) and are left out.
The whole recording is smoothed at once: cutting it into stretches at its gaps, each
smoothed on its own, lost the short stretches between gaps and bent the ends of the
others (15-18 fps streams: 65 % of runs within 5 % of the gap-free λ, against 80 % at
once; ``benchmarks/signal/gaps.py``). Only a stall longer than :data:`SPLIT_SAMPLES` samples of
the smoother's clock (2 s at 30 fps) splits the frames into pieces smoothed on their own.

**Numerics.** Across a stretch without frames only the penalty holds the smoother's
values, and the banded Cholesky of its normal equations failed (``LinAlgError``) on a
10 s stall at 30 fps, or silently returned garbage at 1000 fps (``lam`` ~ 1e16) and failed
at a 0.1 Hz cut-off: the smoother therefore runs on at most :data:`MAX_SMOOTHER_RATIO`
samples per cut-off period (a faster clock on every r-th sample,
:func:`smoother_step`, read back by a cubic spline), and stalls split it (above).
Eilers (2003), "A perfect smoother", Analytical Chemistry
75, 3631, is the method with zero weights for missing data. :mod:`liquidtouch.signal.tactile`
builds ``u(t)`` with it.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from liquidtouch._core.checks import as_number, check_times, finite_array
from liquidtouch.errors import SignalError

__all__ = [
    "DEFAULT_LOWPASS_HZ",
    "GAP_PERIODS",
    "MAX_SMOOTHER_RATIO",
    "SLOSH_MAX_HZ",
    "SPLIT_SAMPLES",
    "lowpass",
    "lowpass_frames",
    "max_bridged_gap_s",
    "observed_samples",
    "smoother_step",
]

#: the low-pass cut-off [Hz] unless one is asked for, by the API and the command line alike.
#: Not 3 Hz: a broad slosh line (detergent: ω ≈ 14.5 rad/s, λ 3-6 1/s) reaches into a 3 Hz
#: roll-off, and the filter's response at the release biased a one-mode fit's λ 5-9 % low
#: (noise-free) and the default fit's 5-15 % low (0.02 px marker noise); at 4 Hz both are
#: within 2 % up to λ 4.5/s. Higher is not better: 5 Hz let in more noise, and the push
#: spread through video grew (1.7 % at 4 Hz, 4.8 % at 5 Hz, 3.1 % at 3 Hz). Measured by
#: ``benchmarks/signal/lowpass_bias.py`` and ``benchmarks/extraction/push_invariance.py``
#: (benchmarks/RESULTS.md, "lowpass_bias").
DEFAULT_LOWPASS_HZ = 4.0
#: the fastest slosh the signal is for [Hz]: the catalogue's containers slosh at 1.9-2.6 Hz
#: (``_core.containers``); the stretches bridged across dropped frames keep it (Nyquist)
SLOSH_MAX_HZ = 3.0
#: without a low-pass, a stretch without frames longer than this many frame periods is a gap
GAP_PERIODS = 2.0
#: order of the differences the smoother penalises. 5: with its half-power point at the
#: cut-off (4 Hz, 25 fps) it passes 98.8 % at 2.5 Hz, 93.6 % at 3 Hz and 2.9 % at 6 Hz,
#: close to the 4th-order Butterworth run forwards and backwards that it replaced (98.5,
#: 93.3, 1.4 %), so a recording without gaps gives much the same signal, and it reads three
#: dropped frames of a ring-down 0.3 % of its amplitude off. Order 4 passed 89.6 % at
#: 3 Hz and was 1.4 % off there; order 6 (0.02 %) is sharper than the Butterworth and
#: moved detergent-like fits at the release more (``benchmarks/signal/lowpass_bias.py``). lam grows
#: as (fps / f_c)^10: at 4 Hz and 200 fps the smoother still matches the Butterworth's
#: error on a noisy ring-down.
SMOOTHER_ORDER = 5
#: most samples of the smoother's clock per period of the cut-off: the smoother's system
#: (weight ``lam = (2 sin(pi f_c / fps))^-10``, largest eigenvalue ~ 4^5 lam against ~1 for
#: the data) is then at most ~1e9 times from singular: at 25 its solution was within 2e-8
#: of a QR solve of the same least squares, at 50 (4 Hz at 200 fps) 4e-5, at 100 1.4 %, at
#: 250 (1000 fps) 97 % off, and at 300 (a 0.1 Hz cut-off at 30 fps) the banded Cholesky
#: failed. A faster clock is smoothed on every r-th sample and read off by a cubic spline:
#: on a ring-down at 2.2 Hz sampled at 200 fps that reads within 0.15 % of the ideal
#: low-pass (the fine clock 0.03 %, 30 fps 0.7 %).
MAX_SMOOTHER_RATIO = 25.0
#: a stretch without frames longer than this many samples of the smoother's clock splits the
#: frames into pieces smoothed on their own. In a stretch without frames only the penalty
#: holds the smoother's values, and its conditioning falls as the stretch's length in samples
#: to the 10th power: at 60 samples the values on either side were within 1e-6 (15 samples
#: per cut-off period) to 2e-5 (31) of a QR solve, of a unit signal; at 120 within 4e-5 (15)
#: to 1e-3 (31), and at 300 (10 s at 30 fps) the Cholesky failed. 64 samples: 2.1 s at
#: 30 fps, longer than the stalls of ``benchmarks/signal/gaps.py`` (up to 1 s), which stay
#: smoothed at once.
SPLIT_SAMPLES = 64


def max_bridged_gap_s(lowpass_hz: float | None, fps: float) -> float:
    """Longest stretch without frames [s] that is bridged rather than left out.

    Half the period of the low-pass cut-off, ``1 / (2 f_c)``, with ``f_c`` at most
    :data:`SLOSH_MAX_HZ`: the filtered slosh holds nothing faster, so samples that far
    apart still catch it (Nyquist); a longer stretch lost motion that no smoother
    can recover. A cut-off above the slosh (the default) passes the tail of a broad line
    and noise there, which the bridge need not keep, so it does not shorten the
    stretches bridged (0.17 s). At least :data:`GAP_PERIODS`
    frame periods; that alone without a low-pass.
    """
    least = GAP_PERIODS / fps
    if lowpass_hz is None:
        return least
    return max(least, 0.5 / min(float(lowpass_hz), SLOSH_MAX_HZ))


def observed_samples(t_frames: np.ndarray, t_clock: np.ndarray, max_gap_s: float) -> np.ndarray:
    """Which clock times ``t_clock`` [s] are observed: not inside a stretch without frames
    longer than ``max_gap_s`` [s], and not beyond the frames at either end.

    ``t_frames`` [s], on the same clock, increasing. The ends are where two frames in
    a row last came one frame period apart (half a period of slack): a dropped frame or
    three at the very end leave a lone frame that the smoother of
    :func:`lowpass_frames` cannot bridge to, since nothing lies beyond it (a ring-down's
    last 0.16 s read up to 5x the push's amplitude).
    """
    gaps = np.diff(t_frames)
    k = np.clip(np.searchsorted(t_frames, t_clock, side="right"), 1, t_frames.size - 1)
    inside = (t_clock > t_frames[k - 1]) & (t_clock < t_frames[k])
    observed = ~(inside & (gaps[k - 1] > max_gap_s))
    if gaps.size:
        period = float(np.median(gaps))
        regular = np.flatnonzero(gaps < 1.5 * period)
        first, last = (
            (t_frames[0], t_frames[-1])
            if regular.size == 0
            else (t_frames[regular[0]], t_frames[regular[-1] + 1])
        )
        observed &= (t_clock >= first - 0.5 * period) & (t_clock <= last + 0.5 * period)
    return observed


def _difference_gram(n: int, order: int) -> np.ndarray:
    """``D^T D`` of the (n - order, n) ``order``-th difference matrix, upper banded form."""
    coef = np.array([math.comb(order, k) * (-1.0) ** (order - k) for k in range(order + 1)])
    rows = n - order
    banded = np.zeros((order + 1, n))
    for k in range(order + 1):
        diagonal = banded[order - k, k:]  # (D^T D)[i, i + k] = sum_m coef[m] coef[m + k]
        for m in range(order + 1 - k):
            diagonal[m : min(m + rows, n - k)] += coef[m] * coef[m + k]
    return banded


def smoother_step(fps: float, cutoff_hz: float) -> int:
    """Clock samples per sample of the smoother's own clock: 1, or the fewest that keep it
    at most :data:`MAX_SMOOTHER_RATIO` samples per period of the cut-off ``cutoff_hz`` [Hz]
    at ``fps`` [Hz] (module docstring, "Numerics")."""
    return max(1, math.ceil(fps / (MAX_SMOOTHER_RATIO * cutoff_hz) - 1e-9))


def lowpass_frames(
    t_frames: np.ndarray,
    y: np.ndarray,
    t_clock: np.ndarray,
    fps: float,
    cutoff_hz: float = DEFAULT_LOWPASS_HZ,
) -> np.ndarray:
    """The low-pass (module docstring) of frames ``y`` (F, ...) taken at ``t_frames`` [s],
    on the clock ``t_clock`` [s] of rate ``fps`` [Hz]: (T, ...).

    ``t_clock`` lies on the uniform lattice ``t_clock[0] + j / fps`` (it may skip
    samples: whole steps). Frames outside its span are not used. A stretch without frames
    longer than :data:`SPLIT_SAMPLES` samples of the smoother's clock splits the frames
    into pieces smoothed on their own; the clock's samples inside such a stretch, and
    those of a piece of at most :data:`SMOOTHER_ORDER` frames, are NaN (no estimate).
    At least :data:`SMOOTHER_ORDER` + 1 frames must lie inside the clock's span.
    """
    from scipy.interpolate import CubicSpline  # why: SciPy loads on first use (start-up time)

    t_frames = check_times(t_frames, "the frame times", min_count=1)
    t_clock = check_times(t_clock, "the clock", min_count=1)
    if not 0 < as_number(fps) < math.inf:
        raise SignalError(f"fps must be a frame rate > 0 in Hz, got {fps!r}")
    if not 0 < as_number(cutoff_hz) < 0.5 * fps:
        raise SignalError(
            f"low-pass cut-off {cutoff_hz} Hz must lie between 0 and the Nyquist "
            f"frequency {0.5 * fps:.3g} Hz of a {fps:.3g} fps recording"
        )
    values = np.asarray(y, dtype=float)
    if values.shape[:1] != t_frames.shape:
        raise SignalError(f"{t_frames.size} frame times but {values.shape[:1]} frames of motion")
    slack = 1e-6 / fps  # a frame on the clock's first or last sample is inside, to rounding
    inside = (t_frames >= t_clock[0] - slack) & (t_frames <= t_clock[-1] + slack)
    if np.count_nonzero(inside) <= SMOOTHER_ORDER:
        raise SignalError(
            f"only {np.count_nonzero(inside)} frames; at least {SMOOTHER_ORDER + 1} are "
            "needed to filter the motion"
        )
    values = values[inside].reshape(np.count_nonzero(inside), -1)
    wanted = np.rint((t_clock - t_clock[0]) * fps).astype(np.int64)  # lattice samples
    ratio = smoother_step(fps, cutoff_hz)
    # each frame's place on the smoother's clock, in its samples from the clock's start
    position = (t_frames[inside] - t_clock[0]) * (fps / ratio)
    lam = (2.0 * math.sin(math.pi * cutoff_hz * ratio / fps)) ** (-2 * SMOOTHER_ORDER)
    cuts = np.flatnonzero(np.diff(position) > SPLIT_SAMPLES) + 1
    edges = np.concatenate([[0], cuts, [position.size]])
    out = np.full((wanted.size, values.shape[1]), np.nan)
    last_sample = float(wanted[-1]) / ratio
    for p, (lo, hi) in enumerate(itertools.pairwise(edges)):
        # the piece's samples: from its first frame to its last (the outer pieces to the
        # clock's ends), at least SMOOTHER_ORDER + 1 of them
        begin = 0.0 if p == 0 else position[lo]
        end = last_sample if hi == position.size else position[hi - 1]
        first = math.floor(begin)
        n = max(math.ceil(end) - first, SMOOTHER_ORDER) + 1
        if hi - lo <= SMOOTHER_ORDER:
            continue  # too few frames to smooth: no estimate here
        smooth = _smooth(position[lo:hi] - first, values[lo:hi], n, lam)
        # the clock's samples within the piece, read off the smoother's clock
        local = wanted / ratio - first
        here = (local >= begin - first) & (local <= end - first)
        if ratio == 1:
            out[here] = smooth[np.rint(local[here]).astype(np.int64)]
        else:
            out[here] = CubicSpline(np.arange(n), smooth, axis=0)(local[here])
    return out.reshape((wanted.size, *np.shape(y)[1:]))


def _smooth(position: np.ndarray, values: np.ndarray, n: int, lam: float) -> np.ndarray:
    """The smoother's values (n, C) on its clock 0 .. n - 1 of frames ``values`` (F, C) at
    ``position`` (F,) [samples, in 0 .. n - 1], with penalty weight ``lam``."""
    from scipy.linalg import solveh_banded  # why: SciPy loads on first use (start-up time)

    k = np.clip(np.floor(position).astype(np.int64), 0, n - 2)
    a = np.clip(position - k, 0.0, 1.0)  # a share `a` of the way from sample k to k + 1
    gram = _difference_gram(n, SMOOTHER_ORDER) * lam
    gram[-1] += np.bincount(k, (1 - a) ** 2, n) + np.bincount(k + 1, a**2, n)
    gram[-2, 1:] += np.bincount(k, a * (1 - a), n)[:-1]
    rhs = np.zeros((n, values.shape[1]))
    rows, first = np.unique(k, return_index=True)  # k never decreases: frames in order
    rhs[rows] += np.add.reduceat((1 - a)[:, None] * values, first, axis=0)
    rhs[rows + 1] += np.add.reduceat(a[:, None] * values, first, axis=0)
    return solveh_banded(gram, rhs, check_finite=False)


def lowpass(
    x: np.ndarray, fps: float, cutoff_hz: float = DEFAULT_LOWPASS_HZ, order: int = 4
) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``x`` along axis 0 (``sosfiltfilt``)."""
    from scipy.signal import butter, sosfiltfilt

    x = finite_array(x, "the motion to low-pass", min_ndim=1)
    if not 0 < as_number(fps) < math.inf:
        raise SignalError(f"fps must be a frame rate > 0 in Hz, got {fps!r}")
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 1:
        raise SignalError(f"the filter order must be a whole number >= 1, got {order!r}")
    nyquist = 0.5 * fps
    if not 0 < cutoff_hz < nyquist:
        raise SignalError(
            f"low-pass cut-off {cutoff_hz} Hz must lie between 0 and the Nyquist "
            f"frequency {nyquist:.3g} Hz of a {fps:.3g} fps recording"
        )
    sos = butter(order, cutoff_hz, fs=fps, output="sos")
    padlen = 3 * (2 * len(sos) + 1)  # what sosfiltfilt pads with
    if x.shape[0] <= padlen:
        raise SignalError(
            f"only {x.shape[0]} frames; at least {padlen + 1} are needed to filter the motion"
        )
    return sosfiltfilt(sos, x, axis=0)
