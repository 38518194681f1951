"""Marker detection and sub-pixel tracking on GelSight images → :class:`MarkerTracks`.

Detection needs no grid size or marker count: the image is divided by a
smooth background (a morphological closing, which removes the dark markers),
the normalised darkness ``d = 1 − I / background`` is thresholded (Otsu),
connected components are kept by area and shape, and each marker's sub-pixel
position is the darkness-weighted centroid described below.

**Centroid** (one definition everywhere): in a square window around the marker,
``d = 1 − I / b`` with ``b`` the window's 75th-percentile brightness (the local
background; invariant to lighting gain and flicker), weights
``max(d − d_0, 0)`` where ``d_0`` is a fifth of the marker's peak darkness in
the first frame, and the position is the weighted mean pixel coordinate,
re-centred until the window stays put. Pixels below ``d_0`` get no weight, so
the window can shift by a pixel without moving the result. Pixels outside the
image get no weight either (a marker cut by the border: visible part).

**Tracking** refines every marker on a window around its predicted position
(constant velocity) — no full-frame work per frame, all markers at once with
numpy fancy indexing. A marker is flagged lost (``valid = False``, position
NaN) when its centre leaves the image, its blob shrinks or grows beyond 3×,
or it comes within half a marker spacing of another marker (two windows on one
blob). Lost markers are re-acquired by a full detection (at most every few
frames while any are lost), matched one-to-one to their last positions with a
KD-tree, gated at half the spacing measured in the first frame.

Coordinates are pixels, ``x`` to the right and ``y`` down, pixel centres at
integers.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from liquidtouch.errors import MarkerError

MIN_MARKERS = 4
THRESHOLD_FRACTION = 0.2  # of peak darkness: low keeps the edge pixels (less jitter)
BACKGROUND_PERCENTILE = 75


@dataclass(frozen=True)
class Detections:
    """Markers found in one image: positions (N, 2) px, blob areas (N,) px², peak darkness (N,)."""

    positions: np.ndarray
    areas: np.ndarray
    peak_darkness: np.ndarray
    diameter_px: float


@dataclass
class MarkerTracks:
    """Tracked markers of one sensor video.

    Attributes
    ----------
    t : (T,) frame timestamps [s].
    positions : (T, N, 2) marker centres [px] (x, y); NaN where lost.
    valid : (T, N) bool, False where the marker was lost.
    reference : (N, 2) positions in the first frame [px].
    sensor : sensor name (``left``, ``right`` or the video's name).
    spacing_px : median nearest-neighbour marker distance in the first frame [px].
    diameter_px : median marker diameter [px].
    """

    t: np.ndarray
    positions: np.ndarray
    valid: np.ndarray
    reference: np.ndarray
    sensor: str = "sensor"
    spacing_px: float = float("nan")
    diameter_px: float = float("nan")
    first_frame: np.ndarray | None = field(default=None, repr=False)

    @property
    def n_markers(self) -> int:
        return int(self.reference.shape[0])

    @property
    def displacement(self) -> np.ndarray:
        """(T, N, 2) motion from the first frame [px]; NaN where lost."""
        return self.positions - self.reference[None]


def _odd(n: float) -> int:
    k = max(3, int(np.ceil(n)))
    return k if k % 2 else k + 1


def background(image: np.ndarray, diameter_px: float) -> np.ndarray:
    """Smooth background brightness (markers removed) of a grey image, float32, same shape.

    A morphological closing wider than the markers, computed on an image
    shrunk by ~diameter/3 (it is smooth anyway), then enlarged back.
    """
    import cv2

    height, width = image.shape
    factor = max(1, int(diameter_px // 3))
    small = cv2.resize(
        image, (max(1, width // factor), max(1, height // factor)), interpolation=cv2.INTER_AREA
    ).astype(np.float32)
    size = _odd(2.5 * diameter_px / factor)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    closed = cv2.morphologyEx(small, cv2.MORPH_CLOSE, kernel, borderType=cv2.BORDER_REPLICATE)
    closed = cv2.GaussianBlur(closed, (0, 0), sigmaX=max(1.0, size / 4))
    return cv2.resize(closed, (width, height), interpolation=cv2.INTER_LINEAR)


def _components(image: np.ndarray, diameter_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Candidate dark blobs: (centroids (K, 2), stats (K, 5)) of thresholded normalised darkness."""
    import cv2

    bg = np.maximum(background(image, diameter_px), 1.0)
    darkness = np.clip(1.0 - image.astype(np.float32) / bg, 0.0, 1.0)
    scaled = (darkness * 255).astype(np.uint8)
    otsu, _ = cv2.threshold(scaled, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    level = np.clip(otsu / 255.0, 0.08, 0.6)
    mask = (darkness > level).astype(np.uint8)
    _, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    return centroids[1:], stats[1:]


def _blob_filter(stats: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Keep round, marker-sized blobs not cut by the image border."""
    area = stats[:, 4].astype(float)
    big = area >= 5
    if not big.any():
        return big
    # a percentile, not the max: one huge blob (contact imprint, shadow) must not set the scale
    typical = np.median(area[big & (area >= 0.1 * np.percentile(area[big], 90))])
    left, top, w, h = stats[:, 0], stats[:, 1], stats[:, 2], stats[:, 3]
    fill = area / np.maximum(w * h, 1)
    aspect = np.maximum(w, h) / np.maximum(np.minimum(w, h), 1)
    # A marker cut by the image border is still a marker: kept, but its shape is not round.
    cut = (left == 0) | (top == 0) | (left + w == shape[1]) | (top + h == shape[0])
    return (
        big
        & (area >= np.where(cut, 0.2, 0.3) * typical)
        & (area <= 3.0 * typical)
        & (fill >= 0.4)
        & ((aspect <= 2.0) | cut)
    )


def detect_markers(image: np.ndarray, diameter_px: float | None = None) -> Detections:
    """Find the dark markers of a grey image with sub-pixel centroids (no grid size needed).

    ``diameter_px`` is estimated from the image when not given. Markers cut by
    the image border are kept; their centroid is that of the visible part.
    """
    image = _grey(image)
    height, width = image.shape
    if diameter_px is None:
        # A first pass with a generous background scale measures the marker size.
        _, stats = _components(image, min(height, width) / 6)
        keep = _blob_filter(stats, image.shape)
        if keep.sum() == 0:
            return Detections(np.zeros((0, 2)), np.zeros(0), np.zeros(0), float("nan"))
        diameter_px = float(2 * np.sqrt(np.median(stats[keep, 4]) / np.pi))
    centroids, stats = _components(image, diameter_px)
    keep = _blob_filter(stats, image.shape)
    if keep.sum() == 0:
        return Detections(np.zeros((0, 2)), np.zeros(0), np.zeros(0), float(diameter_px))
    diameter_px = float(2 * np.sqrt(np.median(stats[keep, 4]) / np.pi))
    half = window_half_size(diameter_px)
    refined = refine_centroids(image, centroids[keep], half, threshold=None)
    ok = refined.ok
    return Detections(
        positions=refined.positions[ok],
        areas=refined.areas[ok],
        peak_darkness=refined.peak[ok],
        diameter_px=diameter_px,
    )


def window_half_size(diameter_px: float) -> int:
    """Half-width [px] of the refinement window: the blob plus a margin for prediction error."""
    return int(np.ceil(0.8 * diameter_px)) + 2


@dataclass(frozen=True)
class Refined:
    positions: np.ndarray  # (N, 2)
    areas: np.ndarray  # (N,) px above the darkness threshold
    peak: np.ndarray  # (N,) peak normalised darkness
    ok: np.ndarray  # (N,) window inside the image and a blob found


def refine_centroids(
    image: np.ndarray,
    guesses: np.ndarray,
    half: int,
    threshold: np.ndarray | None,
    iterations: int = 3,
) -> Refined:
    """Darkness-weighted centroids in (2·half+1)² windows around ``guesses`` (N, 2), vectorised.

    ``threshold`` (N,) is the per-marker darkness below which pixels get no
    weight; ``None`` uses half of each window's own peak darkness.
    """
    height, width = image.shape
    offsets = np.arange(-half, half + 1)
    positions = np.asarray(guesses, dtype=float).copy()
    n = positions.shape[0]
    ok = np.isfinite(positions).all(axis=1)
    areas = np.zeros(n)
    peak = np.zeros(n)
    if n == 0:
        return Refined(positions, areas, peak, ok)
    for _ in range(iterations):
        centre = np.rint(np.where(np.isfinite(positions), positions, -1e6)).astype(np.int64)
        cx, cy = centre[:, 0], centre[:, 1]
        ok &= (cx >= 0) & (cx < width) & (cy >= 0) & (cy < height)
        xs_raw, ys_raw = cx[:, None] + offsets, cy[:, None] + offsets
        xs, ys = np.clip(xs_raw, 0, width - 1), np.clip(ys_raw, 0, height - 1)
        patch = image[ys[:, :, None], xs[:, None, :]].astype(np.float32)
        flat = patch.reshape(n, -1)
        local_bg = np.maximum(np.percentile(flat, BACKGROUND_PERCENTILE, axis=1), 1.0)
        darkness = 1.0 - patch / local_bg[:, None, None]
        # Pixels beyond the image border (a marker partly out of view) get no weight.
        in_x, in_y = xs_raw == xs, ys_raw == ys
        darkness = np.where(in_y[:, :, None] & in_x[:, None, :], darkness, 0.0)
        peak = darkness.reshape(n, -1).max(axis=1)
        level = THRESHOLD_FRACTION * peak if threshold is None else threshold
        weight = np.maximum(darkness - level[:, None, None], 0.0)
        mass = weight.sum(axis=(1, 2))
        found = mass > 0
        ok &= found
        safe = np.where(found, mass, 1.0)
        dx = (weight.sum(axis=1) @ offsets) / safe
        dy = (weight.sum(axis=2) @ offsets) / safe
        new = np.stack([cx + dx, cy + dy], axis=1)
        areas = (weight > 0).sum(axis=(1, 2)).astype(float)
        positions = np.where(ok[:, None], new, np.nan)
        if np.array_equal(np.rint(np.nan_to_num(positions, nan=-1e6)).astype(np.int64), centre):
            break
    return Refined(positions, areas, peak, ok)


def _grey(image: np.ndarray) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim == 3:
        image = image.mean(axis=2)
    if image.ndim != 2:
        raise MarkerError(f"expected a 2-D grey image, got shape {image.shape}")
    if image.dtype != np.uint8:
        image = np.clip(image, 0, 255).astype(np.uint8)
    return image


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


def track_markers(
    frames: Iterable[tuple[float, np.ndarray]],
    sensor: str = "sensor",
    *,
    diameter_px: float | None = None,
    reacquire_every: int = 5,
    on_frame: Callable[[int], None] | None = None,
) -> MarkerTracks:
    """Detect markers in the first frame and track them through ``frames`` of ``(t_s, image)``.

    Raises :class:`MarkerError` when the first frame has no or too few markers,
    or all markers are lost in more than a tenth of the frames.
    """
    tracker = MarkerTracker(diameter_px=diameter_px, reacquire_every=reacquire_every)
    times: list[float] = []
    rows: list[np.ndarray] = []
    first = None
    for k, (t_s, image) in enumerate(frames):
        if k == 0:
            first = _grey(image)
            rows.append(tracker.start(first).copy())
        else:
            rows.append(tracker.step(image))
        times.append(float(t_s))
        if on_frame is not None:
            on_frame(k)
    if not rows:
        raise MarkerError(f"{sensor}: no frames to track")
    positions = np.stack(rows)
    valid = np.isfinite(positions).all(axis=2)
    none_valid = ~valid.any(axis=1)
    if none_valid.mean() > 0.1:
        raise MarkerError(
            f"{sensor}: all markers lost in {int(none_valid.sum())} of {len(rows)} frames; "
            "the gel may be out of view or the video too blurred"
        )
    return MarkerTracks(
        t=np.asarray(times),
        positions=positions,
        valid=valid,
        reference=tracker.reference,
        sensor=sensor,
        spacing_px=tracker.spacing_px,
        diameter_px=float(tracker.diameter_px),
        first_frame=first,
    )


def save_tracks(path: str | Path, tracks: list[MarkerTracks]) -> None:
    """Write tracks of one or more sensors to an ``.npz`` file (atomic, no pickle).

    Keys: ``sensors`` (names) and per sensor ``<name>/t``, ``<name>/positions``,
    ``<name>/valid``, ``<name>/reference``.
    """
    from liquidtouch import atomic

    arrays: dict[str, np.ndarray] = {"sensors": np.array([tr.sensor for tr in tracks], dtype=str)}
    for tr in tracks:
        arrays[f"{tr.sensor}/t"] = tr.t
        arrays[f"{tr.sensor}/positions"] = tr.positions
        arrays[f"{tr.sensor}/valid"] = tr.valid
        arrays[f"{tr.sensor}/reference"] = tr.reference
    with atomic.atomic_path(path) as tmp, open(tmp, "wb") as handle:
        np.savez_compressed(handle, **arrays)


def load_tracks(path: str | Path) -> list[MarkerTracks]:
    """Read tracks written by :func:`save_tracks`."""
    with np.load(path, allow_pickle=False) as data:
        return [
            MarkerTracks(
                t=data[f"{name}/t"],
                positions=data[f"{name}/positions"],
                valid=data[f"{name}/valid"],
                reference=data[f"{name}/reference"],
                sensor=str(name),
                spacing_px=marker_spacing(data[f"{name}/reference"]),
            )
            for name in data["sensors"]
        ]
