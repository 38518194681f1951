"""Tracking for markerless gels: the gel's own image, pooled over a grid of cells → MarkerTracks.

A gel without printed markers (the GelSight Mini's standard gel, DIGIT) still shows the
motion: the container's imprint (its edge, its shading, the face's fine texture) moves
with the gel's shear. This module measures that motion against a reference frame on a
grid of square cells and hands the signal stage the same
:class:`~liquidtouch.tracking.tracks.MarkerTracks` markers give: each textured cell is a
point (its centre plus its motion [px]), with a valid mask.

**Why not a dense flow's output.** OpenCV's DIS flow (medium preset) reads small
sub-pixel motion with a different gain than large motion, which bends the ring-down's
envelope (−7 % to +12 % between 0.05 and 0.5 px in ``benchmarks/tracking/markerless.py``;
docs/recording.md, "Markerless gels"), and costs ~13 ms a frame at 320 × 240 where
decoding costs 1-3. Interpolating the frame at a sub-pixel offset (Lucas–Kanade's usual
warp) has the same flaw: bilinear sampling reads 0.05 px as 0.057, OpenCV's remap rounds
the offset to 1/32 px. So a cell's motion ``d = n + δ`` is read in two parts: the frame
is read at a **whole-pixel** offset ``n`` (the last frame's motion, rounded: no
interpolation at all), and the rest ``δ`` solves the least-squares step
``Σ g (J(x + n) − R(x)) = −(Σ g gᵀ) δ`` over the cell's pixels (``R`` the reference,
``J`` the frame, ``g`` the mean of both images' gradients: second-order accurate, a
sinusoid of ``k`` rad/px reads ``(2/k) tan(kδ/2)``, 1 % high at kδ = 0.35). The step is
linear in the image, so small and large motions are read with one gain (within 3 % from
0.05 to 2 px on rendered shifts, ``tests/tracking/test_flow.py``). All chosen cells at
once: each cell's block of the frame is one strided gather at its whole-pixel offset (no
warp of the image), the sums one ``einsum`` per product; only the cells whose step lands
beyond half a pixel are read again (~0.7 ms a frame at 320 × 240).

**Pre-filter.** Both images are band-passed (a narrow Gaussian minus a wide box mean)
at a working scale where the image is about :data:`WORK_WIDTH_PX` wide: the narrow Gaussian takes
the pixel noise down, the box removes what does not move with the gel (the LEDs' smooth
lighting, slow brightness drift), so that a cell is trusted for the texture or edge it
shows, not for a lighting gradient.

**Which cells.** A cell's motion has the noise std ``σ / sqrt(a)`` along its
best-textured direction (``σ`` the pixel noise, estimated from the first frame
(Immerkær 1996), ``a`` the larger eigenvalue of its normal matrix); a cell is used
when that is at most :data:`MAX_CELL_STD_PX`. A cell on a straight edge (its other
direction noisier than :data:`EDGE_STD_PX`) is read across the edge only, and a ridge
(:data:`PRIOR_PX`) keeps a direction without information at rest. Fewer than
:data:`MIN_CELLS` usable cells raise :class:`TextureError` with what helps. A cell whose
residual grows beyond :data:`LOST_RESIDUAL` × its first one is lost in that frame. The
signal stage then keeps the cells that move most, as it keeps markers.

**Reference.** The stream's first frame; when the image drifts (the cells' median
residual after the step grows beyond :data:`REREFERENCE_RESIDUAL` × its value at the
first step: lighting drift, gel creep, a deformation the translation does not explain)
the current frame becomes the reference and the motion so far its offset.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from liquidtouch.errors import MarkerError, VideoError
from liquidtouch.tracking.detect import as_grey
from liquidtouch.tracking.tracks import MarkerTracks, run_tracker

__all__ = [
    "FlowTracker",
    "TextureError",
    "noise_std",
    "track_flow",
]

#: the grid's columns over the image width: cells of 32 px on a GelSight Mini or DIGIT
#: (320 × 240: ~1.9 mm, the marker pitch of a marker gel, so as many cells as markers on
#: the contact); 150 cells, of which the signal stage keeps the 16 that move most, as it
#: keeps markers. Smaller cells are noisier: at 16 px a simulated corn-oil trial's u(t)
#: explained 64 % of the cells' motion (markers: 91 %, 32-px cells: 72 %); over five trials
#: a liquid neither size reads λ within 3 % of the markers everywhere
#: (benchmarks/RESULTS.md, "markerless")
GRID_COLUMNS = 10
#: image width [px] worked at: a GelSight Mini's and a DIGIT's; a larger image is averaged
#: down to about it (640 × 480 by 2 × 2), which costs a quarter and reads the motion as
#: well (a cell covers the same gel either way)
WORK_WIDTH_PX = 320
#: std of the pre-filter's narrow Gaussian, in cells (1 px at the working scale): takes
#: the pixel noise down and keeps a texture of a few px
BLUR_CELLS = 1 / 32
#: the band-pass's wide part (a box mean of the variance of a Gaussian this many narrow
#: widths wide): a cell's worth of smooth lighting is removed, an edge a few px wide kept
BAND_RATIO = 4.0
#: a cell is used when its motion's noise std along its best direction is at most this
#: [px]: a quarter of the smallest slosh motion on the gel (0.2 px for a 0.1 N slosh force,
#: :mod:`liquidtouch.sim.gelsight`), so
#: that the cells the signal keeps are those that move, not those that are noisy (at
#: half, the imprint's rim cells outranked the contact's 0.25 px motion on a Mini)
MAX_CELL_STD_PX = 0.05
#: fewest usable cells a sensor must show (as MIN_MARKERS markers)
MIN_CELLS = 4
#: prior std of a cell's motion between whole-pixel reads [px] (the slosh moves the gel
#: 0.2-2 px, :mod:`liquidtouch.sim.gelsight`): a ridge σ²/PRIOR_PX² on the normal matrix
#: keeps the direction along a straight edge (no information) at rest instead of letting
#: noise walk it away, and lowers a usable cell's gain by at most 0.3 % (its normal matrix
#: is ≥ σ²/0.05²)
PRIOR_PX = 1.0
#: a cell whose weaker direction reads motion with a noise std above this [px] (a
#: straight edge) is read across its stronger direction only: beyond it, noise alone
#: crosses the whole-pixel rounding (±0.5 px) at two std and walks the cell away
EDGE_STD_PX = 0.25
#: the reference is renewed when the cells' median residual grows beyond this factor of
#: its value at the first step (the image changed by more than the noise: √3× it)
REREFERENCE_RESIDUAL = 2.0
#: a cell's step is refused (the cell lost in that frame) when it moves more than this
#: many cells between frames, or its residual grows beyond LOST_RESIDUAL × its value at
#: the first step (3×: the image no longer matches where the cell says it is)
MAX_STEP_CELLS = 0.5
LOST_RESIDUAL = 3.0
#: the noise is read on the quietest quarter of the image's cells (the gel outside the
#: contact; the contact's texture inflates the estimate)
NOISE_QUANTILE = 0.25
#: lowest pixel noise assumed [grey levels]: uint8 rounding alone gives 0.29
NOISE_FLOOR = 0.5

#: what helps when the images show too little to measure
TEXTURE_ADVICE = (
    "a markerless gel needs the contact to show texture or an edge that moves with the "
    "gel: press a textured face (a label, an embossed or rough surface), or push across "
    "a cylinder's axis so that its edge moves across the image; or use a marker gel"
)


class TextureError(MarkerError):
    """A markerless image whose contact shows too little texture or edge to measure."""


@dataclass(frozen=True)
class _Grid:
    """The cells: size [px], the tiled region's top-left corner and cell counts."""

    cell: int
    x0: int
    y0: int
    nx: int
    ny: int

    @classmethod
    def of(cls, shape: tuple[int, int], columns: int = GRID_COLUMNS) -> _Grid:
        height, width = shape
        cell = max(4, width // columns)
        nx, ny = width // cell, height // cell
        if nx < 1 or ny < 1:
            raise VideoError(f"the image ({width} × {height} px) is too small for flow tracking")
        return cls(cell, (width - nx * cell) // 2, (height - ny * cell) // 2, nx, ny)

    @property
    def slices(self) -> tuple[slice, slice]:
        return (
            slice(self.y0, self.y0 + self.ny * self.cell),
            slice(self.x0, self.x0 + self.nx * self.cell),
        )

    def centres(self) -> np.ndarray:
        """(ny·nx, 2) cell centres (x, y) [px], row-major."""
        half = (self.cell - 1) / 2
        gy, gx = np.mgrid[0 : self.ny, 0 : self.nx]
        return np.stack(
            [self.x0 + gx.ravel() * self.cell + half, self.y0 + gy.ravel() * self.cell + half],
            axis=1,
        )

    def sums(self, values: np.ndarray) -> np.ndarray:
        """(ny·nx,) sum of ``values`` (region-shaped) over each cell."""
        import cv2

        means = cv2.resize(values, (self.nx, self.ny), interpolation=cv2.INTER_AREA)
        return means.ravel().astype(np.float64) * self.cell**2

    def corners(self, cells: np.ndarray) -> np.ndarray:
        """(len(cells), 2) top-left pixel (row, column) of the cells of row-major indices
        ``cells``."""
        iy, ix = np.divmod(np.asarray(cells), self.nx)
        return np.stack([self.y0 + iy * self.cell, self.x0 + ix * self.cell], axis=1)


def _cell_sums(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(cells,) Σ a·b over each cell's pixels of two (cells, c, c) blocks (float64 sums)."""
    return np.einsum("nij,nij->n", a, b, dtype=np.float64)


def noise_std(image: np.ndarray, cells: int = GRID_COLUMNS) -> float:
    """Pixel noise std [grey levels] of one image.

    Immerkær (1996, "Fast noise variance estimation"): the mean absolute response to a
    Laplacian-difference mask, which cancels smooth image content; taken on a grid of
    ``cells`` columns and read at the :data:`NOISE_QUANTILE` of the cells, because a fine
    texture (the very thing tracked) also answers the mask.
    """
    import cv2

    grey = np.asarray(image, dtype=np.float32)
    mask = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], dtype=np.float32)
    response = np.abs(cv2.filter2D(grey, -1, mask, borderType=cv2.BORDER_REFLECT))
    grid = _Grid.of(grey.shape, cells)
    per_cell = grid.sums(response[grid.slices]) / grid.cell**2
    return float(np.sqrt(np.pi / 2) * np.quantile(per_cell, NOISE_QUANTILE) / 6.0)


class FlowTracker:
    """Cell motion against a reference: ``start(image)`` on the first frame, then ``step(image)``.

    ``start`` returns the usable cells' centres (N, 2) [px]; ``step`` their positions
    in the next frame (N, 2) [px], NaN where a cell's fit failed in that frame.
    """

    def __init__(self, max_cell_std_px: float = MAX_CELL_STD_PX) -> None:
        if not 0 < float(max_cell_std_px) < np.inf:
            raise MarkerError(
                f"max_cell_std_px must be a motion std > 0 in pixels, got {max_cell_std_px!r}"
            )
        self.max_cell_std_px = float(max_cell_std_px)
        self.rereferences = 0

    @property
    def spacing_px(self) -> float:
        """The cell size [px] (what a marker tracker calls the marker spacing)."""
        return float(self.grid.cell * self.scale)

    @property
    def diameter_px(self) -> float:
        """The cell size [px] (a cell is the tracked "marker")."""
        return self.spacing_px

    def _working(self, grey: np.ndarray) -> np.ndarray:
        """``grey`` as float32 at the working scale (pixel means over scale × scale)."""
        import cv2

        image = grey.astype(np.float32)
        if self.scale > 1:
            height, width = image.shape
            size = (width // self.scale, height // self.scale)
            image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        return image

    def _filtered(self, grey: np.ndarray) -> np.ndarray:
        """The band-passed image at the working scale (module docstring, "Pre-filter")."""
        import cv2

        image = self._working(grey)
        narrow = cv2.GaussianBlur(image, (0, 0), self.sigma, borderType=cv2.BORDER_REFLECT)
        # the wide part as a box mean of the same variance: its cost does not grow with it
        wide = cv2.blur(image, (self.box, self.box), borderType=cv2.BORDER_REFLECT)
        return narrow - wide

    def start(self, image: np.ndarray) -> np.ndarray:
        """Choose the textured cells of the first frame; return their centres (N, 2) [px].

        Raises :class:`TextureError` when fewer than :data:`MIN_CELLS` cells show
        enough texture or edge.
        """
        grey = as_grey(image)
        self.shape = grey.shape
        # work at about WORK_WIDTH_PX wide (an image of 640 × 480 at half)
        self.scale = max(1, round(grey.shape[1] / WORK_WIDTH_PX))
        height, width = (n // self.scale * self.scale for n in grey.shape)
        self.crop = (slice(0, height), slice(0, width))  # of the full image
        full = _Grid.of((height // self.scale, width // self.scale))
        self.sigma = BLUR_CELLS * full.cell
        # a box of the same variance as a Gaussian of BAND_RATIO × sigma (odd width)
        self.box = 2 * int(round(np.sqrt(12) * BAND_RATIO * self.sigma) // 2) + 1
        filtered = self._filtered(grey[self.crop])
        self.noise = max(noise_std(self._working(grey[self.crop])), NOISE_FLOOR)
        self.ridge = self.noise**2 / PRIOR_PX**2
        self.grid = full
        self._corners = full.corners(np.arange(full.nx * full.ny))
        self._reference(filtered)
        eig_max = 0.5 * (self._sxx + self._syy) + np.sqrt(
            0.25 * (self._sxx - self._syy) ** 2 + self._sxy**2
        )
        self.cell_std_px = self.noise / np.sqrt(np.maximum(eig_max, 1e-12))
        chosen = np.flatnonzero(self.cell_std_px <= self.max_cell_std_px)
        if len(chosen) < MIN_CELLS:
            raise TextureError(
                f"the images show no printed markers (a markerless gel) and too little "
                f"texture or edge to measure the gel's motion: {len(chosen)} of "
                f"{len(self.cell_std_px)} image cells would read it to "
                f"{self.max_cell_std_px:g} px (noise {self.noise:.2g} grey levels); "
                f"{TEXTURE_ADVICE}"
            )
        # positions in the full image's pixels (a working pixel's centre is at scale·(k + ½) − ½)
        self.reference = (full.centres()[chosen] + 0.5) * self.scale - 0.5
        # from here on only the chosen cells' bounding box is read, with a margin for the
        # band-pass's support and the motion (half a cell)
        iy, ix = np.divmod(chosen, full.nx)
        c = full.cell
        box = _Grid(
            c, full.x0 + ix.min() * c, full.y0 + iy.min() * c, np.ptp(ix) + 1, np.ptp(iy) + 1
        )
        margin = max(int(np.ceil(3 * self.sigma)), self.box // 2) + c // 2
        y0, x0 = max(box.y0 - margin, 0), max(box.x0 - margin, 0)
        y1 = min(box.y0 + box.ny * c + margin, height // self.scale)
        x1 = min(box.x0 + box.nx * c + margin, width // self.scale)
        k = self.scale
        self.crop = (slice(y0 * k, y1 * k), slice(x0 * k, x1 * k))
        self.grid = _Grid(c, box.x0 - x0, box.y0 - y0, box.nx, box.ny)
        self.cells = (iy - iy.min()) * box.nx + (ix - ix.min())  # of the box's grid
        self._corners = self.grid.corners(self.cells)  # the chosen cells only from here
        self._reference(self._filtered(grey[self.crop]))
        n = len(chosen)
        self.motion = np.zeros((n, 2))  # against the current reference [px]
        self.previous = np.zeros((n, 2))
        self.offset = np.zeros((n, 2))  # motion up to the current reference [px]
        self.residual0: np.ndarray | None = None  # each cell's residual at the first step
        return self.reference.copy()

    def _gradients(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """x and y derivatives [grey levels/px] (5-point central differences, exact to
        O(h⁴): a texture's gain does not depend on its fineness as with 3 points)."""
        import cv2

        taps = np.array([[1.0, -8.0, 0.0, 8.0, -1.0]], dtype=np.float32) / 12.0
        gx = cv2.filter2D(image, cv2.CV_32F, taps, borderType=cv2.BORDER_REFLECT)
        gy = cv2.filter2D(image, cv2.CV_32F, taps.T, borderType=cv2.BORDER_REFLECT)
        return gx, gy

    def _reference(self, filtered: np.ndarray) -> None:
        """Make ``filtered`` the reference: its cells' pixels and gradients, their normal
        matrices."""
        gx, gy = self._gradients(filtered)
        self._ref, self._gx, self._gy = (self._blocks(a, self._corners) for a in (filtered, gx, gy))
        self._sxx = _cell_sums(self._gx, self._gx)
        self._syy = _cell_sums(self._gy, self._gy)
        self._sxy = _cell_sums(self._gx, self._gy)
        # a cell that reads its motion well in one direction only (a straight edge): the
        # other direction holds no information, so its motion is kept along the first
        half_gap = np.sqrt(0.25 * (self._sxx - self._syy) ** 2 + self._sxy**2)
        eig_min = 0.5 * (self._sxx + self._syy) - half_gap
        angle = 0.5 * np.arctan2(2 * self._sxy, self._sxx - self._syy)
        self._strong = np.stack([np.cos(angle), np.sin(angle)], axis=1)
        self._edge = eig_min * EDGE_STD_PX**2 < self.noise**2

    def _blocks(self, image: np.ndarray, corners: np.ndarray) -> np.ndarray:
        """(cells, c, c) copies of the c × c blocks of ``image`` at ``corners`` (cells, 2)
        (row, column of the top-left pixel); beyond the image, its edge pixels repeated."""
        import cv2

        c = self.grid.cell
        height, width = image.shape
        # how far the blocks reach beyond each side: padded only then (a cell at the
        # image's edge that moved out)
        top, left = (max(0, -int(corners[:, k].min())) for k in range(2))
        bottom = max(0, int(corners[:, 0].max()) + c - height)
        right = max(0, int(corners[:, 1].max()) + c - width)
        if top or left or bottom or right:
            image = cv2.copyMakeBorder(image, top, bottom, left, right, cv2.BORDER_REPLICATE)
            corners = corners + np.array([top, left])
        windows = np.lib.stride_tricks.sliding_window_view(image, (c, c))
        return windows[corners[:, 0], corners[:, 1]]

    def _solve(self, shift: np.ndarray, planes: list[np.ndarray], which: np.ndarray) -> tuple:
        """One symmetric gradient step of cells ``which`` from whole-pixel ``shift`` (cells,
        2): (motion, residual) of those cells.

        The frame is read at whole-pixel offsets (no interpolation, so no sub-pixel bias);
        the sub-pixel rest ``δ`` solves ``Σ g (J(x + n) − R(x)) = −Σ g gᵀ δ`` with ``g`` the
        mean of both images' gradients (second-order accurate: a sinusoid of ``k`` rad/px
        reads ``(2/k) tan(kδ/2)``, 1 % high at kδ = 0.35).
        """
        shift = shift[which]
        corners = self._corners[which] + shift[:, ::-1].astype(np.intp)  # (row, column)
        moved, gx, gy = (self._blocks(plane, corners) for plane in planes)
        error = moved - self._ref[which]
        gx += self._gx[which]
        gx *= 0.5
        gy += self._gy[which]
        gy *= 0.5
        sxx, sxy, syy = _cell_sums(gx, gx), _cell_sums(gx, gy), _cell_sums(gy, gy)
        bx, by = _cell_sums(gx, error), _cell_sums(gy, error)
        sxx, syy = sxx + self.ridge, syy + self.ridge
        det = sxx * syy - sxy * sxy
        rest = -np.stack([syy * bx - sxy * by, sxx * by - sxy * bx], axis=1) / det[:, None]
        motion = shift + rest
        edge = self._edge[which]
        strong = self._strong[which][edge]
        motion[edge] = strong * np.sum(strong * motion[edge], axis=1, keepdims=True)
        # what the step leaves unexplained: Σ (e + g·δ)² from the cell sums (δ = rest)
        rx, ry = rest[:, 0], rest[:, 1]
        explained = 2 * (rx * bx + ry * by) + rx * rx * sxx + 2 * rx * ry * sxy + ry * ry * syy
        return motion, np.maximum(_cell_sums(error, error) + explained, 0.0)

    def step(self, image: np.ndarray) -> np.ndarray:
        """Measure the cells' motion in the next frame; return their positions (N, 2) [px]."""

        frame = self._filtered(as_grey(image)[self.crop])
        planes = [frame, *self._gradients(frame)]  # the frame and its x, y gradients
        # read at the last frame's motion, rounded; the cells whose step lands more than
        # half a pixel away are read again at the new rounding, so the step always covers
        # ±0.5 px: at the slosh's speed (0.56 px a frame for 1 px at 14 rad/s and 25 fps) it
        # would reach ±1 px, where it reads a few % high (large motion over small: λ high)
        shift = np.rint(self.motion)
        motion, residuals = self._solve(shift, planes, slice(None))
        again = np.flatnonzero(np.any(np.abs(motion - shift) > 0.5, axis=1))
        if len(again):
            shift[again] = np.rint(motion[again])
            motion[again], residuals[again] = self._solve(shift, planes, again)
        if self.residual0 is None:  # the first step against this reference: noise only
            # at least what the pixel noise leaves after the band-pass (white noise through
            # a Gaussian of sigma keeps 1/(4π sigma²) of its variance)
            floor = self.grid.cell**2 * self.noise**2 / (4 * np.pi * self.sigma**2)
            self.residual0 = np.maximum(residuals, floor)
        ratio = residuals / self.residual0
        step = np.hypot(*(motion - self.motion).T)
        lost = (step > MAX_STEP_CELLS * self.grid.cell) | (ratio > LOST_RESIDUAL**2)
        motion[lost] = self.motion[lost]
        self.previous, self.motion = self.motion, motion
        positions = self.reference + self.scale * (self.offset + motion)
        positions[lost] = np.nan
        if np.median(ratio) > REREFERENCE_RESIDUAL**2:
            self.offset += motion
            self.previous = self.previous - motion  # keep the velocity across the renewal
            self.motion = np.zeros_like(motion)
            self._reference(frame)
            self.residual0 = None
            self.rereferences += 1
        return positions


def track_flow(
    frames: Iterable[tuple[float, np.ndarray]],
    sensor: str = "sensor",
    *,
    max_cell_std_px: float = MAX_CELL_STD_PX,
    on_frame: Callable[[int], None] | None = None,
) -> MarkerTracks:
    """Track a markerless gel's motion on a grid of textured cells (module docstring).

    Parameters
    ----------
    frames : iterable of (t_s, image)
        Timestamps [s] (finite, strictly increasing) and grey or colour images of one
        size, e.g. :func:`liquidtouch.io.frames.iter_frames`.
    sensor : str
        Name of the sensor.
    max_cell_std_px : float
        A cell is used when its motion's noise std is at most this [px].
    on_frame : callable, optional
        Called with the index of each frame once it is tracked (progress bars).

    Returns
    -------
    MarkerTracks
        One "marker" per usable cell: ``reference`` the cell centres, ``positions``
        centre + motion [px]; ``spacing_px`` and ``diameter_px`` the cell size.

    Raises
    ------
    TextureError
        The first frame shows too little texture or edge (what helps is in the message).
    VideoError
        No frames, timestamps not finite and increasing, or frames of different sizes.
    """
    if not isinstance(sensor, str) or not sensor:
        raise MarkerError(f"sensor must be a non-empty name such as 'left', got {sensor!r}")
    tracker = FlowTracker(max_cell_std_px)
    try:
        times, positions, first = run_tracker(frames, tracker, sensor, on_frame)
    except TextureError as exc:
        raise TextureError(f"{sensor}: {exc}") from None
    return MarkerTracks(
        t=times,
        positions=positions,
        valid=np.isfinite(positions).all(axis=2),
        reference=tracker.reference,
        sensor=sensor,
        spacing_px=tracker.spacing_px,
        diameter_px=tracker.diameter_px,
        first_frame=first,
        tracking="flow",
    )
