"""Frame-to-frame marker tracking (see :mod:`liquidtouch.tracking.tracks`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from liquidtouch.errors import MarkerError
from liquidtouch.tracking.centroid import THRESHOLD_FRACTION, refine_centroids
from liquidtouch.tracking.detect import (
    as_grey,
    as_number,
    check_diameter,
    detect_markers,
    window_half_size,
)

#: fewest markers the first frame must show
MIN_MARKERS = 4
#: default frames between re-detections while markers are lost
REACQUIRE_EVERY = 5
#: search radius around the predicted position, as a fraction of the marker spacing
#: (also the closest two tracked markers may come: two windows on one blob)
SEARCH_FRACTION = 0.5
#: a marker is lost when its blob area leaves this range, in units of its first-frame area
AREA_CHANGE = (0.3, 3.0)
#: neighbours whose motion predicts a marker's second search
N_NEIGHBOURS = 8


def marker_spacing(positions: np.ndarray) -> float:
    """Median nearest-neighbour distance between markers [px]."""
    from scipy.spatial import cKDTree

    distance, _ = cKDTree(positions).query(positions, k=2)
    return float(np.median(distance[:, 1]))


def match_one_to_one(
    targets: np.ndarray, candidates: np.ndarray, gate_px: float
) -> tuple[np.ndarray, np.ndarray]:
    """Mutual-nearest matching within ``gate_px``; return (target indices, candidate indices)."""
    from scipy.spatial import cKDTree

    if len(targets) == 0 or len(candidates) == 0:
        return np.zeros(0, int), np.zeros(0, int)
    d_tc, to_c = cKDTree(candidates).query(targets, distance_upper_bound=gate_px)
    _, to_t = cKDTree(targets).query(candidates, distance_upper_bound=gate_px)
    rows = np.flatnonzero(np.isfinite(d_tc))
    mutual = to_t[to_c[rows]] == rows
    return rows[mutual], to_c[rows[mutual]]


class MarkerTracker:
    """Frame-to-frame tracker: ``start(image)`` on the first frame, then ``step(image)``."""

    def __init__(
        self,
        diameter_px: float | None = None,
        reacquire_every: int = REACQUIRE_EVERY,
        *,
        search_fraction: float = SEARCH_FRACTION,
        area_change: tuple[float, float] = AREA_CHANGE,
        detect_kwargs: Mapping[str, Any] | None = None,
    ) -> None:
        check_diameter(diameter_px)
        whole = isinstance(reacquire_every, int | np.integer) and not isinstance(
            reacquire_every, bool
        )
        if not whole or reacquire_every < 1:
            raise MarkerError(
                f"reacquire_every must be a whole number of frames >= 1, got {reacquire_every!r}"
            )
        if not 0 < as_number(search_fraction) <= 1:
            raise MarkerError(
                f"search_fraction must lie in (0, 1] (a fraction of the marker spacing), "
                f"got {search_fraction!r}; the default is {SEARCH_FRACTION}"
            )
        try:
            low, high = (as_number(v) for v in area_change)
        except (TypeError, ValueError):
            low = high = float("nan")
        if not 0 <= low < 1 < high < np.inf:
            raise MarkerError(
                f"area_change must be a pair (low, high) with 0 <= low < 1 < high (multiples "
                f"of the first-frame blob area), got {area_change!r}; the default is {AREA_CHANGE}"
            )
        self.diameter_px = diameter_px
        self.reacquire_every = int(reacquire_every)
        self.search_fraction = float(search_fraction)
        self.area_change = (low, high)
        self.detect_kwargs = dict(detect_kwargs or {})

    def start(self, image: np.ndarray) -> np.ndarray:
        """Detect the markers of the first frame; return their positions (N, 2)."""
        from scipy.spatial import cKDTree

        image = as_grey(image)
        found = detect_markers(image, self.diameter_px, **self.detect_kwargs)
        if len(found.positions) == 0:
            raise MarkerError(
                "no markers found in the first frame; is this a GelSight marker video "
                "(dark dots on a lit gel)?"
            )
        if len(found.positions) < MIN_MARKERS:
            raise MarkerError(
                f"only {len(found.positions)} markers found in the first frame; at least "
                f"{MIN_MARKERS} are needed (check focus and lighting)"
            )
        self.diameter_px = found.diameter_px
        self.half = window_half_size(found.diameter_px)
        self.spacing_px = marker_spacing(found.positions)
        self.gate_px = self.search_fraction * self.spacing_px
        self.threshold = THRESHOLD_FRACTION * found.peak_darkness
        self.area_ref = found.areas
        self.reference = found.positions
        self.last = found.positions.copy()  # last known position (kept while lost)
        self.previous = found.positions.copy()  # position one frame ago (NaN if lost)
        self.current = found.positions.copy()
        self.since_reacquire = 0
        self.closest_bound = 0.0  # lower bound on the closest pair's distance [px]
        k = min(len(self.reference), N_NEIGHBOURS + 1)
        self.neighbours = cKDTree(self.reference).query(self.reference, k=k)[1][:, 1:]
        return self.current

    def step(self, image: np.ndarray) -> np.ndarray:
        """Track into the next frame; return positions (N, 2), NaN for lost markers."""
        image = as_grey(image)
        current = self.current
        guess = 2.0 * current - self.previous  # constant velocity; NaN when lost
        fresh = np.isnan(guess[:, 0]) & ~np.isnan(current[:, 0])  # just re-acquired
        guess[fresh] = current[fresh]
        positions, residual = self._refine(image, guess, np.arange(len(guess)))
        failed = np.flatnonzero(np.isnan(positions[:, 0]) & ~np.isnan(current[:, 0]))
        if failed.size:  # a second search, predicted from the neighbours' motion this frame
            second = current[failed] + self._neighbour_motion(positions, failed)
            positions[failed], residual[failed] = self._refine(image, second, failed)
        self._drop_crowded(positions, residual)
        self.since_reacquire += 1
        lost = np.isnan(positions[:, 0])
        if lost.any() and self.since_reacquire >= self.reacquire_every:
            self.since_reacquire = 0
            positions = self._reacquire(image, positions, lost)
        self.previous, self.current = current, positions
        valid = ~np.isnan(positions[:, 0])
        self.last[valid] = positions[valid]
        return positions

    def _refine(
        self, image: np.ndarray, guess: np.ndarray, index: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Refine markers ``index`` from ``guess``; NaN where the blob is not theirs."""
        refined = refine_centroids(image, guess, self.half, self.threshold[index])
        residual = np.hypot(*(refined.positions - guess).T)
        area = self.area_ref[index]
        ok = (
            refined.ok
            & (refined.areas >= self.area_change[0] * area)
            & (refined.areas <= self.area_change[1] * area)
            & (residual <= self.gate_px)
        )
        positions = refined.positions
        positions[~ok] = np.nan
        return positions, np.where(ok, residual, np.inf)

    def _neighbour_motion(self, positions: np.ndarray, index: np.ndarray) -> np.ndarray:
        """(n, 2) median motion this frame of each marker's nearest tracked neighbours."""
        motion = positions[self.neighbours[index]] - self.current[self.neighbours[index]]
        have = ~np.isnan(motion[..., 0]).all(axis=1)
        out = np.zeros((len(index), 2))
        if have.any():
            out[have] = np.nanmedian(motion[have], axis=1)
        return out

    def _drop_crowded(self, positions: np.ndarray, residual: np.ndarray) -> None:
        """Of two markers closer than the search radius (one blob), drop the one that jumped.

        The exact check runs only when a lower bound on the closest pair's distance
        (last exact value minus twice the largest motion since) falls to the gate.
        """
        from scipy.spatial import cKDTree

        motion = np.hypot(*(positions - self.current).T)
        largest = float(np.max(motion, initial=0.0, where=~np.isnan(motion)))
        self.closest_bound -= 2.0 * largest
        if self.closest_bound > self.gate_px:
            return
        index = np.flatnonzero(~np.isnan(positions[:, 0]))
        if len(index) < 2:
            return
        tree = cKDTree(positions[index])
        pairs = tree.query_pairs(self.gate_px, output_type="ndarray")
        if len(pairs):
            a, b = index[pairs[:, 0]], index[pairs[:, 1]]
            positions[np.where(residual[a] > residual[b], a, b)] = np.nan
            index = np.flatnonzero(~np.isnan(positions[:, 0]))
            if len(index) < 2:
                return
            tree = cKDTree(positions[index])
        self.closest_bound = float(tree.query(positions[index], k=2)[0][:, 1].min())

    def _reacquire(self, image: np.ndarray, positions: np.ndarray, lost: np.ndarray) -> np.ndarray:
        found = detect_markers(image, self.diameter_px, **self.detect_kwargs).positions
        valid = ~lost
        if len(found) and valid.any():
            from scipy.spatial import cKDTree

            near, _ = cKDTree(positions[valid]).query(found, distance_upper_bound=self.gate_px)
            found = found[~np.isfinite(near)]
        lost_index = np.flatnonzero(lost)
        rows, cols = match_one_to_one(self.last[lost_index], found, self.gate_px)
        if len(rows):
            back = lost_index[rows]
            refined = refine_centroids(image, found[cols], self.half, self.threshold[back])
            good = refined.ok
            positions[back[good]] = refined.positions[good]
            self.closest_bound = 0.0  # new markers: check the closest pair exactly next time
        return positions
