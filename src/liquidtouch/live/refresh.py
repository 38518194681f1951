"""One refresh of the streaming estimate: tracks so far → signal → phase → fit.

:func:`refresh` is a plain function of the tracks so far (no state), run by the
estimator every ~0.25 s of stream:

1. **Signal**: the offline :func:`~liquidtouch.signal.tactile_signal` on the
   growing tracks (resampled, zero-phase low-pass, marker selection, PCA). The
   zero-phase filter has no delay but its last samples see the window's edge, so
   the last :data:`EDGE_S` of signal are not trusted (not fitted, not used to
   find the push) until the stream ends.
2. **Phase**: the push is the largest excursion
   (:func:`~liquidtouch.segment.free_decay_start`) once it stands
   ``MIN_PUSH_SNR`` noise levels above the signal before it
   (:func:`~liquidtouch.segment.push_snr`, judged on at least
   :data:`MIN_NOISE_S` of it); the free decay starts there. "waiting" before a
   push, "push" until :data:`MIN_WINDOW_S` of decay follow the peak, then "decay".
3. **Fit**: ``fit_oscillation`` on the trusted free decay with the settings'
   model (the final fit's, so the streamed λ converges on the final one: the
   amplitude model's λ0 and the single-mode λ of the same window differ by
   10-30 % on simulated slosh), except ``two-mode``, fitted single-mode while
   streaming (:data:`REFRESH_MODEL`: the slow mode is the feature, and the
   two-mode multi-start is ~90 % of a fit's time) and ``auto`` fitted with the
   amplitude model (:data:`REFRESH_AUTO_MODEL`); standard errors from the
   blocked jackknife of the window (:data:`REFRESH_NOISE`). The final refresh fits
   the whole signal exactly as :func:`~liquidtouch.extraction.extract` does.
   Each streaming fit is warm-started from the previous refresh's (λ, ω).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from liquidtouch.errors import LiquidTouchError, NoOscillationError
from liquidtouch.fit.choices import AUTO as AUTO_MODEL
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.fit_settings import AUTO, FitSettings
from liquidtouch.lowpass_filter import DEFAULT_LOWPASS_HZ
from liquidtouch.segment import MIN_PUSH_SNR, free_decay_start, push_snr
from liquidtouch.signal import TactileSignal, tactile_signal
from liquidtouch.tracking.tracks import MarkerTracks

#: signal within this much of the newest sample is not trusted while streaming [s]: the
#: zero-phase Butterworth's edge transient lasts about one period of its cut-off (3 Hz:
#: 0.33 s; the default 4 Hz: 0.25 s)
EDGE_S = 0.3
#: least free decay fitted [s]: a few samples and most of a slosh period; whether the fit is
#: good enough is then decided from its std, not from time
MIN_WINDOW_S = 0.5
#: least signal before the push its noise level is judged on [s]
MIN_NOISE_S = 0.5
#: stream time [s] a kept decay start may give no oscillation before the push is
#: searched again after it: a grasp or a lift seen before the push (a camera watching
#: the whole trial) stands out of the noise too, and its "decay" is overdamped
REDETECT_AFTER_S = 1.0
#: the fit's model while streaming when the settings ask for two modes (the final fit uses them)
REFRESH_MODEL = "single-mode"
#: the fit's model while streaming when the settings let the data choose (``"auto"``, the
#: default): the amplitude model, which ``auto`` keeps or refines with a second mode on most
#: simulated slosh; fitting every candidate at every refresh would take 3-4× as long
REFRESH_AUTO_MODEL = "amplitude"
#: noise model of the streaming fits' std: the blocked jackknife of the window so far (the
#: larger of it and the correlated-noise std, as the final fit's), the std of a streamed ω
#: (:mod:`liquidtouch.live.uncertainty`); white-noise errors were 1.5-2× too small
REFRESH_NOISE = "jackknife"


@dataclass
class Refreshed:
    """What one refresh found. Times on the signal's clock [s]."""

    t: np.ndarray  # (T,) signal times
    u: np.ndarray  # (T,) signal [px]
    phase: str
    decay_start_s: float = math.nan  # where the free decay starts (NaN: no push yet)
    fit: object | None = None  # OscillationFit of the free decay, if any
    message: str = ""
    no_oscillation: bool = False  # the fit found no oscillation (noise or overdamped)

    @property
    def now_s(self) -> float:
        """Newest signal time [s] (NaN without a signal)."""
        return float(self.t[-1]) if self.t.size else math.nan

    def fit_curve(self) -> np.ndarray:
        """The fitted curve on ``t`` (NaN outside the fitted window)."""
        out = np.full(self.t.shape, np.nan)
        if self.fit is not None:
            inside = (self.t >= self.fit.t0) & (self.t <= self.fit.t0 + self.fit.duration_s)
            out[inside] = self.fit.curve(self.t[inside])
        return out


def fit_options(settings: FitSettings, final: bool) -> dict[str, object]:
    """``fit_oscillation``'s options for a refresh: as offline when ``final``, else the
    streaming model and noise (module docstring, 3)."""
    options = settings.fit_options()
    if not final:
        options["noise"] = REFRESH_NOISE
        if options["model"] == "two-mode":
            options["model"] = REFRESH_MODEL
        elif options["model"] == AUTO_MODEL:
            options["model"] = REFRESH_AUTO_MODEL
    return options


def refresh(
    tracks: Sequence[MarkerTracks],
    *,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = 16,
    fit_settings: FitSettings | None = None,
    final: bool = False,
    push_seen: bool = False,
    decay_start_s: float = math.nan,
    warm_start: tuple[float, float] | None = None,
    search_from_s: float = -math.inf,
) -> Refreshed:
    """Signal, phase and fit of the tracks so far (module docstring).

    ``final``: the stream has ended: the whole signal is trusted and fitted with
    ``fit_settings`` (its model and start) as offline. ``push_seen``: an earlier
    refresh found the push (its noise test is not repeated on the longer
    signal, whose high-pass and noise level move). ``decay_start_s``: the free
    decay's start found earlier [s], kept while streaming (the largest excursion
    of a short window can land at its edge, where the high-pass rings). ``warm_start``:
    (λ, ω) of the previous refresh's fit, where the streaming fit starts (not the final
    one, which is fitted as offline). ``search_from_s``: look for the push only
    after this time [s] (an earlier "push" gave no oscillation). Input problems of the
    partial stream (too few frames, no oscillation yet) are reported in
    ``message``, not raised.
    """

    settings = FitSettings() if fit_settings is None else fit_settings
    empty = np.zeros(0)
    try:
        signal = tactile_signal(tracks, lowpass_hz=lowpass_hz, n_markers=n_markers)
    except LiquidTouchError as exc:
        return Refreshed(empty, empty, "waiting", message=str(exc))
    t, u = signal.t, signal.u
    trusted = np.ones(t.shape, bool) if final else t <= t[-1] - EDGE_S
    if trusted.sum() < 3:
        return Refreshed(t, u, "waiting", message="too little signal yet")
    t_in, u_in = t[trusted], u[trusted]
    if final and settings.start != AUTO:
        start = int(np.searchsorted(t, float(settings.start)))
    elif not final and math.isfinite(decay_start_s):
        start = int(np.argmin(np.abs(t - decay_start_s)))  # nearest: the grid moves per refresh
    else:
        offset = int(np.searchsorted(t_in, search_from_s))
        if len(t_in) - offset < 3:
            return Refreshed(t, u, "waiting", message="too little signal yet")
        t_s, u_s = t_in[offset:], u_in[offset:]
        start = free_decay_start(t_s, u_s)
        snr = math.inf if final or push_seen else push_snr(t_s, u_s, start, min_noise_s=MIN_NOISE_S)
        start += offset
        if not (final or push_seen) and not snr >= MIN_PUSH_SNR:
            why = "no push yet" if math.isfinite(snr) else "too little signal before the push"
            return Refreshed(t, u, "waiting", message=why)
    decay_start = float(t[min(start, len(t) - 1)])
    if t_in[-1] - decay_start < MIN_WINDOW_S:
        return Refreshed(t, u, "push", decay_start, message="the push is under way")
    keep = trusted & (t >= decay_start)
    fit, message, no_oscillation = fit_ring_down(
        t[keep], u[keep], decay_start, math.inf, settings, final=final, warm_start=warm_start
    )
    if fit is None:
        return Refreshed(t, u, "decay", decay_start, message=message, no_oscillation=no_oscillation)
    return Refreshed(t, u, "decay", decay_start, fit)


def window_tracks(
    tracks: Sequence[MarkerTracks], from_s: float = -math.inf, to_s: float = math.inf
) -> list[MarkerTracks]:
    """The tracks' frames within ``[from_s, to_s]`` on the shared clock [s] (``start_s`` moved).

    The signal of a window is its own PCA: over a whole trial the grasp, lift and lowering
    dominate the first component and the slosh may hardly show in it (a rig trial watched
    from before the grasp: λ +10 % from the whole stream's u, +3 % from the window's).
    """
    out = []
    for tr in tracks:
        shared = float(tr.start_s) + tr.t - tr.t[0]
        keep = (shared >= from_s) & (shared <= to_s)
        if keep.sum() < 2:
            keep[-2:] = True
        first = int(np.flatnonzero(keep)[0])
        out.append(
            MarkerTracks(
                t=tr.t[keep],
                positions=tr.positions[keep],
                valid=tr.valid[keep],
                reference=tr.reference,
                sensor=tr.sensor,
                spacing_px=tr.spacing_px,
                diameter_px=tr.diameter_px,
                first_frame=tr.first_frame,
                start_s=float(shared[first]),
            )
        )
    return out


def shared_signal(
    tracks: Sequence[MarkerTracks],
    *,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = 16,
    from_s: float = -math.inf,
    to_s: float = math.inf,
) -> TactileSignal:
    """:func:`~liquidtouch.signal.tactile_signal` of the window, its ``t`` on the shared clock."""
    if math.isfinite(from_s) or math.isfinite(to_s):
        tracks = window_tracks(tracks, from_s, to_s)
    signal = tactile_signal(tracks, lowpass_hz=lowpass_hz, n_markers=n_markers)
    signal.t = signal.t + max(float(tr.start_s) for tr in tracks)
    return signal


def fit_ring_down(
    t: np.ndarray,
    u: np.ndarray,
    start_s: float,
    end_s: float,
    settings: FitSettings,
    *,
    final: bool,
    warm_start: tuple[float, float] | None = None,
) -> tuple[object | None, str, bool]:
    """The fit of ``u`` over ``[start_s, end_s]``: ``(fit or None, message, no_oscillation)``.

    ``final``: with the settings as offline (``extract``); else the streaming model and
    noise (module docstring, 3).
    """
    keep = (t >= start_s) & (t <= end_s)
    options = fit_options(settings, final)
    try:
        fit = fit_oscillation(
            t[keep],
            u[keep],
            **options,
            min_duration_s=MIN_WINDOW_S,
            warm_start=None if final else warm_start,
        )
    except NoOscillationError as exc:
        return None, str(exc), True
    except LiquidTouchError as exc:
        return None, str(exc), False
    return fit, "", False
