"""Building datasets from one's own recordings, without writing ``meta.json`` by hand.

:func:`init_dataset` makes an empty dataset directory
(:mod:`liquidtouch.io.dataset_dir`); :func:`add_trial` adds one trial to it —
video files or image folders (copied, or hard-linked), GelSight marker CSVs
(stored as ``tracks.npz``) or the image topics of a ROS bag (written as image
folders; :mod:`liquidtouch.io.trial_build`) — with validated labels
(:mod:`liquidtouch.io.labels`) and ``meta.json``, and appends the trial's row to
``manifest.csv``.

**All or nothing.** The trial is built in a hidden temporary directory in the
dataset, checked as the extraction will read it, renamed into place, and its row
appended to the manifest (read, append, atomic rewrite; existing rows are kept
byte for byte). A failure or Ctrl-C at any point leaves the dataset as it was.
Concurrent ``add``s to one dataset are serialised by a lock on the marker file.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from liquidtouch._core import atomic
from liquidtouch.errors import DatasetError, LiquidTouchError
from liquidtouch.io.dataset import TrialMeta, read_trial_meta, write_trial_meta
from liquidtouch.io.dataset_dir import (
    append_manifest_row,
    dataset_lock,
    is_dataset,
    manifest_rows,
)
from liquidtouch.io.labels import check_labels
from liquidtouch.io.sources import resolve_sources
from liquidtouch.io.trial_build import (
    build_from_bag,
    build_from_files,
    build_from_markers,
    check_fps,
    check_sensor_names,
    check_trial_name,
    default_trial_name,
)
from liquidtouch.io.trial_tracks import read_trial_tracks

__all__ = ["AddedTrial", "add_trial"]

_SPLIT = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")


@dataclass
class AddedTrial:
    """What :func:`add_trial` did."""

    root: Path
    trial: str
    path: Path
    kind: str  # "files", "markers" or "rosbag"
    sensors: list[str]
    fps: float
    labels: dict[str, object]
    split: str | None
    n_trials: int
    linked: int = 0
    copied: int = 0
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, object]:
        """JSON-ready summary."""
        return {
            "dataset": str(self.root),
            "trial": self.trial,
            "path": str(self.path),
            "kind": self.kind,
            "sensors": self.sensors,
            "fps": self.fps,
            "split": self.split,
            "labels": {k: v for k, v in self.labels.items() if v is not None},
            "n_trials": self.n_trials,
            "linked": self.linked,
            "copied": self.copied,
            "warnings": self.warnings,
        }


def add_trial(
    root: str | os.PathLike[str],
    sources: Sequence[str | os.PathLike[str]] = (),
    *,
    markers: Sequence[str | os.PathLike[str]] = (),
    bag: str | os.PathLike[str] | None = None,
    topics: Sequence[str] = (),
    labels: Mapping[str, object] | None = None,
    split: str | None = None,
    name: str | None = None,
    fps: float | None = None,
    link: bool = False,
    sensor_names: Sequence[str] | None = None,
    time_source: str = "header",
    progress: bool = False,
) -> AddedTrial:
    """Add one trial to the dataset ``root`` and its manifest; return what was done.

    Give exactly one kind of input: ``sources`` (video files or image folders, one
    per sensor), ``markers`` (GelSight marker CSVs, one per sensor) or ``bag``
    (a ROS bag; ``topics``: its image topics, default all). ``labels``: label
    values (strings or numbers; see the module doc). ``split``: the manifest's
    ``split`` column (e.g. ``train``, ``test``). ``name``: the trial's path in the
    dataset (default ``trial-0001``, ``trial-0002``, ...). ``fps``: the frame rate
    [Hz] for ``meta.json`` (default: the first video's stream rate, or the rate of
    an image folder's ``timestamps.csv``); required for image folders without
    ``timestamps.csv`` and marker CSVs without a ``t_s`` column. ``link``:
    hard-link videos and images instead of copying them (copied where a link is
    impossible, e.g. across file systems). ``sensor_names``: names for the
    sensors, one per input (default: the file or folder stems, or the topic
    parts). ``time_source``: bag only, ``header`` or ``bag`` stamps.

    Raises :class:`~liquidtouch.errors.LiquidTouchError` (nothing is written) for
    any bad input.
    """
    root = Path(root)
    if isinstance(sources, str | os.PathLike):
        sources = [sources]
    if isinstance(markers, str | os.PathLike):
        markers = [markers]
    if isinstance(topics, str):
        topics = [topics]
    if not root.is_dir() or not is_dataset(root):
        raise DatasetError(
            f"{root} is not a dataset directory; create it with 'liquidtouch dataset init {root}'"
        )
    kinds = [k for k, given in (("files", sources), ("markers", markers), ("rosbag", bag)) if given]
    if len(kinds) != 1:
        raise DatasetError(
            "give the recording as video files or image folders, as `markers` CSV files, or "
            "as a `bag`" + (f" (got {' and '.join(kinds)})" if kinds else "")
        )
    kind = kinds[0]
    if topics and kind != "rosbag":
        raise DatasetError("`topics` goes with `bag`")
    if time_source != "header" and kind != "rosbag":
        raise DatasetError("`time_source` goes with `bag`")
    if link and kind != "files":
        raise DatasetError("`link` applies to video files and image folders only")
    fps = check_fps(fps)
    if split is not None and not _SPLIT.fullmatch(str(split)):
        raise DatasetError(f"split {split!r}: use a word such as train or test")
    n_inputs = len(sources) if kind == "files" else len(markers) if kind == "markers" else None
    if sensor_names is not None:
        sensor_names = check_sensor_names(sensor_names)
        count = n_inputs if n_inputs is not None else len(topics)
        if n_inputs is None and not topics:
            raise DatasetError("`sensor_names` with `bag` needs the `topics` of each sensor")
        if len(sensor_names) != count:
            raise DatasetError(f"{len(sensor_names)} sensor name(s) for {count} input(s)")
    with dataset_lock(root):
        header, rows = manifest_rows(root)
        column = header.index("trial") if header else 0
        existing = [row[column] for row in rows if len(row) > column]
        known = {
            key: [row[header.index(key)] for row in rows if len(row) > header.index(key)]
            for key in ("liquid", "container")
            if key in header
        }
        checked, warnings = check_labels(
            labels or {}, {k: [v for v in vs if v] for k, vs in known.items()}
        )
        name = check_trial_name(
            root, name if name is not None else default_trial_name(root, existing), existing
        )
        tmp = Path(tempfile.mkdtemp(prefix=".add.", suffix=".tmp", dir=root))
        try:
            os.chmod(tmp, 0o777 & ~_umask())
            if kind == "files":
                built = build_from_files(tmp, [Path(s) for s in sources], sensor_names, fps, link)
            elif kind == "markers":
                built = build_from_markers(tmp, [Path(m) for m in markers], sensor_names, fps)
            else:
                built = build_from_bag(
                    tmp,
                    Path(bag),
                    topics,
                    sensor_names,
                    fps,
                    time_source,
                    progress,  # type: ignore[arg-type]
                )
            warnings += built.warnings
            meta = TrialMeta(
                fps=built.fps,
                sensors=built.sensors,
                tracks=built.tracks,
                **checked,
                source={"kind": kind, **built.source},
            )
            write_trial_meta(tmp, meta)
            target = root / name
            try:
                _check_trial(tmp, kind)
            except LiquidTouchError as exc:  # name the trial, not the hidden folder
                raise type(exc)(str(exc).replace(str(tmp), str(target))) from None
            row = {"trial": name, **({"split": split} if split is not None else {}), **checked}
            with atomic.deferred_interrupt():
                made: list[Path] = []
                try:
                    _make_parents(root, target, made)
                    os.rename(tmp, target)
                    n_trials = append_manifest_row(root, header, rows, row)
                except BaseException:
                    shutil.rmtree(target, ignore_errors=True)
                    for folder in reversed(made):  # the folders this add created, deepest first
                        with contextlib.suppress(OSError):
                            folder.rmdir()
                    raise
        finally:
            if tmp.exists():
                shutil.rmtree(tmp, ignore_errors=True)
    return AddedTrial(
        root=root,
        trial=name,
        path=root / name,
        kind=kind,
        sensors=built.names,
        fps=built.fps,
        labels=checked,
        split=split,
        n_trials=n_trials,
        linked=built.linked,
        copied=built.copied,
        warnings=warnings,
    )


def _make_parents(root: Path, target: Path, made: list[Path]) -> None:
    """Create the folders between ``root`` and ``target``; list those it created in ``made``."""
    folder = root
    for part in target.relative_to(root).parts[:-1]:
        folder = folder / part
        if not folder.is_dir():
            folder.mkdir()
            made.append(folder)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _check_trial(tmp: Path, kind: str) -> None:
    """Read the new trial as the extraction will (sources, frame rates, tracks)."""

    meta = read_trial_meta(tmp)
    if kind == "markers":
        read_trial_tracks(tmp, meta)
    else:
        resolve_sources(tmp)
