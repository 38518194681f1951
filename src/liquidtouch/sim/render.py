"""GelSight frame rendering (encoding to H.264 is in :mod:`liquidtouch.sim.encode`).

A frame is: a static background (uneven coloured LED lighting, vignetting, faint
dust), times the container's contact imprint (a soft tinted patch with a shaded
rim, shifted sub-pixel with the gel), times the markers' ink transmittance, times
a per-frame LED flicker gain, plus sensor noise. The background and imprint are
computed once per video, the imprint's shifted copies at 1/8 px steps once per
shift. Per frame: the lit gel with the imprint (float32) is rewritten only where
the imprint moved; one full-image pass turns it into uint8 times the flicker
gain; the markers' patches, evaluated from a radial look-up table at their exact
sub-pixel offsets, are written over that from their windows only (all markers at
once with one gather and one scatter); one pass adds the noise. The pixels are
bit-identical to the renderer before issue 27 (this file at git 675ffb2, measured
against by ``benchmarks/sim/simulate_speed.py``), which re-darkened and restored a
float32 copy of the frame every frame.

A marker's darkening is radially symmetric about its intended position and its
edge is a Gaussian-blurred step (``marker_edge_px``), so the pixel-sampled blob
is effectively band-limited: its intensity-weighted centroid equals the intended
position to ~1e-4 px (before uint8 rounding and codec).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator

import numpy as np
from numpy.lib.stride_tricks import as_strided

from liquidtouch.errors import LiquidTouchError
from liquidtouch.sim.sensors import SensorProfile, get_sensor_profile

_LUT_PER_PX2 = 64  # radial look-up table resolution in squared pixels


def make_background(
    profile: SensorProfile | str, rng: np.random.Generator, *, lighting: bool = True
) -> np.ndarray:
    """Static illumination of the gel, float32 (H, W, 3) in grey levels (RGB).

    ``lighting=False`` gives a flat grey (useful for measuring marker centroids).
    The per-sensor randomness (``rng``) varies the LED colours and adds a smooth
    unevenness and a few faint dust specks.
    """
    import cv2

    profile = get_sensor_profile(profile)
    h, w = profile.height_px, profile.width_px
    if not lighting:
        return np.full((h, w, 3), 110.0, dtype=np.float32)
    # the lighting is smooth: evaluate it on a coarse grid and upsample
    step = 4
    hc, wc = -(-h // step), -(-w // step)
    yy, xx = np.mgrid[0:hc, 0:wc].astype(np.float32)
    xn, yn = xx * step / (w - 1), yy * step / (h - 1)
    diag = float(np.hypot(w, h))
    img = np.empty((hc, wc, 3), dtype=np.float32)
    img[:] = np.asarray(profile.base_rgb, dtype=np.float32)
    for led in profile.leds:
        cx = led.center[0] + rng.normal(0, 0.03)
        cy = led.center[1] + rng.normal(0, 0.03)
        d2 = ((xn - cx) * w) ** 2 + ((yn - cy) * h) ** 2
        lobe = np.exp(-d2 / (2 * (led.width * diag) ** 2))
        colour = np.asarray(led.rgb, dtype=np.float32) * rng.uniform(0.9, 1.1, 3)
        img += lobe[..., None] * colour.astype(np.float32)
    # smooth unevenness of the gel's coating: a coarse random field, upsampled
    coarse = rng.normal(0.0, 1.0, (5, 7, 3)).astype(np.float32)
    img *= 1.0 + 0.04 * cv2.resize(coarse, (wc, hc), interpolation=cv2.INTER_CUBIC)
    r2 = ((xn - 0.5) ** 2 + (yn - 0.5) ** 2) / 0.5
    img *= (1.0 - profile.vignette * r2**1.5)[..., None]
    img = cv2.resize(img, (w, h), interpolation=cv2.INTER_LINEAR)
    # faint dust specks: small soft spots, far lighter than the markers
    for _ in range(rng.integers(2, 6)):
        sx, sy = rng.uniform(8, w - 8), rng.uniform(8, h - 8)
        rad = rng.uniform(0.8, 1.8)
        x0, y0 = int(sx) - 6, int(sy) - 6
        py, px = np.mgrid[y0 : y0 + 13, x0 : x0 + 13]
        spot = np.exp(-((px - sx) ** 2 + (py - sy) ** 2) / (2 * rad**2)).astype(np.float32)
        img[y0 : y0 + 13, x0 : x0 + 13] *= (1.0 - rng.uniform(0.1, 0.25) * spot)[..., None]
    return np.clip(img, 0.0, 255.0)


def make_imprint(
    profile: SensorProfile | str,
    radius_px: float,
    *,
    grooves: bool = True,
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """Multiplicative gain (h, h, 3) of the container's contact imprint, centred in the patch.

    The patch is square, just large enough for the rim; outside the
    contact the gain is 1. The contact is a slightly wide ellipse, tinted and a
    little brighter, with a rim lit on one side and shaded on the other (the LEDs
    shine at a grazing angle) and, with ``grooves``, faint parallel grooves. With
    ``rng``, the face's fine texture (``profile.face_texture``: Gaussian-smoothed noise
    of ``face_texture_mm``) is printed on the contact, as a plain gel shows it.
    """
    profile = get_sensor_profile(profile)
    edge_px = max(2.0, 0.06 * radius_px)
    half = int(np.ceil(1.15 * radius_px + 4 * edge_px))
    yy, xx = np.mgrid[-half : half + 1, -half : half + 1].astype(np.float32)
    a, b = 1.15 * radius_px, 0.87 * radius_px
    rho_px = (np.sqrt((xx / a) ** 2 + (yy / b) ** 2) - 1.0) * radius_px
    # mask and rim depend on rho only: tabulate them instead of evaluating erfc/exp per pixel
    table_rho = np.linspace(-radius_px, 2 * half, 4096)
    mask = np.interp(rho_px, table_rho, 0.5 * _erfc(table_rho / (np.sqrt(2.0) * edge_px)))
    rim = np.interp(rho_px, table_rho, np.exp(-(table_rho**2) / (2 * edge_px**2)))
    # light from upper-left: rim facing it is lit, the opposite side shaded
    direction = (-(xx + yy) / np.float32(np.sqrt(2.0))) / np.maximum(np.hypot(xx, yy), 1.0)
    gain = np.ones((*xx.shape, 3), dtype=np.float32)
    gain += mask[..., None].astype(np.float32) * np.array([0.10, -0.03, 0.09], dtype=np.float32)
    gain += (0.08 * rim * direction).astype(np.float32)[..., None]
    if grooves:
        period_px = 0.9 / profile.mm_per_px
        gain += (0.012 * mask * np.sin(2 * np.pi * yy / period_px)).astype(np.float32)[..., None]
    if rng is not None and profile.face_texture > 0:
        import cv2

        grain = cv2.GaussianBlur(
            rng.standard_normal(xx.shape).astype(np.float32),
            (0, 0),
            profile.face_texture_mm / profile.mm_per_px,
            borderType=cv2.BORDER_REFLECT,
        )
        grain *= np.float32(profile.face_texture) / max(float(grain.std()), 1e-12)
        gain *= (1.0 + mask * grain).astype(np.float32)[..., None]
    return gain.astype(np.float32)


def _erfc(x: np.ndarray) -> np.ndarray:
    """The complementary error function, elementwise (float64; without importing SciPy).

    ``math.erfc`` agrees with ``scipy.special.erfc`` to 1 ulp, and exactly once in float32.
    """
    return np.frompyfunc(math.erfc, 1, 1)(np.asarray(x, dtype=float)).astype(float)


def _marker_lut(profile: SensorProfile) -> tuple[np.ndarray, int]:
    """Ink coverage against squared distance [px²] (×_LUT_PER_PX2), and the patch half-size.

    The patch is large enough for markers up to 10 % larger than nominal.
    """
    half = int(np.ceil(1.1 * profile.marker_radius_px + 3.5 * profile.marker_edge_px))
    d2 = np.arange(0, int(1.3 * 2 * (half + 1) ** 2 * _LUT_PER_PX2) + 2) / _LUT_PER_PX2
    edge = np.sqrt(2.0) * profile.marker_edge_px
    coverage = 0.5 * _erfc((np.sqrt(d2) - profile.marker_radius_px) / edge)
    return coverage.astype(np.float32), half


def _marker_styles(
    profile: SensorProfile, n_markers: int, rng: np.random.Generator, vary: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Per-marker squared-distance scale (radius variation) and ink opacity (1 − transmittance).

    Scaling the squared distance by (r0/r)² turns the nominal profile into one of
    radius r (with an edge scaled alike): still radially symmetric, so centroids
    stay exact.
    """
    spread = 1.0 if vary else 0.0
    rel = np.clip(rng.normal(0.0, spread * profile.marker_radius_jitter, n_markers), -0.1, 0.1)
    d2_scale = ((1.0 / (1.0 + rel)) ** 2 * _LUT_PER_PX2).astype(np.float32)
    transmittance = profile.marker_transmittance + rng.normal(
        0.0, spread * profile.marker_ink_jitter, n_markers
    )
    opacity = 1.0 - np.clip(transmittance, 0.02, 0.6)
    return d2_scale, opacity.astype(np.float32)


def iter_frames(
    positions_px: np.ndarray,
    profile: SensorProfile | str,
    rng: np.random.Generator,
    *,
    background: np.ndarray | None = None,
    contact_center_px: np.ndarray | None = None,
    contact_radius_px: float | None = None,
    contact_offsets_px: np.ndarray | None = None,
    noise: bool = True,
    flicker: bool = True,
    marker_variation: bool = True,
    gains: np.ndarray | None = None,
    marker_ink: np.ndarray | None = None,
    noise_rgb: tuple[float, float, float] | None = None,
    noise_corr_px: float = 0.0,
    imprint_motion: Callable[[int, np.ndarray], np.ndarray] | None = None,
) -> Iterator[np.ndarray]:
    """Yield uint8 RGB frames (H, W, 3), one per row of ``positions_px`` (T, N, 2) [px].

    ``background`` defaults to :func:`make_background`. The imprint is drawn when
    ``contact_center_px`` and ``contact_radius_px`` are given, shifted each frame
    by ``contact_offsets_px`` (T, 2). ``noise`` adds sensor noise; ``flicker``
    varies the LED brightness from frame to frame; ``marker_variation`` gives each
    marker its own radius and ink density (printing spread; centroids stay exact).
    Each yielded array is reused by the next frame: copy it to keep it.

    Bench nuisances (:mod:`liquidtouch.sim.realism`; all off by default, which
    leaves the frames exactly as without them): ``gains`` (T,) multiplies each
    frame's brightness (auto-exposure and LED drift); ``marker_ink`` (N,) scales
    each marker's ink (0 = rubbed off); ``noise_rgb`` replaces the profile's
    white noise by noise of that std per channel [grey levels], spatially
    correlated by a Gaussian blur of ``noise_corr_px`` [px] (the same random
    draws, blurred and rescaled).

    A plain gel (no markers: give ``positions_px`` with no markers): ``imprint_motion``
    ``(frame, points (N, 2) from the contact centre [px]) → (N, 2)`` [px] is the gel's
    displacement, which moves the imprint, with the face's texture, pixel by pixel
    (instead of as a whole by ``contact_offsets_px``).
    """
    import cv2

    profile = get_sensor_profile(profile)
    positions_px = np.asarray(positions_px, dtype=np.float64)
    if positions_px.ndim != 3 or positions_px.shape[2] != 2:
        raise LiquidTouchError("positions_px must have shape (frames, markers, 2)")
    if not np.all(np.isfinite(positions_px)):
        raise LiquidTouchError("marker positions contain NaN or infinite values")
    n_frames = positions_px.shape[0]
    h, w = profile.height_px, profile.width_px
    if background is None:
        background = make_background(profile, rng)
    if background.shape != (h, w, 3):
        raise LiquidTouchError(f"background must have shape {(h, w, 3)}, got {background.shape}")
    lut, half = _marker_lut(profile)
    d2_scale, opacity = _marker_styles(profile, positions_px.shape[1], rng, marker_variation)
    if marker_ink is not None:
        opacity = (opacity * np.asarray(marker_ink, dtype=np.float32)).astype(np.float32)
    pad = half + 2
    hp, wp = h + 2 * pad, w + 2 * pad
    # base: the lit gel with the imprint where it is this frame (float32, padded); it is
    # only rewritten where the imprint moved. The frame is base × flicker gain as uint8
    # (one full-image pass) with the markers' patches written over it from their
    # windows of base (base × ink, then the same rounding), then the noise.
    base = cv2.copyMakeBorder(
        np.ascontiguousarray(background, dtype=np.float32), pad, pad, pad, pad, cv2.BORDER_REFLECT
    )
    base_visible = base[pad : pad + h, pad : pad + w]
    drawn = np.empty((hp, wp, 3), dtype=np.uint8)  # the frame before noise, padded
    drawn_visible = drawn[pad : pad + h, pad : pad + w]
    out = np.empty((h, w, 3), dtype=np.uint8)
    k = np.arange(2 * half + 1)
    size = 2 * half + 1
    # every marker's (K, K, 3) patch as a window into base / drawn, indexed by its
    # top-left corner: one gather and one scatter draw all markers
    shape = (hp - size + 1, wp - size + 1, size, size, 3)
    base_windows = as_strided(
        base, shape=shape, strides=base.strides[:2] * 2 + base.strides[2:], writeable=False
    )
    drawn_windows = as_strided(
        drawn, shape=shape, strides=drawn.strides[:2] * 2 + drawn.strides[2:], writeable=True
    )
    bounds = np.array([wp - half - 1, hp - half - 1])

    if imprint_motion is None:
        imprint = _ImprintLayer.build(profile, contact_center_px, contact_radius_px, pad, (hp, wp))
    else:
        imprint = _GelImprint.build(
            profile, contact_center_px, contact_radius_px, pad, (hp, wp), rng
        )
        if imprint is not None:
            imprint.motion = imprint_motion
    background_box = None if imprint is None else base[imprint.slices].copy()
    if contact_offsets_px is None:
        contact_offsets_px = np.zeros((n_frames, 2))
    contact_offsets_px = np.asarray(contact_offsets_px, dtype=float)
    if contact_offsets_px.shape != (n_frames, 2):
        raise LiquidTouchError(f"contact_offsets_px must have shape ({n_frames}, 2)")

    use_noise = noise and (profile.noise_std > 0 if noise_rgb is None else max(noise_rgb) > 0)
    if use_noise:
        npad = 48
        # integer noise, as after the camera's ADC, split into its positive and negative
        # parts so that it can be added to the uint8 frame with saturation
        white = rng.standard_normal((h + npad, w + npad, 3), dtype=np.float32)
        if noise_rgb is None:
            noise_float = profile.noise_std * white
        else:
            noise_float = _coloured_noise(white, noise_rgb, noise_corr_px)
        noise_tile = np.rint(noise_float)
        noise_up = np.clip(noise_tile, 0, 255).astype(np.uint8)
        noise_down = np.clip(-noise_tile, 0, 255).astype(np.uint8)
        offsets = rng.integers(0, npad, (n_frames, 2))
    gains_flicker = _flicker_gains(profile.flicker_std if flicker else 0.0, n_frames, rng)
    if gains is not None:
        drift = np.asarray(gains, dtype=float)
        if drift.shape != (n_frames,):
            raise LiquidTouchError(f"gains must have shape ({n_frames},)")
        gains_flicker = gains_flicker * drift
    gains = gains_flicker

    imprint_key = None
    spacing = _Spacing(size)
    dithered = imprint_motion is not None and positions_px.shape[1] == 0
    for i in range(n_frames):
        if imprint is not None:
            key = imprint.key(contact_offsets_px[i], i)
            if key != imprint_key:
                cv2.multiply(background_box, imprint.shifted(key), dst=base[imprint.slices])
                imprint_key = key
        alpha = float(gains[i])
        # rounds to nearest and saturates to 0..255 (values are never negative here)
        if dithered and use_noise:
            # a plain gel's faint texture: the noise before the rounding, as a camera's ADC
            # sees it (rounded first, motion of a tenth of a pixel would freeze)
            oy, ox = offsets[i]
            lit = cv2.scaleAdd(base_visible, alpha, noise_float[oy : oy + h, ox : ox + w])
            np.copyto(out, np.clip(np.rint(lit), 0, 255), casting="unsafe")
            yield out
            continue
        cv2.convertScaleAbs(base_visible, dst=drawn_visible, alpha=alpha)
        pos = positions_px[i] + pad
        corner_all = np.floor(pos).astype(np.intp) - half  # (N, 2) top-left (x, y)
        inside = np.all((pos >= half) & (pos < bounds), axis=1)
        pos, corner = pos[inside], corner_all[inside]
        if len(pos):
            dx2 = ((corner[:, 0:1] + k - pos[:, 0:1]) ** 2).astype(np.float32)  # (N, K)
            dy2 = ((corner[:, 1:2] + k - pos[:, 1:2]) ** 2).astype(np.float32)
            d2 = (dy2[:, :, None] + dx2[:, None, :]) * d2_scale[inside, None, None]
            d2 += np.float32(0.5)
            coverage = lut[d2.astype(np.intp)]
            coverage *= opacity[inside, None, None]
            factor = np.subtract(np.float32(1.0), coverage, out=coverage)
            cy, cx = corner[:, 1], corner[:, 0]
            if spacing.may_overlap(corner_all):  # rare: markers touching
                _draw_overlapping(base, drawn, corner, factor, alpha)
            else:
                # (N·K, K, 3) rows of the markers' windows of base, times their ink factor
                # (cv2 rather than numpy's slow broadcast over a last axis of 3)
                patches = base_windows[cy, cx].reshape(-1, size, 3)
                factor = factor.reshape(-1, size)
                patches = cv2.multiply(patches, cv2.merge((factor, factor, factor)))
                drawn_windows[cy, cx] = cv2.convertScaleAbs(patches, alpha=alpha).reshape(
                    -1, size, size, 3
                )
        if use_noise:
            oy, ox = offsets[i]
            cv2.add(drawn_visible, noise_up[oy : oy + h, ox : ox + w], dst=out)
            cv2.subtract(out, noise_down[oy : oy + h, ox : ox + w], dst=out)
        else:
            np.copyto(out, drawn_visible)
        yield out


def _draw_overlapping(
    base: np.ndarray, drawn: np.ndarray, corner: np.ndarray, factor: np.ndarray, alpha: float
) -> None:
    """Draw markers whose patches overlap: one after the other, on a copy of their box."""
    import cv2

    size = factor.shape[1]
    x0, y0 = corner.min(axis=0)
    x1, y1 = corner.max(axis=0) + size
    box = base[y0:y1, x0:x1].copy()
    for (cx, cy), f in zip(corner - (x0, y0), factor, strict=True):
        box[cy : cy + size, cx : cx + size] *= f[..., None]
    cv2.convertScaleAbs(box, dst=drawn[y0:y1, x0:x1], alpha=alpha)


class _Spacing:
    """Whether marker patches (size × size, top-left ``corner``) may overlap, cheaply per frame.

    Keeps a reference layout and its smallest gap between patches; while no corner
    has moved more than half the spare gap from it, no two patches can touch, and
    otherwise the pairs are checked (and the layout becomes the new reference).
    """

    def __init__(self, size: int):
        self.size = size
        self.ref: np.ndarray | None = None
        self.gap = 0

    def may_overlap(self, corner: np.ndarray) -> bool:
        if self.ref is not None and self.ref.shape == corner.shape and len(corner):
            drift = int(np.abs(corner - self.ref).max())
            if self.gap - 2 * drift >= self.size:
                return False
        self.ref, self.gap = corner.copy(), _smallest_gap(corner)
        return self.gap < self.size


def _smallest_gap(corner: np.ndarray) -> int:
    """Smallest Chebyshev distance between two of the ``corner`` (N, 2) (large if N < 2)."""
    if len(corner) < 2:
        return 1 << 30
    gap = np.abs(corner[:, None, :] - corner[None, :, :]).max(axis=2)
    np.fill_diagonal(gap, 1 << 30)
    return int(gap.min())


def _coloured_noise(
    white: np.ndarray, std_rgb: tuple[float, float, float], corr_px: float
) -> np.ndarray:
    """``white`` (H, W, 3) blurred by a Gaussian of ``corr_px`` and scaled to ``std_rgb``."""
    import cv2

    out = white
    if corr_px > 0:
        out = cv2.GaussianBlur(white, (0, 0), sigmaX=corr_px, borderType=cv2.BORDER_REFLECT)
        out = out / out.std(axis=(0, 1), keepdims=True)
    return out * np.asarray(std_rgb, dtype=np.float32)


def _flicker_gains(flicker_std: float, n_frames: int, rng: np.random.Generator) -> np.ndarray:
    """Per-frame LED brightness gain: an AR(1) wander around 1 with std ``flicker_std``."""
    if flicker_std <= 0:
        return np.ones(n_frames)
    rho = 0.8
    innov = rng.normal(0.0, flicker_std * np.sqrt(1 - rho**2), n_frames)
    innov[0] = rng.normal(0.0, flicker_std)
    out, level = np.empty(n_frames), 0.0
    for i, x in enumerate(innov.tolist()):  # y[i] = x[i] + rho·y[i−1], as scipy's lfilter
        level = x + rho * level
        out[i] = level
    return 1.0 + out


class _ImprintLayer:
    """The contact imprint's gain patch, shifted with the gel (cached at 1/8 px steps)."""

    _STEPS_PER_PX = 8

    def __init__(
        self,
        gain: np.ndarray,
        box: tuple[int, int, int, int],
        sub: np.ndarray,
        centre: tuple[int, int] = (0, 0),
    ):
        self.gain, self.box, self.sub, self.centre = gain, box, sub, centre
        self._cache: dict[tuple[int, int], np.ndarray] = {}

    @classmethod
    def build(
        cls, profile, center_px, radius_px, pad, padded_shape, rng=None
    ) -> _ImprintLayer | None:
        """The layer of an imprint of ``radius_px`` at ``center_px`` (None without one);
        ``rng`` prints the face's texture on it (a plain gel)."""
        if center_px is None or radius_px is None:
            return None
        gain = make_imprint(profile, float(radius_px), rng=rng)
        ih = gain.shape[0] // 2
        hp, wp = padded_shape
        cx, cy = (float(c) + pad for c in center_px)
        cxi, cyi = round(cx), round(cy)
        x0, x1 = max(cxi - ih, 0), min(cxi + ih + 1, wp)
        y0, y1 = max(cyi - ih, 0), min(cyi + ih + 1, hp)
        if x0 >= x1 or y0 >= y1:
            return None
        gain = np.ascontiguousarray(
            gain[y0 - (cyi - ih) : y1 - (cyi - ih), x0 - (cxi - ih) : x1 - (cxi - ih)]
        )
        return cls(gain, (y0, y1, x0, x1), np.array([cx - cxi, cy - cyi]), (cxi - x0, cyi - y0))

    @property
    def slices(self) -> tuple[slice, slice]:
        """The imprint's box in the padded image."""
        y0, y1, x0, x1 = self.box
        return slice(y0, y1), slice(x0, x1)

    def key(self, offset_px: np.ndarray, frame: int) -> tuple[int, int]:
        """The shift of the imprint for a gel offset, in 1/8 px steps (x, y)."""
        steps = self._STEPS_PER_PX
        return (
            round((float(offset_px[0]) + self.sub[0]) * steps),
            round((float(offset_px[1]) + self.sub[1]) * steps),
        )

    def shifted(self, key: tuple[int, int]) -> np.ndarray:
        """The imprint's gain shifted by ``key`` (from :meth:`key`)."""
        import cv2

        moved = self._cache.get(key)
        if moved is None:
            dx, dy = np.asarray(key, dtype=float) / self._STEPS_PER_PX
            shift = np.array([[1.0, 0.0, dx], [0.0, 1.0, dy]], dtype=np.float32)
            moved = cv2.warpAffine(
                self.gain,
                shift,
                (self.gain.shape[1], self.gain.shape[0]),
                flags=cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=(1.0, 1.0, 1.0),
            )
            if len(self._cache) < 256:
                self._cache[key] = moved
        return moved


class _GelImprint(_ImprintLayer):
    """A plain gel's imprint, with the face's texture, moved pixel by pixel with the gel.

    Each frame resamples the rest imprint where the gel's displacement field ``motion``
    put it (Lanczos, 8 × 8 taps: bilinear sampling of a fine texture would change its gain
    with the fraction of a pixel), at positions jittered by OpenCV's 1/32 px step (below). The
    content at rest point ``p`` shows at ``p + d(p)``; pixel ``q`` reads the rest imprint
    at ``p = q − d(q − d(q))`` (one fixed-point step: exact to second order in the
    field's gradient).
    """

    _FIELD_STEP_PX = 4

    def key(self, offset_px: np.ndarray, frame: int) -> int:
        return frame

    def shifted(self, frame: int) -> np.ndarray:
        import cv2

        h, w = self.gain.shape[:2]
        step = self._FIELD_STEP_PX
        if not hasattr(self, "_coarse"):
            # the field is smooth (its width is the contact's size): evaluated every
            # _FIELD_STEP_PX and read linearly between (error ~1e-3 px)
            yy, xx = np.mgrid[0 : h + step : step, 0 : w + step : step]
            self._coarse_shape = xx.shape
            self._coarse = np.stack([xx.ravel(), yy.ravel()], axis=1).astype(np.float64)
            self._coarse_rel = self._coarse - np.asarray(self.centre) - self.sub
            self._grid = np.mgrid[0:h, 0:w][::-1].astype(np.float32)  # (x, y) of each pixel
            self._jitter = np.random.default_rng(0)  # the same frames every run
        d = self.motion(frame, self._coarse_rel)
        d = self.motion(frame, self._coarse_rel - d)  # from the contact centre [px]
        ch, cw = self._coarse_shape
        size = (cw * step, ch * step)
        maps = []
        for axis in range(2):
            fine = cv2.resize(d[:, axis].reshape(ch, cw).astype(np.float32), size)
            # cv2.resize aligns pixel centres: coarse sample k sits at fine (k + 0.5)·step − 0.5
            shift = (step - 1) / 2
            fine = cv2.warpAffine(
                fine,
                np.float32([[1, 0, -shift], [0, 1, -shift]]),
                size,
                flags=cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_REPLICATE,
            )[:h, :w]
            maps.append(self._grid[axis] - fine - np.float32(self.sub[axis]))
        # OpenCV rounds the positions to 1/32 px; a uniform jitter of one such step makes
        # that rounding exact on average (0.05 px would otherwise read as 0.0625): the jitter
        # moves a pixel by ≤ 1/64 px, a change of ~0.01 grey level, far below the noise
        jitter = self._jitter.uniform(-1 / 64, 1 / 64, (2, h, w)).astype(np.float32)
        return cv2.remap(
            self.gain,
            maps[0] + jitter[0],
            maps[1] + jitter[1],
            cv2.INTER_LANCZOS4,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=(1.0, 1.0, 1.0),
        )


def render_frames(
    positions_px: np.ndarray,
    profile: SensorProfile | str,
    rng: np.random.Generator,
    **kwargs,
) -> np.ndarray:
    """All frames at once, uint8 (T, H, W, 3); see :func:`iter_frames` for the options.

    Holds every frame in memory (T × H × W × 3 bytes): prefer :func:`iter_frames`
    for long recordings.
    """
    return np.stack([f.copy() for f in iter_frames(positions_px, profile, rng, **kwargs)])
