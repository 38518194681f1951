"""The wrist force-torque baseline: the same oscillation fit on the wrist F/T signal.

The paper compares GelSight with a wrist F/T sensor (its noise is far larger
than the slosh force). We treat the wrist signal exactly like the markers:
zero-phase low-pass, then the first principal component of the force
channels, resampled to the camera's rate (:data:`WRENCH_FPS`), then the
oscillation fit (:class:`~liquidtouch.extraction.fit_settings.FitSettings`). A wrist signal
with no oscillation above its noise is refused, unless ``best_effort`` asks for the
fit anyway, as the paper did for its F/T baseline.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from liquidtouch.errors import SignalError
from liquidtouch.extraction.fit_settings import AUTO, FitSettings
from liquidtouch.fit.oscillation import fit_oscillation
from liquidtouch.io.dataset import WRENCH_NAME, read_trial_meta, read_wrench_csv
from liquidtouch.signal.lowpass import DEFAULT_LOWPASS_HZ, lowpass
from liquidtouch.signal.tactile import first_component

if TYPE_CHECKING:
    from liquidtouch.extraction.fit_settings import FitSettings

WRENCH_FPS = 30.0
"""The clock the wrist signal is resampled to [Hz] (the cameras' frame rate)."""


def wrench_signal(
    t_s: np.ndarray,
    force_n: np.ndarray,
    *,
    lowpass_hz: float = DEFAULT_LOWPASS_HZ,
    fps: float = WRENCH_FPS,
) -> tuple[np.ndarray, np.ndarray, float]:
    """``(t [s], u [N], explained variance)`` of the wrist forces, on a uniform ``fps`` clock.

    ``t_s`` (n,) [s] and ``force_n`` (n, 3) [N] are the wrist samples; ``lowpass_hz``
    [Hz] is the zero-phase low-pass cut-off applied before the principal component.
    """

    rate = 1.0 / float(np.median(np.diff(t_s)))
    if rate < 2 * lowpass_hz:
        raise SignalError(f"the wrist signal's {rate:.3g} Hz rate is too low for the low-pass")
    smooth = lowpass(force_n, rate, lowpass_hz)
    t_uniform = np.arange(t_s[0], t_s[-1], 1.0 / fps)
    resampled = np.column_stack([np.interp(t_uniform, t_s, smooth[:, j]) for j in range(3)])
    u, _, explained = first_component(resampled)
    return t_uniform, u, explained


def wrench_features(
    trial_dir: str | Path,
    *,
    lowpass_hz: float = DEFAULT_LOWPASS_HZ,
    fit_settings: FitSettings | None = None,
    best_effort: bool = False,
) -> dict[str, float]:
    """Feature row of a trial's wrist F/T signal (the same keys as the GelSight features).

    ``lowpass_hz`` [Hz]: the low-pass of the wrist forces (:func:`wrench_signal`);
    ``fit_settings``: how the signal is fitted (default
    :class:`~liquidtouch.extraction.fit_settings.FitSettings`: the free decay, the paper's fit);
    ``best_effort``: fit even a signal that shows no oscillation above its noise
    (and where no push stands out of it, from the end of the push the trial's
    ``meta.json`` records, ``push_end_s``: the robot knows when it pushed).
    """
    import dataclasses

    fit = FitSettings() if fit_settings is None else fit_settings
    t_s, force_n = read_wrench_csv(Path(trial_dir) / WRENCH_NAME)
    t, u, explained = wrench_signal(t_s, force_n, lowpass_hz=lowpass_hz, fps=WRENCH_FPS)
    try:
        window = fit.window(t, u)
    except SignalError:
        push_end_s = (read_trial_meta(trial_dir).model_extra or {}).get("push_end_s")
        if not best_effort or fit.start != AUTO or not isinstance(push_end_s, int | float):
            raise
        window = dataclasses.replace(fit, start=float(push_end_s)).window(t, u)
    result = fit_oscillation(*window, **fit.fit_options(), check_oscillation=not best_effort)
    row = dict(result.to_dict())
    row.update(explained_variance=explained, n_markers=0, fps=WRENCH_FPS, frames=len(t))
    return row
