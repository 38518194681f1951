"""Frame times from files: ``timestamps.csv`` of image folders, and the sidecar of videos.

**Image folders** carry no clock of their own: their frames are timed by the
folder's :data:`TIMESTAMPS_NAME` (column ``t_s``, one row per image in natural
name order), else by a frame rate the caller gives (:func:`folder_times`).

**Video sidecar**: the recorder writes ``<name>.timestamps.csv``
(:data:`VIDEO_TIMESTAMPS_SUFFIX`, the same columns) beside each ``<name>.mkv``,
with the capture times to 1 µs, while Matroska keeps the PTS to 1 ms (two frames
read back to back after a stall can share one). A present sidecar with one valid
row per frame wins over the container's PTS (:func:`video_sidecar_times`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from liquidtouch._core.checks import check_times
from liquidtouch.errors import VideoError

#: per-frame timestamps of an image folder: CSV with a ``t_s`` column, one row per image
TIMESTAMPS_NAME = "timestamps.csv"
#: per-frame timestamps of a video ``<name>.mkv``: ``<name>.timestamps.csv`` beside it
VIDEO_TIMESTAMPS_SUFFIX = ".timestamps.csv"


def folder_times(folder: str | Path, n_images: int, fps: float | None = None) -> np.ndarray:
    """Frame times [s] from 0 of an image folder of ``n_images`` images (see iter_image_folder)."""
    folder = Path(folder)
    stamps = read_folder_timestamps(folder, n_images)
    if stamps is not None:
        return stamps - stamps[0]
    if fps is None:
        raise VideoError(
            f"image folder {folder} has no frame rate: give it (`fps`, or the trial's "
            f"meta.json 'fps') or add a {TIMESTAMPS_NAME} with a t_s column, one row per image"
        )
    try:
        fps = float(fps)
    except (TypeError, ValueError):
        raise VideoError(f"frame rate must be a number of frames per second, got {fps!r}") from None
    if not 0 < fps < np.inf:
        raise VideoError(f"frame rate must be positive and finite, got {fps}")
    return np.arange(n_images) / fps


def read_folder_timestamps(folder: str | Path, n_images: int) -> np.ndarray | None:
    """The ``t_s`` column [s] of ``folder/timestamps.csv``; ``None`` when there is no such file.

    The file must hold a header with a ``t_s`` column and exactly one row per image
    (``n_images``), finite and strictly increasing; otherwise :class:`VideoError`.
    """
    path = Path(folder) / TIMESTAMPS_NAME
    if not path.exists():
        return None
    return read_timestamps_csv(path, n_images, "the folder holds", "images")


def video_sidecar(video: str | Path) -> Path:
    """Where the timestamps of ``video`` are kept: ``<name>.timestamps.csv`` beside it."""
    video = Path(video)
    return video.with_name(video.stem + VIDEO_TIMESTAMPS_SUFFIX)


def video_sidecar_times(video: str | Path, n_frames: int) -> np.ndarray | None:
    """Frame times [s, from 0] of ``video`` from its sidecar; ``None`` when it has none.

    A sidecar that does not give one valid ``t_s`` row per frame (``n_frames``)
    is refused (:class:`VideoError`): it belongs to another recording.
    """
    path = video_sidecar(video)
    if not path.is_file():
        return None
    stamps = read_timestamps_csv(path, n_frames, f"the video {Path(video).name} holds", "frames")
    return stamps - stamps[0]


def read_timestamps_csv(path: Path, n_rows: int, holder: str, items: str) -> np.ndarray:
    """The ``t_s`` column [s] of a timestamps CSV with exactly ``n_rows`` rows, validated.

    ``holder`` and ``items`` name what the rows time, for the error message
    (``"the folder holds"``, ``"images"``).
    """
    import csv

    limit = 64 * (n_rows + 2) + 4096  # generous for one number per row and extra columns
    try:
        size = path.stat().st_size
        if size > limit:
            raise VideoError(
                f"{path} is {size} bytes, far more than {n_rows} timestamps need; "
                f"give one t_s row per {items[:-1]}"
            )
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise VideoError(f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") from None
    rows = [row for row in csv.reader(lines) if row and any(cell.strip() for cell in row)]
    header = [cell.strip() for cell in rows[0]] if rows else []
    if "t_s" not in header:
        raise VideoError(f"{path} needs a header row with a t_s column (frame times in seconds)")
    column = header.index("t_s")
    if len(rows) - 1 != n_rows:
        raise VideoError(
            f"{path} lists {len(rows) - 1} timestamps but {holder} {n_rows} {items}; "
            f"give exactly one t_s row per {items[:-1]}, in order"
        )
    try:
        stamps = np.array([float(row[column]) for row in rows[1:]])
    except (ValueError, IndexError):
        raise VideoError(f"{path}: every t_s value must be a number of seconds") from None
    what = f"{path}: column t_s (by data row)"
    return check_times(stamps, what, VideoError, min_count=1, first=1)
