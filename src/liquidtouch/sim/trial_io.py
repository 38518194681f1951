"""Writing a simulated trial to a trial directory (formats: ``docs/formats.md``), and plotting it.

Files: ``force.csv`` (time, per-finger shear force and twist), ``wrench.csv``
(the wrist force-torque signal), one video per sensor (when rendered) and,
written last so that its presence means the trial is complete, ``meta.json``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from liquidtouch.io import atomic
from liquidtouch.io.dataset import (
    FORCE_COLUMNS,
    FORCE_NAME,
    WRENCH_COLUMNS,
    WRENCH_NAME,
    TrialMeta,
    write_trial_meta,
)
from liquidtouch.io.figures import save_figure
from liquidtouch.sim.encode import X264_PARAMS
from liquidtouch.sim.trial import CAMERA_FPS, SimulatedTrial

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


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


def trial_meta(trial: SimulatedTrial, *, sensors: list[str], fps: float) -> TrialMeta:
    """The ``meta.json`` contents: labels, ground truth and the simulator's trial parameters."""
    return TrialMeta(
        fps=fps,
        sensors=sensors,
        **trial.labels(),
        simulated=True,
        seed=trial.seed,
        sample_rate_hz=float(1.0 / (trial.t_s[1] - trial.t_s[0])),
        duration_s=trial.loads.duration_s,
        **trial.extra,
        simulator=asdict(trial.params),
    )


def write_trial(
    trial: SimulatedTrial,
    out_dir: str | Path,
    *,
    video: bool = True,
    sensor: str = "default",
    x264_params: str = X264_PARAMS,
) -> Path:
    """Write ``trial`` into ``out_dir`` (created if needed); return the directory.

    With ``video=True`` the GelSight renderer writes one video per finger
    (``liquidtouch.sim.gelsight.write_sensor_videos``); otherwise the trial
    holds the loads and labels only and ``fps`` is the camera's nominal 30.
    ``x264_params`` overrides the video encoder's options (see
    :data:`liquidtouch.sim.encode.X264_PARAMS`).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    _write_csv(out / FORCE_NAME, FORCE_COLUMNS, force_table(trial))
    _write_csv(
        out / WRENCH_NAME, ("t_s", *WRENCH_COLUMNS), np.column_stack([trial.t_s, trial.wrench])
    )
    sensors: list[str] = []
    fps = CAMERA_FPS
    if video:
        from liquidtouch.sim.gelsight import write_sensor_videos

        recording = write_sensor_videos(
            trial.loads, out, sensor=sensor, seed=trial.seed, x264_params=x264_params
        )
        sensors, fps = list(recording.files), float(recording.fps)
    write_trial_meta(out, trial_meta(trial, sensors=sensors, fps=fps))
    return out


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
