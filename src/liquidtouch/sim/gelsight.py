"""Simulated GelSight sensors: marker motion from finger loads, video files.

Frame timing is :mod:`liquidtouch.sim.camera_timing` (``frame_timestamps``, used here).

The gel under the container is sheared by the tangential force and twisted by the
moment about its normal. Markers move with a Gaussian-weighted displacement field
centred on the contact:

    d(p) = w(p) · [ c_s · F_img  +  (R(c_t · M) − I)(p − p_c) ],   w(p) = exp(−|p − p_c|² / 2σ²)

with ``c_s`` the shear compliance [px/N], ``c_t`` the twist compliance [rad/(N·mm)],
``p_c`` the contact centre and ``σ`` growing with the grasp preload (Hertz:
contact radius ∝ F_n^(1/3)).

Image conventions (pixels, x right, y down): the ``left`` sensor (finger 0) sees
world x as image +x, the ``right`` sensor (finger 1) sees world x as image −x (its
camera faces the other way), and world y (up) is image −y for both. So the same
world shear moves the two sensors' markers in opposite horizontal senses. A
positive twist moment (counter-clockwise seen from the container) appears as a
clockwise rotation in each sensor's image, since the camera looks at the gel
from behind.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from liquidtouch._core.atomic import atomic_path
from liquidtouch.errors import DatasetError, LiquidTouchError
from liquidtouch.io.dataset import TRUTH_TRACKS_NAME
from liquidtouch.sim.camera_timing import frame_timestamps
from liquidtouch.sim.encode import X264_PARAMS, encode_video
from liquidtouch.sim.loads import FingerLoads
from liquidtouch.sim.nuisances import brightness_gains, camera_times, gel_response, marker_ink
from liquidtouch.sim.realism import CAMERA_NUISANCES, Realism
from liquidtouch.sim.render import iter_frames, make_background
from liquidtouch.sim.sensors import SensorProfile, get_sensor_profile

__all__ = [
    "IMAGE_X_SIGN",
    "SENSOR_NAMES",
    "ContactGeometry",
    "SensorRecording",
    "SensorScene",
    "contact_geometry",
    "contact_offsets",
    "gel_displacement",
    "gel_loads_px",
    "marker_positions",
    "marker_rest_positions",
    "sensor_scene",
    "write_sensor_videos",
]

SENSOR_NAMES = ("left", "right")
IMAGE_X_SIGN = np.array([1.0, -1.0])
"""Image-x sign of world x for (left, right): the two cameras are mirrored."""


@dataclass(frozen=True)
class ContactGeometry:
    """Where and how large the contact is on each sensor's image (rest state).

    Attributes
    ----------
    center_px : (2, 2) contact centre per sensor, image (x, y) [px].
    radius_px : (2,) contact (imprint) radius per sensor [px].
    field_sigma_px : (2,) Gaussian width of the displacement field per sensor [px].
    """

    center_px: np.ndarray
    radius_px: np.ndarray
    field_sigma_px: np.ndarray


@dataclass(frozen=True)
class SensorRecording:
    """What :func:`write_sensor_videos` wrote.

    Attributes
    ----------
    out_dir : directory holding the files.
    files : video file names, ``["left.mp4", "right.mp4"]`` (finger 0, finger 1).
    truth_file : name of the ground-truth marker tracks (``truth_tracks.npz``).
    sensor : sensor profile name.
    fps : nominal frame rate [Hz]; the real one is a little lower (see ``timestamps_s``).
    n_frames : frames per video (after dropped frames).
    timestamps_s : (n_frames,) presentation time of each frame [s], shared by both videos.
    frame_index : (n_frames,) index of each frame on the nominal clock (gaps = dropped frames).
    width_px, height_px : frame size.
    drawn : what the camera and gel nuisances drew (empty in the clean world).
    """

    out_dir: Path
    files: list[str]
    truth_file: str
    sensor: str
    fps: float
    n_frames: int
    timestamps_s: np.ndarray
    frame_index: np.ndarray
    width_px: int
    height_px: int
    drawn: dict[str, Any] = field(default_factory=dict)


def marker_rest_positions(
    profile: SensorProfile | str, rng: np.random.Generator | None = None
) -> np.ndarray:
    """Rest positions of the markers in view, (N, 2) image (x, y) [px], row-major order.

    The grid spans the gel (``gel_size_mm``) at ``marker_pitch_mm`` centred on the
    image; markers whose centre lies closer than radius + 2 px to the border are
    left out. With ``rng``, each marker gets a small printing irregularity.
    """
    profile = get_sensor_profile(profile)
    pitch_px = profile.marker_pitch_mm / profile.mm_per_px
    half_counts = [
        int(np.floor(size / 2 / profile.marker_pitch_mm)) for size in profile.gel_size_mm
    ]
    kx = np.arange(-half_counts[0], half_counts[0] + 1)
    ky = np.arange(-half_counts[1], half_counts[1] + 1)
    gy, gx = np.meshgrid(ky, kx, indexing="ij")
    cx, cy = (profile.width_px - 1) / 2, (profile.height_px - 1) / 2
    pos = np.stack([cx + gx.ravel() * pitch_px, cy + gy.ravel() * pitch_px], axis=1)
    margin = profile.marker_radius_px + 2.0
    inside = (
        (pos[:, 0] >= margin)
        & (pos[:, 0] <= profile.width_px - 1 - margin)
        & (pos[:, 1] >= margin)
        & (pos[:, 1] <= profile.height_px - 1 - margin)
    )
    pos = pos[inside]
    if rng is not None and profile.marker_rest_jitter_px > 0:
        pos = pos + rng.normal(0.0, profile.marker_rest_jitter_px, pos.shape)
    return pos


def contact_geometry(loads: FingerLoads, profile: SensorProfile | str) -> ContactGeometry:
    """Contact centre, imprint radius and displacement-field width on each sensor image."""
    profile = get_sensor_profile(profile)
    center_mm = np.asarray(loads.contact_center_mm, dtype=float)
    cx, cy = (profile.width_px - 1) / 2, (profile.height_px - 1) / 2
    center_px = np.stack(
        [
            cx + IMAGE_X_SIGN * center_mm[:, 0] / profile.mm_per_px,
            cy - center_mm[:, 1] / profile.mm_per_px,
        ],
        axis=1,
    )
    preload = np.clip(np.asarray(loads.normal_force_n, dtype=float), 0.05, None)
    radius_mm = profile.contact_radius_mm_ref * np.cbrt(preload / profile.preload_ref_n)
    radius_px = radius_mm / profile.mm_per_px
    return ContactGeometry(center_px, radius_px, radius_px * profile.field_spread)


def _loads_at(
    loads: FingerLoads, profile: SensorProfile, t_frames: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Shear (T, 2, 2) [N] and twist (T, 2) [N·mm] seen by the frames at ``t_frames`` [s].

    The camera integrates light over its exposure (``profile.exposure_fraction``
    of the frame period) centred on each frame time, so a frame sees the mean
    load over that window (the integral of the linearly interpolated loads, exact
    on their grid); an exposure of 0 samples the loads instantly.
    """
    exposure_s = profile.exposure_fraction / profile.fps
    t = np.asarray(loads.t_s, dtype=float)
    channels = np.column_stack(
        [
            np.asarray(loads.shear_force_n, dtype=float).reshape(len(t), 4),
            np.asarray(loads.twist_moment_nmm, dtype=float),
        ]
    )  # (n, 6)
    if exposure_s > 0:
        frames = np.clip(t_frames, t[0], t[-1])
        start = np.maximum(frames - 0.5 * exposure_s, t[0])
        end = np.minimum(frames + 0.5 * exposure_s, t[-1])  # never empty: frames are inside
        steps = 0.5 * np.diff(t)[:, None] * (channels[1:] + channels[:-1])
        area = np.concatenate([np.zeros((1, 6)), np.cumsum(steps, axis=0)])
        at = (
            np.stack([np.interp(end, t, a) - np.interp(start, t, a) for a in area.T], axis=1)
            / (end - start)[:, None]
        )
    else:
        at = np.stack([np.interp(t_frames, t, c) for c in channels.T], axis=1)
    return at[:, :4].reshape(-1, 2, 2), at[:, 4:]


def marker_positions(
    loads: FingerLoads,
    profile: SensorProfile | str,
    t_frames: np.ndarray,
    *,
    rest_px: np.ndarray | None = None,
) -> np.ndarray:
    """Marker positions of both sensors at the frame times, (2, T, N, 2) image (x, y) [px].

    Axis 0 is the sensor (left, right); ``rest_px`` (N, 2) defaults to the regular
    grid of :func:`marker_rest_positions`. Loads are averaged over each frame's
    exposure (``profile.exposure_fraction`` of the frame period) centred on
    ``t_frames`` [s] (the loads' time axis starts at 0).
    """
    profile = get_sensor_profile(profile)
    t_frames = np.asarray(t_frames, dtype=float)
    if t_frames.ndim != 1 or not np.all(np.isfinite(t_frames)):
        raise LiquidTouchError("t_frames must be a 1-D array of finite times in seconds")
    rest = marker_rest_positions(profile) if rest_px is None else np.asarray(rest_px, float)
    shear, twist = _loads_at(loads, profile, t_frames)
    shear_px = _shear_px(profile, shear)  # (2, T, 2)
    geom = contact_geometry(loads, profile)
    out = np.empty((2, len(t_frames), len(rest), 2))
    for s in range(2):
        rel = rest - geom.center_px[s]  # (N, 2)
        angle = profile.twist_compliance_rad_per_nmm * twist[:, s]  # (T,), clockwise on screen
        out[s] = rest[None] + gel_displacement(rel, geom.field_sigma_px[s], shear_px[s], angle)
    return out


def gel_loads_px(
    loads: FingerLoads, profile: SensorProfile | str, t_frames: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each gel's shear at its contact centre (2, T, 2) [px] and twist (2, T) [rad, clockwise
    on screen] as the frames at ``t_frames`` [s] see them (the argument of
    :func:`gel_displacement`)."""
    profile = get_sensor_profile(profile)
    shear, twist = _loads_at(loads, profile, np.asarray(t_frames, dtype=float))
    return _shear_px(profile, shear), profile.twist_compliance_rad_per_nmm * twist.T


def gel_displacement(
    rel_px: np.ndarray, sigma_px: float, shear_px: np.ndarray, angle_rad: np.ndarray
) -> np.ndarray:
    """The gel's displacement (T, N, 2) [px] at points ``rel_px`` (N, 2) from the contact centre.

    ``shear_px`` (T, 2) is the shear at the centre [px], ``angle_rad`` (T,) the twist
    (clockwise on screen), ``sigma_px`` the Gaussian width of the field (module docstring).
    """
    weight = np.exp(-np.sum(rel_px**2, axis=1) / (2 * sigma_px**2))
    cos_m1, sin = np.cos(angle_rad) - 1.0, np.sin(angle_rad)
    twist_dx = cos_m1[:, None] * rel_px[None, :, 0] - sin[:, None] * rel_px[None, :, 1]
    twist_dy = sin[:, None] * rel_px[None, :, 0] + cos_m1[:, None] * rel_px[None, :, 1]
    disp = shear_px[:, None, :] + np.stack([twist_dx, twist_dy], axis=2)
    return weight[None, :, None] * disp


def contact_offsets(
    loads: FingerLoads, profile: SensorProfile | str, t_frames: np.ndarray
) -> np.ndarray:
    """Displacement of each contact centre (where the imprint moves), (2, T, 2) [px]."""
    profile = get_sensor_profile(profile)
    shear, _ = _loads_at(loads, profile, np.asarray(t_frames, dtype=float))  # as the markers
    return _shear_px(profile, shear)


def _shear_px(profile: SensorProfile, shear_n: np.ndarray) -> np.ndarray:
    """Image displacement (2, T, 2) [px] of each sensor's gel under shear (T, 2, 2) [N]."""
    image_x = IMAGE_X_SIGN[None, :] * shear_n[:, :, 0]  # the two cameras are mirrored
    image_y = -shear_n[:, :, 1]  # world up is image −y
    return profile.shear_compliance_px_per_n * np.stack([image_x, image_y], axis=2).swapaxes(0, 1)


@dataclass(frozen=True)
class SensorScene:
    """What both sensors see over a recording: frame times and marker positions [px].

    ``timestamps_s`` (T,) from the first frame, ``frame_index`` (T,) nominal frame
    numbers (drops skip some), ``geometry`` the contact, ``offsets_px`` (2, T, 2)
    the contact imprint's offset, ``rest_px`` (2, N, 2) and ``positions_px``
    (2, T, N, 2) the markers at rest and per frame. With camera nuisances
    (:mod:`liquidtouch.sim.realism`) ``timestamps_s`` are the recorded (host)
    times and ``exposure_s`` the times the frames were exposed at (else ``None``:
    the same); ``drawn`` what the nuisances drew.
    """

    timestamps_s: np.ndarray
    frame_index: np.ndarray
    geometry: ContactGeometry
    offsets_px: np.ndarray
    rest_px: np.ndarray
    positions_px: np.ndarray
    exposure_s: np.ndarray | None = None
    drawn: dict[str, Any] = field(default_factory=dict)
    shear_px: np.ndarray | None = None
    twist_rad: np.ndarray | None = None

    def displacement(self, s: int) -> Callable[[int, np.ndarray], np.ndarray]:
        """Sensor ``s``'s gel displacement ``(frame, rel_px (N, 2)) → (N, 2)`` [px] (points
        relative to the contact centre): what moves a plain gel's imprint."""
        sigma = float(self.geometry.field_sigma_px[s])

        def at(frame: int, rel_px: np.ndarray) -> np.ndarray:
            shear = self.shear_px[s, frame : frame + 1]
            return gel_displacement(rel_px, sigma, shear, self.twist_rad[s, frame : frame + 1])[0]

        return at


def sensor_scene(
    loads: FingerLoads,
    profile: SensorProfile,
    rng: np.random.Generator,
    *,
    jitter: bool = True,
    realism: Realism | None = None,
    seed: int = 0,
) -> SensorScene:
    """Frame times (jittered, with drops, unless ``jitter`` is False) and marker motion.

    ``realism`` adds the camera's and the gel's nuisances
    (:mod:`liquidtouch.sim.nuisances`), drawn from ``seed``'s nuisance streams;
    the clean draws from ``rng`` are made all the same, so the rest of the scene
    (marker grid, noise) is that of the clean world.
    """
    timestamps, frame_index = frame_timestamps(
        loads.duration_s, profile, rng, jitter=jitter, drops=jitter
    )
    exposure, drawn = None, {}
    world = Realism.clean() if realism is None else realism
    if jitter and any(world.active(name) for name in CAMERA_NUISANCES):
        timestamps, exposure, frame_index, drawn = camera_times(
            loads.duration_s, profile, world, seed
        )
    if world.active("gel_creep") or world.active("gel_hysteresis"):
        loads = gel_response(loads, world)
    t_frames = (timestamps if exposure is None else exposure) + float(loads.t_s[0])
    rests = np.stack([marker_rest_positions(profile, rng) for _ in range(2)])
    positions = np.stack(
        [marker_positions(loads, profile, t_frames, rest_px=rests[s])[s] for s in range(2)]
    )
    shear_px, twist_rad = gel_loads_px(loads, profile, t_frames)
    return SensorScene(
        timestamps,
        frame_index,
        contact_geometry(loads, profile),
        contact_offsets(loads, profile, t_frames),
        rests,
        positions,
        exposure,
        drawn,
        shear_px=shear_px,
        twist_rad=twist_rad,
    )


def write_sensor_videos(
    loads: FingerLoads,
    out_dir: Path,
    *,
    sensor: str = "default",
    seed: int = 0,
    jitter: bool = True,
    noise: bool = True,
    x264_params: str = X264_PARAMS,
    realism: Realism | None = None,
) -> SensorRecording:
    """Render both sensors' videos for ``loads`` into ``out_dir``.

    Writes ``left.mp4`` and ``right.mp4`` (H.264, per-frame timestamps as PTS in a
    1/90000 s time base) and ``truth_tracks.npz`` (plain arrays, load with
    ``allow_pickle=False``): ``timestamps_s`` (T,), ``frame_index`` (T,),
    ``positions_px`` (2, T, N, 2) sensor × frame × marker × (x, y),
    ``rest_positions_px`` (2, N, 2), ``marker_ids`` (N,), ``sensors`` (2,),
    ``contact_center_px`` (2, 2), ``contact_radius_px`` (2,), ``contact_offset_px``
    (2, T, 2), ``mm_per_px``, ``fps_nominal``, ``profile``.
    All files are written atomically. ``jitter`` False gives exact nominal
    timestamps without drops; ``noise`` False renders clean frames.
    ``x264_params`` overrides the encoder options (default
    :data:`liquidtouch.sim.encode.X264_PARAMS`; ``""`` gives x264's lossy defaults).
    A plain gel (the profile's ``gel``, :mod:`liquidtouch.sim.sensors`) shows no markers:
    its imprint, with the face's texture, moves with the gel's displacement field; the
    truth tracks are still those of the markers it would have.
    ``realism`` adds the bench's camera, gel and image nuisances
    (:mod:`liquidtouch.sim.realism`; default: none). With camera nuisances the
    videos' timestamps are the recorded (host) times and ``truth_tracks.npz``
    also holds ``exposure_times_s`` (T,), when the frames were exposed.
    """

    profile = get_sensor_profile(sensor)
    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DatasetError(
            f"cannot create the trial directory {out_dir}: {exc.strerror or exc}; "
            "choose a writable directory path"
        ) from None
    world = Realism.clean() if realism is None else realism
    scene = sensor_scene(
        loads, profile, np.random.default_rng(seed), jitter=jitter, realism=world, seed=seed
    )
    image_kwargs: list[dict[str, Any]] = [{}, {}]
    for s in range(2):
        if world.active("exposure_drift"):
            image_kwargs[s]["gains"] = brightness_gains(scene.timestamps_s, world, seed, s)
        if world.active("marker_wear"):
            image_kwargs[s]["marker_ink"] = marker_ink(scene.rest_px.shape[1], world, seed, s)
        if world.active("pixel_noise"):
            image_kwargs[s]["noise_rgb"] = world.pixel_noise_rgb
            image_kwargs[s]["noise_corr_px"] = world.pixel_noise_corr_px
    timestamps, frame_index, geom = scene.timestamps_s, scene.frame_index, scene.geometry
    offsets, rests, positions = scene.offsets_px, scene.rest_px, scene.positions_px
    files = [f"{name}.mp4" for name in SENSOR_NAMES]

    def render_and_encode(s: int) -> None:
        sensor_rng = np.random.default_rng([seed, s + 1])
        background = make_background(profile, sensor_rng)
        plain = {}
        if profile.gel == "plain":  # no markers: the imprint moves with the gel's field
            plain = {"imprint_motion": scene.displacement(s)}
            image_kwargs[s].pop("marker_ink", None)
        frames = iter_frames(
            positions[s][:, :0] if plain else positions[s],
            profile,
            sensor_rng,
            background=background,
            contact_center_px=geom.center_px[s],
            contact_radius_px=float(geom.radius_px[s]),
            contact_offsets_px=offsets[s],
            noise=noise,
            **plain,
            **image_kwargs[s],
        )
        encode_video(
            out_dir / files[s],
            frames,
            timestamps,
            profile.fps,
            x264_params=x264_params,
        )

    # the two sensors are independent (own random streams, own files): render and encode
    # them on two threads (OpenCV, NumPy's large operations and x264 release the GIL)
    with ThreadPoolExecutor(max_workers=len(files)) as pool:
        for done in [pool.submit(render_and_encode, s) for s in range(len(files))]:
            done.result()
    more = {} if scene.exposure_s is None else {"exposure_times_s": scene.exposure_s}
    with atomic_path(out_dir / TRUTH_TRACKS_NAME) as tmp, open(tmp, "wb") as fh:
        np.savez(
            fh,
            **more,
            timestamps_s=timestamps,
            frame_index=frame_index,
            positions_px=positions.astype(np.float32),
            rest_positions_px=rests,
            marker_ids=np.arange(rests.shape[1]),
            sensors=np.array(SENSOR_NAMES),
            contact_center_px=geom.center_px,
            contact_radius_px=geom.radius_px,
            contact_offset_px=offsets,
            mm_per_px=np.float64(profile.mm_per_px),
            fps_nominal=np.float64(profile.fps),
            profile=np.array(profile.name),
        )
    return SensorRecording(
        out_dir=out_dir,
        files=files,
        truth_file=TRUTH_TRACKS_NAME,
        sensor=profile.name,
        fps=profile.fps,
        n_frames=len(timestamps),
        timestamps_s=timestamps,
        frame_index=frame_index,
        width_px=profile.width_px,
        height_px=profile.height_px,
        drawn=scene.drawn,
    )
