"""Marker detection in one grey image (see :mod:`liquidtouch.tracking.tracks`).

Detection needs no grid size or marker count: the image is divided by a smooth
background (a morphological closing, which removes the dark markers), the
normalised darkness ``d = 1 − I / background`` is thresholded (Otsu),
connected components are kept by area and shape, and each marker's sub-pixel
position is the centroid of :mod:`liquidtouch.tracking.centroid`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from liquidtouch.errors import MarkerError
from liquidtouch.tracking.centroid import refine_centroids


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
    image = as_grey(image)
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


def as_grey(image: np.ndarray) -> np.ndarray:
    """A 2-D ``uint8`` grey image from a grey or colour (channel mean) array."""
    image = np.asarray(image)
    if image.ndim == 3:
        image = image.mean(axis=2)
    if image.ndim != 2:
        raise MarkerError(f"expected a 2-D grey image, got shape {image.shape}")
    if image.dtype != np.uint8:
        image = np.clip(image, 0, 255).astype(np.uint8)
    return image
