"""``liquidtouch dataset``: build a dataset from your own recordings, no JSON by hand.

``dataset init DIR`` makes an empty dataset; ``dataset add DIR ...`` adds one trial
(videos or image folders, GelSight marker CSVs, or the image topics of a ROS bag)
with its labels, a validated ``meta.json`` and its row in ``manifest.csv``. The
work is done by :mod:`liquidtouch.io.recordings` (importers:
:mod:`liquidtouch.io.marker_csv`, :mod:`liquidtouch.io.rosbag`).
"""

from __future__ import annotations

import json
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from liquidtouch.cli import options

dataset_app = typer.Typer(
    help="Build a dataset from your own recordings: init a directory, then add trials.",
    no_args_is_help=True,
)


class TimeSourceChoice(StrEnum):
    """``dataset add --time-source`` (``io.rosbag.TIME_SOURCES``)."""

    header = "header"
    bag = "bag"


DatasetDir = Annotated[
    Path,
    typer.Argument(help="The dataset directory (made by 'dataset init').", show_default=False),
]

RecordingSources = Annotated[
    list[Path] | None,
    typer.Argument(
        help="Video files or image folders of the recording, one per sensor (or give "
        "--markers or --bag instead).",
        show_default=False,
    ),
]

LabelOption = Annotated[
    list[str] | None,
    typer.Option(
        "--label",
        "-l",
        help="A label KEY=VALUE, repeated: liquid, container, height_mm, sugar_concentration, "
        "viscosity_cst, log10_viscosity_cst, temperature_c.",
        show_default=False,
    ),
]

Split = Annotated[
    str | None,
    typer.Option(
        "--split", help="The manifest's split column, e.g. train or test.", show_default=False
    ),
]

TrialName = Annotated[
    str | None,
    typer.Option(
        "--name",
        help="The trial's path in the dataset, e.g. water/h25-run1 (default: trial-0001, ...).",
        show_default=False,
    ),
]

TrialFps = Annotated[
    float | None,
    typer.Option(
        "--fps",
        help="Frame rate [Hz] for meta.json: needed for image folders without timestamps.csv "
        "and marker CSVs without a t_s column (default: the video stream's rate).",
        show_default=False,
    ),
]

Link = Annotated[
    bool,
    typer.Option(
        "--link",
        help="Hard-link the videos and images instead of copying them (copied where a link "
        "is impossible, e.g. another file system).",
    ),
]

MarkerCsvs = Annotated[
    list[Path] | None,
    typer.Option(
        "--markers",
        help="A GelSight marker-location CSV (frame, row, col, x0, y0, x, y), one per sensor, "
        "repeated: stored as tracks.npz, used instead of videos.",
        show_default=False,
    ),
]

Bag = Annotated[
    Path | None,
    typer.Option(
        "--bag",
        help="A ROS 1 .bag or ROS 2 bag (directory, .db3 or .mcap) with image topics "
        "(needs: pip install 'liquidtouch[ros]').",
        show_default=False,
    ),
]

Topics = Annotated[
    list[str] | None,
    typer.Option(
        "--topic",
        help="An image topic of --bag, one per sensor, repeated (default: every "
        "sensor_msgs/Image and CompressedImage topic).",
        show_default=False,
    ),
]

SensorNames = Annotated[
    list[str] | None,
    typer.Option(
        "--sensor-name",
        help="Names of the sensors, one per video, CSV or topic, in order (default: the "
        "file names, or the parts of the topic names that differ).",
        show_default=False,
    ),
]

TimeSource = Annotated[
    TimeSourceChoice,
    typer.Option(
        "--time-source",
        help="--bag frame times: the messages' header stamps, or the bag's record times.",
    ),
]


@dataset_app.command("init")
def init_command(
    directory: Path = typer.Argument(
        ..., help="Dataset directory to create (new, or an empty directory).", show_default=False
    ),
    as_json: options.Json = False,
) -> None:
    """Create an empty dataset directory; add trials with 'liquidtouch dataset add'.

    The directory holds only the marker file .liquidtouch-dataset until the first
    'dataset add' writes manifest.csv.
    """
    from liquidtouch.io.dataset_dir import init_dataset

    root = init_dataset(directory)
    if as_json:
        typer.echo(json.dumps({"dataset": str(root)}))
        return
    typer.echo(
        f"created the empty dataset {root}; add trials with: liquidtouch dataset add {root} "
        "left.mp4 right.mp4 --label liquid=water --label height_mm=25"
    )


@dataset_app.command("add")
def add_command(
    directory: DatasetDir,
    sources: RecordingSources = None,
    label: LabelOption = None,
    split: Split = None,
    name: TrialName = None,
    fps: TrialFps = None,
    link: Link = False,
    markers: MarkerCsvs = None,
    bag: Bag = None,
    topic: Topics = None,
    sensor_name: SensorNames = None,
    time_source: TimeSource = TimeSourceChoice.header,
    as_json: options.Json = False,
) -> None:
    """Add one trial to a dataset: copy the recording in, write meta.json, extend manifest.csv.

    The trial is built in a temporary directory, checked as 'features' will read
    it, and renamed into place; the manifest is then rewritten atomically. A
    failure leaves the dataset as it was.
    """
    from liquidtouch.cli.format import warn
    from liquidtouch.io.labels import parse_label_options
    from liquidtouch.io.recordings import add_trial

    added = add_trial(
        directory,
        sources or (),
        markers=markers or (),
        bag=bag,
        topics=topic or (),
        labels=parse_label_options(label or []),
        split=split,
        name=name,
        fps=fps,
        link=link,
        sensor_names=sensor_name or None,
        time_source=time_source.value,
        progress=not as_json,
    )
    for warning in added.warnings:
        warn(warning)
    if as_json:
        typer.echo(json.dumps(added.to_dict()))
        return
    _print_added(added)


def _print_added(added) -> None:
    """What ``dataset add`` added, in two lines."""
    labels = ", ".join(
        f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
        for k, v in added.labels.items()
        if v is not None
    )
    what = {"files": "sensors", "markers": "marker tracks of", "rosbag": "image topics as"}
    typer.echo(
        f"added {added.trial} to {added.root}: {what[added.kind]} {', '.join(added.sensors)}, "
        f"{added.fps:g} fps{'; ' + labels if labels else ''}\n"
        f"  {added.root / 'manifest.csv'} lists {added.n_trials} trial(s)"
    )


def register(app: typer.Typer) -> None:
    """Register the ``dataset`` command group on ``app``."""
    app.add_typer(dataset_app, name="dataset")
