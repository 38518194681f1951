"""``run-trial --live/--model/--serve``: the live estimate of the frames being recorded.

The recorder hands every captured frame to :meth:`LiveTrial.tap` (on its capture thread:
it only queues, and drops a frame when the estimator is behind), the protocol's events
to :meth:`LiveTrial.event`; a thread runs :func:`liquidtouch.live.live_updates` over them
with ``protocol=True`` (the push and the end of the hold are the protocol's, not guessed)
and publishes to the live page when ``--serve`` is given. With ``--max-pushes`` the
protocol asks :meth:`LiveTrial.decide` after each hold whether to push again (the
ring-downs so far combined: every target met, or "cannot tell here", ends the trial).
:meth:`LiveTrial.write` puts the final update (every ring-down's estimate, their
combination, the events, the decisions) into the trial as ``live.json``.
"""

from __future__ import annotations

import json
import logging
import math
import queue
import threading
import time
from pathlib import Path

from liquidtouch.cli.live import SERVE_FRAME_HZ, live_model, parse_serve
from liquidtouch.errors import LiquidTouchError

logger = logging.getLogger("liquidtouch.cli.live_trial")

#: frames queued for the estimator at most (per trial): beyond, frames are dropped
MAX_QUEUED = 600
_END = object()


class LiveTrial:
    """The live estimate beside a ``run-trial`` (module docstring)."""

    def __init__(self, names, *, model_file=None, until_std=(), serve=None, max_pushes=1,
                 tracking=None, n_markers=None):  # fmt: skip
        """Check everything (model file, targets, serve address, --max-pushes, --tracking,
        --markers) before a robot moves."""
        from liquidtouch.live.stopping import parse_until_std
        from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ
        from liquidtouch.signal.tactile import DEFAULT_N_MARKERS, check_signal_options
        from liquidtouch.tracking.gel import DEFAULT_TRACKING, check_tracking

        self.tracking = check_tracking(DEFAULT_TRACKING if tracking is None else tracking)
        self.n_markers = DEFAULT_N_MARKERS if n_markers is None else n_markers
        check_signal_options(n_markers=self.n_markers)

        self.names = list(names)
        self.limits = parse_until_std(list(until_std))
        self.address = parse_serve(serve) if serve else None
        #: the model, and the --until-std targets it can never meet {target: its std floor}
        self.model, self.unreachable = live_model(
            model_file, self.limits, DEFAULT_LOWPASS_HZ, self.n_markers
        )
        self.max_pushes = int(max_pushes)
        if self.max_pushes > 1 and (getattr(self.model, "kind", "") != "regression"
                                    or not self.limits):  # fmt: skip
            raise LiquidTouchError(
                f"--max-pushes {self.max_pushes} needs --model (a regression model, from "
                "train) and --until-std TARGET=STD: another push is made only when the "
                "answer misses a target"
            )
        #: ring-downs judged final so far, the latest combined answer, the decisions made
        self.finals_seen = 0
        self.combined: dict = {}
        self.decisions: list[dict] = []
        self.frames: queue.Queue = queue.Queue(maxsize=MAX_QUEUED)
        self.events: queue.Queue = queue.Queue()
        self.all_events: list[tuple[str, float]] = []
        self.final: dict | None = None
        self.dropped = 0
        self.hub = self.server = None
        self.url = ""
        self._thread: threading.Thread | None = None

    def tap(self, sensor: str, frame) -> None:
        try:
            self.frames.put_nowait((sensor, frame))
        except queue.Full:
            self.dropped += 1

    def event(self, name: str, t_s: float) -> None:
        self.events.put((name, t_s))
        self.all_events.append((name, t_s))

    def start(self) -> None:
        """Start serving (``--serve``) and estimating."""
        from liquidtouch.cli.format import note

        if self.address is not None:
            from liquidtouch.live.hub import LiveHub
            from liquidtouch.live.web import start_server

            self.hub = LiveHub()
            self.server = start_server(self.hub, host=self.address[0], port=self.address[1])
            self.url = self.server.url
            note(f"serving the live view at {self.server.url}")
        self._thread = threading.Thread(target=self._run, name="live-trial", daemon=True)
        self._thread.start()

    def _frames(self):
        from liquidtouch.live import LiveFrame

        while True:
            item = self.frames.get()
            if item is _END:
                return
            sensor, frame = item
            yield LiveFrame(sensor, float(frame.t_s), frame.image, float(frame.t_s))

    def _new_events(self):
        out = []
        while True:
            try:
                out.append(self.events.get_nowait())
            except queue.Empty:
                return out

    def _run(self) -> None:
        from liquidtouch.live import live_updates

        last: dict[str, float] = {}
        said = set(self.unreachable)  # warned about at the start

        def on_frame(frame, positions, reference) -> None:
            now = time.monotonic()
            if (
                self.hub is not None
                and now - last.get(frame.sensor, -math.inf) >= 1 / SERVE_FRAME_HZ
            ):
                last[frame.sensor] = now
                self.hub.publish_frame(frame.sensor, frame.image, reference, positions)

        try:
            for update in live_updates(
                self._frames(),
                sensors=self.names,
                model=self.model,
                until_std=self.limits,
                realtime=True,
                protocol=True,
                on_event=self._new_events,
                on_frame=on_frame,
                stop_on_until_std=self.max_pushes <= 1,  # else the pushes' answer decides
                tracking=self.tracking,
                n_markers=self.n_markers,
            ):
                if update.segment_final and update.combined:
                    self.finals_seen = max(self.finals_seen, update.segment)
                    self.combined = update.combined
                if self.hub is not None:
                    self.hub.publish(update.to_dict(include_signal=True))
                logger.info("live: %s", update)
                new = set(update.until_std_unreachable) - said
                if new:  # a target this trial cannot meet: said once, when first known
                    said |= new
                    logger.warning("live: %s", update.message)
                if update.final:
                    self.final = update.to_dict()
        except Exception as exc:  # the trial matters more than its live view
            logger.warning("the live estimate failed: %s", exc)
            self.final = {"error": str(exc)}

    def decide(self, pushes: int) -> bool | None:
        """After push ``pushes``: push again? ``None`` until the live estimate has judged
        that push's ring-down (:func:`liquidtouch.live.combined.next_push`); ``False`` when
        the estimate has ended or failed (another push would go unjudged)."""
        from liquidtouch.live.combined import next_push

        if self.finals_seen < pushes:
            alive = self._thread is not None and self._thread.is_alive()
            if alive and self.final is None:
                return None
            again, why = (
                False,
                "the live estimate ended: "
                + str((self.final or {}).get("error") or (self.final or {}).get("message") or "?"),
            )
        else:
            again, why = next_push(self.combined)
        self.decisions.append({"after_push": pushes, "push_again": again, "why": why})
        logger.info("after push %d: %s (%s)", pushes, "push again" if again else "done", why)
        return again

    def end(self) -> None:
        """The recording is over: end the stream, wait for the final update, stop serving."""
        try:
            self.frames.put(_END, timeout=5.0)
        except queue.Full:
            self.frames = queue.Queue()
            self.frames.put(_END)
        if self._thread is not None:
            self._thread.join(timeout=120.0)
        if self.hub is not None:
            self.hub.close()
        if self.server is not None:
            self.server.stop()

    def write(self, trial_dir: Path) -> Path | None:
        if self.final is None:
            return None
        record = {
            **self.final,
            "protocol_events": [{"event": n, "t_s": t} for n, t in self.all_events],
            "decisions": self.decisions,
            "frames_dropped_by_live": self.dropped,
        }
        path = Path(trial_dir) / "live.json"
        path.write_text(json.dumps(record, indent=1, default=str), encoding="utf-8")
        return path
