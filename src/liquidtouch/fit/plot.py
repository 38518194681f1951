"""Figure of an oscillation fit: signal, fitted curve, both modes, and the residual.

The plot functions of liquidtouch never select a matplotlib backend: with no
axes given they build a bare :class:`matplotlib.figure.Figure` (no pyplot, so
they work headless and leave a notebook's inline backend alone); with axes
given they draw into them. They return the figure and, given ``path``, save it
atomically in the format named by the path's suffix.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from liquidtouch.errors import LiquidTouchError
from liquidtouch.fit.result import OscillationFit
from liquidtouch.io.figures import save_figure

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["as_axes_list", "plot_fit"]


def as_axes_list(axes: Axes | Sequence[Axes], allowed: tuple[int, ...], what: str) -> list[Axes]:
    """``axes`` (one Axes or a sequence/array of them) as a flat list of ``allowed`` length."""
    from matplotlib.axes import Axes

    flat = [axes] if isinstance(axes, Axes) else list(np.ravel(np.asarray(axes, dtype=object)))
    if len(flat) not in allowed or not all(isinstance(ax, Axes) for ax in flat):
        counts = " or ".join(str(n) for n in allowed)
        raise LiquidTouchError(f"{what} takes {counts} matplotlib Axes (got {axes!r})")
    return flat


def plot_fit(
    t: np.ndarray,
    u: np.ndarray,
    fit: OscillationFit,
    path: str | os.PathLike[str] | None = None,
    *,
    axes: Axes | Sequence[Axes] | None = None,
) -> Figure:
    """Draw the signal, the fit, its slow and fast modes, and the residual; return the figure.

    ``t`` [s] and ``u`` are the samples that were fitted. ``axes``: one Axes
    (signal and fit only) or two (signal and fit, residual); by default a new
    two-panel :class:`~matplotlib.figure.Figure`. ``path``: also save the
    figure there (atomically; format from the suffix, PNG without one).
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    if t.ndim != 1 or t.shape != u.shape:
        raise LiquidTouchError(
            f"t and u must be 1-D of equal length (got shapes {t.shape} and {u.shape})"
        )
    if axes is None:
        from matplotlib.figure import Figure

        fig = Figure(figsize=(9, 5.5))
        ax, ax_res = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    else:
        panels = as_axes_list(axes, (1, 2), "plot_fit")
        ax, ax_res = panels[0], (panels[1] if len(panels) == 2 else None)
        fig = ax.figure
    dense = np.linspace(t[0], t[-1], max(2000, 8 * t.size))
    slow, fast, drift = fit.modes(dense)
    ax.plot(t, u, ".", ms=3, color="0.4", label="signal")
    ax.plot(dense, fit.curve(dense), "-", lw=1.2, color="C3", label="fit")
    ax.plot(
        dense,
        slow + drift,
        "-",
        lw=1.0,
        color="C0",
        label=f"slow mode + drift (λ={fit.decay_rate:.3g}/s, ω={fit.angular_frequency:.3g} rad/s)",
    )
    if fit.model == "two-mode":
        ax.plot(
            dense,
            fast + drift,
            "-",
            lw=1.0,
            color="C2",
            label=f"fast mode + drift (λ'={fit.fast_decay_rate:.3g}/s, "
            f"ω'={fit.fast_angular_frequency:.3g} rad/s)",
        )
    ax.plot(dense, drift, "--", lw=0.8, color="0.2", label="drift")
    ax.set_ylabel("u")
    ax.set_title(f"{fit.model} fit, loss={fit.loss}, R²={fit.r2:.4f}")
    ax.legend(fontsize=8, loc="upper right")
    if ax_res is not None:
        ax_res.plot(t, u - fit.curve(t), ".", ms=2.5, color="C3")
        ax_res.axhline(0.0, color="0.3", lw=0.8)
        ax_res.set_ylabel("residual")
        ax_res.set_xlabel("t [s]")
    else:
        ax.set_xlabel("t [s]")
    if axes is None:
        fig.tight_layout()
    if path is not None:
        save_figure(fig, path)
    return fig
