"""Sub-pixel marker centroids in square windows, all markers at once.

See :mod:`liquidtouch.tracking.tracks` for the overview.

**Centroid** (one definition everywhere): in a (2·half+1)² window around the
marker, the local background ``b(x, y)`` is the plane through the mean
brightness of the window's four border rows/columns (the border ring holds no
marker pixels: the window half-size is 0.8·diameter + 2, well inside the marker
spacing; means of 2·half+1 pixels, so sensor noise barely moves it; a plane,
so a lighting gradient or the slope of a contact imprint does not bias the
centroid towards the darker side). The normalised darkness is
``d = 1 − I / b`` (invariant to lighting gain and flicker), the weights are
``max(d − d_0, 0)`` with ``d_0`` a fifth of the marker's peak darkness in the
first frame, and the position is the weighted mean pixel coordinate. The
window is re-centred on the result while the result lies more than a pixel
from the window centre. Pixels below ``d_0`` get no weight, so a window a pixel
off moves the result by much less than the noise. Pixels outside the image get
no weight (a marker cut by the border: its visible part).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

THRESHOLD_FRACTION = 0.2  # of peak darkness: low keeps the edge pixels (less jitter)
RECENTRE_PX = 1.0  # re-centre the window when the centroid is further than this from its centre


@dataclass(frozen=True)
class Refined:
    positions: np.ndarray  # (N, 2)
    areas: np.ndarray  # (N,) px above the darkness threshold
    peak: np.ndarray  # (N,) peak normalised darkness (NaN unless the threshold was None)
    ok: np.ndarray  # (N,) window centre inside the image and a blob found


@dataclass(frozen=True)
class _Geometry:
    half: int
    plane: np.ndarray  # (3, K) float32: rows 1, x offset, y offset (K = (2·half+1)²)
    ring: np.ndarray  # (K, 3) float32: pixels → background plane (level, x slope, y slope)
    moments: np.ndarray  # (K, 3) float32: columns 1, x offset, y offset
    offset: np.ndarray  # (2·half+1,) int offsets


@lru_cache(maxsize=8)
def _geometry(half: int) -> _Geometry:
    offset = np.arange(-half, half + 1)
    oy, ox = np.meshgrid(offset, offset, indexing="ij")
    plane = np.stack([np.ones(ox.size), ox.ravel(), oy.ravel()]).astype(np.float32)
    # Mean of each border row/column (top, bottom, left, right) → the plane through them.
    size = offset.size
    sides = np.zeros((size, size, 4))
    sides[0, :, 0] = sides[-1, :, 1] = sides[:, 0, 2] = sides[:, -1, 3] = 1.0 / size
    to_plane = np.array([[0.25, 0.25, 0.25, 0.25], [0, 0, -1, 1], [-1, 1, 0, 0]]) / np.array(
        [[1.0], [2 * half], [2 * half]]
    )
    ring = (sides.reshape(-1, 4) @ to_plane.T).astype(np.float32)
    return _Geometry(
        half=half, plane=plane, ring=ring, moments=np.ascontiguousarray(plane.T), offset=offset
    )


def refine_centroids(
    image: np.ndarray,
    guesses: np.ndarray,
    half: int,
    threshold: np.ndarray | None,
    iterations: int = 3,
) -> Refined:
    """Darkness-weighted centroids in (2·half+1)² windows around ``guesses`` (N, 2), vectorised.

    ``image`` is 2-D ``uint8``. ``threshold`` (N,) is the per-marker darkness
    below which pixels get no weight; ``None`` uses a fifth of each window's own
    peak darkness (detection). Only markers whose window had to move are
    refined again (at most ``iterations`` passes in all).
    """
    import cv2
    from numpy.lib.stride_tricks import as_strided

    height, width = image.shape
    geo = _geometry(int(half))
    size = 2 * half + 1
    positions = np.array(guesses, dtype=float).reshape(-1, 2)
    n = positions.shape[0]
    ok = np.isfinite(positions).all(axis=1)
    areas = np.zeros(n)
    peak = np.full(n, np.nan)
    todo = np.flatnonzero(ok)
    if todo.size == 0:
        positions[~ok] = np.nan
        return Refined(positions, areas, peak, ok)
    padded = cv2.copyMakeBorder(image, half, half, half, half, cv2.BORDER_REPLICATE)
    # windows[y, x] is the window centred on (x, y) (a strided view, no copy)
    windows = as_strided(padded, (height, width, size, size), padded.strides * 2, writeable=False)
    for _ in range(iterations):
        centre = np.rint(positions[todo]).astype(np.intp)
        cx, cy = centre[:, 0], centre[:, 1]
        inside = (cx >= 0) & (cx < width) & (cy >= 0) & (cy < height)
        if not inside.all():
            ok[todo[~inside]] = False
            todo, centre, cx, cy = todo[inside], centre[inside], cx[inside], cy[inside]
        if todo.size == 0:
            break
        patch = windows[cy, cx].astype(np.float32)
        level = None if threshold is None else threshold[todo]
        delta, area, top = _centroid(patch, geo, level, cx, cy, width, height)
        found = area > 0
        positions[todo] = centre + delta
        areas[todo] = area
        if top is not None:
            peak[todo] = top
        ok[todo[~found]] = False
        moved = found & (np.abs(delta) > RECENTRE_PX).any(axis=1)
        todo = todo[moved]
        if todo.size == 0:
            break
    positions[~ok] = np.nan
    return Refined(positions, areas, peak, ok)


def _centroid(
    patch: np.ndarray,
    geo: _Geometry,
    level: np.ndarray | None,
    cx: np.ndarray,
    cy: np.ndarray,
    width: int,
    height: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Centroid offsets (n, 2) from the window centres, areas (n,), peak darkness (n,) or None."""
    n = patch.shape[0]
    half = geo.half
    flat = patch.reshape(n, -1)
    coeff = flat @ geo.ring  # (n, 3): background at the centre, x slope, y slope
    # Keep the plane above half its centre value over the window (and above 1 grey level).
    coeff[:, 0] = np.maximum(coeff[:, 0], 1.0)
    tilt = half * (np.abs(coeff[:, 1]) + np.abs(coeff[:, 2]))
    coeff[:, 1:] *= np.minimum(1.0, 0.5 * coeff[:, 0] / np.maximum(tilt, 1e-6))[:, None]
    bg = coeff @ geo.plane  # (n, K)
    ratio = np.divide(flat, bg, out=bg)  # I / b; darkness d = 1 − ratio
    # Pixels beyond the image border (a marker partly out of view) get no weight.
    edge = np.flatnonzero((cx < half) | (cx >= width - half) | (cy < half) | (cy >= height - half))
    if edge.size:
        xs = cx[edge, None] + geo.offset
        ys = cy[edge, None] + geo.offset
        outside = ~(((ys >= 0) & (ys < height))[:, :, None] & ((xs >= 0) & (xs < width))[:, None])
        ratio[edge] = np.where(outside.reshape(edge.size, -1), 1.0, ratio[edge])
    top = None
    if level is None:
        top = 1.0 - ratio.min(axis=1)
        level = THRESHOLD_FRACTION * top
    excess = np.subtract((1.0 - level).astype(np.float32)[:, None], ratio, out=ratio)  # d − d_0
    weight = np.add(excess, np.abs(excess), out=excess)  # 2·max(d − d_0, 0): fast, ½ cancels
    mass, sx, sy = (weight @ geo.moments).T
    found = mass > 0
    safe = np.where(found, mass, 1.0)
    delta = np.stack([sx / safe, sy / safe], axis=1).astype(float)
    area = np.add.reduce(weight > 0, axis=1, dtype=np.int32)
    return delta, np.where(found, area, 0), top
