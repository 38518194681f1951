"""The figure of an extraction: the markers on the first frames, their motions, u(t) and fit."""

from __future__ import annotations

from typing import TYPE_CHECKING

from liquidtouch.fit.plot import as_axes_list
from liquidtouch.io.figures import save_figure

if TYPE_CHECKING:
    from collections.abc import Sequence

    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from liquidtouch.extraction.pipeline import Extraction, PathLike
    from liquidtouch.signal.tactile import TactileSignal
    from liquidtouch.tracking.tracks import MarkerTracks

__all__ = ["plot_extraction"]


def plot_extraction(
    extraction: Extraction,
    path: PathLike | None = None,
    *,
    axes: Axes | Sequence[Axes] | None = None,
) -> Figure:
    """First frames with markers (chosen ones highlighted), marker motions, u(t) and fit.

    ``axes``: one Axes (u(t) and fit only) or a 2 × ``max(2, sensors)`` grid of
    Axes (first row: each sensor's first frame; second row: the motions, then
    u(t)); by default a new :class:`~matplotlib.figure.Figure` (built without
    pyplot: no backend is selected). ``path``: also save the figure there,
    atomically (format from the suffix, PNG without one). Returns the figure.
    """

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
    """u(t); the fit drawn only over the window it was fitted to (shaded), not through the push."""
    signal = extraction.signal
    ax.plot(signal.t, signal.u, color="k", lw=1, label="u(t)")
    if extraction.fit is not None:
        fit = extraction.fit
        start, end = fit.t0, fit.t0 + fit.duration_s
        ax.axvspan(start, end, color="tab:red", alpha=0.08, lw=0, label="fitted window")
        inside = (signal.t >= start) & (signal.t <= end)
        ax.plot(signal.t[inside], fit.curve(signal.t[inside]), color="tab:red", lw=1, label="fit")
        ax.set_title(
            f"λ = {fit.decay_rate:.3g} 1/s, ω = {fit.angular_frequency:.3g} rad/s, "
            f"EV = {signal.explained_variance:.1%}"
        )
    ax.set(xlabel="t [s]", ylabel="u [px]")
    ax.legend(fontsize=8)
