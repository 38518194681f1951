"""Linear prediction: continue a sampled signal past its ends (Burg's autoregressive model).

The tactile signal is low-passed on each stretch between gaps on its own
(:mod:`liquidtouch.signal`); a zero-phase filter needs samples beyond a stretch's
ends, and its own odd-reflection padding bends an oscillation there. A free decay
is a sum of damped oscillations, which an autoregressive model of low order
continues exactly, so the ends are continued by one (Burg's method: stable, and
good on short records) and the continuation dropped after filtering.
"""

from __future__ import annotations

import numpy as np

from liquidtouch.errors import SignalError

__all__ = ["AR_FIT", "AR_ORDER", "predict_edges"]

#: order of the prediction [samples]: 4 damped oscillations, with room
AR_ORDER = 8
#: rows next to an end the prediction is fitted to (1.5 s at 25 fps)
AR_FIT = 38


def predict_edges(x: np.ndarray, before: int, after: int, order: int = AR_ORDER) -> np.ndarray:
    """``x`` (T, ...) continued by ``before`` rows back and ``after`` rows on, per column.

    Burg's autoregressive model of ``order`` [samples], fitted to the ``AR_FIT``
    rows next to each end (its linear trend removed, then restored), predicts the
    continuation: a sum of damped oscillations continues as one, where a mirror
    image breaks its curvature. ``x`` needs at least ``3 × order`` rows.
    """
    if x.shape[0] < 3 * order:
        raise SignalError(f"{x.shape[0]} rows are too few to predict from (need {3 * order})")
    shape, x = x.shape[1:], x.reshape(len(x), -1)
    parts = [x]
    if before:
        parts.insert(0, _predict(x[:AR_FIT][::-1], before, order)[::-1])
    if after:
        parts.append(_predict(x[-AR_FIT:], after, order))
    extended = np.concatenate(parts)
    return extended.reshape((len(extended), *shape))


def _predict(x: np.ndarray, n: int, order: int) -> np.ndarray:
    """The ``n`` rows after ``x`` (T, C) by Burg's AR(``order``) of each column's detrended x."""
    steps = np.arange(x.shape[0], dtype=float)
    trend = np.polynomial.polynomial.polyfit(steps, x, 1)  # (2, C)
    y = x - (trend[0] + np.outer(steps, trend[1]))
    a = _burg(y, order)  # (order + 1, C), a[0] = 1
    history = list(y[-order:])
    ahead = np.empty((n, x.shape[1]))
    for k in range(n):
        nxt = -sum(a[j] * history[-j] for j in range(1, order + 1))
        history.append(nxt)
        ahead[k] = nxt
    return ahead + trend[0] + np.outer(x.shape[0] + np.arange(n), trend[1])


def _burg(y: np.ndarray, order: int) -> np.ndarray:
    """Burg's AR coefficients of each column of ``y`` (T, C): (order + 1, C), first row 1."""
    forward, backward = y.copy(), y.copy()
    a = np.zeros((order + 1, y.shape[1]))
    a[0] = 1.0
    for m in range(order):
        f, b = forward[m + 1 :], backward[m:-1]
        energy = np.sum(f**2 + b**2, axis=0)
        k = np.where(energy > 0, -2 * np.sum(f * b, axis=0) / np.where(energy > 0, energy, 1), 0)
        a[: m + 2] = a[: m + 2] + k * a[: m + 2][::-1]
        forward[m + 1 :], backward[m + 1 :] = f + k * b, b + k * f
    return a
