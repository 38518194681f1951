"""GelSight sensor profiles: image geometry, marker grid, gel compliance, lighting, timing.

Two profiles ship:

- ``"default"``: 640 × 480 px at 30 fps seeing a 20 × 15 mm field of view of a
  20 × 20 mm gel, i.e. 0.03125 mm/px (32 px/mm). Markers at 1.8 mm pitch
  (57.6 px), radius 5.5 px (blob area ≈ 95 px): an 11 × 9 grid in view.
- ``"mini"``: a GelSight Mini, 320 × 240 px at 25 fps over 19.2 × 14.4 mm,
  i.e. 0.06 mm/px; markers at 1.8 mm pitch (30 px), radius 5.9 px (area ≈ 110 px,
  as in the real Mini recording described in ``docs/real_data.md``).

- ``"digit"``: a DIGIT (Lambeta et al. 2020), 320 × 240 px at 60 fps over its
  19 × 14 mm field of view (0.06 mm/px), lit by red, green and blue LEDs from three
  sides; its gel has no markers (``gel="plain"``).

Compliances are chosen inside the realistic range 3–40 px/N, so that a 0.1 N
slosh force moves the markers at the contact centre by ~0.5–1.2 px.

**Gels** (:data:`GELS`): ``markers`` (printed dots) or ``plain`` (none: only the contact's
imprint, its edge, shading and the face's fine texture, moves with the gel). Every
profile also exists with the other gel, named ``<profile>-<gel>`` (``mini-plain``,
``digit-markers``): :func:`with_gel` gives the name, so that a gel is chosen wherever
a profile name is passed on.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from liquidtouch.errors import CatalogueError


@dataclass(frozen=True)
class LedLobe:
    """One coloured LED's contribution to the gel's illumination.

    Attributes
    ----------
    center : (x, y) in units of the image width/height (0..1; may lie outside).
    rgb : colour added at the lobe's peak, 0..255 levels.
    width : Gaussian width of the lobe in units of the image diagonal.
    """

    center: tuple[float, float]
    rgb: tuple[float, float, float]
    width: float


@dataclass(frozen=True)
class SensorProfile:
    """Everything the renderer needs to know about one GelSight sensor model."""

    name: str
    width_px: int
    height_px: int
    fps: float
    mm_per_px: float
    marker_pitch_mm: float = 1.8
    gel_size_mm: tuple[float, float] = (20.0, 20.0)
    marker_radius_px: float = 5.5
    marker_edge_px: float = 0.8
    """Standard deviation of the marker's blurred edge [px] (soft, anti-aliased)."""
    marker_transmittance: float = 0.22
    """Fraction of the light a marker's ink lets through at its centre."""
    marker_rest_jitter_px: float = 0.25
    """Printing irregularity of the marker grid [px]."""
    marker_radius_jitter: float = 0.04
    """Relative spread of the markers' radii (printing), clipped to ±10 %."""
    marker_ink_jitter: float = 0.03
    """Spread of the markers' transmittance (ink density)."""
    shear_compliance_px_per_n: float = 10.0
    twist_compliance_rad_per_nmm: float = 0.004
    contact_radius_mm_ref: float = 4.0
    """Contact (imprint) radius at the reference preload; scales with preload^(1/3) (Hertz)."""
    preload_ref_n: float = 5.0
    field_spread: float = 1.3
    """Gaussian width of the displacement field in units of the contact radius."""
    base_rgb: tuple[float, float, float] = (40.0, 62.0, 78.0)
    leds: tuple[LedLobe, ...] = field(default_factory=tuple)
    vignette: float = 0.35
    """Relative darkening at the image corners."""
    noise_std: float = 1.2
    """Sensor noise [grey levels, per channel]."""
    flicker_std: float = 0.003
    """Relative frame-to-frame brightness flicker of the LEDs."""
    jitter_std_s: float = 0.0015
    """Standard deviation of the frame timestamps' jitter [s]."""
    drop_probability: float = 0.01
    """Probability that a frame is dropped."""
    rate_factor: float = 0.985
    """Real frame rate / nominal (real sensors run a little slow)."""
    exposure_fraction: float = 0.9
    """Exposure time / frame period. Each frame shows the marker motion averaged over
    its exposure (motion blur), so arm vibration near a multiple of the frame rate
    is attenuated before it aliases into the slosh band, as in a real camera."""
    gel: str = "markers"
    """``markers`` (printed dots) or ``plain`` (markerless: the imprint's texture moves)."""
    face_texture: float = 0.04
    """Relative std of the container face's fine texture in the imprint of a plain gel:
    a printed or embossed label pressed on a gel shows ~4 % (a grey-level std of ~7 on a
    background of ~170)."""
    face_texture_mm: float = 0.1
    """Correlation length of that texture [mm] (Gaussian-smoothed noise): a label's
    print and embossing grain, 1.7 px on a Mini, so that the pixels sample it finely."""


# LED lobes fitted (non-negative least squares, vignetting included) to the
# marker-free background of the real GelSight Mini recording in
# docs/real_data.md (gsrobotics mini_example.avi): teal top, magenta centre,
# warm bottom. Residual 5.5 grey levels rms against a background std of 32.
_FITTED_BASE_RGB = (0.0, 38.9, 19.7)
_FITTED_LEDS = tuple(
    LedLobe(center=c, rgb=rgb, width=0.22)
    for c, rgb in (
        ((0.5, 0.55), (76.3, 35.8, 55.8)),
        ((0.3, 0.5), (4.2, 0.0, 36.4)),
        ((0.7, 0.5), (0.0, 25.9, 36.1)),
        ((0.5, 1.1), (0.0, 26.4, 0.0)),
        ((0.5, -0.1), (0.0, 30.9, 48.5)),
        ((-0.1, 0.5), (27.4, 21.8, 38.8)),
        ((1.1, 0.5), (26.3, 0.0, 36.7)),
        ((0.0, 0.0), (0.0, 34.9, 41.1)),
        ((1.0, 0.0), (0.0, 26.6, 44.2)),
        ((0.0, 1.0), (26.2, 36.8, 26.1)),
        ((1.0, 1.0), (27.5, 32.1, 27.5)),
        ((0.5, 0.9), (55.3, 0.0, 0.0)),
    )
)

SENSOR_PROFILES: dict[str, SensorProfile] = {
    "default": SensorProfile(
        name="default",
        width_px=640,
        height_px=480,
        fps=30.0,
        mm_per_px=0.03125,
        marker_radius_px=5.5,
        shear_compliance_px_per_n=12.0,
        twist_compliance_rad_per_nmm=0.004,
        base_rgb=_FITTED_BASE_RGB,
        leds=_FITTED_LEDS,
    ),
    "mini": SensorProfile(
        name="mini",
        width_px=320,
        height_px=240,
        fps=25.0,
        mm_per_px=0.06,
        marker_radius_px=5.9,
        marker_edge_px=1.0,
        shear_compliance_px_per_n=6.0,
        twist_compliance_rad_per_nmm=0.004,
        base_rgb=_FITTED_BASE_RGB,
        leds=_FITTED_LEDS,
        noise_std=1.0,
    ),
}


# DIGIT's three LEDs (red, green, blue) shine from three sides of the gel (Lambeta et al.
# 2020); their strengths put the image in the same grey range as the Mini's fitted light.
_DIGIT_LEDS = (
    LedLobe(center=(0.5, -0.15), rgb=(110.0, 10.0, 10.0), width=0.35),
    LedLobe(center=(-0.15, 0.9), rgb=(10.0, 110.0, 10.0), width=0.35),
    LedLobe(center=(1.15, 0.9), rgb=(10.0, 10.0, 110.0), width=0.35),
)
SENSOR_PROFILES["digit"] = replace(  # the Mini's gel geometry and optics, DIGIT's clock and light
    SENSOR_PROFILES["mini"],
    name="digit",
    fps=60.0,
    base_rgb=(40.0, 40.0, 40.0),
    leds=_DIGIT_LEDS,
    gel="plain",
)

#: the simulated gels: printed markers, or none (the imprint's own texture moves)
GELS = ("markers", "plain")
for _name, _profile in list(SENSOR_PROFILES.items()):
    for _gel in GELS:
        if _gel != _profile.gel:
            SENSOR_PROFILES[f"{_name}-{_gel}"] = replace(_profile, name=f"{_name}-{_gel}", gel=_gel)


def with_gel(sensor: str, gel: str | None) -> str:
    """The name of profile ``sensor`` with ``gel`` (``None``: the profile's own gel)."""
    profile = get_sensor_profile(sensor)
    if gel is None or gel == profile.gel:
        return profile.name
    if gel not in GELS:
        raise CatalogueError(f"unknown gel {gel!r}; choose one of: {', '.join(GELS)}")
    base = profile.name.removesuffix(f"-{profile.gel}")
    return base if get_sensor_profile(base).gel == gel else f"{base}-{gel}"


def get_sensor_profile(sensor: str | SensorProfile) -> SensorProfile:
    """Return the profile called ``sensor`` (or ``sensor`` itself if already a profile)."""
    if isinstance(sensor, SensorProfile):
        return sensor
    try:
        return SENSOR_PROFILES[sensor]
    except KeyError:
        known = ", ".join(sorted(SENSOR_PROFILES))
        raise CatalogueError(f"unknown sensor {sensor!r}; choose one of: {known}") from None
