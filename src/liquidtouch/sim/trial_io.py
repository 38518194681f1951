"""Writing a simulated trial to a trial directory (formats: ``docs/formats.md``), and plotting it.

Files: ``force.csv`` (time, per-finger shear force and twist), ``wrench.csv``
(the wrist force-torque signal), one video per sensor (when rendered),
``truth_tracks.npz`` (with the videos), ``loads.png`` (on request) and, written
last so that its presence means the trial is complete, ``meta.json``.

The whole directory is built beside the target and renamed into place at the
end (:func:`liquidtouch._core.atomic.atomic_directory`): a failed or interrupted
write leaves an existing trial exactly as it was. An existing directory is only
replaced if it holds nothing but trial files.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from liquidtouch._core import atomic
from liquidtouch.io.dataset import (
    FORCE_COLUMNS,
    FORCE_NAME,
    META_NAME,
    TRUTH_TRACKS_NAME,
    WRENCH_COLUMNS,
    WRENCH_NAME,
    TrialMeta,
    write_trial_meta,
)
from liquidtouch.io.figures import save_figure
from liquidtouch.sim.encode import X264_PARAMS
from liquidtouch.sim.gelsight import write_sensor_videos
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.sim.trial import CAMERA_FPS, SimulatedTrial

PLOT_NAME = "loads.png"
TRIAL_FILES = frozenset(
    {META_NAME, FORCE_NAME, WRENCH_NAME, TRUTH_TRACKS_NAME, "left.mp4", "right.mp4", PLOT_NAME}
)
"""The files ``write_trial`` may write: a directory holding only these may be replaced."""

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "PLOT_NAME",
    "TRIAL_FILES",
    "check_trial_dir",
    "force_table",
    "plot_trial",
    "trial_meta",
    "write_trial",
]


def _write_csv(path: Path, header: tuple[str, ...], table: np.ndarray) -> None:
    with atomic.atomic_path(path) as tmp:
        np.savetxt(tmp, table, fmt="%.7g", delimiter=",", header=",".join(header), comments="")


def force_table(trial: SimulatedTrial) -> np.ndarray:
    """The rows of ``force.csv``: ``FORCE_COLUMNS`` (N, N·mm, s)."""
    loads = trial.loads
    cols = [loads.t_s]
    for finger in range(2):
        cols += [
            loads.shear_force_n[:, finger, 0],
            loads.shear_force_n[:, finger, 1],
            loads.twist_moment_nmm[:, finger],
        ]
    return np.column_stack(cols)


def trial_meta(
    trial: SimulatedTrial,
    *,
    sensors: list[str],
    fps: float,
    camera_drawn: dict[str, object] | None = None,
) -> TrialMeta:
    """The ``meta.json`` contents: labels, ground truth and the simulator's trial parameters.

    ``realism`` records the world the trial was simulated in (its name, every
    nuisance parameter and what the nuisances drew; ``camera_drawn`` adds the
    camera's draws under ``drawn.camera``).
    """
    realism = trial.realism_record()
    if camera_drawn:
        realism["drawn"] = {**realism["drawn"], "camera": camera_drawn}
    return TrialMeta(
        fps=fps,
        sensors=sensors,
        **trial.labels(),
        simulated=True,
        seed=trial.seed,
        sample_rate_hz=float(1.0 / (trial.t_s[1] - trial.t_s[0])),
        duration_s=trial.loads.duration_s,
        **trial.extra,
        # a push across the container is recorded; the paper's push (x) leaves meta as it was
        **({"push_axis": trial.push_axis} if trial.push_axis != "x" else {}),
        simulator=asdict(trial.params),
        realism=realism,
    )


def _trial_replace_reason(path: Path) -> str | None:
    """``None`` if the existing directory ``path`` may be replaced by a new trial, else why not."""
    try:
        names = [entry.name for entry in os.scandir(path)]
    except OSError as exc:
        return f"it cannot be read ({exc.strerror or exc})"
    foreign = sorted(
        name
        for name in names
        if name not in TRIAL_FILES and not (name.startswith(".") and ".tmp" in name)
    )
    if foreign:
        shown = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
        return (
            f"it holds files that are not part of a simulated trial ({shown}); "
            "choose a new or empty directory, or an existing trial directory"
        )
    return None


def check_trial_dir(out_dir: str | Path) -> Path:
    """Raise :class:`~liquidtouch.errors.OutputError` now unless ``out_dir`` can take a trial.

    ``out_dir`` may be new, an empty directory, or a directory holding only
    trial files (:data:`TRIAL_FILES`: it is replaced as a whole). Writes nothing;
    returns the resolved directory path.
    """
    return atomic.check_directory_target(out_dir, replaceable=_trial_replace_reason)


def write_trial(
    trial: SimulatedTrial,
    out_dir: str | Path,
    *,
    video: bool = True,
    sensor: str = "default",
    x264_params: str = X264_PARAMS,
    plot: bool = False,
) -> Path:
    """Write ``trial`` as the trial directory ``out_dir``; return the directory.

    With ``video=True`` the GelSight renderer writes one video per finger
    (``liquidtouch.sim.gelsight.write_sensor_videos``); otherwise the trial
    holds the loads and labels only and ``fps`` is the camera's nominal 30.
    ``x264_params`` overrides the video encoder's options (see
    :data:`liquidtouch.sim.encode.X264_PARAMS`). ``plot`` also saves
    ``loads.png`` (:func:`plot_trial`). The camera, gel and image nuisances of
    ``trial.realism`` (:mod:`liquidtouch.sim.realism`) act on the videos here.

    The directory is built beside ``out_dir`` and renamed into place at the
    end, replacing an existing trial there as a whole; on any failure (or
    Ctrl-C) an existing ``out_dir`` is left untouched and nothing else remains.
    ``sensor`` and ``out_dir`` are checked before anything is written: an
    unknown sensor raises :class:`~liquidtouch.errors.CatalogueError`; an
    ``out_dir`` that is a file, or a directory holding other files, raises
    :class:`~liquidtouch.errors.OutputError`.
    """
    get_sensor_profile(sensor)
    with atomic.atomic_directory(out_dir, replaceable=_trial_replace_reason) as tmp:
        _write_csv(tmp / FORCE_NAME, FORCE_COLUMNS, force_table(trial))
        _write_csv(
            tmp / WRENCH_NAME,
            ("t_s", *WRENCH_COLUMNS),
            np.column_stack([trial.t_s, trial.wrench]),
        )
        sensors: list[str] = []
        fps = CAMERA_FPS
        camera_drawn: dict[str, object] = {}
        if video:
            recording = write_sensor_videos(
                trial.loads,
                tmp,
                sensor=sensor,
                seed=trial.seed,
                x264_params=x264_params,
                realism=trial.realism,
            )
            sensors, fps = list(recording.files), float(recording.fps)
            camera_drawn = recording.drawn
        if plot:
            plot_trial(trial, tmp / PLOT_NAME)
        write_trial_meta(
            tmp, trial_meta(trial, sensors=sensors, fps=fps, camera_drawn=camera_drawn)
        )
    return Path(out_dir)


def plot_trial(
    trial: SimulatedTrial, path: str | Path | None = None, *, axes: Sequence[Axes] | None = None
) -> Figure:
    """Plot the trial's gel shear force, gel twist and wrist force over time; return the figure.

    Draws three panels into ``axes`` (a sequence of three Axes) when given, else
    into a new :class:`matplotlib.figure.Figure` (not registered with pyplot, so
    it neither changes the backend nor stays open; Jupyter shows the returned
    figure inline). With ``path`` the figure is also saved there atomically, in
    the format of its suffix (``.png``, ``.pdf``, ``.svg``; PNG if none).
    """
    if axes is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(8, 7))
        axes = fig.subplots(3, 1, sharex=True)
        own_figure = True
    else:
        if len(axes) != 3:
            raise ValueError(f"plot_trial draws 3 panels; got {len(axes)} axes")
        fig = axes[0].figure
        own_figure = False
    t = trial.t_s
    for finger, name in enumerate(("left", "right")):
        axes[0].plot(t, trial.loads.shear_force_n[:, finger, 0], lw=0.8, label=name)
        axes[1].plot(t, trial.loads.twist_moment_nmm[:, finger], lw=0.8, label=name)
    axes[2].plot(t, trial.wrench[:, 0], lw=0.5, color="0.4", label="wrist Fx")
    axes[0].set_ylabel("shear x [N]")
    axes[1].set_ylabel("twist [N·mm]")
    axes[2].set_ylabel("wrist Fx [N]")
    axes[2].set_xlabel("time [s]")
    for ax in axes:
        ax.axvspan(trial.params.push_start_s, trial.params.push_end_s, color="C3", alpha=0.15)
        ax.legend(loc="upper right", fontsize=8)
    conc = (
        f", c={trial.sugar_concentration:g}"
        if trial.liquid == "sugar-water" and trial.sugar_concentration is not None
        else ""
    )
    axes[0].set_title(
        f"{trial.liquid}{conc}, h={trial.height_mm:g} mm, {trial.container}: "
        f"λ={trial.true_decay_rate:.3f} 1/s, ω={trial.true_angular_frequency:.2f} rad/s"
    )
    if own_figure:
        fig.tight_layout()
    if path is not None:
        save_figure(fig, path)
    return fig
