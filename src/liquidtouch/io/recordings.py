"""Building datasets from one's own recordings, without writing ``meta.json`` by hand.

:func:`init_dataset` makes an empty dataset directory; :func:`add_trial` adds one
trial to it — video files or image folders (copied, or hard-linked), GelSight
marker CSVs (stored as ``tracks.npz``) or the image topics of a ROS bag (written
as image folders) — with a validated ``meta.json``, and appends the trial's row to
``manifest.csv``.

**Empty datasets.** ``manifest.csv`` must list at least one trial, so a new
dataset holds only the marker file ``.liquidtouch-dataset`` (JSON); the first
:func:`add_trial` writes ``manifest.csv``. :func:`add_trial` accepts a directory
with the marker or with a ``manifest.csv`` (e.g. a simulated dataset).

**All or nothing.** The trial is built in a hidden temporary directory in the
dataset, checked as the extraction will read it, renamed into place, and its row
appended to the manifest (read, append, atomic rewrite; existing rows are kept
byte for byte). A failure or Ctrl-C at any point leaves the dataset as it was.
Concurrent ``add``s to one dataset are serialised by a lock on the marker file.

**Labels** (``--label key=value``): the label columns
(:data:`~liquidtouch.io.dataset.LABEL_COLUMNS`) only. ``liquid`` and ``container``
may be any name (a real recording may use liquids the simulator does not know),
but a name that differs from a catalogue name or from one already in the dataset
only in case, spaces, ``_`` or ``-`` is refused (it would split one class in two).
Numeric labels must be finite numbers (``height_mm`` and ``viscosity_cst`` > 0,
``sugar_concentration`` >= 0, ``temperature_c`` above absolute zero).
``log10_viscosity_cst`` is derived from ``viscosity_cst`` and vice versa; given
both, they must agree.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import shutil
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from liquidtouch.errors import DatasetError
from liquidtouch.io import atomic
from liquidtouch.io.dataset import (
    FEATURES_NAME,
    LABEL_COLUMNS,
    MANIFEST_NAME,
    META_NAME,
    NUMERIC_LABELS,
    TrialMeta,
    read_manifest,
    read_trial_meta,
    trial_path,
    write_trial_meta,
)

DATASET_MARKER = ".liquidtouch-dataset"
"""Marker file of a dataset directory made by :func:`init_dataset` (also the ``add`` lock)."""
DATASET_FORMAT = {"format": "liquidtouch-dataset", "format_version": 1}
TRIAL_PREFIX = "trial-"
_NAME_PART = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_SENSOR_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")
_SPLIT = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]*")
_MAX_NAME = 200
#: ``viscosity_cst`` and ``log10_viscosity_cst`` given together must agree this well (log10)
LOG10_TOLERANCE = 1e-3
_POSITIVE = {"height_mm", "viscosity_cst"}
_NON_NEGATIVE = {"sugar_concentration"}


# -- dataset directory -----------------------------------------------------------------------


def init_dataset(root: str | os.PathLike[str]) -> Path:
    """Create the empty dataset directory ``root`` (new, or an existing empty directory).

    Writes only the marker file :data:`DATASET_MARKER`; :func:`add_trial` writes
    ``manifest.csv`` with the first trial. Raises :class:`DatasetError` if
    ``root`` is already a dataset, a file, or a directory holding other files.
    """
    root = Path(root)
    if is_dataset(root):
        raise DatasetError(f"{root} is already a dataset directory; add trials to it")
    if root.exists() and not root.is_dir():
        raise DatasetError(f"{root} exists and is not a directory")
    if root.is_dir() and any(root.iterdir()):
        raise DatasetError(
            f"{root} is not empty; give a new or empty directory for the dataset (the "
            "recordings to add can stay where they are)"
        )
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DatasetError(f"cannot create {root}: {exc.strerror or exc}") from None
    atomic.write_text(root / DATASET_MARKER, json.dumps(DATASET_FORMAT) + "\n")
    return root


def is_dataset(root: str | os.PathLike[str]) -> bool:
    """Whether ``root`` is a dataset directory: it holds ``manifest.csv`` or the marker file."""
    root = Path(root)
    return (root / MANIFEST_NAME).is_file() or (root / DATASET_MARKER).is_file()


@contextlib.contextmanager
def _dataset_lock(root: Path) -> Iterator[None]:
    """Hold an exclusive lock on the dataset's marker file (created if missing)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: no lock
        yield
        return
    marker = root / DATASET_MARKER
    with open(marker, "a+", encoding="utf-8") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            if handle.tell() == 0:  # a dataset made by the simulator: mark it too
                handle.write(json.dumps(DATASET_FORMAT) + "\n")
                handle.flush()
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _manifest_rows(root: Path) -> tuple[list[str], list[list[str]]]:
    """Header and rows of ``manifest.csv`` as written (strings), validated; empty if none."""
    import csv

    path = root / MANIFEST_NAME
    if not path.exists():
        return [], []
    read_manifest(root)  # the usual checks: parses, a trial column, unique trials
    with path.open(encoding="utf-8", newline="") as handle:
        rows = [row for row in csv.reader(handle) if any(cell.strip() for cell in row)]
    return rows[0], rows[1:]


def _format(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _write_manifest(root: Path, header: list[str], rows: list[list[str]], new: dict) -> int:
    """Append the row ``new`` to the manifest (new columns added, empty in old rows); atomic."""
    import csv
    import io

    header = list(header) or ["trial"]
    header += [key for key in new if key not in header]
    width = len(header)
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    for row in rows:
        writer.writerow([*row, *[""] * (width - len(row))])
    writer.writerow([_format(new.get(key)) for key in header])
    atomic.write_text(root / MANIFEST_NAME, out.getvalue())
    read_manifest(root)  # what was written reads back (it was built from checked values)
    return len(rows) + 1


# -- labels ----------------------------------------------------------------------------------


def parse_label_options(items: Sequence[str]) -> dict[str, str]:
    """``["liquid=water", "height_mm=25"]`` → ``{"liquid": "water", "height_mm": "25"}``."""
    labels: dict[str, str] = {}
    for item in items:
        key, sep, value = str(item).partition("=")
        key = key.strip()
        if not sep or not key:
            raise DatasetError(f"--label {item!r} must be KEY=VALUE, e.g. --label liquid=water")
        if key in labels:
            raise DatasetError(f"label {key} is given twice")
        labels[key] = value.strip()
    return labels


def _normal(name: str) -> str:
    return re.sub(r"[\s_-]+", "-", name.strip().lower())


def check_labels(
    labels: Mapping[str, object], known: Mapping[str, Sequence[str]] | None = None
) -> tuple[dict[str, object], list[str]]:
    """Validated labels (all :data:`LABEL_COLUMNS`, ``None`` when not given) and warnings.

    ``known``: names already used per name column (``liquid``, ``container``),
    e.g. those of the dataset's manifest. See the module doc for the rules.
    """
    import difflib

    from liquidtouch.sim.containers import CONTAINERS
    from liquidtouch.sim.liquids import LIQUIDS

    catalogue = {"liquid": list(LIQUIDS), "container": list(CONTAINERS)}
    out: dict[str, object] = dict.fromkeys(LABEL_COLUMNS)
    warnings: list[str] = []
    for key, raw in labels.items():
        if key not in LABEL_COLUMNS:
            close = difflib.get_close_matches(key, LABEL_COLUMNS, n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise DatasetError(
                f"unknown label {key!r}{hint}; the labels are {', '.join(LABEL_COLUMNS)}"
            )
        text = "" if raw is None else str(raw).strip()
        if not text:
            raise DatasetError(f"label {key} is empty; leave it out if it is not known")
        if key in NUMERIC_LABELS:
            out[key] = _numeric_label(key, text)
            continue
        if len(text) > _MAX_NAME or any(not ch.isprintable() for ch in text):
            raise DatasetError(f"label {key} {text!r} must be a short printable name")
        names = [*catalogue[key], *(known or {}).get(key, [])]
        for name in dict.fromkeys(names):
            if name != text and _normal(name) == _normal(text):
                raise DatasetError(
                    f"{key} {text!r} differs from {name!r} only in spelling; use "
                    f"--label {key}={name} (or a clearly different name)"
                )
        if text not in names:
            warnings.append(
                f"{key} {text!r} is not in the simulator's catalogue "
                f"({', '.join(catalogue[key])}); kept as a label"
            )
        out[key] = text
    _derive_viscosity(out)
    return out, warnings


def _numeric_label(key: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DatasetError(f"label {key} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise DatasetError(f"label {key} must be a finite number, got {text!r}")
    if key in _POSITIVE and value <= 0:
        raise DatasetError(f"label {key} must be > 0, got {text}")
    if key in _NON_NEGATIVE and value < 0:
        raise DatasetError(f"label {key} must be >= 0, got {text}")
    if key == "temperature_c" and value <= -273.15:
        raise DatasetError(f"label temperature_c must be above absolute zero, got {text} °C")
    return value


def _derive_viscosity(labels: dict[str, object]) -> None:
    nu, log_nu = labels["viscosity_cst"], labels["log10_viscosity_cst"]
    if nu is not None and log_nu is not None:
        if abs(math.log10(nu) - log_nu) > LOG10_TOLERANCE:  # type: ignore[arg-type]
            raise DatasetError(
                f"viscosity_cst {nu:g} and log10_viscosity_cst {log_nu:g} disagree "
                f"(log10({nu:g}) = {math.log10(nu):.4f}); give one of them"  # type: ignore[arg-type]
            )
    elif nu is not None:
        labels["log10_viscosity_cst"] = math.log10(nu)  # type: ignore[arg-type]
    elif log_nu is not None:
        labels["viscosity_cst"] = 10.0**log_nu  # type: ignore[operator]


# -- trial names -----------------------------------------------------------------------------


def _check_trial_name(root: Path, name: str, existing: Sequence[str]) -> str:
    parts = name.split("/")
    if (
        not name
        or len(name) > _MAX_NAME
        or not all(_NAME_PART.fullmatch(p) and p not in (".", "..") for p in parts)
    ):
        raise DatasetError(
            f"trial name {name!r}: use letters, digits, '.', '_' and '-' (not first), with "
            "'/' between folder levels, e.g. water/h25-run1"
        )
    trial_path(root, name)
    if len(parts) == 1 and (name in (MANIFEST_NAME, FEATURES_NAME) or name.endswith(".csv")):
        raise DatasetError(f"trial name {name!r} is reserved for the dataset's tables")
    if name in existing:
        raise DatasetError(f"{root / MANIFEST_NAME} already lists trial {name!r}; choose --name")
    for other in existing:
        if name.startswith(other + "/") or other.startswith(name + "/"):
            raise DatasetError(
                f"trial {name!r} would nest with trial {other!r}; trials cannot contain trials"
            )
    if (root / name).exists() or (root / name).is_symlink():
        raise DatasetError(f"{root / name} already exists; choose another --name")
    return name


def _default_name(root: Path, existing: Sequence[str]) -> str:
    taken = set(existing)
    k = 1
    while f"{TRIAL_PREFIX}{k:04d}" in taken or (root / f"{TRIAL_PREFIX}{k:04d}").exists():
        k += 1
    return f"{TRIAL_PREFIX}{k:04d}"


def _check_sensor_names(names: Sequence[str]) -> list[str]:
    names = [str(n) for n in names]
    for name in names:
        if not _SENSOR_NAME.fullmatch(name) or len(name) > 100:
            raise DatasetError(
                f"sensor name {name!r}: use letters, digits, '_' and '-' (e.g. left, right)"
            )
    if len(set(names)) < len(names):
        raise DatasetError(f"sensor names must differ: {', '.join(names)}")
    return names


# -- adding a trial --------------------------------------------------------------------------


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


@dataclass
class _Source:
    path: Path
    folder: bool
    fps: float | None  # the video stream's rate, or the rate of a folder's timestamps.csv
    images: list[Path] = field(default_factory=list)
    has_timestamps: bool = False


def _inspect_source(path: Path) -> _Source:
    import numpy as np

    from liquidtouch.io.frames import (
        IMAGE_SUFFIXES,
        TIMESTAMPS_NAME,
        image_files,
        read_folder_timestamps,
        video_info,
    )

    if not path.exists():
        raise DatasetError(f"{path} does not exist; give video files or image folders")
    if path.is_dir():
        if (path / META_NAME).is_file():
            raise DatasetError(
                f"{path} is a trial directory; give its videos (or add it to the manifest by hand)"
            )
        files = image_files(path)
        stamps = read_folder_timestamps(path, len(files))
        fps = None
        if stamps is not None and len(stamps) > 1:
            fps = 1.0 / float(np.median(np.diff(stamps)))
        return _Source(path, True, fps, files, (path / TIMESTAMPS_NAME).is_file())
    if path.suffix.lower() in IMAGE_SUFFIXES:
        raise DatasetError(
            f"{path} is one image; give the folder of a sensor's images (or its video)"
        )
    info = video_info(path)
    return _Source(path, False, info.fps if info.fps > 0 else None)


def _place(src: Path, dst: Path, link: bool) -> bool:
    """Hard-link (if ``link``) or copy ``src`` to ``dst``; True if it was linked."""
    if link:
        try:
            os.link(src, dst)
            return True
        except OSError:  # another file system, or links not allowed: copy
            pass
    shutil.copy2(src, dst)
    return False


def _check_fps(fps: float | None) -> float | None:
    if fps is None:
        return None
    try:
        value = float(fps)
    except (TypeError, ValueError):
        value = math.nan
    if not 0 < value < math.inf:
        raise DatasetError(f"the frame rate (--fps) must be a positive number in Hz, got {fps!r}")
    return value


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
            "give the recording as video files or image folders, as --markers CSV files, or "
            "as a --bag" + (f" (got {' and '.join(kinds)})" if kinds else "")
        )
    kind = kinds[0]
    if topics and kind != "rosbag":
        raise DatasetError("--topic goes with --bag")
    if time_source != "header" and kind != "rosbag":
        raise DatasetError("--time-source goes with --bag")
    if link and kind != "files":
        raise DatasetError("--link applies to video files and image folders only")
    fps = _check_fps(fps)
    if split is not None and not _SPLIT.fullmatch(str(split)):
        raise DatasetError(f"split {split!r}: use a word such as train or test")
    n_inputs = len(sources) if kind == "files" else len(markers) if kind == "markers" else None
    if sensor_names is not None:
        sensor_names = _check_sensor_names(sensor_names)
        count = n_inputs if n_inputs is not None else len(topics)
        if n_inputs is None and not topics:
            raise DatasetError("--sensor with --bag needs the --topic of each sensor")
        if len(sensor_names) != count:
            raise DatasetError(f"{len(sensor_names)} sensor name(s) for {count} input(s)")
    with _dataset_lock(root):
        header, rows = _manifest_rows(root)
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
        name = _check_trial_name(
            root, name if name is not None else _default_name(root, existing), existing
        )
        tmp = Path(tempfile.mkdtemp(prefix=".add.", suffix=".tmp", dir=root))
        try:
            os.chmod(tmp, 0o777 & ~_umask())
            if kind == "files":
                built = _build_from_files(tmp, [Path(s) for s in sources], sensor_names, fps, link)
            elif kind == "markers":
                built = _build_from_markers(tmp, [Path(m) for m in markers], sensor_names, fps)
            else:
                built = _build_from_bag(
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
            _check_trial(tmp, kind)
            target = root / name
            row = {"trial": name, **({"split": split} if split is not None else {}), **checked}
            with atomic.deferred_interrupt():
                target.parent.mkdir(parents=True, exist_ok=True)
                os.rename(tmp, target)
                try:
                    n_trials = _write_manifest(root, header, rows, row)
                except BaseException:
                    shutil.rmtree(target, ignore_errors=True)
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


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _check_trial(tmp: Path, kind: str) -> None:
    """Read the new trial as the extraction will (sources, frame rates, tracks)."""
    from liquidtouch.extraction import resolve_sources
    from liquidtouch.io.importers import read_trial_tracks

    meta = read_trial_meta(tmp)
    if kind == "markers":
        read_trial_tracks(tmp, meta)
    else:
        resolve_sources(tmp)


@dataclass
class _Built:
    sensors: list[str]
    names: list[str]
    fps: float
    tracks: str | None = None
    source: dict[str, object] = field(default_factory=dict)
    linked: int = 0
    copied: int = 0
    warnings: list[str] = field(default_factory=list)


def _build_from_files(
    tmp: Path, paths: list[Path], names: list[str] | None, fps: float | None, link: bool
) -> _Built:
    from liquidtouch.io.frames import TIMESTAMPS_NAME

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
    names = names or _check_sensor_names([_stem(it.path) for it in items])
    warnings: list[str] = []
    untimed = [it.path for it in items if it.folder and not it.has_timestamps]
    if fps is None:
        if untimed:
            raise DatasetError(
                f"image folder {untimed[0]} has no {TIMESTAMPS_NAME}: give the camera's frame "
                f"rate with --fps, or add a {TIMESTAMPS_NAME} (t_s column, one row per image)"
            )
        rates = [it.fps for it in items if it.fps]
        if not rates:
            raise DatasetError(f"the frame rate of {paths[0]} is unknown; give it with --fps")
        rate = float(rates[0])
    else:
        rate = fps
        for it in items:
            if not it.folder and it.fps and abs(it.fps - fps) > 0.01 * it.fps:
                warnings.append(
                    f"--fps {fps:g} differs from the {it.fps:g} fps of {it.path.name}'s video "
                    "stream; meta.json records --fps (videos are timed by their own timestamps)"
                )
    entries, linked, copied = [], 0, 0
    for it, sensor in zip(items, names, strict=True):
        if it.folder:
            entry = sensor
            (tmp / entry).mkdir()
            files = [*it.images, *([it.path / TIMESTAMPS_NAME] if it.has_timestamps else [])]
            for file in files:
                done = _place(file, tmp / entry / file.name, link)
                linked, copied = linked + done, copied + (not done)
        else:
            entry = sensor + it.path.suffix.lower()
            done = _place(it.path, tmp / entry, link)
            linked, copied = linked + done, copied + (not done)
        entries.append(entry)
    if link and copied:
        warnings.append(
            f"copied {copied} file(s) that could not be hard-linked (another file system?)"
        )
    source = {"inputs": [p.name for p in paths]}
    return _Built(entries, names, rate, None, source, linked, copied, warnings)


def _stem(path: Path) -> str:
    stem = path.stem if path.is_file() else path.name
    return (
        "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in stem).lstrip("_-") or "sensor"
    )


def _build_from_markers(
    tmp: Path, paths: list[Path], names: list[str] | None, fps: float | None
) -> _Built:
    import numpy as np

    from liquidtouch.extraction import check_consistent
    from liquidtouch.io.importers import TRACKS_NAME, read_marker_csv
    from liquidtouch.tracking.tracks import save_tracks

    names = names or _check_sensor_names([_stem(p) for p in paths])
    tracks = [read_marker_csv(p, fps=fps, sensor=n) for p, n in zip(paths, names, strict=True)]
    check_consistent(tracks)
    rate = fps if fps is not None else 1.0 / float(np.median(np.diff(tracks[0].t)))
    save_tracks(tmp / TRACKS_NAME, tracks)
    source = {"inputs": [p.name for p in paths]}
    return _Built([], names, rate, TRACKS_NAME, source)


def _build_from_bag(
    tmp: Path,
    bag: Path,
    topics: Sequence[str],
    names: list[str] | None,
    fps: float | None,
    time_source: str,
    progress: bool,
) -> _Built:
    from liquidtouch.io.importers import import_bag
    from liquidtouch.progress import progress_bar

    with progress_bar(f"importing {bag.name}", None, enabled=progress) as advance:
        imported = import_bag(
            bag, tmp, topics=topics, names=names, time_source=time_source, on_message=advance
        )
    rate = fps if fps is not None else imported[0].fps
    source = {
        "inputs": [bag.name],
        "topics": [t.topic for t in imported],
        "time_source": time_source,
    }
    folders = [t.folder for t in imported]
    return _Built(folders, folders, rate, None, source)
