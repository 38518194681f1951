"""Frame-to-frame marker tracking (see :mod:`liquidtouch.markers`)."""

from __future__ import annotations

import numpy as np

from liquidtouch.errors import MarkerError
from liquidtouch.marker_centroid import THRESHOLD_FRACTION, refine_centroids
from liquidtouch.marker_detect import _grey, detect_markers, window_half_size

MIN_MARKERS = 4


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

    def __init__(self, diameter_px: float | None = None, reacquire_every: int = 5) -> None:
        self.diameter_px = diameter_px
        self.reacquire_every = max(1, int(reacquire_every))

    def start(self, image: np.ndarray) -> np.ndarray:
        """Detect the markers of the first frame; return their positions (N, 2)."""
        image = _grey(image)
        found = detect_markers(image, self.diameter_px)
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
        self.gate_px = 0.5 * self.spacing_px
        self.threshold = THRESHOLD_FRACTION * found.peak_darkness
        self.area_ref = found.areas
        self.reference = found.positions
        self.last = found.positions.copy()  # last known position (kept while lost)
        self.previous = found.positions.copy()  # position one frame ago (NaN if lost)
        self.current = found.positions.copy()
        self.since_reacquire = 0
        return self.current

    def step(self, image: np.ndarray) -> np.ndarray:
        """Track into the next frame; return positions (N, 2), NaN for lost markers."""
        image = _grey(image)
        velocity = np.nan_to_num(self.current - self.previous)
        guess = np.where(np.isfinite(self.current), self.current + velocity, np.nan)
        refined = refine_centroids(image, guess, self.half, self.threshold)
        ok = (
            refined.ok
            & (refined.areas >= 0.3 * self.area_ref)
            & (refined.areas <= 3.0 * self.area_ref)
            & (np.hypot(*(refined.positions - guess).T) <= self.gate_px)
        )
        positions = np.where(ok[:, None], refined.positions, np.nan)
        residual = np.hypot(*(refined.positions - guess).T)
        ok &= ~self._crowded(positions, ok, residual)
        positions[~ok] = np.nan
        self.since_reacquire += 1
        lost = ~ok
        if lost.any() and self.since_reacquire >= self.reacquire_every:
            self.since_reacquire = 0
            positions = self._reacquire(image, positions, lost)
        self.previous, self.current = self.current, positions
        valid = np.isfinite(positions[:, 0])
        self.last[valid] = positions[valid]
        return positions

    def _crowded(self, positions: np.ndarray, ok: np.ndarray, residual: np.ndarray) -> np.ndarray:
        """Of two markers within half a spacing (two windows on one blob), the one that jumped."""
        from scipy.spatial import cKDTree

        crowded = np.zeros(len(positions), bool)
        index = np.flatnonzero(ok)
        if len(index) > 1:
            pairs = cKDTree(positions[index]).query_pairs(self.gate_px, output_type="ndarray")
            a, b = index[pairs[:, 0]], index[pairs[:, 1]]
            crowded[np.where(residual[a] > residual[b], a, b)] = True
        return crowded

    def _reacquire(self, image: np.ndarray, positions: np.ndarray, lost: np.ndarray) -> np.ndarray:
        found = detect_markers(image, self.diameter_px).positions
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
        return positions
