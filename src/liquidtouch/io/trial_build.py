"""The directory of one new trial: its name in the dataset and its files, built aside.

:func:`check_trial_name` / :func:`default_trial_name` name the trial;
:func:`build_from_files` (video files or image folders, copied or hard-linked),
:func:`build_from_markers` (GelSight marker CSVs stored as ``tracks.npz``) and
:func:`build_from_bag` (a ROS bag's image topics written as image folders) fill a
temporary directory and say what ``meta.json`` must record (:class:`BuiltTrial`).
:func:`~liquidtouch.io.recordings.add_trial` renames the directory into place.
"""

from __future__ import annotations

import errno
import math
import os
import re
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from liquidtouch._core.checks import MAX_RATE_HZ, MIN_FIT_DURATION_S, MIN_FIT_SAMPLES
from liquidtouch._core.progress import progress_bar
from liquidtouch.errors import DatasetError
from liquidtouch.io.dataset import FEATURES_NAME, MANIFEST_NAME, META_NAME, trial_path
from liquidtouch.io.frame_times import TIMESTAMPS_NAME, read_folder_timestamps
from liquidtouch.io.frames import IMAGE_SUFFIXES, count_frames, image_files, video_info
from liquidtouch.io.image_size import check_image_file
from liquidtouch.io.labels import MAX_NAME
from liquidtouch.io.marker_csv import read_marker_csv
from liquidtouch.io.rosbag import import_bag
from liquidtouch.io.trial_tracks import TRACKS_NAME
from liquidtouch.tracking.clock import check_consistent, fit_frame_period
from liquidtouch.tracking.tracks import check_frame_count, save_tracks

TRIAL_PREFIX = "trial-"
RESERVED_NAMES = (MANIFEST_NAME, FEATURES_NAME, META_NAME)
"""Names a trial (or its top folder) cannot take: the dataset's own files."""
RESERVED_SUFFIXES = (".csv", ".json")
"""Nor names ending so (the dataset's tables and the files ``features`` writes beside them)."""
_NAME_PART = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_SENSOR_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")


def check_trial_name(root: Path, name: str, existing: Sequence[str]) -> str:
    """``name`` if it can be a new trial of the dataset ``root`` (``existing``: its trials).

    Raises :class:`DatasetError` for a bad, reserved, listed, nesting or existing name.
    """
    parts = name.split("/")
    if (
        not name
        or len(name) > MAX_NAME
        or not all(_NAME_PART.fullmatch(p) and p not in (".", "..") for p in parts)
    ):
        raise DatasetError(
            f"trial name {name!r}: use letters, digits, '.', '_' and '-' (not first), with "
            "'/' between folder levels, e.g. water/h25-run1"
        )
    trial_path(root, name)
    top = parts[0]
    if top in RESERVED_NAMES or top.lower().endswith(RESERVED_SUFFIXES):
        raise DatasetError(
            f"trial name {name!r}: {top!r} is reserved for the dataset's own files "
            f"({', '.join(RESERVED_NAMES)}, *{', *'.join(RESERVED_SUFFIXES)}); choose `name`"
        )
    for depth in range(1, len(parts)):
        folder = root.joinpath(*parts[:depth])
        if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
            raise DatasetError(
                f"trial name {name!r}: {folder} is not a folder of trials; choose `name`"
            )
    if name in existing:
        raise DatasetError(f"{root / MANIFEST_NAME} already lists trial {name!r}; choose `name`")
    for other in existing:
        if name.startswith(other + "/") or other.startswith(name + "/"):
            raise DatasetError(
                f"trial {name!r} would nest with trial {other!r}; trials cannot contain trials"
            )
    if (root / name).exists() or (root / name).is_symlink():
        raise DatasetError(f"{root / name} already exists; choose another `name`")
    return name


def default_trial_name(root: Path, existing: Sequence[str]) -> str:
    """The first free ``trial-0001``, ``trial-0002``, ... of the dataset ``root``."""
    taken = set(existing)
    k = 1
    while f"{TRIAL_PREFIX}{k:04d}" in taken or (root / f"{TRIAL_PREFIX}{k:04d}").exists():
        k += 1
    return f"{TRIAL_PREFIX}{k:04d}"


def check_sensor_names(names: Sequence[str]) -> list[str]:
    """``names`` as strings if each is a valid sensor name and they differ (else DatasetError)."""
    names = [str(n) for n in names]
    for name in names:
        if not _SENSOR_NAME.fullmatch(name) or len(name) > 100:
            raise DatasetError(
                f"sensor name {name!r}: use letters, digits, '_' and '-' (e.g. left, right)"
            )
    if len(set(names)) < len(names):
        raise DatasetError(f"sensor names must differ: {', '.join(names)}")
    return names


@dataclass
class _Source:
    path: Path
    folder: bool
    fps: float | None  # the video stream's rate, or the rate of a folder's timestamps.csv
    frames: int
    images: list[Path] = field(default_factory=list)
    has_timestamps: bool = False


def _inspect_source(path: Path) -> _Source:

    if not path.exists():
        raise DatasetError(f"{path} does not exist; give video files or image folders")
    if path.is_dir():
        if (path / META_NAME).is_file():
            raise DatasetError(
                f"{path} is a trial directory; give its videos (or add it to the manifest by hand)"
            )
        files = image_files(path)
        check_image_frames(path, files)
        stamps = read_folder_timestamps(path, len(files))
        fps = None
        if stamps is not None and len(stamps) > 1:  # the rate extract fits (bursts too)
            fps = fit_frame_period(stamps).fps
        return _Source(path, True, fps, len(files), files, (path / TIMESTAMPS_NAME).is_file())
    if path.suffix.lower() in IMAGE_SUFFIXES:
        raise DatasetError(
            f"{path} is one image; give the folder of a sensor's images (or its video)"
        )
    info = video_info(path)
    # the container's count, else its packets (nothing decoded): what extract will track
    frames = info.frames or count_frames(path)
    check_frame_count(frames, f"video {path}", DatasetError)
    return _Source(path, False, info.fps if info.fps > 0 else None, frames)


def check_fit_length(frames: int, duration_s: float, what: str) -> None:
    """Refuse (:class:`DatasetError`) a sensor's recording that no feature can come from:
    fewer frames than the oscillation fit takes (:data:`MIN_FIT_SAMPLES`) or shorter than
    its shortest signal (:data:`MIN_FIT_DURATION_S`, ``duration_s`` from the first frame to
    the last), so that ``dataset add`` says so instead of ``features`` later."""
    if frames < MIN_FIT_SAMPLES or not duration_s >= MIN_FIT_DURATION_S:
        raise DatasetError(
            f"{what} holds {frames} frames over {duration_s:.3g} s; the fit needs at least "
            f"{MIN_FIT_SAMPLES} frames over {MIN_FIT_DURATION_S:g} s (a recording is the push "
            "and its ring-down: ~15 s)"
        )


def check_image_frames(folder: Path, files: Sequence[Path]) -> None:
    """The checks ``extract`` would make on reading a sensor's image folder, made cheaply
    up front: its count of images (:func:`~liquidtouch.tracking.tracks.check_frame_count`),
    each declaring (in its header) a size
    within :data:`~liquidtouch.io.image_size.MAX_FRAME_PIXELS`, all of one size.
    :class:`DatasetError` names the first offender."""
    check_frame_count(len(files), f"image folder {folder}", DatasetError)
    size = None
    for file in files:
        dims = check_image_file(file, DatasetError)
        if size is None:
            size, first = dims, file
        elif dims != size:
            raise DatasetError(
                f"image {file} is {dims[0]}x{dims[1]} but {first.name} is {size[0]}x{size[1]}; "
                "all frames of a sensor must have one size"
            )


LINK_FAILURES = {
    errno.EXDEV: "on another file system",
    errno.EMLINK: "at the file system's hard-link limit",
    errno.EPERM: "not allowed to be hard-linked here",
    errno.EACCES: "not allowed to be hard-linked here",
}
"""Why ``os.link`` failed, by errno (the file is copied instead)."""


def _place(src: Path, dst: Path, link: bool, reasons: set[str]) -> bool:
    """Hard-link (if ``link``) or copy ``src`` to ``dst`` (a symlink: what it points to);
    True if it was linked. Why a link failed goes into ``reasons``."""
    src = src.resolve()  # a symlinked recording: its file, never the link itself
    if link:
        try:
            os.link(src, dst)
            return True
        except OSError as exc:  # copied instead; the reason is reported
            reasons.add(LINK_FAILURES.get(exc.errno, exc.strerror or str(exc)))
    shutil.copy2(src, dst)
    return False


def check_fps(fps: float | None) -> float | None:
    """``fps`` [Hz] as a float (None stays None); DatasetError unless positive and finite."""
    if fps is None:
        return None
    try:
        value = float(fps)
    except (TypeError, ValueError):
        value = math.nan
    if not 0 < value <= MAX_RATE_HZ:
        raise DatasetError(
            f"the frame rate (`fps`) must be a positive number in Hz up to {MAX_RATE_HZ:g}, "
            f"got {str(fps)[:40]}"
        )
    return value


@dataclass
class BuiltTrial:
    """What a builder put in the trial directory and what ``meta.json`` must record.

    ``sensors``: the ``meta.json`` entries (files or folders); ``names``: the sensor
    names; ``fps`` [Hz]; ``tracks``: the tracks file, if any; ``source``: what was
    imported; ``linked``/``copied``: file counts.
    """

    sensors: list[str]
    names: list[str]
    fps: float
    tracks: str | None = None
    source: dict[str, object] = field(default_factory=dict)
    linked: int = 0
    copied: int = 0
    warnings: list[str] = field(default_factory=list)


def build_from_files(
    tmp: Path, paths: list[Path], names: list[str] | None, fps: float | None, link: bool
) -> BuiltTrial:
    """Copy (or, with ``link``, hard-link) video files / image folders into ``tmp``.

    One input per sensor; ``names`` default to the file or folder stems. ``fps``
    [Hz] default: the first video's stream rate, or a folder's ``timestamps.csv`` rate.
    """

    items = [_inspect_source(p) for p in paths]
    seen: dict[object, Path] = {}
    for item in items:
        stat = item.path.stat()
        if (stat.st_dev, stat.st_ino) in seen:
            raise DatasetError(
                f"{seen[(stat.st_dev, stat.st_ino)]} and {item.path} are the same recording; "
                "give each sensor's video once"
            )
        seen[(stat.st_dev, stat.st_ino)] = item.path
    names = names or check_sensor_names([_stem(it.path) for it in items])
    warnings: list[str] = []
    untimed = [it.path for it in items if it.folder and not it.has_timestamps]
    if fps is None:
        if untimed:
            raise DatasetError(
                f"image folder {untimed[0]} has no {TIMESTAMPS_NAME}: give the camera's frame "
                f"rate with `fps`, or add a {TIMESTAMPS_NAME} (t_s column, one row per image)"
            )
        rates = [it.fps for it in items if it.fps]
        if not rates:
            raise DatasetError(f"the frame rate of {paths[0]} is unknown; give it with `fps`")
        rate = float(rates[0])
    else:
        rate = fps
        for it in items:
            if not it.folder and it.fps and abs(it.fps - fps) > 0.01 * it.fps:
                warnings.append(
                    f"`fps` {fps:g} differs from the {it.fps:g} fps of {it.path.name}'s video "
                    "stream; meta.json records `fps` (videos are timed by their own timestamps)"
                )
    for it in items:  # timed as extract will time it: its own clock, else `fps`
        own = it.fps or rate
        check_fit_length(it.frames, (it.frames - 1) / own, f"{it.path} at {own:g} fps")
    entries, linked, copied = [], 0, 0
    reasons: set[str] = set()
    for it, sensor in zip(items, names, strict=True):
        if it.folder:
            entry = sensor
            (tmp / entry).mkdir()
            files = [*it.images, *([it.path / TIMESTAMPS_NAME] if it.has_timestamps else [])]
            for file in files:
                done = _place(file, tmp / entry / file.name, link, reasons)
                linked, copied = linked + done, copied + (not done)
        else:
            entry = sensor + it.path.suffix.lower()
            done = _place(it.path, tmp / entry, link, reasons)
            linked, copied = linked + done, copied + (not done)
        entries.append(entry)
    if link and copied:
        warnings.append(
            f"copied {copied} file(s) that could not be hard-linked ({'; '.join(sorted(reasons))})"
        )
    source = {"inputs": [p.name for p in paths]}
    return BuiltTrial(entries, names, rate, None, source, linked, copied, warnings)


def _stem(path: Path) -> str:
    stem = path.stem if path.is_file() else path.name
    return (
        "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in stem).lstrip("_-") or "sensor"
    )


def build_from_markers(
    tmp: Path, paths: list[Path], names: list[str] | None, fps: float | None
) -> BuiltTrial:
    """Read GelSight marker CSVs (one per sensor) and store them as ``tmp/tracks.npz``.

    ``fps`` [Hz] times files without a ``t_s`` column; default: the rate fitted to the tracks.
    """

    names = names or check_sensor_names([_stem(p) for p in paths])
    tracks = [read_marker_csv(p, fps=fps, sensor=n) for p, n in zip(paths, names, strict=True)]
    for tr in tracks:
        check_frame_count(len(tr.t), f"marker CSV of sensor {tr.sensor}", DatasetError)
        check_fit_length(len(tr.t), float(tr.t[-1] - tr.t[0]), f"marker CSV of sensor {tr.sensor}")
    check_consistent(tracks)
    rate = fps if fps is not None else fit_frame_period(tracks[0].t).fps
    save_tracks(tmp / TRACKS_NAME, tracks)
    source = {"inputs": [p.name for p in paths]}
    return BuiltTrial([], names, rate, TRACKS_NAME, source)


def build_from_bag(
    tmp: Path,
    bag: Path,
    topics: Sequence[str],
    names: list[str] | None,
    fps: float | None,
    time_source: str,
    progress: bool,
) -> BuiltTrial:
    """Write the image ``topics`` of a ROS ``bag`` as image folders in ``tmp``.

    ``fps`` [Hz] default: the first topic's median rate; ``time_source``: ``header``
    or ``bag`` stamps; ``progress``: a progress bar on stderr.
    """

    with progress_bar(f"importing {bag.name}", None, enabled=progress) as advance:
        imported = import_bag(
            bag, tmp, topics=topics, names=names, time_source=time_source, on_message=advance
        )
    rate = fps if fps is not None else imported[0].fps
    for topic in imported:
        check_fit_length(topic.frames, (topic.frames - 1) / rate, f"topic {topic.topic}")
    source = {
        "inputs": [bag.name],
        "topics": [t.topic for t in imported],
        "time_source": time_source,
    }
    folders = [t.folder for t in imported]
    return BuiltTrial(folders, folders, rate, None, source)
