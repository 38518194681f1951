"""End to end: GelSight videos (or a trial directory) → marker tracks → ``u(t)`` → fit.

``extract_signal(paths)`` gives the :class:`~liquidtouch.signal.TactileSignal`;
``extract(paths)`` also keeps the tracks and runs
:func:`~liquidtouch.fit.oscillation.fit_oscillation`; ``extract_trial(trial_dir)``
gives the feature row used by dataset feature tables.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from liquidtouch.errors import VideoError
from liquidtouch.progress import progress_bar
from liquidtouch.signal import TactileSignal, check_signal_options, tactile_signal
from liquidtouch.tracking.tracks import MarkerTracks, track_markers

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

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


def resolve_sources(paths: PathLike | Sequence[PathLike]) -> list[tuple[str, Path]]:
    """``(sensor name, source)`` pairs from video files, image folders or one trial directory."""
    from liquidtouch.io.dataset import META_NAME, read_trial_meta

    items = [paths] if isinstance(paths, str | os.PathLike) else list(paths)
    if not items:
        raise VideoError("no video given; pass video files, image folders or a trial directory")
    items = [Path(p) for p in items]
    if len(items) == 1 and items[0].is_dir() and (items[0] / META_NAME).is_file():
        trial = items[0]
        meta = read_trial_meta(trial)
        if not meta.sensors:
            raise VideoError(f"{trial / META_NAME} lists no sensor videos ('sensors')")
        return [(Path(name).stem, trial / name) for name in meta.sensors]
    names = [p.stem or p.name for p in items]
    if len(set(names)) < len(names):  # two sensors called e.g. "video": number them
        names = [f"{name}{k}" for k, name in enumerate(names)]
    for path in items:
        if not path.exists():
            raise VideoError(f"{path} does not exist; give a video file, image folder or trial")
    return list(zip(names, items, strict=True))


def track_sources(
    sources: Sequence[tuple[str, Path]], *, fps: float = 30.0, progress: bool = False
) -> list[MarkerTracks]:
    """Track the markers of every source; a rich progress bar (on stderr) when ``progress``."""
    from liquidtouch.io.frames import iter_frames, video_info

    tracks = []
    for sensor, source in sources:
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
    fps: float = 30.0,
    progress: bool = False,
    fit: bool = True,
) -> Extraction:
    """Tracks, tactile signal and (when ``fit``) the oscillation fit of one trial's videos.

    ``fps`` is the frame rate of image folders (video files carry their own timestamps).
    The options are checked before any video is read.
    """
    check_signal_options(lowpass_hz, n_markers)
    tracks = track_sources(resolve_sources(paths), fps=fps, progress=progress)
    signal = tactile_signal(tracks, lowpass_hz=lowpass_hz, n_markers=n_markers)
    result = None
    if fit:
        from liquidtouch.fit.oscillation import fit_oscillation
        from liquidtouch.segment import free_decay

        result = fit_oscillation(*free_decay(signal.t, signal.u))
    return Extraction(tracks=tracks, signal=signal, fit=result)


def extract_signal(
    paths: PathLike | Sequence[PathLike],
    *,
    lowpass_hz: float | None = 3.0,
    n_markers: int = 16,
    fps: float = 30.0,
    progress: bool = False,
) -> TactileSignal:
    """The tactile signal ``u(t)`` of video files, image folders, or a trial directory."""
    return extract(
        paths, lowpass_hz=lowpass_hz, n_markers=n_markers, fps=fps, progress=progress, fit=False
    ).signal


def extract_trial(trial_dir: PathLike) -> dict[str, object]:
    """Feature row of a trial directory: the fit's keys plus signal facts (see ``Extraction``)."""
    return extract(trial_dir).to_dict()


def plot_extraction(
    extraction: Extraction, path: PathLike | None = None, *, axes: object = None
) -> Figure:
    """First frames with markers (chosen ones highlighted), marker motions, u(t) and fit.

    ``axes``: one Axes (u(t) and fit only) or a 2 × ``max(2, sensors)`` grid of
    Axes (first row: each sensor's first frame; second row: the motions, then
    u(t)); by default a new :class:`~matplotlib.figure.Figure` (built without
    pyplot: no backend is selected). ``path``: also save the figure there,
    atomically (format from the suffix, PNG without one). Returns the figure.
    """
    from liquidtouch.fit.plot import as_axes_list
    from liquidtouch.io.figures import save_figure

    tracks, signal = extraction.tracks, extraction.signal
    columns = max(2, len(tracks))
    if axes is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(5 * columns, 8))
        panels = list(fig.subplots(2, columns, squeeze=False).ravel())
    else:
        panels = as_axes_list(axes, (1, 2 * columns), "plot_extraction")
        fig = panels[0].figure
    if len(panels) > 1:
        for ax, tr in zip(panels[:columns], tracks, strict=False):
            _draw_markers(ax, tr, signal)
        _draw_motion(panels[columns], signal)
    _draw_signal(panels[columns + 1] if len(panels) > 1 else panels[0], extraction)
    if axes is None:
        fig.tight_layout()
    if path is not None:
        save_figure(fig, path, dpi=90)
    return fig


def _draw_markers(ax: Axes, tr: MarkerTracks, signal: TactileSignal) -> None:
    if tr.first_frame is not None:
        ax.imshow(tr.first_frame, cmap="gray")
    ax.plot(*tr.reference.T, "o", mfc="none", mec="tab:blue", ms=6, label="markers")
    chosen = [i for name, i in signal.markers if name == tr.sensor]
    ax.plot(*tr.reference[chosen].T, "o", color="tab:red", ms=6, label="chosen")
    ax.set_title(f"{tr.sensor}: {tr.n_markers} markers, {len(chosen)} chosen")
    ax.legend(loc="upper right", fontsize=8)


def _draw_motion(ax: Axes, signal: TactileSignal) -> None:
    for k in range(signal.n_markers):
        ax.plot(signal.t, signal.motion[:, k, 0], lw=0.8, color="tab:blue", alpha=0.6)
        ax.plot(signal.t, signal.motion[:, k, 1], lw=0.8, color="tab:orange", alpha=0.6)
    ax.set(xlabel="t [s]", ylabel="displacement [px] (x blue, y orange)")
    ax.set_title(f"filtered motion of the {signal.n_markers} chosen markers")


def _draw_signal(ax: Axes, extraction: Extraction) -> None:
    signal = extraction.signal
    ax.plot(signal.t, signal.u, color="k", lw=1, label="u(t)")
    if extraction.fit is not None:
        fit = extraction.fit
        ax.plot(signal.t, fit.curve(signal.t), color="tab:red", lw=1, label="fit")
        ax.set_title(
            f"λ = {fit.decay_rate:.3g} 1/s, ω = {fit.angular_frequency:.3g} rad/s, "
            f"EV = {signal.explained_variance:.1%}"
        )
    ax.set(xlabel="t [s]", ylabel="u [px]")
    ax.legend(fontsize=8)
