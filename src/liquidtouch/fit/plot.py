"""Figure of an oscillation fit: signal, fitted curve, both modes, and the residual."""

from __future__ import annotations

import os

import numpy as np

from liquidtouch.fit.oscillation import OscillationFit
from liquidtouch.io import atomic


def plot_fit(
    t: np.ndarray, u: np.ndarray, fit: OscillationFit, path: str | os.PathLike[str]
) -> None:
    """Draw the signal, the fit, its slow and fast modes, and the residual; save a PNG atomically.

    ``t`` [s] and ``u`` are the samples that were fitted.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float)
    dense = np.linspace(t[0], t[-1], max(2000, 8 * t.size))
    slow, fast, drift = fit.modes(dense)
    fig, (ax, ax_res) = plt.subplots(
        2, 1, figsize=(9, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]}
    )
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
    ax_res.plot(t, u - fit.curve(t), ".", ms=2.5, color="C3")
    ax_res.axhline(0.0, color="0.3", lw=0.8)
    ax_res.set_ylabel("residual")
    ax_res.set_xlabel("t [s]")
    fig.tight_layout()
    with atomic.atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
