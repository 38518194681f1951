"""End to end: GelSight videos (or a trial directory) → marker tracks → ``u(t)`` → fit.

``extract_signal(paths)`` gives the :class:`~liquidtouch.signal.TactileSignal`;
``extract(paths)`` also keeps the tracks and runs
:func:`~liquidtouch.fit.oscillation.fit_oscillation` on the free decay
(:class:`~liquidtouch.fit_settings.FitSettings`: the fit's options and where the
fitted window starts, shared with the ``fit`` command); ``extract_trial(trial_dir)``
gives the feature row used by dataset feature tables. Its figure:
:func:`~liquidtouch.extraction_plot.plot_extraction`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from liquidtouch.errors import VideoError
from liquidtouch.extraction_plot import plot_extraction
from liquidtouch.fit_settings import AUTO, FitSettings, fit_window
from liquidtouch.progress import progress_bar
from liquidtouch.signal import TactileSignal, check_signal_options, tactile_signal
from liquidtouch.tracking.detect import as_number
from liquidtouch.tracking.tracks import MarkerTracks, track_markers

__all__ = [
    "AUTO",
    "Extraction",
    "FitSettings",
    "check_consistent",
    "extract",
    "extract_signal",
    "extract_trial",
    "fit_window",
    "plot_extraction",
    "resolve_sources",
    "select_sensors",
    "track_sources",
]

PathLike = str | os.PathLike[str]
RATE_TOLERANCE = 0.01  # relative frame-rate difference allowed between the videos of a trial


@dataclass
class Extraction:
    """Everything ``extract`` computed: per-sensor tracks, the signal and its fit."""

    tracks: list[MarkerTracks]
    signal: TactileSignal
    fit: object  # liquidtouch.fit.oscillation.OscillationFit

    def to_dict(self) -> dict[str, object]:
        """The fit's keys plus ``explained_variance``, ``n_markers``, ``fps``, ``frames``."""
        out = dict(self.fit.to_dict())
        out.update(
            explained_variance=float(self.signal.explained_variance),
            n_markers=int(self.signal.n_markers),
            fps=float(self.signal.fps),
            frames=len(self.signal.t),
        )
        return out


def resolve_sources(
    paths: PathLike | Sequence[PathLike], *, fps: float | None = None
) -> list[tuple[str, Path, float | None]]:
    """``(sensor name, source, frame rate)`` of video files, image folders or one trial directory.

    The frame rate times image folders without a ``timestamps.csv`` (video files
    carry their own timestamps): a trial's ``meta.json`` ``fps``, else ``fps``.
    For a trial, an ``fps`` that differs from its ``meta.json`` is refused. The
    same file given twice (two names, a link) is refused: it is one sensor, not two.
    """
    from liquidtouch.io.dataset import META_NAME, read_trial_meta
    from liquidtouch.io.frames import TIMESTAMPS_NAME, image_files

    items = [paths] if isinstance(paths, str | os.PathLike) else list(paths)
    if not items:
        raise VideoError("no video given; pass video files, image folders or a trial directory")
    items = [Path(p) for p in items]
    if fps is not None and not 0 < as_number(fps) < math.inf:
        raise VideoError(f"the frame rate (--fps) must be a positive number in Hz, got {fps!r}")
    if len(items) == 1 and items[0].is_dir() and (items[0] / META_NAME).is_file():
        trial = items[0]
        meta = read_trial_meta(trial)
        if not meta.sensors:
            raise VideoError(f"{trial / META_NAME} lists no sensor videos ('sensors')")
        if fps is not None and not math.isclose(float(fps), meta.fps, rel_tol=1e-9):
            raise VideoError(
                f"--fps {float(fps):g} disagrees with the frame rate {meta.fps:g} of "
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
                f"image folder {path} has no frame rate: pass --fps (the camera's frame rate) "
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


def track_sources(
    sources: Sequence[tuple[str, Path, float | None]], *, progress: bool = False
) -> list[MarkerTracks]:
    """Track the markers of every ``(sensor, source, fps)``; a progress bar (stderr) if asked."""
    from liquidtouch.io.frames import iter_frames, video_info

    tracks = []
    for sensor, source, fps in sources:
        total = None
        if source.is_file():
            total = video_info(source).frames or None
        with progress_bar(f"tracking {sensor}", total, enabled=progress) as advance:
            tracks.append(track_markers(iter_frames(source, fps=fps), sensor, on_frame=advance))
    check_consistent(tracks)
    return tracks


def check_consistent(tracks: Sequence[MarkerTracks]) -> None:
    """The videos of one trial must have the same frame count (±1) and frame rate (±1 %)."""
    if len(tracks) < 2:
        return
    first = tracks[0]
    rate0 = 1.0 / float(np.median(np.diff(first.t))) if len(first.t) > 1 else float("nan")
    for tr in tracks[1:]:
        if abs(len(tr.t) - len(first.t)) > 1:
            raise VideoError(
                f"videos of one trial differ in length: {first.sensor} has {len(first.t)} "
                f"frames, {tr.sensor} has {len(tr.t)}; give the videos of one recording"
            )
        rate = 1.0 / float(np.median(np.diff(tr.t))) if len(tr.t) > 1 else float("nan")
        if not abs(rate - rate0) <= RATE_TOLERANCE * rate0:
            raise VideoError(
                f"videos of one trial differ in frame rate: {first.sensor} {rate0:.3f} fps, "
                f"{tr.sensor} {rate:.3f} fps; give the videos of one recording"
            )


def extract(
    paths: PathLike | Sequence[PathLike],
    *,
    lowpass_hz: float | None = 3.0,
    n_markers: int = 16,
    fps: float | None = None,
    progress: bool = False,
    fit: bool = True,
    fit_settings: FitSettings | None = None,
    sensors: Sequence[str] | None = None,
) -> Extraction:
    """Tracks, tactile signal and (when ``fit``) the oscillation fit of one trial's videos.

    ``fps`` is the frame rate of image folders given directly (video files carry
    their own timestamps; a trial's folders use its ``meta.json`` ``fps``; a
    folder's ``timestamps.csv`` wins over both). ``fit_settings``: how the signal
    is fitted (default :class:`FitSettings`: the free decay, the paper's loss,
    two modes). ``sensors``: names of the sensors to use (video stems, e.g.
    ``["left"]``; default all). The options are checked before any video is read.
    """
    check_signal_options(lowpass_hz, n_markers)
    settings = FitSettings() if fit_settings is None else fit_settings
    if not isinstance(settings, FitSettings):
        raise TypeError(f"fit_settings must be a FitSettings, got {type(settings).__name__}")
    from liquidtouch.io.trial_tracks import stored_tracks

    tracks = stored_tracks(paths, sensors)  # a trial of imported marker tracks: no videos
    if tracks is None:
        sources = select_sensors(resolve_sources(paths, fps=fps), sensors)
        tracks = track_sources(sources, progress=progress)
    signal = tactile_signal(tracks, lowpass_hz=lowpass_hz, n_markers=n_markers)
    result = settings.fit(signal.t, signal.u) if fit else None
    return Extraction(tracks=tracks, signal=signal, fit=result)


def extract_signal(
    paths: PathLike | Sequence[PathLike],
    *,
    lowpass_hz: float | None = 3.0,
    n_markers: int = 16,
    fps: float | None = None,
    progress: bool = False,
) -> TactileSignal:
    """The tactile signal ``u(t)`` of video files, image folders, or a trial directory."""
    return extract(
        paths, lowpass_hz=lowpass_hz, n_markers=n_markers, fps=fps, progress=progress, fit=False
    ).signal


def extract_trial(
    trial_dir: PathLike,
    *,
    lowpass_hz: float | None = 3.0,
    n_markers: int = 16,
    fit_settings: FitSettings | None = None,
    sensors: Sequence[str] | None = None,
) -> dict[str, object]:
    """Feature row of a trial directory: the fit's keys plus signal facts (see ``Extraction``)."""
    return extract(
        trial_dir,
        lowpass_hz=lowpass_hz,
        n_markers=n_markers,
        fit_settings=fit_settings,
        sensors=sensors,
    ).to_dict()
