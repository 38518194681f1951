"""The wrist force-torque baseline: the same oscillation fit on the wrist F/T signal.

The paper compares GelSight with a wrist F/T sensor (its noise is far larger
than the slosh force). We treat the wrist signal exactly like the markers:
zero-phase low-pass, then the first principal component of the force
channels, resampled to the camera's rate, then :func:`fit_oscillation`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from liquidtouch.errors import SignalError
from liquidtouch.io.dataset import WRENCH_NAME, read_wrench_csv


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
    from liquidtouch.fit.oscillation import fit_oscillation
    from liquidtouch.segment import free_decay

    t_s, force_n = read_wrench_csv(Path(trial_dir) / WRENCH_NAME)
    t, u, explained = wrench_signal(t_s, force_n)
    row = dict(fit_oscillation(*free_decay(t, u)).to_dict())
    row.update(explained_variance=explained, n_markers=0, fps=30.0, frames=len(t))
    return row
