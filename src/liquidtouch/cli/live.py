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

import typer

from liquidtouch._core.numbers import with_uncertainty
from liquidtouch.acquire.deadlines import (
    DEFAULT_OPEN_TIMEOUT_S,
    DEFAULT_READ_TIMEOUT_S,
    DEFAULT_WARMUP_TIMEOUT_S,
)
from liquidtouch.cli import options

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


def live(
    sources: list[str] = typer.Argument(
        ...,
        metavar="SRC...",
        help="Camera sources (0, /dev/video2, name:GelSight Mini, a URL) or recordings "
        "(video files, image folders, one trial directory).",
        show_default=False,
    ),
    model_file: Path | None = typer.Option(
        None, "--model", help="Model file (from train): predict its targets with their std."
    ),
    replay: bool = typer.Option(
        False, "--replay", help="Play recordings at the pace of their timestamps (real time)."
    ),
    until_std: list[str] = typer.Option(
        [],
        "--until-std",
        metavar="TARGET=STD",
        help="Stop once TARGET's std is below STD (repeatable; all must hold): decay_rate, "
        "angular_frequency or a model target, e.g. height_mm=0.5.",
        show_default=False,
    ),
    max_duration_s: float | None = typer.Option(
        None,
        "--max-duration",
        metavar="SECONDS",
        help="Stop after this much stream time [s].",
        show_default=False,
    ),
    as_json: bool = typer.Option(
        False, "--json", help="One JSON object per update on stdout; the last has final=true."
    ),
    serve: str | None = typer.Option(
        None,
        "--serve",
        metavar="HOST:PORT",
        help="Show the stream in a browser at http://HOST:PORT (port 0: any free port).",
        show_default=False,
    ),
    linger_s: float = typer.Option(
        0.0,
        "--linger",
        metavar="SECONDS",
        help="With --serve: keep serving the final page this long after the stream ends [s], "
        "0 to 86400 (Ctrl-C ends it sooner).",
    ),
    fps: float | None = typer.Option(
        None,
        "--fps",
        metavar="HZ",
        help="Frame rate of image folders without timestamps [Hz].",
        show_default=False,
    ),
    lowpass_hz: options.MarkerLowpass = options.DEFAULT_LOWPASS_HZ,
    n_markers: options.Markers = options.DEFAULT_MARKERS,
    sensor: options.SensorProfile = options.SensorChoice.raw,
    open_timeout_s: options.OpenTimeout = DEFAULT_OPEN_TIMEOUT_S,
    read_timeout_s: options.ReadTimeout = DEFAULT_READ_TIMEOUT_S,
    warmup_timeout_s: options.WarmupTimeout = DEFAULT_WARMUP_TIMEOUT_S,
) -> None:
    """Estimate λ, ω (and, with --model, properties) while the frames come in.

    An estimate appears as soon as its std supports it; the stream stops at the end of
    the recording, after --max-duration, or once every --until-std target is met.
    """
    from liquidtouch.errors import LiquidTouchError
    from liquidtouch.live import live_updates, parse_until_std

    if not 0 <= linger_s <= MAX_LINGER_S:  # NaN and inf too
        raise LiquidTouchError(f"--linger must be 0 to {MAX_LINGER_S:g} s, got {linger_s:g}")
    limits = parse_until_std(until_std)
    address = parse_serve(serve) if serve else None
    model = None
    if model_file is not None:
        from liquidtouch.models.modelfile import load_model

        model = load_model(model_file)
    hub = server = None
    on_frame = None
    if address is not None:
        hub, server, on_frame = _start_serving(*address)
    try:
        updates = live_updates(
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
            camera_options={
                "open_timeout_s": open_timeout_s,
                "read_timeout_s": read_timeout_s,
                "warmup_timeout_s": warmup_timeout_s,
            },
        )
        try:
            for update in updates:
                _show(update, hub, as_json)
        except KeyboardInterrupt:  # Ctrl-C while showing an update: the stream's final one
            try:
                _show(updates.throw(KeyboardInterrupt), hub, as_json)
            except StopIteration:
                pass
        if server is not None and linger_s > 0:
            hub.close()  # browsers get the end; the page and its history stay served
            _linger(linger_s, server.url)
    finally:
        if server is not None:
            server.stop()
        if hub is not None:
            hub.close()


def _show(update, hub, as_json: bool) -> None:
    """Publish and print one update."""
    if hub is not None:
        hub.publish(update.to_dict(include_signal=True))
    if as_json:
        typer.echo(json.dumps(update.to_dict(), ensure_ascii=False))
    else:
        typer.echo(_line(update))
    if update.stopped_because == "source_error":
        typer.echo(f"warning: the stream ended early: {update.message}", err=True)
    logger.info("update: %s", update)


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
    elif update.message and not math.isfinite(update.angular_frequency):
        parts.append(f"({update.message})")
    return "  ".join(parts)
