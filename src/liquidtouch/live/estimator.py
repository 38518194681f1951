"""The incremental estimator: frames in, :class:`~liquidtouch.live.updates.LiveUpdate` out.

:class:`LiveEstimator` does not know where frames come from:
``add_frame(sensor, t_s, image)`` tracks the frame's markers at once (the only
per-frame work) and, every :data:`REFRESH_S` of stream time, refreshes the
estimate (:func:`~liquidtouch.live.refresh.refresh`) — on a worker thread when
``threaded`` (so a slow fit never holds up the frames; a refresh due while one
runs waits for it), else in the call. ``add_frame`` returns the update of a
refresh that finished, else ``None``; :meth:`LiveEstimator.finish` fits the
whole stream as offline (a stream stopped on ``until_std`` keeps the estimate
that met the thresholds) and returns the final update.

**Emission rule** (from the uncertainty, no time floor): ω is reported once its
std is below :data:`MAX_FREQ_REL_STD` of ω; λ once its std is below
:data:`MAX_DECAY_REL_STD` of λ. While streaming, the std is how far the value
may still be from the stream's final one (:mod:`liquidtouch.live.uncertainty`):
the fit's correlated-noise standard error plus calibrated terms for the
window's length, in e-foldings of the decay and in seconds — the damping of a real slosh is
not exactly exponential, so the fit's std alone claims a precision a short
window does not have (simulated water: the first λ emitted was 38 % off the
final one while its std claimed 6 %). The final update keeps the final fit's
std. Properties do not wait for these gates: a regression model's targets are
predicted from every fit, the λ and ω std propagated and added to the model's
calibrated std (:mod:`liquidtouch.live.properties`), and a target with an
``until_std`` threshold is reported once its std meets it (so a height that
depends on ω answers before λ's std is below 10 %). A classifier's probabilities
wait until λ and ω are both reported.
"""

from __future__ import annotations

import dataclasses
import math
import threading
import time
from collections.abc import Mapping

import numpy as np

from liquidtouch.errors import VideoError
from liquidtouch.fit_settings import AUTO, FitSettings
from liquidtouch.live.properties import (
    check_live_model,
    classify_with_fit_std,
    predict_with_fit_std,
)
from liquidtouch.live.refresh import MIN_WINDOW_S, REDETECT_AFTER_S, Refreshed, refresh
from liquidtouch.live.stopping import check_until_std
from liquidtouch.live.tracks import GrowingTracks
from liquidtouch.live.uncertainty import streamed_decay_rate_std, streamed_frequency_std
from liquidtouch.live.updates import LiveUpdate
from liquidtouch.signal import check_signal_options

#: stream time between refreshes of the estimate [s]
REFRESH_S = 0.25
#: ω is reported once its std is below this fraction of ω
MAX_FREQ_REL_STD = 0.01
#: λ is reported once its std (fit and window length) is below this fraction of λ
MAX_DECAY_REL_STD = 0.10
#: what the final update keeps of the last streamed one when the final refit fails
KEPT_FIELDS = (
    "decay_rate", "decay_rate_std", "angular_frequency", "angular_frequency_std",
    "window_s", "model",
)  # fmt: skip


class LiveEstimator:
    """Streaming estimate of λ, ω (and properties) from frames of one or more sensors.

    Parameters
    ----------
    sensors : names of the sensors whose frames will come (all must deliver
        frames before a signal is built).
    model : a :class:`~liquidtouch.models.property_model.PropertyModel`, optional: a
        regression model adds ``predicted`` properties with their std, a liquid
        classifier ``classified`` probabilities (no std, so no ``until_std`` target).
    until_std : ``{target: std}`` thresholds (checked here; used by the caller's stop rule);
        a model target is reported once its std meets its threshold.
    lowpass_hz, n_markers : as :func:`~liquidtouch.signal.tactile_signal`.
    fit_settings : the final fit's settings (default: ``extract``'s).
    refresh_s : stream time between refreshes [s].
    threaded : refresh on a worker thread (real-time streams) instead of in ``add_frame``.
    """

    def __init__(
        self,
        sensors: list[str],
        *,
        model: object | None = None,
        until_std: Mapping[str, float] | None = None,
        lowpass_hz: float | None = 3.0,
        n_markers: int = 16,
        fit_settings: FitSettings | None = None,
        refresh_s: float = REFRESH_S,
        threaded: bool = False,
    ) -> None:
        check_signal_options(lowpass_hz, n_markers)
        if not sensors or len(set(sensors)) != len(sensors):
            raise VideoError(f"give one or more distinct sensor names, got {sensors!r}")
        self.model_kind = check_live_model(model) if model is not None else ""
        self.targets = list(model.targets) if self.model_kind == "regression" else []
        check_until_std(dict(until_std or {}), self.targets)
        self.until_std = dict(until_std or {})
        if not 0 < float(refresh_s) < math.inf:
            raise VideoError(f"refresh_s must be a time > 0 in seconds, got {refresh_s!r}")
        self.model = model
        self.options = {"lowpass_hz": lowpass_hz, "n_markers": n_markers}
        self.fit_settings = FitSettings() if fit_settings is None else fit_settings
        self.refresh_s = float(refresh_s)
        self.threaded = bool(threaded)
        self.tracks = {name: GrowingTracks(name) for name in sensors}
        self.frames = 0
        self.first_t_s = math.nan
        self.newest_due_s = math.nan
        self.next_refresh_t_s = math.nan
        self.push_seen = False  # once a push stood out, it is not judged again
        self.decay_start_s = math.nan  # kept once the decay is fitted (see refresh)
        self.warm_start: tuple[float, float] | None = None  # (λ, ω) of the last refresh's fit
        self.search_from_s = -math.inf  # the push is searched after this (see _run_refresh)
        self.last: LiveUpdate | None = None
        #: seconds spent in each add_frame call (tracking plus any synchronous refresh)
        self.latencies_s: list[float] = []
        self._worker: threading.Thread | None = None
        self._result: LiveUpdate | None = None
        self._lock = threading.Lock()

    # -- frames ------------------------------------------------------------------------

    def add_frame(
        self, sensor: str, t_s: float, image: np.ndarray, due_s: float = math.nan
    ) -> LiveUpdate | None:
        """Track one frame [``t_s``: s on the shared clock]; the update of a finished refresh.

        ``due_s``: the :func:`time.monotonic` moment the frame became available,
        for the update's ``lag_s`` (NaN: not measured).
        """
        began = time.perf_counter()
        if sensor not in self.tracks:
            raise VideoError(f"unknown sensor {sensor!r}; expected one of {', '.join(self.tracks)}")
        self.tracks[sensor].add(t_s, image)
        self.frames += 1
        self.newest_due_s = float(due_s)
        if math.isnan(self.first_t_s):
            self.first_t_s = float(t_s)
            self.next_refresh_t_s = float(t_s) + self.refresh_s
        update = self._take_result()
        ready = all(tr.n for tr in self.tracks.values())
        if ready and t_s >= self.next_refresh_t_s and not self._busy():
            self.next_refresh_t_s = float(t_s) + self.refresh_s
            snapshot = self._snapshot()
            if self.threaded:
                self._worker = threading.Thread(
                    target=self._run_refresh, args=snapshot, name="live-fit", daemon=True
                )
                self._worker.start()
            else:
                self._run_refresh(*snapshot)
                update = self._take_result()
        self.latencies_s.append(time.perf_counter() - began)
        return update

    def finish(self, stopped_because: str = "end_of_stream") -> LiveUpdate:
        """Wait for a running refresh, fit the whole stream as offline; the final update.

        A stream stopped by ``until_std`` keeps the last streamed estimate — the
        one whose std met the thresholds (a refit of a short record, edge
        included, can be far worse) — and so does one whose refit fails.
        """
        if self._worker is not None:
            self._worker.join()
        self._take_result()
        previous = self.last
        tracks, frames, elapsed, due = self._snapshot()
        if not all(grown.n for grown in self.tracks.values()):
            result = Refreshed(np.zeros(0), np.zeros(0), "waiting", message="no frames")
        else:
            settings = self.fit_settings
            if math.isfinite(self.search_from_s) and math.isfinite(self.decay_start_s):
                if settings.start == AUTO:  # the push found after an earlier false one
                    settings = dataclasses.replace(settings, start=self.decay_start_s)
            result = refresh(tracks, **self.options, fit_settings=settings, final=True)
        update = self._update(result, frames, elapsed, due, final=True)
        keep = result.fit is None or stopped_because == "until_std"
        if keep and previous is not None and math.isfinite(previous.window_s):
            for name in (*KEPT_FIELDS, "predicted", "classified"):
                setattr(update, name, getattr(previous, name))
            why = result.message if result.fit is None else "stopped on the std thresholds"
            update.message = f"{why}: the last streamed estimate is kept"
        update.phase, update.stopped_because = "done", stopped_because
        self.last = update
        return update

    # -- refreshes ----------------------------------------------------------------------

    def _busy(self) -> bool:
        return self._worker is not None and self._worker.is_alive()

    def _snapshot(self) -> tuple[list, int, float, float]:
        tracks = [tr.snapshot() for tr in self.tracks.values() if tr.n]
        newest = max((tr.last_t_s for tr in self.tracks.values() if tr.n), default=math.nan)
        return tracks, self.frames, newest - self.first_t_s, self.newest_due_s

    def _run_refresh(self, tracks: list, frames: int, elapsed_s: float, due_s: float) -> None:
        result = refresh(
            tracks,
            **self.options,
            fit_settings=self.fit_settings,
            push_seen=self.push_seen,
            decay_start_s=self.decay_start_s,
            warm_start=self.warm_start,
            search_from_s=self.search_from_s,
        )
        if result.fit is not None:
            self.warm_start = (result.fit.decay_rate, result.fit.angular_frequency)
        elif result.no_oscillation and result.now_s - self.decay_start_s > (
            MIN_WINDOW_S + REDETECT_AFTER_S
        ):
            # not the push (a grasp or a lift seen by a camera that watches the whole
            # trial): look for the push after it
            self.search_from_s = self.decay_start_s + MIN_WINDOW_S
            self.decay_start_s, self.push_seen, self.warm_start = math.nan, False, None
            return
        self.push_seen = self.push_seen or result.phase != "waiting"
        if result.phase == "decay" and math.isnan(self.decay_start_s):
            # set once: each refresh resamples the signal on a new grid and snaps the start
            # to a sample at or after it, so re-keeping it crept ~0.4 s over a stream (a
            # detergent λ then 38 % below the final one)
            self.decay_start_s = result.decay_start_s
        update = self._update(result, frames, elapsed_s, due_s, final=False)
        with self._lock:
            self._result = update

    def _take_result(self) -> LiveUpdate | None:
        with self._lock:
            update, self._result = self._result, None
        if update is not None:
            self.last = update
        return update

    def _update(
        self, result: Refreshed, frames: int, elapsed_s: float, due_s: float, *, final: bool
    ) -> LiveUpdate:
        """The :class:`LiveUpdate` of one refresh, with the emission rule applied."""
        decay_clock = result.t - (result.decay_start_s if result.phase != "waiting" else np.nan)
        update = LiveUpdate(
            t_s=result.now_s - result.decay_start_s,
            phase=result.phase,
            elapsed_s=elapsed_s,
            frames=frames,
            final=final,
            message=result.message,
            signal_t_s=decay_clock,
            signal_u=result.u,
            signal_fit=result.fit_curve(),
        )
        fit = result.fit
        if fit is not None:
            update.window_s, update.model = fit.duration_s, fit.model
            lam, omega = fit.decay_rate, fit.angular_frequency
            if final:
                lam_std, omega_std = fit.decay_rate_std, fit.angular_frequency_std
            else:
                lam_std = streamed_decay_rate_std(lam, fit.decay_rate_std, fit.duration_s)
                omega_std = streamed_frequency_std(omega, fit.angular_frequency_std, fit.duration_s)
            show_omega = final or omega_std < MAX_FREQ_REL_STD * abs(omega)
            show_lam = final or lam_std < MAX_DECAY_REL_STD * abs(lam)
            if show_omega:
                update.angular_frequency, update.angular_frequency_std = omega, omega_std
            if show_lam:
                update.decay_rate, update.decay_rate_std = lam, lam_std
            features = (lam, lam_std, omega, omega_std)
            if self.model_kind == "regression":
                # no λ/ω gate: a property is as good as its own propagated std says (a
                # height that hangs on ω answers before λ is known to 10 %); a target
                # with an until_std threshold is reported once its std meets it
                predicted = predict_with_fit_std(self.model, *features)
                update.predicted = {
                    t: (mean, std)
                    for t, (mean, std) in predicted.items()
                    if final or std <= self.until_std.get(t, math.inf)
                }
            elif self.model is not None and show_omega and show_lam:
                update.classified = classify_with_fit_std(self.model, *features)
        if math.isfinite(due_s):
            update.lag_s = time.monotonic() - due_s
        return update

    # -- measurements -------------------------------------------------------------------

    def timing(self) -> dict[str, float]:
        """Per-frame latency [ms] of ``add_frame``: ``median``, ``p95``, ``max`` and ``frames``."""
        lat = np.asarray(self.latencies_s) * 1e3
        if not lat.size:
            return {"frames": 0}
        return {
            "frames": int(lat.size),
            "latency_ms_median": float(np.median(lat)),
            "latency_ms_p95": float(np.percentile(lat, 95)),
            "latency_ms_max": float(lat.max()),
        }
