"""Container catalogue: inner geometry, wall factor and mass of each container.

The paper's containers are held lying on their side by the two fingers, which
press on their two large side faces; pushed along world ``x`` the liquid sloshes
along the container's length ``length_mm``, pushed along the grasp axis (world
``y``) across ``width_mm`` (:meth:`Container.along`); the fill height is measured
vertically from the lowest inner point. The upright bottle (shape ``upright``, the
way most bottles are grasped) stands on its base: ``length_mm`` and ``width_mm``
are both its inner diameter, ``depth_mm`` its inner height, and it sloshes alike
along either horizontal axis.

Where the numbers come from (all are choices consistent with the paper, which
gives no drawings): the paper fills the grooved cuboid 16-40 mm, "25-75 %
full", so its inner height is ~55-64 mm (we take 60 mm); its length is chosen
so that the first slosh mode stays below the signal's 3 Hz low-pass (1.9-2.6
Hz over 16-40 mm). The plain cuboid (15-38 mm fills), the cylinder on its side
(12-35 mm) and the glass container (22-39 mm) are sized the same way from the
paper's fill ranges. Wall factors multiply the Stokes boundary-layer damping
(1.4-1.65, the empirical range for real containers; grooves dissipate more,
smooth glass less).
``contact_line_damping`` is the small viscosity-independent contact-line term
[1/s]. Masses: thin plastic 40-70 g; the glass container is heavy (320 g),
comparable to the liquid it holds. The upright bottle is a 1.5 L-class round
bottle (inner diameter 90 mm, inner height 200 mm): its first slosh mode,
``ω² = g k tanh(k h)`` with ``k = 1.841/R`` (the first root of J1'), stays at
2.4-3.2 Hz over 15-190 mm of fill, inside the signal's 4 Hz low-pass; a
narrower bottle (R = 30 mm: 3.9 Hz) would slosh above it. Its damping is the
empirical upright-cylinder formula (:mod:`liquidtouch.sim.slosh`), which already
describes real walls, so its wall factor is 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from liquidtouch.errors import CatalogueError


@dataclass(frozen=True)
class Container:
    """Inner geometry [mm], shape, wall factor, contact-line damping [1/s] and mass [g]."""

    name: str
    shape: str  # "box", "cylinder" (lying on its side, axis along x) or "upright"
    length_mm: float
    width_mm: float
    depth_mm: float
    mass_g: float
    wall_factor: float
    contact_line_damping: float
    note: str = ""

    def check_height(self, height_mm: float) -> None:
        """Raise :class:`CatalogueError` unless ``0 < height_mm < depth_mm``."""
        if not (math.isfinite(height_mm) and 0.0 < height_mm < self.depth_mm):
            raise CatalogueError(
                f"fill height {height_mm} mm does not fit container {self.name!r} "
                f"(inner height {self.depth_mm:g} mm)"
            )

    @property
    def upright(self) -> bool:
        """Whether the container stands on its base (a round bottle held upright)."""
        return self.shape == "upright"

    def along(self, axis: str) -> Container:
        """The container as a push along world ``axis`` (``"x"`` or ``"y"``) sloshes it.

        ``x``: itself (the slosh runs along ``length_mm``); ``y``, the grasp axis: a box
        with its length and width exchanged; an upright bottle is round, the same either
        way. A cylinder on its side has no rectangular section across its axis:
        :class:`CatalogueError`.
        """
        if axis not in ("x", "y"):
            raise CatalogueError(f"push axis {axis!r}: use x or y (the horizontal axes)")
        if axis == "x" or self.upright:
            return self
        if self.shape != "box":
            raise CatalogueError(
                f"container {self.name!r} ({self.shape} on its side) sloshes along its length "
                "only: push it along x"
            )
        return replace(self, length_mm=self.width_mm, width_mm=self.length_mm)

    def axes(self) -> tuple[str, ...]:
        """The push axes :meth:`along` accepts for this container."""
        return ("x", "y") if self.shape in ("box", "upright") else ("x",)

    def liquid_volume_mm3(self, height_mm: float) -> float:
        """Volume of liquid [mm³] at fill ``height_mm``."""
        if self.upright:
            self.check_height(height_mm)
            return math.pi * (self.length_mm / 2.0) ** 2 * height_mm
        return self.cross_section(height_mm)[0] * self.length_mm

    def cross_section(self, height_mm: float) -> tuple[float, float]:
        """Wetted cross-section area [mm²] and free-surface width [mm] at fill ``height_mm``.

        The cross-section is perpendicular to the slosh direction (an upright bottle's:
        its diametral plane, ``diameter × height``).
        """
        self.check_height(height_mm)
        if self.shape in ("box", "upright"):
            return self.width_mm * height_mm, self.width_mm
        r = self.depth_mm / 2.0
        d = r - height_mm
        half_angle = math.acos(d / r)
        area = r * r * (half_angle - math.sin(half_angle) * math.cos(half_angle))
        return area, 2.0 * math.sqrt(max(r * r - d * d, 0.0))

    def equivalent_depth_mm(self, height_mm: float) -> float:
        """Depth of the equivalent rectangular channel, A/W (equals the height for a box)."""
        area, surface_width = self.cross_section(height_mm)
        return area / surface_width

    def fill_fraction(self, height_mm: float) -> float:
        """Fraction of the inner volume that is filled (0-1)."""
        return self.liquid_volume_mm3(height_mm) / self.liquid_volume_mm3(
            self.depth_mm * (1 - 1e-12)
        )


CONTAINERS: dict[str, Container] = {
    "grooved-cuboid": Container(
        "grooved-cuboid", "box", 100.0, 55.0, 60.0, 60.0, 1.60, 0.02,
        note="the paper's main container; grooved walls",
    ),
    "cuboid": Container(
        "cuboid", "box", 112.0, 62.0, 54.0, 55.0, 1.45, 0.02, note="smooth plastic cuboid"
    ),
    "cylinder": Container(
        "cylinder", "cylinder", 125.0, 50.0, 50.0, 45.0, 1.50, 0.02,
        note="plastic bottle on its side (inner diameter 50 mm)",
    ),
    "glass": Container(
        "glass", "box", 95.0, 60.0, 56.0, 320.0, 1.40, 0.015,
        note="heavy glass container, mass comparable to the liquid's",
    ),
    "upright-bottle": Container(
        "upright-bottle", "upright", 90.0, 90.0, 200.0, 45.0, 1.0, 0.02,
        note="round plastic bottle held upright (inner diameter 90 mm, height 200 mm)",
    ),
}  # fmt: skip


def get_container(name: str) -> Container:
    """The container called ``name``; :class:`CatalogueError` listing known names if unknown."""
    container = CONTAINERS.get(name)
    if container is None:
        raise CatalogueError(
            f"unknown container {name!r}; known containers: {', '.join(CONTAINERS)}"
        )
    return container
