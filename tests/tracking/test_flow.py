"""Markerless gels (issue 39): flow tracking on rendered shifts, the gel's kind found from the
image, the clear error for an image without texture, the validation videos."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from helpers import SHARED
from scipy.ndimage import gaussian_filter, map_coordinates
from scipy.optimize import least_squares

from liquidtouch.cli import main
from liquidtouch.errors import LiquidTouchError
from liquidtouch.live.tracks import GrowingTracks
from liquidtouch.sim.render import iter_frames as render
from liquidtouch.sim.sensors import get_sensor_profile
from liquidtouch.tracking.flow import FlowTracker, TextureError, noise_std, track_flow
from liquidtouch.tracking.gel import gel_tracking, track_gel

VIDEOS = SHARED / "validation" / "videos"
PROFILE = get_sensor_profile("mini-plain")
CENTRE = np.array([(PROFILE.width_px - 1) / 2, (PROFILE.height_px - 1) / 2])
RADIUS = PROFILE.contact_radius_mm_ref / PROFILE.mm_per_px


def plain_frames(shifts: np.ndarray, *, contact: bool = True, seed: int = 3) -> list:
    """Grey frames of the plain gel's imprint moved uniformly by ``shifts`` (T, 2) [px]."""
    kwargs = {}
    if contact:
        kwargs = dict(
            contact_center_px=CENTRE,
            contact_radius_px=RADIUS,
            imprint_motion=lambda i, rel: np.tile(shifts[i], (len(rel), 1)),
        )
    frames = render(np.zeros((len(shifts), 0, 2)), PROFILE, np.random.default_rng(seed), **kwargs)
    return [cv2.cvtColor(f, cv2.COLOR_RGB2GRAY) for f in frames]


def held_motion(shifts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The contact cells' motion over the last 10 frames, and the cells' reference."""
    frames = plain_frames(shifts)
    tracker = FlowTracker()
    reference = tracker.start(frames[0])
    held = [tracker.step(f) - reference for f in frames[1:]][-10:]
    inner = np.hypot(*(reference - CENTRE).T) < 0.7 * RADIUS  # the textured contact
    return np.stack(held)[:, inner], reference[inner]


@pytest.mark.parametrize("shift", [0.05, 0.3, 0.75, 2.0])
def test_flow_reads_rendered_sub_pixel_shifts(shift: float) -> None:
    # reached in 10 steps, then held for 10 frames; the same frames at rest (the same
    # noise: the seed) take away what the reference frame's own noise reads (~0.01 px)
    ramp = shift * np.minimum(np.arange(21) / 10, 1.0)
    moved, cells = held_motion(np.column_stack([ramp, -0.5 * ramp]))
    rest, _ = held_motion(np.zeros((21, 2)))
    motion = np.nanmean(moved - rest, axis=0)  # (cells, 2)
    assert len(cells) >= 4
    # the mean over the contact's cells: within 3 % (linear from 0.05 to 2 px), or 0.002 px
    # (the mean's noise: 0.005 px a frame over 10 frames; the renderer's 1/64 px jitter)
    assert np.mean(motion[:, 0]) == pytest.approx(shift, rel=0.03, abs=0.002)
    assert np.mean(motion[:, 1]) == pytest.approx(-0.5 * shift, rel=0.03, abs=0.002)
    assert np.std(motion[:, 0]) < 0.02 + 0.02 * shift  # every cell, not only the mean


def test_noise_estimate_matches_the_rendered_noise() -> None:
    frame = plain_frames(np.zeros((1, 2)))[0]
    # the profile's noise per channel, averaged over three channels by the grey conversion
    expected = PROFILE.noise_std / np.sqrt(3)
    assert noise_std(frame) == pytest.approx(expected, rel=0.35)


def test_the_gel_kind_is_found_from_the_image() -> None:
    plain = plain_frames(np.zeros((1, 2)))[0]
    markers = get_sensor_profile("mini")
    rest = np.array([[x, y] for x in range(40, 300, 30) for y in range(30, 220, 30)], float)
    frame = next(render(rest[None], markers, np.random.default_rng(0)))
    assert gel_tracking(frame) == "markers"
    assert gel_tracking(plain) == "flow"
    assert gel_tracking(frame, "flow") == "flow"  # forced
    with pytest.raises(LiquidTouchError, match="tracking must be one of"):
        gel_tracking(frame, "dots")


def test_flow_tracks_say_so_and_keep_still_at_rest() -> None:
    frames = plain_frames(np.zeros((12, 2)))
    tracks = track_gel(((k / 25, f) for k, f in enumerate(frames)), "left")
    assert tracks.tracking == "flow" and tracks.n_markers >= 10
    assert "flow cells" in repr(tracks)
    # nothing moves: the cells stand still (noise ~0.02 px a cell and frame)
    assert np.abs(np.nanmean(tracks.displacement[1:], axis=(0, 1))).max() < 0.02
    assert np.nanstd(tracks.displacement[1:]) < 0.05


def test_an_image_without_texture_gets_the_clear_error(tmp_path, capsys) -> None:
    frames = plain_frames(np.zeros((30, 2)), contact=False)  # the gel with nothing pressed
    with pytest.raises(TextureError, match=r"no printed markers.*textured face"):
        track_flow((k / 25, f) for k, f in enumerate(frames))
    folder = tmp_path / "left"
    folder.mkdir()
    for k, frame in enumerate(frames):
        cv2.imwrite(str(folder / f"{k:03d}.png"), frame)
    assert main(["extract", str(folder), "--fps", "25"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "markerless" in err and "no push found" not in err
    assert "cylinder" in err and "textured face" in err


def test_live_tracks_wait_for_the_contact_on_a_plain_gel() -> None:
    empty = plain_frames(np.zeros((3, 2)), contact=False)
    pressed = plain_frames(np.zeros((3, 2)))
    grown = GrowingTracks("left")
    for k, frame in enumerate(empty + pressed):
        grown.add(k / 25, frame)
    assert grown.waited == 3 and grown.n == 3 and grown.tracking == "flow"
    assert grown.snapshot().tracking == "flow"


def _ring_down_decay(warp) -> float:
    """λ [1/s] read by flow tracking from a texture whose motion rings down (λ 0.45 1/s,
    ω 9.6 rad/s, 1.8 px at the contact's centre falling off as a Gaussian of 75 px: the
    shape of the validation set's markerless videos), each frame drawn by ``warp(texture,
    x_source, y_source)``; fitted on the most moving cell's x motion."""
    rng = np.random.default_rng(5)
    grains = gaussian_filter(rng.normal(0, 1, (240, 320)), 2.0)  # grains of ~5 px
    texture = 170.0 + 9.0 * grains / grains.std()
    t = np.arange(225) / 25.0
    u = 1.8 * np.exp(-0.45 * t) * np.cos(9.6 * t + 0.2)
    yy, xx = np.mgrid[0:240, 0:320].astype(np.float32)
    falloff = np.exp(-((xx - 160) ** 2 + (yy - 120) ** 2) / (2 * 75.0**2))
    frames = []
    for uk in u:
        image = warp(texture, xx - uk * falloff, yy)
        frames.append(np.clip(np.rint(image + rng.normal(0, 1.0, image.shape)), 0, 255))
    tracker = FlowTracker()
    reference = tracker.start(frames[0].astype(np.uint8))
    x = np.stack([tracker.step(f.astype(np.uint8))[:, 0] for f in frames[1:]]) - reference[:, 0]
    x = x[:, np.argmax(np.nanstd(x, axis=0))]

    def residual(p: np.ndarray) -> np.ndarray:
        return p[0] * np.exp(-p[1] * t[1:]) * np.cos(9.6 * t[1:] + p[2]) + p[3] - x

    return float(least_squares(residual, [1.8, 0.4, 0.2, -1.7]).x[1])


@pytest.mark.slow(seconds=10)
def test_a_ring_down_is_read_with_one_gain() -> None:
    # drawn exactly (a cubic spline reproduces a shifted smooth texture): the envelope, so
    # λ, is read within 3 %, small and large motions with one gain
    def spline(texture, x, y):
        return map_coordinates(texture, [y, x], order=3, mode="nearest")

    assert _ring_down_decay(spline) == pytest.approx(0.45, rel=0.03)

    # drawn by OpenCV's bicubic remap (Keys' kernel with a = -0.75, which does not reproduce
    # a linear ramp: near a whole pixel it moves the image by 1.5x the asked shift, at half
    # a pixel by 1x), the images themselves ring down slower, small motions moving further:
    # the tracker reads what the images show, 7 % low here (0.418; 13 % on the textured
    # validation video below, whose motion is drawn so)
    def bicubic(texture, x, y):
        source = texture.astype(np.float32)
        return cv2.remap(source, x.astype(np.float32), y, cv2.INTER_CUBIC, borderMode=1)

    assert 0.37 < _ring_down_decay(bicubic) < 0.435


@pytest.mark.skipif(not VIDEOS.exists(), reason="../shared/validation not available")
@pytest.mark.slow(seconds=20)
def test_validation_videos(capsys) -> None:
    label = VIDEOS / "markerless_label_mini"
    truth = json.loads((label / "truth.json").read_text())
    assert main(["extract", str(label / "left.mp4"), str(label / "right.mp4"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["tracking"] == "flow"
    assert out["angular_frequency"] == pytest.approx(truth["omega"], rel=0.01)
    # λ reads 13 % low: the images' own motion rings down at ~0.39 1/s, not the truth's 0.45
    # (test_a_ring_down_is_read_with_one_gain: a bicubic-remapped texture moves 1.5x as far
    # as asked near whole pixels); held to what the images show, so that a change is seen
    assert out["decay_rate"] == pytest.approx(0.393, rel=0.05)
    smooth = VIDEOS / "markerless_smooth_mini"
    assert main(["extract", str(smooth / "left.mp4"), str(smooth / "right.mp4"), "--json"]) == 2
    assert "too little texture or edge" in capsys.readouterr().err  # a refusal, not a number
