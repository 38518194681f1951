"""The pieces of a refresh of the streaming estimate: a window's signal and its fit.

The estimator (:mod:`liquidtouch.live.estimator`) cuts the stream into segments
(:func:`~liquidtouch.ring_down.trial_segments`) and, per ring-down, builds the signal of
its window (:func:`shared_signal`: the offline :func:`~liquidtouch.signal.tactile_signal`
of the window's frames, its own PCA) and fits it (:func:`fit_ring_down`):

- **Edge.** The zero-phase low-pass has no delay, but its last samples see the
  window's edge, so the last :data:`EDGE_S` of signal are not trusted (not fitted)
  until the stream ends.
- **Model.** While streaming, ``fit_oscillation`` runs with the settings' model (the
  final fit's, so the streamed λ converges on the final one: the amplitude model's λ0
  and the single-mode λ of the same window differ by 10-30 % on simulated slosh), except
  ``two-mode``, fitted single-mode (:data:`REFRESH_MODEL`: the slow mode is the feature,
  and the two-mode multi-start is ~90 % of a fit's time) and ``auto`` fitted with the
  amplitude model (:data:`REFRESH_AUTO_MODEL`); standard errors from the blocked
  jackknife of the window (:data:`REFRESH_NOISE`). Each streaming fit is warm-started
  from the previous refresh's (λ, ω). A final fit is fitted exactly as
  :func:`~liquidtouch.extraction.extract` fits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from liquidtouch.errors import LiquidTouchError, NoOscillationError
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.fit.choices import AUTO as AUTO_MODEL
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ
from liquidtouch.signal.tactile import DEFAULT_N_MARKERS, TactileSignal, tactile_signal
from liquidtouch.tracking.tracks import MarkerTracks

#: signal within this much of the newest sample is not trusted while streaming [s]: the
#: zero-phase low-pass bends its last samples for about one period of its cut-off (3 Hz:
#: 0.33 s; the default 4 Hz: 0.25 s)
EDGE_S = 0.3
#: least free decay fitted [s]: a few samples and most of a slosh period; whether the fit is
#: good enough is then decided from its std, not from time
MIN_WINDOW_S = 0.5
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
    n_markers: int = DEFAULT_N_MARKERS,
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
