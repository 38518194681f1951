"""End to end: GelSight videos (or a trial directory) → marker tracks → ``u(t)`` → fit.

``extract_signal(paths)`` gives the :class:`~liquidtouch.signal.TactileSignal`;
``extract(paths)`` also keeps the tracks and runs
:func:`~liquidtouch.fit.oscillation.fit_oscillation` on the free decay
(:class:`~liquidtouch.extraction.fit_settings.FitSettings`: the fit's options and where the
fitted window starts, shared with the ``fit`` command); ``extract_trial(trial_dir)``
gives the feature row used by dataset feature tables. Its figure:
:func:`~liquidtouch.extraction.plot.plot_extraction`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from liquidtouch._core.numbers import fixed, number, with_uncertainty
from liquidtouch._core.progress import progress_bar
from liquidtouch.extraction.codec_check import CodecCheck, check_codec
from liquidtouch.extraction.fit_settings import FitSettings
from liquidtouch.fit.result import OscillationFit
from liquidtouch.io.dataset import trial_sensor_starts
from liquidtouch.io.frames import iter_frames, video_info
from liquidtouch.io.sources import resolve_sources, select_sensors
from liquidtouch.io.trial_tracks import stored_tracks
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ
from liquidtouch.signal.tactile import (
    DEFAULT_N_MARKERS,
    TactileSignal,
    check_signal_options,
    tactile_signal,
)
from liquidtouch.tracking.clock import check_consistent
from liquidtouch.tracking.gel import DEFAULT_TRACKING, check_tracking, track_gel
from liquidtouch.tracking.tracks import MarkerTracks

__all__ = [
    "Extraction",
    "extract",
    "extract_signal",
    "extract_trial",
    "track_sources",
]

PathLike = str | os.PathLike[str]


@dataclass(repr=False)
class Extraction:
    """Everything ``extract`` computed: per-sensor tracks, the signal and its fit.

    Its repr is one short line: the sensors, the signal's length and λ, ω ± std.
    """

    tracks: list[MarkerTracks]
    signal: TactileSignal
    fit: OscillationFit | None
    #: is the recording's codec biasing λ? (None: not checked)
    diagnostics: CodecCheck | None = None

    def __repr__(self) -> str:
        sensors = [tr.sensor for tr in self.tracks]
        signal = self.signal
        head = (
            f"Extraction(sensors={sensors!r}, {len(signal.t)} samples at "
            f"{number(signal.fps, 3)} fps, {signal.n_markers} markers"
        )
        fit = self.fit
        if fit is None:
            return head + ", not fitted)"
        decay = with_uncertainty(fit.decay_rate, fit.decay_rate_std)
        omega = with_uncertainty(fit.angular_frequency, fit.angular_frequency_std)
        return (
            f"{head}, decay_rate={decay} 1/s, angular_frequency={omega} rad/s, r2={fixed(fit.r2)})"
        )

    @property
    def tracking(self) -> str:
        """How the sensors were tracked: ``markers`` or ``flow`` (markerless gels), or per
        sensor (``left:markers,right:flow``) when they differ."""
        kinds = {tr.tracking for tr in self.tracks}
        if len(kinds) == 1:
            return kinds.pop()
        return ",".join(f"{tr.sensor}:{tr.tracking}" for tr in self.tracks)

    def to_dict(self) -> dict[str, object]:
        """The fit's keys plus ``tracking`` (:attr:`tracking`), ``explained_variance``,
        ``n_markers``, ``fps``, ``frames``, ``signal_gap_share`` (share of the recording's
        clock not observed: camera stalls) and, with :attr:`diagnostics`,
        ``frozen_step_share`` and ``codec_lambda_bias``."""
        out = dict(self.fit.to_dict())
        out.update(
            tracking=self.tracking,
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


def track_sources(
    sources: Sequence[tuple[str, Path, float | None]],
    *,
    progress: bool = False,
    starts: dict[str, float] | None = None,
    tracking: str = DEFAULT_TRACKING,
) -> list[MarkerTracks]:
    """Track every ``(sensor, source, fps)``; a progress bar (stderr) if asked.

    ``tracking``: ``auto`` (markers or the gel's own image, found from each video's first
    frame: :mod:`liquidtouch.tracking.gel`), ``markers`` or ``flow``.

    ``starts``: each sensor's first-frame time on the trial's shared clock [s]
    (``meta.json`` ``sensor_start_s``), kept as ``MarkerTracks.start_s`` when every
    sensor has one (else the sensors are aligned on their first frames).
    """
    tracks = []
    for sensor, source, fps in sources:
        total = None
        if source.is_file():
            total = video_info(source).frames or None
        with progress_bar(f"tracking {sensor}", total, enabled=progress) as advance:
            frames = iter_frames(source, fps=fps)
            tracks.append(track_gel(frames, sensor, tracking=tracking, on_frame=advance))
    if starts and all(tr.sensor in starts for tr in tracks):
        for tr in tracks:
            tr.start_s = float(starts[tr.sensor])
    check_consistent(tracks)
    return tracks


def extract(
    paths: PathLike | Sequence[PathLike],
    *,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = DEFAULT_N_MARKERS,
    fps: float | None = None,
    progress: bool = False,
    fit: bool = True,
    fit_settings: FitSettings | None = None,
    sensors: Sequence[str] | None = None,
    tracking: str = DEFAULT_TRACKING,
) -> Extraction:
    """Tracks, tactile signal and (when ``fit``) the oscillation fit of one trial's videos.

    ``fps`` is the frame rate of image folders given directly (video files carry
    their own timestamps; a trial's folders use its ``meta.json`` ``fps``; a
    folder's ``timestamps.csv`` wins over both). ``fit_settings``: how the signal
    is fitted (default :class:`FitSettings`: the free decay, the paper's loss,
    two modes). ``sensors``: names of the sensors to use (video stems, e.g.
    ``["left"]``; default all). ``tracking``: how the gels are tracked (``auto``: printed
    markers, or the gel's own image on a markerless gel; ``markers``; ``flow``). The
    options are checked before any video is read.
    """
    check_signal_options(lowpass_hz, n_markers)
    check_tracking(tracking)
    settings = FitSettings() if fit_settings is None else fit_settings
    if not isinstance(settings, FitSettings):
        raise TypeError(f"fit_settings must be a FitSettings, got {type(settings).__name__}")
    tracks = stored_tracks(paths, sensors)  # a trial of imported marker tracks: no videos
    sources: list[tuple[str, Path, float | None]] = []
    if tracks is None:
        sources = select_sensors(resolve_sources(paths, fps=fps), sensors)
        starts = trial_sensor_starts(paths)
        tracks = track_sources(sources, progress=progress, starts=starts, tracking=tracking)
    signal = tactile_signal(tracks, lowpass_hz=lowpass_hz, n_markers=n_markers)
    result = settings.fit(signal.t, signal.u) if fit else None
    check = check_codec(tracks, [path for _, path, _ in sources], n_markers)
    return Extraction(tracks=tracks, signal=signal, fit=result, diagnostics=check)


def extract_signal(
    paths: PathLike | Sequence[PathLike],
    *,
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = DEFAULT_N_MARKERS,
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
    lowpass_hz: float | None = DEFAULT_LOWPASS_HZ,
    n_markers: int = DEFAULT_N_MARKERS,
    fit_settings: FitSettings | None = None,
    sensors: Sequence[str] | None = None,
    tracking: str = DEFAULT_TRACKING,
) -> dict[str, object]:
    """Feature row of a trial directory: the fit's keys plus signal facts (see ``Extraction``)."""
    return extract(
        trial_dir,
        lowpass_hz=lowpass_hz,
        n_markers=n_markers,
        fit_settings=fit_settings,
        sensors=sensors,
        tracking=tracking,
    ).to_dict()
