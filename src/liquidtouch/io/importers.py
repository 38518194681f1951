"""Importers of recordings made with other tools: GelSight marker CSVs and ROS bags.

**Marker CSV** (:func:`read_marker_csv`): the marker locations the GelSight SDK's
marker-tracking demo writes (``gsrobotics``, ``marker_locations_<n>.csv``): no
header, one row per marker per frame, ``frame, row, col, x0, y0, x, y`` — the
frame number (from 1), the marker's (row, column) in the printed grid, its
initial and its current position [px]. A file with a header row may name its
columns instead (``frame,row,col,x,y`` required; ``x0,y0`` and ``t_s`` optional;
the SDK's ``Ox,Oy,Cx,Cy`` are accepted for ``x0,y0,x,y``). Frames are timed by
the ``t_s`` column [s] if there is one, else by the frame rate the caller gives
(frame numbers that skip are dropped frames). The result is a
:class:`~liquidtouch.tracking.tracks.MarkerTracks`; a trial directory stores the
tracks of its sensors as ``tracks.npz`` (:data:`TRACKS_NAME`, listed in
``meta.json`` under ``tracks``), and :func:`stored_tracks` hands them to the
extraction instead of tracking videos.

**ROS bags** (:func:`import_bag`, needs the optional ``rosbags`` package:
``pip install 'liquidtouch[ros]'``): ``sensor_msgs/Image`` (``mono8``, ``rgb8``,
``bgr8``, ``rgba8``, ``bgra8``, ``8UC1``, ``8UC3``, ``8UC4``, ``yuv422``/``uyvy``,
``yuyv``) and ``sensor_msgs/CompressedImage`` (JPEG, PNG) topics of a ROS 1
``.bag`` or a ROS 2 bag (directory, ``.db3`` or ``.mcap``) become one image
folder per topic with a ``timestamps.csv`` of the message header stamps.

Formats: ``docs/formats.md`` ("Imported recordings").
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liquidtouch.errors import DatasetError, TableError, VideoError
from liquidtouch.tracking.tracks import MarkerTracks

TRACKS_NAME = "tracks.npz"
"""File name of imported marker tracks in a trial directory (``meta.json`` ``tracks``)."""
MARKER_CSV_COLUMNS = ("frame", "row", "col", "x0", "y0", "x", "y")
"""The columns of a headerless GelSight marker CSV, in order."""
_REQUIRED = ("frame", "row", "col", "x", "y")
_ALIASES = {"ox": "x0", "oy": "y0", "cx": "x", "cy": "y", "column": "col"}
#: frame times of one frame (``t_s`` of its rows) may differ by this much [s]
_TIME_TOLERANCE_S = 1e-6
ROS_HINT = "pip install 'liquidtouch[ros]'"


# -- GelSight marker CSV ---------------------------------------------------------------------


def read_marker_csv(
    path: str | os.PathLike[str], *, fps: float | None = None, sensor: str | None = None
) -> MarkerTracks:
    """Read a GelSight marker-location CSV into :class:`MarkerTracks` (see the module doc).

    ``fps`` [Hz] times the frames (frame ``k`` at ``(k - first) / fps``) when the
    file has no ``t_s`` column; a ``t_s`` column wins over ``fps``. ``sensor``
    names the tracks (default: the file's stem). Markers are ordered by (row,
    col); a marker missing from a frame, or with an empty or NaN ``x``/``y``,
    is lost there (``valid`` False). The reference positions are ``x0, y0``
    (the SDK's initial positions), else each marker's first position. Raises
    :class:`~liquidtouch.errors.TableError` for a file that is not such a CSV.
    """
    from liquidtouch.io.signal_csv import check_csv_bounds, shorten
    from liquidtouch.tracking.track import marker_spacing

    path = Path(path)
    if not path.is_file():
        raise TableError(f"marker CSV {path} does not exist")
    name = sensor if sensor is not None else (path.stem or "sensor")
    if fps is not None and not 0 < _number(fps) < math.inf:
        raise TableError(f"the frame rate (--fps) must be a positive number in Hz, got {fps!r}")
    check_csv_bounds(path, "marker CSV")
    columns, table = _read_marker_table(path)
    where = shorten(path)
    frame = _integer_column(table, "frame", where)
    row = _integer_column(table, "row", where)
    col = _integer_column(table, "col", where)
    xy = np.column_stack([_float_column(table, c, where) for c in ("x", "y")])
    if (frame < 0).any():
        raise TableError(f"{where}: frame numbers must be >= 0")
    frames, frame_idx = np.unique(frame, return_inverse=True)
    cells, marker_idx = np.unique(np.column_stack([row, col]), axis=0, return_inverse=True)
    marker_idx = marker_idx.ravel()
    n_frames, n_markers = len(frames), len(cells)
    if n_frames < 2:
        raise TableError(f"{where} holds {n_frames} frame(s); a recording needs many frames")
    flat = frame_idx * n_markers + marker_idx
    counts = np.bincount(flat, minlength=n_frames * n_markers)
    if (counts > 1).any():
        k = int(np.argmax(counts > 1))
        r, c = cells[k % n_markers]
        raise TableError(
            f"{where}: marker (row {r}, col {c}) appears twice in frame {frames[k // n_markers]}; "
            "give one row per marker per frame"
        )
    positions = np.full((n_frames, n_markers, 2), np.nan)
    positions[frame_idx, marker_idx] = xy
    valid = np.isfinite(positions).all(axis=2)
    keep = valid.any(axis=0)
    if keep.sum() < 2:
        raise TableError(f"{where} holds fewer than 2 markers with a position")
    reference = _reference(table, columns, frame, marker_idx, n_markers, positions, valid, where)
    positions, valid, reference = positions[:, keep], valid[:, keep], reference[keep]
    positions[~valid] = np.nan
    t = _frame_times(table, columns, frames, frame_idx, fps, where)
    return MarkerTracks(
        t=t,
        positions=positions,
        valid=valid,
        reference=reference,
        sensor=name,
        spacing_px=marker_spacing(reference),
    )


def _number(value: object) -> float:
    try:
        return float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return math.nan


def _read_marker_table(path: Path) -> tuple[list[str], dict[str, np.ndarray]]:
    """Column names and the raw (stripped string) columns of a marker CSV."""
    import pandas as pd

    from liquidtouch.io.signal_csv import shorten

    try:
        with path.open(encoding="utf-8") as handle:
            first = next((line for line in handle if line.strip()), "")
    except UnicodeDecodeError:
        raise TableError(f"{shorten(path)} is not a text CSV file") from None
    if not first:
        raise TableError(
            f"{shorten(path)} is empty; expected rows of {', '.join(MARKER_CSV_COLUMNS)}"
        )
    fields = [cell.strip() for cell in first.split(",")]
    headerless = all(
        cell.lower() in ("", "nan") or not math.isnan(_number(cell)) for cell in fields
    )
    if headerless and len(fields) != len(MARKER_CSV_COLUMNS):
        raise TableError(
            f"{shorten(path)}: a marker CSV without a header has {len(MARKER_CSV_COLUMNS)} "
            f"columns ({', '.join(MARKER_CSV_COLUMNS)}, as the GelSight SDK writes them); this "
            f"one has {len(fields)}. Add a header row naming the columns "
            "(frame,row,col,x,y and optionally x0,y0,t_s)"
        )
    try:
        frame = pd.read_csv(
            path,
            header=None if headerless else 0,
            names=list(MARKER_CSV_COLUMNS) if headerless else None,
            dtype=str,
            keep_default_na=False,
            na_filter=False,
            skipinitialspace=True,
            skip_blank_lines=True,
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise TableError(f"{shorten(path)} is not a readable CSV: {shorten(exc)}") from None
    names = [_ALIASES.get(str(c).strip().lower(), str(c).strip().lower()) for c in frame.columns]
    missing = [c for c in _REQUIRED if c not in names]
    if missing:
        raise TableError(
            f"{shorten(path)} lacks column(s) {', '.join(missing)}; a marker CSV has the columns "
            "frame,row,col,x,y (and optionally x0,y0,t_s), or no header and the GelSight SDK's "
            "7 columns frame, row, col, x0, y0, x, y"
        )
    if len(set(names)) < len(names):
        raise TableError(f"{shorten(path)} names a column twice: {', '.join(names)}")
    if frame.empty:
        raise TableError(f"{shorten(path)} holds no rows")
    table = {name: frame.iloc[:, k].str.strip().to_numpy(dtype=str) for k, name in enumerate(names)}
    return names, table


def _as_floats(values: np.ndarray, name: str, where: str, *, allow_missing: bool) -> np.ndarray:
    import pandas as pd

    out = pd.to_numeric(pd.Series(values), errors="coerce").to_numpy(float)
    missing = np.char.lower(values.astype(str)) == "nan"
    missing |= values == ""
    bad = np.isnan(out) & ~missing if allow_missing else ~np.isfinite(out)
    bad |= np.isinf(out)
    if bad.any():
        k = int(np.argmax(bad))
        from liquidtouch.io.signal_csv import shorten

        raise TableError(
            f"{where}: column {name} must hold numbers; data row {k + 1} has {shorten(values[k])!r}"
        )
    return out


def _integer_column(table: dict[str, np.ndarray], name: str, where: str) -> np.ndarray:
    values = _as_floats(table[name], name, where, allow_missing=False)
    if (values != np.round(values)).any() or (np.abs(values) > 2**53).any():
        k = int(np.argmax(values != np.round(values)))
        raise TableError(f"{where}: column {name} must hold whole numbers; row {k + 1} is not")
    return values.astype(np.int64)


def _float_column(table: dict[str, np.ndarray], name: str, where: str) -> np.ndarray:
    return _as_floats(table[name], name, where, allow_missing=True)


def _reference(
    table: dict[str, np.ndarray],
    columns: list[str],
    frame: np.ndarray,
    marker_idx: np.ndarray,
    n_markers: int,
    positions: np.ndarray,
    valid: np.ndarray,
    where: str,
) -> np.ndarray:
    """(N, 2) reference positions: x0, y0 of each marker's earliest row, else its first position."""
    first_valid = np.argmax(valid, axis=0)
    reference = positions[first_valid, np.arange(n_markers)]
    if "x0" in columns and "y0" in columns:
        start = np.column_stack([_float_column(table, c, where) for c in ("x0", "y0")])
        order = np.argsort(frame, kind="stable")
        _, first_row = np.unique(marker_idx[order], return_index=True)
        rows = order[first_row]
        given = np.full((n_markers, 2), np.nan)
        given[marker_idx[rows]] = start[rows]
        ok = np.isfinite(given).all(axis=1)
        reference[ok] = given[ok]
    return reference


def _frame_times(
    table: dict[str, np.ndarray],
    columns: list[str],
    frames: np.ndarray,
    frame_idx: np.ndarray,
    fps: float | None,
    where: str,
) -> np.ndarray:
    """Frame times [s] from 0: the ``t_s`` column, else the frame numbers over ``fps``."""
    if "t_s" in columns:
        stamps = _as_floats(table["t_s"], "t_s", where, allow_missing=False)
        low = np.full(len(frames), np.inf)
        high = np.full(len(frames), -np.inf)
        np.minimum.at(low, frame_idx, stamps)
        np.maximum.at(high, frame_idx, stamps)
        if (high - low > _TIME_TOLERANCE_S).any():
            k = int(np.argmax(high - low > _TIME_TOLERANCE_S))
            raise TableError(
                f"{where}: the rows of frame {frames[k]} have different t_s ({low[k]:g} to "
                f"{high[k]:g} s); every row of a frame needs the frame's time"
            )
        steps = np.diff(low)
        if (steps <= 0).any():
            k = int(np.argmax(steps <= 0))
            raise TableError(
                f"{where}: t_s must increase with the frame number, but frame {frames[k + 1]} "
                f"({low[k + 1]:g} s) is not after frame {frames[k]} ({low[k]:g} s)"
            )
        return low - low[0]
    if fps is None:
        raise TableError(
            f"{where} has no t_s column, so its frames need a frame rate: pass --fps (the "
            "camera's frame rate), or add a t_s column (frame time in seconds) to the file"
        )
    return (frames - frames[0]) / float(fps)


# -- tracks stored in a trial ----------------------------------------------------------------


def read_trial_tracks(trial_dir: str | os.PathLike[str], meta: object = None) -> list[MarkerTracks]:
    """The marker tracks a trial directory stores (``meta.json`` ``tracks``), validated.

    Raises :class:`~liquidtouch.errors.DatasetError` if the trial lists no tracks
    or the file is missing, damaged or inconsistent.
    """
    from liquidtouch.io.dataset import read_trial_meta
    from liquidtouch.tracking.tracks import load_tracks

    trial = Path(trial_dir)
    meta = read_trial_meta(trial) if meta is None else meta
    name = getattr(meta, "tracks", None)
    if not name:
        raise DatasetError(f"{trial} stores no marker tracks (meta.json has no 'tracks')")
    path = trial / name
    root = trial.resolve()
    if Path(name).is_absolute() or ".." in Path(name).parts or root not in path.resolve().parents:
        raise DatasetError(f"{trial}/meta.json: tracks {name!r} must stay inside the trial")
    if not path.is_file():
        raise DatasetError(f"{path} does not exist; the trial's meta.json lists it as its tracks")
    try:
        tracks = load_tracks(path)
    except (OSError, ValueError, KeyError, EOFError) as exc:
        raise DatasetError(f"{path} is not a readable tracks file: {exc}") from None
    if not tracks:
        raise DatasetError(f"{path} holds no sensors")
    for tr in tracks:
        _check_tracks(tr, path)
    return tracks


def _check_tracks(tr: MarkerTracks, path: Path) -> None:
    t = np.asarray(tr.t, dtype=float)
    n_frames = t.shape[0] if t.ndim == 1 else -1
    n = tr.reference.shape[0] if tr.reference.ndim == 2 else -1
    shapes_ok = (
        t.ndim == 1
        and n_frames >= 2
        and n >= 2
        and tr.reference.shape == (n, 2)
        and tr.positions.shape == (n_frames, n, 2)
        and tr.valid.shape == (n_frames, n)
        and tr.valid.dtype == bool
    )
    if not shapes_ok:
        raise DatasetError(
            f"{path}: the arrays of sensor {tr.sensor!r} do not fit together (t {t.shape}, "
            f"positions {tr.positions.shape}, valid {tr.valid.shape}, reference "
            f"{tr.reference.shape}); expected (T,), (T, N, 2), (T, N), (N, 2) with T, N >= 2"
        )
    if not np.isfinite(t).all() or (np.diff(t) <= 0).any():
        raise DatasetError(f"{path}: the times of sensor {tr.sensor!r} must increase strictly")
    if not np.isfinite(tr.reference).all():
        raise DatasetError(f"{path}: the reference of sensor {tr.sensor!r} holds NaN")
    if not np.isfinite(tr.positions[tr.valid]).all():
        raise DatasetError(f"{path}: sensor {tr.sensor!r} has valid positions that are NaN")


def stored_tracks(
    paths: object, sensors: Sequence[str] | str | None = None
) -> list[MarkerTracks] | None:
    """The stored marker tracks when ``paths`` is one trial directory that has them, else None.

    The extraction's hook: such a trial (imported from marker CSVs) is read from
    its ``tracks.npz`` instead of tracking videos. ``sensors`` selects sensors by
    name (:class:`~liquidtouch.errors.VideoError` for unknown ones).
    """
    from liquidtouch.io.dataset import META_NAME, read_trial_meta

    items = [paths] if isinstance(paths, str | os.PathLike) else list(paths)  # type: ignore[call-overload]
    if len(items) != 1 or not isinstance(items[0], str | os.PathLike):
        return None
    trial = Path(items[0])
    if not (trial.is_dir() and (trial / META_NAME).is_file()):
        return None
    meta = read_trial_meta(trial)
    if not getattr(meta, "tracks", None):
        return None
    tracks = read_trial_tracks(trial, meta)
    if sensors is not None:
        wanted = [sensors] if isinstance(sensors, str) else list(sensors)
        names = [tr.sensor for tr in tracks]
        unknown = [s for s in wanted if s not in names]
        if unknown or not wanted:
            raise VideoError(
                f"no sensor {', '.join(map(repr, unknown)) or '(none given)'}; "
                f"the sensors are {', '.join(names)}"
            )
        tracks = [tr for tr in tracks if tr.sensor in set(wanted)]
    from liquidtouch.extraction import check_consistent

    check_consistent(tracks)
    return tracks


# -- ROS bags --------------------------------------------------------------------------------

IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
TIME_SOURCES = ("header", "bag")
_SKIP_TOPIC_PARTS = frozenset(
    {"image_raw", "image", "image_color", "image_mono", "image_rect", "raw", "compressed"}
)


@dataclass(frozen=True)
class BagTopic:
    """One image topic imported from a bag: its folder, frame count and nominal rate."""

    topic: str
    folder: str
    frames: int
    fps: float
    msgtype: str


def _rosbags():
    """The rosbags modules; :class:`DatasetError` with the install hint when it is missing."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise DatasetError(
            f"reading ROS bags needs the optional rosbags package: {ROS_HINT}"
        ) from None
    return AnyReader, Stores, get_typestore


def topic_sensor_names(topics: Sequence[str]) -> list[str]:
    """Sensor names for image topics: the parts that tell them apart.

    ``/gelsight/left/image_raw``, ``/gelsight/right/image_raw`` → ``left``,
    ``right``; one topic: its last part that is not ``image_raw``, ``compressed``
    and the like (``/gelsight/left/image_raw`` → ``left``).
    """
    parts = [[p for p in t.strip("/").split("/") if p] for t in topics]
    common = set.intersection(*(set(p) for p in parts)) if len(parts) > 1 else set()
    names = []
    for topic, items in zip(topics, parts, strict=True):
        kept = [p for p in items if p not in common and p.lower() not in _SKIP_TOPIC_PARTS]
        if len(topics) == 1:
            kept = kept[-1:]
        name = "_".join(kept) or "_".join(items) or "image"
        names.append("".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in name) or topic)
    if len(set(names)) < len(names):
        names = ["_".join(p) or f"topic{k}" for k, p in enumerate(parts)]
    return names


def bag_image_topics(bag: str | os.PathLike[str]) -> dict[str, str]:
    """``{topic: message type}`` of the image topics of a ROS 1 or ROS 2 bag."""
    with _opened_bag(Path(bag)) as reader:
        return {c.topic: c.msgtype for c in reader.connections if c.msgtype in IMAGE_TYPES}


@contextlib.contextmanager
def _opened_bag(path: Path) -> Iterator[object]:
    """An open rosbags ``AnyReader`` of ``path``; :class:`DatasetError` if it cannot be read."""
    AnyReader, Stores, get_typestore = _rosbags()
    if not path.exists():
        raise DatasetError(f"bag {path} does not exist")
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    except Exception as exc:  # rosbags raises its own errors, and OSError/KeyError on junk
        raise DatasetError(
            f"cannot read bag {path}: {exc}; give a ROS 1 .bag file or a ROS 2 bag "
            "(its directory, or its .db3/.mcap file)"
        ) from None
    try:
        yield reader
    finally:
        reader.close()


def import_bag(
    bag: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    topics: Sequence[str] = (),
    names: Sequence[str] | None = None,
    time_source: str = "header",
    on_message: Callable[..., None] | None = None,
) -> list[BagTopic]:
    """Write each image topic of ``bag`` as an image folder ``out_dir/<name>/`` with timestamps.

    ``topics``: the image topics to import (default: every ``sensor_msgs/Image``
    and ``CompressedImage`` topic of the bag). ``names``: the folder (sensor)
    names, one per topic (default :func:`topic_sensor_names`). Raw images are
    written as PNG (colour kept), compressed ones as the JPEG or PNG bytes they
    hold (each decoded once to check it). ``timestamps.csv`` has ``t_s`` (seconds
    from the earliest frame of all topics) and ``stamp_ns`` (the absolute stamp)
    per image. ``time_source``: ``"header"`` (the messages' ``header.stamp``,
    the capture time) or ``"bag"`` (the time the recorder received them).
    Raises :class:`~liquidtouch.errors.DatasetError` for a missing or bad bag or
    topic, an unsupported encoding, or stamps that do not increase.
    """
    import cv2

    if time_source not in TIME_SOURCES:
        raise DatasetError(f"unknown time source {time_source!r}; choose header or bag")
    out_dir = Path(out_dir)
    path = Path(bag)
    with _opened_bag(path) as reader:
        available = {c.topic: c.msgtype for c in reader.connections}
        images = sorted(t for t, m in available.items() if m in IMAGE_TYPES)
        topics = list(topics) or images
        if not topics:
            raise DatasetError(
                f"bag {path} has no sensor_msgs/Image or CompressedImage topic (its topics: "
                f"{', '.join(sorted(available)) or 'none'})"
            )
        if len(set(topics)) < len(topics):
            raise DatasetError("a topic is given twice; give each sensor's topic once")
        for topic in topics:
            if topic not in available:
                raise DatasetError(
                    f"bag {path} has no topic {topic}; its image topics are "
                    f"{', '.join(images) or 'none'}"
                )
            if available[topic] not in IMAGE_TYPES:
                raise DatasetError(
                    f"topic {topic} carries {available[topic]}, not sensor_msgs/Image or "
                    "sensor_msgs/CompressedImage"
                )
        names = list(names) if names is not None else topic_sensor_names(topics)
        if len(names) != len(topics):
            raise DatasetError(f"{len(names)} sensor names for {len(topics)} topics")
        writers = {
            t: _TopicWriter(out_dir / n, t, available[t])
            for t, n in zip(topics, names, strict=True)
        }
        connections = [c for c in reader.connections if c.topic in writers]
        for connection, bag_ns, raw in reader.messages(connections=connections):
            writer = writers[connection.topic]
            try:
                msg = reader.deserialize(raw, connection.msgtype)
            except Exception as exc:  # a damaged message
                raise DatasetError(
                    f"bag {path}: message {writer.count} of {connection.topic} cannot be "
                    f"decoded: {exc}"
                ) from None
            stamp = msg.header.stamp
            header_ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
            writer.add(msg, header_ns if time_source == "header" else int(bag_ns), cv2)
            if on_message is not None:
                on_message()
    origin = min((w.stamps[0] for w in writers.values() if w.stamps), default=0)
    return [w.finish(origin, time_source) for w in writers.values()]


class _TopicWriter:
    """Writes one topic's images into its folder and collects their stamps."""

    def __init__(self, folder: Path, topic: str, msgtype: str) -> None:
        self.folder, self.topic, self.msgtype = folder, topic, msgtype
        self.stamps: list[int] = []
        self.shape: tuple[int, ...] | None = None
        self.count = 0
        folder.mkdir(parents=True, exist_ok=False)

    def add(self, msg: object, stamp_ns: int, cv2: object) -> None:
        index = self.count
        if self.stamps and stamp_ns <= self.stamps[-1]:
            raise DatasetError(
                f"topic {self.topic}: message {index} has stamp {stamp_ns} ns, not after the "
                f"previous {self.stamps[-1]} ns; the header stamps must increase (unset or "
                "duplicated stamps: use --time-source bag, the recording time)"
            )
        if self.msgtype.endswith("/CompressedImage"):
            data, suffix, shape = _compressed(msg, self.topic, index, cv2)
            (self.folder / f"{index:06d}{suffix}").write_bytes(data)
        else:
            image = _raw_image(msg, self.topic, index, cv2)
            shape = image.shape[:2]
            ok, encoded = cv2.imencode(".png", image)  # type: ignore[attr-defined]
            if not ok:  # pragma: no cover - OpenCV encodes any uint8 image
                raise DatasetError(f"topic {self.topic}: message {index} cannot be saved as PNG")
            (self.folder / f"{index:06d}.png").write_bytes(encoded.tobytes())
        if self.shape is not None and shape != self.shape:
            raise DatasetError(
                f"topic {self.topic}: message {index} is {shape[1]}x{shape[0]} but the first "
                f"is {self.shape[1]}x{self.shape[0]}; all images of a sensor must have one size"
            )
        self.shape = shape
        self.stamps.append(stamp_ns)
        self.count += 1

    def finish(self, origin_ns: int, time_source: str) -> BagTopic:
        from liquidtouch.io import atomic
        from liquidtouch.io.frames import TIMESTAMPS_NAME

        if self.count < 2:
            raise DatasetError(
                f"topic {self.topic} holds {self.count} image(s); a recording needs many frames"
            )
        if time_source == "header" and self.stamps[0] == 0:
            raise DatasetError(
                f"topic {self.topic}: the header stamps are unset (0); use --time-source bag"
            )
        lines = ["t_s,stamp_ns"]
        lines += [f"{(s - origin_ns) / 1e9:.9f},{s}" for s in self.stamps]
        atomic.write_text(self.folder / TIMESTAMPS_NAME, "\n".join(lines) + "\n")
        step_s = float(np.median(np.diff(self.stamps))) / 1e9
        return BagTopic(self.topic, self.folder.name, self.count, 1.0 / step_s, self.msgtype)


_CHANNELS = {
    "mono8": 1,
    "8uc1": 1,
    "bgr8": 3,
    "rgb8": 3,
    "8uc3": 3,
    "bgra8": 4,
    "rgba8": 4,
    "8uc4": 4,
}
_YUV = {"yuv422": "UYVY", "uyvy": "UYVY", "yuv422_yuy2": "YUY2", "yuyv": "YUY2"}


def _raw_image(msg: object, topic: str, index: int, cv2: object) -> np.ndarray:
    """A ``sensor_msgs/Image`` as a uint8 grey or BGR array."""
    encoding = str(msg.encoding).strip().lower()  # type: ignore[attr-defined]
    height, width, step = int(msg.height), int(msg.width), int(msg.step)  # type: ignore[attr-defined]
    data = np.asarray(msg.data, dtype=np.uint8).ravel()  # type: ignore[attr-defined]
    where = f"topic {topic}: message {index}"
    channels = 2 if encoding in _YUV else _CHANNELS.get(encoding)
    if channels is None:
        raise DatasetError(
            f"{where} has encoding {msg.encoding!r}; liquidtouch reads 8-bit images "  # type: ignore[attr-defined]
            f"({', '.join([*_CHANNELS, *_YUV])}); convert the topic first"
        )
    if height < 1 or width < 1 or step < width * channels or data.size < height * step:
        raise DatasetError(
            f"{where}: {data.size} bytes do not hold a {width}x{height} {encoding} image "
            f"(step {step})"
        )
    rows = data[: height * step].reshape(height, step)[:, : width * channels]
    image = rows.reshape(height, width, channels) if channels > 1 else rows
    if encoding in _YUV:
        code = getattr(cv2, f"COLOR_YUV2BGR_{_YUV[encoding]}")
        return cv2.cvtColor(np.ascontiguousarray(image), code)  # type: ignore[attr-defined]
    if encoding.startswith("rgb"):
        image = image[:, :, 2::-1]
    elif channels == 4:
        image = image[:, :, :3]
    return np.ascontiguousarray(image)


def _compressed(
    msg: object, topic: str, index: int, cv2: object
) -> tuple[bytes, str, tuple[int, ...]]:
    """The bytes, file suffix and (height, width) of a ``sensor_msgs/CompressedImage``."""
    data = np.asarray(msg.data, dtype=np.uint8).ravel()  # type: ignore[attr-defined]
    raw = data.tobytes()
    if raw.startswith(b"\xff\xd8"):
        suffix = ".jpg"
    elif raw.startswith(b"\x89PNG"):
        suffix = ".png"
    else:
        raise DatasetError(
            f"topic {topic}: message {index} (format {msg.format!r}) is neither JPEG nor PNG"  # type: ignore[attr-defined]
        )
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)  # type: ignore[attr-defined]
    if image is None or image.dtype != np.uint8:
        raise DatasetError(
            f"topic {topic}: message {index} is not a decodable 8-bit {suffix[1:].upper()} image"
        )
    return raw, suffix, image.shape[:2]
