"""Whether a stretch of the tactile signal is a free decay (a ring-down).

:func:`ring_down_reason` judges a candidate stretch by a quick single-mode fit: an
oscillation in the slosh band that decays and whose envelope follows the fit, not a
transient, a lowering, the low-pass's ringing after a release or the noise of a still
gel. :mod:`liquidtouch.ring_down.segments` uses it to find the trial's ring-downs.
"""

from __future__ import annotations

import math

import numpy as np

from liquidtouch.errors import LiquidTouchError, NoOscillationError
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.signal.lowpass import SLOSH_MAX_HZ

__all__ = [
    "ENVELOPE_FLOOR",
    "ENVELOPE_RATIO",
    "LOBE_FRACTION",
    "MAX_LATE_GROWTH",
    "MIN_CANDIDATE_S",
    "MIN_FIT_R2",
    "MIN_LOBES",
    "MIN_OMEGA_OVER_LAMBDA",
    "ring_down_reason",
]

#: a ring-down oscillates: its fitted ω is at least this many times λ (the catalogue's most
#: damped liquid, detergent, has ω/λ ≈ 4; the lowering and release taken for a push fitted
#: λ 6.8, ω 14: ω/λ ≈ 2)
MIN_OMEGA_OVER_LAMBDA = 3.0
#: ... and shows at least this many half-cycles above LOBE_FRACTION of its largest one
MIN_LOBES = 3
LOBE_FRACTION = 0.05
#: least candidate judged [s]: shorter, it is not (yet) a ring-down
MIN_CANDIDATE_S = 0.5
#: a free decay's envelope follows its fit: over each period where either stands above
#: ENVELOPE_FLOOR of the largest, the signal's RMS (less the fit's drift) is within this
#: factor of the fitted oscillation's (a lowering or release that stops the slosh: the
#: signal drops to the noise where the fit still rings — ratio ≤ 0.2 on slosh stopped
#: after 1.5-2 s of a 3 s window; a two-mode beat or amplitude-dependent damping stays
#: within 3)
ENVELOPE_RATIO = 3.0
ENVELOPE_FLOOR = 0.1
#: ... explains at least this fraction of the signal's variance (less its drift): a ring-down
#: on simulated protocols ≥ 0.99, the slosh's end at the lowering and release 0.8
MIN_FIT_R2 = 0.9
#: ... and decays: the second half of the window holds at most this many times the RMS of the
#: first (a free decay's is smaller; the margin is for a two-mode beat)
MAX_LATE_GROWTH = 1.5


def ring_down_reason(t: np.ndarray, u: np.ndarray) -> tuple[str, object | None]:
    """Whether ``(t, u)`` is a free decay: ``("", fit)``, else ``(why not, fit or None)``.

    A ring-down is a decaying oscillation in the slosh band: the single-mode fit (least
    squares, as a quick check) finds an oscillation above the noise that is not
    overdamped (``fit_oscillation``'s own check), with ω ≥ ``MIN_OMEGA_OVER_LAMBDA`` λ
    and ω/2π ≤ :data:`~liquidtouch.signal.lowpass.SLOSH_MAX_HZ` (faster is the low-pass's own
    ringing after a step), and at least ``MIN_LOBES`` half-cycles (between zero
    crossings of the detrended signal) reach ``LOBE_FRACTION`` of the largest; the
    window spans ``MIN_LOBES`` half-cycles of the fitted ω; the fit explains
    ``MIN_FIT_R2`` of the signal, the signal decays (``MAX_LATE_GROWTH``) and its
    envelope follows the fit's period by period (``ENVELOPE_RATIO``). A stretch that
    passes is a free decay, not a transient, a lowering or the noise of a still gel.
    """
    if len(t) < 8 or t[-1] - t[0] < MIN_CANDIDATE_S:
        return "too short to judge", None
    try:
        fit = fit_oscillation(
            t, u, model="single-mode", loss="ls", noise="white", min_duration_s=MIN_CANDIDATE_S
        )
    except NoOscillationError as exc:
        return str(exc), None
    except LiquidTouchError as exc:
        return str(exc), None
    if fit.angular_frequency < MIN_OMEGA_OVER_LAMBDA * fit.decay_rate:
        return (
            f"not a free decay: λ {fit.decay_rate:.3g}/s, ω {fit.angular_frequency:.3g} rad/s "
            f"(a ring-down has ω ≥ {MIN_OMEGA_OVER_LAMBDA:g} λ)"
        ), fit
    if fit.angular_frequency > 2 * math.pi * SLOSH_MAX_HZ:
        # the low-pass's own ringing after a step (a release) decays at its cut-off
        return (
            f"not a free decay: ω {fit.angular_frequency:.3g} rad/s is above the slosh band "
            f"(≤ {SLOSH_MAX_HZ:g} Hz)"
        ), fit
    x = (t - t[0]) / max(t[-1] - t[0], 1e-12)
    design = np.vander(x, 3)
    detrended = u - design @ np.linalg.lstsq(design, u, rcond=None)[0]
    crossings = np.flatnonzero(np.signbit(detrended[1:]) != np.signbit(detrended[:-1])) + 1
    lobes = [np.max(np.abs(p)) for p in np.split(detrended, crossings) if len(p)]
    big = max(lobes, default=0.0)
    if sum(lobe >= LOBE_FRACTION * big for lobe in lobes) < MIN_LOBES:
        return f"not a free decay: fewer than {MIN_LOBES} half-cycles", fit
    if fit.angular_frequency * (t[-1] - t[0]) < MIN_LOBES * math.pi:
        return (
            f"not a free decay: {t[-1] - t[0]:.2g} s is less than {MIN_LOBES} half-cycles "
            f"of the fitted ω {fit.angular_frequency:.3g} rad/s"
        ), fit
    return _envelope_reason(t, u, fit), fit


def _envelope_reason(t: np.ndarray, u: np.ndarray, fit) -> str:
    """ "" when the signal follows the fitted free decay (``MIN_FIT_R2``), decays
    (``MAX_LATE_GROWTH``) and its envelope follows the fit's (``ENVELOPE_RATIO``)."""
    slow, fast, drift = fit.modes(t)
    observed, model = u - drift, slow + fast
    r2 = 1 - float(np.mean((observed - model) ** 2)) / max(float(np.var(observed)), 1e-300)
    if r2 < MIN_FIT_R2:
        return (
            f"not a free decay: the fit explains {r2:.0%} of the signal "
            f"(a ring-down's ≥ {MIN_FIT_R2:.0%})"
        )
    half = t < t[0] + (t[-1] - t[0]) / 2
    growth = np.sqrt(np.mean(observed[~half] ** 2) / max(np.mean(observed[half] ** 2), 1e-300))
    if growth > MAX_LATE_GROWTH:
        return f"not a free decay: its second half is {growth:.2g}× as large as its first"
    period_s = 2 * math.pi / fit.angular_frequency
    chunk = np.floor((t - t[0]) / period_s).astype(int)
    least = max(3, 0.5 * period_s / float(np.median(np.diff(t))))  # a partial last period
    rms = np.array(
        [
            [np.sqrt(np.mean(observed[chunk == k] ** 2)), np.sqrt(np.mean(model[chunk == k] ** 2))]
            for k in np.unique(chunk)
            if np.sum(chunk == k) >= least
        ]
    )
    if not rms.size:
        return ""
    judged = rms.max(axis=1) >= ENVELOPE_FLOOR * rms.max()
    ratio = rms[judged, 0] / np.maximum(rms[judged, 1], 1e-12)
    worst = float(ratio[np.argmax(np.abs(np.log(np.maximum(ratio, 1e-12))))])
    if not 1 / ENVELOPE_RATIO <= worst <= ENVELOPE_RATIO:
        return (
            f"not a free decay: over a period the signal is {worst:.2g}× the fitted "
            f"oscillation (a free decay follows its fit within {ENVELOPE_RATIO:g}×)"
        )
    return ""
