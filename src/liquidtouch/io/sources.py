"""The sensor sources one trial names: video files, image folders or a trial directory.

:func:`resolve_sources` turns what a user gives (paths, or a trial directory and its
``meta.json``) into ``(sensor name, source, frame rate)``; :func:`select_sensors`
keeps the named sensors.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path

from liquidtouch._core.checks import as_number
from liquidtouch.errors import VideoError
from liquidtouch.io.dataset import META_NAME, read_trial_meta
from liquidtouch.io.frame_times import TIMESTAMPS_NAME
from liquidtouch.io.frames import image_files

PathLike = str | os.PathLike[str]


def resolve_sources(
    paths: PathLike | Sequence[PathLike], *, fps: float | None = None
) -> list[tuple[str, Path, float | None]]:
    """``(sensor name, source, frame rate)`` of video files, image folders or one trial directory.

    The frame rate times image folders without a ``timestamps.csv`` (video files
    carry their own timestamps): a trial's ``meta.json`` ``fps``, else ``fps``.
    For a trial, an ``fps`` that differs from its ``meta.json`` is refused. The
    same file given twice (two names, a link) is refused: it is one sensor, not two.
    """
    items = [paths] if isinstance(paths, str | os.PathLike) else list(paths)
    if not items:
        raise VideoError("no video given; pass video files, image folders or a trial directory")
    items = [Path(p) for p in items]
    if fps is not None and not 0 < as_number(fps) < math.inf:
        raise VideoError(f"the frame rate (`fps`) must be a positive number in Hz, got {fps!r}")
    if len(items) == 1 and items[0].is_dir() and (items[0] / META_NAME).is_file():
        trial = items[0]
        meta = read_trial_meta(trial)
        if not meta.sensors:
            raise VideoError(f"{trial / META_NAME} lists no sensor videos ('sensors')")
        if fps is not None and not math.isclose(float(fps), meta.fps, rel_tol=1e-9):
            raise VideoError(
                f"`fps` {float(fps):g} disagrees with the frame rate {meta.fps:g} of "
                f"{trial / META_NAME}; a trial's image folders are timed by its meta.json "
                "(or their timestamps.csv)"
            )
        sources = [trial / name for name in meta.sensors]
        rate: float | None = meta.fps
    else:
        for path in items:
            if not path.exists():
                raise VideoError(f"{path} does not exist; give a video file, image folder or trial")
        sources, rate = items, fps
    _refuse_duplicates(sources)
    for path in sources:
        if rate is None and path.is_dir() and not (path / TIMESTAMPS_NAME).exists():
            image_files(path)  # a folder with no images (e.g. a dataset) says so first
            raise VideoError(
                f"image folder {path} has no frame rate: pass `fps` (the camera's frame rate) "
                f"or add {path / TIMESTAMPS_NAME} with a t_s column, one row per image"
            )
    names = [p.stem or p.name for p in sources]
    if len(set(names)) < len(names):  # two sensors called e.g. "video": number them
        names = [f"{name}{k}" for k, name in enumerate(names)]
    return [(name, path, rate) for name, path in zip(names, sources, strict=True)]


def _refuse_duplicates(sources: Sequence[Path]) -> None:
    """Raise :class:`VideoError` if two sources are the same file or folder."""
    seen: dict[object, Path] = {}
    for path in sources:
        try:
            stat = path.stat()
            key: object = (stat.st_dev, stat.st_ino)
        except OSError:  # missing: reported when it is read
            key = path.resolve()
        if key in seen:
            raise VideoError(
                f"{seen[key]} and {path} are the same file; each sensor's video must be given "
                "once (the same video twice is one sensor, not two)"
            )
        seen[key] = path


def select_sensors(
    sources: list[tuple[str, Path, float | None]], sensors: Sequence[str] | None
) -> list[tuple[str, Path, float | None]]:
    """The ``sources`` of the named ``sensors`` (all for ``None``); VideoError for unknown names."""
    if sensors is None:
        return sources
    if isinstance(sensors, str):
        sensors = [sensors]
    names = [name for name, _, _ in sources]
    unknown = [s for s in sensors if s not in names]
    if unknown or not sensors:
        raise VideoError(
            f"no sensor {', '.join(map(repr, unknown)) or '(none given)'}; "
            f"the sensors are {', '.join(names)}"
        )
    return [item for item in sources if item[0] in set(sensors)]
