"""``liquidtouch record``: record GelSight cameras into a trial directory (the lab path).

Live progress (frames, measured fps, drops per sensor) goes to stderr when it is a
terminal. Ctrl-C stops the recording and removes it: no trial is left (exit 130,
``error: interrupted``). A camera that cannot be opened or stops delivering is
one line ``error: ...`` and exit status 2, again with nothing left behind.
"""

from __future__ import annotations

import json
import math
from enum import StrEnum
from typing import Annotated

import typer

from liquidtouch.acquire.deadlines import (
    DEFAULT_OPEN_TIMEOUT_S,
    DEFAULT_READ_TIMEOUT_S,
    DEFAULT_WARMUP_TIMEOUT_S,
)
from liquidtouch.cli import options
from liquidtouch.cli.format import warn


class FormatChoice(StrEnum):
    """``record --format`` (``acquire.recording.FORMATS``)."""

    ffv1 = "ffv1"
    png = "png"


def register(app: typer.Typer) -> None:
    """Register this module's commands on ``app``."""
    app.command("record")(record)


Sources = Annotated[
    list[str],
    typer.Argument(
        metavar="SRC",
        help="One camera source per sensor: a device index (0), /dev/videoN, "
        "name:GelSight Mini (matched in /sys/class/video4linux), an http/rtsp URL "
        "(e.g. a GelSight R1.5: http://HOST:8080/?action=stream) or a video file "
        "(replayed in real time).",
        show_default=False,
    ),
]
Seconds = Annotated[
    float,
    typer.Option(
        "--seconds", "-s", help="Recording length [s] (a replayed file may end sooner).",
        show_default=False,
    ),
]  # fmt: skip
Format = Annotated[
    FormatChoice,
    typer.Option(
        "--format",
        help="ffv1: lossless FFV1 video in Matroska (.mkv), its PTS the frame times; "
        "png: a folder of PNG images with timestamps.csv.",
    ),
]
Colour = Annotated[
    bool, typer.Option("--colour", help="Keep the colour (BGR) frames instead of grey (luma).")
]


def record(
    sources: Sources,
    seconds: Seconds,
    out: options.TrialOut,
    sensor: options.SensorProfile = options.SensorChoice.raw,
    fmt: Format = FormatChoice.ffv1,
    label: options.Labels = [],  # noqa: B006 - typer reads the default, never mutates it
    name: options.SensorNames = [],  # noqa: B006
    colour: Colour = False,
    as_json: options.Json = False,
    open_timeout_s: options.OpenTimeout = DEFAULT_OPEN_TIMEOUT_S,
    read_timeout_s: options.ReadTimeout = DEFAULT_READ_TIMEOUT_S,
    warmup_timeout_s: options.WarmupTimeout = DEFAULT_WARMUP_TIMEOUT_S,
) -> None:
    """Record GelSight cameras (or streams, or replayed videos) into a trial directory.

    All sensors are read at once, each on its own thread, with one clock
    (time.monotonic); every frame's time is kept (the video's PTS, and
    NAME.timestamps.csv). meta.json gets the measured fps, the labels and each
    sensor's start time; dropped and duplicated frames are counted and printed.
    Every option is checked before a camera is opened.
    """
    from liquidtouch._core.progress import on_terminal
    from liquidtouch.acquire.recording import record as run_record
    from liquidtouch.errors import DeviceError
    from liquidtouch.io.labels import typed_labels

    if not 0 < seconds <= 3600 or not math.isfinite(seconds):
        raise DeviceError(f"--seconds must be in (0, 3600], got {seconds:g}")
    labels = typed_labels(label)
    with _live_progress(enabled=on_terminal()) as on_progress:
        summary = run_record(
            sources, seconds, out, names=name or None, profile=str(sensor), fmt=str(fmt),
            labels=labels, grey=not colour, on_progress=on_progress,
            open_timeout_s=open_timeout_s, read_timeout_s=read_timeout_s,
            warmup_timeout_s=warmup_timeout_s,
        )  # fmt: skip
    for message in summary.warnings:
        warn(message)
    if as_json:
        typer.echo(json.dumps(summary.to_dict()))
        return
    for s in summary.sensors.values():
        fps = f"{s.measured_fps:.2f}" if s.measured_fps else "—"
        typer.echo(
            f"{s.name}: {s.frames} frames at {fps} fps, {s.drops} dropped, "
            f"{s.duplicates} duplicated, {s.backlog_drops} lost by the encoder ({s.source})"
        )
    typer.echo(f"wrote {summary.trial_dir}")


class _live_progress:
    """A rich live table on stderr: frames, fps, drops per sensor (a no-op when disabled)."""

    def __init__(self, *, enabled: bool) -> None:
        self.enabled = enabled
        self._live = None

    def __enter__(self):
        if not self.enabled:
            return None
        from rich.console import Console
        from rich.live import Live

        self._live = Live(console=Console(stderr=True), transient=True, refresh_per_second=4)
        self._live.__enter__()
        return self.update

    def update(self, recorder, elapsed_s: float) -> None:
        from rich.table import Table

        table = Table(title=f"recording {elapsed_s:5.1f} s")
        for column in ("sensor", "frames", "fps", "dropped", "duplicated", "backlog"):
            table.add_column(column, justify="right")
        backlog = recorder.backlog()
        for name, stats in recorder.stats().items():
            fps = stats.measured_fps
            table.add_row(
                name,
                str(stats.frames),
                f"{fps:.1f}" if fps else "—",
                str(stats.drops),
                str(stats.duplicates),
                str(backlog.get(name, 0)),
            )
        assert self._live is not None
        self._live.update(table)

    def __exit__(self, *exc: object) -> None:
        if self._live is not None:
            self._live.__exit__(*exc)
