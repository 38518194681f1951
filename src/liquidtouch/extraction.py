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
SPAN_TOLERANCE = 0.05  # fraction of the longest video the others may not cover


@dataclass
class Extraction:
    """Everything ``extract`` computed: per-sensor tracks, the signal and its fit."""

    tracks: list[MarkerTracks]
    signal: TactileSignal
    fit: object  # liquidtouch.fit.oscillation.OscillationFit
    #: is the recording's codec biasing λ? (``liquidtouch.codec_check.CodecCheck``)
    diagnostics: object = None

    def to_dict(self) -> dict[str, object]:
        """The fit's keys plus ``explained_variance``, ``n_markers``, ``fps``, ``frames``,
        ``signal_gap_share`` (share of the recording's clock not observed: camera stalls)
        and, with :attr:`diagnostics`, ``frozen_step_share`` and ``codec_lambda_bias``."""
        out = dict(self.fit.to_dict())
        out.update(
            explained_variance=float(self.signal.explained_variance),
            n_markers=int(self.signal.n_markers),
            fps=float(self.signal.fps),
            frames=len(self.signal.t),
            signal_gap_share=float(self.signal.gap_share),
        )
        if self.diagnostics is not None:
            out.update(
                frozen_step_share=float(self.diagnostics.frozen_step_share),
                codec_lambda_bias=float(self.diagnostics.expected_lambda_bias),
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
    sources: Sequence[tuple[str, Path, float | None]],
    *,
    progress: bool = False,
    starts: dict[str, float] | None = None,
) -> list[MarkerTracks]:
    """Track the markers of every ``(sensor, source, fps)``; a progress bar (stderr) if asked.

    ``starts``: each sensor's first-frame time on the trial's shared clock [s]
    (``meta.json`` ``sensor_start_s``), kept as ``MarkerTracks.start_s`` when every
    sensor has one (else the sensors are aligned on their first frames).
    """
    from liquidtouch.io.frames import iter_frames, video_info

    tracks = []
    for sensor, source, fps in sources:
        total = None
        if source.is_file():
            total = video_info(source).frames or None
        with progress_bar(f"tracking {sensor}", total, enabled=progress) as advance:
            tracks.append(track_markers(iter_frames(source, fps=fps), sensor, on_frame=advance))
    if starts and all(tr.sensor in starts for tr in tracks):
        for tr in tracks:
            tr.start_s = float(starts[tr.sensor])
    check_consistent(tracks)
    return tracks


def check_consistent(tracks: Sequence[MarkerTracks]) -> None:
    """The videos of one trial must be one recording: VideoError otherwise.

    Their frame rates (the period fitted to all timestamps,
    :func:`~liquidtouch.clock.frame_period`) agree within :data:`RATE_TOLERANCE`,
    and their time spans (on the trial's shared clock, ``MarkerTracks.start_s``)
    overlap over all but :data:`SPAN_TOLERANCE` of the longest (at least two frame
    periods). Frame counts may differ: sensors drop frames independently.
    """
    if len(tracks) < 2:
        return
    from liquidtouch.clock import frame_period
    from liquidtouch.errors import SignalError

    try:
        periods = [frame_period(tr.t) for tr in tracks]
    except SignalError:  # bad timestamps: the signal says so, per sensor
        return
    rates = [1.0 / p for p in periods]
    for tr, rate in zip(tracks[1:], rates[1:], strict=True):
        if not abs(rate - rates[0]) <= RATE_TOLERANCE * rates[0]:
            raise VideoError(
                f"videos of one trial differ in frame rate: {tracks[0].sensor} {rates[0]:.3f} "
                f"fps, {tr.sensor} {rate:.3f} fps; give the videos of one recording"
            )
    starts = [float(tr.start_s) for tr in tracks]
    ends = [s + float(tr.t[-1] - tr.t[0]) for s, tr in zip(starts, tracks, strict=True)]
    longest = max(e - s for s, e in zip(starts, ends, strict=True))
    overlap = min(ends) - max(starts)
    if longest - overlap > max(2 * max(periods), SPAN_TOLERANCE * longest):
        spans = ", ".join(
            f"{tr.sensor} {s:.2f}–{e:.2f} s" for tr, s, e in zip(tracks, starts, ends, strict=True)
        )
        raise VideoError(
            f"videos of one trial differ in length: {spans} (together {max(overlap, 0):.2f} s); "
            "give the videos of one recording"
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
    sources: list[tuple[str, Path, float | None]] = []
    if tracks is None:
        from liquidtouch.io.dataset import trial_sensor_starts

        sources = select_sensors(resolve_sources(paths, fps=fps), sensors)
        tracks = track_sources(sources, progress=progress, starts=trial_sensor_starts(paths))
    signal = tactile_signal(tracks, lowpass_hz=lowpass_hz, n_markers=n_markers)
    result = settings.fit(signal.t, signal.u) if fit else None
    from liquidtouch.codec_check import check_codec

    check = check_codec(tracks, [path for _, path, _ in sources], n_markers)
    return Extraction(tracks=tracks, signal=signal, fit=result, diagnostics=check)


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
