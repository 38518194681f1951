"""Simulated GelSight: marker motion physics, frame timing, rendered images, video files."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import av
import numpy as np
import pytest
from helpers import SHARED
from hypothesis import given, settings
from hypothesis import strategies as st

from liquidtouch.errors import CatalogueError, DatasetError, LiquidTouchError
from liquidtouch.sim.encode import encode_video
from liquidtouch.sim.gelsight import (
    contact_geometry,
    frame_timestamps,
    marker_positions,
    marker_rest_positions,
    write_sensor_videos,
)
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.render import iter_frames, make_background, render_frames
from liquidtouch.sim.sensors import SENSOR_PROFILES, get_sensor_profile

SLOSH_HZ = 1.5


def make_loads(
    duration_s: float = 2.0,
    amplitude_n: float = 0.1,
    twist_nmm: float = 0.0,
    weight_n: float = 1.0,
    preload_n: float = 5.0,
    center_mm: tuple[float, float] = (1.0, -0.5),
) -> FingerLoads:
    """A damped-cosine slosh shear on both fingers plus their static weight share."""
    t = np.arange(0.0, duration_s + 1e-9, 0.005)
    osc = np.exp(-0.3 * t) * np.cos(2 * np.pi * SLOSH_HZ * t)
    shear = np.zeros((len(t), 2, 2))
    shear[:, :, 0] = amplitude_n * osc[:, None]
    shear[:, :, 1] = -weight_n
    twist = np.repeat((twist_nmm * osc)[:, None], 2, axis=1)
    return FingerLoads(
        t_s=t,
        shear_force_n=shear,
        twist_moment_nmm=twist,
        normal_force_n=np.array([preload_n, preload_n]),
        contact_center_mm=np.array([center_mm, center_mm]),
    )


def decode(path: Path) -> tuple[np.ndarray, np.ndarray, float]:
    """Frames (T, H, W, 3), their decoded times [s] and the stream's average rate [Hz]."""
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        rate = float(stream.average_rate)
        frames, times = [], []
        for frame in container.decode(stream):
            frames.append(frame.to_ndarray(format="rgb24"))
            times.append(frame.time)
        return np.stack(frames), np.array(times), rate


def darkness_centroids(
    darkness: np.ndarray, positions: np.ndarray, half: int, local_baseline: bool = False
) -> np.ndarray:
    """Plain intensity-weighted centroids of ``darkness`` (H, W) in a window around positions.

    With ``local_baseline`` the median of the window's border is subtracted first
    (and negative values clipped), for images whose background is not known.
    """
    out = np.empty_like(positions)
    for j, (x, y) in enumerate(positions):
        xi, yi = round(x), round(y)
        win = darkness[yi - half : yi + half + 1, xi - half : xi + half + 1]
        if local_baseline:
            border = np.concatenate([win[0], win[-1], win[1:-1, 0], win[1:-1, -1]])
            win = np.clip(win - np.median(border), 0.0, None)
        yy, xx = np.mgrid[yi - half : yi + half + 1, xi - half : xi + half + 1]
        out[j] = [(win * xx).sum() / win.sum(), (win * yy).sum() / win.sum()]
    return out


# ---------------------------------------------------------------- marker motion


def instant(sensor: str):
    """The profile with an instant exposure: loads sampled at the frame time (no motion blur)."""
    return dataclasses.replace(get_sensor_profile(sensor), exposure_fraction=0.0)


@pytest.mark.parametrize("sensor", ["default", "mini"])
def test_shear_at_contact_centre_follows_compliance(sensor):
    profile = instant(sensor)
    loads = make_loads(amplitude_n=0.1, weight_n=1.0)
    centre = contact_geometry(loads, profile).center_px
    t = np.array([0.0, 1.0 / SLOSH_HZ / 2])  # slosh force at +max, then near -max
    for s, sign in ((0, 1.0), (1, -1.0)):
        pos = marker_positions(loads, profile, t, rest_px=centre[s : s + 1])[s, :, 0]
        disp = pos - centre[s]
        c = profile.shear_compliance_px_per_n
        assert disp[0, 0] == pytest.approx(sign * c * 0.1, rel=1e-9)
        assert disp[0, 1] == pytest.approx(c * 1.0, rel=1e-9)  # weight pulls down: image +y
        assert np.sign(disp[1, 0]) == -sign
    # a 0.1 N slosh moves markers by a realistic 0.2-2 px
    assert 0.2 <= profile.shear_compliance_px_per_n * 0.1 <= 2.0


@pytest.mark.parametrize("sensor", ["default", "mini"])
def test_exposure_averages_motion_and_tames_aliased_vibration(sensor):
    """A frame shows the shear averaged over its exposure: gain sinc(f·T) at f Hz."""
    profile = get_sensor_profile(sensor)
    exposure_s = profile.exposure_fraction / profile.fps
    t = np.arange(0.0, 4.0, 1e-3)
    frames = np.arange(0.5, 3.5, 1.0 / profile.fps)
    for f_hz in (2.0, profile.fps - 1.0):  # a slosh, and a vibration that aliases to 1 Hz
        shear = np.zeros((len(t), 2, 2))
        shear[:, :, 0] = 0.1 * np.sin(2 * np.pi * f_hz * t)[:, None]
        loads = FingerLoads(t, shear, np.zeros((len(t), 2)), np.array([5.0, 5.0]), np.zeros((2, 2)))
        centre = contact_geometry(loads, profile).center_px
        x = marker_positions(loads, profile, frames, rest_px=centre[:1])[0, :, 0, 0] - centre[0, 0]
        expected = profile.shear_compliance_px_per_n * 0.1 * np.sinc(f_hz * exposure_s)
        assert np.abs(x).max() == pytest.approx(abs(expected), rel=0.02)
    assert np.sinc((profile.fps - 1.0) * exposure_s) < 0.2  # vibration cut by 5x or more
    assert np.sinc(2.0 * exposure_s) > 0.98  # the slosh band barely changes


def test_two_sensors_move_in_opposite_horizontal_senses():
    profile = get_sensor_profile("default")
    loads = make_loads(duration_s=2.0, amplitude_n=0.1)
    t = np.linspace(0, 2.0, 61)
    pos = marker_positions(loads, profile, t)
    dx = pos[..., 0] - pos[:, :1, :, 0]  # x motion relative to frame 0
    moving = np.argmax(np.abs(dx[0]).max(axis=0))
    corr = np.corrcoef(dx[0, :, moving], dx[1, :, moving])[0, 1]
    assert corr < -0.999
    # y (weight) moves the same way on both
    np.testing.assert_allclose(pos[0, :, :, 1] - pos[0, 0, :, 1], pos[1, :, :, 1] - pos[1, 0, :, 1])


def test_displacement_field_is_gaussian_weighted_and_widens_with_preload():
    profile = get_sensor_profile("default")
    soft = make_loads(preload_n=2.0)
    hard = make_loads(preload_n=16.0)
    geom_soft, geom_hard = contact_geometry(soft, profile), contact_geometry(hard, profile)
    assert geom_hard.radius_px[0] == pytest.approx(2.0 * geom_soft.radius_px[0])  # (16/2)^(1/3)
    centre = geom_soft.center_px[0]
    distances = np.array([0.0, 50.0, 100.0, 200.0])
    rest = centre + np.stack([distances, np.zeros(4)], axis=1)
    for loads, geom in ((soft, geom_soft), (hard, geom_hard)):
        disp = marker_positions(loads, profile, np.array([0.0]), rest_px=rest)[0, 0] - rest
        expected = np.exp(-(distances**2) / (2 * geom.field_sigma_px[0] ** 2))
        np.testing.assert_allclose(disp[:, 0] / disp[0, 0], expected, rtol=1e-9)
    far_soft = marker_positions(soft, profile, np.array([0.0]), rest_px=rest)[0, 0, 3] - rest[3]
    far_hard = marker_positions(hard, profile, np.array([0.0]), rest_px=rest)[0, 0, 3] - rest[3]
    assert abs(far_hard[0]) > 2 * abs(far_soft[0])


def test_twist_rotates_markers_about_the_contact_centre():
    profile = instant("default")
    loads = make_loads(amplitude_n=0.0, weight_n=0.0, twist_nmm=5.0)
    geom = contact_geometry(loads, profile)
    radius = 60.0
    angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    weight = np.exp(-(radius**2) / (2 * geom.field_sigma_px[0] ** 2))
    theta = profile.twist_compliance_rad_per_nmm * 5.0
    for s in range(2):
        rest = geom.center_px[s] + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        disp = marker_positions(loads, profile, np.array([0.0]), rest_px=rest)[s, 0] - rest
        # tangential (clockwise on screen with y down), no radial motion to first order
        tangential = disp[:, 0] * -np.sin(angles) + disp[:, 1] * np.cos(angles)
        radial = disp[:, 0] * np.cos(angles) + disp[:, 1] * np.sin(angles)
        np.testing.assert_allclose(tangential, weight * radius * np.sin(theta), rtol=1e-9)
        np.testing.assert_allclose(radial, weight * radius * (np.cos(theta) - 1), atol=1e-9)


def test_rest_grid_pitch_and_blob_geometry():
    for name, profile in SENSOR_PROFILES.items():
        rest = marker_rest_positions(profile)
        pitch_px = profile.marker_pitch_mm / profile.mm_per_px
        xs = np.unique(np.round(rest[:, 0], 6))
        np.testing.assert_allclose(np.diff(xs), pitch_px)
        assert len(rest) >= 60, name
        area = np.pi * profile.marker_radius_px**2
        assert 50 <= area <= 150, name


# ---------------------------------------------------------------- timing


def test_timestamps_jitter_drops_and_rate():
    profile = get_sensor_profile("default")
    t, index = frame_timestamps(13.0, profile, np.random.default_rng(3))
    assert t[0] == 0.0 and np.all(np.diff(t) > 0) and t[-1] <= 13.0
    assert len(t) < len(index) + np.count_nonzero(np.diff(index) > 1) + 1  # consistent
    gaps = np.diff(index)
    assert 1 <= np.count_nonzero(gaps > 1) <= 20  # ~1 % of ~385 frames dropped
    nominal = index / (profile.fps * profile.rate_factor)
    jitter = t - nominal
    assert 0.5e-3 < jitter.std() < 3e-3
    mean_period = np.polyfit(index, t, 1)[0]
    assert mean_period == pytest.approx(1 / (profile.fps * profile.rate_factor), rel=2e-3)
    np.testing.assert_allclose(np.round(t * 90000), t * 90000, rtol=0, atol=1e-6)
    again, _ = frame_timestamps(13.0, profile, np.random.default_rng(3))
    np.testing.assert_array_equal(t, again)
    exact, exact_index = frame_timestamps(
        1.0, profile, np.random.default_rng(3), jitter=False, drops=False
    )
    np.testing.assert_allclose(exact, np.arange(31) / 30.0, atol=1e-5)
    np.testing.assert_array_equal(exact_index, np.arange(31))


@settings(max_examples=40, deadline=None)
@given(
    duration_s=st.floats(0.01, 30.0),
    seed=st.integers(0, 2**32 - 1),
    sensor=st.sampled_from(sorted(SENSOR_PROFILES)),
)
def test_timestamps_are_always_increasing_within_the_recording(duration_s, seed, sensor):
    profile = get_sensor_profile(sensor)
    t, index = frame_timestamps(duration_s, profile, np.random.default_rng(seed))
    assert t[0] == 0.0 and index[0] == 0
    assert np.all(np.diff(t) > 0) and np.all(np.diff(index) > 0)
    assert t[-1] <= duration_s + 0.5 / 90000
    np.testing.assert_allclose(np.round(t * 90000), t * 90000, rtol=0, atol=1e-6)
    # never further from the nominal clock than the clipped jitter
    nominal = index / (profile.fps * profile.rate_factor)
    assert np.all(np.abs(t - nominal) <= 0.3 / (profile.fps * profile.rate_factor) + 1e-5)


def test_bad_inputs_are_reported():
    with pytest.raises(CatalogueError, match="unknown sensor"):
        get_sensor_profile("gelsight-9000")
    profile = get_sensor_profile("mini")
    with pytest.raises(LiquidTouchError, match="duration"):
        frame_timestamps(0.0, profile, np.random.default_rng(0))
    with pytest.raises(LiquidTouchError, match="t_frames"):
        marker_positions(make_loads(), profile, np.array([0.0, np.nan]))
    rng = np.random.default_rng(0)
    with pytest.raises(LiquidTouchError, match="shape"):
        next(iter_frames(np.zeros((3, 4)), profile, rng))
    with pytest.raises(LiquidTouchError, match="NaN"):
        next(iter_frames(np.full((1, 2, 2), np.nan), profile, rng))
    with pytest.raises(LiquidTouchError, match="background"):
        next(iter_frames(np.zeros((1, 1, 2)) + 50, profile, rng, background=np.zeros((2, 2, 3))))
    with pytest.raises(LiquidTouchError, match="contact_offsets_px"):
        next(
            iter_frames(np.zeros((2, 1, 2)) + 50, profile, rng, contact_offsets_px=np.zeros((3, 2)))
        )
    with pytest.raises(CatalogueError):
        write_sensor_videos(make_loads(), Path("/nonexistent/never"), sensor="nope")


def test_unwritable_output_directory_is_reported(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    with pytest.raises(DatasetError, match="cannot create the trial directory"):
        write_sensor_videos(make_loads(duration_s=0.5), blocker / "trial", sensor="mini")


def test_encode_video_rejects_bad_timestamps_and_leaves_no_file(tmp_path):
    frame = np.zeros((240, 320, 3), np.uint8)
    with pytest.raises(LiquidTouchError, match="increasing"):
        encode_video(tmp_path / "a.mp4", [frame, frame], np.array([0.0, 0.0]), 25.0)
    with pytest.raises(LiquidTouchError, match="frames"):
        encode_video(tmp_path / "b.mp4", [frame], np.array([0.0, 0.04]), 25.0)
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------- images


@pytest.mark.parametrize("sensor", ["default", "mini"])
def test_rendered_marker_centroids_are_the_intended_subpixel_positions(sensor):
    profile = get_sensor_profile(sensor)
    rng = np.random.default_rng(7)
    rest = marker_rest_positions(profile)
    positions = rest[None] + rng.uniform(-1.5, 1.5, (3, *rest.shape))
    flat_bg = make_background(profile, rng, lighting=False)
    frames = render_frames(
        positions, profile, rng, background=flat_bg, noise=False, flicker=False
    ).astype(float)
    half = int(np.ceil(profile.marker_radius_px + 4 * profile.marker_edge_px))
    for frame, pos in zip(frames, positions, strict=True):
        inverted = flat_bg[..., 0] - frame.mean(axis=2)  # zero away from markers
        inner = np.all(
            (pos > half + 1) & (pos < [profile.width_px - half - 2, profile.height_px - half - 2]),
            axis=1,
        )
        err = darkness_centroids(inverted, pos[inner], half) - pos[inner]
        assert np.abs(err).max() < 0.05, np.abs(err).max()
        # blob area (pixels darker than half the contrast) is what trackers expect
        contrast = flat_bg[0, 0, 0] * (1 - profile.marker_transmittance)
        area = np.count_nonzero(inverted > contrast / 2) / len(pos)
        assert 50 <= area <= 150
    # with the uneven LED lighting on, the marker coverage still centres exactly
    lit_bg = make_background(profile, np.random.default_rng(1))
    lit = render_frames(positions[:1], profile, rng, background=lit_bg, noise=False, flicker=False)
    coverage = (lit_bg - lit[0]).sum(axis=2) / lit_bg.sum(axis=2)
    pos = positions[0]
    inner = np.all(
        (pos > half + 1) & (pos < [profile.width_px - half - 2, profile.height_px - half - 2]),
        axis=1,
    )
    err = darkness_centroids(coverage, pos[inner], half) - pos[inner]
    assert np.abs(err).max() < 0.05


def test_touching_markers_darken_multiplicatively():
    profile = get_sensor_profile("default")
    rng = np.random.default_rng(0)
    flat = make_background(profile, rng, lighting=False)
    a, b = np.array([[300.3, 200.6]]), np.array([[306.9, 203.2]])  # 7 px apart: patches overlap
    kwargs = dict(background=flat, noise=False, flicker=False, marker_variation=False)
    only_a = render_frames(a[None], profile, rng, **kwargs)[0].astype(float)
    only_b = render_frames(b[None], profile, rng, **kwargs)[0].astype(float)
    both = render_frames(np.concatenate([a, b])[None], profile, rng, **kwargs)[0].astype(float)
    np.testing.assert_allclose(both, only_a * only_b / flat, atol=1.6)  # three roundings
    assert both.min() < only_a.min() - 5  # the overlap is darker than either marker


def test_markers_are_dark_on_an_uneven_coloured_background():
    profile = get_sensor_profile("default")
    rng = np.random.default_rng(0)
    bg = make_background(profile, rng)
    per_channel = bg.reshape(-1, 3).mean(axis=0)
    assert per_channel.max() - per_channel.min() > 10  # coloured, not grey
    lum = bg.mean(axis=2)
    assert lum.max() / lum.min() > 1.5  # uneven LED lighting and vignetting
    rest = marker_rest_positions(profile)
    frame = render_frames(rest[None], profile, rng, background=bg)[0].astype(float)
    at_markers = frame[np.round(rest[:, 1]).astype(int), np.round(rest[:, 0]).astype(int)].mean(
        axis=1
    )
    beside = frame[np.round(rest[:, 1]).astype(int), np.round(rest[:, 0] + 20).astype(int)].mean(
        axis=1
    )
    assert np.all(at_markers < 0.45 * beside)


def test_imprint_moves_with_the_gel_and_noise_and_flicker_are_small():
    profile = get_sensor_profile("mini")
    rng = np.random.default_rng(0)
    bg = make_background(profile, rng, lighting=False)
    no_markers = np.zeros((2, 0, 2))
    centre = np.array([160.0, 120.0])
    frames = render_frames(
        no_markers,
        profile,
        rng,
        background=bg,
        contact_center_px=centre,
        contact_radius_px=60.0,
        contact_offsets_px=np.array([[0.0, 0.0], [4.0, 0.0]]),
        noise=False,
        flicker=False,
    ).astype(float)
    assert np.abs(frames[0] - bg).max() > 5  # the imprint is visible
    moved_back = frames[1][:, 4:]
    np.testing.assert_allclose(moved_back, frames[0][:, :-4], atol=1.01)
    # on the real (uneven) lighting, so that uint8 rounding does not hide the flicker
    lit = make_background(profile, rng)
    noisy = render_frames(np.zeros((20, 0, 2)), profile, rng, background=lit).astype(float)
    noise_std = (noisy - noisy.mean(axis=0)).std()
    assert 0.5 * profile.noise_std < noise_std < 2 * profile.noise_std
    brightness = noisy.mean(axis=(1, 2, 3))
    assert (
        0.2 * profile.flicker_std < brightness.std() / brightness.mean() < 5 * profile.flicker_std
    )


# ---------------------------------------------------------------- video files


def test_videos_decode_with_timestamps_size_and_opposite_motion(tmp_path):
    loads = make_loads(duration_s=3.0, amplitude_n=0.4)
    rec = write_sensor_videos(loads, tmp_path, sensor="mini", seed=5)
    profile = get_sensor_profile("mini")
    assert rec.files == ["left.mp4", "right.mp4"]
    assert rec.fps == 25.0 and rec.n_frames == len(rec.timestamps_s)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "left.mp4",
        "right.mp4",
        "truth_tracks.npz",
    ]
    truth = np.load(tmp_path / "truth_tracks.npz", allow_pickle=False)
    np.testing.assert_array_equal(truth["timestamps_s"], rec.timestamps_s)
    n_markers = len(truth["marker_ids"])
    assert truth["positions_px"].shape == (2, rec.n_frames, n_markers, 2)
    assert list(truth["sensors"]) == ["left", "right"]
    assert np.any(np.diff(rec.frame_index) > 1) or np.std(np.diff(rec.timestamps_s)) > 1e-4

    measured = []
    for s, name in enumerate(rec.files):
        frames, times, rate = decode(tmp_path / name)
        assert frames.shape == (rec.n_frames, profile.height_px, profile.width_px, 3)
        np.testing.assert_allclose(times, rec.timestamps_s, atol=1.5 / 90000)
        assert rate == pytest.approx((rec.n_frames - 1) / rec.timestamps_s[-1], rel=0.02)
        # centroids of the decoded markers follow the ground truth through the codec
        pos = truth["positions_px"][s].astype(float)
        near = np.argsort(np.linalg.norm(pos[0] - truth["contact_center_px"][s], axis=1))[:6]
        cents = np.stack(
            [
                darkness_centroids(255.0 - f.mean(axis=2), p[near], 10, local_baseline=True)
                for f, p in zip(frames, pos, strict=True)
            ]
        )
        err = cents - pos[:, near]
        err -= err.mean(axis=0)  # windowed centroids carry a constant background bias
        assert np.abs(err).max() < 0.35
        assert np.sqrt((err**2).mean()) < 0.1
        measured.append(cents[:, :, 0].mean(axis=1))
    dx_left, dx_right = (m - m.mean() for m in measured)
    assert np.corrcoef(dx_left, dx_right)[0, 1] < -0.95


def test_recording_is_reproducible_and_seed_dependent(tmp_path):
    loads = make_loads(duration_s=1.0)
    a = write_sensor_videos(loads, tmp_path / "a", sensor="mini", seed=1)
    b = write_sensor_videos(loads, tmp_path / "b", sensor="mini", seed=1)
    c = write_sensor_videos(loads, tmp_path / "c", sensor="mini", seed=2, jitter=False)
    np.testing.assert_array_equal(a.timestamps_s, b.timestamps_s)
    ta, tb = (np.load(r.out_dir / "truth_tracks.npz") for r in (a, b))
    np.testing.assert_array_equal(ta["positions_px"], tb["positions_px"])
    fa, _, _ = decode(a.out_dir / "left.mp4")
    fb, _, _ = decode(b.out_dir / "left.mp4")
    np.testing.assert_array_equal(fa, fb)
    np.testing.assert_allclose(c.timestamps_s, np.arange(c.n_frames) / 25.0, atol=1e-5)


REAL_MINI = SHARED / "data" / "real" / "gelsight_mini_press.avi"


@pytest.mark.skipif(not REAL_MINI.exists(), reason="../shared/data/real not available")
def test_mini_lighting_matches_the_real_gelsight_mini():
    import cv2

    with av.open(str(REAL_MINI)) as container:
        decoded = container.decode(video=0)
        frames = [next(decoded).to_ndarray(format="rgb24") for _ in range(20)]
    still = np.median(np.stack(frames), axis=0).astype(np.float32)
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (17, 17))
    real_bg = cv2.morphologyEx(still, cv2.MORPH_CLOSE, disk)  # markers removed

    def regions(img: np.ndarray) -> np.ndarray:  # mean colour of a 3 x 3 grid of regions
        h, w = img.shape[:2]
        return np.array(
            [
                img[i * h // 3 : (i + 1) * h // 3, j * w // 3 : (j + 1) * w // 3].mean(axis=(0, 1))
                for i in range(3)
                for j in range(3)
            ]
        )

    real = regions(real_bg)
    for seed in range(3):
        ours = regions(make_background("mini", np.random.default_rng(seed)))
        assert np.sqrt(((ours - real) ** 2).mean()) < 12.0  # grey levels
    flat = regions(np.full_like(real_bg, real_bg.mean()))
    assert np.sqrt(((flat - real) ** 2).mean()) > 25.0  # the test can tell lighting apart


@pytest.mark.parametrize("sensor", ["default", "mini"])
def test_a_simple_blob_detector_finds_every_marker(tmp_path, sensor):
    """What marker trackers need: dark round blobs of 50-150 px, one per marker, after H.264."""
    import cv2

    rec = write_sensor_videos(make_loads(duration_s=0.3), tmp_path, sensor=sensor, seed=11)
    truth = np.load(tmp_path / "truth_tracks.npz", allow_pickle=False)
    frames, _, _ = decode(tmp_path / rec.files[1])
    gray = cv2.cvtColor(frames[-1], cv2.COLOR_RGB2GRAY)
    local = cv2.GaussianBlur(gray.astype(np.float32), (0, 0), 12)
    dark = (gray.astype(np.float32) < 0.6 * local).astype(np.uint8)
    _, _, stats, centroids = cv2.connectedComponentsWithStats(dark)
    areas = stats[1:, cv2.CC_STAT_AREA]
    blobs = centroids[1:][areas >= 20]
    expected = truth["positions_px"][1, -1]
    assert len(blobs) == len(expected)
    assert np.all((areas[areas >= 20] >= 50) & (areas[areas >= 20] <= 150))
    nearest = np.linalg.norm(blobs[:, None, :] - expected[None], axis=2).min(axis=0)
    assert nearest.max() < 0.5  # px, thresholded blobs: coarse but unambiguous
