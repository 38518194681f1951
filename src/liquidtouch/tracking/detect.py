"""Marker detection in one grey image (see :mod:`liquidtouch.tracking.tracks`).

Detection needs no grid size or marker count: the image is divided by a smooth
background (a morphological closing, which removes the dark markers), the
normalised darkness ``d = 1 − I / background`` is thresholded (Otsu),
connected components are kept by area and shape, and each marker's sub-pixel
position is the centroid of :mod:`liquidtouch.tracking.centroid`.

The thresholds are the module constants below; those a user may need to tune
are also keyword arguments of :func:`detect_markers` (as trackpy's ``locate``
exposes ``minmass`` and ``separation``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from liquidtouch._core.checks import as_number
from liquidtouch.errors import MarkerError
from liquidtouch.tracking.centroid import refine_centroids

#: bounds [0..1] on the Otsu threshold of normalised darkness ``d = 1 − I / background``
THRESHOLD_RANGE = (0.08, 0.6)
#: smallest connected blob [px²] that can be a marker
MIN_AREA_PX = 5
#: blob area range, in units of the typical (median) marker area
AREA_RATIO = (0.3, 3.0)
#: smallest area ratio of a blob cut by the image border (only its visible part counts)
CUT_AREA_RATIO = 0.2
#: smallest blob area over its bounding-box area (a disc fills π/4 ≈ 0.79)
MIN_FILL = 0.4
#: largest bounding-box aspect ratio (long / short side) of a whole marker
MAX_ASPECT = 2.0
#: width of the background closing, in marker diameters (wider than a marker removes it)
BACKGROUND_DIAMETERS = 2.5
#: without a given diameter, a first pass uses a background scale of min(height, width) / this
FIRST_PASS_DIVISOR = 6
#: the refinement window's half-width: this many diameters plus WINDOW_MARGIN_PX
WINDOW_HALF_DIAMETERS = 0.8
WINDOW_MARGIN_PX = 2


@dataclass(frozen=True)
class Detections:
    """Markers found in one image: positions (N, 2) px, blob areas (N,) px², peak darkness (N,)."""

    positions: np.ndarray
    areas: np.ndarray
    peak_darkness: np.ndarray
    diameter_px: float


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
    size = _odd(BACKGROUND_DIAMETERS * diameter_px / factor)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    closed = cv2.morphologyEx(small, cv2.MORPH_CLOSE, kernel, borderType=cv2.BORDER_REPLICATE)
    closed = cv2.GaussianBlur(closed, (0, 0), sigmaX=max(1.0, size / 4))
    return cv2.resize(closed, (width, height), interpolation=cv2.INTER_LINEAR)


def _components(
    image: np.ndarray, diameter_px: float, threshold_range: tuple[float, float]
) -> tuple[np.ndarray, np.ndarray]:
    """Candidate dark blobs: (centroids (K, 2), stats (K, 5)) of thresholded normalised darkness."""
    import cv2

    bg = np.maximum(background(image, diameter_px), 1.0)
    darkness = np.clip(1.0 - image.astype(np.float32) / bg, 0.0, 1.0)
    scaled = (darkness * 255).astype(np.uint8)
    otsu, _ = cv2.threshold(scaled, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    level = np.clip(otsu / 255.0, *threshold_range)
    mask = (darkness > level).astype(np.uint8)
    _, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    return centroids[1:], stats[1:]


def _blob_filter(
    stats: np.ndarray,
    shape: tuple[int, int],
    min_area_px: float,
    area_ratio: tuple[float, float],
    min_fill: float,
    max_aspect: float,
) -> np.ndarray:
    """Keep round, marker-sized blobs (those cut by the image border need not be round)."""
    area = stats[:, 4].astype(float)
    big = area >= min_area_px
    if not big.any():
        return big
    # a percentile, not the max: one huge blob (contact imprint, shadow) must not set the scale
    typical = np.median(area[big & (area >= 0.1 * np.percentile(area[big], 90))])
    left, top, w, h = stats[:, 0], stats[:, 1], stats[:, 2], stats[:, 3]
    fill = area / np.maximum(w * h, 1)
    aspect = np.maximum(w, h) / np.maximum(np.minimum(w, h), 1)
    # A marker cut by the image border is still a marker: kept, but its shape is not round.
    cut = (left == 0) | (top == 0) | (left + w == shape[1]) | (top + h == shape[0])
    low, high = area_ratio
    return (
        big
        & (area >= np.where(cut, min(CUT_AREA_RATIO, low), low) * typical)
        & (area <= high * typical)
        & (fill >= min_fill)
        & ((aspect <= max_aspect) | cut)
    )


def detect_markers(
    image: np.ndarray,
    diameter_px: float | None = None,
    *,
    threshold_range: tuple[float, float] = THRESHOLD_RANGE,
    min_area_px: float = MIN_AREA_PX,
    area_ratio: tuple[float, float] = AREA_RATIO,
    min_fill: float = MIN_FILL,
    max_aspect: float = MAX_ASPECT,
) -> Detections:
    """Find the dark markers of a grey image with sub-pixel centroids (no grid size needed).

    Markers cut by the image border are kept; their centroid is that of the
    visible part.

    Parameters
    ----------
    image : (H, W) or (H, W, C) array
        Grey or colour (channels averaged) image; values are grey levels 0–255.
    diameter_px : float, optional
        Marker diameter [px]; estimated from the image when not given.
    threshold_range : (low, high)
        Bounds on the automatic (Otsu) threshold of normalised darkness
        ``1 − I / background`` [unitless, 0–1]. Raise ``low`` when noise is
        detected as markers, lower ``high`` when faint markers are missed.
    min_area_px : float
        Smallest blob area [px²] considered at all.
    area_ratio : (low, high)
        Blob area range as a multiple of the median marker area [unitless];
        a blob cut by the border may be down to ``min(0.2, low)``.
    min_fill : float
        Smallest blob area over its bounding-box area [unitless, 0–1].
    max_aspect : float
        Largest bounding-box aspect ratio (long / short side) [unitless, ≥ 1].

    Raises
    ------
    MarkerError
        Not an image (wrong shape, empty, NaN values), or a knob out of range.
    """
    image = as_grey(image)
    _check_options(diameter_px, threshold_range, min_area_px, area_ratio, min_fill, max_aspect)
    shape_knobs = (min_area_px, area_ratio, min_fill, max_aspect)
    height, width = image.shape
    if diameter_px is None:
        # A first pass with a generous background scale measures the marker size.
        _, stats = _components(image, min(height, width) / FIRST_PASS_DIVISOR, threshold_range)
        keep = _blob_filter(stats, image.shape, *shape_knobs)
        if keep.sum() == 0:
            return Detections(np.zeros((0, 2)), np.zeros(0), np.zeros(0), float("nan"))
        diameter_px = float(2 * np.sqrt(np.median(stats[keep, 4]) / np.pi))
    centroids, stats = _components(image, diameter_px, threshold_range)
    keep = _blob_filter(stats, image.shape, *shape_knobs)
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


def check_diameter(diameter_px: float | None) -> None:
    """``None`` or a finite marker diameter > 0 [px]; :class:`MarkerError` otherwise."""
    if diameter_px is not None and not 0 < as_number(diameter_px) < np.inf:
        raise MarkerError(
            f"diameter_px must be a marker diameter > 0 in pixels, or None to measure it "
            f"(got {diameter_px!r})"
        )


def _check_options(
    diameter_px: float | None,
    threshold_range: tuple[float, float],
    min_area_px: float,
    area_ratio: tuple[float, float],
    min_fill: float,
    max_aspect: float,
) -> None:
    check_diameter(diameter_px)
    low, high = _pair(threshold_range, "threshold_range")
    if not 0 <= low <= high <= 1:
        raise MarkerError(
            f"threshold_range must satisfy 0 <= low <= high <= 1 (darkness fractions), "
            f"got {threshold_range!r}; the default is {THRESHOLD_RANGE}"
        )
    low, high = _pair(area_ratio, "area_ratio")
    if not 0 <= low < high:
        raise MarkerError(
            f"area_ratio must satisfy 0 <= low < high (multiples of the typical marker area), "
            f"got {area_ratio!r}; the default is {AREA_RATIO}"
        )
    checks = (
        ("min_area_px", min_area_px, 0, np.inf, MIN_AREA_PX),
        ("min_fill", min_fill, 0, 1, MIN_FILL),
        ("max_aspect", max_aspect, 1, np.inf, MAX_ASPECT),
    )
    for name, value, lo, hi, default in checks:
        number = as_number(value)
        if not (lo <= number <= hi and np.isfinite(number)):
            limit = f"in [{lo}, {hi}]" if np.isfinite(hi) else f">= {lo}"
            raise MarkerError(
                f"{name} must be a finite number {limit}, got {value!r}; the default is {default}"
            )


def _pair(value: object, name: str) -> tuple[float, float]:
    try:
        low, high = value  # type: ignore[misc]
    except (TypeError, ValueError):
        raise MarkerError(f"{name} must be a pair (low, high), got {value!r}") from None
    return as_number(low), as_number(high)


def window_half_size(diameter_px: float) -> int:
    """Half-width [px] of the refinement window: the blob plus a margin for prediction error."""
    return int(np.ceil(WINDOW_HALF_DIAMETERS * diameter_px)) + WINDOW_MARGIN_PX


def as_grey(image: np.ndarray) -> np.ndarray:
    """A 2-D ``uint8`` grey image from a grey or colour (channel mean) array of grey levels."""
    try:
        image = np.asarray(image)
    except (TypeError, ValueError):
        raise MarkerError("expected an image (a 2-D grey or 3-D colour array)") from None
    if image.ndim == 3 and image.shape[2] in (1, 3, 4):
        image = image.mean(axis=2)
    if image.ndim != 2:
        hint = "; pass one frame at a time" if image.ndim == 3 else ""
        raise MarkerError(
            f"expected a 2-D grey (H, W) or colour (H, W, 3) image, got shape {image.shape}{hint}"
        )
    if image.size == 0:
        raise MarkerError(f"the image is empty (shape {image.shape}); give a GelSight frame")
    if image.dtype != np.uint8:
        if image.dtype.kind not in "iuf":
            raise MarkerError(f"image values must be real grey levels, got dtype {image.dtype}")
        if not np.isfinite(image).all():
            raise MarkerError("the image holds NaN/inf values; give grey levels 0-255")
        image = np.clip(image, 0, 255).astype(np.uint8)
    return image
