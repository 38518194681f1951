"""The incremental estimator: frames in, :class:`~liquidtouch.live.updates.LiveUpdate` out.

:class:`LiveEstimator` does not know where frames come from:
``add_frame(sensor, t_s, image)`` tracks the frame's markers at once (the only
per-frame work) and, every :data:`REFRESH_S` of stream time, refreshes the
estimate (its segments, then each ring-down's fit: :mod:`liquidtouch.live.refresh`,
:mod:`liquidtouch.live.ring_downs`) — on a worker thread when
``threaded`` (so a slow fit never holds up the frames; a refresh due while one
runs waits for it), else in the call. ``add_frame`` returns the update of a
refresh that finished, else ``None``; :meth:`LiveEstimator.finish` fits the
whole stream as offline (a stream stopped on ``until_std`` keeps the estimate
that met the thresholds) and returns the final update.

What of each refresh is reported: :mod:`liquidtouch.live.emission`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections import deque
from collections.abc import Mapping

import numpy as np

from liquidtouch.errors import LiquidTouchError, VideoError
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.live.combined import combined_answer
from liquidtouch.live.emission import emitted_update
from liquidtouch.live.refresh import (
    EDGE_S,
    Refreshed,
    shared_signal,
)
from liquidtouch.live.ring_downs import (
    RingDown,
    copy_segment,
    final_fit,
    mark_segment,
    signal_start_s,
    streaming_fit,
)
from liquidtouch.live.stopping import (
    EVERYWHERE,
    check_live_model,
    check_until_std,
    unreachable_message,
    unreachable_targets,
)
from liquidtouch.live.tracks import GrowingTracks
from liquidtouch.live.updates import LiveUpdate
from liquidtouch.ring_down import (
    GUARD_S,
    MIN_FREE_DECAY_S,
    Segment,
    ring_down_reason,
    trial_segments,
)
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ
from liquidtouch.signal.tactile import DEFAULT_N_MARKERS, check_signal_options
from liquidtouch.tracking.gel import DEFAULT_TRACKING, check_tracking

logger = logging.getLogger(__name__)

#: stream time between refreshes of the estimate [s]
REFRESH_S = 0.25
#: frames whose add_frame latency is kept for the final update's timing (~1 h at 2 × 30 fps)
MAX_TIMED_FRAMES = 216_000
#: a candidate's verdict is reused for one starting within this much of it [s]
VERDICT_MATCH_S = 0.3
#: a ring-down closed by a transient is fitted as final once this much trusted signal
#: follows the transient's onset [s]: the onset found first, at the edge of the trusted
#: signal, is up to ~0.4 s late (its rise is still filtering in), and a final fit up to
#: it took in the transient's start (simulated protocols: a stretch of rest "closed"
#: with part of the push)
SETTLE_S = 1.0
#: what the final update keeps of the last streamed one when the final refit fails
KEPT_FIELDS = (
    "decay_rate", "decay_rate_std", "angular_frequency", "angular_frequency_std",
    "window_s", "model",
)  # fmt: skip


def _within(t: np.ndarray, u: np.ndarray, start: float, end: float):
    keep = (t >= start) & (t <= end)
    return t[keep], u[keep]


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
    protocol : the protocol's events will be given (:meth:`add_event`): the push and the
        end of the hold are taken from them, not guessed (``run-trial``).
    tracking : how the gels are tracked (as ``extract``): ``auto`` (printed markers, or
        the gel's own image on a markerless gel, found from each sensor's first frame),
        ``markers`` or ``flow``.
    """

    def __init__(
        self,
        sensors: list[str],
        *,
        model: object | None = None,
        until_std: Mapping[str, float] | None = None,
        lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
        n_markers: int = DEFAULT_N_MARKERS,
        fit_settings: FitSettings | None = None,
        refresh_s: float = REFRESH_S,
        threaded: bool = False,
        protocol: bool = False,
        tracking: str = DEFAULT_TRACKING,
    ) -> None:
        check_signal_options(lowpass_hz, n_markers)
        check_tracking(tracking)
        if not sensors or len(set(sensors)) != len(sensors):
            raise VideoError(f"give one or more distinct sensor names, got {sensors!r}")
        self.model_kind = check_live_model(model) if model is not None else ""
        self.targets = list(model.targets) if self.model_kind == "regression" else []
        check_until_std(dict(until_std or {}), self.targets, self.model_kind)
        self.until_std = dict(until_std or {})
        #: until_std targets below the model's calibrated std floor: never met, never a gate
        self.unreachable = unreachable_targets(model, self.until_std)
        if not 0 < float(refresh_s) < math.inf:
            raise VideoError(f"refresh_s must be a time > 0 in seconds, got {refresh_s!r}")
        self.model = model
        self.options = {"lowpass_hz": lowpass_hz, "n_markers": n_markers}
        self.fit_settings = FitSettings() if fit_settings is None else fit_settings
        self.refresh_s = float(refresh_s)
        self.threaded = bool(threaded)
        self.tracks = {name: GrowingTracks(name, tracking=tracking) for name in sensors}
        self.frames = 0
        self.first_t_s = math.nan
        self.newest_due_s = math.nan
        self.next_refresh_t_s = math.nan
        self.protocol = bool(protocol)
        self.events: dict[str, float] = {}  # the protocol's events [s, shared clock]
        self.finals: list[RingDown] = []  # ring-downs whose hold ended: never replaced
        self.verdicts: list[tuple[float, bool, str]] = []  # (start [s], closed, why not)
        self.segments: list[Segment] = []  # of the last refresh
        self.open_start_s = math.nan  # the open ring-down's start, kept once found
        self.warm_start: tuple[float, float] | None = None  # (λ, ω) of the last refresh's fit
        self.last: LiveUpdate | None = None
        #: seconds spent in each add_frame call (tracking plus any synchronous refresh): the
        #: last MAX_TIMED_FRAMES (bounded memory)
        self.latencies_s: deque[float] = deque(maxlen=MAX_TIMED_FRAMES)
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
        return self._added(t_s, due_s, began)

    def add_markers(
        self, sensor: str, t_s: float, positions: np.ndarray, due_s: float = math.nan
    ) -> LiveUpdate | None:
        """As :meth:`add_frame` for marker positions (N, 2) [px] already tracked (a tracker
        of your own, or ``liquidtouch.sim.protocol_scene``): no image, no tracking."""
        began = time.perf_counter()
        if sensor not in self.tracks:
            raise VideoError(f"unknown sensor {sensor!r}; expected one of {', '.join(self.tracks)}")
        self.tracks[sensor].add_positions(t_s, positions)
        return self._added(t_s, due_s, began)

    def _added(self, t_s: float, due_s: float, began: float) -> LiveUpdate | None:
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
        """Wait for a running refresh, fit every ring-down not yet final as offline; the final
        update.

        Its λ, ω are those of the ring-down that stands (the last final one: each lasted
        at least ``MIN_FREE_DECAY_S``; every one is in ``segments``); "no ring-down found" when
        there is none, never another stretch's numbers. A stream stopped by ``until_std``
        keeps the last streamed estimate — the one whose std met the thresholds (a refit
        of a short record, edge included, can be far worse) — and so does one whose refit
        fails.
        """
        if self._worker is not None:
            self._worker.join()
        self._take_result()
        previous = self.last
        tracks, frames, elapsed, due = self._snapshot()
        if not all(grown.n for grown in self.tracks.values()):
            result = Refreshed(np.zeros(0), np.zeros(0), "waiting", message="no frames")
            update = self._emit(result, frames, elapsed, due, final=True)
        else:
            update = self._run_refresh(tracks, frames, elapsed, due, final=True)
            self._take_result()
            if self.finals:
                standing = self.finals[-1]
                update = dataclasses.replace(standing.update, frames=frames, elapsed_s=elapsed)
                update.events = self._events_on(update)
            else:
                update.decay_rate = update.angular_frequency = math.nan
                update.decay_rate_std = update.angular_frequency_std = math.nan
                update.predicted, update.classified = {}, {}
                update.out_of_domain = update.unknown_rule = None
                why = f": {update.message}" if update.message else ""
                update.message = f"no ring-down found{why}"
        update.final = True
        streamed = previous is not None and math.isfinite(previous.window_s)
        refit_failed = not math.isfinite(update.angular_frequency)
        if streamed and (stopped_because == "until_std" or (refit_failed and not self.finals)):
            if (
                previous.segment_final
                or not self.finals
                or previous.segment > self.finals[-1].index
            ):
                for name in (*KEPT_FIELDS, "t_s", "predicted", "classified", "out_of_domain",
                             "unknown_rule"):  # fmt: skip
                    setattr(update, name, getattr(previous, name))
                why = update.message if refit_failed else "stopped on the std thresholds"
                update.message = f"{why}: the last streamed estimate is kept"
                copy_segment(update, previous)
        update.segments = [r.summary(self.first_t_s) for r in self.finals]
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

    def add_event(self, name: str, t_s: float) -> None:
        """A protocol event (``push``, ``pushed``, ``stopped``, ...) at ``t_s`` [s].

        ``t_s`` is on the stream's shared clock."""
        with self._lock:
            self.events[str(name)] = float(t_s)

    def _segments(self, tracks: list, t: np.ndarray, x: np.ndarray, u: np.ndarray, final: bool):
        """The stream's segments (:func:`~liquidtouch.ring_down.trial_segments`), each candidate
        judged on its own window's signal; closed candidates' verdicts are kept."""
        with self._lock:
            events = dict(self.events)
        if self.protocol and "push" not in events:
            return [Segment("rest", float(t[0]), float(t[-1]), False, reason="no push yet")]

        def classify(tt, uu, start: float, end: float, closed: bool) -> str:
            closed = closed or final  # the stream's last candidate is judged on all of it
            for s0, was_closed, verdict in self.verdicts:
                if abs(s0 - start) < VERDICT_MATCH_S and was_closed == closed:
                    return verdict
            try:
                window = shared_signal(tracks, **self.options, from_s=start - EDGE_S, to_s=end)
                reason = ring_down_reason(*_within(window.t, window.u, start, end))[0]
            except LiquidTouchError as exc:
                reason = str(exc)
            except np.linalg.LinAlgError as exc:
                # the PCA of a still stretch's window (synthetic frames, exactly still markers)
                # can fail to converge: that stretch is no ring-down
                reason = f"no signal: {exc}"
            if closed or not reason:  # a ring-down stays one while open; judged again closed
                self.verdicts.append((start, closed, reason))
            return reason

        return trial_segments(t, x, events or None, u=u, classify=classify, final=final)

    def _run_refresh(
        self, tracks: list, frames: int, elapsed_s: float, due_s: float, final: bool = False
    ) -> LiveUpdate:
        try:
            full = shared_signal(tracks, **self.options)
        except LiquidTouchError as exc:
            result = Refreshed(np.zeros(0), np.zeros(0), "waiting", message=str(exc))
            return self._publish(self._emit(result, frames, elapsed_s, due_s, final=final))
        t, u = full.t, full.u
        x = full.motion.reshape(len(t), -1)
        trusted = np.ones(t.shape, bool) if final else t <= t[-1] - EDGE_S
        if trusted.sum() < 8:
            result = Refreshed(t, u, "waiting", message="too little signal yet")
            return self._publish(self._emit(result, frames, elapsed_s, due_s, final=final))
        segments = self._segments(tracks, t[trusted], x[trusted], u[trusted], final)
        last_end = self.finals[-1].end_s if self.finals else -math.inf
        # a stream longer than the tracks' window: a segment at the window's start began
        # before it (its push is gone), never a new ring-down
        cut = any(grown.cut for grown in self.tracks.values())
        cut_s = max(float(tr.start_s) for tr in tracks) + EDGE_S if cut else -math.inf
        current = None
        for i, seg in enumerate(segments):
            if seg.kind != "ring-down" or seg.start_s <= max(last_end, cut_s):
                continue
            window_from = signal_start_s(segments, i)
            if seg.closed and not final and t[trusted][-1] < seg.end_s + GUARD_S + SETTLE_S:
                continue  # its closing transient's onset may still move earlier
            if seg.closed or final:
                self._finalize(tracks, seg, window_from, full, frames, elapsed_s, due_s)
                last_end = seg.end_s
            else:
                current = (seg, window_from)
        self.segments = segments
        update = None
        if current is not None:
            update = self._stream_fit(tracks, *current, frames, elapsed_s, due_s)
        reportable = update is not None and math.isfinite(update.angular_frequency)
        if self.finals and not reportable:
            standing = self.finals[-1]
            kept = dataclasses.replace(standing.update, frames=frames, elapsed_s=elapsed_s)
            kept.final, kept.phase = False, "ended"
            if update is not None:
                kept.message = (
                    f"segment {standing.index} is final; a new ring-down (segment "
                    f"{len(self.finals) + 1}) is under way: {update.message or 'no estimate yet'}"
                )
            update = kept
        if update is None:
            tail = segments[-1]
            phase = "push" if tail.kind in ("transient", "release", "push") else "waiting"
            message = "no push yet" if phase == "waiting" else "a transient is under way"
            if tail.kind == "release":
                message = "the hold ended"
            result = Refreshed(t, u, phase, message=message)
            update = self._emit(result, frames, elapsed_s, due_s, final=final)
        if math.isfinite(due_s):
            update.lag_s = time.monotonic() - due_s
        return self._publish(update)

    def _publish(self, update: LiveUpdate) -> LiveUpdate:
        update.events = self._events_on(update)
        with self._lock:
            self._result = update
        return update

    def _events_on(self, update: LiveUpdate) -> dict[str, float]:
        """The protocol's events on the update's clock (its segment's start is 0) [s]."""
        with self._lock:
            events = dict(self.events)
        zero = update.segment_start_s if math.isfinite(update.segment_start_s) else math.nan
        return {name: t_s - zero for name, t_s in events.items()} if math.isfinite(zero) else {}

    def _finalize(self, tracks, seg: Segment, window_from: float, full, frames, elapsed_s, due_s):
        """Fit a ring-down whose hold ended (or the stream's last) as offline: final, kept."""
        if seg.end_s - seg.start_s < MIN_FREE_DECAY_S:
            # as offline ("record at least 2 s after the push"): a final λ needs 2 s of decay,
            # and a stretch of still gel or a step cut this short can pass for one
            self.verdicts.append((seg.start_s, True, "shorter than a final fit needs"))
            logger.info("candidate at %.2f s is too short to be final", seg.start_s)
            return
        index = len(self.finals) + 1
        result = final_fit(
            tracks, seg, window_from, full, self.options, self.fit_settings,
            protocol_events=bool(self.events),
        )  # fmt: skip
        if result.fit is None:  # not a ring-down after all: never a number of another stretch
            self.verdicts.append((seg.start_s, True, result.message or "no fit"))
            logger.info("candidate at %.2f s is not a ring-down: %s", seg.start_s, result.message)
            return
        update = self._emit(result, frames, elapsed_s, due_s, final=True)
        update.phase = "ended"
        update.final = False
        mark_segment(update, index, seg, final=True)
        logger.info(
            "ring-down %d (%.2f-%.2f s) is final: λ %.4g, ω %.4g",
            index, seg.start_s - self.first_t_s, seg.end_s - self.first_t_s,
            update.decay_rate, update.angular_frequency,
        )  # fmt: skip
        self.finals.append(RingDown(index, seg.start_s, seg.end_s, update))
        update.combined = combined_answer(
            [r.update for r in self.finals], self.model, self.until_std
        )
        self.warm_start = None

    def _stream_fit(self, tracks, seg: Segment, window_from: float, frames, elapsed_s, due_s):
        """The streaming estimate of the open ring-down."""
        if not (math.isfinite(self.open_start_s) and abs(seg.start_s - self.open_start_s) < 0.5):
            self.open_start_s, self.warm_start = seg.start_s, None  # a new ring-down
        result = streaming_fit(
            tracks, self.open_start_s, window_from, self.options, self.fit_settings,
            self.warm_start,
        )  # fmt: skip
        if result.fit is not None:
            self.warm_start = (result.fit.decay_rate, result.fit.angular_frequency)
        update = self._emit(result, frames, elapsed_s, due_s, final=False)
        mark_segment(update, len(self.finals) + 1, seg, final=False)
        return update

    def _take_result(self) -> LiveUpdate | None:
        with self._lock:
            update, self._result = self._result, None
        if update is not None:
            self.last = update
        return update

    def _emit(
        self, result: Refreshed, frames: int, elapsed_s: float, due_s: float, *, final: bool
    ) -> LiveUpdate:
        update = emitted_update(
            result,
            frames,
            elapsed_s,
            due_s,
            final=final,
            model=self.model,
            model_kind=self.model_kind,
            until_std={t: s for t, s in self.until_std.items() if t not in self.unreachable},
        )
        here = update.until_std_unreachable  # below the model's std at this (λ, ω)
        if self.unreachable or here:  # said on every update: the page and --json show why
            notes = [
                unreachable_message(self.unreachable, self.until_std, EVERYWHERE),
                unreachable_message(here, self.until_std),
            ]
            update.until_std_unreachable = {**here, **self.unreachable}
            note = " ".join(n for n in notes if n)
            update.message = f"{update.message}; {note}" if update.message else note
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
