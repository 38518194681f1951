"""Does a reported std mean what it says? Coverage of the truth by ±kσ intervals.

A std σ is calibrated when the truth lies inside ``mean ± σ`` about 68.3 % of
the time and inside ``mean ± 2σ`` about 95.4 % of the time (Gaussian errors).
:func:`coverage` counts those fractions over many estimates (e.g. every
streaming update of many simulated trials, or their final updates);
:func:`nominal_coverage` gives the Gaussian fractions they are compared with,
and :func:`coverage_interval` the spread a calibrated std's coverage has over
``n`` independent estimates (binomial), to tell miscalibration from chance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from liquidtouch.errors import SignalError

#: the interval half-widths checked, in stds
COVERAGE_KS = (1.0, 2.0)


def nominal_coverage(k: float) -> float:
    """Fraction of Gaussian draws within ``±k`` std of the mean (k = 1: 0.683, 2: 0.954)."""
    return math.erf(float(k) / math.sqrt(2.0))


def coverage(
    estimate: np.ndarray,
    std: np.ndarray,
    truth: np.ndarray,
    ks: Sequence[float] = COVERAGE_KS,
) -> dict[float, float]:
    """``{k: fraction of |estimate − truth| ≤ k·std}`` over the finite rows.

    ``estimate``, ``std`` and ``truth`` broadcast together (same unit); rows
    with a NaN or infinite value or a std ≤ 0 are left out (no estimate
    reported). NaN fractions when no row is left.
    """
    est, sd, tru = np.broadcast_arrays(
        np.asarray(estimate, float), np.asarray(std, float), np.asarray(truth, float)
    )
    ok = np.isfinite(est) & np.isfinite(sd) & np.isfinite(tru) & (sd > 0)
    if any(not 0 < float(k) < math.inf for k in ks):
        raise SignalError(f"coverage half-widths must be numbers > 0 (in stds), got {list(ks)}")
    z = np.abs(est[ok] - tru[ok]) / sd[ok]
    return {float(k): float(np.mean(z <= k)) if z.size else math.nan for k in ks}


def coverage_interval(k: float, n: int, z: float = 2.0) -> tuple[float, float]:
    """Range [low, high] of the coverage at ``±k`` std a calibrated std shows over ``n`` rows.

    The nominal fraction ± ``z`` binomial stds (independent rows; the updates of
    one stream are correlated, so take ``n`` = the number of trials there).
    """
    p = nominal_coverage(k)
    half = z * math.sqrt(p * (1 - p) / max(int(n), 1))
    return max(p - half, 0.0), min(p + half, 1.0)
