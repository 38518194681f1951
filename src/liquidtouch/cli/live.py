"""``liquidtouch live``: the streaming estimate of cameras or a replayed recording.

A thin command over :func:`liquidtouch.live.live_updates`: one line (or, with
``--json``, one JSON object) per update, then the final one; ``--serve``
publishes the updates and the frames with their markers to the browser view
(:mod:`liquidtouch.live.hub`, :mod:`liquidtouch.live.web`).
"""

from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path
from typing import Annotated

import typer

from liquidtouch._core.numbers import with_uncertainty
from liquidtouch.acquire.deadlines import (
    DEFAULT_OPEN_TIMEOUT_S,
    DEFAULT_READ_TIMEOUT_S,
    DEFAULT_WARMUP_TIMEOUT_S,
)
from liquidtouch.cli import options
from liquidtouch.cli.format import warn

logger = logging.getLogger("liquidtouch.cli.live")

#: frames published to the browser per sensor at most [Hz]
SERVE_FRAME_HZ = 10.0
#: longest --linger [s] (a day)
MAX_LINGER_S = 86_400.0


def register(app: typer.Typer) -> None:
    """Register this module's commands on ``app``."""
    app.command("live")(live)


def parse_serve(text: str) -> tuple[str, int]:
    """``HOST:PORT`` → ``(host, port)``; typer.BadParameter otherwise (port 0: any free one)."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        raise typer.BadParameter(
            f"{text!r} is not HOST:PORT (e.g. 127.0.0.1:8765)", param_hint="'--serve'"
        )
    return host, int(port)


Replay = Annotated[
    bool, typer.Option("--replay", help="Play recordings at the pace of their timestamps.")
]
MaxDuration = Annotated[
    float | None,
    typer.Option(
        "--max-duration", metavar="SECONDS", help="Stop after this much stream time [s].",
        show_default=False,
    ),
]  # fmt: skip
Linger = Annotated[
    float,
    typer.Option(
        "--linger",
        metavar="SECONDS",
        help="With --serve: keep serving the final page this long after the stream ends [s], "
        "0 to 86400 (Ctrl-C ends it sooner).",
    ),
]
Fps = Annotated[
    float | None,
    typer.Option(
        "--fps", metavar="HZ", help="Frame rate of image folders without timestamps [Hz].",
        show_default=False,
    ),
]  # fmt: skip


Sources = Annotated[
    list[str],
    typer.Argument(
        metavar="SRC...",
        help="Camera sources (0, /dev/video2, name:GelSight Mini, a URL) or recordings "
        "(video files, image folders, one trial directory).",
        show_default=False,
    ),
]


def live(
    sources: Sources,
    model_file: options.LiveModel = None,
    replay: Replay = False,
    until_std: options.UntilStd = [],  # noqa: B006 - typer reads the default, never mutates it
    max_duration_s: MaxDuration = None,
    as_json: options.Json = False,
    serve: options.Serve = None,
    linger_s: Linger = 0.0,
    fps: Fps = None,
    lowpass_hz: options.MarkerLowpass = options.DEFAULT_LOWPASS_HZ,
    n_markers: options.Markers = options.DEFAULT_MARKERS,
    sensor: options.SensorProfile = options.SensorChoice.raw,
    open_timeout_s: options.OpenTimeout = DEFAULT_OPEN_TIMEOUT_S,
    read_timeout_s: options.ReadTimeout = DEFAULT_READ_TIMEOUT_S,
    warmup_timeout_s: options.WarmupTimeout = DEFAULT_WARMUP_TIMEOUT_S,
    tracking: options.Tracking = options.DEFAULT_TRACKING,
) -> None:
    """Estimate λ, ω (and, with --model, properties) while the frames come in.

    An estimate appears as soon as its std supports it; the stream stops at the end of
    the recording, after --max-duration, or once every --until-std target is met (a
    target the model's calibrated std can never meet is said at once). One line (--json:
    one JSON object) per new estimate; a repeat of the last one is not printed again.
    """
    _check_inputs(sources, linger_s)  # before the heavy imports: answered at once
    from liquidtouch.live.stopping import parse_until_std

    limits = parse_until_std(until_std)
    address = parse_serve(serve) if serve else None
    model, unreachable = live_model(model_file, limits, lowpass_hz, n_markers)
    hub = server = on_frame = None
    if address is not None:
        hub, server, on_frame = _start_serving(*address)
    try:
        updates = _updates(
            sources, model, limits, replay, max_duration_s, fps, lowpass_hz, n_markers,
            on_frame, sensor, (open_timeout_s, read_timeout_s, warmup_timeout_s), str(tracking),
        )  # fmt: skip
        _show_all(updates, hub, as_json, said_at_start=unreachable)
        if server is not None and linger_s > 0:
            hub.close()  # browsers get the end; the page and its history stay served
            _linger(linger_s, server.url)
    finally:
        if server is not None:
            server.stop()
        if hub is not None:
            hub.close()


def live_model(
    model_file: Path | None, limits: dict[str, float], lowpass_hz: float | None, n_markers: int
):
    """The ``--model`` (or None) and the ``--until-std`` targets it can never meet, checked
    (a warning says which, and another if the model was trained on features made
    otherwise than the live estimate: ``lowpass_hz``, ``n_markers``, ``extract``'s fit);
    without a model before the heavy imports (a typo is answered at once)."""
    from liquidtouch.live.stopping import EVERYWHERE, check_until_std, unreachable_message

    if model_file is None:
        check_until_std(limits)
        return None, {}
    from liquidtouch.live.properties import check_live_request, settings_warning
    from liquidtouch.models.modelfile import load_model

    model = load_model(model_file)
    unreachable = check_live_request(model, limits)
    if unreachable:
        warn(unreachable_message(unreachable, limits, EVERYWHERE))
    other = settings_warning(model, lowpass_hz=lowpass_hz, n_markers=n_markers)
    if other:
        warn(other)
    return model, unreachable


def _check_inputs(sources: list[str], linger_s: float) -> None:
    """--linger's range, and every source a recording on disk or a camera (DeviceError)."""
    from liquidtouch.acquire.cameras.sources import parse_source
    from liquidtouch.errors import LiquidTouchError

    if not 0 <= linger_s <= MAX_LINGER_S:  # NaN and inf too
        raise LiquidTouchError(f"--linger must be 0 to {MAX_LINGER_S:g} s, got {linger_s:g}")
    for source in sources:
        if not Path(source).exists():
            parse_source(source)  # a camera, or DeviceError


def _updates(sources, model, limits, replay, max_duration_s, fps, lowpass_hz, n_markers,
             on_frame, sensor, timeouts, tracking):  # fmt: skip
    """:func:`liquidtouch.live.live_updates` of the command's options."""
    from liquidtouch.live import live_updates

    return live_updates(
        sources,
        model=model,
        until_std=limits,
        realtime=replay,
        max_duration_s=max_duration_s,
        fps=fps,
        lowpass_hz=lowpass_hz,
        n_markers=n_markers,
        on_frame=on_frame,
        profile=str(sensor),
        camera_options=dict(
            zip(("open_timeout_s", "read_timeout_s", "warmup_timeout_s"), timeouts, strict=True)
        ),
        tracking=tracking,
    )


def _show_all(updates, hub, as_json: bool, said_at_start=()) -> None:
    """Publish every update; print each new one (a repeat of the last printed estimate, as a
    stream that goes on after its ring-down ended gives every refresh, is not printed); say
    once, as soon as it is known, an --until-std target this stream cannot meet."""
    printed, said = None, set(said_at_start)
    try:
        for update in updates:
            printed = _show(update, hub, as_json, printed)
            new = set(update.until_std_unreachable) - said
            if new:  # a target this stream cannot meet: said once, as soon as it is known
                said |= new
                warn(update.message)
    except KeyboardInterrupt:  # Ctrl-C while showing an update: the stream's final one
        try:
            _show(updates.throw(KeyboardInterrupt), hub, as_json, printed)
        except StopIteration:
            pass


def _show(update, hub, as_json: bool, printed: str | None) -> str | None:
    """Publish one update and print it unless it repeats the last printed one; its key."""
    from liquidtouch.live.updates import repeat_key

    if hub is not None:
        hub.publish(update.to_dict(include_signal=True))
    key = repeat_key(update)
    if key == printed:
        return printed
    if as_json:
        typer.echo(json.dumps(update.to_dict(), ensure_ascii=False))
    else:
        typer.echo(_line(update))
    if update.stopped_because == "source_error":
        warn(f"the stream ended early: {update.message}")
    logger.info("update: %s", update)
    return key


def _linger(seconds: float, url: str) -> None:
    """Wait ``seconds`` [s] with the final page still served; Ctrl-C ends the wait early."""
    from liquidtouch.cli.format import note

    note(f"the stream ended; the final page stays at {url} for {seconds:g} s (Ctrl-C ends it)")
    try:
        time.sleep(seconds)
    except KeyboardInterrupt:
        pass


def _start_serving(host: str, port: int):
    """The hub, its web server and an ``on_frame`` that publishes ≤ SERVE_FRAME_HZ per sensor."""
    from liquidtouch.cli.format import note
    from liquidtouch.live.hub import LiveHub
    from liquidtouch.live.web import start_server

    hub = LiveHub()
    server = start_server(hub, host=host, port=port)
    note(f"serving the live view at {server.url}")
    last: dict[str, float] = {}

    def on_frame(frame, positions, reference) -> None:
        now = time.monotonic()
        if now - last.get(frame.sensor, -math.inf) >= 1.0 / SERVE_FRAME_HZ:
            last[frame.sensor] = now
            hub.publish_frame(frame.sensor, frame.image, reference, positions)

    return hub, server, on_frame


def _line(update) -> str:
    """One human-readable line of an update."""
    parts = [f"{update.phase:7s}"]
    if math.isfinite(update.t_s):
        parts.append(f"t = {update.t_s:5.2f} s")
    if math.isfinite(update.decay_rate):
        parts.append(f"λ = {with_uncertainty(update.decay_rate, update.decay_rate_std)} 1/s")
    if math.isfinite(update.angular_frequency):
        omega = with_uncertainty(update.angular_frequency, update.angular_frequency_std)
        parts.append(f"ω = {omega} rad/s")
    for target, (mean, std) in update.predicted.items():
        parts.append(f"{target} = {with_uncertainty(mean, std)}")
    if update.final:
        parts.append(f"(stopped: {update.stopped_because.replace('_', ' ')})")
        if (answer := answer_line(update.to_dict())) is not None:  # several ring-downs
            parts.append(f"\n{answer}")
    elif update.message and not math.isfinite(update.angular_frequency):
        parts.append(f"({update.message})")
    return "  ".join(parts)


def answer_line(final: dict) -> str | None:
    """The combined answer of a trial of several pushes in one line (``None`` for one push):
    each target ``mean ± std`` and the ring-downs' agreement, or "cannot tell" and why."""
    combined = final.get("combined") or {}
    if combined.get("ring_downs", 0) < 2 and not any(
        r.get("cannot_tell") for r in (combined.get("reach") or {}).values()
    ):
        return None
    reach = combined.get("reach") or {}
    cannot = [r["message"] for r in reach.values() if r["cannot_tell"]]
    if cannot:
        return "answer: " + "; ".join(cannot)
    parts = [f"{t} = {with_uncertainty(m, s)}" for t, (m, s) in combined["predicted"].items()]
    missed = [r["message"] for r in reach.values() if not r["met"]]
    unmet = f"; not met: {'; '.join(missed)}" if missed else ""
    return f"answer: {', '.join(parts)} ({combined['message']}{unmet})"
