"""Options shared by several commands, declared once: flag names, help, choices, defaults.

A command takes e.g. ``loss: options.Loss = options.DEFAULT_LOSS``: the flags and
the help text live here only, so ``fit``, ``extract``, ``features`` and
``predict`` offer the same fit options, and every ``--out``/``--jobs`` has the
same short flag. Choices are enums, so ``--help`` lists them and typer refuses
anything else. Nothing heavy is imported (``--help`` stays fast; ``liquidtouch.signal.lowpass``,
for its one default cut-off, brings only numpy); the choice
lists and defaults equal the library's (``tests/cli/test_cli_consistency.py`` checks).

Units in help texts are written in words or upper-case brackets ("[Hz]"): rich reads
a lower-case bracket such as "[rad/s]" as markup and drops it.
"""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from liquidtouch.fit import choices as fit_choices
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ as DEFAULT_LOWPASS_HZ  # the one default

if TYPE_CHECKING:
    from liquidtouch.extraction.fit_settings import FitSettings

OUT = ("--out", "-o")
"""The flags of every output-file option (``typer.Option(*OUT, help=...)``)."""


class LossChoice(StrEnum):
    """``fit_oscillation``'s ``loss`` (``fit.oscillation.LOSSES``)."""

    paper = "paper"
    ls = "ls"


class FitModelChoice(StrEnum):
    """``fit_oscillation``'s ``model`` (``fit.choices.MODELS``)."""

    auto = "auto"
    two_mode = "two-mode"
    single_mode = "single-mode"
    amplitude = "amplitude"
    drifting_line = "drifting-line"
    amplitude_two_mode = "amplitude-two-mode"


class NoiseChoice(StrEnum):
    """``fit_oscillation``'s ``noise`` (``fit.oscillation.NOISE_MODELS``)."""

    white = "white"
    correlated = "correlated"
    jackknife = "jackknife"


class RegressorChoice(StrEnum):
    """``train --model`` (``models.property_model.MODEL_KINDS``)."""

    gpr = "gpr"
    quadratic = "quadratic"
    physics_gpr = "physics-gpr"


class SourceChoice(StrEnum):
    """``features --source`` (``batch.features.SOURCES``)."""

    gelsight = "gelsight"
    wrench = "wrench"
    wrench_best_effort = "wrench-best-effort"


class RealismChoice(StrEnum):
    """``--realism`` (``sim.realism.REALISM_WORLDS``)."""

    clean = "clean"
    lab = "lab"


Realism = Annotated[
    RealismChoice,
    typer.Option(
        "--realism",
        help="clean: the simulator's calibrated world (the default, comparable with earlier "
        "results); lab: with a real bench's nuisances on top (camera rate, drops and noise, "
        "gel creep, finger slip, temperature, fill error, arm vibration, ...; "
        "sources in docs/formats.md).",
    ),
]


# -- output and execution --------------------------------------------------------------------

Json = Annotated[
    bool,
    typer.Option(
        "--json", help="Print one JSON object on stdout (warnings and progress go to stderr)."
    ),
]
Labels = Annotated[
    list[str],
    typer.Option(
        "--label",
        help="A meta.json label KEY=VALUE (repeatable): liquid=water, height_mm=25, ...",
        show_default=False,
    ),
]
Jobs = Annotated[
    int,
    typer.Option(
        "--jobs",
        "-j",
        min=1,
        help="Worker processes (capped at the CPU cores and the number of trials).",
    ),
]
Dask = Annotated[
    str | None,
    typer.Option(
        "--dask",
        metavar="ADDRESS",
        help="Run the trials on a Dask cluster (scheduler address tcp://HOST:PORT) "
        "instead of local processes.",
        show_default=False,
    ),
]
Plot = Annotated[
    Path | None,
    typer.Option(
        "--plot",
        help="Write a figure (format from the suffix: .png, .pdf, .svg; PNG without one).",
        show_default=False,
    ),
]

# -- signal: video -> u(t) ---------------------------------------------------------------------

DEFAULT_MARKERS = 16

Lowpass = Annotated[
    float,
    typer.Option(
        "--lowpass",
        metavar="HZ",
        help="Low-pass cut-off of the marker motion [Hz] (features --source wrench: of the "
        "wrist forces).",
    ),
]
MarkerLowpass = Annotated[
    float,
    typer.Option("--lowpass", metavar="HZ", help="Low-pass cut-off of the marker motion [Hz]."),
]
"""``--lowpass`` of the commands that only see markers (``live``)."""
Markers = Annotated[
    int,
    typer.Option(
        "--markers",
        metavar="N",
        help="Markers to keep for u(t), across sensors: the ones that move most.",
    ),
]
Sensor = Annotated[
    list[str] | None,
    typer.Option(
        "--sensor",
        metavar="NAME",
        help="Use only this sensor's video (its name: the video's stem, e.g. left); repeat "
        "for several. Default: every sensor.",
        show_default=False,
    ),
]


class TrackingChoice(StrEnum):
    """``--tracking`` (``tracking.gel.TRACKING_CHOICES``)."""

    auto = "auto"
    markers = "markers"
    flow = "flow"


DEFAULT_TRACKING = TrackingChoice.auto
Tracking = Annotated[
    TrackingChoice,
    typer.Option(
        "--tracking",
        help="How the gel's motion is read: auto (printed markers, or the gel's own image "
        "on a markerless gel such as the GelSight Mini's standard gel or DIGIT, found from "
        "the first frame); markers; flow (the markerless way).",
    ),
]


class GelChoice(StrEnum):
    """``--gel`` of the simulator (``sim.sensors.GELS``)."""

    markers = "markers"
    plain = "plain"


Gel = Annotated[
    GelChoice | None,
    typer.Option(
        "--gel",
        help="The simulated gel: markers (printed dots), or plain (markerless: only the "
        "contact's imprint, its edge and the face's texture, moves). Default: the sensor "
        "profile's (markers; plain for digit).",
        show_default=False,
    ),
]

# -- oscillation fit ---------------------------------------------------------------------------

DEFAULT_LOSS = LossChoice.paper
DEFAULT_FIT_MODEL = FitModelChoice(fit_choices.DEFAULT_MODEL)
DEFAULT_BAND_LOW_HZ = 0.3
DEFAULT_BAND_HIGH_HZ = 5.0
DEFAULT_NOISE = NoiseChoice(fit_choices.DEFAULT_NOISE)
DEFAULT_START = "auto"
"""``--start`` when not given (the option's default is None: ``fit --example`` differs)."""


def parse_start(value: str | float | None) -> str | float | None:
    """``--start``: ``auto``, a finite time in seconds, or None (not given: the command's default).

    Raises typer.BadParameter for anything else.
    """
    if value is None:
        return None
    text = str(value).strip().lower()
    if text == DEFAULT_START:
        return DEFAULT_START
    try:
        seconds = float(text)
    except ValueError:
        seconds = math.nan
    if not math.isfinite(seconds):
        raise typer.BadParameter(
            f"{value!r} is neither 'auto' nor a time in seconds (e.g. 1.5)", param_hint="'--start'"
        )
    return seconds


Loss = Annotated[
    LossChoice,
    typer.Option(
        "--loss",
        help="paper: the paper's Σ(u−û)²/(u²+δ), which weighs the late decay; "
        "ls: plain least squares.",
    ),
]
FitModel = Annotated[
    FitModelChoice,
    typer.Option(
        "--model",
        help="auto: the model the data support best (lowest information criterion; the "
        "output names it and says why); amplitude: one mode whose damping grows with its "
        "amplitude (λ is the small-amplitude rate λ0, the same whatever the push); two-mode: "
        "the paper's two damped cosines (one when the data do not support a second); "
        "drifting-line: one mode whose damping and frequency both move with its amplitude "
        "(λ0 and ω0 at small amplitude); amplitude-two-mode: amplitude and a second mode; "
        "single-mode: one damped cosine. auto averages the models the data cannot tell apart "
        "and widens the ± by their spread.",
    ),
]
BandLow = Annotated[
    float,
    typer.Option("--band-low", metavar="HZ", help="Lowest slosh frequency of the fit [Hz]."),
]
BandHigh = Annotated[
    float,
    typer.Option("--band-high", metavar="HZ", help="Highest slosh frequency of the fit [Hz]."),
]
Noise = Annotated[
    NoiseChoice,
    typer.Option(
        "--noise",
        help="Standard errors: jackknife (correlated noise and a blocked jackknife of the "
        "window, the calibrated default), correlated (low-passed noise), or white.",
    ),
]
Start = Annotated[
    str | None,
    typer.Option(
        "--start",
        metavar="auto|SECONDS",
        callback=parse_start,
        help="Where the fitted window starts: auto = the free decay after the push (at its "
        "largest excursion, as extract cuts it), or a time in seconds on the signal's clock "
        "(0 for a signal that starts at the release). [default: auto]",
        show_default=False,
    ),
]


def fit_settings(
    loss: str,
    model: str,
    band_low: float,
    band_high: float,
    noise: str,
    start: str | float | None,
) -> FitSettings:
    """The :class:`~liquidtouch.extraction.FitSettings` of the fit options (SignalError if bad).

    ``start`` None (not given) is ``auto``.
    """
    from liquidtouch.extraction.fit_settings import FitSettings

    start = parse_start(start)
    return FitSettings(
        loss=str(loss),
        model=str(model),
        band_hz=(band_low, band_high),
        noise=str(noise),
        start=DEFAULT_START if start is None else start,
    )


# --- cameras (record, run-trial, live) --------------------------------------------------


class SensorChoice(StrEnum):
    """The camera sensor profiles (``acquire.cameras.PROFILES``), for every command that
    opens cameras: ``record``, ``run-trial`` and ``live``."""

    raw = "raw"
    mini = "mini"
    r15 = "r15"
    digit = "digit"


SensorProfile = Annotated[
    SensorChoice,
    typer.Option(
        "--sensor",
        help="Sensor profile of the cameras: mini (GelSight Mini: MJPG 3280x2464 at 25 fps, "
        "1/7 border cropped, 320x240), r15 (640x480, 30 fps), digit (320x240, 60 fps), raw "
        "(frames as the camera gives them).",
    ),
]
OpenTimeout = Annotated[
    float,
    typer.Option(
        "--open-timeout",
        metavar="SECONDS",
        help="Deadline for opening a network camera stream, as a whole [s].",
    ),
]
ReadTimeout = Annotated[
    float,
    typer.Option(
        "--read-timeout",
        metavar="SECONDS",
        help="Deadline for each frame, as a whole: a camera that delivers none fails [s].",
    ),
]
WarmupTimeout = Annotated[
    float,
    typer.Option(
        "--warmup-timeout",
        metavar="SECONDS",
        help="Deadline for the cameras' whole warm-up after opening, first frame included [s].",
    ),
]


# --- the robot and the live estimate (run-trial, live, rig serve) ------------------------

GripperUrl = Annotated[
    str,
    typer.Option(
        "--gripper", help="Gripper URL: wsg50://HOST[:PORT] (a WSG-50; port 1000) or sim://."
    ),
]
ArmUrl = Annotated[
    str,
    typer.Option(
        "--arm",
        help="Arm URL: ur-rtde://HOST (a UR arm, needs liquidtouch[robot]), sim://HOST:PORT "
        "(the simulated rig) or sim://.",
    ),
]
Cameras = Annotated[
    list[str],
    typer.Option(
        "--camera",
        help="A camera source, repeated (left first): a device index, /dev/videoN, "
        "name:GelSight Mini, an http/rtsp stream URL.",
    ),
]
TrialOut = Annotated[
    Path,
    typer.Option("--out", "-o", file_okay=False, help="Trial directory to create (new or empty)."),
]
ProtocolFile = Annotated[
    Path | None,
    typer.Option(
        "--protocol",
        dir_okay=False,
        help="Protocol TOML file (grasp force, lift, push, hold, start pose, ...); "
        "default: the paper's.",
    ),
]
SensorNames = Annotated[
    list[str],
    typer.Option(
        "--name",
        help="Sensor names, one per camera, in order (default left, right, sensor2, ...).",
        show_default=False,
    ),
]
HoldSeconds = Annotated[
    float | None,
    typer.Option("--seconds", help="Recording after the push [s] (the protocol's hold_s)."),
]
TrialSensor = Annotated[
    SensorChoice | None,
    typer.Option(
        "--sensor",
        help="Sensor profile of the cameras (as record --sensor: mini, r15, digit, raw); "
        "default: the protocol file's camera_profile, else raw.",
        show_default=False,
    ),
]
Recover = Annotated[
    bool,
    typer.Option(
        "--recover",
        help="Start from any state: put a held bottle down (carried back over its start, "
        "lowered, released), open the fingers, move the arm to its start pose; then run "
        "the trial.",
    ),
]
LiveModel = Annotated[
    Path | None,
    typer.Option(
        "--model",
        help="Model file (from train or classify): predict its targets (with their std) or "
        "the liquid while the frames come in.",
        show_default=False,
    ),
]
UntilStd = Annotated[
    list[str],
    typer.Option(
        "--until-std",
        metavar="TARGET=STD",
        help="Stop once TARGET's std is below STD (repeatable; all must hold): decay_rate, "
        "angular_frequency or a regression model's target, e.g. height_mm=0.5.",
        show_default=False,
    ),
]
MaxPushes = Annotated[
    int | None,
    typer.Option(
        "--max-pushes",
        help="Push again (back and forth) after a hold whose answer misses an --until-std "
        "target, up to N pushes; the ring-downs are combined, and a target no push can "
        "reach here ends the trial with 'cannot tell' (needs --model, --until-std; default: "
        "the protocol file's max_pushes, else 1).",
        show_default=False,
    ),
]
Plan = Annotated[
    bool,
    typer.Option(
        "--plan",
        help="Propose the push (axis, distance, speed, acceleration) for the container "
        "(--label container=NAME or the protocol file's) and the first --until-std target, "
        "and exit: nothing is connected.",
    ),
]
Serve = Annotated[
    str | None,
    typer.Option(
        "--serve",
        metavar="HOST:PORT",
        help="Show the live estimate in a browser at http://HOST:PORT (port 0: any free port).",
        show_default=False,
    ),
]
