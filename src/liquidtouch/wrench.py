"""The wrist force-torque baseline: the same oscillation fit on the wrist F/T signal.

The paper compares GelSight with a wrist F/T sensor (its noise is far larger
than the slosh force). We treat the wrist signal exactly like the markers:
zero-phase low-pass, then the first principal component of the force
channels, resampled to the camera's rate, then :func:`fit_oscillation`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from liquidtouch.errors import SignalError, TableError

WRENCH_NAME = "wrench.csv"
FORCE_CHANNELS = ("fx_n", "fy_n", "fz_n")


def read_wrench_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read ``wrench.csv``: time ``t_s`` [s] and the force channels [N] as an (n, 3) array."""
    import pandas as pd

    path = Path(path)
    if not path.is_file():
        raise TableError(f"{path} not found: the trial has no wrist force-torque recording")
    table = pd.read_csv(path)
    missing = [c for c in ("t_s", *FORCE_CHANNELS) if c not in table.columns]
    if missing:
        raise TableError(f"{path} lacks column(s) {', '.join(missing)}")
    values = table[["t_s", *FORCE_CHANNELS]].to_numpy(dtype=float)
    if not np.isfinite(values).all():
        raise TableError(f"{path} holds NaN or infinite values")
    return values[:, 0], values[:, 1:]


def wrench_signal(
    t_s: np.ndarray, force_n: np.ndarray, *, lowpass_hz: float = 3.0, fps: float = 30.0
) -> tuple[np.ndarray, np.ndarray, float]:
    """``(t, u, explained variance)`` of the wrist forces, on a uniform ``fps`` clock."""
    from liquidtouch.signal import first_component, lowpass

    rate = 1.0 / float(np.median(np.diff(t_s)))
    if rate < 2 * lowpass_hz:
        raise SignalError(f"the wrist signal's {rate:.3g} Hz rate is too low for the low-pass")
    smooth = lowpass(force_n, rate, lowpass_hz)
    t_uniform = np.arange(t_s[0], t_s[-1], 1.0 / fps)
    resampled = np.column_stack([np.interp(t_uniform, t_s, smooth[:, j]) for j in range(3)])
    u, _, explained = first_component(resampled)
    return t_uniform, u, explained


def wrench_features(trial_dir: str | Path) -> dict[str, float]:
    """Feature row of a trial's wrist F/T signal (the same keys as the GelSight features)."""
    from liquidtouch.oscillation import fit_oscillation
    from liquidtouch.segment import free_decay

    t_s, force_n = read_wrench_csv(Path(trial_dir) / WRENCH_NAME)
    t, u, explained = wrench_signal(t_s, force_n)
    row = dict(fit_oscillation(*free_decay(t, u)).to_dict())
    row.update(explained_variance=explained, n_markers=0, fps=30.0, frames=len(t))
    return row
